//! Eq. (9) for large n by conjugate gradients run in f64 on the f64 matrix H = K + I/c, with
//! one of two preconditioners, stopped on the normwise backward error LAPACK's `dsposv` uses,
//! ‖r‖∞ ≤ √n·ε·‖H‖∞·‖x‖∞ (ε the f64 epsilon): the same quality as an f64 Cholesky solve,
//! checked on the true residual at the end.
//!
//! * [`solve_low_rank`]: a partial pivoted Cholesky factor of K ([`super::pivoted`]). The
//!   Gaussian kernel on the two standardised inputs has a fast-falling spectrum, so a rank of
//!   60–200 leaves less than 10⁻⁶/c of K unexplained and CG converges in one or two steps;
//!   with H in packed storage ([`super::packed`]) nothing costs O(n³). It gives up when the
//!   rank would exceed [`low_rank_max`] (narrow kernels, many inputs).
//! * [`solve`]: an f32 Cholesky factor of H. The f32 factorisation does the n³/3 flops at
//!   twice the SIMD width of f64; each CG step costs one f64 product with H and one pair of
//!   f32 triangular solves. It converges in a few steps while cond(H)·ε_f32 stays well below
//!   1 (cond(H) ≤ 1 + n·c); when the f32 factor does not exist (H numerically indefinite in
//!   f32) or CG has not converged in [`MAX_STEPS`] steps, the caller falls back to the f64
//!   Cholesky. LAPACK's `dsposv` refines with the plain residual iteration; CG is used here
//!   because it still converges, only more slowly, where that iteration diverges.
//!
//! No crate offers a mixed-precision or preconditioned-CG SPD solve on faer matrices, hence
//! this module.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt;
use faer::linalg::matmul::triangular::{matmul, BlockStructure};
use faer::prelude::*;
use faer::{Accum, Par};
use rayon::prelude::*;

use super::cg::{pcg, Cg, Need};
use super::kernel::gauss_rows;
use super::packed::PackedLower;
use super::pivoted::{LowRank, PivotPath};

/// Most CG steps before giving up (LAPACK's `dsposv` allows 30 refinement steps).
pub const MAX_STEPS: usize = 30;

/// The lower triangle (diagonal included) of H = K + I/c in a column-major n×n buffer, the
/// strict upper part 0; columns filled in parallel on faer's global parallelism.
pub fn h_lower(z: &[Vec<f64>], sigma: f64, c: f64) -> Vec<f64> {
    let n = z.len();
    let mut h = vec![0.0f64; n * n];
    fill_lower(z, sigma, c, &mut h);
    h
}

/// Writes H_ij for i ≥ j into the column-major n×n `out`.
fn fill_lower(z: &[Vec<f64>], sigma: f64, c: f64, out: &mut [f64]) {
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
        gauss_rows(&flat[(j + 1) * dim..], dim, zj, inv, &mut col[j + 1..]);
    };
    if faer::get_global_parallelism() == Par::Seq {
        out.chunks_mut(n).enumerate().for_each(|(j, c)| fill(j, c));
    } else {
        // Column j holds n − j entries: small chunks keep the threads balanced.
        out.par_chunks_mut(n)
            .enumerate()
            .with_max_len(16)
            .for_each(|(j, c)| fill(j, c));
    }
}

/// Why an iterative path gave up (the caller then takes the next one, the f64 Cholesky last).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GiveUp {
    /// The f32 Cholesky factor does not exist.
    F32NotPositiveDefinite,
    /// CG did not reach the backward-error criterion in its step budget.
    NoConvergence,
    /// The low-rank preconditioner would need more than [`low_rank_max`] columns.
    RankLimit,
}

/// Statistics of one iterative solve.
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
/// `h32` are the lower triangle of H in f64 ([`h_lower`]) and rounded to f32 (`h32` is
/// factorised in place).
pub fn solve(
    h: &[f64],
    mut h32: Vec<f32>,
    b: MatRef<'_, f64>,
) -> Result<(Mat<f64>, MixedStats), GiveUp> {
    let n = b.nrows();
    let par = faer::get_global_parallelism();
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
        let mut r32 = Mat::<f32>::from_fn(n, r.ncols(), |i, j| r[(i, j)] as f32);
        llt::solve::solve_in_place(
            l32,
            r32.as_mut(),
            par,
            MemStack::new(&mut MemBuffer::new(StackReq::EMPTY)),
        );
        Mat::<f64>::from_fn(n, r.ncols(), |i, j| f64::from(r32[(i, j)]))
    };
    let h = MatRef::from_column_major_slice(h, n, n);
    let apply_h = |x: &Mat<f64>| -> Mat<f64> {
        let mut y = Mat::<f64>::zeros(n, x.ncols());
        sym_mul(h, x.as_ref(), y.as_mut(), par);
        y
    };
    pcg(apply_h, b, precondition, MAX_STEPS)
}

/// Most CG steps of [`solve_low_rank`]; each costs one product with H (12 ms at n = 5000,
/// against about 1 s for the f64 Cholesky).
pub const LOW_RANK_MAX_STEPS: usize = 60;

/// Largest rank of the low-rank preconditioner: n/4, at most 256. Building it reads the
/// columns already taken for each new one, 4·n·r² bytes in all: 1.3 GB at n = 5000, r = 256,
/// a fraction of a second and a tenth of the time of the f64 Cholesky there.
pub fn low_rank_max(n: usize) -> usize {
    (n / 4).clamp(1, 256)
}

/// Solves H·X = B for the columns of `b` by CG in f64 preconditioned with the partial pivoted
/// Cholesky factor of K ([`LowRank`]) built from the inputs `z` (width σ, H = K + I/c); `h`
/// is H's packed lower triangle. No O(n³) step. Columns are taken until the diagonal K leaves
/// unexplained is below 10⁻⁶/c (P⁻¹H then has its eigenvalues within about 10⁻⁶·n of 1,
/// and CG converges in one or two steps), at most [`low_rank_max`] of them. Gives up
/// ([`GiveUp::RankLimit`]) when that many leave more than 1/c unexplained (K's spectrum
/// falls off too slowly: a small σ, many inputs) and ([`GiveUp::NoConvergence`]) after
/// [`LOW_RANK_MAX_STEPS`] steps. Returns the solution, the statistics and the rank.
pub fn solve_low_rank(
    h: &PackedLower,
    z: &[Vec<f64>],
    sigma: f64,
    c: f64,
    b: MatRef<'_, f64>,
) -> Result<(Mat<f64>, MixedStats, usize), GiveUp> {
    let n = b.nrows();
    let p = LowRank::build(z, sigma, 1.0 / c, low_rank_max(n), 1e-6 / c)
        .ok_or(GiveUp::NoConvergence)?;
    if p.remaining() > 1.0 / c {
        return Err(GiveUp::RankLimit);
    }
    let apply_h = |x: &Mat<f64>| -> Mat<f64> {
        let m = x.ncols();
        let flat: Vec<f64> = (0..m)
            .flat_map(|j| x.col(j).iter().copied().collect::<Vec<_>>())
            .collect();
        let y = h.mul(&flat, m);
        Mat::<f64>::from_fn(n, m, |i, j| y[j * n + i])
    };
    let (x, stats) = pcg(
        apply_h,
        b,
        |r| p.apply_inverse(r.as_ref()),
        LOW_RANK_MAX_STEPS,
    )?;
    Ok((x, stats, p.rank()))
}

/// A low-rank-preconditioned solve: the solution, its statistics and the preconditioner's
/// rank, or why it gave up.
pub type LowRankSolve = Result<(Mat<f64>, MixedStats, usize), GiveUp>;

/// [`solve_low_rank`] for the systems H_c = K + I/c of each c of `cs` at once, on the kernel
/// part of the packed `h` (its stored diagonal is not read): their CG recurrences advance in
/// lock step, and each round's products with every H_c are made in one pass over `h`
/// ([`PackedLower::mul_diagonal`]). One system's numbers are those of [`solve_low_rank`] on
/// `h` with its diagonal set to 1 + 1/c, bit for bit; the tuning's folds solve every c of
/// the grid this way, reading their kernel once per step instead of once per c.
pub fn solve_low_rank_shifts(
    h: &PackedLower,
    z: &[Vec<f64>],
    sigma: f64,
    cs: &[f64],
    b: MatRef<'_, f64>,
) -> Vec<LowRankSolve> {
    let n = b.nrows();
    let mut out: Vec<LowRankSolve> = vec![Err(GiveUp::NoConvergence); cs.len()];
    // The systems still running: (index into cs, preconditioner, recurrence).
    let mut running: Vec<(usize, LowRank, Option<Cg>)> = Vec::new();
    // One set of pivoted Cholesky steps, down to the largest c's tolerance, gives every c's
    // factor as a prefix.
    let tightest = cs.iter().map(|&c| 1e-6 / c).fold(f64::INFINITY, f64::min);
    let path = PivotPath::new(z, sigma, low_rank_max(n), tightest);
    for (k, &c) in cs.iter().enumerate() {
        match path.low_rank(1e-6 / c, 1.0 / c) {
            None => out[k] = Err(GiveUp::NoConvergence),
            Some(p) if p.remaining() > 1.0 / c => out[k] = Err(GiveUp::RankLimit),
            Some(p) => running.push((k, p, None)),
        }
    }
    let diag = |k: usize| 1.0 + 1.0 / cs[k];
    // Round 0: H_c·[X₀ | 1] for every system.
    let firsts: Vec<(Mat<f64>, Mat<f64>)> = running
        .iter()
        .map(|(_, p, _)| Cg::first(b, |r| p.apply_inverse(r.as_ref())))
        .collect();
    let products = shifted_products(
        h,
        running
            .iter()
            .zip(&firsts)
            .map(|((k, _, _), (_, x1))| (x1, diag(*k))),
    );
    for ((run, (x0, _)), hx1) in running.iter_mut().zip(firsts).zip(&products) {
        let p = &run.1;
        run.2 = Some(Cg::new(
            b,
            x0,
            hx1,
            |r| p.apply_inverse(r.as_ref()),
            LOW_RANK_MAX_STEPS,
        ));
    }
    while !running.is_empty() {
        // Each system's next need: a step's product, the final check's, or it gave up.
        let mut wants: Vec<(usize, bool, Mat<f64>)> = Vec::new();
        let mut gave_up = Vec::new();
        for (slot, (k, _, cg)) in running.iter_mut().enumerate() {
            let cg = cg
                .as_mut()
                .expect("every running system has its recurrence");
            match cg.next() {
                Ok(Need::Step(p)) => wants.push((slot, true, p.clone())),
                Ok(Need::Check(x)) => wants.push((slot, false, x.clone())),
                Err(why) => {
                    out[*k] = Err(why);
                    gave_up.push(slot);
                }
            }
        }
        let products = shifted_products(
            h,
            wants.iter().map(|(slot, _, v)| (v, diag(running[*slot].0))),
        );
        let mut finished = gave_up;
        for ((slot, step, _), hv) in wants.iter().zip(&products) {
            let (k, p, cg) = &mut running[*slot];
            if *step {
                let cg = cg
                    .as_mut()
                    .expect("every running system has its recurrence");
                if let Err(why) = cg.advance(hv, |r| p.apply_inverse(r.as_ref())) {
                    out[*k] = Err(why);
                    finished.push(*slot);
                }
            } else {
                let cg = cg.take().expect("every running system has its recurrence");
                out[*k] = cg.finish(hv).map(|(x, stats)| (x, stats, p.rank()));
                finished.push(*slot);
            }
        }
        finished.sort_unstable();
        for slot in finished.into_iter().rev() {
            running.remove(slot);
        }
    }
    out
}

/// H_c·V for each (V, 1 + 1/c) of `parts`, all in one pass over the packed kernel `h`.
fn shifted_products<'a>(
    h: &PackedLower,
    parts: impl Iterator<Item = (&'a Mat<f64>, f64)>,
) -> Vec<Mat<f64>> {
    let n = h.n();
    let mut flat = Vec::new();
    let mut diag = Vec::new();
    let mut widths = Vec::new();
    for (v, d) in parts {
        for j in 0..v.ncols() {
            flat.extend(v.col(j).iter().copied());
            diag.push(d);
        }
        widths.push(v.ncols());
    }
    if widths.is_empty() {
        return Vec::new();
    }
    let y = h.mul_diagonal(&flat, &diag);
    let mut at = 0;
    widths
        .into_iter()
        .map(|m| {
            let part = Mat::<f64>::from_fn(n, m, |i, j| y[(at + j) * n + i]);
            at += m;
            part
        })
        .collect()
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

    /// max over columns of ‖b − H·x‖∞ / (‖H‖∞·‖x‖∞), the criterion `pcg` stops on.
    fn backward_error(h: &[f64], n: usize, b: MatRef<'_, f64>, x: MatRef<'_, f64>) -> f64 {
        let hm = MatRef::from_column_major_slice(h, n, n);
        let full = Mat::<f64>::from_fn(n, n, |i, j| if i >= j { hm[(i, j)] } else { hm[(j, i)] });
        let r = b - &full * x;
        let h_norm = (0..n)
            .map(|i| (0..n).map(|j| full[(i, j)].abs()).sum::<f64>())
            .fold(0.0, f64::max);
        (0..b.ncols())
            .map(|j| {
                let rm = (0..n).map(|i| r[(i, j)].abs()).fold(0.0, f64::max);
                let xm = (0..n).map(|i| x[(i, j)].abs()).fold(0.0, f64::max);
                rm / (h_norm * xm)
            })
            .fold(0.0, f64::max)
    }

    fn to_f32(h: &[f64]) -> Vec<f32> {
        h.iter().map(|v| *v as f32).collect()
    }

    fn rhs(y: &[f64]) -> Mat<f64> {
        Mat::<f64>::from_fn(y.len(), 2, |i, j| if j == 0 { y[i] } else { 1.0 })
    }

    /// The f32-preconditioned path converges in a few steps to the f64 Cholesky solution (the
    /// two agree to what the f64 solve itself can resolve).
    #[test]
    fn mixed_matches_f64_cholesky() {
        let n = 1200;
        let (z, y) = scattered(n);
        for (sigma, c) in [(0.67, 42.0), (0.3, 1.0e3)] {
            let h = h_lower(&z, sigma, c);
            let b = rhs(&y);
            let (x, stats) = solve(&h, to_f32(&h), b.as_ref()).unwrap();
            let want = f64_solution(&h, n, b.as_ref());
            let d = max_rel_diff(&x, &want);
            assert!(stats.steps <= 10, "σ {sigma} c {c}: {stats:?}");
            assert!(stats.backward_error < 1e-14, "{stats:?}");
            assert!(d < 1e-10, "σ {sigma} c {c}: max rel diff {d:e}, {stats:?}");
        }
    }

    /// The low-rank-preconditioned path reaches the same solution without a factorisation of
    /// H, in a step or two at the pipeline's σ, c; `solve` takes it from `MIXED_MIN_N` on, and
    /// it also holds the systems f32 cannot (c = 1e9, where `solve` above gives up).
    #[test]
    fn low_rank_matches_f64_cholesky() {
        let n = 1200;
        let (z, y) = scattered(n);
        for (sigma, c, max_steps) in [(0.67, 42.0, 2), (0.3, 1.0e3, 30), (2.0, 1.0e9, 30)] {
            let h = h_lower(&z, sigma, c);
            let b = rhs(&y);
            let packed = PackedLower::gaussian(&z, sigma, c);
            let (x, stats, rank) = solve_low_rank(&packed, &z, sigma, c, b.as_ref()).unwrap();
            let want = f64_solution(&h, n, b.as_ref());
            let d = max_rel_diff(&x, &want);
            assert!(rank <= low_rank_max(n), "{rank}");
            assert!(
                stats.steps <= max_steps,
                "σ {sigma} c {c}: {stats:?} rank {rank}"
            );
            assert!(stats.backward_error < 1e-14, "{stats:?}");
            // LAPACK dsposv's acceptance test, recomputed here on the dense H rather than
            // taken from the solver's own report. Both this and the Cholesky solution then
            // have the backward error of an f64 solve, so for a moderate c their distance is
            // bounded by it times cond(H) ≤ 1 + n·c; at c = 1e9 that bound says nothing (they
            // differ by 2e-5 there).
            let be = backward_error(&h, n, b.as_ref(), x.as_ref());
            assert!(be <= (n as f64).sqrt() * f64::EPSILON, "{be:e}, {stats:?}");
            if c <= 1e3 {
                let bound = 100.0 * f64::EPSILON * n as f64 * c;
                assert!(d < bound, "σ {sigma} c {c}: max rel diff {d:e}, {stats:?}");
            }
        }
        let (_, path) = solve_reporting(&z, &y, 0.67, 42.0).unwrap();
        assert!(matches!(path, SolvePath::LowRank { .. }), "{path:?}");
        let (_, path) =
            solve_reporting(&z[..MIXED_MIN_N - 1], &y[..MIXED_MIN_N - 1], 0.67, 42.0).unwrap();
        assert_eq!(path, SolvePath::F64);
    }

    /// A narrow kernel needs more than `low_rank_max` columns: the low-rank path says so
    /// before any CG step and `solve` takes the f32-preconditioned path; where f32 cannot
    /// hold the system either, `solve` returns the f64 Cholesky solution.
    #[test]
    fn slow_spectra_fall_back_in_order() {
        let n = MIXED_MIN_N;
        let (z, y) = scattered(n);
        let b = rhs(&y);
        let (_, path) = solve_reporting(&z, &y, 0.1, 42.0).unwrap();
        assert!(
            matches!(
                path,
                SolvePath::Mixed {
                    low_rank: GiveUp::RankLimit,
                    ..
                }
            ),
            "{path:?}"
        );
        let (sigma, c) = (0.3, 1.0e9);
        let h = h_lower(&z, sigma, c);
        let why = solve(&h, to_f32(&h), b.as_ref()).unwrap_err();
        let (sol, path) = solve_reporting(&z, &y, sigma, c).unwrap();
        assert_eq!(
            path,
            SolvePath::Fallback {
                low_rank: GiveUp::RankLimit,
                mixed: why
            }
        );
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
        faer::set_global_parallelism(before);
        assert!(seq
            .iter()
            .zip(&par)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        assert_eq!(seq[0], 1.0 + 1.0 / 50.0);
        assert_eq!(seq[300], 0.0); // (0, 1): strict upper part
    }

    /// The lock-step solve of several c gives each c the numbers of its own low-rank solve,
    /// bit for bit, and the same reason where one gives up (c = 1e-3 passes the rank test,
    /// the tiny σ does not).
    #[test]
    fn shifted_solves_are_the_single_solves() {
        let n = 1100;
        let (z, y) = scattered(n);
        let b = rhs(&y);
        for sigma in [0.67, 0.02] {
            let cs = [1e-3, 3.0, 42.0, 1.0e5];
            let packed = PackedLower::gaussian(&z, sigma, 1.0);
            let many = solve_low_rank_shifts(&packed, &z, sigma, &cs, b.as_ref());
            for (&c, got) in cs.iter().zip(many) {
                let mut alone = PackedLower::gaussian(&z, sigma, c);
                alone.set_diagonal(c);
                let want = solve_low_rank(&alone, &z, sigma, c, b.as_ref());
                match (got, want) {
                    (Ok((x, s, r)), Ok((wx, ws, wr))) => {
                        assert_eq!((s, r), (ws, wr), "σ {sigma} c {c}");
                        for j in 0..x.ncols() {
                            for i in 0..n {
                                assert_eq!(x[(i, j)].to_bits(), wx[(i, j)].to_bits());
                            }
                        }
                    }
                    (Err(e), Err(we)) => assert_eq!(e, we, "σ {sigma} c {c}"),
                    (g, w) => panic!("σ {sigma} c {c}: {:?} vs {:?}", g.err(), w.err()),
                }
            }
        }
    }
}
