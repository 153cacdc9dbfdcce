//! Sparse LS-SVM by pruning (Suykens et al. 2000, "Sparse approximation using least squares
//! support vector machines"): solve Eq. (9), drop the points with the smallest |a_i| (the
//! least informative: a_i = c·e_i is proportional to the point's training error), solve again
//! on the rest, until at most the budget remains.
//!
//! Each round is an exact solve (O(n³), n² memory), so pruning suits the block-averaged
//! training sets (hundreds to a few thousand points), not raw multi-day 1 Hz records: that
//! is what [`super::fixed_size`] is for. [`MAX_PRUNE_SAMPLES`] guards against the n×n matrix
//! of a large set.

use super::solve::{solve, Solution};
use super::LssvmError;

/// Largest training set pruning accepts: 20 000 points make a 3.2 GB kernel matrix.
pub const MAX_PRUNE_SAMPLES: usize = 20_000;

/// A pruned solution: the kept training rows and Eq. (9)'s solution on them.
#[derive(Clone, Debug, PartialEq)]
pub struct Pruned {
    /// Indices of the kept rows (the support vectors), ascending.
    pub kept: Vec<usize>,
    /// Eq. (9) solved on the kept rows only.
    pub solution: Solution,
    /// Number of solves performed.
    pub rounds: usize,
}

/// Prunes to at most `budget` support vectors, removing `fraction` of the remaining points
/// per round (at least one, never below the budget). `fraction` = 1 removes everything
/// above the budget after the first solve; smaller fractions let |a| be re-ranked after each
/// removal (the usual choice is 0.05 to 0.1).
pub fn prune(
    z: &[Vec<f64>],
    y: &[f64],
    sigma: f64,
    c: f64,
    budget: usize,
    fraction: f64,
) -> Result<Pruned, LssvmError> {
    if !(fraction > 0.0 && fraction <= 1.0) {
        return Err(LssvmError::HyperParameter {
            name: "fraction",
            value: fraction,
        });
    }
    if budget == 0 {
        return Err(LssvmError::Empty);
    }
    if z.len() > MAX_PRUNE_SAMPLES {
        return Err(LssvmError::TooLarge {
            samples: z.len(),
            max: MAX_PRUNE_SAMPLES,
        });
    }
    if z.len() != y.len() {
        return Err(LssvmError::Length {
            inputs: z.len(),
            targets: y.len(),
        });
    }
    let mut kept: Vec<usize> = (0..z.len()).collect();
    let mut rounds = 0;
    loop {
        let zk: Vec<Vec<f64>> = kept.iter().map(|&i| z[i].clone()).collect();
        let yk: Vec<f64> = kept.iter().map(|&i| y[i]).collect();
        let solution = solve(&zk, &yk, sigma, c)?;
        rounds += 1;
        let n = kept.len();
        if n <= budget {
            return Ok(Pruned {
                kept,
                solution,
                rounds,
            });
        }
        let drop = ((fraction * n as f64).ceil() as usize).clamp(1, n - budget);
        let mut order: Vec<usize> = (0..n).collect();
        // Largest |a| first; ties broken by index so that the result is deterministic.
        order.sort_by(|&a, &b| {
            solution.alpha[b]
                .abs()
                .total_cmp(&solution.alpha[a].abs())
                .then(a.cmp(&b))
        });
        let mut next: Vec<usize> = order[..n - drop].iter().map(|&k| kept[k]).collect();
        next.sort_unstable();
        kept = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lssvm::solve::solve_dense_reference;

    fn data(n: usize) -> (Vec<Vec<f64>>, Vec<f64>) {
        let z = crate::lssvm::test_data::points(n);
        let y = z
            .iter()
            .enumerate()
            .map(|(i, r)| (1.3 * r[0]).sin() + 0.05 * ((i * 7919 % 101) as f64 / 101.0 - 0.5))
            .collect();
        (z, y)
    }

    /// One round keeps exactly the `budget` largest |a| of the dense LU solution of the full
    /// system, and the result is the dense solution on those points.
    #[test]
    fn single_round_keeps_the_largest_alpha_and_resolves() {
        let (z, y) = data(90);
        let (sigma, c) = (0.8, 50.0);
        let full = solve_dense_reference(&z, &y, sigma, c).unwrap();
        let mut order: Vec<usize> = (0..90).collect();
        order.sort_by(|&a, &b| full.alpha[b].abs().total_cmp(&full.alpha[a].abs()));
        let mut want: Vec<usize> = order[..20].to_vec();
        want.sort_unstable();
        let p = prune(&z, &y, sigma, c, 20, 1.0).unwrap();
        assert_eq!(p.kept, want);
        assert_eq!(p.rounds, 2);
        let zk: Vec<Vec<f64>> = want.iter().map(|&i| z[i].clone()).collect();
        let yk: Vec<f64> = want.iter().map(|&i| y[i]).collect();
        let r = solve_dense_reference(&zk, &yk, sigma, c).unwrap();
        for (a, b) in p.solution.alpha.iter().zip(&r.alpha) {
            assert!((a - b).abs() < 1e-9 * b.abs().max(1.0), "{a} vs {b}");
        }
        assert!((p.solution.bias - r.bias).abs() < 1e-9);
    }

    /// Gradual pruning meets the budget exactly; a budget ≥ n is the exact solution.
    #[test]
    fn gradual_pruning_meets_the_budget_and_large_budget_is_exact() {
        let (z, y) = data(120);
        let p = prune(&z, &y, 0.8, 50.0, 30, 0.1).unwrap();
        assert_eq!(p.kept.len(), 30);
        assert!(p.rounds > 2);
        let all = prune(&z, &y, 0.8, 50.0, 500, 0.1).unwrap();
        assert_eq!(all.kept.len(), 120);
        assert_eq!(all.solution, solve(&z, &y, 0.8, 50.0).unwrap());
    }

    #[test]
    fn bad_parameters_are_typed_errors() {
        let (z, y) = data(10);
        assert!(matches!(
            prune(&z, &y, 1.0, 1.0, 5, 0.0),
            Err(LssvmError::HyperParameter {
                name: "fraction",
                ..
            })
        ));
        assert!(matches!(
            prune(&z, &y, 1.0, 1.0, 0, 0.1),
            Err(LssvmError::Empty)
        ));
    }
}
