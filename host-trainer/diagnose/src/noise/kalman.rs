//! The block-mean noise of [`block_mean_cov`](super::covariance::block_mean_cov) as a
//! linear state-space model, and its exact whitening by the Kalman filter's innovations.
//!
//! REML (`reml.rs`) evaluates the likelihood at many variance ratios. Factoring the dense
//! n×n covariance each time is cubic in the series' length, which made fitting on means of
//! several blocks a necessity; the same covariance is that of a state-space model with one
//! state per Gauss–Markov process and one for rate random walk, so its Cholesky whitening is
//! the filter's normalised innovations, in O(n·s²) for s states, and how far to pool is a
//! modelling choice (`reml::pooling`).
//!
//! Per block b of m samples (block length L = m·dt), with the state at the block's start:
//! - a Gauss–Markov process stepped as the generator steps it (a discrete AR(1),
//!   a = e^(−dt/τ), stationary variance v): state g at the block's last preceding sample,
//!   next state a^m·g + e₁, block mean A·g + e₂ with A = (1/m)·Σᵢ aⁱ, and with the
//!   innovations εₗ (variance v(1 − a²)) of the block's samples, e₁ = Σₗ a^(m−l)·εₗ,
//!   e₂ = (1/m)·Σₗ cₗ·εₗ, cₗ = Σ_{i ≥ l} a^(i−l);
//! - rate random walk of diffusion q, started at zero at the record's start: state r at
//!   the block's start, next state r + e₁ (variance qL), block mean r + e₂ (variance qL/3),
//!   Cov(e₁, e₂) = qL/2;
//! - white noise of the block means, added to e₂.
//!
//! The filter in innovations form with correlated state and observation noise: innovation
//! ν = y − hᵀx̂ with variance F = hᵀPh + R, gain k = (f∘Ph + c)/F, x̂ ← f∘x̂ + kν,
//! P ← fPf + Q − F·kkᵀ. Σᵢ ln Fᵢ is ln det Σ and νᵢ/√Fᵢ is L⁻¹y for the Cholesky factor L,
//! i.e. what [`GlsWhitener`](super::whiten::GlsWhitener) gives from the dense matrix (test
//! `kalman_whitening_equals_the_dense_cholesky`).

use rlg_simulate::noise::NoiseParams;

/// The state-space form of the block means' noise (independent states: diagonal transition
/// and state noise).
#[derive(Clone, Debug)]
pub struct BlockStateSpace {
    /// Transition of each state over one block.
    f: Vec<f64>,
    /// Loading of each state on the block mean.
    h: Vec<f64>,
    /// Variance of each state's noise over one block.
    q: Vec<f64>,
    /// Covariance of each state's noise with the block mean's own noise.
    c: Vec<f64>,
    /// Variance of the block mean's own noise (white included).
    r: f64,
    /// Variance of each state at the record's start.
    p0: Vec<f64>,
}

impl BlockStateSpace {
    /// The model of `p`'s noise for blocks of `m` samples at period `dt_s`: white level,
    /// Gauss–Markov bank and rate random walk, exactly as `block_mean_cov` has them.
    pub fn new(p: &NoiseParams, m: usize, dt_s: f64) -> Self {
        let mf = m as f64;
        let mut s = BlockStateSpace {
            f: Vec::new(),
            h: Vec::new(),
            q: Vec::new(),
            c: Vec::new(),
            r: (p.arw_dph_rt_h * 60.0).powi(2) / dt_s / mf,
            p0: Vec::new(),
        };
        if p.bias_instability_dph > 0.0 {
            let (taus, sigma) = p.gauss_markov_bank();
            let v = sigma * sigma;
            for tau in taus {
                let a = (-dt_s / tau).exp();
                let e = v * (1.0 - a * a);
                // Sums over the block's samples l = 1 … m: cₗ = (1 − a^(m−l+1))/(1 − a).
                let (mut sum_c2, mut sum_ac, mut sum_a) = (0.0, 0.0, 0.0);
                for l in 1..=m {
                    let cl = (1.0 - a.powi((m - l + 1) as i32)) / (1.0 - a);
                    sum_c2 += cl * cl;
                    sum_ac += a.powi((m - l) as i32) * cl;
                    sum_a += a.powi(l as i32);
                }
                let am = a.powi(m as i32);
                s.f.push(am);
                s.h.push(sum_a / mf);
                s.q.push(v * (1.0 - am * am));
                s.c.push(e * sum_ac / mf);
                s.r += e * sum_c2 / (mf * mf);
                s.p0.push(v);
            }
        }
        let qk = (p.rrw_dph_per_rt_h / 60.0).powi(2);
        if qk > 0.0 {
            let l = mf * dt_s;
            s.f.push(1.0);
            s.h.push(1.0);
            s.q.push(qk * l);
            s.c.push(qk * l / 2.0);
            s.r += qk * l / 3.0;
            s.p0.push(0.0);
        }
        s
    }

    /// The whitened series L⁻¹x of each of `series` (all of one length n) and ln det Σ of
    /// the n block means' covariance; `None` when an innovation variance is not positive
    /// (the covariance is not positive definite).
    pub fn whiten(&self, series: &[&[f64]]) -> Option<(Vec<Vec<f64>>, f64)> {
        let n = series.first().map_or(0, |x| x.len());
        let k = self.f.len();
        let mut p = vec![0.0; k * k];
        for i in 0..k {
            p[i * k + i] = self.p0[i];
        }
        let mut xs = vec![vec![0.0; k]; series.len()];
        let mut out: Vec<Vec<f64>> = series.iter().map(|_| Vec::with_capacity(n)).collect();
        let mut log_det = 0.0;
        let (mut ph, mut gain) = (vec![0.0; k], vec![0.0; k]);
        for b in 0..n {
            for i in 0..k {
                ph[i] = (0..k).map(|j| p[i * k + j] * self.h[j]).sum();
            }
            let fv = self.r + (0..k).map(|i| self.h[i] * ph[i]).sum::<f64>();
            if !(fv > 0.0 && fv.is_finite()) {
                return None;
            }
            log_det += fv.ln();
            let sd = fv.sqrt();
            for i in 0..k {
                gain[i] = (self.f[i] * ph[i] + self.c[i]) / fv;
            }
            for ((x, o), y) in xs.iter_mut().zip(&mut out).zip(series) {
                let nu = y[b] - (0..k).map(|i| self.h[i] * x[i]).sum::<f64>();
                o.push(nu / sd);
                for i in 0..k {
                    x[i] = self.f[i] * x[i] + gain[i] * nu;
                }
            }
            // P ← fPf + Q − F·kkᵀ, kept symmetric.
            for i in 0..k {
                for j in 0..=i {
                    let mut v = self.f[i] * p[i * k + j] * self.f[j] - fv * gain[i] * gain[j];
                    if i == j {
                        v += self.q[i];
                    }
                    p[i * k + j] = v;
                    p[j * k + i] = v;
                }
            }
        }
        Some((out, log_det))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::covariance::block_mean_cov;
    use crate::noise::whiten::GlsWhitener;

    /// For white level, bank and rate random walk together, and each alone, the filter's
    /// innovations are the dense Cholesky factor's whitening and their log-variances sum to
    /// its log-determinant.
    #[test]
    fn kalman_whitening_equals_the_dense_cholesky() {
        let full = NoiseParams {
            arw_dph_rt_h: 2.5e-4,
            bias_instability_dph: 5e-4,
            rrw_dph_per_rt_h: 6e-4,
            ..Default::default()
        };
        let cases = [
            full.clone(),
            NoiseParams {
                rrw_dph_per_rt_h: 0.0,
                ..full.clone()
            },
            NoiseParams {
                bias_instability_dph: 0.0,
                ..full.clone()
            },
        ];
        let (nb, m) = (120usize, 70usize);
        let y: Vec<f64> = (0..nb)
            .map(|i| 1e-3 * ((i as f64 * 0.37).sin() + 0.2 * (i as f64 * 1.3).cos()))
            .collect();
        let t: Vec<f64> = (0..nb).map(|i| i as f64 / nb as f64).collect();
        for p in cases {
            let g = GlsWhitener::from_cov(block_mean_cov(&p, nb, m, 1.0)).expect("definite");
            let (w, ld) = BlockStateSpace::new(&p, m, 1.0)
                .whiten(&[&y, &t])
                .expect("definite");
            for (x, wk) in [&y, &t].into_iter().zip(&w) {
                let dense = g.whiten(x);
                let scale = dense.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                let worst = dense
                    .iter()
                    .zip(wk)
                    .fold(0.0f64, |a, (d, k)| a.max((d - k).abs()));
                assert!(worst <= 1e-9 * scale, "{p:?}: {worst:e} of {scale:e}");
            }
            assert!(
                (ld - g.log_det()).abs() <= 1e-9 * g.log_det().abs(),
                "{p:?}: log det {ld} vs {}",
                g.log_det()
            );
        }
    }
}
