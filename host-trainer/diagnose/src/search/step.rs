//! A single step in the bias at one time: the time-only shape outside the library that
//! real records show most (a mode jump, a power or readout event), put against aging and
//! periodic terms, which would otherwise take it.

use rayon::prelude::*;

use crate::candidates::Family;
use crate::linalg::{combine, dot};
use crate::noise::replicates::{replicate_rng, simulate_block_means_levelled};
use crate::noise::whiten::Whitener;
use crate::prepare::Prepared;
use crate::scan::{Scan, Scanned};
use crate::score::delta_bic;
use crate::{Options, StepEvidence};
use rlg_simulate::noise::NoiseParams;

/// The best single step in the bias: the block it starts at, its height and its ΔBIC in the
/// scan's whitened metric (two parameters: height and time).
#[derive(Debug, Clone, Copy)]
pub(super) struct Step {
    /// The block it starts at.
    pub(super) block: usize,
    height_dph: f64,
    delta_bic: f64,
    /// The shares of the two bootstraps (see [`step_instead`]; NaN until they are run).
    p_family: f64,
    p_step: f64,
}

/// At most this many step times are tried (evenly spaced blocks).
pub(super) const STEP_TIMES: usize = 600;

/// The blocks a step is tried at: at most about `most`, evenly spaced; none within 2 % of
/// either end, where a step is an offset of a few blocks, which the noise does by itself.
pub(crate) fn step_times(nb: usize, most: usize) -> Vec<usize> {
    let edge = (nb / 50).max(2);
    if nb < 2 * edge + 2 {
        return Vec::new();
    }
    let stride = ((nb - 2 * edge) / most.max(1)).max(1);
    (edge..nb - edge).step_by(stride).collect()
}

/// Whitened step columns at every tried time, orthogonal to the baseline.
pub(super) struct StepScan {
    blocks: Vec<usize>,
    cols: Vec<Vec<f64>>,
    norms: Vec<f64>,
}

impl StepScan {
    fn new(ar: &Whitener, s: &Scan, nb: usize) -> Option<Self> {
        let blocks = step_times(nb, STEP_TIMES);
        if blocks.is_empty() {
            return None;
        }
        let raw: Vec<Vec<f64>> = blocks
            .iter()
            .map(|&k| (0..nb).map(|b| f64::from(u8::from(b >= k))).collect())
            .collect();
        let refs: Vec<&[f64]> = raw.iter().map(Vec::as_slice).collect();
        let cols: Vec<Vec<f64>> = ar
            .whiten_many(&refs)
            .into_par_iter()
            .map(|mut c| {
                s.basis.residual_in_place(&mut c);
                c
            })
            .collect();
        let norms = cols.iter().map(|c| dot(c, c)).collect();
        Some(Self {
            blocks,
            cols,
            norms,
        })
    }

    /// The best step for the whitened residual `e` (orthogonal to the baseline) whose sum of
    /// squares is `rss0`.
    fn best(&self, e: &[f64], n: usize, rss0: f64) -> Step {
        let mut best = Step {
            block: 0,
            height_dph: 0.0,
            delta_bic: f64::INFINITY,
            p_family: f64::NAN,
            p_step: f64::NAN,
        };
        for ((c, g), &k) in self.cols.iter().zip(&self.norms).zip(&self.blocks) {
            if *g <= 0.0 {
                continue;
            }
            let b = dot(c, e);
            let d = delta_bic(n, rss0, b * b / g, 2);
            if d < best.delta_bic {
                best = Step {
                    block: k,
                    height_dph: b / g,
                    delta_bic: d,
                    ..best
                };
            }
        }
        best
    }
}

/// `Some(step)` when the family of the scan's point `i` is aging or a periodic term and the
/// record is better explained by a single step than by that family `f`. The statistic is the
/// step's best ΔBIC less `f`'s; each of the two explanations gives it a null by a parametric
/// bootstrap of its fitted effect plus the fitted noise `gyro` (its white level in time
/// `white_level`, where there is one; on each replicate the best
/// step and the best point of `f`'s grid are refitted), and the step is preferred when the
/// record's statistic is less probable under `f` (share of `f`'s replicates at least as
/// favourable to the step) than under the step (share of the step's replicates at least as
/// favourable to `f`). Unlike the lower ΔBIC alone, this counts the search over the step's
/// time; like it, it can take a real aging whose best step fits slightly better (the two
/// shares are then close). A one-sided test of `f` at α is not enough: it keeps clear steps
/// as aging. Warm-up is not put to it: an early step is what
/// its decay from power-on looks like, and the step would take real warm-ups. The step
/// columns are made once per pass, in `cached`.
pub(super) fn step_instead(
    scanned: &Scanned<'_>,
    i: usize,
    gyro: &NoiseParams,
    white_level: Option<&[f64]>,
    prep: &Prepared,
    opts: &Options,
    cached: &mut Option<Option<StepScan>>,
) -> Option<Step> {
    let (ar, s, points) = (scanned.whitener, scanned.scan, scanned.points);
    let f = points[i].family;
    if !matches!(f, Family::Aging | Family::Periodic) {
        return None;
    }
    let sc = cached
        .get_or_insert_with(|| StepScan::new(ar, s, prep.nb()))
        .as_ref()?;
    let yw = s.basis.residual(&ar.whiten(&prep.y_b));
    let step = sc.best(&yw, s.n, s.rss0);
    let t_obs = step.delta_bic - s.dbic[i];
    if t_obs >= 0.0 {
        return None;
    }
    let grid: Vec<usize> = (0..points.len())
        .filter(|&j| points[j].family == f)
        .collect();
    let reps = opts.bootstrap.max(1);
    let sims: Vec<Vec<f64>> = (0..reps)
        .into_par_iter()
        .map(|k| {
            simulate_block_means_levelled(
                gyro,
                white_level,
                prep.nb(),
                prep.block as f64 * prep.dt_s,
                &mut replicate_rng(opts.seed ^ STEP_SEED, k as u64),
                (opts.seed ^ STEP_SEED).wrapping_add(k as u64 + 1),
            )
        })
        .collect();
    let refs: Vec<&[f64]> = sims.iter().map(Vec::as_slice).collect();
    let noise: Vec<Vec<f64>> = ar
        .whiten_many(&refs)
        .into_par_iter()
        .map(|w| s.basis.residual(&w))
        .collect();
    // The statistic on every replicate of `effect` plus the noise.
    let stats = |effect: &[f64]| -> Vec<f64> {
        noise
            .par_iter()
            .map(|w| {
                let e: Vec<f64> = w.iter().zip(effect).map(|(a, b)| a + b).collect();
                let rss0 = dot(&e, &e);
                let df = grid
                    .iter()
                    .map(|&j| {
                        delta_bic(
                            s.n,
                            rss0,
                            s.fits[j].drss(&s.cperp[j], &e),
                            points[j].n_params(),
                        )
                    })
                    .fold(f64::INFINITY, f64::min);
                sc.best(&e, s.n, rss0).delta_bic - df
            })
            .collect()
    };
    let share = |v: Vec<f64>, extreme: &dyn Fn(f64) -> bool| {
        (1 + v.into_iter().filter(|t| extreme(*t)).count()) as f64 / (reps + 1) as f64
    };
    let p_family = share(stats(&combine(&s.cperp[i], &s.coef[i], s.n)), &|t| {
        t <= t_obs
    });
    let k = sc.blocks.iter().position(|&b| b == step.block)?;
    let step_effect: Vec<f64> = sc.cols[k].iter().map(|c| c * step.height_dph).collect();
    let p_step = share(stats(&step_effect), &|t| t >= t_obs);
    (p_family < p_step).then_some(Step {
        p_family,
        p_step,
        ..step
    })
}

/// Salt of the step test's replicates (another stream than the significance bootstrap's).
const STEP_SEED: u64 = 0x57e9;

impl Step {
    /// The note and the evidence of this step, preferred to family `f` whose best ΔBIC is
    /// `family_dbic`.
    pub(super) fn evidence(
        &self,
        prep: &Prepared,
        f: Family,
        family_dbic: f64,
    ) -> (String, StepEvidence) {
        let block_s = prep.block as f64 * prep.dt_s;
        let st = self;
        let t_s = prep.t_b[st.block] - 0.5 * block_s;
        let (name, into_h) = (f.name(), (t_s - prep.t_b[0] + 0.5 * block_s) / 3600.0);
        let note = format!(
            "a single step of {:.2e} °/h at {t_s:.0} s ({into_h:.1} h into the \
             record; ΔBIC {:.1}) explains it better than {name} (ΔBIC {:.1}): \
             under {name} and the fitted noise a step fits this much better in \
             a share {:.3} of bootstrap replicates, under the step {name} fits \
             this well in {:.3}. A step at one time, not tied to temperature, \
             is outside the term library, so the structure is not attributed",
            st.height_dph, st.delta_bic, family_dbic, st.p_family, st.p_step
        );
        let evidence = StepEvidence {
            t_s,
            height_dph: st.height_dph,
            delta_bic: st.delta_bic,
            instead_of: f.mechanism(),
            instead_of_delta_bic: family_dbic,
            p_under_family: st.p_family,
            p_under_step: st.p_step,
        };
        (note, evidence)
    }
}
