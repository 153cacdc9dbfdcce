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
use wide::f64x4;

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

    /// The principal submatrix on the rows and columns `keep` (increasing): the packed H of
    /// those points, the same bits as a fill of them.
    pub fn principal(&self, keep: &[usize]) -> PackedLower {
        let n = keep.len();
        let mut data = Vec::with_capacity(n * (n + 1) / 2);
        for (a, &j) in keep.iter().enumerate() {
            let col = self.column(j);
            data.extend(keep[a..].iter().map(|&i| col[i - j]));
        }
        PackedLower { n, data }
    }

    /// H_ij (either order of i, j).
    pub fn entry(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        self.column(j)[i - j]
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
        self.mul_with(x, m, |_, stored| stored)
    }

    /// (K + (d_k − 1)·I)·x_k for each column x_k of the column-major `x` (n × `diag.len()`):
    /// the product with the stored kernel part and a diagonal of the caller's per column, so
    /// that one pass over the triangle serves the systems of several c (d = 1 + 1/c). A
    /// column's bits are those of [`PackedLower::mul`] with the diagonal set to its d.
    pub fn mul_diagonal(&self, x: &[f64], diag: &[f64]) -> Vec<f64> {
        self.mul_with(x, diag.len(), |k, _| diag[k])
    }

    /// The product with column k's diagonal entry `diag(k, stored)`.
    fn mul_with(&self, x: &[f64], m: usize, diag: impl Fn(usize, f64) -> f64 + Sync) -> Vec<f64> {
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
                    // Four columns of X at a time: their dot products are independent
                    // chains of additions, so the core overlaps them.
                    let mut k = 0;
                    for (xs, ys) in x.chunks(4 * n).zip(y.chunks_mut(4 * n)) {
                        let dots = match xs.len() / n {
                            4 => axpy_dots::<4>(col, j, xs, ys, n).to_vec(),
                            3 => axpy_dots::<3>(col, j, xs, ys, n).to_vec(),
                            2 => axpy_dots::<2>(col, j, xs, ys, n).to_vec(),
                            _ => axpy_dots::<1>(col, j, xs, ys, n).to_vec(),
                        };
                        for (q, dot) in dots.into_iter().enumerate() {
                            ys[q * n + j] += diag(k + q, col[0]) * xs[q * n + j] + dot;
                        }
                        k += xs.len() / n;
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

/// For each of the K columns x_q, y_q of the column-major `xs`, `ys` (n rows each) below
/// row j: y_q ← y_q + x_qj·h and returns hᵀx_q, h = `col` below its diagonal, in one pass
/// over h. Each dot product keeps four partial sums, lane l taking the entries l, l + 4, …
/// (a single running sum would fix the order of the additions and forbid vector
/// registers), written with `wide`'s four lanes because the compiler left the plain loop
/// scalar. Products and sums are separate roundings (no fused multiply-add), and a column's
/// operations do not depend on K: its bits are the same alone or beside others.
fn axpy_dots<const K: usize>(
    col: &[f64],
    j: usize,
    xs: &[f64],
    ys: &mut [f64],
    n: usize,
) -> [f64; K] {
    let h = &col[1..];
    let len = h.len();
    let mut xq = xs.chunks_exact(n);
    let x: [&[f64]; K] = std::array::from_fn(|_| &xq.next().expect("K columns")[j + 1..]);
    let mut yq = ys.chunks_exact_mut(n);
    let mut y: [&mut [f64]; K] =
        std::array::from_fn(|_| &mut yq.next().expect("K columns")[j + 1..]);
    let s: [f64; K] = std::array::from_fn(|q| xs[q * n + j]);
    let s4 = s.map(f64x4::splat);
    let mut acc = [f64x4::ZERO; K];
    let body = len - len % 4;
    let mut i = 0;
    while i < body {
        let hv = lanes(&h[i..i + 4]);
        for q in 0..K {
            let yv = lanes(&y[q][i..i + 4]) + s4[q] * hv;
            y[q][i..i + 4].copy_from_slice(&yv.to_array());
            acc[q] += hv * lanes(&x[q][i..i + 4]);
        }
        i += 4;
    }
    std::array::from_fn(|q| {
        let a = acc[q].to_array();
        let mut dot = (a[0] + a[1]) + (a[2] + a[3]);
        for i in body..len {
            y[q][i] += s[q] * h[i];
            dot += h[i] * x[q][i];
        }
        dot
    })
}

/// Four consecutive values as one vector.
#[inline]
fn lanes(v: &[f64]) -> f64x4 {
    f64x4::from([v[0], v[1], v[2], v[3]])
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

    /// A column's product does not depend on the columns beside it or on how its diagonal is
    /// given, and a principal submatrix is the fill of its points.
    #[test]
    fn shifted_products_and_submatrices_keep_their_bits() {
        let n = 203;
        let (z, _) = scattered(n);
        let sigma = 0.7;
        let x: Vec<f64> = (0..n * 5)
            .map(|i| ((i * 37 % 101) as f64 - 50.0) / 7.0)
            .collect();
        let cs = [0.5, 2.0, 9.0, 40.0, 1e4];
        let diag: Vec<f64> = cs.iter().map(|c| 1.0 + 1.0 / c).collect();
        let p = PackedLower::gaussian(&z, sigma, 1.0);
        let all = p.mul_diagonal(&x, &diag);
        for (k, &c) in cs.iter().enumerate() {
            let mut alone = PackedLower::gaussian(&z, sigma, c);
            alone.set_diagonal(c);
            let y = alone.mul(&x[k * n..(k + 1) * n], 1);
            assert!(y
                .iter()
                .zip(&all[k * n..(k + 1) * n])
                .all(|(a, b)| a.to_bits() == b.to_bits()));
        }
        let keep: Vec<usize> = (0..n).filter(|i| i % 3 != 1).collect();
        let sub = p.principal(&keep);
        let zk: Vec<Vec<f64>> = keep.iter().map(|&i| z[i].clone()).collect();
        let fill = PackedLower::gaussian(&zk, sigma, 1.0);
        assert_eq!(sub.n(), keep.len());
        assert!(sub
            .data
            .iter()
            .zip(&fill.data)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        assert_eq!(p.entry(3, 17).to_bits(), p.entry(17, 3).to_bits());
        assert_eq!(
            p.entry(3, 17).to_bits(),
            crate::lssvm::kernel::gauss(&z[3], &z[17], 1.0 / (2.0 * sigma * sigma)).to_bits()
        );
    }
}
