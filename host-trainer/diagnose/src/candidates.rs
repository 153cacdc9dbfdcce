//! Candidate terms the baseline may lack: for each, a grid of its non-linear parameters and
//! its unit-amplitude columns, all computed by the shared physics library
//! ([`rlg_physics::contribution`]), so a candidate is exactly the simulator's term.

use serde::{Deserialize, Serialize};

use super::prepare::{
    baseline_specs, baseline_values, read_quantum, DriveSeries, PhysicsModel, Prepared,
};
use super::DiagnoseError;
use rlg_physics::{contribution, Drive, Mechanism, Term, TermStep};

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
            Family::Warmup => log_grid(300.0, (dur / 2.0).clamp(600.0, 30_000.0), 40),
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
                // blocks): at most 0.75 points per block.
                let block_s = prep.block as f64 * prep.dt_s;
                let (f0, f1, df) = (2.0 / dur, 1.0 / (4.0 * block_s), 1.0 / (3.0 * dur));
                let n = ((f1 - f0) / df).floor().max(0.0) as usize + 1;
                (0..n).map(|k| vec![1.0 / (f0 + k as f64 * df)]).collect()
            }
            Family::Aging => vec![vec![]],
            // Scanned on the block variances instead (`super::variance`).
            Family::Heteroscedastic => Vec::new(),
            // Not scanned: the quantum is read from the recorded values.
            Family::TempQuantization => read_quantum(&prep.full_drive.temp_c)
                .map(|q| vec![q])
                .into_iter()
                .collect(),
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

    /// The block means of [`Family::columns`]. For a periodic term in time they are summed in
    /// closed form (a sampled sinusoid's block sum is a geometric series), which keeps the
    /// periodic grid, thousands of periods on a long record, from costing a sine per sample
    /// and period; the other families average their per-sample columns.
    pub fn block_columns(
        self,
        nl: &[f64],
        prep: &Prepared,
        model: &PhysicsModel,
        model_drive: &DriveSeries,
        beta: &[f64],
    ) -> Result<Vec<Vec<f64>>, DiagnoseError> {
        if self == Family::Periodic {
            if let Some(c) = periodic_block_columns(nl[0], prep) {
                return Ok(c);
            }
        }
        // The bias families' columns summed into block means as the term is stepped, the
        // values and order of `columns` then `Prepared::blocks`: a month at 1 Hz would
        // otherwise allocate and drop two 21 MB series per point.
        let t_on = prep.full_drive.t_s[0];
        match self {
            Family::Backscatter => {
                let half = std::f64::consts::FRAC_PI_2;
                return Ok(vec![
                    stepped_blocks(&self.term(nl, &[1.0, 0.0], t_on), prep, false),
                    stepped_blocks(
                        &self.term(nl, &[0.0, 1.0], t_on).with_phase(half),
                        prep,
                        false,
                    ),
                ]);
            }
            Family::GradientLag => {
                return Ok(vec![stepped_blocks(
                    &self.term(nl, &[1.0], t_on),
                    prep,
                    true,
                )]);
            }
            Family::Hysteresis | Family::Warmup | Family::ModeHop | Family::Aging => {
                return Ok(vec![stepped_blocks(
                    &self.term(nl, &[1.0], t_on),
                    prep,
                    false,
                )]);
            }
            _ => {}
        }
        Ok(self
            .columns(nl, prep, model, model_drive, beta)?
            .iter()
            .map(|v| prep.blocks(v))
            .collect())
    }

    /// Unit-amplitude columns (°/h per unit of each linear parameter) over the fitted samples.
    /// Bias terms run over the whole recording from power-on, as in the simulator, and are
    /// then cut to the fitted samples. `sensor_lag` has no amplitude: its column is the change
    /// of the fitted baseline `beta` when its drive is un-lagged by τ (the first-order effect,
    /// amplitude 1 = the full lag), which nests it in the baseline for the tests;
    /// `temp_quantization` likewise with the drive de-quantised. `heteroscedastic` has no
    /// column: it changes the noise, not the mean.
    pub fn columns(
        self,
        nl: &[f64],
        prep: &Prepared,
        model: &PhysicsModel,
        model_drive: &DriveSeries,
        beta: &[f64],
    ) -> Result<Vec<Vec<f64>>, DiagnoseError> {
        let d = &prep.full_drive;
        let t_on = d.t_s[0];
        let cut = |v: Vec<f64>| v[prep.range.clone()].to_vec();
        let run = |term: Term| cut(contribution(&term, &d.t_s, &d.temp_c, &d.dtemp_c_per_s));
        Ok(match self {
            Family::Heteroscedastic => Vec::new(),
            Family::SensorLag | Family::TempQuantization => {
                let lagged = match self {
                    Family::SensorLag => prep.drive_unlagged(nl[0])?,
                    _ => prep.drive_dequantised(nl[0])?,
                };
                // Column by column: a month at 1 Hz holds 21 MB per column.
                let n = prep.rate_dph.len();
                let mut out = vec![0.0; n];
                for ((_, unit), w) in baseline_specs(model).iter().zip(beta) {
                    let ca = baseline_values(unit.as_ref(), &lagged);
                    let cb = baseline_values(unit.as_ref(), model_drive);
                    for (o, (x, y)) in out.iter_mut().zip(ca.iter().zip(&cb)) {
                        *o += w * (x - y);
                    }
                }
                vec![out]
            }
            Family::Backscatter | Family::Periodic => {
                let half = std::f64::consts::FRAC_PI_2;
                vec![
                    run(self.term(nl, &[1.0, 0.0], t_on)),
                    run(self.term(nl, &[0.0, 1.0], t_on).with_phase(half)),
                ]
            }
            Family::GradientLag => {
                // The recording starts at power-on with the body at rest (the warm-up term's
                // assumption too): the lag starts from dT/dt = 0, not from the first sample's
                // one-sided difference, which already sees the self-heating rise. Started
                // there, a 2 400 s lag misses the simulator's effect by 40 % (RMS) and its
                // fitted τ is 35 % short even with no noise.
                let mut rate = d.dtemp_c_per_s.clone();
                if let Some(r0) = rate.first_mut() {
                    *r0 = 0.0;
                }
                vec![cut(contribution(
                    &self.term(nl, &[1.0], t_on),
                    &d.t_s,
                    &d.temp_c,
                    &rate,
                ))]
            }
            _ => vec![run(self.term(nl, &[1.0], t_on))],
        })
    }
}

/// Block means over the fitted samples of `term`'s contribution stepped over the whole
/// recording from power-on (`contribution`, cut to `prep.range`, then `Prepared::blocks`,
/// bit for bit), without the per-sample series. `rest_start`: the drive's dT/dt starts at 0
/// (the gradient lag's start, see `Family::columns`).
fn stepped_blocks(term: &Term, prep: &Prepared, rest_start: bool) -> Vec<f64> {
    let d = &prep.full_drive;
    let n = d.t_s.len().min(d.temp_c.len()).min(d.dtemp_c_per_s.len());
    let nb = prep.nb();
    let m = prep.block;
    if n == 0 || m == 0 {
        return vec![0.0; nb];
    }
    let stride = node_stride(term, prep);
    if stride > 1 {
        return strided_blocks(term, prep, stride);
    }
    let drive = |i: usize| Drive {
        t_s: d.t_s[i],
        temp_c: d.temp_c[i],
        dtemp_c_per_s: if rest_start && i == 0 {
            0.0
        } else {
            d.dtemp_c_per_s[i]
        },
    };
    let mut st = TermStep::new(term, &drive(0));
    // `Iterator::sum` of f64 starts from −0.0; so do these sums.
    let mut sums = vec![-0.0f64; nb];
    let r = prep.range.clone();
    for i in 0..n.min(r.end) {
        let v = st.step(&drive(i), d.temp_c[i]);
        if i >= r.start {
            let b = (i - r.start) / m;
            if b < nb {
                sums[b] += v;
            }
        }
    }
    sums.iter().map(|s| s / m as f64).collect()
}

/// Samples between the steps of a term driven by a lagging or leading node in the scan: the
/// node's lag over 40, at most a block. Such a node moves by at most τ·dT/dt over a lag, so
/// at τ/40 a mode hop's switching moves by at most a fortieth of a lag and a block mean by at
/// most that share of its step (a ripple or a play by far less); stepped at every sample, the
/// scan's eight lagged copies of the three families take about four times as long on a
/// month at 1 Hz. The refinement and every check after the scan step the
/// term at every sample (`Family::columns`).
fn node_stride(term: &Term, prep: &Prepared) -> usize {
    let lag = match term {
        Term::Hysteresis { node_lag_s, .. }
        | Term::ModeHop { node_lag_s, .. }
        | Term::Backscatter { node_lag_s, .. } => node_lag_s.abs(),
        _ => 0.0,
    };
    if lag == 0.0 || prep.dt_s <= 0.0 {
        return 1;
    }
    ((lag / 200.0 / prep.dt_s).floor() as usize).clamp(1, prep.block.max(1))
}

/// [`stepped_blocks`] with the term stepped at every `stride`-th sample of each block (from
/// the block's first), each block's mean taken over the samples stepped; the samples before
/// the fitted range are stepped at the same stride from the first.
fn strided_blocks(term: &Term, prep: &Prepared, stride: usize) -> Vec<f64> {
    let d = &prep.full_drive;
    let n = d.t_s.len().min(d.temp_c.len()).min(d.dtemp_c_per_s.len());
    let (nb, m) = (prep.nb(), prep.block);
    let drive = |i: usize| Drive {
        t_s: d.t_s[i],
        temp_c: d.temp_c[i],
        dtemp_c_per_s: d.dtemp_c_per_s[i],
    };
    let r = prep.range.clone();
    let mut st = TermStep::new(term, &drive(0));
    let (mut sums, mut counts) = (vec![0.0f64; nb], vec![0usize; nb]);
    let end = n.min(r.end);
    let mut i = 0;
    while i < end {
        let v = st.step(&drive(i), d.temp_c[i]);
        if i >= r.start {
            let b = (i - r.start) / m;
            if b < nb {
                sums[b] += v;
                counts[b] += 1;
            }
            // The next sample: `stride` on, or the next block's first.
            let k = i - r.start;
            let next_block = (b + 1) * m;
            i = r.start + (k + stride).min(next_block);
        } else {
            i = (i + stride).min(r.start.max(i + 1));
        }
    }
    sums.iter()
        .zip(&counts)
        .map(|(s, c)| if *c > 0 { s / *c as f64 } else { 0.0 })
        .collect()
}

/// Block means of sin(ωt) and cos(ωt), ω = 2π/`period_s`, over the fitted samples, in closed
/// form: for m samples t₀ + k·dt, Σ sin(a + kθ) = sin(a + (m−1)θ/2)·sin(mθ/2)/sin(θ/2) with
/// a = ωt₀, θ = ω·dt (and cos likewise). `None` when a block's samples are not evenly spaced
/// (then the per-sample columns are averaged) or θ is a multiple of 2π.
fn periodic_block_columns(period_s: f64, prep: &Prepared) -> Option<Vec<Vec<f64>>> {
    let t = &prep.drive.t_s;
    let m = prep.block;
    let w = std::f64::consts::TAU / period_s;
    let theta = w * prep.dt_s;
    let half = (0.5 * theta).sin();
    if half.abs() < 1e-9 {
        return None;
    }
    let gain = (0.5 * m as f64 * theta).sin() / (half * m as f64);
    let nb = prep.nb();
    let (mut s, mut c) = (Vec::with_capacity(nb), Vec::with_capacity(nb));
    for b in 0..nb {
        let (t0, t1) = (t[b * m], t[b * m + m - 1]);
        if ((t1 - t0) - (m - 1) as f64 * prep.dt_s).abs() > 1e-6 * prep.dt_s * m as f64 {
            return None;
        }
        // The phase of the block's centre, reduced before the sine so a long record keeps
        // full precision.
        let centre = (w * (0.5 * (t0 + t1))).rem_euclid(std::f64::consts::TAU);
        let (sn, cs) = centre.sin_cos();
        s.push(sn * gain);
        c.push(cs * gain);
    }
    Some(vec![s, c])
}

trait WithPhase {
    fn with_phase(self, phase: f64) -> Term;
}

impl WithPhase for Term {
    /// Unit amplitude at the given phase (the cosine column of a sine/cosine pair).
    fn with_phase(self, phase: f64) -> Term {
        match self {
            Term::Backscatter {
                period_c,
                node_lag_s,
                ..
            } => Term::Backscatter {
                period_c,
                amplitude_dph: 1.0,
                phase_rad: phase,
                node_lag_s,
            },
            Term::Periodic { period_s, .. } => Term::Periodic {
                period_s,
                amplitude_dph: 1.0,
                phase_rad: phase,
                windows_s: Vec::new(),
            },
            t => t,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prepare::{block_samples, prepare, MAX_BLOCKS};
    use rlg_io::recording::Recording;

    fn recording(n: usize) -> Recording {
        Recording {
            time_s: (0..n).map(|k| 1000.0 + k as f64).collect(),
            temp_c: (0..n)
                .map(|k| 20.0 + 10.0 * (k as f64 / 7200.0).sin())
                .collect(),
            rate_dph: vec![-7.1; n],
            ..Recording::default()
        }
    }

    /// The closed-form block means of the periodic columns are the block means of the
    /// per-sample columns, for periods from four blocks to the record's length.
    #[test]
    fn periodic_block_columns_are_the_block_means_of_the_samples() {
        let prep = prepare(recording(60_000)).unwrap();
        let model = PhysicsModel::paper();
        for period in [400.0, 777.7, 5_000.0, 59_000.0] {
            let fast = periodic_block_columns(period, &prep).unwrap();
            let slow: Vec<Vec<f64>> = Family::Periodic
                .columns(&[period], &prep, &model, &prep.drive, &[])
                .unwrap()
                .iter()
                .map(|v| prep.blocks(v))
                .collect();
            for (f, s) in fast.iter().zip(&slow) {
                let worst = f
                    .iter()
                    .zip(s)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                assert!(worst < 1e-12, "period {period}: {worst:e}");
            }
        }
    }

    /// A family's block columns from the scan's fast path and from its per-sample columns.
    fn fast_and_slow(
        f: Family,
        nl: &[f64],
        prep: &Prepared,
        model: &PhysicsModel,
    ) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
        let fast = f.block_columns(nl, prep, model, &prep.drive, &[]).unwrap();
        let slow = f
            .columns(nl, prep, model, &prep.drive, &[])
            .unwrap()
            .iter()
            .map(|v| prep.blocks(v))
            .collect();
        (fast, slow)
    }

    /// The stepped block means of the bias families are `columns` then `Prepared::blocks`,
    /// bit for bit, at the first points of each family's grid.
    #[test]
    fn stepped_block_columns_are_the_block_means_of_the_samples() {
        let prep = prepare(recording(60_000)).unwrap();
        let model = PhysicsModel::paper();
        for f in [
            Family::Backscatter,
            Family::GradientLag,
            Family::Hysteresis,
            Family::Warmup,
            Family::ModeHop,
            Family::Aging,
        ] {
            let grid = f.grid(&prep);
            assert!(!grid.is_empty(), "{f:?}: no grid point to compare");
            for nl in grid.into_iter().take(3) {
                let (fast, slow) = fast_and_slow(f, &nl, &prep, &model);
                assert_eq!(fast.len(), slow.len(), "{f:?}");
                for (a, b) in fast.iter().zip(&slow) {
                    assert!(
                        a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()),
                        "{f:?} at {nl:?}"
                    );
                }
            }
        }
    }

    /// The scan's block means of a term driven by another node, stepped at a stride of the
    /// node's lag over 200, are those of the term stepped at every sample to within a few
    /// per cent of its amplitude, for a lagging and a leading node of each family.
    #[test]
    fn strided_block_columns_of_a_node_follow_the_samples() {
        let prep = prepare(recording(60_000)).unwrap();
        let model = PhysicsModel::paper();
        for f in [Family::Hysteresis, Family::ModeHop, Family::Backscatter] {
            for lag in [3200.0, -1600.0] {
                let nl = f
                    .grid(&prep)
                    .into_iter()
                    .filter(|p| node_lag(f, p) == lag)
                    // A mode hop mid-range, which the node's swing crosses.
                    .nth(if f == Family::ModeHop { 100 } else { 7 })
                    .expect("a lagged point");
                let term = f.term(&nl, &[1.0, 0.0], 1000.0);
                assert!(node_stride(&term, &prep) > 1, "{f:?} {lag}: not strided");
                let (fast, slow) = fast_and_slow(f, &nl, &prep, &model);
                for (a, b) in fast.iter().zip(&slow) {
                    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                    let worst = a
                        .iter()
                        .zip(b)
                        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
                    let rms = (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>()
                        / a.len() as f64)
                        .sqrt();
                    assert!(scale > 0.1, "{f:?} {lag}: a column of nothing");
                    assert!(
                        worst <= 0.2 * scale && rms <= 0.02 * scale,
                        "{f:?} {lag}: {worst} {rms}"
                    );
                }
            }
        }
    }

    /// A record longer than MAX_BLOCKS 100 s blocks is averaged over whole multiples of 100 s.
    #[test]
    fn long_records_get_longer_blocks() {
        assert_eq!(block_samples(100 * MAX_BLOCKS, 1.0), 100);
        assert_eq!(block_samples(100 * MAX_BLOCKS + 1, 1.0), 200);
        assert_eq!(block_samples(2_678_400, 1.0), 700);
        assert_eq!(block_samples(2 * 2_678_400, 0.5), 1400);
    }
}
