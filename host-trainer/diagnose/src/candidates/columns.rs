//! A candidate's columns: its unit-amplitude contribution per sample, and their block means
//! summed as the term is stepped (closed form for a periodic term in time).

use super::Family;
use crate::linalg::Basis;
use crate::prepare::{baseline_specs, baseline_values, DriveSeries, PhysicsModel, Prepared};
use crate::DiagnoseError;
use rlg_physics::{contribution, Drive, Term, TermStep};

impl Family {
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
    /// of the baseline, its coefficients refitted on the un-lagged drive, when its drive is
    /// un-lagged by τ (amplitude 1 = the full lag), which nests it in the baseline for the
    /// tests; `temp_quantization` likewise with the drive de-quantised and the fitted
    /// baseline `beta`. `heteroscedastic` has no
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
                // A lagging sensor's coefficients are refitted on the un-lagged drive: fitted
                // on the late reading, the baseline's dT/dt coefficient has taken the lag's
                // first-order part (b'(T)·τ·dT/dt), and a column built from it misplaces the
                // rest of the lag's shape.
                let refitted;
                let beta = match self {
                    Family::SensorLag => {
                        refitted = Basis::new(&prep.baseline_blocks(model, &lagged))
                            .coefficients(&prep.y_b);
                        &refitted[..]
                    }
                    _ => beta,
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
pub(super) fn node_stride(term: &Term, prep: &Prepared) -> usize {
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
/// a = ωt₀, θ = ω·dt (and cos likewise). A block whose samples are not evenly spaced (a gap
/// or jitter inside it) is summed run by run, each run of evenly spaced samples in closed
/// form, so a gap costs its block's samples once, not a sine per sample and period. `None`
/// when θ is a multiple of 2π.
pub(super) fn periodic_block_columns(period_s: f64, prep: &Prepared) -> Option<Vec<Vec<f64>>> {
    let t = &prep.drive.t_s;
    let m = prep.block;
    let dt = prep.dt_s;
    let w = std::f64::consts::TAU / period_s;
    let theta = w * dt;
    let half = (0.5 * theta).sin();
    if half.abs() < 1e-9 {
        return None;
    }
    // The sum of a run of k samples from t₀ at its centre's phase, reduced before the sine so
    // a long record keeps full precision.
    let run = |t0: f64, k: usize| {
        let centre = (w * (t0 + 0.5 * (k - 1) as f64 * dt)).rem_euclid(std::f64::consts::TAU);
        let (sn, cs) = centre.sin_cos();
        let g = (0.5 * k as f64 * theta).sin() / half;
        (sn * g, cs * g)
    };
    let gain = (0.5 * m as f64 * theta).sin() / (half * m as f64);
    let nb = prep.nb();
    let (mut s, mut c) = (Vec::with_capacity(nb), Vec::with_capacity(nb));
    for b in 0..nb {
        let block = &t[b * m..b * m + m];
        let (t0, t1) = (block[0], block[m - 1]);
        if ((t1 - t0) - (m - 1) as f64 * dt).abs() <= 1e-6 * dt * m as f64 {
            let centre = (w * (0.5 * (t0 + t1))).rem_euclid(std::f64::consts::TAU);
            let (sn, cs) = centre.sin_cos();
            s.push(sn * gain);
            c.push(cs * gain);
            continue;
        }
        let (mut ss, mut cc) = (0.0, 0.0);
        let mut i = 0;
        while i < m {
            let mut k = 1;
            while i + k < m && (block[i + k] - block[i] - k as f64 * dt).abs() <= 1e-6 * dt {
                k += 1;
            }
            let (a, b) = run(block[i], k);
            ss += a;
            cc += b;
            i += k;
        }
        s.push(ss / m as f64);
        c.push(cc / m as f64);
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
