//! Held-out scoring: interleaved cross-validation of the 100 s means over 1 h chunks, the
//! model columns of a baseline with or without a candidate, and the ΔBIC every test uses.

use super::candidates::{node_lag, Family};
use super::linalg::Basis;
use super::prepare::{
    baseline_specs, baseline_values, model_drive, DriveSeries, PhysicsModel, Prepared,
};
use super::{DiagnoseError, Figures};
use rlg_eval::metrics::{bias_stability_dph, rms};
use rlg_physics::Term;
use std::borrow::Cow;

/// Held-out folds: 1 h chunks of 100 s means, interleaved over this many folds, so every
/// fold samples every part of the run (warm-up, ramps, holds) and none is extrapolated
/// ([`fold_of`]).
pub(super) const FOLDS: usize = 4;
/// Blocks per chunk (1 h of 100 s blocks).
pub(super) const CHUNK_BLOCKS: usize = 36;

/// Held-out result of one model.
#[derive(Clone, Debug, PartialEq)]
pub struct HeldOut {
    /// Figures of merit.
    pub figures: Figures,
    /// Held-out sum of squares of the 100 s means, (°/h)².
    pub rss_b: f64,
}

/// The temperature cycle of each block (`rlg_io::cycles`), when the record has at least two.
pub(super) fn cycle_folds(prep: &Prepared) -> Option<Vec<usize>> {
    let spans = rlg_io::cycles::cycle_spans(&prep.t_b, &prep.temp_b);
    (spans.len() >= 2).then(|| {
        prep.t_b
            .iter()
            .map(|t| {
                spans
                    .iter()
                    .position(|s| *t < s.1)
                    .unwrap_or(spans.len() - 1)
            })
            .collect()
    })
}

/// Held-out sum of squares of the 100 s means when each temperature cycle is predicted
/// from the others (`fold`: the cycle of each block), with `extra` added to `model` or not.
pub(super) fn cycle_rss(
    prep: &Prepared,
    model: &PhysicsModel,
    extra: Option<&Term>,
    fold: &[usize],
) -> Result<f64, DiagnoseError> {
    let mdrive = model_drive(model, prep)?;
    let ex = extra.and_then(nonlinear_of);
    let cols = ModelColumns::new(
        prep,
        model,
        &mdrive,
        ex.as_ref().map(|(f, nl)| (*f, &nl[..])),
    )?;
    Ok(fold_fits(prep, &cols.blocks()?, fold).1)
}

/// Least-squares fits of the 100 s means with each fold of `fold` held out: the
/// coefficients of each fold (None where nothing is held out) and the held-out sum of
/// squares.
fn fold_fits(prep: &Prepared, cols_b: &[Vec<f64>], fold: &[usize]) -> (Vec<Option<Vec<f64>>>, f64) {
    let nb = prep.nb();
    let folds = fold.iter().max().map_or(0, |m| m + 1);
    let mut rss = 0.0;
    let betas = (0..folds)
        .map(|f| {
            let train: Vec<usize> = (0..nb).filter(|&b| fold[b] != f).collect();
            if train.len() == nb {
                return None;
            }
            let tc: Vec<Vec<f64>> = cols_b
                .iter()
                .map(|c| train.iter().map(|&b| c[b]).collect())
                .collect();
            let ty: Vec<f64> = train.iter().map(|&b| prep.y_b[b]).collect();
            let beta = Basis::new(&tc).coefficients(&ty);
            for b in (0..nb).filter(|&b| fold[b] == f) {
                let pred: f64 = cols_b.iter().zip(&beta).map(|(c, w)| c[b] * w).sum();
                rss += (prep.y_b[b] - pred).powi(2);
            }
            Some(beta)
        })
        .collect();
    (betas, rss)
}

/// Cross-validation of the 100 s means with the given fold of each block, and the figures
/// of the held-out 1 Hz residual. The per-sample columns are made twice, once for their
/// block means and once for the held-out prediction, one at a time: a month's record then
/// holds one 20 MB column instead of all of them (about 165 MB less at the check, heaptrack),
/// and the 30-day diagnosis' CPU time is unchanged (79 s).
fn cross_validate_by(
    prep: &Prepared,
    cols: &ModelColumns<'_>,
    nonlinear: usize,
    fold: &[usize],
) -> Result<HeldOut, DiagnoseError> {
    let cols_b = cols.blocks()?;
    let k = cols_b.len() + nonlinear;
    let (betas, rss) = fold_fits(prep, &cols_b, fold);
    drop(cols_b);
    let mut fit1 = vec![0.0; prep.rate_dph.len()];
    let mut j = 0;
    cols.for_each(|c| {
        for (b, f) in fold.iter().enumerate() {
            if let Some(w) = betas[*f].as_ref().map(|beta| beta[j]) {
                let r = b * prep.block..(b + 1) * prep.block;
                fit1[r.clone()]
                    .iter_mut()
                    .zip(&c[r])
                    .for_each(|(o, v)| *o += v * w);
            }
        }
        j += 1;
    })?;
    let resid1: Vec<f64> = prep
        .rate_dph
        .iter()
        .zip(&fit1)
        .map(|(a, p)| a - p)
        .collect();
    drop(fit1);
    let n = prep.nb() as f64;
    Ok(HeldOut {
        figures: Figures {
            rms_dph: rms(&resid1).unwrap_or(0.0),
            // 100 s windows whatever the block length of a long record.
            b100_dph: bias_stability_dph(
                &resid1,
                (super::prepare::BLOCK_S / prep.dt_s).round().max(1.0) as usize,
            )
            .unwrap_or(0.0),
            bic: n * (rss / n).max(1e-300).ln() + k as f64 * n.ln(),
        },
        rss_b: rss,
    })
}

/// The non-linear parameters of a library term as the candidate family scans them.
pub(super) fn nonlinear_of(term: &Term) -> Option<(Family, Vec<f64>)> {
    Some(match term {
        Term::SensorLag { tau_s } => (Family::SensorLag, vec![*tau_s]),
        Term::GradientLag { tau_s, .. } => (Family::GradientLag, vec![*tau_s]),
        Term::Hysteresis {
            width_c,
            node_lag_s,
            ..
        } => (Family::Hysteresis, vec![*width_c, *node_lag_s]),
        Term::Warmup { tau_s, .. } => (Family::Warmup, vec![*tau_s]),
        Term::ModeHop {
            temp_c,
            hysteresis_c,
            node_lag_s,
            ..
        } => (Family::ModeHop, vec![*temp_c, *hysteresis_c, *node_lag_s]),
        Term::Backscatter {
            period_c,
            node_lag_s,
            ..
        } => (Family::Backscatter, vec![*period_c, *node_lag_s]),
        Term::Periodic { period_s, .. } => (Family::Periodic, vec![*period_s]),
        Term::Aging { .. } => (Family::Aging, vec![]),
        Term::TempQuantization { step_c } => (Family::TempQuantization, vec![*step_c]),
        _ => return None,
    })
}

/// The per-sample columns of the baseline plus a candidate at non-linear parameters `nl`
/// (a sensor lag or a temperature quantum changes the baseline's drive instead of adding a
/// column), made on demand one at a time.
pub(super) struct ModelColumns<'a> {
    prep: &'a Prepared,
    model: &'a PhysicsModel,
    mdrive: &'a DriveSeries,
    /// The baseline's drive: `mdrive`, or a candidate's changed drive.
    drive: Cow<'a, DriveSeries>,
    /// A candidate that adds columns.
    extra: Option<(Family, Vec<f64>)>,
}

impl<'a> ModelColumns<'a> {
    pub(super) fn new(
        prep: &'a Prepared,
        model: &'a PhysicsModel,
        mdrive: &'a DriveSeries,
        extra: Option<(Family, &[f64])>,
    ) -> Result<Self, DiagnoseError> {
        let (drive, extra) = match extra {
            None => (Cow::Borrowed(mdrive), None),
            Some((Family::SensorLag, nl)) => (Cow::Owned(prep.drive_unlagged(nl[0])?), None),
            Some((Family::TempQuantization, nl)) => {
                (Cow::Owned(prep.drive_dequantised(nl[0])?), None)
            }
            Some((f, nl)) => (Cow::Borrowed(mdrive), Some((f, nl.to_vec()))),
        };
        Ok(Self {
            prep,
            model,
            mdrive,
            drive,
            extra,
        })
    }

    /// Calls `each` with every column in order: the baseline's, then the candidate's.
    pub(super) fn for_each(&self, mut each: impl FnMut(&[f64])) -> Result<(), DiagnoseError> {
        for (_, unit) in baseline_specs(self.model) {
            each(&baseline_values(unit.as_ref(), &self.drive));
        }
        if let Some((f, nl)) = &self.extra {
            for c in f.columns(nl, self.prep, self.model, self.mdrive, &[])? {
                each(&c);
            }
        }
        Ok(())
    }

    /// The block means of every column.
    pub(super) fn blocks(&self) -> Result<Vec<Vec<f64>>, DiagnoseError> {
        let mut out = Vec::new();
        self.for_each(|c| out.push(self.prep.blocks(c)))?;
        Ok(out)
    }
}

/// Held-out figures of `model` alone or with `extra` added (its non-linear parameters fixed,
/// its amplitude fitted), by 4-fold interleaved cross-validation on the recording. The
/// benchmark calls this with the true hidden term to obtain the true model's gain. A
/// `heteroscedastic` term does not change the mean: its check is `variance::heldout_variance`.
pub fn heldout_metrics(
    prep: &Prepared,
    model: &PhysicsModel,
    extra: Option<&Term>,
) -> Result<HeldOut, DiagnoseError> {
    heldout_on(prep, model, extra, &interleaved(prep.nb(), CHUNK_BLOCKS))
}

/// [`heldout_metrics`] on the folds `fold` (the fold of each block).
fn heldout_on(
    prep: &Prepared,
    model: &PhysicsModel,
    extra: Option<&Term>,
    fold: &[usize],
) -> Result<HeldOut, DiagnoseError> {
    let mdrive = model_drive(model, prep)?;
    let ex = extra.and_then(nonlinear_of);
    let cols = ModelColumns::new(
        prep,
        model,
        &mdrive,
        ex.as_ref().map(|(f, nl)| (*f, &nl[..])),
    )?;
    // BIC's parameter count: the columns and a candidate's non-linear parameters.
    let nonlinear = ex.as_ref().map_or(0, |(f, nl)| {
        f.n_params().saturating_sub(1) + usize::from(node_lag(*f, nl) != 0.0)
    });
    cross_validate_by(prep, &cols, nonlinear, fold)
}

/// Fold of each block: chunks of `chunk` blocks dealt to the [`FOLDS`] folds
/// ([`fold_of`]).
fn interleaved(nb: usize, chunk: usize) -> Vec<usize> {
    (0..nb).map(|b| fold_of(b, chunk)).collect()
}

/// The fold of block `b` in chunks of `chunk` blocks: each run of [`FOLDS`] consecutive
/// chunks goes one to each fold, in an order of its own (a fixed pseudo-random permutation
/// per run). *Why not in turn:* dealt in turn, the folds repeat every `FOLDS` chunks, and a
/// chamber programme of the same cycle (a 3 h hold and a 1 h ramp, with 1 h chunks) puts
/// every ramp in one fold: the others then have none to fit the rate terms and a term of
/// the ramps from, and a real effect of the ramps (a backscatter ripple crossed on each)
/// came out worse than nothing held out. Every run still gives each fold one chunk, so each
/// fold samples every part of the record.
pub(super) fn fold_of(b: usize, chunk: usize) -> usize {
    let c = b / chunk.max(1);
    let run = (c / FOLDS) as u64;
    // SplitMix64's finaliser: a fixed, well-mixed order per run (no state, no seed).
    let mut z = run.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    // The permutation numbered z mod FOLDS! (Lehmer code), applied to the chunk's place.
    let mut left: Vec<usize> = (0..FOLDS).collect();
    let mut code = z % (1..=FOLDS as u64).product::<u64>();
    let mut order = Vec::with_capacity(FOLDS);
    for k in (1..=FOLDS).rev() {
        let f: u64 = (1..k as u64).product();
        order.push(left.remove((code / f) as usize));
        code %= f;
    }
    order[c % FOLDS]
}

/// The held-out gain of a warm-up (the model's held-out sum of squares less the model's with
/// `warmup` added) on chunks of half its time constant instead of an hour. A warm-up lives in
/// its first few τ: with τ under an hour the first 1 h chunk holds nearly all of it, and with
/// that chunk held out the other folds cannot fit its amplitude, so the 1 h check calls real
/// warm-ups of τ under an hour worse than nothing (a negative held-out gain). Shorter chunks
/// deal the warm-up to every fold.
pub(super) fn warmup_heldout_gain(
    prep: &Prepared,
    model: &PhysicsModel,
    warmup: &Term,
    tau_s: f64,
) -> Result<f64, DiagnoseError> {
    let block_s = prep.block as f64 * prep.dt_s;
    let chunk = ((0.5 * tau_s / block_s).round() as usize).clamp(1, CHUNK_BLOCKS);
    let fold = interleaved(prep.nb(), chunk);
    Ok(heldout_on(prep, model, None, &fold)?.rss_b
        - heldout_on(prep, model, Some(warmup), &fold)?.rss_b)
}

pub(super) fn delta_bic(n: usize, rss0: f64, drss: f64, k: usize) -> f64 {
    let n = n as f64;
    n * ((rss0 - drss).max(1e-300 * rss0) / rss0).ln() + k as f64 * n.ln()
}
