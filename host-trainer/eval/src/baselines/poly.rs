//! Least-squares polynomial in one variable (the paper's "least-squares quadratic model" of
//! Table 1 / Fig. 2(a) is degree 2), with coefficient standard errors and exact
//! leave-one-out residuals from the hat matrix.
//!
//! The fit is made in t = (x − centre)/scale (centre = mean, scale = population standard
//! deviation of x) so the Vandermonde columns are of order 1; coefficients are then converted
//! to the raw power basis a₀ + a₁x + … + a_d x^d, with their covariance propagated.

use super::ols::{ols, Ols, OlsError};

/// Why a polynomial fit could not be made.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PolyError {
    /// x and y differ in length.
    #[error("x has {x} points, y has {y}")]
    LengthMismatch {
        /// Length of x.
        x: usize,
        /// Length of y.
        y: usize,
    },
    /// All x equal: only degree 0 is identifiable.
    #[error("all x values are equal; a degree-{degree} polynomial is not identifiable")]
    ConstantX {
        /// Requested degree.
        degree: usize,
    },
    /// A NaN or infinite x.
    #[error("non-finite x at point {0}")]
    NonFiniteX(usize),
    /// The underlying least-squares solve failed.
    #[error(transparent)]
    Ols(#[from] OlsError),
}

/// A fitted polynomial y ≈ Σ aₖ xᵏ, in the units of the x and y it was fitted to.
#[derive(Debug, Clone, PartialEq)]
pub struct PolyFit {
    degree: usize,
    centre: f64,
    scale: f64,
    /// Coefficients in the scaled variable t, ascending powers.
    scaled: Vec<f64>,
    /// Coefficients in the raw variable x, ascending powers.
    raw: Vec<f64>,
    /// Standard errors of `raw`.
    raw_se: Vec<f64>,
    fit: Ols,
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

impl PolyFit {
    /// Fits a polynomial of `degree` to the points (x, y) by least squares.
    pub fn fit(x: &[f64], y: &[f64], degree: usize) -> Result<Self, PolyError> {
        if x.len() != y.len() {
            return Err(PolyError::LengthMismatch {
                x: x.len(),
                y: y.len(),
            });
        }
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(PolyError::NonFiniteX(i));
        }
        let n = x.len().max(1) as f64;
        let centre = x.iter().sum::<f64>() / n;
        let sd = (x.iter().map(|v| (v - centre).powi(2)).sum::<f64>() / n).sqrt();
        if sd == 0.0 && degree > 0 {
            return Err(PolyError::ConstantX { degree });
        }
        let scale = if sd > 0.0 { sd } else { 1.0 };
        let t: Vec<f64> = x.iter().map(|v| (v - centre) / scale).collect();
        let columns: Vec<Vec<f64>> = (0..=degree)
            .map(|k| t.iter().map(|ti| ti.powi(k as i32)).collect())
            .collect();
        let fit = ols(&columns, y)?;

        // Σₖ bₖ ((x − c)/s)ᵏ = Σⱼ xʲ Σₖ≥ⱼ bₖ C(k, j) (−c)^(k−j) / sᵏ, i.e. a = M b.
        let p = degree + 1;
        let m = |j: usize, k: usize| {
            if k < j {
                0.0
            } else {
                binomial(k, j) * (-centre).powi((k - j) as i32) / scale.powi(k as i32)
            }
        };
        let raw: Vec<f64> = (0..p)
            .map(|j| (0..p).map(|k| m(j, k) * fit.coef[k]).sum())
            .collect();
        // Var(aⱼ) = Σₖ Σₗ Mⱼₖ Cov(bₖ, bₗ) Mⱼₗ
        let raw_se = (0..p)
            .map(|j| {
                (0..p)
                    .flat_map(|k| (0..p).map(move |l| (k, l)))
                    .map(|(k, l)| m(j, k) * fit.cov(k, l) * m(j, l))
                    .sum::<f64>()
                    .sqrt()
            })
            .collect();
        Ok(Self {
            degree,
            centre,
            scale,
            scaled: fit.coef.clone(),
            raw,
            raw_se,
            fit,
        })
    }

    /// Degree of the polynomial.
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Coefficients a₀ … a_d of 1, x, …, x^d (raw units: [y]/[x]ᵏ).
    pub fn coefficients(&self) -> &[f64] {
        &self.raw
    }

    /// Standard errors of [`Self::coefficients`], from σ² = RSS/(n − d − 1).
    pub fn std_errors(&self) -> &[f64] {
        &self.raw_se
    }

    /// Evaluates the polynomial at `x` (Horner in the scaled variable, which is what was
    /// solved for; the raw coefficients lose digits when |centre| ≫ scale).
    pub fn predict(&self, x: f64) -> f64 {
        let t = (x - self.centre) / self.scale;
        self.scaled.iter().rev().fold(0.0, |acc, b| acc * t + b)
    }

    /// Training residuals yᵢ − ŷᵢ, in the unit of y.
    pub fn residuals(&self) -> &[f64] {
        &self.fit.residuals
    }

    /// Leverages hᵢᵢ of the points.
    pub fn leverage(&self) -> &[f64] {
        &self.fit.leverage
    }

    /// Residual standard deviation σ = √(RSS/(n − d − 1)), in the unit of y.
    pub fn sigma(&self) -> f64 {
        self.fit.sigma2().sqrt()
    }

    /// Exact leave-one-out residuals yᵢ − ŷ₍₋ᵢ₎ = eᵢ/(1 − hᵢᵢ): the error at point i of the
    /// polynomial refitted without it.
    pub fn loo_residuals(&self) -> Result<Vec<f64>, PolyError> {
        Ok(self.fit.loo_residuals()?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic noise in [−1, 1) from an LCG, so tests need no RNG crate.
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 52) as f64 - 1.0
            })
            .collect()
    }

    /// Hand-computed line (see ols tests): x = 0..3, y = [1, 3, 2, 5] → a = [1.1, 1.1],
    /// se(a₁) = √(1.35/5), se(a₀) = √(1.35 · 0.7); LOO residuals e/(1 − h) with
    /// h = [0.7, 0.3, 0.3, 0.7].
    #[test]
    fn line_matches_hand_computation() {
        let f = PolyFit::fit(&[0.0, 1.0, 2.0, 3.0], &[1.0, 3.0, 2.0, 5.0], 1).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(f.coefficients()[0], 1.1) && close(f.coefficients()[1], 1.1));
        assert!(close(f.std_errors()[1], (1.35f64 / 5.0).sqrt()));
        assert!(close(f.std_errors()[0], (1.35f64 * 0.7).sqrt()));
        let loo = f.loo_residuals().unwrap();
        for (l, e) in loo
            .iter()
            .zip([-0.1 / 0.3, 0.8 / 0.7, -1.3 / 0.7, 0.6 / 0.3])
        {
            assert!(close(*l, e), "{l} vs {e}");
        }
    }

    /// Noise-free quadratic far from the origin (x in 1000..1100, where a raw Vandermonde
    /// would be badly conditioned) is recovered to near machine precision.
    #[test]
    fn recovers_exact_quadratic_far_from_origin() {
        let a = [2.0, -3.0, 0.5e-3];
        let x: Vec<f64> = (0..20).map(|i| 1000.0 + 5.0 * i as f64).collect();
        let y: Vec<f64> = x.iter().map(|x| a[0] + a[1] * x + a[2] * x * x).collect();
        let f = PolyFit::fit(&x, &y, 2).unwrap();
        for (got, want) in f.coefficients().iter().zip(a) {
            assert!((got - want).abs() <= 1e-6 * want.abs(), "{got} vs {want}");
        }
        for (xi, yi) in x.iter().zip(&y) {
            assert!((f.predict(*xi) - yi).abs() < 1e-9 * yi.abs());
        }
    }

    /// The hat-matrix LOO residuals equal brute-force refits with each point dropped.
    #[test]
    fn loo_matches_brute_force_refits() {
        let n = 15;
        let x: Vec<f64> = (0..n).map(|i| -35.0 + 7.0 * i as f64).collect();
        let e = noise(n, 3);
        let y: Vec<f64> = x
            .iter()
            .zip(&e)
            .map(|(x, e)| -7.1 - 4e-4 * x + 2e-6 * x * x + 1e-3 * e)
            .collect();
        for degree in 1..=3 {
            let f = PolyFit::fit(&x, &y, degree).unwrap();
            let loo = f.loo_residuals().unwrap();
            for i in 0..n {
                let (xs, ys): (Vec<f64>, Vec<f64>) =
                    (0..n).filter(|&j| j != i).map(|j| (x[j], y[j])).unzip();
                let g = PolyFit::fit(&xs, &ys, degree).unwrap();
                let brute = y[i] - g.predict(x[i]);
                assert!(
                    (loo[i] - brute).abs() < 1e-12,
                    "deg {degree} pt {i}: {} vs {brute}",
                    loo[i]
                );
            }
        }
    }

    /// Standard errors in raw units agree with the covariance of an unscaled fit made
    /// directly on raw powers (well conditioned here: x in [−1, 1]).
    #[test]
    fn raw_std_errors_match_unscaled_fit() {
        let n = 12;
        let x: Vec<f64> = (0..n)
            .map(|i| -1.0 + 2.0 * i as f64 / (n - 1) as f64)
            .collect();
        let e = noise(n, 9);
        let y: Vec<f64> = x
            .iter()
            .zip(&e)
            .map(|(x, e)| 1.0 + x - 2.0 * x * x + 0.1 * e)
            .collect();
        let f = PolyFit::fit(&x, &y, 2).unwrap();
        let cols: Vec<Vec<f64>> = (0..3)
            .map(|k| x.iter().map(|x| x.powi(k)).collect())
            .collect();
        let direct = ols(&cols, &y).unwrap();
        for k in 0..3 {
            assert!((f.coefficients()[k] - direct.coef[k]).abs() < 1e-12);
            assert!((f.std_errors()[k] - direct.std_errors()[k]).abs() < 1e-12);
        }
    }

    #[test]
    fn bad_inputs_are_errors() {
        assert!(matches!(
            PolyFit::fit(&[1.0], &[1.0, 2.0], 1),
            Err(PolyError::LengthMismatch { .. })
        ));
        assert!(matches!(
            PolyFit::fit(&[2.0; 4], &[1.0; 4], 1),
            Err(PolyError::ConstantX { .. })
        ));
        assert!(matches!(
            PolyFit::fit(&[0.0, 1.0, 2.0], &[1.0; 3], 2),
            Err(PolyError::Ols(_))
        ));
    }
}
