//! What a chamber's data logger does to a recording (`--logger`): one artefact per case,
//! applied to the finished recording, so the case keeps its conditions, hidden effect and
//! drawn D (which is the record's before the artefact).
//!
//! The generator's recordings are complete, 1 Hz, stamped from zero by an exact clock, their
//! temperature always valid. Real logs are not: a logger drops minutes when its disk or link
//! stalls and seconds when it is busy, writes means over a few seconds, stamps Unix time from
//! a crystal that runs off by tens of ppm, and a temperature sensor returns its power-on or
//! error value now and then (85 °C and −127 °C on a common digital sensor). None of this is
//! physics of the gyro, so the right verdict is the twin's without the artefact.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Serialize;

use super::uni;
use rlg_io::recording::Recording;

/// One logger artefact with its drawn parameters.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Logger {
    /// Minutes lost.
    Dropouts {
        /// (start, length) of each gap, s from the record's start.
        gaps: Vec<(f64, f64)>,
    },
    /// Seconds lost, many times.
    Hiccups {
        /// Number of gaps.
        count: usize,
        /// The longest a gap may be, s.
        longest_s: f64,
    },
    /// Means of consecutive samples, stamped at their centre.
    Averaged {
        /// Seconds per mean.
        period_s: f64,
    },
    /// Unix time stamps in milliseconds from a clock off in rate, with jitter.
    EpochClock {
        /// Unix time of the record's start, s.
        offset_s: f64,
        /// Rate error of the clock, parts per million.
        ppm: f64,
        /// σ of each stamp's jitter, ms.
        jitter_ms: f64,
    },
    /// Temperature readings replaced by a sensor's error values (85 °C, −127 °C).
    TempFaults {
        /// Readings replaced (drawn with replacement, so at most this many).
        count: usize,
    },
}

/// Salt of the artefact's stream, apart from every stream of the case's own draw.
const LOGGER_SALT: u64 = 0x6c6f_6767_6572;

impl Logger {
    /// The artefact of case `id` for master seed `seed`, for a record of `duration_s`.
    pub fn draw(seed: u64, id: usize, duration_s: f64) -> Logger {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ LOGGER_SALT);
        rng.set_stream(id as u64);
        match rng.random_range(0..5u32) {
            0 => {
                let n = rng.random_range(1..=4usize);
                let gaps = (0..n)
                    .map(|_| {
                        let len = uni(&mut rng, 300.0, 3600.0).round();
                        let start = uni(&mut rng, 0.05, 0.95) * (duration_s - len);
                        (start.round(), len)
                    })
                    .collect();
                Logger::Dropouts { gaps }
            }
            1 => Logger::Hiccups {
                count: rng.random_range(20..=80usize),
                longest_s: uni(&mut rng, 5.0, 60.0).round(),
            },
            2 => Logger::Averaged {
                period_s: [2.0, 5.0, 10.0][rng.random_range(0..3usize)],
            },
            3 => Logger::EpochClock {
                offset_s: uni(&mut rng, 1.5e9, 1.9e9).round(),
                ppm: uni(&mut rng, -50.0, 50.0),
                jitter_ms: uni(&mut rng, 2.0, 50.0),
            },
            _ => Logger::TempFaults {
                count: rng.random_range(2..=10usize),
            },
        }
    }

    /// The condition's name in the report.
    pub fn tag(&self) -> &'static str {
        match self {
            Logger::Dropouts { .. } => LOGGER_TAGS[0],
            Logger::Hiccups { .. } => LOGGER_TAGS[1],
            Logger::Averaged { .. } => LOGGER_TAGS[2],
            Logger::EpochClock { .. } => LOGGER_TAGS[3],
            Logger::TempFaults { .. } => LOGGER_TAGS[4],
        }
    }

    /// One phrase for the case's description.
    pub fn describe(&self) -> String {
        match self {
            Logger::Dropouts { gaps } => {
                let lost: f64 = gaps.iter().map(|g| g.1).sum();
                format!(
                    "logger drops {} gap(s), {:.0} min in all",
                    gaps.len(),
                    lost / 60.0
                )
            }
            Logger::Hiccups { count, longest_s } => {
                format!("logger drops {count} short gaps of up to {longest_s:.0} s")
            }
            Logger::Averaged { period_s } => format!("logger writes {period_s:.0} s means"),
            Logger::EpochClock { ppm, jitter_ms, .. } => {
                format!("Unix time stamps in ms, clock {ppm:+.0} ppm, jitter {jitter_ms:.0} ms")
            }
            Logger::TempFaults { count } => {
                format!("{count} temperature readings at a sensor's error values")
            }
        }
    }

    /// Applies the artefact to `rec` (1 Hz, stamped from zero); `seed` and `id` as drawn.
    pub fn apply(&self, rec: &mut Recording, seed: u64, id: usize) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ LOGGER_SALT ^ 1);
        rng.set_stream(id as u64);
        let n = rec.time_s.len();
        match self {
            Logger::Dropouts { gaps } => {
                let t0 = rec.time_s[0];
                let drop: Vec<bool> = rec
                    .time_s
                    .iter()
                    .map(|t| gaps.iter().any(|(s, l)| (t - t0) >= *s && (t - t0) < s + l))
                    .collect();
                *rec = rec.without(&drop);
            }
            Logger::Hiccups { count, longest_s } => {
                let mut drop = vec![false; n];
                for _ in 0..*count {
                    let len = rng.random_range(1..=(*longest_s as usize));
                    let start = rng.random_range(1..n.saturating_sub(len + 1).max(2));
                    drop[start..(start + len).min(n)].fill(true);
                }
                *rec = rec.without(&drop);
            }
            Logger::Averaged { period_s } => {
                let k = *period_s as usize;
                let mean = |v: &[f64]| -> Vec<f64> {
                    v.chunks_exact(k)
                        .map(|c| c.iter().sum::<f64>() / k as f64)
                        .collect()
                };
                rec.time_s = mean(&rec.time_s);
                rec.rate_dph = mean(&rec.rate_dph);
                rec.temp_c = mean(&rec.temp_c);
                rec.chamber_c = rec.chamber_c.as_deref().map(mean);
            }
            Logger::EpochClock {
                offset_s,
                ppm,
                jitter_ms,
            } => {
                for t in &mut rec.time_s {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    let ms = ((*t * (1.0 + ppm * 1e-6)) * 1e3 + jitter_ms * z).round();
                    *t = offset_s + ms / 1e3;
                }
            }
            Logger::TempFaults { count } => {
                for _ in 0..*count {
                    let i = rng.random_range(0..n);
                    rec.temp_c[i] = if rng.random::<bool>() { 85.0 } else { -127.0 };
                }
            }
        }
    }
}

/// The logger conditions, in the report's order (after [`super::gen::CONDITION_TAGS`]).
pub(super) const LOGGER_TAGS: [&str; 5] = [
    "logger: dropouts of minutes",
    "logger: short gaps",
    "logger: means of seconds",
    "logger: Unix time, drifting clock",
    "logger: temperature error values",
];
