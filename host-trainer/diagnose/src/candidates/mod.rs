//! Candidate terms the baseline may lack: for each, a grid of its non-linear parameters and
//! its unit-amplitude columns, all computed by the shared physics library
//! ([`rlg_physics::contribution`]), so a candidate is exactly the simulator's term.
//!
//! [`Family`] names each candidate and its grid; [`columns`] computes its block columns.

mod columns;
#[cfg(test)]
mod tests;

use serde::{Deserialize, Serialize};

use super::prepare::Prepared;
use rlg_physics::{Mechanism, Term};

/// A family of candidate terms: one term of the physics library.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    /// `sensor_lag`: the recorded temperature lags the body.
    SensorLag,
    /// `gradient_lag`: a bias from a lagged thermal gradient.
    GradientLag,
    /// `hysteresis`: different bias on heating and cooling branches.
    Hysteresis,
    /// `warmup`: an exponential transient from power-on.
    Warmup,
    /// `mode_hop`: a bias step at a temperature, with switching hysteresis.
    ModeHop,
    /// `backscatter`: a ripple periodic in temperature.
    Backscatter,
    /// `periodic`: a ripple periodic in time.
    Periodic,
    /// `aging`: a linear drift in time.
    Aging,
    /// `heteroscedastic`: the white noise grows away from a temperature (a test on the
    /// variance of the 1 Hz samples, not on the 100 s means: see `super::variance`).
    Heteroscedastic,
    /// `temp_quantization`: the temperature reading is rounded to a coarse quantum.
    TempQuantization,
}

/// The slowest warm-up of the library, s: an RLG settles after power-on within hours, and a
/// decay from power-on slower than this is a trend of the bias (aging). The warm-up's τ is
/// also kept under half the record, the slowest decay a record tells from a trend.
pub const WARMUP_TAU_MAX_S: f64 = 30_000.0;

impl Family {
    /// Every family the diagnosis tests: the bias, sensor and noise-scale terms of the
    /// library. (New families go last: the benchmark numbers its cases in this order.)
    pub const ALL: [Family; 10] = [
        Family::SensorLag,
        Family::GradientLag,
        Family::Hysteresis,
        Family::Warmup,
        Family::ModeHop,
        Family::Backscatter,
        Family::Periodic,
        Family::Aging,
        Family::Heteroscedastic,
        Family::TempQuantization,
    ];

    /// The physics library's mechanism this family tests.
    pub fn mechanism(self) -> Mechanism {
        match self {
            Family::SensorLag => Mechanism::SensorLag,
            Family::GradientLag => Mechanism::GradientLag,
            Family::Hysteresis => Mechanism::Hysteresis,
            Family::Warmup => Mechanism::Warmup,
            Family::ModeHop => Mechanism::ModeHop,
            Family::Backscatter => Mechanism::Backscatter,
            Family::Periodic => Mechanism::Periodic,
            Family::Aging => Mechanism::Aging,
            Family::Heteroscedastic => Mechanism::Heteroscedastic,
            Family::TempQuantization => Mechanism::TempQuantization,
        }
    }

    /// The physics library's term name.
    pub fn name(self) -> &'static str {
        self.mechanism().name()
    }

    /// The family that tests `m`, `None` for the paper's own terms (the baseline).
    pub fn of(m: Mechanism) -> Option<Family> {
        Family::ALL.into_iter().find(|f| f.mechanism() == m)
    }

    /// Position in [`Family::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The family of a library term name.
    pub fn from_name(name: &str) -> Option<Family> {
        Mechanism::from_name(name).and_then(Family::of)
    }

    /// The parameter judged in the benchmark and its relative tolerance: 20 % for lags,
    /// periods and widths, 25 % for amplitudes.
    pub fn key_parameter(self) -> (&'static str, f64) {
        match self {
            Family::SensorLag | Family::GradientLag | Family::Warmup => ("tau_s", 0.20),
            Family::Hysteresis => ("width_c", 0.20),
            Family::ModeHop => ("step_dph", 0.25),
            Family::Backscatter => ("period_c", 0.20),
            Family::Periodic => ("period_s", 0.20),
            Family::Aging => ("rate_dph_per_day", 0.25),
            Family::Heteroscedastic => ("k", 0.25),
            Family::TempQuantization => ("step_c", 0.20),
        }
    }

    /// Whether the family's effect is a function of the temperature history (it recurs in
    /// every temperature cycle), as opposed to time alone (warm-up, aging, periodic) or the
    /// noise (heteroscedastic, tested on the samples' variance).
    pub fn is_thermal(self) -> bool {
        matches!(
            self,
            Family::SensorLag
                | Family::GradientLag
                | Family::Hysteresis
                | Family::ModeHop
                | Family::Backscatter
                | Family::TempQuantization
        )
    }

    /// Number of free parameters counted by the information criterion (linear amplitudes
    /// plus scanned non-linear parameters).
    pub fn n_params(self) -> usize {
        match self {
            Family::SensorLag | Family::Aging | Family::TempQuantization => 1,
            Family::GradientLag | Family::Hysteresis | Family::Warmup | Family::Heteroscedastic => {
                2
            }
            Family::ModeHop | Family::Backscatter | Family::Periodic => 3,
        }
    }

    /// Whether the family's term may be driven by another node of the body than the sensor's
    /// (its last non-linear parameter is then the node's lag, `node_lag_s`).
    pub fn has_node_lag(self) -> bool {
        matches!(
            self,
            Family::Hysteresis | Family::ModeHop | Family::Backscatter
        )
    }

    /// The grid of non-linear parameters scanned on this recording.
    pub fn grid(self, prep: &Prepared) -> Vec<Vec<f64>> {
        let (lo, hi) = quantiles(&prep.drive.temp_c, 0.05, 0.95);
        let range = (hi - lo).max(1.0);
        let dur = prep.drive.t_s.last().copied().unwrap_or(0.0) - prep.full_drive.t_s[0];
        match self {
            Family::SensorLag => log_grid(10.0, 1500.0, 36),
            Family::GradientLag => log_grid(30.0, 10_000.0, 45),
            Family::Hysteresis => with_node_lags(
                log_grid(0.5, range.min(40.0), 40),
                log_grid(0.5, range.min(40.0), 20),
                dur,
            ),
            Family::Warmup => log_grid(300.0, (dur / 2.0).clamp(600.0, WARMUP_TAU_MAX_S), 40),
            Family::ModeHop => {
                let hops = |hyst: &[f64]| {
                    let mut g = Vec::new();
                    for i in 0..40 {
                        let temp = lo + range * (i as f64 + 0.5) / 40.0;
                        g.extend(hyst.iter().map(|h| vec![temp, *h]));
                    }
                    g
                };
                let own = hops(&[0.0, 0.5, 1.0, 2.0, 4.0]);
                with_node_lags(own.clone(), own, dur)
            }
            Family::Backscatter => {
                let hi = (range / 1.5).clamp(1.5, 40.0);
                with_node_lags(log_grid(1.0, hi, 60), log_grid(1.0, hi, 60), dur)
            }
            Family::Periodic => {
                // Uniform in frequency, a third of the record's resolution 1/duration, from
                // two periods per record to four blocks (block means pass periods above two
                // blocks): at most 0.75 points per block. Across a long gap the duration
                // outgrows the blocks, and so would the grid (a day of samples with a month's
                // gap: 6 600 points for 400 blocks); the points are then spread evenly over
                // the same band, 0.75 per block, so the cost follows the samples. A period
                // coherent across the gap falls between the finer fringes such a grid would
                // resolve, and is found at reduced power (METHOD.md).
                let block_s = prep.block as f64 * prep.dt_s;
                let (f0, f1, mut df) = (2.0 / dur, 1.0 / (4.0 * block_s), 1.0 / (3.0 * dur));
                let mut n = ((f1 - f0) / df).floor().max(0.0) as usize + 1;
                let most = (3 * prep.nb()).div_ceil(4).max(1);
                if n > most {
                    n = most;
                    df = (f1 - f0) / (most - 1).max(1) as f64;
                }
                (0..n).map(|k| vec![1.0 / (f0 + k as f64 * df)]).collect()
            }
            Family::Aging => vec![vec![]],
            // Scanned on the block variances instead (`super::variance`).
            Family::Heteroscedastic => Vec::new(),
            // Not scanned: the quantum is read from the recorded values.
            Family::TempQuantization => prep.temp_quantum_c.map(|q| vec![q]).into_iter().collect(),
        }
    }

    /// The term with non-linear parameters `nl` and linear coefficients `amps` of
    /// [`Family::columns`]; `t_on_s` is the power-on time (the recording's first sample).
    pub fn term(self, nl: &[f64], amps: &[f64], t_on_s: f64) -> Term {
        let a = amps.first().copied().unwrap_or(0.0);
        let (amp, phase) = match amps {
            [s, c] => (s.hypot(*c), c.atan2(*s)),
            _ => (a, 0.0),
        };
        match self {
            Family::SensorLag => Term::SensorLag { tau_s: nl[0] },
            Family::GradientLag => Term::GradientLag {
                tau_s: nl[0],
                gain: a,
            },
            Family::Hysteresis => Term::Hysteresis {
                width_c: nl[0],
                height_dph: a,
                node_lag_s: node_lag(self, nl),
            },
            Family::Warmup => Term::Warmup {
                amplitude_dph: a,
                tau_s: nl[0],
                t_on_s,
            },
            Family::ModeHop => Term::ModeHop {
                temp_c: nl[0],
                step_dph: a,
                hysteresis_c: nl[1],
                node_lag_s: node_lag(self, nl),
            },
            Family::Backscatter => Term::Backscatter {
                period_c: nl[0],
                amplitude_dph: amp,
                phase_rad: phase,
                node_lag_s: node_lag(self, nl),
            },
            Family::Periodic => Term::Periodic {
                period_s: nl[0],
                amplitude_dph: amp,
                phase_rad: phase,
                windows_s: Vec::new(),
            },
            Family::Aging => Term::Aging {
                rate_dph_per_day: a,
            },
            Family::Heteroscedastic => Term::Heteroscedastic { k: a, ref_c: nl[0] },
            Family::TempQuantization => Term::TempQuantization { step_c: nl[0] },
        }
    }
}

/// Lags (> 0) and leads (< 0) of the driving node scanned, s, besides the sensor's own
/// temperature (0). A mechanism of the laser block read by a sensor on the case (or the
/// reverse) is the library's function of a temperature τ·dT/dt away from the reading, 13–67 °C
/// at 1 °C/min for τ 800–4 000 s: scanned at the sensor's temperature alone, a mode hop's
/// switching then looks tens of degrees wide and a ripple is smeared between heating and
/// cooling, and even a strong effect is named far less often than on the sensor's node. Octaves
/// from 400 s: the coarsest grid that recovered most of that loss at 2.5× the scan's cost; the
/// best point's lag is then refined (`super::refine`).
pub(crate) const NODE_LAGS_S: [f64; 8] = [
    400.0, 800.0, 1600.0, 3200.0, -400.0, -800.0, -1600.0, -3200.0,
];

/// `own` with lag 0 (the sensor's node) appended to every point, then `lagged` with each of
/// [`NODE_LAGS_S`] no longer than a quarter of the record (`dur_s`), which must hold a few
/// lags to tell one from another. `lagged` is coarser than `own` (a mode hop's switching
/// hysteresis 0, 1 and 3 °C, two thirds of the ripple's periods, half the play's widths):
/// where a lag moves the temperature by degrees the finer steps add little, and on a month's
/// record every grid point costs its block columns twice in memory.
fn with_node_lags(own: Vec<Vec<f64>>, lagged: Vec<Vec<f64>>, dur_s: f64) -> Vec<Vec<f64>> {
    let at = |grid: &[Vec<f64>], lag: f64| -> Vec<Vec<f64>> {
        grid.iter()
            .map(|p| {
                let mut p = p.clone();
                p.push(lag);
                p
            })
            .collect()
    };
    let mut out = at(&own, 0.0);
    for lag in NODE_LAGS_S.into_iter().filter(|l| l.abs() <= 0.25 * dur_s) {
        out.extend(at(&lagged, lag));
    }
    out
}

/// The node's lag of a point of family `f`: its last non-linear parameter where the family has
/// one (0 when `nl` is given without it).
pub(crate) fn node_lag(f: Family, nl: &[f64]) -> f64 {
    let at = match f {
        Family::Hysteresis | Family::Backscatter => 1,
        Family::ModeHop => 2,
        _ => return 0.0,
    };
    nl.get(at).copied().unwrap_or(0.0)
}

/// `n` log-spaced single-parameter points from `lo` to `hi`.
fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<Vec<f64>> {
    let hi = hi.max(lo * 1.01);
    (0..n)
        .map(|k| vec![lo * (hi / lo).powf(k as f64 / (n - 1).max(1) as f64)])
        .collect()
}

/// The `a` and `b` quantiles of `x` (nearest rank).
pub(crate) fn quantiles(x: &[f64], a: f64, b: f64) -> (f64, f64) {
    let mut s = x.to_vec();
    s.sort_by(f64::total_cmp);
    if s.is_empty() {
        return (0.0, 0.0);
    }
    let q = |p: f64| s[((p * (s.len() - 1) as f64).round() as usize).min(s.len() - 1)];
    (q(a), q(b))
}
