//! Per-feature standardisation z = (x − mean) / scale, fitted on the training inputs.
//!
//! The scale is the population standard deviation. The board applies the same map in f32
//! with the stored mean and 1/scale (see `compensator_core::ModelRef::standardise`).

use serde::{Deserialize, Serialize};

use super::LssvmError;
use crate::features::RowSet;

/// Mean and population standard deviation of each input feature, in the feature's unit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scaling {
    /// Per-feature mean, in the feature's unit.
    pub mean: Vec<f64>,
    /// Per-feature population standard deviation, in the feature's unit; always > 0.
    pub scale: Vec<f64>,
}

impl Scaling {
    /// Fits mean and population std on the rows of `x`; `names` label the columns in errors.
    ///
    /// A feature whose values are all equal (std 0 or too small to divide by) is an error that
    /// names it: such a feature carries no information and would divide by zero.
    pub fn fit<X: RowSet + ?Sized>(names: &[String], x: &X) -> Result<Scaling, LssvmError> {
        let dim = names.len();
        if x.n_rows() == 0 {
            return Err(LssvmError::Empty);
        }
        let rows = || (0..x.n_rows()).map(|i| x.row(i));
        for (i, row) in rows().enumerate() {
            if row.len() != dim {
                return Err(LssvmError::Dimension {
                    row: i,
                    got: row.len(),
                    want: dim,
                });
            }
            if let Some(d) = row.iter().position(|v| !v.is_finite()) {
                return Err(LssvmError::NonFinite {
                    what: "input",
                    index: i,
                    feature: Some(names[d].clone()),
                });
            }
        }
        let n = x.n_rows() as f64;
        let mut mean = vec![0.0; dim];
        let mut scale = vec![0.0; dim];
        for d in 0..dim {
            let m = rows().map(|r| r[d]).sum::<f64>() / n;
            // Two-pass variance: the features sit far from zero (°C) relative to their spread.
            let var = rows().map(|r| (r[d] - m).powi(2)).sum::<f64>() / n;
            let s = var.sqrt();
            // Relative to the feature's magnitude: a spread at rounding level is no spread.
            // Also catches s = 0 at m = 0 (the threshold is then 0).
            if s <= 1e-12 * m.abs() {
                return Err(LssvmError::ConstantFeature {
                    feature: names[d].clone(),
                    value: m,
                });
            }
            mean[d] = m;
            scale[d] = s;
        }
        Ok(Scaling { mean, scale })
    }

    /// Number of features.
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// Standardises one raw feature vector (length must be [`Scaling::dim`]).
    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(self.mean.iter().zip(&self.scale))
            .map(|(v, (m, s))| (v - m) / s)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names() -> Vec<String> {
        vec!["temp_c".into(), "temp_rate_c_per_s".into()]
    }

    #[test]
    fn standardised_columns_have_zero_mean_and_unit_population_std() {
        let x: Vec<Vec<f64>> = (0..50)
            .map(|i| vec![10.0 + i as f64, (i as f64 * 0.3).sin() * 0.02])
            .collect();
        let s = Scaling::fit(&names(), &x).unwrap();
        let z: Vec<Vec<f64>> = x.iter().map(|r| s.apply(r)).collect();
        for d in 0..2 {
            let m = z.iter().map(|r| r[d]).sum::<f64>() / 50.0;
            let v = z.iter().map(|r| (r[d] - m).powi(2)).sum::<f64>() / 50.0;
            assert!(m.abs() < 1e-12 && (v - 1.0).abs() < 1e-12, "{d}: {m} {v}");
        }
    }

    #[test]
    fn constant_feature_is_named() {
        let x: Vec<Vec<f64>> = (0..5).map(|i| vec![i as f64, 0.0]).collect();
        let e = Scaling::fit(&names(), &x).unwrap_err();
        assert!(e.to_string().contains("temp_rate_c_per_s"), "{e}");
    }
}
