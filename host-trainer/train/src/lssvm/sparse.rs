//! Reduced LS-SVM models with at most a fixed number of support vectors, so that a model fits
//! the board's table of fixed capacity: one entry point, [`train_reduced`], over the two
//! methods of [`super::fixed_size`] and [`super::prune`].

use super::fixed_size::{
    self, select_active_set, solve_fixed_size, solve_on_active, FixedSizeOptions, Rows,
};
use super::prune::prune;
use super::{Lssvm, LssvmError};
use crate::features::RowSet;

/// Default support-vector budget: the board table's default capacity.
pub const DEFAULT_BUDGET: usize = 64;

/// How to reduce the model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reduction {
    /// Fixed-size LS-SVM: Rényi-entropy active set, Nyström map, primal solve. O(n·M) memory;
    /// the method for large training sets.
    FixedSize {
        /// Swap attempts of the active-set search.
        trials: usize,
        /// Seed of the active-set search.
        seed: u64,
    },
    /// Iterative pruning of the smallest |a| with an exact re-solve per round (n ≤
    /// [`super::prune::MAX_PRUNE_SAMPLES`]).
    Prune {
        /// Fraction of the remaining points removed per round, (0, 1].
        fraction: f64,
        /// After pruning, refit the coefficients on ALL training points with the kept points
        /// as the only support vectors (the primal solve of [`super::fixed_size`]), instead of
        /// the exact solve on the kept points alone. Pruning keeps the points with the largest
        /// |a| = c·|e|, the worst-fitted ones; fitted on those alone the model follows their
        /// noise.
        refit_all: bool,
    },
}

impl Reduction {
    /// Fixed-size with the default search (20 000 swap attempts, seed 0).
    pub const FIXED_SIZE: Reduction = Reduction::FixedSize {
        trials: 20_000,
        seed: 0,
    };
    /// Pruning 5 % of the remaining points per round, coefficients from the last exact
    /// solve on the kept points (the classical method).
    pub const PRUNE: Reduction = Reduction::Prune {
        fraction: 0.05,
        refit_all: false,
    };
    /// Pruning as [`Reduction::PRUNE`], then the coefficients refitted on all points.
    pub const PRUNE_REFIT: Reduction = Reduction::Prune {
        fraction: 0.05,
        refit_all: true,
    };

    /// Short name for tables and file names.
    pub fn name(&self) -> &'static str {
        match self {
            Reduction::FixedSize { .. } => "fixed-size",
            Reduction::Prune {
                refit_all: false, ..
            } => "prune",
            Reduction::Prune {
                refit_all: true, ..
            } => "prune+refit",
        }
    }
}

/// Trains on raw inputs `x` (columns named by `features`) and targets `y_dph` (°/h) a model
/// with at most `budget` support vectors. The standardisation is fitted on all of `x`, as
/// [`Lssvm::train`] does, so a reduced model and the full one see the same inputs.
pub fn train_reduced<X: RowSet + ?Sized>(
    features: &[String],
    x: &X,
    y_dph: &[f64],
    sigma: f64,
    c: f64,
    budget: usize,
    method: Reduction,
) -> Result<Lssvm, LssvmError> {
    let (scaling, support, alpha_dph, bias_dph) = match method {
        Reduction::FixedSize { trials, seed } => {
            let (scaling, rows) = super::standardised_rows(features, x, y_dph)?;
            let opts = FixedSizeOptions {
                budget,
                trials,
                seed,
            };
            let s = solve_fixed_size(&rows, y_dph, sigma, c, &opts)?;
            let support = s.active.iter().map(|&i| rows.row(i).to_vec()).collect();
            (scaling, support, s.alpha, s.bias)
        }
        Reduction::Prune {
            fraction,
            refit_all: false,
        } => {
            let (scaling, z) = super::standardised(features, x, y_dph)?;
            let p = prune(&z, y_dph, sigma, c, budget, fraction)?;
            let support = p.kept.iter().map(|&i| z[i].clone()).collect();
            (scaling, support, p.solution.alpha, p.solution.bias)
        }
        Reduction::Prune {
            fraction,
            refit_all: true,
        } => {
            let (scaling, z) = super::standardised(features, x, y_dph)?;
            let p = prune(&z, y_dph, sigma, c, budget, fraction)?;
            let rows = Rows::from_rows(&z);
            let s = solve_on_active(&rows, y_dph, sigma, c, p.kept)?;
            let support = s.active.iter().map(|&i| z[i].clone()).collect();
            (scaling, support, s.alpha, s.bias)
        }
    };
    Ok(Lssvm {
        features: features.to_vec(),
        scaling,
        support,
        alpha_dph,
        bias_dph,
        sigma,
        c,
        in_kernel: Vec::new(),
        linear_dph: Vec::new(),
    })
}

/// The fixed-size model of [`train_reduced`] at one σ, ready for any c: the standardisation,
/// the active set and the normal equations depend on σ alone, so a grid over c costs one
/// active-set search and one pass over the data per σ. `model(c)` equals
/// `train_reduced(…, sigma, c, opts.budget, Reduction::FixedSize { trials, seed })` with
/// `opts`' trials and seed.
#[derive(Clone, Debug)]
pub struct FixedSizePath {
    features: Vec<String>,
    scaling: super::Scaling,
    support: Vec<Vec<f64>>,
    normal: fixed_size::ActiveNormal,
    sigma: f64,
}

impl FixedSizePath {
    /// Standardises `x`, chooses the active set of at most `budget` rows at σ and forms the
    /// normal equations.
    pub fn new(
        features: &[String],
        x: &[Vec<f64>],
        y_dph: &[f64],
        sigma: f64,
        opts: &FixedSizeOptions,
    ) -> Result<FixedSizePath, LssvmError> {
        let (scaling, rows) = super::standardised_rows(features, x, y_dph)?;
        // The checks of `solve_fixed_size`, with c = 1 standing for any valid c.
        fixed_size::validate(&rows, y_dph, sigma, 1.0, opts)?;
        let active = select_active_set(&rows, opts.budget, sigma, opts.trials, opts.seed);
        let support = active.iter().map(|&i| rows.row(i).to_vec()).collect();
        let normal = fixed_size::normal_on_active_with(&rows, y_dph, &[], sigma, active)?;
        Ok(FixedSizePath {
            features: features.to_vec(),
            scaling,
            support,
            normal,
            sigma,
        })
    }

    /// The model at regularisation `c`.
    pub fn model(&self, c: f64) -> Result<Lssvm, LssvmError> {
        let s = self.normal.solve(c)?;
        Ok(Lssvm {
            features: self.features.clone(),
            scaling: self.scaling.clone(),
            support: self.support.clone(),
            alpha_dph: s.alpha,
            bias_dph: s.bias,
            sigma: self.sigma,
            c,
            in_kernel: Vec::new(),
            linear_dph: Vec::new(),
        })
    }
}

/// The partially linear model ([`Lssvm::train_partially_linear`]) as a fixed-size LS-SVM of
/// at most `budget` support vectors: the active set is chosen on the kernel inputs, and the
/// linear columns join the bias in the primal solve ([`fixed_size::solve_on_active_with`]).
#[allow(clippy::too_many_arguments)]
pub fn train_fixed_size_partially_linear(
    features: &[String],
    x: &[Vec<f64>],
    y_dph: &[f64],
    sigma: f64,
    c: f64,
    budget: usize,
    linear: &[bool],
) -> Result<Lssvm, LssvmError> {
    let (scaling, z, lin) = super::partially_linear_design(features, x, y_dph, linear)?;
    let rows = Rows::from_rows(&z);
    let opts = FixedSizeOptions::with_budget(budget);
    let active = select_active_set(&rows, budget, sigma, opts.trials, opts.seed);
    let s = fixed_size::solve_on_active_with(&rows, y_dph, &lin, sigma, c, active)?;
    Ok(Lssvm {
        features: features.to_vec(),
        support: s.active.iter().map(|&i| rows.row(i).to_vec()).collect(),
        alpha_dph: s.alpha,
        bias_dph: s.bias,
        in_kernel: linear.iter().map(|l| !l).collect(),
        linear_dph: super::expand_linear(linear, &s.linear),
        scaling,
        sigma,
        c,
    })
}

/// The LS-SVM with a linear trend: every feature is a kernel input, and the features with
/// `trend[d]` set also enter linearly on (x − mean) beside the bias. A steep trend (a MEMS
/// gyro's 100 °/h per °C) is then carried by one coefficient instead of kernel coefficients
/// that cancel, which f32 on the board cannot sum. Exact up to `budget` samples, fixed-size
/// with `budget` vectors beyond.
#[allow(clippy::too_many_arguments)]
pub fn train_with_trend(
    features: &[String],
    x: &[Vec<f64>],
    y_dph: &[f64],
    sigma: f64,
    c: f64,
    budget: usize,
    trend: &[bool],
) -> Result<Lssvm, LssvmError> {
    if trend.len() != features.len() {
        return Err(LssvmError::Dimension {
            row: 0,
            got: trend.len(),
            want: features.len(),
        });
    }
    let (scaling, z) = super::standardised(features, x, y_dph)?;
    let lin: Vec<Vec<f64>> = (0..features.len())
        .filter(|&d| trend[d])
        .map(|d| x.iter().map(|r| r[d] - scaling.mean[d]).collect())
        .collect();
    let (support, alpha_dph, bias_dph, beta) = if z.len() <= budget {
        let s = super::solve::solve_partially_linear(&z, &lin, y_dph, sigma, c)?;
        (z, s.solution.alpha, s.solution.bias, s.beta)
    } else {
        let rows = Rows::from_rows(&z);
        let opts = FixedSizeOptions::with_budget(budget);
        let active = select_active_set(&rows, budget, sigma, opts.trials, opts.seed);
        let s = fixed_size::solve_on_active_with(&rows, y_dph, &lin, sigma, c, active)?;
        let support = s.active.iter().map(|&i| rows.row(i).to_vec()).collect();
        (support, s.alpha, s.bias, s.linear)
    };
    Ok(Lssvm {
        features: features.to_vec(),
        scaling,
        support,
        alpha_dph,
        bias_dph,
        sigma,
        c,
        in_kernel: vec![true; features.len()],
        linear_dph: super::expand_linear(trend, &beta),
    })
}

/// One point of a hyper-parameter grid and its validation error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridPoint {
    /// Kernel width σ, standardised units.
    pub sigma: f64,
    /// Regularisation c.
    pub c: f64,
    /// RMS error on the validation rows, °/h (NaN when training failed).
    pub validation_rms_dph: f64,
}

/// Evaluates every (σ, c) of `sigmas` × `cs` in parallel (rayon, one task per point): a
/// reduced model is trained on the training rows and scored on the validation rows, which are
/// every `folds`-th contiguous block of `block` rows (blocks rather than single rows, because
/// neighbouring 1 Hz samples share their noise and would flatter the score). Returns the grid
/// in row-major order (σ outer); pick the smallest `validation_rms_dph`.
#[allow(clippy::too_many_arguments)]
pub fn grid_search(
    features: &[String],
    x: &[Vec<f64>],
    y_dph: &[f64],
    sigmas: &[f64],
    cs: &[f64],
    budget: usize,
    method: Reduction,
    block: usize,
    folds: usize,
) -> Result<Vec<GridPoint>, LssvmError> {
    use rayon::prelude::*;
    if x.len() != y_dph.len() {
        return Err(LssvmError::Length {
            inputs: x.len(),
            targets: y_dph.len(),
        });
    }
    let block = block.max(1);
    let folds = folds.max(2);
    let is_val = |i: usize| (i / block) % folds == folds - 1;
    let (mut xt, mut yt, mut xv, mut yv) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (i, (r, v)) in x.iter().zip(y_dph).enumerate() {
        if is_val(i) {
            xv.push(r.clone());
            yv.push(*v);
        } else {
            xt.push(r.clone());
            yt.push(*v);
        }
    }
    if xt.is_empty() || xv.is_empty() {
        return Err(LssvmError::Empty);
    }
    let grid: Vec<(f64, f64)> = sigmas
        .iter()
        .flat_map(|&s| cs.iter().map(move |&c| (s, c)))
        .collect();
    Ok(grid
        .par_iter()
        .map(|&(sigma, c)| {
            let rms =
                train_reduced(features, &xt, &yt, sigma, c, budget, method).map_or(f64::NAN, |m| {
                    let ss: f64 = xv
                        .iter()
                        .zip(&yv)
                        .map(|(r, v)| (m.predict(r) - v).powi(2))
                        .sum();
                    (ss / xv.len() as f64).sqrt()
                });
            GridPoint {
                sigma,
                c,
                validation_rms_dph: rms,
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(n: usize) -> (Vec<String>, Vec<Vec<f64>>, Vec<f64>) {
        let x: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                let t = i as f64;
                vec![
                    10.0 + 55.0 * (t * 0.618_033_988_7).fract(),
                    0.02 * ((t * 0.414_213_562_4).fract() - 0.5),
                ]
            })
            .collect();
        let y = x.iter().map(|r| -7.1 - 2e-4 * r[0] + 2.0 * r[1]).collect();
        (vec!["temp_c".into(), "temp_rate_c_per_s".into()], x, y)
    }

    /// A path's model at each c is `train_reduced`'s, bit for bit, and the path refuses what
    /// `train_reduced` refuses.
    #[test]
    fn fixed_size_path_equals_train_reduced_at_every_c() {
        let (f, x, y) = data(300);
        let path = FixedSizePath::new(&f, &x, &y, 0.6, &FixedSizeOptions::with_budget(24)).unwrap();
        for c in [0.1, 3.0, 100.0, 1e5] {
            let a = path.model(c).unwrap();
            let b = train_reduced(&f, &x, &y, 0.6, c, 24, Reduction::FIXED_SIZE).unwrap();
            assert_eq!(a, b, "c = {c}");
        }
        assert!(path.model(0.0).is_err());
        assert!(path.model(f64::NAN).is_err());
        assert!(FixedSizePath::new(&f, &x, &y, -1.0, &FixedSizeOptions::with_budget(24)).is_err());
        let mut bad = y.clone();
        bad[7] = f64::NAN;
        assert!(FixedSizePath::new(&f, &x, &bad, 0.6, &FixedSizeOptions::with_budget(24)).is_err());
    }

    /// Rows held in one block train the model of rows held as vectors, bit for bit, by
    /// every reduction, and give the same training summary.
    #[test]
    fn rows_in_one_block_train_the_same_model() {
        let (f, x, y) = data(300);
        let mut rows = crate::features::FeatureRows::with_capacity(2, x.len());
        for r in &x {
            rows.push_row(r.iter().copied());
        }
        for method in [
            Reduction::FIXED_SIZE,
            Reduction::Prune {
                fraction: 0.1,
                refit_all: false,
            },
            Reduction::Prune {
                fraction: 0.1,
                refit_all: true,
            },
        ] {
            let a = train_reduced(&f, &x, &y, 0.6, 10.0, 24, method).unwrap();
            let b = train_reduced(&f, &rows, &y, 0.6, 10.0, 24, method).unwrap();
            assert_eq!(a, b, "{}", method.name());
            let p = || crate::model::Provenance::from_bytes("d", b"", "t");
            let ma = crate::model::ModelFile::from_trained(a, &x, &y, 10.0, 1.0, None, p());
            let mb = crate::model::ModelFile::from_trained(b, &rows, &y, 10.0, 1.0, None, p());
            assert_eq!(ma.unwrap(), mb.unwrap());
        }
    }

    /// Both methods respect the budget and, with a budget ≥ n, agree with the exact model on
    /// raw inputs (fixed-size to the Nyström truncation, pruning exactly).
    #[test]
    fn both_methods_meet_the_budget_and_match_exact_when_unreduced() {
        let (f, x, y) = data(120);
        let exact = Lssvm::train(&f, &x, &y, 1.0, 100.0).unwrap();
        for method in [
            Reduction::FIXED_SIZE,
            Reduction::PRUNE,
            Reduction::PRUNE_REFIT,
        ] {
            let r = train_reduced(&f, &x, &y, 1.0, 100.0, 16, method).unwrap();
            assert_eq!(r.support.len(), 16, "{}", method.name());
            assert_eq!(r.scaling, exact.scaling);
            let u = train_reduced(&f, &x, &y, 1.0, 100.0, 500, method).unwrap();
            for row in &x {
                let d = (u.predict(row) - exact.predict(row)).abs();
                assert!(d < 1e-8, "{}: {d}", method.name());
            }
        }
    }

    /// The parallel grid equals point-by-point serial evaluation, and on a smooth target
    /// with a known width the best σ is not at the grid's extremes of badly over- or
    /// under-smoothing.
    #[test]
    fn grid_search_matches_serial_and_prefers_a_sensible_width() {
        let (f, x, _) = data(3000);
        let y: Vec<f64> = x.iter().map(|r| (r[0] / 8.0).sin() + 30.0 * r[1]).collect();
        let sigmas = [0.02, 0.5, 50.0];
        let cs = [100.0];
        let g = grid_search(&f, &x, &y, &sigmas, &cs, 32, Reduction::FIXED_SIZE, 50, 5).unwrap();
        assert_eq!(g.len(), 3);
        let train: Vec<usize> = (0..3000).filter(|i| (i / 50) % 5 != 4).collect();
        let val: Vec<usize> = (0..3000).filter(|i| (i / 50) % 5 == 4).collect();
        let xt: Vec<Vec<f64>> = train.iter().map(|&i| x[i].clone()).collect();
        let yt: Vec<f64> = train.iter().map(|&i| y[i]).collect();
        for p in &g {
            let m = train_reduced(&f, &xt, &yt, p.sigma, p.c, 32, Reduction::FIXED_SIZE).unwrap();
            let ss: f64 = val.iter().map(|&i| (m.predict(&x[i]) - y[i]).powi(2)).sum();
            let rms = (ss / val.len() as f64).sqrt();
            assert!(
                (rms - p.validation_rms_dph).abs() <= 1e-12 * rms.max(1e-300),
                "{p:?}"
            );
        }
        assert!(g[1].validation_rms_dph < g[0].validation_rms_dph, "{g:?}");
        assert!(g[1].validation_rms_dph < g[2].validation_rms_dph, "{g:?}");
    }

    #[test]
    fn mismatched_lengths_are_an_error() {
        let (f, x, y) = data(10);
        assert!(matches!(
            train_reduced(&f, &x, &y[..4], 1.0, 1.0, 4, Reduction::PRUNE),
            Err(LssvmError::Length { .. })
        ));
    }
}
