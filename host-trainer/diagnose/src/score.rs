//! Held-out scoring: interleaved cross-validation of the 100 s means over 1 h chunks, the
//! model columns of a baseline with or without a candidate, and the ΔBIC every test uses.

use super::candidates::Family;
use super::linalg::Basis;
use super::prepare::{baseline_columns, model_drive, DriveSeries, PhysicsModel, Prepared};
use super::{DiagnoseError, Figures};
use rlg_eval::metrics::{bias_stability_dph, rms};
use rlg_physics::Term;

/// Held-out folds: 1 h chunks of 100 s means, interleaved over this many folds, so every
/// fold samples every part of the run (warm-up, ramps, holds) and none is extrapolated.
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

pub(super) fn cross_validate(prep: &Prepared, cols1: &[Vec<f64>], k: usize) -> HeldOut {
    let fold: Vec<usize> = (0..prep.nb()).map(|b| (b / CHUNK_BLOCKS) % FOLDS).collect();
    cross_validate_by(prep, cols1, k, &fold)
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
    let cols = model_columns(
        prep,
        model,
        &mdrive,
        ex.as_ref().map(|(f, nl)| (*f, &nl[..])),
    )?;
    Ok(cross_validate_by(prep, &cols, cols.len(), fold).rss_b)
}

/// Cross-validation of the 100 s means with the given fold of each block.
fn cross_validate_by(prep: &Prepared, cols1: &[Vec<f64>], k: usize, fold: &[usize]) -> HeldOut {
    let cols_b: Vec<Vec<f64>> = cols1.iter().map(|c| prep.blocks(c)).collect();
    let nb = prep.nb();
    let folds = fold.iter().max().map_or(0, |m| m + 1);
    let mut resid1 = vec![0.0; prep.rate_dph.len()];
    let mut rss = 0.0;
    for f in 0..folds {
        let train: Vec<usize> = (0..nb).filter(|&b| fold[b] != f).collect();
        if train.len() == nb {
            continue;
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
            for i in b * prep.block..(b + 1) * prep.block {
                let p: f64 = cols1.iter().zip(&beta).map(|(c, w)| c[i] * w).sum();
                resid1[i] = prep.rate_dph[i] - p;
            }
        }
    }
    let n = nb as f64;
    HeldOut {
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
    }
}

/// The non-linear parameters of a library term as the candidate family scans them.
pub(super) fn nonlinear_of(term: &Term) -> Option<(Family, Vec<f64>)> {
    Some(match term {
        Term::SensorLag { tau_s } => (Family::SensorLag, vec![*tau_s]),
        Term::GradientLag { tau_s, .. } => (Family::GradientLag, vec![*tau_s]),
        Term::Hysteresis { width_c, .. } => (Family::Hysteresis, vec![*width_c]),
        Term::Warmup { tau_s, .. } => (Family::Warmup, vec![*tau_s]),
        Term::ModeHop {
            temp_c,
            hysteresis_c,
            ..
        } => (Family::ModeHop, vec![*temp_c, *hysteresis_c]),
        Term::Backscatter { period_c, .. } => (Family::Backscatter, vec![*period_c]),
        Term::Periodic { period_s, .. } => (Family::Periodic, vec![*period_s]),
        Term::Aging { .. } => (Family::Aging, vec![]),
        Term::TempQuantization { step_c } => (Family::TempQuantization, vec![*step_c]),
        _ => return None,
    })
}

/// Columns (per sample) of the baseline plus a candidate at non-linear parameters `nl`;
/// a sensor lag replaces the baseline's drive instead of adding a column.
pub(super) fn model_columns(
    prep: &Prepared,
    model: &PhysicsModel,
    mdrive: &DriveSeries,
    extra: Option<(Family, &[f64])>,
) -> Result<Vec<Vec<f64>>, DiagnoseError> {
    let vals = |d: &DriveSeries| -> Vec<Vec<f64>> {
        baseline_columns(model, d)
            .into_iter()
            .map(|c| c.values)
            .collect()
    };
    Ok(match extra {
        None => vals(mdrive),
        Some((Family::SensorLag, nl)) => vals(&prep.drive_unlagged(nl[0])?),
        Some((Family::TempQuantization, nl)) => vals(&prep.drive_dequantised(nl[0])?),
        Some((f, nl)) => {
            let mut c = vals(mdrive);
            c.extend(f.columns(nl, prep, model, mdrive, &[])?);
            c
        }
    })
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
    let mdrive = model_drive(model, prep)?;
    let ex = extra.and_then(nonlinear_of);
    let cols = model_columns(
        prep,
        model,
        &mdrive,
        ex.as_ref().map(|(f, nl)| (*f, &nl[..])),
    )?;
    let k = cols.len() + ex.map_or(0, |(f, _)| f.n_params().saturating_sub(1));
    Ok(cross_validate(prep, &cols, k))
}

pub(super) fn delta_bic(n: usize, rss0: f64, drss: f64, k: usize) -> f64 {
    let n = n as f64;
    n * ((rss0 - drss).max(1e-300 * rss0) / rss0).ln() + k as f64 * n.ln()
}
