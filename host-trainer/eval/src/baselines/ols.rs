//! Ordinary least squares through a thin Householder QR factorisation (faer), the shared
//! solver of the polynomial and stepwise baselines.
//!
//! QR instead of the normal equations: the paper's candidate terms span ~11 decades
//! (T³ ≈ 1e5 vs (dT/dt)³ ≈ 1e-6), and forming XᵀX would square the condition number.
//! Callers still centre/scale their columns first; this module works in whatever units the
//! design columns are given in.

use faer::linalg::triangular_solve::solve_upper_triangular_in_place;
use faer::{Mat, Par};

/// A column is treated as linearly dependent on the previous ones when its QR pivot is below
/// this fraction of its own norm (i.e. the part of it outside their span is ≤ 1e-10 of it).
pub const RANK_TOL: f64 = 1e-10;

/// A point whose leverage is this close to 1 has an undefined leave-one-out residual.
pub const LEVERAGE_TOL: f64 = 1e-12;

/// Why a least-squares fit could not be made.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OlsError {
    /// A design column and the response differ in length.
    #[error("design column {column} has {got} rows, the response has {expected}")]
    LengthMismatch {
        /// Index of the offending column.
        column: usize,
        /// Its length.
        got: usize,
        /// Length of the response.
        expected: usize,
    },
    /// No residual degrees of freedom: need more points than parameters.
    #[error("{points} points cannot fit {params} parameters with a residual variance (need more points than parameters)")]
    TooFewPoints {
        /// Number of observations.
        points: usize,
        /// Number of parameters.
        params: usize,
    },
    /// The design has no columns.
    #[error("the design has no columns")]
    NoColumns,
    /// A NaN or infinite value in the design or response.
    #[error("non-finite value at row {row} ({where_})")]
    NonFinite {
        /// Row index.
        row: usize,
        /// `"response"` or `"design"`.
        where_: &'static str,
    },
    /// A column lies (numerically) in the span of the preceding ones.
    #[error("design column {column} is linearly dependent on the preceding columns")]
    RankDeficient {
        /// Index of the dependent column.
        column: usize,
    },
    /// Leave-one-out residual undefined: the point fixes its own fitted value (leverage ≈ 1).
    #[error("point {row} has leverage ≈ 1; its leave-one-out residual is undefined")]
    LeverageOne {
        /// Row index.
        row: usize,
    },
}

/// A least-squares fit y ≈ Xβ; all quantities in the units of the given columns and response.
#[derive(Debug, Clone, PartialEq)]
pub struct Ols {
    /// β, one per design column.
    pub coef: Vec<f64>,
    /// (XᵀX)⁻¹, p × p row-major; the coefficient covariance is σ² times this.
    pub cov_unscaled: Vec<f64>,
    /// Residuals y − ŷ, one per point.
    pub residuals: Vec<f64>,
    /// Leverages hᵢᵢ (diagonal of the hat matrix X(XᵀX)⁻¹Xᵀ), each in [0, 1].
    pub leverage: Vec<f64>,
    /// Residual sum of squares Σ(y − ŷ)².
    pub rss: f64,
    /// Residual degrees of freedom n − p.
    pub dof: usize,
}

impl Ols {
    /// Number of parameters p.
    pub fn params(&self) -> usize {
        self.coef.len()
    }

    /// Residual variance estimate σ² = RSS / (n − p).
    pub fn sigma2(&self) -> f64 {
        self.rss / self.dof as f64
    }

    /// Coefficient covariance σ²(XᵀX)⁻¹ entry (i, j).
    pub fn cov(&self, i: usize, j: usize) -> f64 {
        self.sigma2() * self.cov_unscaled[i * self.params() + j]
    }

    /// Standard errors √(σ²[(XᵀX)⁻¹]ᵢᵢ) of the coefficients.
    pub fn std_errors(&self) -> Vec<f64> {
        (0..self.params()).map(|i| self.cov(i, i).sqrt()).collect()
    }

    /// Exact leave-one-out residuals yᵢ − ŷ₍₋ᵢ₎ = eᵢ / (1 − hᵢᵢ) (no refits needed).
    pub fn loo_residuals(&self) -> Result<Vec<f64>, OlsError> {
        self.residuals
            .iter()
            .zip(&self.leverage)
            .enumerate()
            .map(|(row, (e, h))| {
                if 1.0 - h <= LEVERAGE_TOL {
                    Err(OlsError::LeverageOne { row })
                } else {
                    Ok(e / (1.0 - h))
                }
            })
            .collect()
    }
}

/// Least squares of `y` on the given design columns (no intercept is added: pass a column of
/// ones for one).
pub fn ols(columns: &[Vec<f64>], y: &[f64]) -> Result<Ols, OlsError> {
    let n = y.len();
    let p = columns.len();
    if p == 0 {
        return Err(OlsError::NoColumns);
    }
    for (column, c) in columns.iter().enumerate() {
        if c.len() != n {
            return Err(OlsError::LengthMismatch {
                column,
                got: c.len(),
                expected: n,
            });
        }
        if let Some(row) = c.iter().position(|v| !v.is_finite()) {
            return Err(OlsError::NonFinite {
                row,
                where_: "design",
            });
        }
    }
    if let Some(row) = y.iter().position(|v| !v.is_finite()) {
        return Err(OlsError::NonFinite {
            row,
            where_: "response",
        });
    }
    if n <= p {
        return Err(OlsError::TooFewPoints {
            points: n,
            params: p,
        });
    }

    let x = Mat::from_fn(n, p, |i, j| columns[j][i]);
    let qr = x.qr();
    let r = qr.thin_R().to_owned();
    for (column, c) in columns.iter().enumerate() {
        let norm = c.iter().map(|v| v * v).sum::<f64>().sqrt();
        if r[(column, column)].abs() <= RANK_TOL * norm || norm == 0.0 {
            return Err(OlsError::RankDeficient { column });
        }
    }
    let q = qr.compute_thin_Q();

    // β = R⁻¹ Qᵀ y
    let yv = Mat::from_fn(n, 1, |i, _| y[i]);
    let mut beta = q.transpose() * &yv;
    solve_upper_triangular_in_place(r.as_ref(), beta.as_mut(), Par::Seq);
    let coef: Vec<f64> = (0..p).map(|j| beta[(j, 0)]).collect();

    // (XᵀX)⁻¹ = R⁻¹ R⁻ᵀ
    let mut rinv = Mat::<f64>::identity(p, p);
    solve_upper_triangular_in_place(r.as_ref(), rinv.as_mut(), Par::Seq);
    let cov_m = &rinv * rinv.transpose();
    let cov_unscaled = (0..p * p).map(|k| cov_m[(k / p, k % p)]).collect();

    let residuals: Vec<f64> = (0..n)
        .map(|i| y[i] - (0..p).map(|j| columns[j][i] * coef[j]).sum::<f64>())
        .collect();
    let leverage = (0..n)
        .map(|i| (0..p).map(|j| q[(i, j)] * q[(i, j)]).sum())
        .collect();
    let rss = residuals.iter().map(|e| e * e).sum();
    Ok(Ols {
        coef,
        cov_unscaled,
        residuals,
        leverage,
        rss,
        dof: n - p,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hand-computed simple regression: x = 0..3, y = [1, 3, 2, 5] → x̄ = 1.5, ȳ = 2.75,
    /// Sxx = 5, Sxy = 5.5, slope 1.1, intercept 1.1, residuals [−0.1, 0.8, −1.3, 0.6],
    /// RSS 2.7, σ² = 1.35, se(slope) = √(1.35/5), se(intercept) = √(1.35(1/4 + 2.25/5)),
    /// leverages 1/n + (x − x̄)²/Sxx = [0.7, 0.3, 0.3, 0.7].
    #[test]
    fn simple_regression_matches_hand_computation() {
        let fit = ols(
            &[vec![1.0; 4], vec![0.0, 1.0, 2.0, 3.0]],
            &[1.0, 3.0, 2.0, 5.0],
        )
        .unwrap();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(
            close(fit.coef[0], 1.1) && close(fit.coef[1], 1.1),
            "{:?}",
            fit.coef
        );
        for (r, e) in fit.residuals.iter().zip([-0.1, 0.8, -1.3, 0.6]) {
            assert!(close(*r, e));
        }
        assert!(close(fit.rss, 2.7));
        assert_eq!(fit.dof, 2);
        let se = fit.std_errors();
        assert!(close(se[1], (1.35f64 / 5.0).sqrt()));
        assert!(close(se[0], (1.35f64 * (0.25 + 0.45)).sqrt()));
        for (h, e) in fit.leverage.iter().zip([0.7, 0.3, 0.3, 0.7]) {
            assert!(close(*h, e));
        }
    }

    #[test]
    fn bad_inputs_are_errors() {
        let y = [1.0, 2.0, 3.0];
        assert_eq!(ols(&[], &y), Err(OlsError::NoColumns));
        assert!(matches!(
            ols(&[vec![1.0; 2]], &y),
            Err(OlsError::LengthMismatch { .. })
        ));
        assert!(matches!(
            ols(&[vec![1.0; 3], vec![2.0; 3]], &y),
            Err(OlsError::RankDeficient { column: 1 })
        ));
        assert!(matches!(
            ols(&[vec![1.0; 3]], &[1.0, f64::NAN, 3.0]),
            Err(OlsError::NonFinite { row: 1, .. })
        ));
        assert!(matches!(
            ols(
                &[vec![1.0; 3], vec![0.0, 1.0, 2.0], vec![0.0, 1.0, 4.0]],
                &y
            ),
            Err(OlsError::TooFewPoints { .. })
        ));
    }
}
