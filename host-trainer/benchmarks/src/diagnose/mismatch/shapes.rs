//! Library mechanisms in functional forms other than the diagnosis' terms
//! (`rlg benchmark-diagnose --set mismatched --other-shapes`).
//!
//! The mismatched set hides each mechanism as the very term the diagnosis scans for
//! (`rlg_physics::contribution`), driven by this generator's temperatures. A real gyro's
//! warm-up need not be one exponential, nor its mode hop an instant relay: a diagnosis that
//! names a mechanism only when it has the library's exact shape would fail on real
//! recordings while scoring well here. Each form below keeps what makes the mechanism what
//! it is (a decay from power-on, a level that changes at a temperature and remembers the
//! direction, a ripple periodic in temperature, …) and changes the rest. Forms are drawn
//! per case; the key parameter is not scored (the forms have none comparable with the
//! term's).

use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::thermal::Trajectory;
use super::{log_uni, uni};
use rlg_diagnose::candidates::Family;
use rlg_physics::{contribution, Term};
use std::f64::consts::TAU;

/// A mechanism's effect in a form the term library does not have, at an amplitude.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "form", rename_all = "snake_case")]
pub enum Shape {
    /// a·(w·e^(−t/τ₁) + (1 − w)·e^(−t/τ₂)): a warm-up with a fast and a slow part (the
    /// discharge's own settling and the cavity's heating).
    WarmupTwoExp {
        /// a, °/h at power-on.
        amplitude_dph: f64,
        /// τ₁, s.
        tau1_s: f64,
        /// τ₂, s.
        tau2_s: f64,
        /// The fast part's share.
        w: f64,
    },
    /// a·(1 + t/τ)^(−p): a warm-up that decays as a power of time.
    WarmupPower {
        /// a, °/h at power-on.
        amplitude_dph: f64,
        /// τ, s.
        tau_s: f64,
        /// p.
        p: f64,
    },
    /// a·ln(1 + t/τ)/ln(1 + 1 d/τ) (a at one day): aging that slows, as gas clean-up and
    /// mirror settling do.
    AgingLog {
        /// a, °/h at one day.
        amplitude_dph: f64,
        /// τ, s.
        tau_s: f64,
    },
    /// a·√(t / 1 d): aging as a diffusion.
    AgingSqrt {
        /// a, °/h at one day.
        amplitude_dph: f64,
    },
    /// The library's relay, its step settling in time with τ after each switch (the
    /// path-length control re-locking).
    ModeHopSettling {
        /// Upper switching temperature, °C.
        temp_c: f64,
        /// Bias step, °/h.
        step_dph: f64,
        /// Switching hysteresis, °C.
        hysteresis_c: f64,
        /// Settling time constant, s.
        settle_s: f64,
    },
    /// a·(sin θ + h·sin(2θ + φ₂)), θ = 2π·T/P + φ: a backscatter ripple with its second
    /// harmonic.
    BackscatterHarmonic {
        /// P, °C.
        period_c: f64,
        /// a, °/h.
        amplitude_dph: f64,
        /// φ, rad.
        phase_rad: f64,
        /// h, the second harmonic's share.
        h: f64,
        /// φ₂, rad.
        phase2_rad: f64,
    },
    /// The same in time (θ = 2π·t/P + φ): a periodic disturbance that is not a sine.
    PeriodicHarmonic {
        /// P, s.
        period_s: f64,
        /// a, °/h.
        amplitude_dph: f64,
        /// φ, rad.
        phase_rad: f64,
        /// h, the second harmonic's share.
        h: f64,
        /// φ₂, rad.
        phase2_rad: f64,
    },
    /// The mean of three play operators of widths w/4, w/2 and w (each ±height when
    /// saturated): after a reversal the output bends into saturation in three steps
    /// instead of one, as a spread of coercive widths makes it (Preisach-like).
    HysteresisRounded {
        /// w, °C.
        width_c: f64,
        /// Half the gap between the saturated branches, °/h.
        height_dph: f64,
    },
    /// gain·G₂ with two cascaded lags of τ/2 (τ/2·Ġ₁ = −G₁ + Ṫ, τ/2·Ġ₂ = −G₂ + G₁): a
    /// gradient that builds through two thermal paths.
    GradientTwoLags {
        /// τ, s.
        tau_s: f64,
        /// °/h per (°C/s).
        gain: f64,
    },
}

const DAY_S: f64 = 86_400.0;

impl Shape {
    /// A form of `f` other than its term, unit amplitude and random parameters, in the
    /// sensor node's range `lo`…`hi`; `None` for the families kept in the library form
    /// (`sensor_lag`, `temp_quantization` and `heteroscedastic`, which act through the
    /// reading or the noise).
    pub(super) fn draw(f: Family, rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> Option<Shape> {
        // Nothing drawn for those, so that their cases are the library set's.
        if matches!(
            f,
            Family::SensorLag | Family::TempQuantization | Family::Heteroscedastic
        ) {
            return None;
        }
        let sign = if uni(rng, 0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
        let range = (hi - lo).max(1.0);
        let coin = uni(rng, 0.0, 1.0) < 0.5;
        Some(match f {
            Family::Warmup if coin => Shape::WarmupTwoExp {
                amplitude_dph: sign,
                tau1_s: log_uni(rng, 300.0, 1200.0),
                tau2_s: log_uni(rng, 3000.0, 15_000.0),
                w: uni(rng, 0.3, 0.7),
            },
            Family::Warmup => Shape::WarmupPower {
                amplitude_dph: sign,
                tau_s: log_uni(rng, 600.0, 3600.0),
                p: uni(rng, 0.5, 1.5),
            },
            Family::Aging if coin => Shape::AgingLog {
                amplitude_dph: sign,
                tau_s: log_uni(rng, 3600.0, 36_000.0),
            },
            Family::Aging => Shape::AgingSqrt {
                amplitude_dph: sign,
            },
            Family::ModeHop => Shape::ModeHopSettling {
                temp_c: lo + range * uni(rng, 0.3, 0.7),
                step_dph: sign,
                hysteresis_c: uni(rng, 0.5, 3.0),
                settle_s: log_uni(rng, 60.0, 600.0),
            },
            Family::Backscatter => Shape::BackscatterHarmonic {
                period_c: (4.0 + 11.0 * uni(rng, 0.0, 1.0)).min(range / 3.0),
                amplitude_dph: 1.0,
                phase_rad: uni(rng, 0.0, TAU),
                h: uni(rng, 0.3, 0.7),
                phase2_rad: uni(rng, 0.0, TAU),
            },
            Family::Periodic => Shape::PeriodicHarmonic {
                period_s: log_uni(rng, 1500.0, 10_000.0),
                amplitude_dph: 1.0,
                phase_rad: uni(rng, 0.0, TAU),
                h: uni(rng, 0.3, 0.7),
                phase2_rad: uni(rng, 0.0, TAU),
            },
            Family::Hysteresis => Shape::HysteresisRounded {
                width_c: (3.0 + 12.0 * uni(rng, 0.0, 1.0)).min(range / 3.0),
                height_dph: sign,
            },
            Family::GradientLag => Shape::GradientTwoLags {
                tau_s: log_uni(rng, 200.0, 3000.0),
                gain: sign,
            },
            Family::SensorLag | Family::TempQuantization | Family::Heteroscedastic => return None,
        })
    }

    /// The form's name.
    pub fn form(&self) -> &'static str {
        match self {
            Shape::WarmupTwoExp { .. } => "warmup_two_exp",
            Shape::WarmupPower { .. } => "warmup_power",
            Shape::AgingLog { .. } => "aging_log",
            Shape::AgingSqrt { .. } => "aging_sqrt",
            Shape::ModeHopSettling { .. } => "mode_hop_settling",
            Shape::BackscatterHarmonic { .. } => "backscatter_harmonic",
            Shape::PeriodicHarmonic { .. } => "periodic_harmonic",
            Shape::HysteresisRounded { .. } => "hysteresis_rounded",
            Shape::GradientTwoLags { .. } => "gradient_two_lags",
        }
    }

    /// The family whose mechanism it is.
    pub fn family(&self) -> Family {
        match self {
            Shape::WarmupTwoExp { .. } | Shape::WarmupPower { .. } => Family::Warmup,
            Shape::AgingLog { .. } | Shape::AgingSqrt { .. } => Family::Aging,
            Shape::ModeHopSettling { .. } => Family::ModeHop,
            Shape::BackscatterHarmonic { .. } => Family::Backscatter,
            Shape::PeriodicHarmonic { .. } => Family::Periodic,
            Shape::HysteresisRounded { .. } => Family::Hysteresis,
            Shape::GradientTwoLags { .. } => Family::GradientLag,
        }
    }

    /// The same form `k` times as large.
    pub(super) fn scaled(&self, k: f64) -> Shape {
        let mut s = self.clone();
        match &mut s {
            Shape::WarmupTwoExp { amplitude_dph, .. }
            | Shape::WarmupPower { amplitude_dph, .. }
            | Shape::AgingLog { amplitude_dph, .. }
            | Shape::AgingSqrt { amplitude_dph }
            | Shape::BackscatterHarmonic { amplitude_dph, .. }
            | Shape::PeriodicHarmonic { amplitude_dph, .. } => *amplitude_dph *= k,
            Shape::ModeHopSettling { step_dph, .. } => *step_dph *= k,
            Shape::HysteresisRounded { height_dph, .. } => *height_dph *= k,
            Shape::GradientTwoLags { gain, .. } => *gain *= k,
        }
        s
    }

    /// What it adds to the bias on the node's trajectory, °/h per sample.
    pub(super) fn bias_effect(&self, tr: &Trajectory) -> Vec<f64> {
        let (t, temp, dtemp) = (&tr.t_s, &tr.node_c, &tr.dnode_c_per_s);
        let term = |term: Term| contribution(&term, t, temp, dtemp);
        match *self {
            Shape::WarmupTwoExp {
                amplitude_dph,
                tau1_s,
                tau2_s,
                w,
            } => t
                .iter()
                .map(|t| {
                    amplitude_dph * (w * (-t / tau1_s).exp() + (1.0 - w) * (-t / tau2_s).exp())
                })
                .collect(),
            Shape::WarmupPower {
                amplitude_dph,
                tau_s,
                p,
            } => t
                .iter()
                .map(|t| amplitude_dph * (1.0 + t / tau_s).powf(-p))
                .collect(),
            Shape::AgingLog {
                amplitude_dph,
                tau_s,
            } => {
                let norm = (1.0 + DAY_S / tau_s).ln();
                t.iter()
                    .map(|t| amplitude_dph * (1.0 + t / tau_s).ln() / norm)
                    .collect()
            }
            Shape::AgingSqrt { amplitude_dph } => t
                .iter()
                .map(|t| amplitude_dph * (t / DAY_S).sqrt())
                .collect(),
            Shape::ModeHopSettling {
                temp_c,
                step_dph,
                hysteresis_c,
                settle_s,
            } => lag_in_time(
                &term(Term::ModeHop {
                    temp_c,
                    step_dph,
                    hysteresis_c,
                    node_lag_s: 0.0,
                }),
                t,
                settle_s,
            ),
            Shape::BackscatterHarmonic {
                period_c,
                amplitude_dph,
                phase_rad,
                h,
                phase2_rad,
            } => with_harmonic(temp, period_c, amplitude_dph, phase_rad, h, phase2_rad),
            Shape::PeriodicHarmonic {
                period_s,
                amplitude_dph,
                phase_rad,
                h,
                phase2_rad,
            } => with_harmonic(t, period_s, amplitude_dph, phase_rad, h, phase2_rad),
            Shape::HysteresisRounded {
                width_c,
                height_dph,
            } => {
                let plays: Vec<Vec<f64>> = [0.25, 0.5, 1.0]
                    .iter()
                    .map(|f| {
                        term(Term::Hysteresis {
                            width_c: width_c * f,
                            height_dph,
                            node_lag_s: 0.0,
                        })
                    })
                    .collect();
                (0..t.len())
                    .map(|i| plays.iter().map(|p| p[i]).sum::<f64>() / 3.0)
                    .collect()
            }
            Shape::GradientTwoLags { tau_s, gain } => lag_in_time(
                &term(Term::GradientLag {
                    tau_s: tau_s / 2.0,
                    gain,
                }),
                t,
                tau_s / 2.0,
            ),
        }
    }

    /// Its name and parameters, for the case's description.
    pub(super) fn describe(&self) -> String {
        let s = serde_json::to_value(self).unwrap_or_default();
        let Some(map) = s.as_object() else {
            return String::new();
        };
        let form = self.form();
        let params: Vec<String> = map
            .iter()
            .filter(|(k, _)| *k != "form")
            .filter_map(|(k, v)| v.as_f64().map(|v| format!("{k} {v:.3e}")))
            .collect();
        format!("{} as {form} ({})", self.family().name(), params.join(", "))
    }
}

/// a·(sin θ + h·sin(2θ + φ₂)), θ = 2π·x/P + φ, at each x.
fn with_harmonic(x: &[f64], period: f64, a: f64, phase: f64, h: f64, phase2: f64) -> Vec<f64> {
    x.iter()
        .map(|x| {
            let th = TAU * x / period + phase;
            a * (th.sin() + h * (2.0 * th + phase2).sin())
        })
        .collect()
}

/// x through a first-order lag of time constant τ, starting at x's first value; each
/// sample's x is taken as held over the step before it (1 s steps against τ of minutes).
/// Written here because the physics crate's lags are the terms' own state, not a filter of
/// an arbitrary series.
fn lag_in_time(x: &[f64], t: &[f64], tau_s: f64) -> Vec<f64> {
    let mut y = x.first().copied().unwrap_or(0.0);
    let mut prev_t = t.first().copied().unwrap_or(0.0);
    x.iter()
        .zip(t)
        .map(|(&v, &ti)| {
            y += (v - y) * (1.0 - (-(ti - prev_t) / tau_s).exp());
            prev_t = ti;
            y
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record of `n` s at 1 Hz whose temperature is `temp(t)`.
    fn trajectory(n: usize, temp: impl Fn(f64) -> f64) -> Trajectory {
        let t_s: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let node_c: Vec<f64> = t_s.iter().map(|&t| temp(t)).collect();
        let dnode_c_per_s: Vec<f64> = t_s.iter().map(|&t| temp(t + 0.5) - temp(t - 0.5)).collect();
        Trajectory {
            air_c: node_c.clone(),
            other_c: node_c.clone(),
            dother_c_per_s: dnode_c_per_s.clone(),
            t_s,
            node_c,
            dnode_c_per_s,
        }
    }

    /// Each form against its closed form: aging at one day, the settling relay's step
    /// response, the rounded loop's saturation and its first branch, the two-lag gradient's
    /// steady state, the warm-ups at power-on.
    #[test]
    fn forms_follow_their_definitions() {
        let day = trajectory(86_401, |_| 20.0);
        let last = |v: Vec<f64>| *v.last().expect("samples");
        let log = Shape::AgingLog {
            amplitude_dph: 2.0,
            tau_s: 7200.0,
        };
        assert!((last(log.bias_effect(&day)) - 2.0).abs() < 1e-12);
        let sqrt = Shape::AgingSqrt { amplitude_dph: 3.0 };
        assert!((last(sqrt.bias_effect(&day)) - 3.0).abs() < 1e-12);
        let two = Shape::WarmupTwoExp {
            amplitude_dph: 1.5,
            tau1_s: 600.0,
            tau2_s: 6000.0,
            w: 0.4,
        };
        let e = two.bias_effect(&day);
        assert!((e[0] - 1.5).abs() < 1e-12);
        let want = 1.5 * (0.4 * (-1.0f64).exp() + 0.6 * (-0.1f64).exp());
        assert!((e[600] - want).abs() < 1e-12);
        let pow = Shape::WarmupPower {
            amplitude_dph: 1.0,
            tau_s: 1000.0,
            p: 1.0,
        };
        assert!((pow.bias_effect(&day)[1000] - 0.5).abs() < 1e-12);

        // 0 → 10 °C at 0.01 °C/s, then held: the relay switches at 5 °C (t = 500 s) and its
        // step settles with τ.
        let ramp = trajectory(3000, |t| (0.01 * t).clamp(0.0, 10.0));
        let hop = Shape::ModeHopSettling {
            temp_c: 5.0,
            step_dph: 1.0,
            hysteresis_c: 1.0,
            settle_s: 200.0,
        };
        let e = hop.bias_effect(&ramp);
        assert!(e[500].abs() < 1e-9, "before the switch: {}", e[500]);
        let at_tau = e[701];
        assert!((at_tau - (1.0 - (-1.0f64).exp())).abs() < 0.01, "{at_tau}");
        assert!((e[2999] - 1.0).abs() < 1e-3);

        // Up 0 → 20 °C, down to 0: the loop saturates at ±height, and after the reversal
        // the branch leaves at the plays' mean slope (8 + 4 + 2)/(3w) per °C.
        let cycle = trajectory(4001, |t| {
            if t <= 2000.0 {
                0.01 * t
            } else {
                40.0 - 0.01 * t
            }
        });
        let loop_ = Shape::HysteresisRounded {
            width_c: 8.0,
            height_dph: 1.0,
        };
        let e = loop_.bias_effect(&cycle);
        assert!((e[2000] - 1.0).abs() < 1e-9 && (e[4000] + 1.0).abs() < 1e-9);
        let slope = (e[2000] - e[2050]) / 0.5;
        assert!((slope - 14.0 / (3.0 * 8.0)).abs() < 1e-9, "{slope}");

        // A steady 0.01 °C/s: G₂ settles to Ṫ, as the one-lag term's G does.
        let steady = trajectory(40_000, |t| 0.01 * t);
        let grad = Shape::GradientTwoLags {
            tau_s: 1000.0,
            gain: 2.0,
        };
        assert!((last(grad.bias_effect(&steady)) - 0.02).abs() < 1e-6);
    }

    /// Both forms of warm-up and of aging are drawn, each labelled with its family; the
    /// three families kept in the library form draw nothing and leave the stream alone.
    #[test]
    fn draws_cover_every_form() {
        use rand::SeedableRng;
        let mut forms = std::collections::BTreeSet::new();
        for seed in 0..40 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            for f in Family::ALL {
                let before = rng.clone();
                match Shape::draw(f, &mut rng, -10.0, 50.0) {
                    Some(s) => {
                        assert_eq!(s.family(), f);
                        forms.insert(s.form());
                    }
                    None => assert_eq!(rng, before, "{}", f.name()),
                }
            }
        }
        assert_eq!(forms.len(), 9, "{forms:?}");
    }
}
