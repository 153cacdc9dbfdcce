//! Cross-validation shared by every model of a calibration: the folds (whole cycles, or
//! blocked within one), out-of-fold RMS, the polynomial's degree, even pooling.

use rlg_eval::baselines::PolyFit;
use rlg_train::dataset::Dataset;
use rlg_train::lssvm::tune::{fold_indices, Validation, PARSIMONY};

use crate::error::{ensure, CalibrateError};
use crate::options::{MAX_FOLDS, MAX_POLY_DEGREE};

pub(crate) fn col(x: &[Vec<f64>], d: usize) -> Vec<f64> {
    x.iter().map(|r| r[d]).collect()
}

/// CV RMS of a model fitted by `fit` (training indices → predictions at held-out indices).
pub(crate) fn cv_rms(
    folds: &[Vec<usize>],
    n: usize,
    y: &[f64],
    fit: impl Fn(&[usize], &[usize]) -> Option<Vec<f64>>,
) -> Option<f64> {
    cv_rms_many(folds, n, y, 1, |tr, te| vec![fit(tr, te)])[0]
}

/// [`cv_rms`] of `k` models fitted together per fold (`fit` gives each model's held-out
/// predictions, `None` where it failed): the same sums, model by model.
pub(crate) fn cv_rms_many(
    folds: &[Vec<usize>],
    n: usize,
    y: &[f64],
    k: usize,
    fit: impl Fn(&[usize], &[usize]) -> Vec<Option<Vec<f64>>>,
) -> Vec<Option<f64>> {
    let mut ss = vec![Some(0.0); k];
    let mut count = 0usize;
    for f in folds {
        let mut out = vec![false; n];
        for &i in f {
            out[i] = true;
        }
        let train: Vec<usize> = (0..n).filter(|&i| !out[i]).collect();
        let preds = fit(&train, f);
        for (s, pred) in ss.iter_mut().zip(&preds) {
            *s = match (*s, pred) {
                (Some(mut acc), Some(pred)) => {
                    for (p, &i) in pred.iter().zip(f) {
                        acc += (y[i] - p).powi(2);
                    }
                    Some(acc)
                }
                _ => None,
            };
        }
        count += f.len();
    }
    ss.into_iter()
        .map(|s| s.filter(|_| count > 0).map(|s| (s / count as f64).sqrt()))
        .collect()
}

pub(crate) fn poly_of(x: &[f64], y: &[f64], idx: &[usize], degree: usize) -> Option<PolyFit> {
    let xs: Vec<f64> = idx.iter().map(|&i| x[i]).collect();
    let ys: Vec<f64> = idx.iter().map(|&i| y[i]).collect();
    PolyFit::fit(&xs, &ys, degree).ok()
}

/// CV RMS of a polynomial in `t` of each degree 1 … [`MAX_POLY_DEGREE`] on `folds`, °/h (NaN
/// where a fold cannot be fitted).
pub(crate) fn poly_cv_dph(folds: &[Vec<usize>], t: &[f64], y: &[f64]) -> Vec<f64> {
    (1..=MAX_POLY_DEGREE)
        .map(|d| {
            cv_rms(folds, t.len(), y, |tr, te| {
                let p = poly_of(t, y, tr, d)?;
                Some(te.iter().map(|&i| p.predict(t[i])).collect())
            })
            .unwrap_or(f64::NAN)
        })
        .collect()
}

/// The polynomial's degree from its CV curve (`cv[d − 1]` for degree d): the lowest within
/// [`PARSIMONY`] of the best.
pub(crate) fn poly_degree(cv: &[f64]) -> Result<usize, CalibrateError> {
    let best = cv
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(f64::INFINITY, f64::min);
    ensure!(
        best.is_finite(),
        Input,
        "no polynomial in T could be fitted"
    );
    Ok(1 + cv
        .iter()
        .position(|v| *v <= best * (1.0 + PARSIMONY))
        .unwrap_or(0))
}

/// The CV scheme of the tuning means from the cycle each starts in (`labels`): leave one cycle
/// out when they span two or more, else blocked CV ([`rlg_train::protocol::CV`]); with the
/// number of groups (1 for blocked).
pub(crate) fn validation_of(
    labels: &[usize],
    block_s: usize,
) -> Result<(Validation, usize), CalibrateError> {
    let n_tune = labels.len();
    let mut distinct = labels.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    let out = if distinct.len() > MAX_FOLDS {
        // Many cycles: runs of consecutive whole cycles form MAX_FOLDS groups, so the cost
        // stays that of MAX_FOLDS fits per grid point and no cycle is split.
        let g = distinct.len();
        let grouped: Vec<usize> = labels
            .iter()
            .map(|l| distinct.partition_point(|d| d < l) * MAX_FOLDS / g)
            .collect();
        (Validation::Groups(grouped), MAX_FOLDS)
    } else if distinct.len() >= 2 {
        (Validation::Groups(labels.to_vec()), distinct.len())
    } else {
        (blocked_within_a_cycle(n_tune, block_s), 1)
    };
    ensure!(
        fold_indices(&out.0, n_tune).is_ok(),
        Input,
        "the training span holds {n_tune} training means of {block_s} s; tuning needs at least \
         {} (give a shorter --block, or a longer recording)",
        MIN_RUNS * 5
    );
    Ok(out)
}

/// Fewest means a run of blocked CV holds.
const MIN_RUNS: usize = 10;
/// A run of blocked CV lasts this long at least, s: longer than the slow noise neighbouring
/// means share ([`CV`]: 10 means of 100 s).
const RUN_S: usize = 1000;

/// Blocked CV within one training cycle for means of `block_s` s: 5 folds of interleaved runs
/// of [`RUN_S`] (at least [`MIN_RUNS`] means), shorter runs when the span holds fewer than
/// ten of them. Means of 100 s give [`CV`], the reproduction's choice.
pub fn blocked_within_a_cycle(n: usize, block_s: usize) -> Validation {
    let run = RUN_S.div_ceil(block_s.max(1)).max(MIN_RUNS);
    let run = run.min(n / 10).max(MIN_RUNS.min(n / 5).max(1));
    Validation::Blocked {
        block: run,
        folds: 5,
    }
}

/// Pools training means into cells of one cycle, 1 °C of T and a tenth of the largest
/// |dT/dt|, each cell one mean (`--even-temperature`): a slow stretch of an uneven ramp then
/// weighs as much as a fast one at the same temperature and rate, instead of as many times
/// more as it has means. Returns the pooled set and each cell's cycle, in (cycle, T, dT/dt)
/// order.
pub fn pool_even(d: &Dataset, labels: &[usize]) -> (Dataset, Vec<usize>) {
    use std::collections::BTreeMap;
    let rate_step = 0.1
        * d.x
            .iter()
            .map(|r| r[1].abs())
            .fold(0.0, f64::max)
            .max(1e-12);
    // (cycle, T bin, dT/dt bin) → (sum of x, sum of y, count).
    type Cell = (Vec<f64>, f64, usize);
    let mut cells: BTreeMap<(usize, i64, i64), Cell> = BTreeMap::new();
    for ((x, y), &g) in d.x.iter().zip(&d.y_dph).zip(labels) {
        let key = (g, x[0].floor() as i64, (x[1] / rate_step).round() as i64);
        let e = cells
            .entry(key)
            .or_insert_with(|| (vec![0.0; x.len()], 0.0, 0));
        for (s, v) in e.0.iter_mut().zip(x) {
            *s += v;
        }
        e.1 += y;
        e.2 += 1;
    }
    let mut out = Dataset {
        features: d.features.clone(),
        x: Vec::with_capacity(cells.len()),
        y_dph: Vec::with_capacity(cells.len()),
        dt_s: d.dt_s,
    };
    let mut groups = Vec::with_capacity(cells.len());
    for ((g, _, _), (sx, sy, n)) in cells {
        let k = n as f64;
        out.x.push(sx.iter().map(|v| v / k).collect());
        out.y_dph.push(sy / k);
        groups.push(g);
    }
    (out, groups)
}
