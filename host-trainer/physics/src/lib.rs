//! The shared library of RLG physics terms: one definition of each effect, used by the
//! simulator and computable from a driving series (t, T_c, dT_c/dt) for residual fitting.
//!
//! Each [`Term`] has a stable snake_case name (its `kind` in TOML/JSON) and parameters with
//! units. A term plays one of three [`Role`]s: it adds to the bias (°/h), it transforms the
//! temperature-sensor reading (°C), or it scales the white-noise σ. Stateful terms (lags, play
//! operator, relay) run as a [`TermStep`]; [`contribution`] runs one over whole series.
//! [`term_reference`] documents every kind for the users of model files.

pub mod hysteresis;
pub mod mechanism;
pub mod reference;

use compensator_core::physics::decay;
use serde::{Deserialize, Serialize};

pub use hysteresis::{Play, Relay};
pub use mechanism::{Mechanism, UnknownMechanism};
pub use reference::{term_reference, term_reference_markdown, ParamDoc, TermDoc};

/// The first-order lag of the board's features, in f64 (one definition, generic over the
/// float type, in `compensator_core::physics`).
pub type FirstOrderLag = compensator_core::physics::FirstOrderLag<f64>;

/// Earth rotation rate, °/h (7.292115e-5 rad/s, WGS-84).
pub const EARTH_RATE_DPH: f64 = 7.292_115e-5 * 180.0 / std::f64::consts::PI * 3600.0;

/// Direction of the gyro's input axis along the local vertical.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    /// Axis points up: the gyro senses +Ω_e·sin(latitude).
    Up,
    /// Axis points down: −Ω_e·sin(latitude). At 28.2 °N (Changsha, where the paper's gyro
    /// was tested) this is −7.108 °/h, the level of the paper's Table 1.
    #[default]
    Down,
}

/// One physics term with its parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Term {
    /// Constant ±Ω_e·sin(latitude), °/h.
    EarthRate {
        /// Latitude, degrees (north positive).
        latitude_deg: f64,
        /// Axis direction along the vertical.
        #[serde(default)]
        axis: Axis,
    },
    /// Σ c_k·((T_c − center)/scale)^k, °/h.
    StaticPoly {
        /// Expansion centre, °C.
        #[serde(default)]
        center_c: f64,
        /// Scale of the normalised temperature, °C.
        #[serde(default = "one")]
        scale_c: f64,
        /// Coefficients c_0, c_1, …, °/h each.
        coeffs_dph: Vec<f64>,
    },
    /// Eq. (11)-style terms in Ṫ = dT_c/dt (°C/s): linear·Ṫ + cubic·Ṫ³ + temp_linear·T_c·Ṫ.
    RateTerms {
        /// °/h per (°C/s).
        #[serde(default)]
        linear: f64,
        /// °/h per (°C/s)³.
        #[serde(default)]
        cubic: f64,
        /// °/h per (°C·°C/s).
        #[serde(default)]
        temp_linear: f64,
    },
    /// Sensor lags the body: τ·dT_s/dt = T_c − T_s.
    SensorLag {
        /// Time constant, s.
        tau_s: f64,
    },
    /// Thermal-gradient bias: gain·G with τ·dG/dt = −G + dT_c/dt.
    GradientLag {
        /// Time constant, s.
        tau_s: f64,
        /// °/h per (°C/s).
        gain: f64,
    },
    /// height·(T_c − p)/(w/2), p the play operator of width w on T_c.
    Hysteresis {
        /// Full width of the play, °C.
        width_c: f64,
        /// Half the gap between branches, °/h.
        height_dph: f64,
        /// The driving node's lag behind T_c, s (see [`node_temperature`]); 0: T_c itself.
        #[serde(default, skip_serializing_if = "is_zero")]
        node_lag_s: f64,
    },
    /// amplitude·exp(−(t − t_on)/τ) from power-on on (0 before).
    Warmup {
        /// °/h at power-on.
        amplitude_dph: f64,
        /// Time constant, s.
        tau_s: f64,
        /// Power-on time, s.
        #[serde(default)]
        t_on_s: f64,
    },
    /// Relay: +step when T_c rises above temp_c, removed when it falls below temp_c − hysteresis_c.
    ModeHop {
        /// Upper switching temperature, °C.
        temp_c: f64,
        /// Bias step, °/h.
        step_dph: f64,
        /// Switching hysteresis, °C.
        hysteresis_c: f64,
        /// The driving node's lag behind T_c, s (see [`node_temperature`]); 0: T_c itself.
        #[serde(default, skip_serializing_if = "is_zero")]
        node_lag_s: f64,
    },
    /// amplitude·sin(2π·T_c/period + phase): lock-in/backscatter ripple with cavity length.
    Backscatter {
        /// Period in temperature, °C.
        period_c: f64,
        /// °/h.
        amplitude_dph: f64,
        /// rad.
        #[serde(default)]
        phase_rad: f64,
        /// The driving node's lag behind T_c, s (see [`node_temperature`]); 0: T_c itself.
        #[serde(default, skip_serializing_if = "is_zero")]
        node_lag_s: f64,
    },
    /// amplitude·sin(2π·t/period + phase), only inside `windows_s` when any are given.
    Periodic {
        /// Period, s.
        period_s: f64,
        /// °/h.
        amplitude_dph: f64,
        /// rad.
        #[serde(default)]
        phase_rad: f64,
        /// Active time windows [start, end), s; empty: always active.
        #[serde(default)]
        windows_s: Vec<[f64; 2]>,
    },
    /// Linear drift rate·t/86400, °/h.
    Aging {
        /// °/h per day.
        rate_dph_per_day: f64,
    },
    /// White-noise σ multiplier 1 + k·((T_c − ref)/30)².
    Heteroscedastic {
        /// Dimensionless.
        k: f64,
        /// Temperature of least noise, °C.
        #[serde(default = "twenty")]
        ref_c: f64,
    },
    /// The sensor reading is rounded to a multiple of step_c.
    TempQuantization {
        /// Quantum, °C.
        step_c: f64,
    },
}

fn one() -> f64 {
    1.0
}
fn twenty() -> f64 {
    20.0
}
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// The temperature of the node that drives a term with `node_lag_s` = τ, given T_c and its
/// rate: τ > 0, a first-order node τ behind T_c (`lag`, at rest at the first sample); τ < 0,
/// a node |τ| ahead, T_c + |τ|·dT_c/dt, which is exactly the node a first-order lag of |τ|
/// would follow (so both placements of a two-node body are one family); τ = 0, T_c.
///
/// A real gyro's mechanisms live in the laser block and its readout while its sensor sits
/// elsewhere on the body, so a mechanism fitted on the sensor's temperature may be driven by
/// a temperature tens of degrees away on a ramp (τ·dT/dt).
pub fn node_temperature(lag: &mut FirstOrderLag, d: &Drive, dt_s: f64, node_lag_s: f64) -> f64 {
    if node_lag_s > 0.0 {
        lag.step(d.temp_c, dt_s, node_lag_s)
    } else if node_lag_s < 0.0 {
        d.temp_c - node_lag_s * d.dtemp_c_per_s
    } else {
        d.temp_c
    }
}

/// What a term acts on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Adds to the gyro bias, °/h.
    Bias,
    /// Transforms the temperature-sensor reading, °C.
    Sensor,
    /// Multiplies the white-noise σ.
    NoiseScale,
}

/// The driving quantities at one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drive {
    /// Time, s.
    pub t_s: f64,
    /// True body/cavity temperature T_c, °C.
    pub temp_c: f64,
    /// dT_c/dt, °C/s.
    pub dtemp_c_per_s: f64,
}

impl Term {
    /// The term's mechanism: its kind without the parameters.
    pub fn mechanism(&self) -> Mechanism {
        match self {
            Term::EarthRate { .. } => Mechanism::EarthRate,
            Term::StaticPoly { .. } => Mechanism::StaticPoly,
            Term::RateTerms { .. } => Mechanism::RateTerms,
            Term::SensorLag { .. } => Mechanism::SensorLag,
            Term::GradientLag { .. } => Mechanism::GradientLag,
            Term::Hysteresis { .. } => Mechanism::Hysteresis,
            Term::Warmup { .. } => Mechanism::Warmup,
            Term::ModeHop { .. } => Mechanism::ModeHop,
            Term::Backscatter { .. } => Mechanism::Backscatter,
            Term::Periodic { .. } => Mechanism::Periodic,
            Term::Aging { .. } => Mechanism::Aging,
            Term::Heteroscedastic { .. } => Mechanism::Heteroscedastic,
            Term::TempQuantization { .. } => Mechanism::TempQuantization,
        }
    }

    /// Stable name (the `kind` tag).
    pub fn name(&self) -> &'static str {
        self.mechanism().name()
    }

    /// The term's numeric parameters as (name, value), names exactly as in TOML/JSON (the
    /// serde field names), in declaration order; `windows_s` and `axis` are not scalars and
    /// are left out, `coeffs_dph` is listed as `coeffs_dph[k]`, and `node_lag_s` only when it
    /// is not 0 (as serialised).
    pub fn parameters(&self) -> Vec<(String, f64)> {
        let p = |n: &str, v: f64| (n.to_string(), v);
        let with_lag = |mut v: Vec<(String, f64)>, lag: f64| {
            if lag != 0.0 {
                v.push(p("node_lag_s", lag));
            }
            v
        };
        match self {
            Term::EarthRate { latitude_deg, .. } => vec![p("latitude_deg", *latitude_deg)],
            Term::StaticPoly {
                center_c,
                scale_c,
                coeffs_dph,
            } => {
                let mut v = vec![p("center_c", *center_c), p("scale_c", *scale_c)];
                v.extend(
                    coeffs_dph
                        .iter()
                        .enumerate()
                        .map(|(k, c)| (format!("coeffs_dph[{k}]"), *c)),
                );
                v
            }
            Term::RateTerms {
                linear,
                cubic,
                temp_linear,
            } => vec![
                p("linear", *linear),
                p("cubic", *cubic),
                p("temp_linear", *temp_linear),
            ],
            Term::SensorLag { tau_s } => vec![p("tau_s", *tau_s)],
            Term::GradientLag { tau_s, gain } => vec![p("tau_s", *tau_s), p("gain", *gain)],
            Term::Hysteresis {
                width_c,
                height_dph,
                node_lag_s,
            } => with_lag(
                vec![p("width_c", *width_c), p("height_dph", *height_dph)],
                *node_lag_s,
            ),
            Term::Warmup {
                amplitude_dph,
                tau_s,
                t_on_s,
            } => vec![
                p("amplitude_dph", *amplitude_dph),
                p("tau_s", *tau_s),
                p("t_on_s", *t_on_s),
            ],
            Term::ModeHop {
                temp_c,
                step_dph,
                hysteresis_c,
                node_lag_s,
            } => with_lag(
                vec![
                    p("temp_c", *temp_c),
                    p("step_dph", *step_dph),
                    p("hysteresis_c", *hysteresis_c),
                ],
                *node_lag_s,
            ),
            Term::Backscatter {
                period_c,
                amplitude_dph,
                phase_rad,
                node_lag_s,
            } => with_lag(
                vec![
                    p("period_c", *period_c),
                    p("amplitude_dph", *amplitude_dph),
                    p("phase_rad", *phase_rad),
                ],
                *node_lag_s,
            ),
            Term::Periodic {
                period_s,
                amplitude_dph,
                phase_rad,
                ..
            } => vec![
                p("period_s", *period_s),
                p("amplitude_dph", *amplitude_dph),
                p("phase_rad", *phase_rad),
            ],
            Term::Aging { rate_dph_per_day } => vec![p("rate_dph_per_day", *rate_dph_per_day)],
            Term::Heteroscedastic { k, ref_c } => vec![p("k", *k), p("ref_c", *ref_c)],
            Term::TempQuantization { step_c } => vec![p("step_c", *step_c)],
        }
    }

    /// A bias term with its amplitude set to 1 (the column of its amplitude), `None` for terms
    /// that have no single amplitude (the polynomial, rate terms, sensor and noise terms).
    pub fn unit_amplitude(&self) -> Option<Term> {
        let mut t = self.clone();
        match &mut t {
            Term::GradientLag { gain, .. } => *gain = 1.0,
            Term::Hysteresis { height_dph, .. } => *height_dph = 1.0,
            Term::Warmup { amplitude_dph, .. } => *amplitude_dph = 1.0,
            Term::ModeHop { step_dph, .. } => *step_dph = 1.0,
            Term::Backscatter { amplitude_dph, .. } => *amplitude_dph = 1.0,
            Term::Periodic { amplitude_dph, .. } => *amplitude_dph = 1.0,
            Term::Aging { rate_dph_per_day } => *rate_dph_per_day = 1.0,
            Term::EarthRate { .. }
            | Term::StaticPoly { .. }
            | Term::RateTerms { .. }
            | Term::SensorLag { .. }
            | Term::Heteroscedastic { .. }
            | Term::TempQuantization { .. } => return None,
        }
        Some(t)
    }

    /// What the term acts on.
    pub fn role(&self) -> Role {
        match self {
            Term::SensorLag { .. } | Term::TempQuantization { .. } => Role::Sensor,
            Term::Heteroscedastic { .. } => Role::NoiseScale,
            Term::EarthRate { .. }
            | Term::StaticPoly { .. }
            | Term::RateTerms { .. }
            | Term::GradientLag { .. }
            | Term::Hysteresis { .. }
            | Term::Warmup { .. }
            | Term::ModeHop { .. }
            | Term::Backscatter { .. }
            | Term::Periodic { .. }
            | Term::Aging { .. } => Role::Bias,
        }
    }

    /// Checks parameters that would make the term meaningless (a zero period, a negative
    /// time constant, a non-finite value); the message names the parameter.
    pub fn validate(&self) -> Result<(), String> {
        let pos = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{}: `{name}` must be > 0, got {v}", self.name()))
            }
        };
        let nonneg = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("{}: `{name}` must be ≥ 0, got {v}", self.name()))
            }
        };
        let finite = |name: &str, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(format!("{}: `{name}` must be finite, got {v}", self.name()))
            }
        };
        match self {
            Term::StaticPoly { scale_c, .. } => pos("scale_c", *scale_c),
            Term::SensorLag { tau_s } => nonneg("tau_s", *tau_s),
            Term::GradientLag { tau_s, .. } => nonneg("tau_s", *tau_s),
            Term::Hysteresis {
                width_c,
                node_lag_s,
                ..
            } => pos("width_c", *width_c).and(finite("node_lag_s", *node_lag_s)),
            Term::Warmup { tau_s, .. } => pos("tau_s", *tau_s),
            Term::ModeHop {
                hysteresis_c,
                node_lag_s,
                ..
            } => nonneg("hysteresis_c", *hysteresis_c).and(finite("node_lag_s", *node_lag_s)),
            Term::Backscatter {
                period_c,
                node_lag_s,
                ..
            } => pos("period_c", *period_c).and(finite("node_lag_s", *node_lag_s)),
            Term::Periodic { period_s, .. } => pos("period_s", *period_s),
            Term::TempQuantization { step_c } => pos("step_c", *step_c),
            // Any finite value is a meaningful parameter of these (deserialisation has already
            // refused what is not a number).
            Term::EarthRate { .. }
            | Term::RateTerms { .. }
            | Term::Aging { .. }
            | Term::Heteroscedastic { .. } => Ok(()),
        }
    }
}

/// The running state of the stateful terms (lags, play operator, relay); a term leaves the
/// parts it does not use at rest.
#[derive(Clone, Copy, Debug)]
struct State {
    lag: FirstOrderLag,
    play: Play,
    relay: Relay,
}

/// A term with its running state; step it once per sample, in time order.
#[derive(Clone, Debug)]
pub struct TermStep {
    term: Term,
    state: State,
    t_prev_s: Option<f64>,
}

impl TermStep {
    /// Starts the term at rest at the first sample `d0` (lags settled, play centred).
    pub fn new(term: &Term, d0: &Drive) -> Self {
        // The driving node at the first sample: a lagging node at rest there, a leading one
        // already ahead by its lead times the rate.
        let node0 = |lag: f64| {
            if lag < 0.0 {
                d0.temp_c - lag * d0.dtemp_c_per_s
            } else {
                d0.temp_c
            }
        };
        let rest = State {
            lag: FirstOrderLag::new(0.0),
            play: Play::new(0.0, d0.temp_c),
            relay: Relay::new(f64::INFINITY, f64::INFINITY, d0.temp_c),
        };
        let state = match term {
            Term::SensorLag { .. } => State {
                lag: FirstOrderLag::new(d0.temp_c),
                ..rest
            },
            Term::GradientLag { .. } => State {
                lag: FirstOrderLag::new(d0.dtemp_c_per_s),
                ..rest
            },
            Term::Hysteresis {
                width_c,
                node_lag_s,
                ..
            } => State {
                play: Play::new(*width_c, node0(*node_lag_s)),
                lag: FirstOrderLag::new(d0.temp_c),
                ..rest
            },
            Term::ModeHop {
                temp_c,
                hysteresis_c,
                node_lag_s,
                ..
            } => State {
                relay: Relay::new(*temp_c, temp_c - hysteresis_c, node0(*node_lag_s)),
                lag: FirstOrderLag::new(d0.temp_c),
                ..rest
            },
            Term::Backscatter { .. } => State {
                lag: FirstOrderLag::new(d0.temp_c),
                ..rest
            },
            Term::EarthRate { .. }
            | Term::StaticPoly { .. }
            | Term::RateTerms { .. }
            | Term::Warmup { .. }
            | Term::Periodic { .. }
            | Term::Aging { .. }
            | Term::Heteroscedastic { .. }
            | Term::TempQuantization { .. } => rest,
        };
        Self {
            term: term.clone(),
            state,
            t_prev_s: None,
        }
    }

    /// The term.
    pub fn term(&self) -> &Term {
        &self.term
    }

    /// Advances to sample `d`. Returns, by [`Role`]: the bias contribution (°/h); the new
    /// sensor reading given the reading `sensor_in_c` so far (°C); or the σ multiplier.
    pub fn step(&mut self, d: &Drive, sensor_in_c: f64) -> f64 {
        let dt = self.t_prev_s.map_or(0.0, |t| d.t_s - t);
        self.t_prev_s = Some(d.t_s);
        let tau2pi = 2.0 * std::f64::consts::PI;
        let st = &mut self.state;
        match &self.term {
            Term::EarthRate { latitude_deg, axis } => {
                let s = EARTH_RATE_DPH * latitude_deg.to_radians().sin();
                match axis {
                    Axis::Up => s,
                    Axis::Down => -s,
                }
            }
            Term::StaticPoly {
                center_c,
                scale_c,
                coeffs_dph,
            } => {
                let x = (d.temp_c - center_c) / scale_c;
                coeffs_dph.iter().rev().fold(0.0, |acc, c| acc * x + c)
            }
            Term::RateTerms {
                linear,
                cubic,
                temp_linear,
            } => {
                let r = d.dtemp_c_per_s;
                linear * r + cubic * r * r * r + temp_linear * d.temp_c * r
            }
            Term::SensorLag { tau_s } => st.lag.step(sensor_in_c, dt, *tau_s),
            Term::GradientLag { tau_s, gain } => gain * st.lag.step(d.dtemp_c_per_s, dt, *tau_s),
            Term::Hysteresis {
                height_dph,
                node_lag_s,
                ..
            } => {
                height_dph
                    * st.play
                        .step(node_temperature(&mut st.lag, d, dt, *node_lag_s))
            }
            Term::Warmup {
                amplitude_dph,
                tau_s,
                t_on_s,
            } => match d.t_s >= *t_on_s {
                true => amplitude_dph * decay(d.t_s - t_on_s, *tau_s),
                false => 0.0,
            },
            Term::ModeHop {
                step_dph,
                node_lag_s,
                ..
            } => match st
                .relay
                .step(node_temperature(&mut st.lag, d, dt, *node_lag_s))
            {
                true => *step_dph,
                false => 0.0,
            },
            Term::Backscatter {
                period_c,
                amplitude_dph,
                phase_rad,
                node_lag_s,
            } => {
                let temp = node_temperature(&mut st.lag, d, dt, *node_lag_s);
                amplitude_dph * (tau2pi * temp / period_c + phase_rad).sin()
            }
            Term::Periodic {
                period_s,
                amplitude_dph,
                phase_rad,
                windows_s,
            } => {
                let active =
                    windows_s.is_empty() || windows_s.iter().any(|w| d.t_s >= w[0] && d.t_s < w[1]);
                if active {
                    amplitude_dph * (tau2pi * d.t_s / period_s + phase_rad).sin()
                } else {
                    0.0
                }
            }
            Term::Aging { rate_dph_per_day } => rate_dph_per_day * d.t_s / 86_400.0,
            Term::Heteroscedastic { k, ref_c } => {
                let x = (d.temp_c - ref_c) / 30.0;
                1.0 + k * x * x
            }
            Term::TempQuantization { step_c } => (sensor_in_c / step_c).round() * step_c,
        }
    }
}

/// Runs `term` over driving series (t in s, T_c in °C, dT_c/dt in °C/s; equal lengths,
/// shorter series truncate) and returns its output per sample: the bias contribution (°/h),
/// the sensor reading driven by T_c alone (°C), or the σ multiplier, by [`Term::role`].
pub fn contribution(term: &Term, t_s: &[f64], temp_c: &[f64], dtemp_c_per_s: &[f64]) -> Vec<f64> {
    let n = t_s.len().min(temp_c.len()).min(dtemp_c_per_s.len());
    let drive = |i: usize| Drive {
        t_s: t_s[i],
        temp_c: temp_c[i],
        dtemp_c_per_s: dtemp_c_per_s[i],
    };
    if n == 0 {
        return Vec::new();
    }
    let mut st = TermStep::new(term, &drive(0));
    (0..n).map(|i| st.step(&drive(i), temp_c[i])).collect()
}

#[cfg(test)]
mod tests;
