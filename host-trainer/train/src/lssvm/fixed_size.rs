//! Fixed-size LS-SVM (Suykens et al., *Least Squares Support Vector Machines*, 2002, §6.4):
//! a Nyström approximation of the Gaussian feature map on an active set of M points chosen by
//! maximising the quadratic Rényi entropy, and Eq. (9)'s ridge problem solved in the primal.
//!
//! Memory is O(n·d + M²) and time O(n·M²): the n×M kernel block is streamed in chunks and only
//! the (r+1)×(r+1) normal equations are kept, so a million samples never form an n×n matrix.
//!
//! Derivation. With K_MM = U Λ Uᵀ on the active set and k_M(x) = [K(x, a_j)]_j, the Nyström
//! feature map is φ(x) = Λ^{−1/2} Uᵀ k_M(x) ∈ ℝʳ (eigenvalues below `EIG_REL_TOL`·λ_max
//! dropped, r ≤ M). The primal of Eq. (9), min ½‖w‖² + c/2 Σ (y_i − wᵀφ(x_i) − b)², has the
//! normal equations
//!
//! ```text
//! [ ΦᵀΦ + I/c   Φᵀ1 ] [ w ]   [ Φᵀy ]
//! [ 1ᵀΦ          n  ] [ b ] = [ 1ᵀy ]
//! ```
//!
//! and f(x) = wᵀφ(x) + b = Σ_j α_j K(x, a_j) + b with α = U Λ^{−1/2} w: a model of the same
//! form as Eq. (10) with the M active points as support vectors. With every training point
//! active (M = n) the Nyström map is exact (ΦΦᵀ = K) and the solution is Eq. (9)'s.

use faer::prelude::*;
use faer::{Mat, Side};
use rand::seq::index;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::kernel::{gauss, gauss_rows};
use super::LssvmError;

/// Eigenvalues of K_MM below this fraction of the largest are dropped from the Nyström map:
/// near-duplicate active points make K_MM numerically singular, and their directions carry
/// at most λ·c of the fit (below 1e-9 relative for c ≤ 1e3).
pub const EIG_REL_TOL: f64 = 1e-12;

/// Rows per chunk of the streamed n×M kernel block (bounds the working memory per thread to
/// `CHUNK_ROWS`·M f64).
const CHUNK_ROWS: usize = 4096;

/// Standardised inputs as one contiguous row-major block.
#[derive(Clone, Debug, PartialEq)]
pub struct Rows {
    /// Row-major values, `len() = n · dim`.
    pub data: Vec<f64>,
    /// Values per row (input features).
    pub dim: usize,
}

impl Rows {
    /// Copies rows of equal length into one block.
    pub fn from_rows(z: &[Vec<f64>]) -> Rows {
        let dim = z.first().map_or(0, Vec::len);
        Rows {
            data: z.iter().flat_map(|r| r.iter().copied()).collect(),
            dim,
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.data.len().checked_div(self.dim).unwrap_or(0)
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Row `i`.
    pub fn row(&self, i: usize) -> &[f64] {
        &self.data[i * self.dim..(i + 1) * self.dim]
    }
}

/// Quadratic Rényi entropy of the points `idx` of `z` with a Gaussian Parzen window of width
/// σ: H₂ = −ln( (1/M²) Σ_ij K(a_i, a_j) ) (up to a constant that does not depend on the set).
/// Larger means the points are more spread out. Direct O(M²) evaluation.
pub fn renyi_entropy(z: &Rows, idx: &[usize], sigma: f64) -> f64 {
    let inv = 1.0 / (2.0 * sigma * sigma);
    let m = idx.len() as f64;
    let s: f64 = idx
        .iter()
        .map(|&i| {
            idx.iter()
                .map(|&j| gauss(z.row(i), z.row(j), inv))
                .sum::<f64>()
        })
        .sum();
    -(s / (m * m)).ln()
}

/// Chooses `m` distinct rows of `z` that (locally) maximise the quadratic Rényi entropy.
///
/// Starts from a random subset and makes `trials` swap attempts: a random candidate row q
/// outside the set is compared against every member, and replaces the member whose removal
/// lowers Σ_ij K(a_i, a_j) the most, if the total then falls (the entropy rises). The running
/// row sums make one attempt O(M). Deterministic for a given `seed`. Returns the indices in
/// ascending order; with m ≥ n every row.
pub fn select_active_set(z: &Rows, m: usize, sigma: f64, trials: usize, seed: u64) -> Vec<usize> {
    let n = z.len();
    if m >= n {
        return (0..n).collect();
    }
    if m == 0 {
        return Vec::new();
    }
    let inv = 1.0 / (2.0 * sigma * sigma);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut active: Vec<usize> = index::sample(&mut rng, n, m).into_vec();
    let mut member = vec![false; n];
    for &a in &active {
        member[a] = true;
    }
    // kaa[i·m + j] = K(a_i, a_j); rows[i] = Σ_{j≠i} K(a_i, a_j).
    let mut kaa = vec![0.0; m * m];
    for i in 0..m {
        for j in 0..m {
            kaa[i * m + j] = gauss(z.row(active[i]), z.row(active[j]), inv);
        }
    }
    let mut rows: Vec<f64> = (0..m)
        .map(|i| kaa[i * m..(i + 1) * m].iter().sum::<f64>() - 1.0)
        .collect();
    let mut kq = vec![0.0; m];
    // The active rows, contiguous, for `gauss_rows`.
    let mut af: Vec<f64> = active
        .iter()
        .flat_map(|&a| z.row(a).iter().copied())
        .collect();
    let dim = z.dim;
    for _ in 0..trials {
        let q = rng.random_range(0..n);
        if member[q] {
            continue;
        }
        gauss_rows(&af, dim, z.row(q), inv, &mut kq);
        let total: f64 = kq.iter().sum();
        // Change of Σ_ij K when member i is replaced by q: 2·(Σ_{j≠i} K(q,a_j) − rows[i]).
        let (best, delta) = (0..m)
            .map(|i| (i, 2.0 * (total - kq[i] - rows[i])))
            .fold((0, f64::INFINITY), |b, c| if c.1 < b.1 { c } else { b });
        if delta >= 0.0 {
            continue;
        }
        let old = active[best];
        member[old] = false;
        member[q] = true;
        active[best] = q;
        af[best * dim..(best + 1) * dim].copy_from_slice(z.row(q));
        for j in 0..m {
            if j == best {
                continue;
            }
            rows[j] += kq[j] - kaa[best * m + j];
            kaa[best * m + j] = kq[j];
            kaa[j * m + best] = kq[j];
        }
        rows[best] = total - kq[best];
    }
    active.sort_unstable();
    active
}

/// Options of [`solve_fixed_size`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedSizeOptions {
    /// Largest number of support vectors M.
    pub budget: usize,
    /// Swap attempts of the active-set search ([`select_active_set`]).
    pub trials: usize,
    /// Seed of the active-set search.
    pub seed: u64,
}

impl FixedSizeOptions {
    /// `budget` support vectors, 20 000 swap attempts (ample for M ≤ 256 on 2-D inputs: the
    /// entropy stops rising well before), seed 0.
    pub fn with_budget(budget: usize) -> FixedSizeOptions {
        FixedSizeOptions {
            budget,
            trials: 20_000,
            seed: 0,
        }
    }
}

/// A fixed-size solution: the active rows and Eq. (10)'s coefficients on them.
#[derive(Clone, Debug, PartialEq)]
pub struct FixedSizeSolution {
    /// Indices of the active rows (the support vectors), ascending.
    pub active: Vec<usize>,
    /// Coefficient a_j of each active row, target unit.
    pub alpha: Vec<f64>,
    /// Bias b, target unit.
    pub bias: f64,
    /// Rank r of the Nyström map (active points minus numerically redundant directions).
    pub rank: usize,
    /// Coefficients of the linear columns ([`solve_on_active_with`]), target unit per unit.
    pub linear: Vec<f64>,
}

/// The checks of [`solve_fixed_size`]: σ and c positive and finite, a non-empty budget and
/// data, lengths that agree, finite inputs and targets.
pub(crate) fn validate(
    z: &Rows,
    y: &[f64],
    sigma: f64,
    c: f64,
    opts: &FixedSizeOptions,
) -> Result<(), LssvmError> {
    for (name, value) in [("sigma", sigma), ("c", c)] {
        if !(value > 0.0 && value.is_finite()) {
            return Err(LssvmError::HyperParameter { name, value });
        }
    }
    let n = z.len();
    if n == 0 || opts.budget == 0 {
        return Err(LssvmError::Empty);
    }
    if n != y.len() {
        return Err(LssvmError::Length {
            inputs: n,
            targets: y.len(),
        });
    }
    if let Some(i) = z.data.iter().position(|v| !v.is_finite()) {
        return Err(LssvmError::NonFinite {
            what: "input",
            index: i / z.dim,
            feature: None,
        });
    }
    if let Some(i) = y.iter().position(|v| !v.is_finite()) {
        return Err(LssvmError::NonFinite {
            what: "target",
            index: i,
            feature: None,
        });
    }
    Ok(())
}

/// Solves the fixed-size LS-SVM on standardised rows `z` and targets `y` (see the module
/// doc). Validates σ, c, lengths and finiteness.
pub fn solve_fixed_size(
    z: &Rows,
    y: &[f64],
    sigma: f64,
    c: f64,
    opts: &FixedSizeOptions,
) -> Result<FixedSizeSolution, LssvmError> {
    validate(z, y, sigma, c, opts)?;
    let active = select_active_set(z, opts.budget, sigma, opts.trials, opts.seed);
    solve_on_active(z, y, sigma, c, active)
}

/// The primal solve of the module doc on a given active set (distinct row indices of `z`):
/// every row of `z` enters the fit, only the active rows become support vectors. Inputs are
/// assumed validated (as [`solve_fixed_size`] does).
pub fn solve_on_active(
    z: &Rows,
    y: &[f64],
    sigma: f64,
    c: f64,
    active: Vec<usize>,
) -> Result<FixedSizeSolution, LssvmError> {
    solve_on_active_with(z, y, &[], sigma, c, active)
}

/// [`solve_on_active`] with unregularised linear columns `lin` (each of length n) next to the
/// bias: the primal form of the partially linear LS-SVM, y ≈ Φw + b + Lβ with the ridge 1/c
/// on w only.
pub fn solve_on_active_with(
    z: &Rows,
    y: &[f64],
    lin: &[Vec<f64>],
    sigma: f64,
    c: f64,
    active: Vec<usize>,
) -> Result<FixedSizeSolution, LssvmError> {
    normal_on_active_with(z, y, lin, sigma, active)?.solve(c)
}

/// The normal equations of [`solve_on_active_with`] without the ridge 1/c: the kernel block,
/// the Nyström map and [Φ 1 L]ᵀ[Φ 1 L] depend on σ and the active set only, so a grid of c
/// values solves them once each instead of rebuilding them.
#[derive(Clone, Debug)]
pub struct ActiveNormal {
    active: Vec<usize>,
    p: Mat<f64>,
    g: Mat<f64>,
    h: Mat<f64>,
    r: usize,
    p_lin: usize,
}

/// Builds the [`ActiveNormal`] of `z`, `y`, `lin` at σ on `active` (see
/// [`solve_on_active_with`]).
pub fn normal_on_active_with(
    z: &Rows,
    y: &[f64],
    lin: &[Vec<f64>],
    sigma: f64,
    active: Vec<usize>,
) -> Result<ActiveNormal, LssvmError> {
    let n = z.len();
    if active.is_empty() || n != y.len() || active.iter().any(|&a| a >= n) {
        return Err(LssvmError::Empty);
    }
    if lin.iter().any(|col| col.len() != n) {
        return Err(LssvmError::Length {
            inputs: n,
            targets: y.len(),
        });
    }
    let p_lin = lin.len();
    let m = active.len();
    let inv = 1.0 / (2.0 * sigma * sigma);
    let kmm = Mat::<f64>::from_fn(m, m, |i, j| gauss(z.row(active[i]), z.row(active[j]), inv));
    let evd = kmm
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| LssvmError::Singular)?;
    let lam: Vec<f64> = (0..m).map(|k| evd.S()[k]).collect();
    let lmax = lam.iter().copied().fold(0.0, f64::max);
    let keep: Vec<usize> = (0..m).filter(|&k| lam[k] > EIG_REL_TOL * lmax).collect();
    let r = keep.len();
    if r == 0 {
        return Err(LssvmError::Singular);
    }
    // P = U_r Λ_r^{−1/2} (M×r): φ(x)ᵀ = k_M(x)ᵀ P, and α = P w.
    let p = Mat::<f64>::from_fn(m, r, |i, k| evd.U()[(i, keep[k])] / lam[keep[k]].sqrt());
    let active_flat: Vec<f64> = active
        .iter()
        .flat_map(|&a| z.row(a).iter().copied())
        .collect();

    // Normal equations of [Φ 1], accumulated chunk by chunk (in parallel over chunks). The
    // partial sums are collected in chunk order and added serially, so the result does not
    // depend on how the work was split between threads.
    let parts: Vec<(Mat<f64>, Mat<f64>)> = (0..n.div_ceil(CHUNK_ROWS))
        .into_par_iter()
        .map(|ch| {
            let lo = ch * CHUNK_ROWS;
            let hi = (lo + CHUNK_ROWS).min(n);
            let mut kr = vec![0.0; (hi - lo) * m];
            for (i, row) in kr.chunks_mut(m).enumerate() {
                gauss_rows(&active_flat, z.dim, z.row(lo + i), inv, row);
            }
            let kc = Mat::<f64>::from_fn(hi - lo, m, |i, j| kr[i * m + j]);
            let phi = &kc * &p;
            let aug = Mat::<f64>::from_fn(hi - lo, r + 1 + p_lin, |i, k| match k {
                k if k < r => phi[(i, k)],
                k if k == r => 1.0,
                k => lin[k - r - 1][lo + i],
            });
            let g = aug.transpose() * &aug;
            let yc = Mat::<f64>::from_fn(hi - lo, 1, |i, _| y[lo + i]);
            let h = aug.transpose() * &yc;
            (g, h)
        })
        .collect();
    let mut g = Mat::<f64>::zeros(r + 1 + p_lin, r + 1 + p_lin);
    let mut h = Mat::<f64>::zeros(r + 1 + p_lin, 1);
    for (gp, hp) in &parts {
        g += gp;
        h += hp;
    }
    Ok(ActiveNormal {
        active,
        p,
        g,
        h,
        r,
        p_lin,
    })
}

impl ActiveNormal {
    /// The solution at regularisation `c`.
    pub fn solve(&self, c: f64) -> Result<FixedSizeSolution, LssvmError> {
        if !(c > 0.0 && c.is_finite()) {
            return Err(LssvmError::HyperParameter {
                name: "c",
                value: c,
            });
        }
        let (r, p_lin, m) = (self.r, self.p_lin, self.active.len());
        let (p, h) = (&self.p, &self.h);
        let mut g = self.g.clone();
        for k in 0..r {
            g[(k, k)] += 1.0 / c;
        }
        let llt = g.llt(Side::Lower).map_err(|e| match e {
            faer::linalg::solvers::LltError::NonPositivePivot { index } => {
                LssvmError::NotPositiveDefinite { pivot: index }
            }
        })?;
        let wb = llt.solve(&h);
        let w = wb.as_ref().subrows(0, r);
        let alpha_m = p * w;
        let alpha: Vec<f64> = (0..m).map(|i| alpha_m[(i, 0)]).collect();
        let bias = wb[(r, 0)];
        let linear: Vec<f64> = (0..p_lin).map(|k| wb[(r + 1 + k, 0)]).collect();
        if !(bias.is_finite() && alpha.iter().chain(&linear).all(|a| a.is_finite())) {
            return Err(LssvmError::Singular);
        }
        Ok(FixedSizeSolution {
            active: self.active.clone(),
            alpha,
            bias,
            rank: r,
            linear,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lssvm::solve::solve_dense_reference;

    /// The shared scattered 2-D fixture, as rows.
    fn data(n: usize) -> (Rows, Vec<f64>) {
        let (z, y) = crate::lssvm::test_data::scattered(n);
        (Rows::from_rows(&z), y)
    }

    fn predict(z: &Rows, s: &FixedSizeSolution, x: &[f64], sigma: f64) -> f64 {
        let inv = 1.0 / (2.0 * sigma * sigma);
        s.active
            .iter()
            .zip(&s.alpha)
            .map(|(&a, al)| al * gauss(z.row(a), x, inv))
            .sum::<f64>()
            + s.bias
    }

    /// Largest |f_fixed(x) − f_exact(x)| over a test grid, against the dense LU solution of
    /// the full Eq. (9).
    fn max_dev_from_exact(n: usize, m: usize, sigma: f64, c: f64) -> f64 {
        let (z, y) = data(n);
        let zr: Vec<Vec<f64>> = (0..n).map(|i| z.row(i).to_vec()).collect();
        let exact = solve_dense_reference(&zr, &y, sigma, c).unwrap();
        let fs = solve_fixed_size(&z, &y, sigma, c, &FixedSizeOptions::with_budget(m)).unwrap();
        let inv = 1.0 / (2.0 * sigma * sigma);
        let mut worst = 0.0f64;
        for gx in 0..15 {
            for gy in 0..15 {
                let x = [-1.6 + 0.23 * f64::from(gx), -1.6 + 0.23 * f64::from(gy)];
                let fe = zr
                    .iter()
                    .zip(&exact.alpha)
                    .map(|(sv, a)| a * gauss(sv, &x, inv))
                    .sum::<f64>()
                    + exact.bias;
                worst = worst.max((predict(&z, &fs, &x, sigma) - fe).abs());
            }
        }
        worst
    }

    /// With every point active the Nyström map is exact and the primal solution is Eq. (9)'s.
    #[test]
    fn full_active_set_reproduces_the_exact_solution() {
        let d = max_dev_from_exact(80, 80, 1.0, 100.0);
        assert!(d < 1e-7, "max deviation {d}");
    }

    /// The approximation error shrinks as the active set grows towards n.
    #[test]
    fn deviation_from_exact_shrinks_as_m_grows() {
        let (sigma, c) = (0.7, 100.0);
        let devs: Vec<f64> = [8, 24, 60, 150]
            .iter()
            .map(|&m| max_dev_from_exact(150, m, sigma, c))
            .collect();
        assert!(devs.windows(2).all(|w| w[1] < w[0]), "{devs:?}");
        assert!(devs[0] > 1e-3 && devs[3] < 1e-7, "{devs:?}");
    }

    /// The swap search raises the entropy above that of random subsets of the same size, and
    /// its running sums agree with the direct evaluation.
    #[test]
    fn renyi_active_set_beats_random_subsets() {
        let (z, _) = data(2000);
        let (m, sigma) = (32, 0.5);
        let active = select_active_set(&z, m, sigma, 20_000, 1);
        assert_eq!(active.len(), m);
        assert!(active.windows(2).all(|w| w[0] < w[1]), "distinct, sorted");
        let h = renyi_entropy(&z, &active, sigma);
        let mut rng = ChaCha8Rng::seed_from_u64(99);
        let best_random = (0..50)
            .map(|_| renyi_entropy(&z, &index::sample(&mut rng, 2000, m).into_vec(), sigma))
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(
            h > best_random + 0.05,
            "rényi {h} vs best random {best_random}"
        );
        // Zero trials leaves the random start: the search must have improved on it.
        let start = select_active_set(&z, m, sigma, 0, 1);
        assert!(h > renyi_entropy(&z, &start, sigma));
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let (z, y) = data(20);
        let o = FixedSizeOptions::with_budget(5);
        assert!(matches!(
            solve_fixed_size(&z, &y, 0.0, 1.0, &o),
            Err(LssvmError::HyperParameter { name: "sigma", .. })
        ));
        assert!(matches!(
            solve_fixed_size(&z, &y[..3], 1.0, 1.0, &o),
            Err(LssvmError::Length { .. })
        ));
        let mut y2 = y.clone();
        y2[4] = f64::INFINITY;
        assert!(matches!(
            solve_fixed_size(&z, &y2, 1.0, 1.0, &o),
            Err(LssvmError::NonFinite { index: 4, .. })
        ));
        // Identical inputs: K_MM has rank 1; the map keeps one direction and fits the mean.
        let same = Rows {
            data: vec![0.5; 20],
            dim: 2,
        };
        let ys = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0];
        let s = solve_fixed_size(&same, &ys, 1.0, 1.0, &o).unwrap();
        assert_eq!(s.rank, 1);
        let f = predict(&same, &s, &[0.5, 0.5], 1.0);
        assert!((f - 5.5).abs() < 1e-9, "{f}");
    }
}
