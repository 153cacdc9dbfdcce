//! The Gaussian kernel of Eq. (8), K(x, y) = exp(−‖x − y‖² / 2σ²): one entry function that
//! every solver, predictor and fill calls, so the kernel has the same bits wherever it is
//! formed (a dense fill, a packed fill, a pivoted factor, a prediction).

use faer::Mat;

/// exp(−‖a − b‖² · inv), inv = 1/(2σ²): one entry of Eq. (8), the same bits wherever the
/// kernel is formed.
#[inline]
pub fn gauss(a: &[f64], b: &[f64], inv: f64) -> f64 {
    let d2: f64 = a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum();
    (-d2 * inv).exp()
}

/// The Gaussian kernel matrix K_ij = exp(−‖z_i − z_j‖² / 2σ²) of Eq. (8).
///
/// Symmetric with a unit diagonal: each off-diagonal entry is computed once and mirrored.
/// Rows of `z` must share one length; σ > 0.
pub fn kernel_matrix(z: &[Vec<f64>], sigma: f64) -> Mat<f64> {
    let n = z.len();
    let dim = z.first().map_or(0, Vec::len);
    // A contiguous copy: the inner loop then streams through memory.
    let flat: Vec<f64> = z.iter().flat_map(|r| r.iter().copied()).collect();
    let inv = 1.0 / (2.0 * sigma * sigma);
    let mut k = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        let zj = &flat[j * dim..(j + 1) * dim];
        k[(j, j)] = 1.0;
        for i in j + 1..n {
            let v = gauss(&flat[i * dim..(i + 1) * dim], zj, inv);
            k[(i, j)] = v;
            k[(j, i)] = v;
        }
    }
    k
}
