//! The baseline model's design: one column per linear parameter, each its unit
//! contribution computed by the shared physics library.

use super::drive::DriveSeries;
use super::model::PhysicsModel;
use rlg_physics::{contribution, Role, Term};

/// One column of a design: a linear parameter's unit contribution per sample.
#[derive(Clone, Debug)]
pub struct Column {
    /// Which term and parameter, e.g. `static_poly.coeffs_dph[2]`.
    pub name: String,
    /// °/h per unit of the parameter, per sample.
    pub values: Vec<f64>,
}

/// The baseline model's columns evaluated on `drive`, each a linear parameter of the model:
/// a constant (Earth rate and any offset), each `static_poly` coefficient, the three rate
/// terms, and the amplitude of any other bias term at its given non-linear parameters.
/// Sensor terms of the model (a `sensor_lag`) are applied to the drive by the caller.
pub fn baseline_columns(model: &PhysicsModel, drive: &DriveSeries) -> Vec<Column> {
    baseline_specs(model)
        .into_iter()
        .map(|(name, unit)| Column {
            values: baseline_values(unit.as_ref(), drive),
            name,
        })
        .collect()
}

/// The linear parameters of [`baseline_columns`], in its order: each column's name and its
/// unit-amplitude term (`None`: the offset, a column of ones).
pub fn baseline_specs(model: &PhysicsModel) -> Vec<(String, Option<Term>)> {
    let mut specs = vec![("offset".to_string(), None)];
    for term in &model.terms {
        match term {
            Term::EarthRate { .. } => {}
            Term::StaticPoly {
                center_c,
                scale_c,
                coeffs_dph,
            } => {
                // The constant is the offset column; one column per higher power.
                for k in 1..coeffs_dph.len() {
                    let mut unit = vec![0.0; coeffs_dph.len()];
                    unit[k] = 1.0;
                    let u = Term::StaticPoly {
                        center_c: *center_c,
                        scale_c: *scale_c,
                        coeffs_dph: unit,
                    };
                    specs.push((format!("static_poly.coeffs_dph[{k}]"), Some(u)));
                }
            }
            Term::RateTerms { .. } => {
                for (name, (a, b, c)) in [
                    ("linear", (1.0, 0.0, 0.0)),
                    ("cubic", (0.0, 1.0, 0.0)),
                    ("temp_linear", (0.0, 0.0, 1.0)),
                ] {
                    let u = Term::RateTerms {
                        linear: a,
                        cubic: b,
                        temp_linear: c,
                    };
                    specs.push((format!("rate_terms.{name}"), Some(u)));
                }
            }
            other if other.role() == Role::Bias => {
                if let Some(u) = other.unit_amplitude() {
                    specs.push((format!("{}.amplitude", other.name()), Some(u)));
                }
            }
            _ => {}
        }
    }
    specs
}

/// One column of [`baseline_columns`] on `drive`, from its [`baseline_specs`] entry: one
/// column at a time, so that a caller combining columns over a long record holds one, not
/// all of them.
pub fn baseline_values(unit: Option<&Term>, drive: &DriveSeries) -> Vec<f64> {
    let (t, x, r) = (&drive.t_s, &drive.temp_c, &drive.dtemp_c_per_s);
    match unit {
        None => vec![1.0; t.len()],
        Some(u) => contribution(u, t, x, r),
    }
}
