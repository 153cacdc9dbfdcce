//! Eq. (9) for large n by a mixed-precision solve: an f32 Cholesky factor of H = K + I/c as
//! the preconditioner of conjugate gradients run in f64 on the f64 matrix.
//!
//! The f32 factorisation does the n³/3 flops at twice the SIMD width of f64; each CG step
//! costs one f64 product with H (2n² flops) and one pair of f32 triangular solves, and the
//! iteration stops on the normwise backward error LAPACK's `dsposv` uses,
//! ‖r‖∞ ≤ √n·ε·‖H‖∞·‖x‖∞ (ε the f64 epsilon), the same quality as an f64 Cholesky solve.
//! CG with this preconditioner converges in a few steps while cond(H)·ε_f32 stays well below
//! 1 (cond(H) ≤ 1 + n·c); when the f32 factor does not exist (H numerically indefinite in
//! f32) or CG has not converged in [`MAX_STEPS`] steps, the caller falls back to the f64
//! Cholesky. LAPACK's `dsposv` refines with the plain residual iteration; CG is used here
//! because it still converges, only more slowly, where that iteration diverges. No crate
//! offers a mixed-precision SPD solve, hence this module.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt;
use faer::linalg::matmul::triangular::{matmul, BlockStructure};
use faer::prelude::*;
use faer::{Accum, Par};
use rayon::prelude::*;

/// Most CG steps before giving up (LAPACK's `dsposv` allows 30 refinement steps).
pub const MAX_STEPS: usize = 30;

/// The lower triangle (diagonal included) of H = K + I/c in a column-major n×n buffer, the
/// strict upper part 0; columns filled in parallel on faer's global parallelism.
pub fn h_lower(z: &[Vec<f64>], sigma: f64, c: f64) -> Vec<f64> {
    let n = z.len();
    let mut h = vec![0.0f64; n * n];
    let mut none: Vec<f32> = Vec::new();
    fill_lower(z, sigma, c, &mut h, &mut none);
    h
}

/// [`h_lower`] and its entries rounded to f32, from one pass over the kernel.
pub fn h_lower_pair(z: &[Vec<f64>], sigma: f64, c: f64) -> (Vec<f64>, Vec<f32>) {
    let n = z.len();
    let mut h = vec![0.0f64; n * n];
    let mut h32 = vec![0.0f32; n * n];
    fill_lower(z, sigma, c, &mut h, &mut h32);
    (h, h32)
}

/// Writes H_ij for i ≥ j into the column-major n×n `out`, and rounded to f32 into `out32`
/// unless that is empty.
fn fill_lower(z: &[Vec<f64>], sigma: f64, c: f64, out: &mut [f64], out32: &mut [f32]) {
    let n = z.len();
    if n == 0 {
        return;
    }
    let dim = z.first().map_or(0, Vec::len);
    let flat: Vec<f64> = z.iter().flat_map(|r| r.iter().copied()).collect();
    let inv = 1.0 / (2.0 * sigma * sigma);
    let diag = 1.0 + 1.0 / c;
    let fill = |j: usize, col: &mut [f64]| {
        let zj = &flat[j * dim..(j + 1) * dim];
        col[j] = diag;
        for (i, v) in col.iter_mut().enumerate().skip(j + 1) {
            let zi = &flat[i * dim..(i + 1) * dim];
            let d2: f64 = zi.iter().zip(zj).map(|(a, b)| (a - b) * (a - b)).sum();
            *v = (-d2 * inv).exp();
        }
    };
    let round = |j: usize, col: &[f64], col32: &mut [f32]| {
        for (d, s) in col32[j..].iter_mut().zip(&col[j..]) {
            *d = *s as f32;
        }
    };
    let seq = faer::get_global_parallelism() == Par::Seq;
    match (seq, out32.is_empty()) {
        (true, true) => out.chunks_mut(n).enumerate().for_each(|(j, c)| fill(j, c)),
        (true, false) => out
            .chunks_mut(n)
            .zip(out32.chunks_mut(n))
            .enumerate()
            .for_each(|(j, (c, c32))| {
                fill(j, c);
                round(j, c, c32);
            }),
        // Column j holds n − j entries: small chunks keep the threads balanced.
        (false, true) => out
            .par_chunks_mut(n)
            .enumerate()
            .with_max_len(16)
            .for_each(|(j, c)| fill(j, c)),
        (false, false) => out
            .par_chunks_mut(n)
            .zip(out32.par_chunks_mut(n))
            .enumerate()
            .with_max_len(16)
            .for_each(|(j, (c, c32))| {
                fill(j, c);
                round(j, c, c32);
            }),
    }
}

/// Why the mixed-precision path gave up (the caller then solves in f64).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GiveUp {
    /// The f32 Cholesky factor does not exist.
    F32NotPositiveDefinite,
    /// CG did not reach the backward-error criterion in [`MAX_STEPS`] steps.
    NoConvergence,
}

/// Statistics of one mixed-precision solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MixedStats {
    /// CG steps taken (the slowest right-hand side).
    pub steps: usize,
    /// Largest final normwise backward error ‖r‖∞ / (‖H‖∞·‖x‖∞) over the right-hand sides.
    pub backward_error: f64,
}

/// y ← H·x for the symmetric H stored as its lower triangle `h`.
fn sym_mul(h: MatRef<'_, f64>, x: MatRef<'_, f64>, y: MatMut<'_, f64>, par: Par) {
    let mut y = y;
    matmul(
        y.rb_mut(),
        BlockStructure::Rectangular,
        Accum::Replace,
        h,
        BlockStructure::TriangularLower,
        x,
        BlockStructure::Rectangular,
        1.0,
        par,
    );
    matmul(
        y,
        BlockStructure::Rectangular,
        Accum::Add,
        h.transpose(),
        BlockStructure::StrictTriangularUpper,
        x,
        BlockStructure::Rectangular,
        1.0,
        par,
    );
}

/// Solves H·X = B for the columns of `b` by f32-Cholesky-preconditioned CG in f64; `h` and
/// `h32` are the lower triangle of H in f64 and f32 as [`h_lower_pair`] returns them (`h32`
/// is factorised in place).
pub fn solve(
    h: &[f64],
    mut h32: Vec<f32>,
    b: MatRef<'_, f64>,
) -> Result<(Mat<f64>, MixedStats), GiveUp> {
    let n = b.nrows();
    let m = b.ncols();
    let par = faer::get_global_parallelism();
    let h = MatRef::from_column_major_slice(h, n, n);
    let mut buf = MemBuffer::new(llt::factor::cholesky_in_place_scratch::<f32>(
        n,
        par,
        Default::default(),
    ));
    llt::factor::cholesky_in_place(
        MatMut::from_column_major_slice_mut(&mut h32, n, n),
        Default::default(),
        par,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .map_err(|_| GiveUp::F32NotPositiveDefinite)?;
    let l32 = MatRef::from_column_major_slice(&h32, n, n);
    let precondition = |r: &Mat<f64>| -> Mat<f64> {
        let mut r32 = Mat::<f32>::from_fn(n, m, |i, j| r[(i, j)] as f32);
        llt::solve::solve_in_place(
            l32,
            r32.as_mut(),
            par,
            MemStack::new(&mut MemBuffer::new(StackReq::EMPTY)),
        );
        Mat::<f64>::from_fn(n, m, |i, j| f64::from(r32[(i, j)]))
    };
    let col_dot = |a: &Mat<f64>, b: &Mat<f64>, j: usize| -> f64 {
        (0..n).map(|i| a[(i, j)] * b[(i, j)]).sum()
    };
    let col_max =
        |a: &Mat<f64>, j: usize| -> f64 { (0..n).map(|i| a[(i, j)].abs()).fold(0.0, f64::max) };

    // ‖H‖∞: H's entries are positive (Gaussian kernel plus a positive diagonal), so the row
    // sums of |H| are H·1.
    let mut row_sums = Mat::<f64>::zeros(n, 1);
    sym_mul(h, Mat::<f64>::ones(n, 1).as_ref(), row_sums.as_mut(), par);
    let h_norm = (0..n).map(|i| row_sums[(i, 0)]).fold(0.0, f64::max);
    let tol = (n as f64).sqrt() * f64::EPSILON * h_norm;

    let mut x = precondition(&b.to_owned());
    let mut r = Mat::<f64>::zeros(n, m);
    sym_mul(h, x.as_ref(), r.as_mut(), par);
    r = b - &r;
    let mut zr = precondition(&r);
    let mut p = zr.clone();
    let mut rz: Vec<f64> = (0..m).map(|j| col_dot(&r, &zr, j)).collect();
    let mut q = Mat::<f64>::zeros(n, m);
    let converged = |r: &Mat<f64>, x: &Mat<f64>, j: usize| col_max(r, j) <= tol * col_max(x, j);
    let mut steps = 0;
    loop {
        let done: Vec<bool> = (0..m).map(|j| converged(&r, &x, j)).collect();
        if done.iter().all(|d| *d) {
            break;
        }
        if steps == MAX_STEPS {
            return Err(GiveUp::NoConvergence);
        }
        steps += 1;
        sym_mul(h, p.as_ref(), q.as_mut(), par);
        for j in 0..m {
            if done[j] {
                continue;
            }
            let pq = col_dot(&p, &q, j);
            if !(pq > 0.0 && rz[j].is_finite()) {
                return Err(GiveUp::NoConvergence);
            }
            let a = rz[j] / pq;
            for i in 0..n {
                x[(i, j)] += a * p[(i, j)];
                r[(i, j)] -= a * q[(i, j)];
            }
        }
        zr = precondition(&r);
        for j in 0..m {
            if done[j] {
                continue;
            }
            let rz_new = col_dot(&r, &zr, j);
            let beta = rz_new / rz[j];
            rz[j] = rz_new;
            for i in 0..n {
                p[(i, j)] = zr[(i, j)] + beta * p[(i, j)];
            }
        }
    }
    // The recurrence's residual drifts from the true one: check the true residual.
    sym_mul(h, x.as_ref(), r.as_mut(), par);
    let r = b - &r;
    let mut backward_error: f64 = 0.0;
    for j in 0..m {
        let xm = col_max(&x, j);
        let rm = col_max(&r, j);
        // `col_max` would skip a NaN (f64::max ignores it): check finiteness on its own.
        let finite = (0..n).all(|i| x[(i, j)].is_finite() && r[(i, j)].is_finite());
        if !finite || rm > 4.0 * tol * xm {
            return Err(GiveUp::NoConvergence);
        }
        backward_error = backward_error.max(rm / (h_norm * xm));
    }
    Ok((
        x,
        MixedStats {
            steps,
            backward_error,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lssvm::solve::{solve_reporting, SolvePath, MIXED_MIN_N};
    use crate::lssvm::test_data::scattered;

    /// The f64 Cholesky solve of the same system, for comparison.
    fn f64_solution(h: &[f64], n: usize, b: MatRef<'_, f64>) -> Mat<f64> {
        let llt = MatRef::from_column_major_slice(h, n, n)
            .llt(faer::Side::Lower)
            .unwrap();
        let mut x = b.to_owned();
        llt.solve_in_place(&mut x);
        x
    }

    fn max_rel_diff(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
        let scale = (0..b.nrows())
            .flat_map(|i| (0..b.ncols()).map(move |j| (i, j)))
            .map(|(i, j)| b[(i, j)].abs())
            .fold(0.0, f64::max);
        (0..b.nrows())
            .flat_map(|i| (0..b.ncols()).map(move |j| (i, j)))
            .map(|(i, j)| (a[(i, j)] - b[(i, j)]).abs() / scale)
            .fold(0.0, f64::max)
    }

    /// At the pipeline's σ, c the mixed path converges in a few steps to the f64 Cholesky
    /// solution (the two agree to what the f64 solve itself can resolve), and `solve` takes it.
    #[test]
    fn mixed_matches_f64_cholesky() {
        let n = 1200;
        let (z, y) = scattered(n);
        for (sigma, c) in [(0.67, 42.0), (0.3, 1.0e3)] {
            let (h, h32) = h_lower_pair(&z, sigma, c);
            let b = Mat::<f64>::from_fn(n, 2, |i, j| if j == 0 { y[i] } else { 1.0 });
            let (x, stats) = solve(&h, h32, b.as_ref()).unwrap();
            let want = f64_solution(&h, n, b.as_ref());
            let d = max_rel_diff(&x, &want);
            assert!(stats.steps <= 10, "σ {sigma} c {c}: {stats:?}");
            assert!(stats.backward_error < 1e-14, "{stats:?}");
            assert!(d < 1e-10, "σ {sigma} c {c}: max rel diff {d:e}, {stats:?}");
        }
        let (_, path) = solve_reporting(&z, &y, 0.67, 42.0).unwrap();
        assert!(matches!(path, SolvePath::Mixed(_)), "{path:?}");
        let (_, path) =
            solve_reporting(&z[..MIXED_MIN_N - 1], &y[..MIXED_MIN_N - 1], 0.67, 42.0).unwrap();
        assert_eq!(path, SolvePath::F64);
    }

    /// Where f32 cannot represent the system (c so large that H is numerically singular in
    /// f32), the mixed path gives up and `solve` returns the f64 Cholesky solution.
    #[test]
    fn ill_conditioned_system_falls_back_to_f64() {
        let n = MIXED_MIN_N;
        let (z, y) = scattered(n);
        let (sigma, c) = (2.0, 1.0e9);
        let (h, h32) = h_lower_pair(&z, sigma, c);
        let b = Mat::<f64>::from_fn(n, 2, |i, j| if j == 0 { y[i] } else { 1.0 });
        let why = solve(&h, h32, b.as_ref()).unwrap_err();
        let (sol, path) = solve_reporting(&z, &y, sigma, c).unwrap();
        assert_eq!(path, SolvePath::Fallback(why));
        let want = f64_solution(&h, n, b.as_ref());
        // The f64 block elimination of that solution.
        let s: f64 = (0..n).map(|i| want[(i, 1)]).sum();
        let bias = (0..n).map(|i| want[(i, 0)]).sum::<f64>() / s;
        assert_eq!(sol.bias, bias);
    }

    /// The parallel fill and the sequential fill give the same bits.
    #[test]
    fn h_lower_is_the_same_sequential_and_parallel() {
        let (z, _) = scattered(300);
        let before = faer::get_global_parallelism();
        faer::set_global_parallelism(Par::Seq);
        let seq = h_lower(&z, 0.7, 50.0);
        faer::set_global_parallelism(Par::rayon(2));
        let par = h_lower(&z, 0.7, 50.0);
        let (pair, pair32) = h_lower_pair(&z, 0.7, 50.0);
        faer::set_global_parallelism(before);
        assert!(seq
            .iter()
            .zip(&par)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(seq
            .iter()
            .zip(&pair)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(seq
            .iter()
            .zip(&pair32)
            .all(|(a, b)| (*a as f32).to_bits() == b.to_bits()));
        assert_eq!(seq[0], 1.0 + 1.0 / 50.0);
        assert_eq!(seq[300], 0.0); // (0, 1): strict upper part
    }
}
