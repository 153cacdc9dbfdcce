//! Noise models of the residual.
//!
//! * For the tests, the 100 s-mean residual is whitened ([`Whitener`]): 1 Hz gyro noise is
//!   coloured, so the 100 s means are correlated, and least squares on whitened data is the
//!   efficient (GLS) fit. The whitener is the exact Cholesky factor of the fitted gyro
//!   noise's block-mean covariance ([`block_mean_autocov`], [`GlsWhitener`]); an AR(p ≤ 3)
//!   filter chosen by BIC ([`ArModel`]) whitens the first pass (before the noise is fitted)
//!   and recordings too long for the dense factor. The AR(3) filter alone cannot represent
//!   the bank's correlation times of up to 100 blocks, and slow effects compete with exactly
//!   that slow noise.
//! * For the significance thresholds, replicates of the fitted gyro noise (the simulator's
//!   noise model: white, a Gauss–Markov bank, rate random walk; fitted by REML on the 100 s
//!   means in `reml.rs`, by the 1 Hz Allan fit [`fit_gyro_noise`] on records too long for
//!   the dense factor) are simulated with the simulator's generator
//!   ([`simulate_block_means`]). Not an AR(p) bootstrap: it cannot reproduce the bank's slow
//!   wander (correlation times up to 10⁴ s) and gives 59 % false alarms on the benchmark's
//!   no-effect recordings (measured; white noise alone gives none in 8).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::linalg::Basis;
use super::reml::block_avar;
use rlg_eval::metrics::allan::{octave_clusters, overlapping_adev};
use rlg_simulate::noise::gauss_markov_avar;
use rlg_simulate::noise::{NoiseGen, NoiseParams};

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

/// Fits angle random walk and bias instability (a Gauss–Markov bank over the simulator's
/// default 100 … 10 000 s) to the overlapping Allan variance of the 1 Hz residual `r`
/// (sample period `dt_s`): AVAR(τ) = N²·3600/τ + B²·G(τ) is linear in (N², B²); fitted by
/// non-negative weighted least squares on τ ≤ a tenth of the record.
pub fn fit_gyro_noise(r: &[f64], dt_s: f64) -> NoiseParams {
    let ms: Vec<usize> = octave_clusters(r.len())
        .into_iter()
        .filter(|&m| m * 10 <= r.len())
        .collect();
    let pts = overlapping_adev(r, dt_s, &ms);
    let unit = NoiseParams {
        bias_instability_dph: 1.0,
        ..Default::default()
    };
    let (taus, s_unit) = unit.gauss_markov_bank();
    let basis = |tau: f64| -> [f64; 3] {
        let g: f64 = taus
            .iter()
            .map(|&t| gauss_markov_avar(s_unit, t, tau))
            .sum();
        [3600.0 / tau, g, tau / 10_800.0]
    };
    let rows: Vec<([f64; 3], f64)> = pts
        .iter()
        .filter(|p| p.adev > 0.0 && p.err > 0.0)
        .map(|p| {
            // Weight by the estimate's own 1σ error, σ(AVAR) ≈ 2·adev·err, so the few-cluster
            // long-τ points (noisy, and the first to show model misfit) do not set the slow
            // noise terms.
            let s = 2.0 * p.adev * p.err;
            let b = basis(p.tau_s);
            ([b[0] / s, b[1] / s, b[2] / s], p.adev * p.adev / s)
        })
        .collect();
    let mut best: Option<(f64, [f64; 3])> = None;
    // Rate random walk is left out of the fit (subsets of the first two terms only): over a
    // record of hours it is confounded with the bank's slowest processes and with model
    // misfit, and a spurious K (fitted 3e-4 … 6e-4 °/h/√h on recordings simulated with 0 or
    // 5e-5) made the bootstrap's drifts swamp every real effect.
    for mask in 1u8..4 {
        let idx: Vec<usize> = (0..3).filter(|k| mask & (1 << k) != 0).collect();
        let cols: Vec<Vec<f64>> = idx
            .iter()
            .map(|&k| rows.iter().map(|r| r.0[k]).collect())
            .collect();
        let y: Vec<f64> = rows.iter().map(|r| r.1).collect();
        let b = Basis::new(&cols);
        let c = b.coefficients(&y);
        if c.iter().any(|v| *v < 0.0 || !v.is_finite()) {
            continue;
        }
        let res = b.residual(&y);
        let rss: f64 = res.iter().map(|v| v * v).sum();
        let mut x = [0.0; 3];
        for (k, v) in idx.iter().zip(&c) {
            x[*k] = *v;
        }
        if best.as_ref().is_none_or(|b| rss < b.0) {
            best = Some((rss, x));
        }
    }
    let x = best.map_or([0.0; 3], |b| b.1);
    NoiseParams {
        arw_dph_rt_h: x[0].sqrt(),
        bias_instability_dph: x[1].sqrt(),
        rrw_dph_per_rt_h: x[2].sqrt(),
        ..Default::default()
    }
}

/// `nb` means of `block_s`-second blocks of gyro noise with parameters `p`, simulated by the
/// simulator's generator: the white part exactly (σ/√samples per block), the coloured part
/// stepped every tenth of a block and averaged (its correlation times are ≥ 100 s).
pub fn simulate_block_means(
    p: &NoiseParams,
    nb: usize,
    block_s: f64,
    rng: &mut ChaCha8Rng,
    seed: u64,
) -> Vec<f64> {
    let white = p.arw_dph_rt_h * 60.0 / block_s.sqrt();
    let coloured = NoiseParams {
        arw_dph_rt_h: 0.0,
        angle_quantum_arcsec: 0.0,
        ..p.clone()
    };
    let mut g = NoiseGen::new(&coloured, seed);
    let sub = 10;
    let h = block_s / sub as f64;
    (0..nb)
        .map(|_| {
            let c: f64 = (0..sub).map(|_| g.step(h, 1.0)).sum::<f64>() / sub as f64;
            let z: f64 = StandardNormal.sample(rng);
            c + white * z
        })
        .collect()
}

/// Re-scales the bias instability of `p` so that the bootstrap's noise, after the same
/// baseline fit as the data (`residual`), has the data's residual Allan variance at 200 …
/// 1600 s (`resid_b`, the baseline residual's block means). The baseline fit absorbs part of
/// the slow wander, so the Allan fit on the residual alone underestimates B (by ≈ 25 % on
/// simulated no-effect recordings), which let slow noise pass as aging, periodic or
/// unexplained structure. B² is fitted by least squares over the four cluster sizes from 24
/// simulated replicates of each part; the factor on B² is limited to 1/4 … 16.
pub fn calibrate_bias_instability(
    p: &NoiseParams,
    resid_b: &[f64],
    block_s: f64,
    residual: impl Fn(&[f64]) -> Vec<f64>,
    seed: u64,
) -> NoiseParams {
    let ms = [2usize, 4, 8, 16];
    let nb = resid_b.len();
    let data = block_avar(resid_b, &ms);
    let b_ref = if p.bias_instability_dph > 0.0 {
        p.bias_instability_dph
    } else {
        p.arw_dph_rt_h.max(1e-12)
    };
    let white = NoiseParams {
        arw_dph_rt_h: p.arw_dph_rt_h,
        ..Default::default()
    };
    let gm = NoiseParams {
        bias_instability_dph: b_ref,
        ..Default::default()
    };
    let reps = 24;
    let mean_avar = |q: &NoiseParams, salt: u64| -> Vec<f64> {
        let mut acc = vec![0.0; ms.len()];
        for k in 0..reps {
            let mut rng = replicate_rng(seed ^ salt, k);
            let x = simulate_block_means(q, nb, block_s, &mut rng, seed ^ salt ^ (k + 1));
            for (a, v) in acc.iter_mut().zip(block_avar(&residual(&x), &ms)) {
                *a += v / reps as f64;
            }
        }
        acc
    };
    let aw = mean_avar(&white, 0x77);
    let ag = mean_avar(&gm, 0x99);
    let num: f64 = (0..ms.len())
        .map(|i| (data[i] - aw[i]) * ag[i] / (data[i] * data[i]).max(1e-300))
        .sum();
    let den: f64 = (0..ms.len())
        .map(|i| ag[i] * ag[i] / (data[i] * data[i]).max(1e-300))
        .sum();
    let c = if den > 0.0 { num / den } else { 0.0 };
    let b2 = (c * b_ref * b_ref).clamp(
        0.25 * p.bias_instability_dph.powi(2),
        16.0 * p
            .bias_instability_dph
            .powi(2)
            .max(if p.bias_instability_dph > 0.0 {
                0.0
            } else {
                b_ref * b_ref
            }),
    );
    NoiseParams {
        bias_instability_dph: b2.max(0.0).sqrt(),
        ..p.clone()
    }
}

/// Autocovariance, lags 0 … `nb` − 1 (°/h)², of the means of consecutive `m`-sample blocks
/// of the simulator's stationary noise with parameters `p` at sample period `dt_s`: the white
/// part (σ² = (N·60)²/dt per sample) at lag 0 only; each Gauss–Markov process of the bank
/// exactly as the generator steps it (a discrete AR(1), a = e^(−dt/τ), variance s²):
/// lag 0 s²/m²·(m + 2·a·(m(1 − a) − (1 − a^m))/(1 − a)²), lag k ≥ 1 s²/m²·a^((k−1)m+1)·S²
/// with S = (1 − a^m)/(1 − a). Rate random walk is not stationary and is left out here;
/// `reml::block_mean_cov` adds it to a dense covariance.
pub fn block_mean_autocov(p: &NoiseParams, nb: usize, m: usize, dt_s: f64) -> Vec<f64> {
    let mf = m as f64;
    let mut c = vec![0.0; nb];
    if let Some(c0) = c.first_mut() {
        *c0 = (p.arw_dph_rt_h * 60.0).powi(2) / dt_s / mf;
    }
    if p.bias_instability_dph <= 0.0 {
        return c;
    }
    let (taus, s) = p.gauss_markov_bank();
    for tau in taus {
        let a = (-dt_s / tau).exp();
        let am = a.powi(m as i32);
        let one = 1.0 - a;
        let s2 = s * s / (mf * mf);
        let sum = (1.0 - am) / one;
        for (k, ck) in c.iter_mut().enumerate() {
            *ck += if k == 0 {
                s2 * (mf + 2.0 * a * (mf * one - (1.0 - am)) / (one * one))
            } else {
                s2 * a.powf(((k - 1) * m + 1) as f64) * sum * sum
            };
        }
    }
    c
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

/// A deterministic generator for replicate `k` of a bootstrap seeded by `seed`.
pub fn replicate_rng(seed: u64, k: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(k);
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The simulator's noise with known N, B, K is fitted back from its Allan variance within
    /// 10 % (N), 25 % (B) — the references are the simulation's parameters.
    #[test]
    fn fits_simulated_gyro_noise() {
        let p = NoiseParams {
            arw_dph_rt_h: 2.5e-4,
            bias_instability_dph: 5e-4,
            ..Default::default()
        };
        let mut g = NoiseGen::new(&p, 9);
        let x: Vec<f64> = (0..400_000).map(|_| g.step(1.0, 1.0)).collect();
        let f = fit_gyro_noise(&x, 1.0);
        assert!((f.arw_dph_rt_h / 2.5e-4 - 1.0).abs() < 0.1, "{f:?}");
        assert!((f.bias_instability_dph / 5e-4 - 1.0).abs() < 0.25, "{f:?}");
        // Block means simulated from the fit scatter like those of the original.
        let m = rlg_eval::metrics::block_means(&x, 100);
        let sd = |v: &[f64]| (v.iter().map(|a| a * a).sum::<f64>() / v.len() as f64).sqrt();
        let sim = simulate_block_means(&f, 4000, 100.0, &mut replicate_rng(1, 0), 2);
        assert!(
            (sd(&sim) / sd(&m) - 1.0).abs() < 0.15,
            "{} {}",
            sd(&sim),
            sd(&m)
        );
    }

    /// The closed form of the block-mean autocovariance against the brute-force double sum of
    /// the per-sample autocovariance r(d) = σ_w²·δ_d + Σ s²·a^d over two blocks.
    #[test]
    fn block_mean_autocov_is_the_double_sum() {
        let p = NoiseParams {
            arw_dph_rt_h: 2.5e-4,
            bias_instability_dph: 5e-4,
            ..Default::default()
        };
        let (m, dt) = (100usize, 1.0);
        let c = block_mean_autocov(&p, 40, m, dt);
        let (taus, s) = p.gauss_markov_bank();
        let w2 = (p.arw_dph_rt_h * 60.0).powi(2) / dt;
        let r = |d: usize| {
            let gm: f64 = taus
                .iter()
                .map(|t| s * s * (-(d as f64) * dt / t).exp())
                .sum();
            gm + if d == 0 { w2 } else { 0.0 }
        };
        for k in [0usize, 1, 2, 7, 39] {
            let mut sum = 0.0;
            for i in 0..m {
                for j in 0..m {
                    sum += r((k * m + j).abs_diff(i));
                }
            }
            let brute = sum / (m * m) as f64;
            assert!(
                (c[k] / brute - 1.0).abs() < 1e-9,
                "lag {k}: {} vs {brute}",
                c[k]
            );
        }
    }

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
