//! H = K + I/c stored as its packed lower triangle (column by column, n(n+1)/2 values, half
//! the memory of the square), with a one-pass symmetric product H·X.
//!
//! Conjugate gradients spend their time in H·X, which is bound by memory traffic: faer's
//! triangular products read the stored triangle twice (once as L, once as the strict upper
//! part Lᵀ), this product reads each entry once and uses it for both its row and its column
//! (BLAS `dspmv` does the same; faer has no packed symmetric product, hence this module).
//! The work is cut into a fixed number of column blocks of equal size whatever the thread
//! count, and the blocks' partial results are added in block order: the product has the same
//! bits on one thread or many.

use rayon::prelude::*;

use super::kernel::gauss_rows;

/// Column blocks of [`PackedLower::mul`] (fixed: the sum order must not depend on threads).
const BLOCKS: usize = 16;

/// The packed lower triangle of H.
pub struct PackedLower {
    n: usize,
    data: Vec<f64>,
}

/// Offset of column j in the packed storage of an n×n lower triangle.
fn offset(n: usize, j: usize) -> usize {
    // Σ_{k<j} (n − k)
    j * n - j * j.saturating_sub(1) / 2
}

impl PackedLower {
    /// H_ij = exp(−‖z_i − z_j‖²/2σ²) + δ_ij/c for i ≥ j, columns filled in parallel on the
    /// rayon pool (the same values, bit for bit, as [`super::mixed::h_lower`]).
    pub fn gaussian(z: &[Vec<f64>], sigma: f64, c: f64) -> PackedLower {
        let n = z.len();
        let dim = z.first().map_or(0, Vec::len);
        let flat: Vec<f64> = z.iter().flat_map(|r| r.iter().copied()).collect();
        let inv = 1.0 / (2.0 * sigma * sigma);
        let diag = 1.0 + 1.0 / c;
        let mut data = vec![0.0f64; n * (n + 1) / 2];
        let cols = split_columns(&mut data, n);
        cols.into_par_iter().with_max_len(16).for_each(|(j, col)| {
            let zj = &flat[j * dim..(j + 1) * dim];
            col[0] = diag;
            gauss_rows(&flat[(j + 1) * dim..], dim, zj, inv, &mut col[1..]);
        });
        PackedLower { n, data }
    }

    /// Sets the diagonal to 1 + 1/c (the Gaussian kernel's K_ii = 1): the same H as
    /// [`PackedLower::gaussian`] at that c, without refilling the kernel.
    pub fn set_diagonal(&mut self, c: f64) {
        let diag = 1.0 + 1.0 / c;
        for j in 0..self.n {
            self.data[offset(self.n, j)] = diag;
        }
    }

    /// Order of H.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Column j from the diagonal down: H_jj, H_j+1,j, …, H_n−1,j.
    pub fn column(&self, j: usize) -> &[f64] {
        let start = offset(self.n, j);
        &self.data[start..start + self.n - j]
    }

    /// The lower triangle in a column-major n×n buffer (strict upper part 0), the layout of
    /// [`super::mixed::h_lower`].
    pub fn to_square_lower(&self) -> Vec<f64> {
        let n = self.n;
        let mut out = vec![0.0f64; n * n];
        for j in 0..n {
            out[j * n + j..(j + 1) * n].copy_from_slice(self.column(j));
        }
        out
    }

    /// H·X for the m columns of the column-major n×m `x`; returns the column-major n×m product.
    pub fn mul(&self, x: &[f64], m: usize) -> Vec<f64> {
        let n = self.n;
        assert_eq!(x.len(), n * m, "x must be n×m");
        if n == 0 {
            return Vec::new();
        }
        // Block boundaries with about equal numbers of entries.
        let total = self.data.len();
        let mut bounds = vec![0usize];
        let mut j = 0;
        for b in 1..BLOCKS {
            let target = total * b / BLOCKS;
            while j < n && offset(n, j) < target {
                j += 1;
            }
            bounds.push(j);
        }
        bounds.push(n);
        let partials: Vec<Vec<f64>> = bounds
            .par_windows(2)
            .map(|w| {
                let mut y = vec![0.0f64; n * m];
                for j in w[0]..w[1] {
                    let col = self.column(j);
                    for k in 0..m {
                        let xk = &x[k * n..(k + 1) * n];
                        let yk = &mut y[k * n..(k + 1) * n];
                        let dot = axpy_dot(&col[1..], xk[j], &xk[j + 1..], &mut yk[j + 1..]);
                        yk[j] += col[0] * xk[j] + dot;
                    }
                }
                y
            })
            .collect();
        let mut y = vec![0.0f64; n * m];
        for p in &partials {
            for (a, b) in y.iter_mut().zip(p) {
                *a += b;
            }
        }
        y
    }
}

/// y ← y + s·col and returns colᵀx, in one pass; four independent partial sums so that the
/// compiler can keep the dot product in vector registers (a single running sum would fix the
/// order of the additions and forbid it).
fn axpy_dot(col: &[f64], s: f64, x: &[f64], y: &mut [f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let (c4, cr) = col.split_at(col.len() - col.len() % 4);
    let (x4, xr) = x.split_at(c4.len());
    let (y4, yr) = y.split_at_mut(c4.len());
    for ((c, xx), yy) in c4
        .chunks_exact(4)
        .zip(x4.chunks_exact(4))
        .zip(y4.chunks_exact_mut(4))
    {
        for l in 0..4 {
            yy[l] += s * c[l];
            acc[l] += c[l] * xx[l];
        }
    }
    let mut dot = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for ((c, xx), yy) in cr.iter().zip(xr).zip(yr) {
        *yy += s * c;
        dot += c * xx;
    }
    dot
}

/// The packed storage cut into its columns, each with its index.
fn split_columns(data: &mut [f64], n: usize) -> Vec<(usize, &mut [f64])> {
    let mut out = Vec::with_capacity(n);
    let mut rest = data;
    for j in 0..n {
        let (col, tail) = rest.split_at_mut(n - j);
        out.push((j, col));
        rest = tail;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lssvm::mixed::h_lower;
    use crate::lssvm::test_data::scattered;

    /// Same entries as the square lower triangle, and H·X equal to the dense product to
    /// rounding, on one thread and two with the same bits.
    #[test]
    fn packed_product_matches_the_dense_one() {
        let n = 301;
        let (z, _) = scattered(n);
        let (sigma, c) = (0.7, 50.0);
        let sq = h_lower(&z, sigma, c);
        let p = PackedLower::gaussian(&z, sigma, c);
        assert_eq!(p.n(), n);
        assert!(p
            .to_square_lower()
            .iter()
            .zip(&sq)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        let m = 3;
        let x: Vec<f64> = (0..n * m)
            .map(|i| ((i * 37 % 101) as f64 - 50.0) / 7.0)
            .collect();
        let y = p.mul(&x, m);
        for k in 0..m {
            for i in 0..n {
                let want: f64 = (0..n)
                    .map(|j| {
                        let h = if i >= j { sq[j * n + i] } else { sq[i * n + j] };
                        h * x[k * n + j]
                    })
                    .sum();
                let got = y[k * n + i];
                assert!(
                    (got - want).abs() <= 1e-12 * want.abs().max(1.0),
                    "{i},{k}: {got} vs {want}"
                );
            }
        }
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let y1 = one.install(|| p.mul(&x, m));
        assert!(y.iter().zip(&y1).all(|(a, b)| a.to_bits() == b.to_bits()));
    }

    #[test]
    fn offsets_follow_the_columns() {
        let n = 7;
        let mut sum = 0;
        for j in 0..n {
            assert_eq!(offset(n, j), sum);
            sum += n - j;
        }
    }
}
