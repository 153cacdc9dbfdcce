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

/// Whitened single columns of one shape outside the library at each of its placements (a
/// step at each tried time, a bump between each pair of temperature levels), orthogonal to
/// the baseline, and the parameters a placement is charged.
pub(super) struct Placements {
    cols: Vec<Vec<f64>>,
    norms: Vec<f64>,
    n_params: usize,
}

impl Placements {
    /// The block columns `raw` whitened by `ar` and made orthogonal to `s`'s baseline.
    pub(super) fn new(ar: &Whitener, s: &Scan, raw: &[Vec<f64>], n_params: usize) -> Self {
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
        Self {
            cols,
            norms,
            n_params,
        }
    }

    /// The best placement for the whitened residual `e` (orthogonal to the baseline) whose
    /// sum of squares is `rss0`: its index, height and ΔBIC.
    fn best(&self, e: &[f64], n: usize, rss0: f64) -> Option<(usize, f64, f64)> {
        let mut best: Option<(usize, f64, f64)> = None;
        for (k, (c, g)) in self.cols.iter().zip(&self.norms).enumerate() {
            if *g <= 0.0 {
                continue;
            }
            let b = dot(c, e);
            let d = delta_bic(n, rss0, b * b / g, self.n_params);
            if best.is_none_or(|(_, _, bd)| d < bd) {
                best = Some((k, b / g, d));
            }
        }
        best
    }
}

/// What a shape outside the library is put against a family with: the pass's scan, its
/// fitted noise (and white level in time, where there is one), the record and the options.
pub(super) struct Against<'a> {
    pub(super) scanned: &'a Scanned<'a>,
    pub(super) gyro: &'a NoiseParams,
    pub(super) white_level: Option<&'a [f64]>,
    pub(super) prep: &'a Prepared,
    pub(super) opts: &'a Options,
}

/// A shape outside the library preferred to a family by [`instead`].
#[derive(Debug, Clone, Copy)]
pub(super) struct Preferred {
    /// The placement's index.
    pub(super) index: usize,
    /// Its height, °/h.
    pub(super) height_dph: f64,
    /// Its ΔBIC in the scan's whitened metric.
    pub(super) delta_bic: f64,
    /// Share of the family's replicates in which the shape beats it by as much as on the
    /// record.
    pub(super) p_family: f64,
    /// Share of the shape's replicates in which the family comes as close as on the record.
    pub(super) p_shape: f64,
}

/// `Some` when the record is better explained by the best placement of `pl` than by the
/// family of the scan's point `i`. The statistic is the shape's best ΔBIC less the
/// family's; each of the two explanations gives it a null by a parametric bootstrap of its
/// fitted effect plus the fitted noise of `on` (its white level in time, where there is
/// one; on each replicate the best placement and the best point of the family's grid are
/// refitted), and the shape is preferred when the record's statistic is less
/// probable under the family (share of its replicates at least as favourable to the shape)
/// than under the shape (share of the shape's replicates at least as favourable to the
/// family). Unlike the lower ΔBIC alone, this counts the search over the placements; like
/// it, it can take a real effect of the family whose best placement fits slightly better
/// (the two shares are then close). A one-sided test of the family at α is not enough: it
/// keeps clear steps as aging. `salt` picks the replicates' stream.
pub(super) fn instead(on: &Against<'_>, i: usize, pl: &Placements, salt: u64) -> Option<Preferred> {
    let (prep, opts) = (on.prep, on.opts);
    let (ar, s, points) = (on.scanned.whitener, on.scanned.scan, on.scanned.points);
    let f = points[i].family;
    let yw = s.basis.residual(&ar.whiten(&prep.y_b));
    let (k, height_dph, shape_dbic) = pl.best(&yw, s.n, s.rss0)?;
    let t_obs = shape_dbic - s.dbic[i];
    if t_obs >= 0.0 {
        return None;
    }
    let grid: Vec<usize> = (0..points.len())
        .filter(|&j| points[j].family == f)
        .collect();
    let reps = opts.bootstrap.max(1);
    let sims: Vec<Vec<f64>> = (0..reps)
        .into_par_iter()
        .map(|r| {
            simulate_block_means_levelled(
                on.gyro,
                on.white_level,
                prep.nb(),
                prep.block as f64 * prep.dt_s,
                &mut replicate_rng(opts.seed ^ salt, r as u64),
                (opts.seed ^ salt).wrapping_add(r as u64 + 1),
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
                pl.best(&e, s.n, rss0).map_or(f64::INFINITY, |b| b.2) - df
            })
            .collect()
    };
    let share = |v: Vec<f64>, extreme: &dyn Fn(f64) -> bool| {
        (1 + v.into_iter().filter(|t| extreme(*t)).count()) as f64 / (reps + 1) as f64
    };
    let p_family = share(stats(&combine(&s.cperp[i], &s.coef[i], s.n)), &|t| {
        t <= t_obs
    });
    let effect: Vec<f64> = pl.cols[k].iter().map(|c| c * height_dph).collect();
    let p_shape = share(stats(&effect), &|t| t >= t_obs);
    (p_family < p_shape).then_some(Preferred {
        index: k,
        height_dph,
        delta_bic: shape_dbic,
        p_family,
        p_shape,
    })
}

/// Whitened step columns at every tried time, orthogonal to the baseline.
pub(super) struct StepScan {
    blocks: Vec<usize>,
    placements: Placements,
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
        Some(Self {
            placements: Placements::new(ar, s, &raw, 2),
            blocks,
        })
    }
}

/// `Some(step)` when the family of the scan's point `i` is aging or a periodic term and the
/// record is better explained by a single step than by that family ([`instead`], the step's
/// time searched over [`STEP_TIMES`] blocks). Warm-up is not put to it: an early step is
/// what its decay from power-on looks like, and the step would take real warm-ups. The step
/// columns are made once per pass, in `cached`.
pub(super) fn step_instead(
    on: &Against<'_>,
    i: usize,
    cached: &mut Option<Option<StepScan>>,
) -> Option<Step> {
    let scanned = on.scanned;
    if !matches!(scanned.points[i].family, Family::Aging | Family::Periodic) {
        return None;
    }
    let sc = cached
        .get_or_insert_with(|| StepScan::new(scanned.whitener, scanned.scan, on.prep.nb()))
        .as_ref()?;
    let p = instead(on, i, &sc.placements, STEP_SEED)?;
    Some(Step {
        block: sc.blocks[p.index],
        height_dph: p.height_dph,
        delta_bic: p.delta_bic,
        p_family: p.p_family,
        p_step: p.p_shape,
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
