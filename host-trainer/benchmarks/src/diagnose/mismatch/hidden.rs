//! The hidden effect of a mismatched case: a library term, a library mechanism in another
//! form ([`Shape`]), nothing, or an effect outside the library: a step in time, a term in
//! (dT/dt)², and with `--outside-kinds` a transient bump in time, a random telegraph
//! (switching between two levels at random times) and a bump at one temperature.

use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::detect::{lag_effect, reading_effect};
use super::noise::NoiseDraw;
use super::shapes::Shape;
use super::thermal::Trajectory;
use super::{log_uni, uni};
use crate::diagnose::cases::scale_amplitude;
use crate::diagnose::{BenchError, Label};
use rlg_diagnose::candidates::Family;
use rlg_diagnose::prepare::Prepared;
use rlg_physics::{contribution, Role, Term};

/// What a case hides.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Hidden {
    /// Nothing.
    None,
    /// A term of the library.
    Library {
        /// The term at its amplitude.
        term: Term,
    },
    /// A bias step at a time unrelated to temperature.
    Step {
        /// s.
        time_s: f64,
        /// °/h.
        step_dph: f64,
    },
    /// a·(dT/dt)², dT/dt in °C/min.
    RateSquared {
        /// °/h per (°C/min)².
        coeff: f64,
    },
    /// A transient in time unrelated to temperature: a Gaussian of width `width_s` (1σ)
    /// centred at `centre_s` (a disturbance of the bench, a reference settling after an
    /// event).
    BumpInTime {
        /// s.
        centre_s: f64,
        /// s.
        width_s: f64,
        /// °/h at the centre.
        amplitude_dph: f64,
    },
    /// A bias that switches between 0 and `level_dph` at the times `switches_s`
    /// (burst noise of a readout or a mode competition), unrelated to temperature.
    Telegraph {
        /// s, ascending.
        switches_s: Vec<f64>,
        /// °/h.
        level_dph: f64,
    },
    /// A bump at one temperature: a Gaussian in the node's temperature of width `width_c`
    /// (1σ) centred at `centre_c` (a lock-in or a mirror resonance at one temperature); neither
    /// a step (mode hop) nor a ripple (backscatter).
    BumpInTemperature {
        /// °C.
        centre_c: f64,
        /// °C.
        width_c: f64,
        /// °/h at the centre.
        amplitude_dph: f64,
    },
    /// A library mechanism in another functional form (`--other-shapes`).
    Shaped {
        /// The form at its amplitude.
        shape: Shape,
    },
}

impl Hidden {
    /// The right verdict.
    pub(super) fn label(&self) -> Label {
        match self {
            Hidden::None => Label::None,
            Hidden::Library { term } => Label::Mechanism(term.mechanism()),
            Hidden::Step { .. }
            | Hidden::RateSquared { .. }
            | Hidden::BumpInTime { .. }
            | Hidden::Telegraph { .. }
            | Hidden::BumpInTemperature { .. } => Label::Unexplained,
            Hidden::Shaped { shape } => Label::Mechanism(shape.family().mechanism()),
        }
    }

    /// The same effect `k` times as large (library terms without an amplitude unchanged).
    pub(super) fn scaled(&self, k: f64) -> Hidden {
        match self {
            Hidden::None => Hidden::None,
            Hidden::Library { term } => Hidden::Library {
                term: scale_amplitude(term, k),
            },
            Hidden::Step { time_s, step_dph } => Hidden::Step {
                time_s: *time_s,
                step_dph: step_dph * k,
            },
            Hidden::RateSquared { coeff } => Hidden::RateSquared { coeff: coeff * k },
            Hidden::BumpInTime {
                centre_s,
                width_s,
                amplitude_dph,
            } => Hidden::BumpInTime {
                centre_s: *centre_s,
                width_s: *width_s,
                amplitude_dph: amplitude_dph * k,
            },
            Hidden::Telegraph {
                switches_s,
                level_dph,
            } => Hidden::Telegraph {
                switches_s: switches_s.clone(),
                level_dph: level_dph * k,
            },
            Hidden::BumpInTemperature {
                centre_c,
                width_c,
                amplitude_dph,
            } => Hidden::BumpInTemperature {
                centre_c: *centre_c,
                width_c: *width_c,
                amplitude_dph: amplitude_dph * k,
            },
            Hidden::Shaped { shape } => Hidden::Shaped {
                shape: shape.scaled(k),
            },
        }
    }

    /// What it adds to the bias, °/h per sample (0 for sensor and noise terms).
    pub(super) fn bias_effect(&self, tr: &Trajectory) -> Vec<f64> {
        match self {
            Hidden::Library { term } if term.role() == Role::Bias => {
                contribution(term, &tr.t_s, &tr.node_c, &tr.dnode_c_per_s)
            }
            Hidden::Step { time_s, step_dph } => tr
                .t_s
                .iter()
                .map(|t| if t >= time_s { *step_dph } else { 0.0 })
                .collect(),
            Hidden::RateSquared { coeff } => tr
                .dnode_c_per_s
                .iter()
                .map(|r| coeff * (60.0 * r).powi(2))
                .collect(),
            Hidden::BumpInTime {
                centre_s,
                width_s,
                amplitude_dph,
            } => tr
                .t_s
                .iter()
                .map(|t| amplitude_dph * (-0.5 * ((t - centre_s) / width_s).powi(2)).exp())
                .collect(),
            Hidden::Telegraph {
                switches_s,
                level_dph,
            } => tr
                .t_s
                .iter()
                .map(|t| {
                    let passed = switches_s.partition_point(|s| s <= t);
                    if passed % 2 == 1 {
                        *level_dph
                    } else {
                        0.0
                    }
                })
                .collect(),
            Hidden::BumpInTemperature {
                centre_c,
                width_c,
                amplitude_dph,
            } => tr
                .node_c
                .iter()
                .map(|c| amplitude_dph * (-0.5 * ((c - centre_c) / width_c).powi(2)).exp())
                .collect(),
            Hidden::Shaped { shape } => shape.bias_effect(tr),
            _ => vec![0.0; tr.t_s.len()],
        }
    }

    pub(super) fn describe(&self) -> String {
        let num = |v: f64| {
            if v == 0.0 || (0.01..1e5).contains(&v.abs()) {
                format!("{}", (v * 1e3).round() / 1e3)
            } else {
                format!("{v:.2e}")
            }
        };
        match self {
            Hidden::None => "nothing".into(),
            Hidden::Library { term } => {
                let p: Vec<String> = term
                    .parameters()
                    .into_iter()
                    .map(|(n, v)| format!("{n} {}", num(v)))
                    .collect();
                format!("{} ({})", term.name(), p.join(", "))
            }
            Hidden::Step { time_s, step_dph } => {
                format!("step {} °/h at {:.1} h", num(*step_dph), time_s / 3600.0)
            }
            Hidden::RateSquared { coeff } => {
                format!("rate_squared {} °/h per (°C/min)²", num(*coeff))
            }
            Hidden::BumpInTime {
                centre_s,
                width_s,
                amplitude_dph,
            } => format!(
                "bump_in_time {} °/h at {:.1} h, σ {:.2} h",
                num(*amplitude_dph),
                centre_s / 3600.0,
                width_s / 3600.0
            ),
            Hidden::Telegraph {
                switches_s,
                level_dph,
            } => {
                let at: Vec<String> = switches_s
                    .iter()
                    .map(|s| format!("{:.1}", s / 3600.0))
                    .collect();
                format!(
                    "telegraph {} °/h, switching at {} h",
                    num(*level_dph),
                    at.join(", ")
                )
            }
            Hidden::BumpInTemperature {
                centre_c,
                width_c,
                amplitude_dph,
            } => format!(
                "bump_in_temperature {} °/h at {:.1} °C, σ {:.1} °C",
                num(*amplitude_dph),
                centre_c,
                width_c
            ),
            Hidden::Shaped { shape } => shape.describe(),
        }
    }
}

/// A library term of `f` with random non-linear parameters and unit amplitude, placed in
/// the sensor node's temperature range `lo`…`hi` (its 5–95 % quantiles). A warm-up starts
/// with the record (the diagnosis' power-on), also after a warm start: the laser's own
/// transient is what it names, not the body's heating.
pub(super) fn library_term(f: Family, rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> Term {
    let sign = if uni(rng, 0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
    let range = (hi - lo).max(1.0);
    match f {
        Family::SensorLag => Term::SensorLag {
            tau_s: log_uni(rng, 60.0, 600.0),
        },
        Family::GradientLag => Term::GradientLag {
            tau_s: log_uni(rng, 200.0, 3000.0),
            gain: sign,
        },
        Family::Hysteresis => Term::Hysteresis {
            width_c: (3.0 + 12.0 * uni(rng, 0.0, 1.0)).min(range / 3.0),
            height_dph: sign,
            node_lag_s: 0.0,
        },
        Family::Warmup => Term::Warmup {
            amplitude_dph: sign,
            tau_s: log_uni(rng, 1200.0, 7200.0),
            t_on_s: 0.0,
        },
        Family::ModeHop => Term::ModeHop {
            temp_c: lo + range * uni(rng, 0.3, 0.7),
            step_dph: sign,
            hysteresis_c: uni(rng, 0.5, 3.0),
            node_lag_s: 0.0,
        },
        Family::Backscatter => Term::Backscatter {
            period_c: (4.0 + 11.0 * uni(rng, 0.0, 1.0)).min(range / 3.0),
            amplitude_dph: 1.0,
            phase_rad: uni(rng, 0.0, std::f64::consts::TAU),
            node_lag_s: 0.0,
        },
        Family::Periodic => Term::Periodic {
            period_s: log_uni(rng, 1500.0, 10_000.0),
            amplitude_dph: 1.0,
            phase_rad: uni(rng, 0.0, std::f64::consts::TAU),
            windows_s: Vec::new(),
        },
        Family::Aging => Term::Aging {
            rate_dph_per_day: sign,
        },
        Family::Heteroscedastic => Term::Heteroscedastic {
            k: 1.0,
            ref_c: lo + range * uni(rng, 0.2, 0.8),
        },
        Family::TempQuantization => Term::TempQuantization {
            step_c: (log_uni(rng, 0.05, 0.5) * 1e4).round() / 1e4,
        },
    }
}

/// The mean effect (°/h per sample) whose D is the case's: the bias it adds, or for a
/// sensor term the base's change from being driven by the reading.
pub(super) fn mean_effect(
    h: &Hidden,
    tr: &Trajectory,
    bias: &[Term],
    read: &[f64],
) -> Result<Vec<f64>, BenchError> {
    Ok(match h {
        Hidden::Library {
            term: Term::SensorLag { tau_s },
        } => lag_effect(bias, &tr.t_s, &tr.node_c, &tr.dnode_c_per_s, *tau_s),
        Hidden::Library {
            term: Term::TempQuantization { .. },
        } => reading_effect(bias, &tr.t_s, &tr.node_c, &tr.dnode_c_per_s, read)?,
        _ => h.bias_effect(tr),
    })
}

/// D of a `heteroscedastic` term on the node temperatures of the fitted samples, under the
/// recording's noise ([`NoiseDraw::scale_detectability`]).
pub(super) fn hetero_d(
    h: &Hidden,
    tr: &Trajectory,
    prep: &Prepared,
    noise: &NoiseDraw,
) -> Option<f64> {
    match h {
        Hidden::Library {
            term: Term::Heteroscedastic { k, ref_c },
        } => Some(noise.scale_detectability(
            &tr.node_c[prep.range.clone()],
            *k,
            *ref_c,
            prep.dt_s,
            prep.block,
        )),
        _ => None,
    }
}
