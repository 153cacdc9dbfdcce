//! The covariance of block means of the simulator's gyro noise: the stationary part as an
//! autocovariance, and with rate random walk as a dense matrix.

use faer::Mat;

use rlg_simulate::noise::NoiseParams;

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

/// Dense covariance (°/h)² of the means of `nb` consecutive `m`-sample blocks of gyro noise
/// `p`: the stationary part ([`block_mean_autocov`]: white and the Gauss–Markov bank) plus
/// rate random walk. A random walk of the rate with diffusion q = (K/60)² (°/h)²/s, started
/// at the record's start: for blocks i ≤ j of L seconds, block i starting at aᵢ,
/// Cov = q·(aᵢ + L/3) when i = j and q·(aᵢ + L/2) otherwise (the double integral of
/// min(s, t) over the two blocks). Its start value is a constant the baseline's offset takes.
pub fn block_mean_cov(p: &NoiseParams, nb: usize, m: usize, dt_s: f64) -> Mat<f64> {
    let acov = block_mean_autocov(p, nb, m, dt_s);
    let q = (p.rrw_dph_per_rt_h / 60.0).powi(2);
    let l = m as f64 * dt_s;
    Mat::from_fn(nb, nb, |i, j| {
        let rrw = if q > 0.0 {
            let a = i.min(j) as f64 * l;
            q * (a + if i == j { l / 3.0 } else { l / 2.0 })
        } else {
            0.0
        };
        acov[i.abs_diff(j)] + rrw
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rlg_simulate::noise::NoiseGen;

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

    /// The dense block-mean covariance of rate random walk against the sample covariance of
    /// many simulated walks (block means, 30 blocks of 100 samples; 2 000 walks).
    #[test]
    fn rrw_block_covariance_matches_simulation() {
        let p = NoiseParams {
            rrw_dph_per_rt_h: 1e-3,
            ..Default::default()
        };
        let (nb, m) = (30usize, 100usize);
        let c = block_mean_cov(&p, nb, m, 1.0);
        let reps = 2000u64;
        let mut acc = [0.0; 3];
        let pairs = [(0usize, 0usize), (10, 20), (29, 29)];
        for r in 0..reps {
            let mut g = NoiseGen::new(&p, 500 + r);
            let x: Vec<f64> = (0..nb * m).map(|_| g.step(1.0, 1.0)).collect();
            let b = rlg_eval::metrics::block_means(&x, m);
            for (a, (i, j)) in acc.iter_mut().zip(pairs) {
                *a += b[i] * b[j] / reps as f64;
            }
        }
        for (a, (i, j)) in acc.iter().zip(pairs) {
            let rel = a / c[(i, j)] - 1.0;
            // Block 0's variance is small (a third of a block of walk), the others' are
            // dominated by the walk's accumulated level; 2 000 replicates give ≈ 3–7 %.
            assert!(
                rel.abs() < 0.15,
                "({i},{j}): simulated {a} vs {}",
                c[(i, j)]
            );
        }
    }

    /// Replicates drawn with a white level in time against the variance it gives each block's
    /// mean (the stationary block-mean variance, its white part scaled by the level): the
    /// sample variance over 4 000 replicates of white noise and bias instability, the white
    /// variance doubled on the middle blocks and halved after them.
    #[test]
    fn white_level_replicates_have_its_variance() {
        use crate::noise::replicates::{replicate_rng, simulate_block_means_levelled};
        let p = NoiseParams {
            arw_dph_rt_h: 4e-4,
            bias_instability_dph: 3e-4,
            ..Default::default()
        };
        let (nb, m) = (12usize, 100usize);
        let w: Vec<f64> = (0..nb)
            .map(|b| match b {
                4..=7 => 2.0,
                8.. => 0.5,
                _ => 1.0,
            })
            .collect();
        let white = (p.arw_dph_rt_h * 60.0).powi(2) / m as f64;
        let c0 = block_mean_autocov(&p, nb, m, 1.0)[0];
        let expected: Vec<f64> = w.iter().map(|wb| c0 + white * (wb - 1.0)).collect();
        let reps = 4000u64;
        let mut var = vec![0.0; nb];
        for k in 0..reps {
            let x = simulate_block_means_levelled(
                &p,
                Some(&w),
                nb,
                m as f64,
                &mut replicate_rng(9, k),
                k + 1,
            );
            for (v, xb) in var.iter_mut().zip(&x) {
                *v += xb * xb / reps as f64;
            }
        }
        for (b, v) in var.iter().enumerate() {
            // 4 000 replicates place a variance to about 2.2 % (1σ).
            let rel = v / expected[b] - 1.0;
            assert!(
                rel.abs() < 0.09,
                "block {b}: simulated {v:e} vs {:e}",
                expected[b]
            );
        }
        assert!(expected[5] > 1.5 * expected[0] && expected[10] < 0.8 * expected[0]);
    }
}
