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

use super::kernel::gauss_rows;

/// The preconditioner P = L·Lᵀ + D with D = diag(d) + I/c.
pub struct LowRank {
    /// n×r factor.
    l: Mat<f64>,
    /// 1 / D.
    d_inv: Vec<f64>,
    /// Cholesky factor of I + LᵀD⁻¹L.
    inner: faer::linalg::solvers::Llt<f64>,
    /// Largest diagonal entry of K − L·Lᵀ.
    remaining: f64,
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
        let n = z.len();
        let dim = z.first().map_or(0, Vec::len);
        let flat: Vec<f64> = z.iter().flat_map(|r| r.iter().copied()).collect();
        let inv = 1.0 / (2.0 * sigma * sigma);
        let max_rank = max_rank.min(n);
        // L column-major, grown one column at a time (the rank is usually far below
        // `max_rank`).
        let mut lbuf: Vec<f64> = Vec::new();
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
            rank += 1;
        }
        let l = MatRef::from_column_major_slice(&lbuf, n, rank).to_owned();
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
            inner,
            remaining,
        })
    }

    /// Columns of L.
    pub fn rank(&self) -> usize {
        self.l.ncols()
    }

    /// Largest diagonal entry of K − L·Lᵀ, the part of K the factor leaves out.
    pub fn remaining(&self) -> f64 {
        self.remaining
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
}
