//! The Gaussian kernel of Eq. (8), K(x, y) = exp(−‖x − y‖² / 2σ²): one entry function that
//! every solver, predictor and fill calls, so the kernel has the same bits wherever it is
//! formed (a dense fill, a packed fill, a pivoted factor, a prediction).
//!
//! The exponential is `wide`'s four-lane `f64x4::exp` (Cody–Waite reduction by ln 2, a
//! degree-13 polynomial; within 2 ulp of the correctly rounded value, test
//! `exp_is_within_two_ulp`), for single entries too: [`gauss`] and [`gauss_rows`] then give
//! the same bits for the same pair, so a vectorised fill and a scalar prediction agree.

use faer::MatRef;
use wide::f64x4;

/// e^x lane by lane. `wide` maps NaN to 0; here NaN stays NaN, so a NaN input is never
/// mistaken for a far-away point.
#[inline]
fn exp4(x: f64x4) -> f64x4 {
    let e = x.exp();
    x.is_nan().blend(x, e)
}

/// ‖a − b‖², summed in the order of the coordinates.
#[inline]
fn dist2(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum()
}

/// exp(−‖a − b‖² · inv), inv = 1/(2σ²): one entry of Eq. (8), the same bits wherever the
/// kernel is formed.
#[inline]
pub fn gauss(a: &[f64], b: &[f64], inv: f64) -> f64 {
    exp4(f64x4::splat(-dist2(a, b) * inv)).to_array()[0]
}

/// `out[k] = gauss(row k, q, inv)` for the rows of the row-major `rows` (`dim` values each,
/// at least `out.len()` rows), four entries per exponential call; bit for bit [`gauss`].
pub fn gauss_rows(rows: &[f64], dim: usize, q: &[f64], inv: f64, out: &mut [f64]) {
    let n = out.len();
    assert!(rows.len() >= n * dim, "gauss_rows: fewer rows than outputs");
    let mut k = 0;
    if dim == 2 {
        // [T, dT/dt], the models' usual input: the squared distances four lanes wide too
        // (dx² + dy², the order `dist2` adds them in).
        let (qx, qy) = (f64x4::splat(q[0]), f64x4::splat(q[1]));
        let inv4 = f64x4::splat(inv);
        while k + 4 <= n {
            let r = &rows[2 * k..2 * k + 8];
            let dx = f64x4::from([r[0], r[2], r[4], r[6]]) - qx;
            let dy = f64x4::from([r[1], r[3], r[5], r[7]]) - qy;
            let e = exp4(-(dx * dx + dy * dy) * inv4);
            out[k..k + 4].copy_from_slice(&e.to_array());
            k += 4;
        }
    }
    while k + 4 <= n {
        let d = |l: usize| -dist2(&rows[(k + l) * dim..(k + l + 1) * dim], q);
        let e = exp4(f64x4::from([d(0), d(1), d(2), d(3)]) * f64x4::splat(inv));
        out[k..k + 4].copy_from_slice(&e.to_array());
        k += 4;
    }
    for (j, o) in out.iter_mut().enumerate().skip(k) {
        *o = gauss(&rows[j * dim..(j + 1) * dim], q, inv);
    }
}

/// The Gaussian kernel matrix K_ij = exp(−‖z_i − z_j‖² / 2σ²) of Eq. (8), n × n,
/// column-major (`data[j·n + i]` = K_ij); [`KernelMatrix::as_mat`] views it as a faer
/// matrix.
#[derive(Clone, Debug, PartialEq)]
pub struct KernelMatrix {
    n: usize,
    data: Vec<f64>,
}

impl KernelMatrix {
    /// Its order n.
    pub fn n(&self) -> usize {
        self.n
    }

    /// The matrix as a faer view.
    pub fn as_mat(&self) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice(&self.data, self.n, self.n)
    }
}

impl std::ops::Index<(usize, usize)> for KernelMatrix {
    type Output = f64;

    fn index(&self, (i, j): (usize, usize)) -> &f64 {
        assert!(i < self.n && j < self.n, "kernel matrix index out of range");
        &self.data[j * self.n + i]
    }
}

/// The Gaussian kernel matrix of the rows of `z` ([`KernelMatrix`]), on the rayon pool
/// unless faer's global parallelism is `Seq`.
///
/// Symmetric with a unit diagonal. Each column is computed whole: twice the exponentials of
/// a lower triangle mirrored, but the mirror pass strides through every column and cannot be
/// split between threads, and at n = 5 000 most of the time is the first touch of the
/// result's 200 MB, not the 12.5·10⁶ exponentials (0.024 s). The storage is a zeroed `Vec`,
/// whose pages the allocator maps lazily, so the first touch happens in the fill, shared
/// between the threads (a faer `Mat::zeros` writes every page first, on one thread: 0.11 s
/// of the 0.16 s the mirrored fill took). The entries are bit for bit the same either way:
/// (a − b)² = (b − a)² in floating point, and [`gauss_rows`] gives [`gauss`]'s bits. Rows
/// of `z` must share one length; σ > 0.
pub fn kernel_matrix(z: &[Vec<f64>], sigma: f64) -> KernelMatrix {
    fill_kernel_matrix(z, sigma, faer::get_global_parallelism() != faer::Par::Seq)
}

/// [`kernel_matrix`], on the rayon pool when `parallel`.
fn fill_kernel_matrix(z: &[Vec<f64>], sigma: f64, parallel: bool) -> KernelMatrix {
    use rayon::prelude::*;
    let n = z.len();
    let dim = z.first().map_or(0, Vec::len);
    // A contiguous copy: the inner loop then streams through memory.
    let flat: Vec<f64> = z.iter().flat_map(|r| r.iter().copied()).collect();
    let inv = 1.0 / (2.0 * sigma * sigma);
    let mut data = vec![0.0f64; n * n];
    let fill = |(j, col): (usize, &mut [f64])| {
        gauss_rows(&flat, dim, &flat[j * dim..(j + 1) * dim], inv, col);
        col[j] = 1.0;
    };
    if n > 0 {
        if parallel {
            data.par_chunks_mut(n)
                .enumerate()
                .with_max_len(16)
                .for_each(fill);
        } else {
            data.chunks_mut(n).enumerate().for_each(fill);
        }
    }
    KernelMatrix { n, data }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Units in the last place between two positive finite f64.
    fn ulps(a: f64, b: f64) -> u64 {
        a.to_bits().abs_diff(b.to_bits())
    }

    /// Over the kernel's whole argument range (0 down to the underflow of e^x) the lane exp
    /// is within 2 ulp of libm's (itself within 1 ulp of the true value), and NaN and
    /// ±∞ come out as exp's.
    #[test]
    fn exp_is_within_two_ulp() {
        let mut worst = 0;
        let mut x = -700.0f64;
        while x <= 0.0 {
            for dx in [0.0, 1e-9, 0.31, 0.5, 0.693] {
                let v = x - dx;
                let got = exp4(f64x4::splat(v)).to_array()[0];
                worst = worst.max(ulps(got, v.exp()));
            }
            x += 0.0137;
        }
        assert!(worst <= 2, "worst {worst} ulp");
        let s = exp4(f64x4::from([f64::NAN, f64::NEG_INFINITY, 0.0, -1e-300])).to_array();
        assert!(s[0].is_nan());
        assert_eq!(s[1], 0.0);
        assert_eq!(s[2], 1.0);
        assert_eq!(s[3], 1.0);
    }

    /// The parallel fill and the sequential one give the same bits, the matrix is exactly
    /// symmetric (each column is computed whole, so K_ij and K_ji come from separate
    /// calls) with a unit diagonal, an entry is `gauss` of its pair, and the faer view
    /// reads the same entries.
    #[test]
    fn kernel_matrix_is_the_same_sequential_and_parallel() {
        // 103 rows: columns of every length modulo the four lanes.
        let z: Vec<Vec<f64>> = (0..103)
            .map(|i| {
                let t = i as f64;
                vec![
                    (t * 0.618).fract() * 4.0 - 2.0,
                    (t * 0.414).fract() * 3.0 - 1.5,
                ]
            })
            .collect();
        let seq = fill_kernel_matrix(&z, 0.7, false);
        let par = fill_kernel_matrix(&z, 0.7, true);
        let inv = 1.0 / (2.0 * 0.7 * 0.7);
        for i in 0..z.len() {
            for j in 0..z.len() {
                assert_eq!(seq[(i, j)].to_bits(), par[(i, j)].to_bits(), "({i}, {j})");
                assert_eq!(seq[(i, j)].to_bits(), seq[(j, i)].to_bits(), "({i}, {j})");
            }
            assert_eq!(seq[(i, i)], 1.0);
        }
        assert_eq!(seq[(5, 17)], gauss(&z[5], &z[17], inv));
        assert_eq!(seq.as_mat()[(5, 17)], seq[(5, 17)]);
        assert_eq!(seq.as_mat()[(17, 5)], seq[(5, 17)]);
        assert_eq!(seq.n(), 103);
        assert!(seq[(5, 17)] > 0.0 && seq[(5, 17)] < 1.0);
    }

    /// Four-at-a-time rows give `gauss`'s bits, tail included; a NaN coordinate gives NaN.
    #[test]
    fn rows_agree_with_single_entries() {
        let dim = 2;
        let rows: Vec<f64> = (0..2 * 11)
            .map(|i| (i as f64 * 0.618).fract() * 4.0 - 2.0)
            .collect();
        let q = [0.3, -0.7];
        let mut out = vec![0.0; 11];
        gauss_rows(&rows, dim, &q, 0.9, &mut out);
        for (j, v) in out.iter().enumerate() {
            assert_eq!(
                v.to_bits(),
                gauss(&rows[j * 2..j * 2 + 2], &q, 0.9).to_bits()
            );
        }
        let mut bad = rows.clone();
        bad[5] = f64::NAN;
        gauss_rows(&bad, dim, &q, 0.9, &mut out);
        assert!(out[2].is_nan());
        assert!(gauss(&[f64::NAN, 0.0], &q, 0.9).is_nan());
    }
}
