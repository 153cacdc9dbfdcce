//! Automatic choice of the kernel width σ and the regularisation c of an exact LS-SVM by
//! cross-validation over a logarithmic grid with local refinement.
//!
//! Two validation schemes, for two kinds of data:
//! * [`Validation::LeaveOneOut`]: the closed-form leave-one-out residuals of LS-SVM (PRESS,
//!   [`super::solve::solve_with_loo`]); exact and cheap, but right only for independent
//!   samples such as the static test's temperature points.
//! * [`Validation::Blocked`] and [`Validation::Groups`]: for time series, whose neighbouring
//!   samples share slow noise (a left-out 100 s mean is predicted from its neighbours, which
//!   flatters small σ). Blocked CV leaves out interleaved runs of contiguous samples; group CV
//!   leaves out one labelled group at a time (e.g. one temperature cycle).
//!
//! The score is the RMS of the out-of-fold residuals (°/h). The coarse grid σ × c is evaluated
//! in parallel (rayon, one task per point); then `refine` rounds each evaluate the 3 × 3 grid
//! at half the previous log step around the best point so far (inside the grid's range).
//! The choice is the most regularised point (smallest c, then widest σ) whose score is within
//! [`PARSIMONY`] (1 %) of the best: near its minimum the CV curve is flat, and the smaller c
//! keeps the coefficients the board sums in f32 small.
//!
//! The standardisation is fitted once on all inputs and shared by the folds: it uses the
//! inputs' spread, never the targets, so no target information leaks into a fold.

use indicatif::ProgressBar;
use rayon::prelude::*;

use super::kernel::gauss_rows;
use super::{solve, LssvmError};

/// How the out-of-sample error of a (σ, c) is estimated.
#[derive(Clone, Debug, PartialEq)]
pub enum Validation {
    /// Closed-form leave-one-out residuals (PRESS): independent samples.
    LeaveOneOut,
    /// `folds` folds of interleaved blocks: sample i belongs to fold (i / `block`) mod `folds`.
    Blocked {
        /// Contiguous samples per block.
        block: usize,
        /// Number of folds (≥ 2).
        folds: usize,
    },
    /// `folds` contiguous runs of samples, each left out in turn: the model must predict a
    /// stretch of time it has not seen, as a held-out later cycle asks of it.
    Contiguous {
        /// Number of folds (≥ 2).
        folds: usize,
    },
    /// Leave one group out: `groups[i]` labels sample i (e.g. its temperature cycle).
    Groups(Vec<usize>),
}

impl Validation {
    /// A one-line description for reports.
    pub fn describe(&self) -> String {
        match self {
            Validation::LeaveOneOut => "closed-form leave-one-out (PRESS)".to_string(),
            Validation::Blocked { block, folds } => {
                format!("blocked {folds}-fold CV, blocks of {block} consecutive samples")
            }
            Validation::Contiguous { folds } => {
                format!("contiguous {folds}-fold CV (each fold one stretch of time)")
            }
            Validation::Groups(g) => {
                let mut u = g.clone();
                u.sort_unstable();
                u.dedup();
                format!("leave-one-group-out CV over {} groups", u.len())
            }
        }
    }
}

/// The choice is the most regularised point whose CV RMS is within this fraction of the
/// best one's (see [`tune`]).
pub const PARSIMONY: f64 = 0.01;

/// A logarithmic search grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Smallest and largest σ (standardised units) of the coarse grid.
    pub sigma: (f64, f64),
    /// Points of σ on the coarse grid (≥ 2).
    pub sigma_points: usize,
    /// Smallest and largest c of the coarse grid.
    pub c: (f64, f64),
    /// Points of c on the coarse grid (≥ 2).
    pub c_points: usize,
    /// Rounds of local refinement (each halves the log step).
    pub refine: usize,
}

impl Default for Grid {
    /// σ from 0.05 to 5 (standardised units: a twentieth of a standard deviation to far
    /// wider than the data), c from 0.1 to 1e5, 9 × 7 points, 3 refinements.
    fn default() -> Self {
        Grid {
            sigma: (0.05, 5.0),
            sigma_points: 9,
            c: (0.1, 1e5),
            c_points: 7,
            refine: 3,
        }
    }
}

/// One evaluated (σ, c).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CvPoint {
    /// Kernel width σ, standardised units.
    pub sigma: f64,
    /// Regularisation c.
    pub c: f64,
    /// RMS of the out-of-fold residuals, °/h; NaN where a fold could not be trained.
    pub cv_rms_dph: f64,
}

/// The chosen hyper-parameters and the evidence for them.
#[derive(Clone, Debug, PartialEq)]
pub struct Tuned {
    /// Chosen σ.
    pub sigma: f64,
    /// Chosen c.
    pub c: f64,
    /// Its cross-validated RMS, °/h.
    pub cv_rms_dph: f64,
    /// The coarse grid, σ outer, c inner (the CV curve).
    pub curve: Vec<CvPoint>,
    /// Points evaluated during refinement, in order.
    pub refined: Vec<CvPoint>,
    /// What the score is.
    pub validation: String,
}

/// Why tuning failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TuneError {
    /// The data or a fold could not be set up.
    #[error(transparent)]
    Lssvm(#[from] LssvmError),
    /// The grid or the validation scheme is unusable.
    #[error("invalid tuning setup: {0}")]
    Setup(String),
    /// No grid point could be trained on every fold.
    #[error("no (sigma, c) of the grid could be trained on every fold")]
    NothingTrained,
}

/// `n` log-spaced values from `lo` to `hi` inclusive (`lo` alone for `n` = 1).
pub fn log_space(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let (a, b) = (lo.ln(), hi.ln());
    (0..n)
        .map(|i| (a + (b - a) * i as f64 / (n.max(2) - 1) as f64).exp())
        .collect()
}

/// The folds of `validation` over `n` samples, as lists of held-out sample indices (empty
/// for leave-one-out): for scoring another model on exactly the folds [`tune`] uses.
pub fn fold_indices(validation: &Validation, n: usize) -> Result<Vec<Vec<usize>>, TuneError> {
    match validation {
        Validation::LeaveOneOut => Ok(Vec::new()),
        Validation::Blocked { block, folds } => {
            if *block == 0 || *folds < 2 || n < block * folds {
                return Err(TuneError::Setup(format!(
                    "blocked CV needs block ≥ 1, folds ≥ 2 and at least block·folds = {} samples (have {n})",
                    block * folds
                )));
            }
            Ok((0..*folds)
                .map(|f| (0..n).filter(|i| (i / block) % folds == f).collect())
                .collect())
        }
        Validation::Contiguous { folds } => {
            if *folds < 2 || n < 2 * folds {
                return Err(TuneError::Setup(format!(
                    "contiguous CV needs folds ≥ 2 and at least two samples per fold (have {n} for {folds})"
                )));
            }
            Ok((0..*folds)
                .map(|f| (f * n / folds..(f + 1) * n / folds).collect())
                .collect())
        }
        Validation::Groups(g) => {
            if g.len() != n {
                return Err(TuneError::Setup(format!(
                    "{} group labels for {n} samples",
                    g.len()
                )));
            }
            let mut labels = g.clone();
            labels.sort_unstable();
            labels.dedup();
            if labels.len() < 2 {
                return Err(TuneError::Setup(
                    "leave-one-group-out CV needs at least two groups".to_string(),
                ));
            }
            Ok(labels
                .iter()
                .map(|l| (0..n).filter(|&i| g[i] == *l).collect())
                .collect())
        }
    }
}

/// Out-of-fold RMS at one (σ, c); NaN when any fold fails to train. `lin` are the linear
/// columns of a partially linear model (none: Eq. (9)).
fn score(
    z: &[Vec<f64>],
    lin: &[Vec<f64>],
    y: &[f64],
    folds: &[Vec<usize>],
    sigma: f64,
    c: f64,
) -> f64 {
    if folds.is_empty() {
        return solve::loo_residuals(z, y, sigma, c).map_or(f64::NAN, |r| {
            (r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64).sqrt()
        });
    }
    score_row(z, lin, y, folds, sigma, &[c])[0]
}

/// Largest training fold whose kernel fill is kept for the next c: the kept copy adds
/// 8·n² bytes to the solve's peak (128 MB here), so beyond it each c fills afresh.
const SHARED_FILL_MAX: usize = 4000;

/// Out-of-fold RMS at σ and each of `cs` (fold schemes only). The kernel part of a fold's
/// matrix and of its held-out predictions depends on σ alone, so each fold fills them once
/// and solves once per c (up to [`SHARED_FILL_MAX`] training rows): the same numbers as a
/// fill per (σ, c), with the exponentials of one fill instead of `cs.len()`.
fn score_row(
    z: &[Vec<f64>],
    lin: &[Vec<f64>],
    y: &[f64],
    folds: &[Vec<usize>],
    sigma: f64,
    cs: &[f64],
) -> Vec<f64> {
    // Folds in parallel; the squared residuals are then added in fold order, so the score
    // does not depend on how the work was split.
    // The folds' training matrices are principal submatrices of the whole set's: one fill
    // at σ serves every fold whose training part takes the packed path.
    let n = z.len();
    let packed =
        lin.is_empty() && sigma > 0.0 && folds.iter().any(|f| n - f.len() >= solve::MIXED_MIN_N);
    let full = packed.then(|| super::packed::PackedLower::gaussian(z, sigma, 1.0));
    let per_fold: Vec<Vec<Option<Vec<f64>>>> = folds
        .par_iter()
        .map(|fold| fold_residuals(z, lin, y, fold, (sigma, cs), full.as_ref()))
        .collect();
    let count: usize = folds.iter().map(Vec::len).sum();
    (0..cs.len())
        .map(|k| {
            let mut ss = 0.0;
            for f in &per_fold {
                let Some(r) = &f[k] else {
                    return f64::NAN;
                };
                for v in r {
                    ss += v;
                }
            }
            (ss / count as f64).sqrt()
        })
        .collect()
}

/// The squared held-out residuals of one fold at σ and each of `cs` (`None` where the fold
/// could not be trained), in the fold's order.
fn fold_residuals(
    z: &[Vec<f64>],
    lin: &[Vec<f64>],
    y: &[f64],
    fold: &[usize],
    (sigma, cs): (f64, &[f64]),
    full: Option<&super::packed::PackedLower>,
) -> Vec<Option<Vec<f64>>> {
    let n = z.len();
    let inv = 1.0 / (2.0 * sigma * sigma);
    let mut held = vec![false; n];
    fold.iter().for_each(|&i| held[i] = true);
    let keep: Vec<usize> = (0..n).filter(|&i| !held[i]).collect();
    let zt: Vec<Vec<f64>> = keep.iter().map(|&i| z[i].clone()).collect();
    let yt: Vec<f64> = keep.iter().map(|&i| y[i]).collect();
    let lt: Vec<Vec<f64>> = lin
        .iter()
        .map(|col| keep.iter().map(|&i| col[i]).collect())
        .collect();
    let nt = zt.len();
    let fill = full.map(|f| f.principal(&keep));
    let solutions = fold_solutions(&zt, &lt, &yt, (sigma, cs), fill);
    // Held-out row i's kernel values against the training rows, in training order.
    let mut k_out: Option<Vec<f64>> = None;
    solutions
        .into_iter()
        .map(|sol| {
            let sol = sol?;
            let ko = k_out.get_or_insert_with(|| {
                let flat: Vec<f64> = zt.iter().flatten().copied().collect();
                let dim = zt.first().map_or(0, Vec::len);
                let mut ko = vec![0.0; fold.len() * nt];
                for (r, &i) in fold.iter().enumerate() {
                    let row = &mut ko[r * nt..(r + 1) * nt];
                    match full {
                        // The same bits: an entry's two points enter only as (a − b)².
                        Some(f) => row
                            .iter_mut()
                            .zip(&keep)
                            .for_each(|(v, &t)| *v = f.entry(i, t)),
                        None => gauss_rows(&flat, dim, &z[i], inv, row),
                    }
                }
                ko
            });
            let r: Vec<f64> = fold
                .iter()
                .enumerate()
                .map(|(r, &i)| {
                    let f: f64 = ko[r * nt..(r + 1) * nt]
                        .iter()
                        .zip(&sol.solution.alpha)
                        .map(|(g, a)| a * g)
                        .sum::<f64>()
                        + sol.solution.bias
                        + lin
                            .iter()
                            .zip(&sol.beta)
                            .map(|(col, b)| b * col[i])
                            .sum::<f64>();
                    (y[i] - f).powi(2)
                })
                .collect();
            Some(r)
        })
        .collect()
}

/// The fold's model at σ and each of `cs` on its training rows `zt`, `lt`, `yt` (`None`
/// where it cannot be trained). Eq. (9) without linear columns from `MIXED_MIN_N` rows on:
/// `solve::solve_packed`'s paths on one packed fill per σ (`fill`, the kernel of `zt` when
/// the caller has it), all c at once; otherwise the dense partially linear solve, its kernel
/// filled once and kept for the next c.
fn fold_solutions(
    zt: &[Vec<f64>],
    lt: &[Vec<f64>],
    yt: &[f64],
    (sigma, cs): (f64, &[f64]),
    fill: Option<super::packed::PackedLower>,
) -> Vec<Option<solve::PartiallyLinear>> {
    let nt = zt.len();
    let valid: Vec<bool> = cs
        .iter()
        .map(|&c| {
            solve::validate(zt, yt, sigma, c).is_ok() && lt.iter().flatten().all(|v| v.is_finite())
        })
        .collect();
    if lt.is_empty() && nt >= solve::MIXED_MIN_N {
        let good: Vec<f64> = cs
            .iter()
            .zip(&valid)
            .filter(|(_, v)| **v)
            .map(|(c, _)| *c)
            .collect();
        let mut solved = match good.first() {
            Some(&c0) => {
                let mut packed =
                    fill.unwrap_or_else(|| super::packed::PackedLower::gaussian(zt, sigma, c0));
                solve::solve_packed_shifts(&mut packed, zt, yt, sigma, &good)
            }
            None => Vec::new(),
        }
        .into_iter();
        return valid
            .iter()
            .map(|&v| {
                let (solution, _) = v.then(|| solved.next())??.ok()?;
                Some(solve::PartiallyLinear {
                    solution,
                    beta: Vec::new(),
                })
            })
            .collect();
    }
    let mut kernel: Option<Vec<f64>> = None;
    cs.iter()
        .zip(&valid)
        .map(|(&c, &v)| {
            if !v {
                return None;
            }
            let mut h = match &kernel {
                Some(h) => h.clone(),
                None => {
                    let h = super::mixed::h_lower(zt, sigma, c);
                    if nt <= SHARED_FILL_MAX && cs.len() > 1 {
                        kernel = Some(h.clone());
                    }
                    h
                }
            };
            solve::set_h_diagonal(&mut h, nt, c);
            solve::partially_linear_on(&h, lt, yt).ok()
        })
        .collect()
}

/// The cross-validated RMS, °/h, of one (σ, c) of the (partially linear) model under
/// `validation`: the score [`tune`] ranks by, for a model chosen some other way.
pub fn cross_validate(
    features: &[String],
    x: &[Vec<f64>],
    y_dph: &[f64],
    linear: &[bool],
    validation: &Validation,
    sigma: f64,
    c: f64,
) -> Result<f64, TuneError> {
    let (_, z, lin) = super::partially_linear_design(features, x, y_dph, linear)?;
    let folds = fold_indices(validation, z.len())?;
    let v = score(&z, &lin, y_dph, &folds, sigma, c);
    if v.is_finite() {
        Ok(v)
    } else {
        Err(TuneError::NothingTrained)
    }
}

fn best(points: &[CvPoint]) -> Option<CvPoint> {
    points
        .iter()
        .filter(|p| p.cv_rms_dph.is_finite())
        .copied()
        .min_by(|a, b| a.cv_rms_dph.total_cmp(&b.cv_rms_dph))
}

fn evaluate(
    z: &[Vec<f64>],
    lin: &[Vec<f64>],
    y: &[f64],
    folds: &[Vec<usize>],
    pairs: &[(f64, f64)],
    progress: &ProgressBar,
) -> Vec<CvPoint> {
    if folds.is_empty() {
        return pairs
            .par_iter()
            .map(|&(sigma, c)| {
                let cv_rms_dph = score(z, lin, y, folds, sigma, c);
                progress.inc(1);
                CvPoint {
                    sigma,
                    c,
                    cv_rms_dph,
                }
            })
            .collect();
    }
    // One task per σ: its c values share the kernel fills (`score_row`).
    by_sigma(pairs, |sigma, cs| {
        let v = score_row(z, lin, y, folds, sigma, cs);
        progress.inc(cs.len() as u64);
        v
    })
    .into_iter()
    .zip(pairs)
    .map(|(cv_rms_dph, &(sigma, c))| CvPoint {
        sigma,
        c,
        cv_rms_dph,
    })
    .collect()
}

/// Evaluates `row(σ, cs)` (one value per c of `cs`) once per distinct σ of `pairs`, the σ in
/// parallel (rayon), and returns the values in the order of `pairs`: for scores whose work
/// at one σ is shared by its c values.
pub fn by_sigma<T: Clone + Send>(
    pairs: &[(f64, f64)],
    row: impl Fn(f64, &[f64]) -> Vec<T> + Sync,
) -> Vec<T> {
    let mut rows: Vec<(f64, Vec<f64>)> = Vec::new();
    let mut at = Vec::with_capacity(pairs.len());
    for &(sigma, c) in pairs {
        let r = match rows.iter().position(|r| r.0.to_bits() == sigma.to_bits()) {
            Some(r) => r,
            None => {
                rows.push((sigma, Vec::new()));
                rows.len() - 1
            }
        };
        rows[r].1.push(c);
        at.push((r, rows[r].1.len() - 1));
    }
    let values: Vec<Vec<T>> = rows.par_iter().map(|(s, cs)| row(*s, cs)).collect();
    at.iter().map(|&(r, k)| values[r][k].clone()).collect()
}

/// Chooses σ and c for an exact LS-SVM on raw inputs `x` (columns named by `features`) and
/// targets `y_dph` (°/h) by `validation` over `grid`. `progress` counts evaluated points
/// (pass `ProgressBar::hidden()` when nobody watches).
pub fn tune(
    features: &[String],
    x: &[Vec<f64>],
    y_dph: &[f64],
    validation: &Validation,
    grid: &Grid,
    progress: &ProgressBar,
) -> Result<Tuned, TuneError> {
    let linear = vec![false; features.len()];
    tune_partially_linear(features, x, y_dph, &linear, validation, grid, progress)
}

/// [`tune`] for the partially linear model of `Lssvm::train_partially_linear`: the features
/// with `linear[d]` set are linear terms, the rest kernel inputs. Leave-one-out is closed
/// form for the kernel model only; with linear terms use a fold scheme.
pub fn tune_partially_linear(
    features: &[String],
    x: &[Vec<f64>],
    y_dph: &[f64],
    linear: &[bool],
    validation: &Validation,
    grid: &Grid,
    progress: &ProgressBar,
) -> Result<Tuned, TuneError> {
    if linear.iter().any(|l| *l) && matches!(validation, Validation::LeaveOneOut) {
        return Err(TuneError::Setup(
            "closed-form leave-one-out is for the kernel model; give a fold scheme for linear terms"
                .to_string(),
        ));
    }
    let ok = |(lo, hi): (f64, f64)| lo > 0.0 && hi >= lo && hi.is_finite();
    if !(ok(grid.sigma) && ok(grid.c) && grid.sigma_points >= 2 && grid.c_points >= 2) {
        return Err(TuneError::Setup(format!(
            "grid needs 0 < lo ≤ hi < ∞ and ≥ 2 points per axis: sigma {:?} × {}, c {:?} × {}",
            grid.sigma, grid.sigma_points, grid.c, grid.c_points
        )));
    }
    if x.len() != y_dph.len() {
        return Err(LssvmError::Length {
            inputs: x.len(),
            targets: y_dph.len(),
        }
        .into());
    }
    if let Some(i) = y_dph.iter().position(|v| !v.is_finite()) {
        return Err(LssvmError::NonFinite {
            what: "target",
            index: i,
            feature: None,
        }
        .into());
    }
    let (_, z, lin) = super::partially_linear_design(features, x, y_dph, linear)?;
    let folds = fold_indices(validation, z.len())?;
    if matches!(validation, Validation::LeaveOneOut) && z.len() < 3 {
        return Err(TuneError::Setup(format!(
            "leave-one-out needs at least 3 samples (have {})",
            z.len()
        )));
    }
    let sigmas = log_space(grid.sigma.0, grid.sigma.1, grid.sigma_points);
    let cs = log_space(grid.c.0, grid.c.1, grid.c_points);
    let pairs: Vec<(f64, f64)> = sigmas
        .iter()
        .flat_map(|&s| cs.iter().map(move |&c| (s, c)))
        .collect();
    progress.set_length((pairs.len() + 9 * grid.refine) as u64);
    let curve = evaluate(&z, &lin, y_dph, &folds, &pairs, progress);
    let mut at = best(&curve).ok_or(TuneError::NothingTrained)?;
    // Log steps of the coarse grid; each refinement halves them.
    let mut ds = (grid.sigma.1 / grid.sigma.0).ln() / (grid.sigma_points - 1) as f64;
    let mut dc = (grid.c.1 / grid.c.0).ln() / (grid.c_points - 1) as f64;
    let mut refined = Vec::new();
    for _ in 0..grid.refine {
        ds /= 2.0;
        dc /= 2.0;
        let local: Vec<(f64, f64)> = [-1.0, 0.0, 1.0]
            .iter()
            .flat_map(|i| {
                [-1.0, 0.0, 1.0].iter().map(move |j| {
                    // Refinement stays inside the declared search range.
                    (
                        (at.sigma * (i * ds).exp()).clamp(grid.sigma.0, grid.sigma.1),
                        (at.c * (j * dc).exp()).clamp(grid.c.0, grid.c.1),
                    )
                })
            })
            .collect();
        let pts = evaluate(&z, &lin, y_dph, &folds, &local, progress);
        if let Some(b) = best(&pts) {
            if b.cv_rms_dph < at.cv_rms_dph {
                at = b;
            }
        }
        refined.extend(pts);
    }
    progress.finish_and_clear();
    // Among the points within `PARSIMONY` of the best, the most regularised (smallest c,
    // then widest σ): CV curves are flat near their minimum, and a smaller c keeps the
    // coefficients small, which the board's f32 sum needs (cancelling |a_i| of 1e4 lose
    // 1e-3 °/h there).
    let limit = at.cv_rms_dph * (1.0 + PARSIMONY);
    let chosen = curve
        .iter()
        .chain(&refined)
        .filter(|p| p.cv_rms_dph <= limit)
        .copied()
        .min_by(|a, b| a.c.total_cmp(&b.c).then(b.sigma.total_cmp(&a.sigma)))
        .unwrap_or(at);
    Ok(Tuned {
        sigma: chosen.sigma,
        c: chosen.c,
        cv_rms_dph: chosen.cv_rms_dph,
        curve,
        refined,
        validation: validation.describe(),
    })
}

#[cfg(test)]
mod tests;
