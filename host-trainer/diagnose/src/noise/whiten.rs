//! Whitening of the 100 s-mean residual for the tests: 1 Hz gyro noise is coloured, so the
//! 100 s means are correlated, and least squares on whitened data is the efficient (GLS)
//! fit. The whitener is the exact Cholesky factor of the fitted gyro noise's block-mean
//! covariance ([`GlsWhitener`]); an AR(p ≤ 3) filter chosen by BIC ([`ArModel`]) whitens
//! the first pass (before the noise is fitted) and recordings too long for the dense
//! factor. The AR(3) filter alone cannot represent the bank's correlation times of up to
//! 100 blocks, and slow effects compete with exactly that slow noise.

use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::linalg::Basis;

/// Largest AR order tried.
const MAX_ORDER: usize = 3;

/// A fitted AR(p) model of a series of 100 s means.
#[derive(Clone, Debug, PartialEq)]
pub struct ArModel {
    /// Coefficients φ_1 … φ_p.
    pub phi: Vec<f64>,
    /// Innovation standard deviation, °/h.
    pub sigma: f64,
}

impl ArModel {
    /// Fits AR(p) for p = 0 … 3 by least squares on `r` and keeps the lowest BIC.
    pub fn fit(r: &[f64]) -> ArModel {
        let n = r.len();
        let mut best: Option<(f64, ArModel)> = None;
        for p in 0..=MAX_ORDER.min(n.saturating_sub(10) / 2) {
            let rows = n - MAX_ORDER;
            let y = &r[MAX_ORDER..];
            let cols: Vec<Vec<f64>> = (1..=p)
                .map(|lag| r[MAX_ORDER - lag..n - lag].to_vec())
                .collect();
            let basis = Basis::new(&cols);
            let res = basis.residual(y);
            let rss: f64 = res.iter().map(|v| v * v).sum();
            let phi = basis.coefficients(y);
            let bic =
                rows as f64 * (rss / rows as f64).max(1e-300).ln() + p as f64 * (rows as f64).ln();
            let stable = phi.iter().map(|v| v.abs()).sum::<f64>() < 1.0;
            let m = ArModel {
                phi,
                sigma: (rss / rows as f64).sqrt(),
            };
            if (p == 0 || stable) && best.as_ref().is_none_or(|b| bic < b.0) {
                best = Some((bic, m));
            }
        }
        best.map(|b| b.1).unwrap_or(ArModel {
            phi: Vec::new(),
            sigma: 0.0,
        })
    }

    /// The whitened series e_t = x_t − Σ φ_i·x_{t−i} for t ≥ p (the first p rows dropped).
    pub fn whiten(&self, x: &[f64]) -> Vec<f64> {
        let p = self.phi.len();
        (p..x.len())
            .map(|t| {
                x[t] - self
                    .phi
                    .iter()
                    .enumerate()
                    .map(|(i, f)| f * x[t - 1 - i])
                    .sum::<f64>()
            })
            .collect()
    }

    /// A simulated series of length `n` (after a burn-in of 10·p + 50 samples).
    pub fn simulate(&self, n: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
        let p = self.phi.len();
        let burn = 10 * p + 50;
        let mut x = vec![0.0; n + burn];
        for t in 0..n + burn {
            let z: f64 = StandardNormal.sample(rng);
            let ar: f64 = (0..p.min(t)).map(|i| self.phi[i] * x[t - 1 - i]).sum();
            x[t] = ar + self.sigma * z;
        }
        x.split_off(burn)
    }
}

/// Generalised-least-squares whitening of block means whose noise has a known stationary
/// covariance: x ↦ L⁻¹x with Σ = LLᵀ (Cholesky of the Toeplitz matrix of the autocovariance).
/// Under that noise the whitened series is exactly white with unit variance, so least squares
/// on it is the efficient fit and its sums of squares are χ² — which a short AR filter only
/// approximates when the noise has correlation times of 10⁴ s (100 blocks).
#[derive(Clone, Debug)]
pub struct GlsWhitener {
    l: faer::Mat<f64>,
}

/// Largest series whitened by the exact Cholesky factor (a dense n×n factor: 4 000 blocks is
/// 128 MB and ~5 s to factor; a longer recording is whitened by its AR(p) fit instead).
pub const GLS_MAX_BLOCKS: usize = 4000;

impl GlsWhitener {
    /// The whitener of a stationary series with autocovariance `acov` (lags 0 … n − 1), or
    /// `None` when the Toeplitz matrix is not positive definite (e.g. an all-zero noise fit)
    /// or the series is longer than [`GLS_MAX_BLOCKS`].
    pub fn new(acov: &[f64]) -> Option<Self> {
        let n = acov.len();
        if n == 0 || n > GLS_MAX_BLOCKS || !acov.iter().all(|v| v.is_finite()) {
            return None;
        }
        Self::from_cov(faer::Mat::from_fn(n, n, |i, j| acov[i.abs_diff(j)]))
    }

    /// The whitener of block means with the dense covariance `sigma` (a non-stationary part
    /// such as rate random walk included), or `None` when it is not positive definite or
    /// larger than [`GLS_MAX_BLOCKS`].
    pub fn from_cov(sigma: faer::Mat<f64>) -> Option<Self> {
        if sigma.nrows() == 0 || sigma.nrows() > GLS_MAX_BLOCKS {
            return None;
        }
        // Factored in place (what `Mat::llt` does on its own copy of the lower triangle,
        // with the same defaults, so the same bits): Σ is not needed afterwards, and one
        // n×n matrix is held instead of three at the copy-out (330 MB at 3 700 blocks).
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
        let mut l = sigma;
        let n = l.nrows();
        let par = faer::get_global_parallelism();
        let mut mem = MemBuffer::new(cholesky_in_place_scratch::<f64>(n, par, Default::default()));
        cholesky_in_place(
            l.as_mut(),
            Default::default(),
            par,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .ok()?;
        for j in 1..n {
            for i in 0..j {
                l[(i, j)] = 0.0;
            }
        }
        Some(Self { l })
    }

    /// ln det Σ = 2·Σ ln L_ii.
    pub fn log_det(&self) -> f64 {
        (0..self.l.nrows()).map(|i| 2.0 * self.l[(i, i)].ln()).sum()
    }

    /// L⁻¹x (all rows kept).
    pub fn whiten(&self, x: &[f64]) -> Vec<f64> {
        let n = self.l.nrows();
        debug_assert_eq!(x.len(), n);
        let mut v = faer::Mat::from_fn(n, 1, |i, _| x[i]);
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(
            self.l.as_ref(),
            v.as_mut(),
            faer::Par::Seq,
        );
        (0..n).map(|i| v[(i, 0)]).collect()
    }
}

/// The noise filter the tests use: the exact GLS whitener of the fitted gyro noise when it
/// exists, else the AR(p) fit of the residual's block means.
#[derive(Clone, Debug)]
pub enum Whitener {
    /// Exact GLS of the fitted gyro noise model.
    Gls(GlsWhitener),
    /// AR(p) prediction errors.
    Ar(ArModel),
}

impl Whitener {
    /// The whitened series.
    pub fn whiten(&self, x: &[f64]) -> Vec<f64> {
        match self {
            Self::Gls(g) => g.whiten(x),
            Self::Ar(a) => a.whiten(x),
        }
    }

    /// The whitened series of each of `xs` (each as [`Whitener::whiten`] gives it). The GLS
    /// factor is applied to 64 series per triangular solve, in parallel: one pass over the
    /// n² factor then serves 64 series instead of one (at 3 700 blocks, 6× faster than one
    /// by one); the values agree with one-by-one solves to rounding (1e-12 relative).
    pub fn whiten_many(&self, xs: &[&[f64]]) -> Vec<Vec<f64>> {
        use rayon::prelude::*;
        match self {
            Self::Ar(a) => xs.par_iter().map(|x| a.whiten(x)).collect(),
            Self::Gls(g) => {
                const BATCH: usize = 64;
                let n = g.l.nrows();
                xs.par_chunks(BATCH)
                    .flat_map_iter(|chunk| {
                        let mut m = faer::Mat::from_fn(n, chunk.len(), |i, j| chunk[j][i]);
                        faer::linalg::triangular_solve::solve_lower_triangular_in_place(
                            g.l.as_ref(),
                            m.as_mut(),
                            faer::Par::Seq,
                        );
                        (0..chunk.len())
                            .map(|j| (0..n).map(|i| m[(i, j)]).collect::<Vec<f64>>())
                            .collect::<Vec<_>>()
                    })
                    .collect()
            }
        }
    }

    /// Name for the evidence: "gls" or "ar".
    pub fn name(&self) -> &'static str {
        match self {
            Self::Gls(_) => "gls",
            Self::Ar(_) => "ar",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::covariance::block_mean_autocov;
    use crate::noise::replicates::replicate_rng;
    use rlg_simulate::noise::{NoiseGen, NoiseParams};

    /// Block means of the simulator's noise whitened by the GLS factor of their exact
    /// covariance are white with unit variance (60 records of 300 blocks).
    #[test]
    fn gls_whitening_whitens_simulated_noise() {
        let p = NoiseParams {
            arw_dph_rt_h: 2.5e-4,
            bias_instability_dph: 5e-4,
            ..Default::default()
        };
        let (nb, m) = (300usize, 100usize);
        let g = GlsWhitener::new(&block_mean_autocov(&p, nb, m, 1.0)).expect("positive definite");
        let (mut ss, mut c1, mut c5, mut n) = (0.0, 0.0, 0.0, 0usize);
        for rep in 0..60u64 {
            let mut gen = NoiseGen::new(&p, 100 + rep);
            let x: Vec<f64> = (0..nb * m).map(|_| gen.step(1.0, 1.0)).collect();
            let w = g.whiten(&rlg_eval::metrics::block_means(&x, m));
            ss += w.iter().map(|v| v * v).sum::<f64>();
            c1 += w.windows(2).map(|p| p[0] * p[1]).sum::<f64>();
            c5 += w.windows(6).map(|p| p[0] * p[5]).sum::<f64>();
            n += w.len();
        }
        let var = ss / n as f64;
        assert!((var - 1.0).abs() < 0.05, "variance {var}");
        assert!((c1 / ss).abs() < 0.03, "lag-1 correlation {}", c1 / ss);
        assert!((c5 / ss).abs() < 0.03, "lag-5 correlation {}", c5 / ss);
    }

    /// An AR(1) with φ = 0.6 is recovered (order and coefficient) from a long simulation,
    /// and its whitened series has lag-1 autocorrelation near 0.
    #[test]
    fn recovers_ar1_and_whitens() {
        let truth = ArModel {
            phi: vec![0.6],
            sigma: 2.0,
        };
        let x = truth.simulate(20_000, &mut replicate_rng(3, 0));
        let m = ArModel::fit(&x);
        assert_eq!(m.phi.len(), 1, "{m:?}");
        assert!(
            (m.phi[0] - 0.6).abs() < 0.03 && (m.sigma / 2.0 - 1.0).abs() < 0.03,
            "{m:?}"
        );
        let w = m.whiten(&x);
        let c1: f64 =
            w.windows(2).map(|p| p[0] * p[1]).sum::<f64>() / w.iter().map(|v| v * v).sum::<f64>();
        assert!(c1.abs() < 0.03, "{c1}");
    }
}
