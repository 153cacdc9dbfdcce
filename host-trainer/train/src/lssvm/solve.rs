//! Eq. (9) of Yu et al. 2011 on standardised inputs.
//!
//! With H = K + I/c (K the Gaussian kernel matrix of Eq. 8), the bordered system of Eq. (9),
//!
//! ```text
//! [ 0  1ᵀ ] [ b ]   [ 0 ]
//! [ 1  H  ] [ a ] = [ y ],
//! ```
//!
//! is solved by one Cholesky factorisation of the symmetric positive definite H and two
//! solves, η = H⁻¹y and ν = H⁻¹1: b = 1ᵀη / 1ᵀν, a = η − bν (block elimination of the first
//! row). Cost: n³/3 flops for the factorisation, n² per solve. From [`MIXED_MIN_N`] samples
//! on, [`solve`] solves by preconditioned CG in f64 ([`super::mixed`]) to the backward error
//! of the f64 solve, with a low-rank preconditioner (no O(n³) step) or, failing that, an f32
//! Cholesky one; [`solve_f64`] is the plain f64 path. The LOO residuals need diag(H⁻¹): from
//! the same low-rank factor with a bounded correction where it is accurate enough, else from
//! the f64 factor ([`solve_with_loo`]).
//!
//! Leave-one-out residuals follow in closed form (Cawley & Talbot 2004, after Allen's PRESS):
//! with A the full (n+1)×(n+1) matrix above, y_i − f₋ᵢ(x_i) = a_i / (A⁻¹)_{i+1,i+1}, and the
//! lower-right block of A⁻¹ is H⁻¹ − ννᵀ/1ᵀν, so only diag(H⁻¹) is needed.

use faer::prelude::*;
use faer::Side;

use super::packed::PackedLower;
use super::pivoted::LowRank;
use super::{mixed, LssvmError};

/// Solution of Eq. (9): coefficients a_i and bias b, in the targets' unit (°/h).
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    /// Coefficients a_i of Eq. (10), one per training sample.
    pub alpha: Vec<f64>,
    /// Bias b of Eq. (10).
    pub bias: f64,
}

/// Checks shapes, finiteness and hyper-parameters; returns the input dimension.
/// Largest training set an exact solve accepts. The solve holds the packed kernel, then its
/// square f64 and f32 copies: about 12·n² bytes at its peak, 1.7 GB at this size.
pub const MAX_EXACT_SAMPLES: usize = 12_000;

pub(crate) fn validate(z: &[Vec<f64>], y: &[f64], sigma: f64, c: f64) -> Result<usize, LssvmError> {
    if !(sigma > 0.0 && sigma.is_finite()) {
        return Err(LssvmError::HyperParameter {
            name: "sigma",
            value: sigma,
        });
    }
    if !(c > 0.0 && c.is_finite()) {
        return Err(LssvmError::HyperParameter {
            name: "c",
            value: c,
        });
    }
    if z.is_empty() {
        return Err(LssvmError::Empty);
    }
    if z.len() != y.len() {
        return Err(LssvmError::Length {
            inputs: z.len(),
            targets: y.len(),
        });
    }
    // Refused before anything of size n² is allocated.
    if z.len() > MAX_EXACT_SAMPLES {
        return Err(LssvmError::TooLarge {
            samples: z.len(),
            max: MAX_EXACT_SAMPLES,
        });
    }
    let dim = z[0].len();
    for (i, row) in z.iter().enumerate() {
        if row.len() != dim {
            return Err(LssvmError::Dimension {
                row: i,
                got: row.len(),
                want: dim,
            });
        }
        if row.iter().any(|v| !v.is_finite()) {
            return Err(LssvmError::NonFinite {
                what: "input",
                index: i,
                feature: None,
            });
        }
    }
    if let Some(i) = y.iter().position(|v| !v.is_finite()) {
        return Err(LssvmError::NonFinite {
            what: "target",
            index: i,
            feature: None,
        });
    }
    Ok(dim)
}

/// The Cholesky factor of H and the two solves of the block elimination.
struct Factorised {
    llt: faer::linalg::solvers::Llt<f64>,
    /// ν = H⁻¹1.
    nu: Vec<f64>,
    /// 1ᵀν.
    s: f64,
    solution: Solution,
}

/// The f64 Cholesky factor of H from its lower triangle ([`mixed::h_lower`]).
fn llt_f64(h: &[f64], n: usize) -> Result<faer::linalg::solvers::Llt<f64>, LssvmError> {
    MatRef::from_column_major_slice(h, n, n)
        .llt(Side::Lower)
        .map_err(|e| match e {
            faer::linalg::solvers::LltError::NonPositivePivot { index } => {
                LssvmError::NotPositiveDefinite { pivot: index }
            }
        })
}

/// Block elimination of Eq. (9)'s first row from the two solves `x` = [η ν] = H⁻¹[y 1]:
/// b = 1ᵀη / 1ᵀν, a = η − bν; returns the solution, ν and 1ᵀν.
fn eliminate(x: MatRef<'_, f64>) -> Result<(Solution, Vec<f64>, f64), LssvmError> {
    let n = x.nrows();
    let eta: Vec<f64> = (0..n).map(|i| x[(i, 0)]).collect();
    let nu: Vec<f64> = (0..n).map(|i| x[(i, 1)]).collect();
    let s: f64 = nu.iter().sum();
    let bias = eta.iter().sum::<f64>() / s;
    let alpha: Vec<f64> = eta.iter().zip(&nu).map(|(e, v)| e - bias * v).collect();
    if !(bias.is_finite() && s.is_finite() && s != 0.0 && alpha.iter().all(|a| a.is_finite())) {
        return Err(LssvmError::Singular);
    }
    Ok((Solution { alpha, bias }, nu, s))
}

fn rhs_y1(y: &[f64]) -> Mat<f64> {
    Mat::<f64>::from_fn(y.len(), 2, |i, j| if j == 0 { y[i] } else { 1.0 })
}

fn factorise(z: &[Vec<f64>], y: &[f64], sigma: f64, c: f64) -> Result<Factorised, LssvmError> {
    validate(z, y, sigma, c)?;
    let llt = llt_f64(&mixed::h_lower(z, sigma, c), z.len())?;
    let mut rhs = rhs_y1(y);
    llt.solve_in_place(&mut rhs);
    let (solution, nu, s) = eliminate(rhs.as_ref())?;
    Ok(Factorised {
        llt,
        nu,
        s,
        solution,
    })
}

/// Eq. (9) by the f64 Cholesky alone, whatever n (the reference the mixed path is held to).
pub fn solve_f64(z: &[Vec<f64>], y: &[f64], sigma: f64, c: f64) -> Result<Solution, LssvmError> {
    factorise(z, y, sigma, c).map(|f| f.solution)
}

/// From this many samples on, [`solve`] takes the iterative paths ([`mixed`]); below, the
/// f64 Cholesky costs little and the results stay those of the plain f64 solve.
pub const MIXED_MIN_N: usize = 1000;

/// How [`solve_reporting`] solved the system.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SolvePath {
    /// f64 Cholesky (n below [`MIXED_MIN_N`]).
    F64,
    /// f64 CG preconditioned by a pivoted Cholesky factor of K of this rank.
    LowRank {
        /// Columns of the factor.
        rank: usize,
        /// CG statistics.
        stats: mixed::MixedStats,
    },
    /// The low-rank path gave up (why), then f32 Cholesky + f64 CG.
    Mixed {
        /// Why the low-rank path gave up.
        low_rank: mixed::GiveUp,
        /// CG statistics.
        stats: mixed::MixedStats,
    },
    /// Both iterative paths gave up, then f64 Cholesky.
    Fallback {
        /// Why the low-rank path gave up.
        low_rank: mixed::GiveUp,
        /// Why the mixed-precision path gave up.
        mixed: mixed::GiveUp,
    },
}

/// [`solve`], also saying which path solved it.
pub fn solve_reporting(
    z: &[Vec<f64>],
    y: &[f64],
    sigma: f64,
    c: f64,
) -> Result<(Solution, SolvePath), LssvmError> {
    validate(z, y, sigma, c)?;
    let n = z.len();
    if n < MIXED_MIN_N {
        return factorise(z, y, sigma, c).map(|f| (f.solution, SolvePath::F64));
    }
    solve_packed(&PackedLower::gaussian(z, sigma, c), z, y, sigma, c)
}

/// The iterative paths of [`solve_reporting`] (n ≥ [`MIXED_MIN_N`]) on H already filled in
/// packed form for this σ and c (`PackedLower::gaussian`, `PackedLower::set_diagonal`), so
/// that a grid over c fills the kernel once per σ. Inputs assumed validated.
pub fn solve_packed(
    packed: &PackedLower,
    z: &[Vec<f64>],
    y: &[f64],
    sigma: f64,
    c: f64,
) -> Result<(Solution, SolvePath), LssvmError> {
    let rhs = rhs_y1(y);
    match mixed::solve_low_rank(packed, z, sigma, c, rhs.as_ref()) {
        Ok((x, stats, rank)) => {
            eliminate(x.as_ref()).map(|(sol, _, _)| (sol, SolvePath::LowRank { rank, stats }))
        }
        Err(why) => after_low_rank(packed, rhs, why),
    }
}

/// [`solve_packed`] at each c of `cs` on one kernel fill `packed`: the low-rank paths of all
/// c in lock step ([`mixed::solve_low_rank_shifts`]), then the later paths one c at a time
/// for those it could not solve (with `packed`'s diagonal set to that c). The same
/// solutions, bit for bit, as [`solve_packed`] per c.
pub fn solve_packed_shifts(
    packed: &mut PackedLower,
    z: &[Vec<f64>],
    y: &[f64],
    sigma: f64,
    cs: &[f64],
) -> Vec<Result<(Solution, SolvePath), LssvmError>> {
    let rhs = rhs_y1(y);
    let low = mixed::solve_low_rank_shifts(packed, z, sigma, cs, rhs.as_ref());
    low.into_iter()
        .zip(cs)
        .map(|(r, &c)| match r {
            Ok((x, stats, rank)) => {
                eliminate(x.as_ref()).map(|(sol, _, _)| (sol, SolvePath::LowRank { rank, stats }))
            }
            Err(why) => {
                packed.set_diagonal(c);
                after_low_rank(packed, rhs.clone(), why)
            }
        })
        .collect()
}

/// The paths after the low-rank one gave up (`low_rank` says why): f32-Cholesky-
/// preconditioned CG, then the f64 Cholesky.
fn after_low_rank(
    packed: &PackedLower,
    mut rhs: Mat<f64>,
    low_rank: mixed::GiveUp,
) -> Result<(Solution, SolvePath), LssvmError> {
    let n = packed.n();
    let h = packed.to_square_lower();
    let h32: Vec<f32> = h.iter().map(|v| *v as f32).collect();
    let why = match mixed::solve(&h, h32, rhs.as_ref()) {
        Ok((x, stats)) => {
            return eliminate(x.as_ref())
                .map(|(sol, _, _)| (sol, SolvePath::Mixed { low_rank, stats }))
        }
        Err(why) => why,
    };
    let llt = llt_f64(&h, n)?;
    drop(h);
    llt.solve_in_place(&mut rhs);
    eliminate(rhs.as_ref()).map(|(sol, _, _)| {
        (
            sol,
            SolvePath::Fallback {
                low_rank,
                mixed: why,
            },
        )
    })
}

/// Solves Eq. (9) for standardised inputs `z` (rows) and targets `y`: by the f64 Cholesky of
/// K + I/c below [`MIXED_MIN_N`] samples; from there on by CG on the f64 system to the
/// backward error of that Cholesky solve, preconditioned by a low-rank factor of K, else by
/// an f32 Cholesky factor, and by the f64 Cholesky when neither converges.
pub fn solve(z: &[Vec<f64>], y: &[f64], sigma: f64, c: f64) -> Result<Solution, LssvmError> {
    solve_reporting(z, y, sigma, c).map(|(s, _)| s)
}

/// A partially linear solution: Eq. (10)'s a_i and b, and the coefficients β of the linear
/// columns.
#[derive(Clone, Debug, PartialEq)]
pub struct PartiallyLinear {
    /// Kernel part and bias.
    pub solution: Solution,
    /// One coefficient per linear column, target unit per column unit.
    pub beta: Vec<f64>,
}

/// Eq. (9) with linear regressors beside the kernel (the semiparametric LS-SVM):
/// y_i = Σ_j a_j K(z_i, z_j) + a_i/c + b + Σ_k β_k L_ik with 1ᵀa = 0 and Lᵀa = 0.
///
/// With A = [1 L] and H = K + I/c: θ = [b; β] solves (AᵀH⁻¹A)θ = AᵀH⁻¹y and a = H⁻¹(y − Aθ),
/// one Cholesky factorisation of H and 2 + p solves. `lin` holds the columns, each of length
/// n; with none this is [`solve`].
pub fn solve_partially_linear(
    z: &[Vec<f64>],
    lin: &[Vec<f64>],
    y: &[f64],
    sigma: f64,
    c: f64,
) -> Result<PartiallyLinear, LssvmError> {
    validate(z, y, sigma, c)?;
    let n = z.len();
    if let Some(col) = lin.iter().find(|col| col.len() != n) {
        return Err(LssvmError::Length {
            inputs: col.len(),
            targets: n,
        });
    }
    if lin.iter().flatten().any(|v| !v.is_finite()) {
        return Err(LssvmError::NonFinite {
            what: "input",
            index: 0,
            feature: Some("linear column".into()),
        });
    }
    partially_linear_on(&mixed::h_lower(z, sigma, c), lin, y)
}

/// The diagonal of a column-major n×n H = K + I/c (Gaussian kernel, K_ii = 1) set for `c`:
/// the kernel part of H does not depend on c, so one fill serves every c of a grid.
pub fn set_h_diagonal(h: &mut [f64], n: usize, c: f64) {
    let d = 1.0 + 1.0 / c;
    for i in 0..n {
        h[i * n + i] = d;
    }
}

/// [`solve_partially_linear`] on the lower triangle of H already filled
/// ([`mixed::h_lower`], [`set_h_diagonal`]); inputs assumed validated.
pub fn partially_linear_on(
    h: &[f64],
    lin: &[Vec<f64>],
    y: &[f64],
) -> Result<PartiallyLinear, LssvmError> {
    let n = y.len();
    let llt = llt_f64(h, n)?;
    let p = lin.len();
    // Columns: y, 1, L₁ … L_p.
    let mut rhs = Mat::<f64>::from_fn(n, p + 2, |i, j| match j {
        0 => y[i],
        1 => 1.0,
        j => lin[j - 2][i],
    });
    llt.solve_in_place(&mut rhs);
    let col = |j: usize, i: usize| match j {
        0 => 1.0,
        j => lin[j - 1][i],
    };
    let q = p + 1;
    let m = Mat::<f64>::from_fn(q, q, |r, k| {
        (0..n).map(|i| col(r, i) * rhs[(i, k + 1)]).sum()
    });
    let v = Mat::<f64>::from_fn(q, 1, |r, _| (0..n).map(|i| col(r, i) * rhs[(i, 0)]).sum());
    let theta = m.full_piv_lu().solve(&v);
    let alpha: Vec<f64> = (0..n)
        .map(|i| rhs[(i, 0)] - (0..q).map(|k| rhs[(i, k + 1)] * theta[(k, 0)]).sum::<f64>())
        .collect();
    let bias = theta[(0, 0)];
    let beta: Vec<f64> = (1..q).map(|k| theta[(k, 0)]).collect();
    if !(bias.is_finite() && alpha.iter().chain(&beta).all(|a| a.is_finite())) {
        return Err(LssvmError::Singular);
    }
    Ok(PartiallyLinear {
        solution: Solution { alpha, bias },
        beta,
    })
}

/// Solves Eq. (9) and returns the leave-one-out residuals y_i − f₋ᵢ(x_i) (PRESS) with it.
///
/// Below [`MIXED_MIN_N`] samples one f64 factorisation serves both: with H = LLᵀ,
/// (H⁻¹)_ii = ‖column i of L⁻¹‖², so the triangular inverse (n³/3 flops) replaces the full
/// inverse L⁻ᵀL⁻¹ (2n³/3). From there on the solution comes from [`solve`]'s low-rank path
/// and diag(H⁻¹) from the pivoted Cholesky factor of K and one first-order correction
/// ([`LowRank::inverse_diagonal`], O(n²·r)), taken when the bound on what the correction
/// leaves out is below [`LOO_REL_TOL`] of every residual's denominator; otherwise (a narrow
/// kernel, whose spectrum falls off slowly) the f64 factorisation as below.
pub fn solve_with_loo(
    z: &[Vec<f64>],
    y: &[f64],
    sigma: f64,
    c: f64,
) -> Result<(Solution, Vec<f64>), LssvmError> {
    validate(z, y, sigma, c)?;
    if z.len() >= MIXED_MIN_N {
        if let Some(out) = loo_low_rank(z, y, sigma, c)? {
            return Ok(out);
        }
    }
    loo_dense(z, y, sigma, c)
}

/// Largest relative error of a leave-one-out residual that the low-rank path's bound may
/// allow (rounding aside; the dense path's own is about cond(H)·ε, 1e-11 at c = 42 and
/// n = 5 000).
pub const LOO_REL_TOL: f64 = 1e-10;

/// The low-rank path of [`solve_with_loo`]; `None` when it cannot reach [`LOO_REL_TOL`].
fn loo_low_rank(
    z: &[Vec<f64>],
    y: &[f64],
    sigma: f64,
    c: f64,
) -> Result<Option<(Solution, Vec<f64>)>, LssvmError> {
    let n = z.len();
    let h = PackedLower::gaussian(z, sigma, c);
    let rhs = rhs_y1(y);
    let Ok((x, _, _)) = mixed::solve_low_rank(&h, z, sigma, c, rhs.as_ref()) else {
        return Ok(None);
    };
    let (solution, nu, s) = eliminate(x.as_ref())?;
    // Columns until c·Σd ≤ 1e-6, so that the bound c·ρ²/(1 − ρ) is about 1e-12·c.
    let tol = 1e-6 / (c * n as f64);
    let Some(p) = LowRank::build(z, sigma, 1.0 / c, mixed::low_rank_max(n), tol) else {
        return Ok(None);
    };
    let Some((diag, bound)) = p.inverse_diagonal(z, sigma, 1.0 / c) else {
        return Ok(None);
    };
    let a_inv: Vec<f64> = diag.iter().zip(&nu).map(|(d, v)| d - v * v / s).collect();
    let smallest = a_inv.iter().map(|v| v.abs()).fold(f64::INFINITY, f64::min);
    if bound.is_nan() || smallest.is_nan() || bound > LOO_REL_TOL * smallest {
        return Ok(None);
    }
    let r: Vec<f64> = solution
        .alpha
        .iter()
        .zip(&a_inv)
        .map(|(a, d)| a / d)
        .collect();
    if r.iter().any(|v| !v.is_finite()) {
        return Err(LssvmError::Singular);
    }
    Ok(Some((solution, r)))
}

/// [`solve_with_loo`] by the f64 factorisation and the triangular inverse, whatever n.
pub fn loo_dense(
    z: &[Vec<f64>],
    y: &[f64],
    sigma: f64,
    c: f64,
) -> Result<(Solution, Vec<f64>), LssvmError> {
    let f = factorise(z, y, sigma, c)?;
    let n = z.len();
    let mut l_inv = Mat::<f64>::zeros(n, n);
    faer::linalg::triangular_inverse::invert_lower_triangular(
        l_inv.as_mut(),
        f.llt.L(),
        faer::get_global_parallelism(),
    );
    let r: Vec<f64> = (0..n)
        .map(|i| {
            // Column i of the lower-triangular L⁻¹ is non-zero from row i down.
            let h_inv_ii: f64 = (i..n).map(|k| l_inv[(k, i)] * l_inv[(k, i)]).sum();
            let a_inv_ii = h_inv_ii - f.nu[i] * f.nu[i] / f.s;
            f.solution.alpha[i] / a_inv_ii
        })
        .collect();
    if r.iter().any(|v| !v.is_finite()) {
        return Err(LssvmError::Singular);
    }
    Ok((f.solution, r))
}

/// Leave-one-out residuals y_i − f₋ᵢ(x_i) of Eq. (9) in closed form (see the module doc).
pub fn loo_residuals(
    z: &[Vec<f64>],
    y: &[f64],
    sigma: f64,
    c: f64,
) -> Result<Vec<f64>, LssvmError> {
    solve_with_loo(z, y, sigma, c).map(|(_, r)| r)
}

/// Reference solution: the full (n+1)×(n+1) system of Eq. (9) assembled as printed and solved
/// by LU with partial pivoting. O((n+1)³) and independent of the Cholesky path; for tests.
pub fn solve_dense_reference(
    z: &[Vec<f64>],
    y: &[f64],
    sigma: f64,
    c: f64,
) -> Result<Solution, LssvmError> {
    validate(z, y, sigma, c)?;
    let n = z.len();
    let inv = 1.0 / (2.0 * sigma * sigma);
    let a = Mat::<f64>::from_fn(n + 1, n + 1, |i, j| match (i, j) {
        (0, 0) => 0.0,
        (0, _) | (_, 0) => 1.0,
        _ => {
            let d2: f64 = z[i - 1]
                .iter()
                .zip(&z[j - 1])
                .map(|(p, q)| (p - q).powi(2))
                .sum();
            (-d2 * inv).exp() + if i == j { 1.0 / c } else { 0.0 }
        }
    });
    let rhs = Mat::<f64>::from_fn(n + 1, 1, |i, _| if i == 0 { 0.0 } else { y[i - 1] });
    let x = a.partial_piv_lu().solve(&rhs);
    let bias = x[(0, 0)];
    let alpha: Vec<f64> = (1..=n).map(|i| x[(i, 0)]).collect();
    if !(bias.is_finite() && alpha.iter().all(|v| v.is_finite())) {
        return Err(LssvmError::Singular);
    }
    Ok(Solution { alpha, bias })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lssvm::kernel_matrix;

    use crate::lssvm::test_data::scattered as data;

    fn rel_err(a: f64, b: f64, scale: f64) -> f64 {
        (a - b).abs() / scale
    }

    /// A training set beyond the exact solve's size is refused before the kernel matrix is
    /// formed (93 600 samples would take 105 GB), with the block size that would fit.
    #[test]
    fn too_many_samples_are_refused_before_allocating() {
        let n = 93_600;
        let z: Vec<Vec<f64>> = (0..n).map(|i| vec![i as f64 / n as f64]).collect();
        let y = vec![0.0; n];
        let e = solve(&z, &y, 1.0, 10.0).unwrap_err();
        assert!(
            matches!(
                e,
                LssvmError::TooLarge {
                    samples: 93_600,
                    max: MAX_EXACT_SAMPLES
                }
            ),
            "{e:?}"
        );
        let m = e.to_string();
        assert!(
            m.contains("--block 8") && m.contains("--budget") && m.contains("105.1 GB"),
            "{m}"
        );
        assert!(loo_residuals(&z, &y, 1.0, 10.0).is_err());
    }

    /// The partially linear solve equals the full bordered system assembled as written
    /// ([[H, 1, L], [1ᵀ, 0, 0], [Lᵀ, 0, 0]] solved by dense LU), and with no linear column
    /// it is the plain solve.
    #[test]
    fn partially_linear_matches_the_bordered_system() {
        let (z, y) = crate::lssvm::test_data::scattered(60);
        let lin: Vec<Vec<f64>> = vec![
            z.iter().map(|r| r[0] * r[1]).collect(),
            z.iter().map(|r| (r[1] * 2.0).cos()).collect(),
        ];
        let (sigma, c) = (0.8, 200.0);
        let got = solve_partially_linear(&z, &lin, &y, sigma, c).unwrap();
        let n = z.len();
        let k = kernel_matrix(&z, sigma);
        let dim = n + 3;
        let a = Mat::<f64>::from_fn(dim, dim, |i, j| match (i < n, j < n) {
            (true, true) => k[(i, j)] + if i == j { 1.0 / c } else { 0.0 },
            (true, false) => {
                if j == n {
                    1.0
                } else {
                    lin[j - n - 1][i]
                }
            }
            (false, true) => {
                if i == n {
                    1.0
                } else {
                    lin[i - n - 1][j]
                }
            }
            (false, false) => 0.0,
        });
        let b = Mat::<f64>::from_fn(dim, 1, |i, _| if i < n { y[i] } else { 0.0 });
        let x = a.full_piv_lu().solve(&b);
        for i in 0..n {
            assert!((got.solution.alpha[i] - x[(i, 0)]).abs() < 1e-8 * (1.0 + x[(i, 0)].abs()));
        }
        assert!((got.solution.bias - x[(n, 0)]).abs() < 1e-9);
        for kk in 0..2 {
            assert!((got.beta[kk] - x[(n + 1 + kk, 0)]).abs() < 1e-9, "{kk}");
        }
        let plain = solve(&z, &y, sigma, c).unwrap();
        let none = solve_partially_linear(&z, &[], &y, sigma, c).unwrap();
        for i in 0..n {
            assert!((plain.alpha[i] - none.solution.alpha[i]).abs() < 1e-9);
        }
    }

    #[test]
    fn cholesky_matches_dense_lu_of_eq9() {
        for &(sigma, c) in &[(0.5, 10.0), (1.0, 1000.0), (2.0, 1.0e5)] {
            let (z, y) = data(120);
            let s = solve(&z, &y, sigma, c).unwrap();
            let r = solve_dense_reference(&z, &y, sigma, c).unwrap();
            let amax = r.alpha.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let worst = s
                .alpha
                .iter()
                .zip(&r.alpha)
                .map(|(a, b)| rel_err(*a, *b, amax))
                .fold(0.0, f64::max);
            assert!(worst < 1e-9, "σ={sigma} c={c}: alpha rel err {worst}");
            assert!(
                rel_err(s.bias, r.bias, r.bias.abs().max(amax)) < 1e-9,
                "bias {} vs {}",
                s.bias,
                r.bias
            );
            // Eq. (9)'s first row: Σ a_i = 0.
            assert!(s.alpha.iter().sum::<f64>().abs() < 1e-9 * amax * 120.0);
        }
    }

    #[test]
    fn loo_residuals_match_brute_force_refits() {
        let (z, y) = data(40);
        let (sigma, c) = (0.8, 200.0);
        let (sol, r) = solve_with_loo(&z, &y, sigma, c).unwrap();
        assert_eq!(sol, solve(&z, &y, sigma, c).unwrap());
        for (i, r_i) in r.iter().enumerate() {
            let mut zi = z.clone();
            let mut yi = y.clone();
            let xi = zi.remove(i);
            let target = yi.remove(i);
            let s = solve_dense_reference(&zi, &yi, sigma, c).unwrap();
            let inv = 1.0 / (2.0 * sigma * sigma);
            let pred: f64 = zi
                .iter()
                .zip(&s.alpha)
                .map(|(sv, a)| {
                    a * (-(sv[0] - xi[0]).powi(2) * inv - (sv[1] - xi[1]).powi(2) * inv).exp()
                })
                .sum::<f64>()
                + s.bias;
            let brute = target - pred;
            assert!(
                (r_i - brute).abs() <= 1e-8 * brute.abs().max(1e-3),
                "{i}: {} vs {brute}",
                r_i
            );
        }
    }

    /// From [`MIXED_MIN_N`] on, the LOO residuals from the low-rank factor equal the dense
    /// factorisation's within the dense path's own rounding (measured: 4e-12, 7e-10 and 2e-14
    /// of the largest residual at the three points below); a narrow kernel, whose
    /// spectrum the factor cannot capture, falls back to the dense path.
    #[test]
    fn low_rank_loo_residuals_equal_the_dense_ones() {
        let n = 1500;
        let (z, y) = data(n);
        for (sigma, c) in [(0.67, 42.0), (1.5, 1e4), (1.0, 1.0)] {
            let (sol, r) = solve_with_loo(&z, &y, sigma, c).unwrap();
            assert!(
                loo_low_rank(&z, &y, sigma, c).unwrap().is_some(),
                "σ {sigma}, c {c}: the low-rank path gave up"
            );
            let (sol_d, r_d) = loo_dense(&z, &y, sigma, c).unwrap();
            let scale = r_d.iter().map(|v| v.abs()).fold(0.0, f64::max);
            let worst = r
                .iter()
                .zip(&r_d)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            // The dense path's own rounding is about cond(H)·ε ≤ (1 + c·n)·ε.
            let tol = 1e-10 + c * n as f64 * f64::EPSILON;
            assert!(
                worst <= tol * scale,
                "σ {sigma}, c {c}: {worst:e} of {scale:e}"
            );
            assert_eq!(sol, solve(&z, &y, sigma, c).unwrap());
            let da = sol
                .alpha
                .iter()
                .zip(&sol_d.alpha)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(da <= 1e-9 * sol_d.alpha.iter().map(|v| v.abs()).fold(0.0, f64::max));
        }
        // σ = 0.05 on these inputs needs more columns than `low_rank_max` allows.
        assert!(loo_low_rank(&z, &y, 0.05, 42.0).unwrap().is_none());
        assert_eq!(
            solve_with_loo(&z, &y, 0.05, 42.0).unwrap().1,
            loo_dense(&z, &y, 0.05, 42.0).unwrap().1
        );
    }

    #[test]
    fn kernel_matrix_is_symmetric_gaussian() {
        // 150 rows: columns of every length modulo the kernel's four lanes.
        let (z, _) = data(150);
        let k = kernel_matrix(&z, 0.7);
        for i in 0..150 {
            for j in 0..150 {
                let d2: f64 = (0..2).map(|d| (z[i][d] - z[j][d]).powi(2)).sum();
                assert_eq!(k[(i, j)], k[(j, i)]);
                assert!((k[(i, j)] - (-d2 / (2.0 * 0.49)).exp()).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let (z, y) = data(10);
        assert!(matches!(
            solve(&z, &y, 0.0, 1.0),
            Err(LssvmError::HyperParameter { name: "sigma", .. })
        ));
        assert!(matches!(
            solve(&z, &y, 1.0, -1.0),
            Err(LssvmError::HyperParameter { name: "c", .. })
        ));
        assert!(matches!(
            solve(&z, &y, f64::NAN, 1.0),
            Err(LssvmError::HyperParameter { .. })
        ));
        assert!(matches!(
            solve(&z, &y[..9], 1.0, 1.0),
            Err(LssvmError::Length { .. })
        ));
        assert!(matches!(solve(&[], &[], 1.0, 1.0), Err(LssvmError::Empty)));
        let mut y2 = y.clone();
        y2[3] = f64::NAN;
        assert!(matches!(
            solve(&z, &y2, 1.0, 1.0),
            Err(LssvmError::NonFinite {
                what: "target",
                index: 3,
                ..
            })
        ));
        let mut z2 = z.clone();
        z2[2] = vec![1.0];
        assert!(matches!(
            solve(&z2, &y, 1.0, 1.0),
            Err(LssvmError::Dimension { row: 2, .. })
        ));
    }

    #[test]
    fn duplicated_inputs_with_huge_c_fail_cleanly() {
        // Identical inputs make K singular; with 1/c below rounding the factorisation must
        // report failure (or the solve non-finiteness), never panic or return garbage.
        let z = vec![vec![0.0, 0.0]; 6];
        let y = vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        match solve(&z, &y, 1.0, 1e300) {
            Err(LssvmError::NotPositiveDefinite { .. }) | Err(LssvmError::Singular) => {}
            other => panic!("expected a factorisation failure, got {other:?}"),
        }
    }
}
