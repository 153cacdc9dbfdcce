//! A low-rank preconditioner for H = K + I/c: the partial pivoted Cholesky factor of the
//! Gaussian kernel matrix (Harbrecht, Peters & Schneider 2012), with the diagonal it leaves
//! unexplained, P = L·Lᵀ + diag(d) + I/c.
//!
//! The Gaussian kernel on two or three standardised inputs has eigenvalues that fall off
//! faster than geometrically, so a rank of a few hundred captures K to well below 1/c and
//! P⁻¹H has its eigenvalues in a narrow band above 1: conjugate gradients on the exact f64 H
//! then converge in a few tens of steps, each one O(n²) product, and no O(n³) factorisation is
//! needed. Building L costs O(n·r²) flops and r columns of K, which are computed from the
//! inputs (O(n) exponentials each) rather than read from the stored triangle, whose rows are
//! strided in memory. P⁻¹ is applied by the Woodbury identity through the r×r matrix
//! I + LᵀD⁻¹L (D = diag(d) + I/c), which is ≥ I and so safe to factorise. Gardner et al.
//! (2018) use the same preconditioner for Gaussian-process solves; no crate offers it on a
//! dense faer matrix, hence this module.

use faer::linalg::matmul::matmul;
use faer::prelude::*;
use faer::{Accum, Par, Side};

use rayon::prelude::*;

use super::kernel::gauss_rows;
#[cfg(doc)]
use super::packed::PackedLower;

/// The preconditioner P = L·Lᵀ + D with D = diag(d) + I/c.
pub struct LowRank {
    /// n×r factor.
    l: Mat<f64>,
    /// 1 / D.
    d_inv: Vec<f64>,
    /// Remaining diagonal of K − L·Lᵀ as computed (before rounding's negatives are cut to 0).
    rest: Vec<f64>,
    /// Cholesky factor of I + LᵀD⁻¹L.
    inner: faer::linalg::solvers::Llt<f64>,
    /// Largest diagonal entry of K − L·Lᵀ.
    remaining: f64,
}

/// The steps of a partial pivoted Cholesky of the Gaussian kernel matrix, taken down to one
/// tolerance: the pivots do not depend on where the steps stop, so the factor for any larger
/// tolerance is a prefix of these columns ([`PivotPath::low_rank`]), the same bits as a
/// factorisation stopped there.
pub struct PivotPath {
    n: usize,
    /// The columns of L, column-major.
    lbuf: Vec<f64>,
    /// Pivot row of each column.
    pivots: Vec<usize>,
    /// The largest remaining diagonal before each column (its pivot's), and after the last
    /// when the steps stopped on the tolerance rather than on the rank.
    largest: Vec<f64>,
}

impl PivotPath {
    /// The steps for the rows of `z` (width σ): pivots are taken while the largest remaining
    /// diagonal exceeds `tol` and fewer than `max_rank` columns exist.
    pub fn new(z: &[Vec<f64>], sigma: f64, max_rank: usize, tol: f64) -> PivotPath {
        let n = z.len();
        let dim = z.first().map_or(0, Vec::len);
        let flat: Vec<f64> = z.iter().flat_map(|r| r.iter().copied()).collect();
        let inv = 1.0 / (2.0 * sigma * sigma);
        let max_rank = max_rank.min(n);
        // L column-major, grown one column at a time (the rank is usually far below
        // `max_rank`).
        let mut lbuf: Vec<f64> = Vec::new();
        let mut pivots = Vec::new();
        let mut largest = Vec::new();
        // Remaining diagonal of K − L·Lᵀ (K's diagonal is 1).
        let mut d = vec![1.0f64; n];
        let mut rank = 0;
        while rank < max_rank {
            let (p, dp) =
                d.iter()
                    .copied()
                    .enumerate()
                    .fold(
                        (0, f64::NEG_INFINITY),
                        |b, (i, v)| if v > b.1 { (i, v) } else { b },
                    );
            largest.push(dp);
            if dp.is_nan() || dp <= tol {
                break;
            }
            let zp = &flat[p * dim..(p + 1) * dim];
            let mut k = vec![0.0; n];
            gauss_rows(&flat, dim, zp, inv, &mut k);
            let mut col = Mat::<f64>::from_fn(n, 1, |i, _| k[i]);
            if rank > 0 {
                // col −= L·L[p, :]ᵀ
                let l = MatRef::from_column_major_slice(&lbuf, n, rank);
                let lp = Mat::<f64>::from_fn(rank, 1, |k, _| l[(p, k)]);
                matmul(col.as_mut(), Accum::Add, l, lp.as_ref(), -1.0, Par::Seq);
            }
            let s = 1.0 / dp.sqrt();
            for i in 0..n {
                let v = col[(i, 0)] * s;
                lbuf.push(v);
                d[i] -= v * v;
            }
            d[p] = 0.0;
            pivots.push(p);
            rank += 1;
        }
        PivotPath {
            n,
            lbuf,
            pivots,
            largest,
        }
    }

    /// The preconditioner of the steps a factorisation stopped at `tol` (at least the
    /// path's) would take, with `shift` = 1/c: [`LowRank::build`]'s result.
    pub fn low_rank(&self, tol: f64, shift: f64) -> Option<LowRank> {
        let n = self.n;
        let rank = self
            .largest
            .iter()
            .position(|dp| dp.is_nan() || *dp <= tol)
            .unwrap_or(self.pivots.len());
        // The remaining diagonal after `rank` columns, in the order the steps formed it.
        let mut d = vec![1.0f64; n];
        for (col, &p) in self
            .lbuf
            .chunks_exact(n.max(1))
            .zip(&self.pivots)
            .take(rank)
        {
            for (di, v) in d.iter_mut().zip(col) {
                *di -= v * v;
            }
            d[p] = 0.0;
        }
        let l = MatRef::from_column_major_slice(&self.lbuf[..n * rank], n, rank).to_owned();
        // Rounding can leave a remaining diagonal slightly negative: it is ≥ 0 in exact
        // arithmetic.
        let d_inv: Vec<f64> = d.iter().map(|v| 1.0 / (v.max(0.0) + shift)).collect();
        let dl = Mat::<f64>::from_fn(n, rank, |i, j| l[(i, j)] * d_inv[i]);
        let mut inner = Mat::<f64>::identity(rank, rank);
        matmul(
            inner.as_mut(),
            Accum::Add,
            l.transpose(),
            dl.as_ref(),
            1.0,
            Par::Seq,
        );
        let inner = inner.llt(Side::Lower).ok()?;
        let remaining = d.iter().copied().fold(0.0, f64::max);
        Some(LowRank {
            l,
            d_inv,
            rest: d,
            inner,
            remaining,
        })
    }
}

impl LowRank {
    /// Partial pivoted Cholesky of the Gaussian kernel matrix of the rows of `z` (width σ):
    /// pivots are taken while the largest remaining diagonal exceeds `tol` and fewer than
    /// `max_rank` columns exist; `shift` is H's diagonal excess 1/c. `None` if the inner
    /// matrix cannot be factorised (only for non-finite inputs).
    pub fn build(
        z: &[Vec<f64>],
        sigma: f64,
        shift: f64,
        max_rank: usize,
        tol: f64,
    ) -> Option<LowRank> {
        PivotPath::new(z, sigma, max_rank, tol).low_rank(tol, shift)
    }

    /// Columns of L.
    pub fn rank(&self) -> usize {
        self.l.ncols()
    }

    /// Largest diagonal entry of K − L·Lᵀ, the part of K the factor leaves out.
    pub fn remaining(&self) -> f64 {
        self.remaining
    }

    /// diag(H⁻¹) for H = K + I/c (`h`, its packed lower triangle; `shift` = 1/c as built)
    /// without an O(n³) step, and a bound on its error.
    ///
    /// With E = H − P = (K − L·Lᵀ) − diag(d), H⁻¹ = P⁻¹ − P⁻¹EP⁻¹ + Σ_{k≥2} P⁻¹(−EP⁻¹)ᵏ.
    /// The first two terms are computed exactly in O(n²·r) (one product of H with r
    /// columns); the rest is bounded, not computed: P ⪰ I/c gives ‖P⁻¹‖ ≤ c, and K − L·Lᵀ is
    /// positive semi-definite with diagonal d, so ‖E‖ ≤ Σd and, with ρ = c·Σd < 1, every
    /// entry of the rest is at most c·ρ²/(1 − ρ) (Σd is padded for the rounding of d). The
    /// closed-form LOO residuals need only this diagonal (`solve::solve_with_loo`); a dense
    /// Cholesky and triangular inverse cost 2n³/3 flops for it. `None` when ρ ≥ 1.
    pub fn inverse_diagonal(
        &self,
        z: &[Vec<f64>],
        sigma: f64,
        shift: f64,
    ) -> Option<(Vec<f64>, f64)> {
        let (n, r) = (self.l.nrows(), self.l.ncols());
        let c = 1.0 / shift;
        let sum_d =
            self.rest.iter().map(|v| v.abs()).sum::<f64>() + (n * (r + 1)) as f64 * f64::EPSILON;
        let rho = c * sum_d;
        if rho.is_nan() || rho >= 1.0 {
            return None;
        }
        let bound = c * rho * rho / (1.0 - rho);
        // U = D⁻¹L; Y = U·G with G = (I + LᵀD⁻¹L)⁻¹, so that P⁻¹ = D⁻¹ − Y·Uᵀ.
        let u = Mat::<f64>::from_fn(n, r, |i, k| self.l[(i, k)] * self.d_inv[i]);
        let mut yt = u.transpose().to_owned();
        self.inner.solve_in_place(&mut yt);
        // F = E·U = K·U − L·(LᵀU) − diag(d')·U, d' the remaining diagonal P holds.
        let ku = kernel_times(z, sigma, u.as_ref());
        let ltu = self.l.transpose() * &u;
        let l_ltu = &self.l * &ltu;
        let f = Mat::<f64>::from_fn(n, r, |i, k| {
            let dp = 1.0 / self.d_inv[i] - shift;
            ku[(i, k)] - l_ltu[(i, k)] - dp * u[(i, k)]
        });
        // (P⁻¹)_ii = D⁻¹_i − u_i·y_i and (P⁻¹EP⁻¹)_ii = y_iᵀ(UᵀF)y_i − 2·D⁻¹_i·f_i·y_i (its
        // D⁻¹ED⁻¹ part is E_ii = 0), u_i, f_i, y_i the rows i: dots down the columns of the
        // r×n transposes.
        let my = (u.transpose() * &f) * &yt;
        let ut = u.transpose().to_owned();
        let ft = f.transpose().to_owned();
        let dot = |a: &Mat<f64>, b: &Mat<f64>, i: usize| -> f64 {
            a.col(i)
                .iter()
                .zip(b.col(i).iter())
                .map(|(x, y)| x * y)
                .sum()
        };
        let diag = (0..n)
            .map(|i| {
                let p_ii = self.d_inv[i] - dot(&ut, &yt, i);
                p_ii - (dot(&yt, &my, i) - 2.0 * self.d_inv[i] * dot(&ft, &yt, i))
            })
            .collect();
        Some((diag, bound))
    }

    /// P⁻¹·v = D⁻¹v − D⁻¹L (I + LᵀD⁻¹L)⁻¹ LᵀD⁻¹v, column by column.
    pub fn apply_inverse(&self, v: MatRef<'_, f64>) -> Mat<f64> {
        let (n, m) = (v.nrows(), v.ncols());
        let dv = Mat::<f64>::from_fn(n, m, |i, j| v[(i, j)] * self.d_inv[i]);
        let mut w = self.l.transpose() * &dv;
        self.inner.solve_in_place(&mut w);
        let lw = &self.l * &w;
        Mat::<f64>::from_fn(n, m, |i, j| dv[(i, j)] - self.d_inv[i] * lw[(i, j)])
    }
}

/// K·U for the Gaussian kernel matrix K of the rows of `z` (width σ), without holding K: its
/// columns are computed a block at a time and each block multiplied by faer's product, so
/// that memory stays O(n·block) while the work is the dense product's (the packed product
/// of [`PackedLower::mul`] streams every column of U past every column of H, which for
/// a hundred columns is slower than recomputing the kernel).
pub fn kernel_times(z: &[Vec<f64>], sigma: f64, u: MatRef<'_, f64>) -> Mat<f64> {
    const BLOCK: usize = 256;
    let n = z.len();
    let dim = z.first().map_or(0, Vec::len);
    let flat: Vec<f64> = z.iter().flat_map(|r| r.iter().copied()).collect();
    let inv = 1.0 / (2.0 * sigma * sigma);
    let mut out = Mat::<f64>::zeros(n, u.ncols());
    let mut block = vec![0.0f64; n * BLOCK.min(n)];
    let mut j0 = 0;
    while j0 < n {
        let w = BLOCK.min(n - j0);
        block[..n * w]
            .par_chunks_mut(n)
            .enumerate()
            .for_each(|(k, col)| {
                let j = j0 + k;
                gauss_rows(&flat, dim, &flat[j * dim..(j + 1) * dim], inv, col);
            });
        let kb = MatRef::from_column_major_slice(&block[..n * w], n, w);
        matmul(
            out.as_mut(),
            Accum::Add,
            kb,
            u.subrows(j0, w),
            1.0,
            faer::get_global_parallelism(),
        );
        j0 += w;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lssvm::kernel_matrix;
    use crate::lssvm::test_data::scattered;

    /// P⁻¹ applied to P·v gives v back, and at full rank P is H itself.
    #[test]
    fn woodbury_inverse_is_the_inverse_of_p() {
        let n = 120;
        let (z, _) = scattered(n);
        let (sigma, c) = (0.7, 50.0);
        let k = kernel_matrix(&z, sigma);
        for max_rank in [5, 30, n] {
            let p = LowRank::build(&z, sigma, 1.0 / c, max_rank, 0.0).unwrap();
            assert!(p.rank() <= max_rank);
            // P = L·Lᵀ + D, D from d_inv.
            let mut pm = &p.l * p.l.transpose();
            for i in 0..n {
                pm[(i, i)] += 1.0 / p.d_inv[i];
            }
            let v = Mat::<f64>::from_fn(n, 2, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0);
            let back = p.apply_inverse((&pm * &v).as_ref());
            let err = (0..n)
                .flat_map(|i| (0..2).map(move |j| (i, j)))
                .map(|(i, j)| (back[(i, j)] - v[(i, j)]).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-8, "rank {}: {err:e}", p.rank());
            if p.rank() == n {
                // Full rank: L·Lᵀ reproduces K and D is I/c.
                let dk = (0..n)
                    .flat_map(|i| (0..n).map(move |j| (i, j)))
                    .map(|(i, j)| {
                        (pm[(i, j)] - k[(i, j)] - if i == j { 1.0 / c } else { 0.0 }).abs()
                    })
                    .fold(0.0, f64::max);
                assert!(dk < 1e-10, "{dk:e}");
            }
        }
    }

    /// The pivoted Cholesky stops at the tolerance: the remaining diagonal is then ≤ tol, and
    /// the Gaussian kernel on 2-D inputs needs far fewer than n columns for it.
    #[test]
    fn stops_at_the_tolerance_with_a_small_rank() {
        let n = 2000;
        let (z, _) = scattered(n);
        let p = LowRank::build(&z, 0.67, 1.0 / 42.0, n, 1e-6).unwrap();
        let shift = 1.0 / 42.0;
        let worst = p.d_inv.iter().map(|v| 1.0 / v - shift).fold(0.0, f64::max);
        assert!(worst <= 1e-6 + 1e-12, "{worst:e}");
        assert!(p.rank() < n / 4, "rank {}", p.rank());
    }

    /// A factor read off a path taken to a tighter tolerance is the factor built to its own
    /// tolerance, bit for bit.
    #[test]
    fn a_path_prefix_is_the_stopped_factor() {
        let n = 300;
        let (z, _) = scattered(n);
        let sigma = 0.5;
        let path = PivotPath::new(&z, sigma, 80, 1e-12);
        let v = Mat::<f64>::from_fn(n, 2, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0);
        for c in [1e-2, 1.0, 1e3, 1e6] {
            let (tol, shift) = (1e-6 / c, 1.0 / c);
            let a = path.low_rank(tol, shift).unwrap();
            let b = LowRank::build(&z, sigma, shift, 80, tol).unwrap();
            assert_eq!(a.rank(), b.rank(), "c {c}");
            assert_eq!(a.remaining().to_bits(), b.remaining().to_bits());
            let (pa, pb) = (a.apply_inverse(v.as_ref()), b.apply_inverse(v.as_ref()));
            for j in 0..2 {
                for i in 0..n {
                    assert_eq!(pa[(i, j)].to_bits(), pb[(i, j)].to_bits(), "c {c}");
                }
            }
        }
    }
}
