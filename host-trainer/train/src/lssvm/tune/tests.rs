//! The tuning against explicit refits (each fold's score, a row of c), its optimum on data with
//! a known noise level, the folds, and its errors.

use super::*;
use crate::lssvm::kernel::gauss;
use crate::lssvm::{Lssvm, Scaling};

/// An `Lssvm` trained on already standardised rows (identity scaling), σ = 0.7, c = 50.
fn refit(f: &[String], xt: Vec<Vec<f64>>, yt: &[f64]) -> Lssvm {
    let m = crate::lssvm::solve::solve(&xt, yt, 0.7, 50.0).unwrap();
    Lssvm {
        features: f.to_vec(),
        scaling: Scaling {
            mean: vec![0.0; 2],
            scale: vec![1.0; 2],
        },
        support: xt,
        alpha_dph: m.alpha,
        bias_dph: m.bias,
        sigma: 0.7,
        c: 50.0,

        in_kernel: Vec::new(),
        linear_dph: Vec::new(),
    }
}

fn names(d: usize) -> Vec<String> {
    (0..d).map(|i| format!("x{i}")).collect()
}

/// The blocked score equals training on the other folds and predicting the held-out ones
/// with the public `Lssvm` (an independent path through `train`/`predict`), and LOO
/// equals the mean of 1-point refits.
#[test]
fn scores_match_explicit_refits() {
    let (z, y) = crate::lssvm::test_data::scattered(60);
    let f = names(2);
    let scaling = Scaling::fit(&f, &z).unwrap();
    let zs: Vec<Vec<f64>> = z.iter().map(|r| scaling.apply(r)).collect();
    let v = Validation::Blocked { block: 4, folds: 3 };
    let fo = fold_indices(&v, zs.len()).unwrap();
    let got = score(&zs, &[], &y, &fo, 0.7, 50.0);
    let mut ss = 0.0;
    for fold in &fo {
        let keep: Vec<usize> = (0..60).filter(|i| !fold.contains(i)).collect();
        let xt: Vec<Vec<f64>> = keep.iter().map(|&i| zs[i].clone()).collect();
        let yt: Vec<f64> = keep.iter().map(|&i| y[i]).collect();
        let model = refit(&f, xt, &yt);
        ss += fold
            .iter()
            .map(|&i| (model.predict(&zs[i]) - y[i]).powi(2))
            .sum::<f64>();
    }
    let want = (ss / 60.0).sqrt();
    assert!((got - want).abs() < 1e-12 * want, "{got} vs {want}");

    let loo = score(&zs, &[], &y, &[], 0.7, 50.0);
    let mut ss = 0.0;
    for i in 0..60 {
        let keep: Vec<usize> = (0..60).filter(|&j| j != i).collect();
        let xt: Vec<Vec<f64>> = keep.iter().map(|&j| zs[j].clone()).collect();
        let yt: Vec<f64> = keep.iter().map(|&j| y[j]).collect();
        // Refit on the standardised inputs: the closed form keeps the scaling fixed.
        let model = refit(&f, xt, &yt);
        ss += (model.predict(&zs[i]) - y[i]).powi(2);
    }
    let want = (ss / 60.0).sqrt();
    assert!((loo - want).abs() < 1e-8 * want, "{loo} vs {want}");
}

/// A row of c values at one σ scores each c exactly as a refit per (fold, c) through the
/// public solvers does: the exact Cholesky below `MIXED_MIN_N` training rows (with and
/// without a linear column), `solve::solve`'s iterative paths above it.
#[test]
fn a_row_of_c_scores_as_separate_refits() {
    for (n, with_lin) in [(300, false), (300, true), (1_200, false)] {
        let (z, y) = crate::lssvm::test_data::scattered(n);
        let lin: Vec<Vec<f64>> = if with_lin {
            vec![z.iter().map(|r| r[0] * 0.3).collect()]
        } else {
            Vec::new()
        };
        let fo = fold_indices(&Validation::Contiguous { folds: 10 }, n).unwrap();
        let cs = [0.3, 50.0, 1e4];
        let row = score_row(&z, &lin, &y, &fo, 0.7, &cs);
        for (k, &c) in cs.iter().enumerate() {
            let mut ss = 0.0;
            for fold in &fo {
                let keep: Vec<usize> = (0..n).filter(|i| !fold.contains(i)).collect();
                let zt: Vec<Vec<f64>> = keep.iter().map(|&i| z[i].clone()).collect();
                let yt: Vec<f64> = keep.iter().map(|&i| y[i]).collect();
                let lt: Vec<Vec<f64>> = lin
                    .iter()
                    .map(|col| keep.iter().map(|&i| col[i]).collect())
                    .collect();
                let sol = if with_lin || zt.len() < solve::MIXED_MIN_N {
                    solve::solve_partially_linear(&zt, &lt, &yt, 0.7, c).unwrap()
                } else {
                    solve::PartiallyLinear {
                        solution: solve::solve(&zt, &yt, 0.7, c).unwrap(),
                        beta: Vec::new(),
                    }
                };
                let inv = 1.0 / (2.0 * 0.7 * 0.7);
                for &i in fold {
                    let f = zt
                        .iter()
                        .zip(&sol.solution.alpha)
                        .map(|(s, a)| a * gauss(s, &z[i], inv))
                        .sum::<f64>()
                        + sol.solution.bias
                        + lin
                            .iter()
                            .zip(&sol.beta)
                            .map(|(l, b)| b * l[i])
                            .sum::<f64>();
                    ss += (y[i] - f).powi(2);
                }
            }
            let want = (ss / n as f64).sqrt();
            assert_eq!(
                row[k].to_bits(),
                want.to_bits(),
                "n {n}, c {c}: {} vs {want}",
                row[k]
            );
        }
    }
}

/// On a smooth 1-D target with known noise, the chosen σ is neither the grid's smallest
/// nor its largest, the CV RMS is near the noise level, and refinement never worsens it.
#[test]
fn finds_an_interior_optimum_near_the_noise_level() {
    let n = 200;
    let noise = 0.05;
    let x: Vec<Vec<f64>> = (0..n).map(|i| vec![i as f64 / n as f64 * 6.0]).collect();
    // Deterministic pseudo-noise, uniform in ±√3·noise (std = noise).
    let y: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let u = ((i as f64 * 0.754_877_666).fract() - 0.5) * 2.0 * 3f64.sqrt() * noise;
            r[0].sin() + u
        })
        .collect();
    for v in [
        Validation::LeaveOneOut,
        Validation::Blocked { block: 5, folds: 5 },
    ] {
        let t = tune(
            &names(1),
            &x,
            &y,
            &v,
            &Grid::default(),
            &ProgressBar::hidden(),
        )
        .unwrap();
        // Within the parsimony tolerance of every evaluated point, and the most
        // regularised of those that are.
        let all: Vec<CvPoint> = t.curve.iter().chain(&t.refined).copied().collect();
        let best_all = best(&all).unwrap();
        let limit = best_all.cv_rms_dph * (1.0 + PARSIMONY);
        assert!(t.cv_rms_dph <= limit, "{v:?}");
        assert!(
            all.iter().all(|p| p.cv_rms_dph > limit || p.c >= t.c),
            "{v:?}: a smaller c is within tolerance"
        );
        assert!(t.sigma > 0.05 && t.sigma < 5.0, "{v:?}: sigma {}", t.sigma);
        assert!(
            t.cv_rms_dph > 0.8 * noise && t.cv_rms_dph < 1.5 * noise,
            "{v:?}: cv {}",
            t.cv_rms_dph
        );
        assert_eq!(t.curve.len(), 63);
        assert_eq!(t.refined.len(), 27);
    }
}

#[test]
fn contiguous_folds_cover_each_sample_once_in_order() {
    let f = fold_indices(&Validation::Contiguous { folds: 3 }, 10).unwrap();
    assert_eq!(f, vec![vec![0, 1, 2], vec![3, 4, 5], vec![6, 7, 8, 9]]);
    assert!(fold_indices(&Validation::Contiguous { folds: 3 }, 5).is_err());
}

#[test]
fn group_folds_leave_out_each_group() {
    let g = vec![0, 0, 1, 1, 2, 2, 2];
    let f = fold_indices(&Validation::Groups(g), 7).unwrap();
    assert_eq!(f, vec![vec![0, 1], vec![2, 3], vec![4, 5, 6]]);
    assert!(matches!(
        fold_indices(&Validation::Groups(vec![0; 7]), 7),
        Err(TuneError::Setup(_))
    ));
    assert!(matches!(
        fold_indices(&Validation::Blocked { block: 4, folds: 3 }, 11),
        Err(TuneError::Setup(_))
    ));
}

#[test]
fn bad_grids_and_data_are_errors() {
    let x = vec![vec![1.0], vec![2.0], vec![3.0], vec![4.0]];
    let y = vec![1.0, 2.0, 1.0, 2.0];
    let hidden = ProgressBar::hidden();
    let bad = Grid {
        sigma: (0.0, 1.0),
        ..Grid::default()
    };
    assert!(matches!(
        tune(&names(1), &x, &y, &Validation::LeaveOneOut, &bad, &hidden),
        Err(TuneError::Setup(_))
    ));
    let nan_y = vec![1.0, f64::NAN, 1.0, 2.0];
    assert!(matches!(
        tune(
            &names(1),
            &x,
            &nan_y,
            &Validation::LeaveOneOut,
            &Grid::default(),
            &hidden
        ),
        Err(TuneError::Lssvm(LssvmError::NonFinite { index: 1, .. }))
    ));
    assert!(matches!(
        tune(
            &names(1),
            &x,
            &y[..3],
            &Validation::LeaveOneOut,
            &Grid::default(),
            &hidden
        ),
        Err(TuneError::Lssvm(LssvmError::Length { .. }))
    ));
}
