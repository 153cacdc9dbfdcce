//! Scenario files (TOML): chamber setpoint profile, thermal constants, physics terms, noise.

use serde::{Deserialize, Serialize};

use super::noise::NoiseParams;
use super::thermal::ThermalParams;
use rlg_physics::Term;

/// One piece of the chamber setpoint profile.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Segment {
    /// Step the setpoint to `setpoint_c` and hold it for `duration_s`.
    Soak {
        /// °C.
        setpoint_c: f64,
        /// s.
        duration_s: f64,
    },
    /// Keep the current setpoint for `duration_s`.
    Hold {
        /// s.
        duration_s: f64,
    },
    /// Move the setpoint linearly to `to_c` at `rate_c_per_min`.
    Ramp {
        /// °C.
        to_c: f64,
        /// Magnitude of the slope, °C/min (> 0).
        rate_c_per_min: f64,
    },
    /// `count` repetitions of `segments`.
    Repeat {
        /// Number of repetitions.
        count: u32,
        /// The repeated pieces.
        segments: Vec<Segment>,
    },
}

/// A simulated experiment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name, written into the recording's provenance.
    pub name: String,
    /// Sample period, s (1 Hz default).
    #[serde(default = "one")]
    pub sample_period_s: f64,
    /// Gyro power-on (start of recording and of self-heating), s from the profile start.
    #[serde(default)]
    pub power_on_s: f64,
    /// Length of the run from the profile start, s; default: the end of the profile.
    #[serde(default)]
    pub duration_s: Option<f64>,
    /// Setpoint (and settled air/body temperature) before the first segment, °C.
    pub start_c: f64,
    /// Chamber and gyro thermal constants.
    pub thermal: ThermalParams,
    /// Chamber setpoint profile, in order; after its end the last setpoint is held.
    pub profile: Vec<Segment>,
    /// Physics terms (bias, sensor, noise-scale), applied in order.
    #[serde(default)]
    pub terms: Vec<Term>,
    /// Stochastic gyro noise.
    #[serde(default)]
    pub noise: NoiseParams,
}

fn one() -> f64 {
    1.0
}

/// Why a scenario is unusable.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ScenarioError {
    /// The file could not be read.
    #[error("{path}: cannot read the scenario")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The TOML does not describe a scenario.
    #[error("{path}: not a valid scenario")]
    Parse {
        /// The file.
        path: String,
        /// The parser's message (with line and column).
        source: toml::de::Error,
    },
    /// A value is out of range.
    #[error("scenario `{name}`: {message}")]
    Invalid {
        /// Scenario name.
        name: String,
        /// What is wrong.
        message: String,
    },
}

/// Setpoint profile flattened to linear pieces (t0, t1, sp0, sp1), s and °C.
pub type Pieces = Vec<(f64, f64, f64, f64)>;

impl Scenario {
    /// Reads and validates a scenario file.
    pub fn from_file(path: &std::path::Path) -> Result<Self, ScenarioError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
            path: p.clone(),
            source,
        })?;
        Self::from_toml_str(&text, &p)
    }

    /// Parses and validates scenario text; `origin` names it in errors.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, ScenarioError> {
        let s: Scenario = toml::from_str(text).map_err(|source| ScenarioError::Parse {
            path: origin.to_string(),
            source,
        })?;
        s.validate()?;
        Ok(s)
    }

    /// Checks ranges: positive sample period and durations, finite values, valid terms.
    pub fn validate(&self) -> Result<(), ScenarioError> {
        let bad = |message: String| {
            Err(ScenarioError::Invalid {
                name: self.name.clone(),
                message,
            })
        };
        if !(self.sample_period_s > 0.0 && self.sample_period_s.is_finite()) {
            return bad(format!(
                "sample_period_s must be > 0, got {}",
                self.sample_period_s
            ));
        }
        if !(self.power_on_s >= 0.0 && self.power_on_s.is_finite() && self.start_c.is_finite()) {
            return bad("power_on_s must be ≥ 0 and start_c finite".into());
        }
        if let Err(m) = self.thermal.validate() {
            return bad(m);
        }
        if let Err(m) = self.noise.validate() {
            return bad(m);
        }
        if let Err(m) = check_segments(&self.profile) {
            return bad(m);
        }
        for t in &self.terms {
            if let Err(m) = t.validate() {
                return bad(m);
            }
        }
        let d = self.duration();
        if !(d > self.power_on_s && d.is_finite()) {
            return bad(format!(
                "duration {d} s must exceed power_on_s {} s",
                self.power_on_s
            ));
        }
        if d / self.sample_period_s > 1e9 {
            return bad(format!(
                "{d} s at {} s per sample is too many samples",
                self.sample_period_s
            ));
        }
        Ok(())
    }

    /// The profile as linear pieces.
    pub fn pieces(&self) -> Pieces {
        let mut out = Vec::new();
        let (mut t, mut sp) = (0.0, self.start_c);
        flatten(&self.profile, &mut t, &mut sp, &mut out);
        out
    }

    /// Run length, s: `duration_s` or the end of the profile.
    pub fn duration(&self) -> f64 {
        self.duration_s
            .unwrap_or_else(|| self.pieces().last().map_or(0.0, |p| p.1))
    }
}

fn check_segments(segs: &[Segment]) -> Result<(), String> {
    for s in segs {
        match s {
            Segment::Soak {
                setpoint_c,
                duration_s,
            } if !(setpoint_c.is_finite() && *duration_s >= 0.0 && duration_s.is_finite()) => {
                return Err(format!(
                    "soak needs a finite setpoint and a duration ≥ 0: {s:?}"
                ))
            }
            Segment::Hold { duration_s } if !(*duration_s >= 0.0 && duration_s.is_finite()) => {
                return Err(format!("hold needs a duration ≥ 0: {s:?}"))
            }
            Segment::Ramp {
                to_c,
                rate_c_per_min,
            } if !(to_c.is_finite() && *rate_c_per_min > 0.0 && rate_c_per_min.is_finite()) => {
                return Err(format!("ramp needs a finite target and a rate > 0: {s:?}"))
            }
            Segment::Repeat { count, segments } => {
                if *count > 10_000 {
                    return Err(format!("repeat count {count} is implausible"));
                }
                check_segments(segments)?
            }
            _ => {}
        }
    }
    Ok(())
}

fn flatten(segs: &[Segment], t: &mut f64, sp: &mut f64, out: &mut Pieces) {
    for s in segs {
        match s {
            Segment::Soak {
                setpoint_c,
                duration_s,
            } => {
                *sp = *setpoint_c;
                out.push((*t, *t + duration_s, *sp, *sp));
                *t += duration_s;
            }
            Segment::Hold { duration_s } => {
                out.push((*t, *t + duration_s, *sp, *sp));
                *t += duration_s;
            }
            Segment::Ramp {
                to_c,
                rate_c_per_min,
            } => {
                let d = (to_c - *sp).abs() / rate_c_per_min * 60.0;
                out.push((*t, *t + d, *sp, *to_c));
                *t += d;
                *sp = *to_c;
            }
            Segment::Repeat { count, segments } => {
                for _ in 0..*count {
                    flatten(segments, t, sp, out);
                }
            }
        }
    }
}

/// Setpoint at `t_s` from the flattened pieces (start value before, last value after).
pub fn setpoint_at(pieces: &Pieces, start_c: f64, t_s: f64) -> f64 {
    // Pieces are contiguous and sorted; binary search the one holding t.
    let i = pieces.partition_point(|p| p.1 <= t_s);
    match pieces.get(i) {
        Some(&(t0, t1, a, b)) if t_s >= t0 => {
            if t1 > t0 {
                a + (b - a) * (t_s - t0) / (t1 - t0)
            } else {
                b
            }
        }
        Some(_) => start_c,
        None => pieces.last().map_or(start_c, |p| p.3),
    }
}
