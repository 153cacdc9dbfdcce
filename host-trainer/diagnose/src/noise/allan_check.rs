//! The fitted noise model checked against the residual's own Allan deviation: the
//! overlapping Allan variance of the baseline residual's means at 1, 2, 4, … blocks,
//! compared with the distribution of the same statistic over 200 replicates of the fitted
//! model (each put through the same baseline fit), which is that statistic's confidence band
//! without an equivalent-degrees-of-freedom approximation ([`allan_check`]).

use rayon::prelude::*;

use super::replicates::{replicate_rng, simulate_block_means};
use rlg_simulate::noise::NoiseParams;

/// Overlapping Allan variance of a series of block means at cluster sizes `ms` (blocks); 0
/// where the series is shorter than two clusters.
pub fn block_avar(x: &[f64], ms: &[usize]) -> Vec<f64> {
    let c: Vec<f64> = std::iter::once(0.0)
        .chain(x.iter().scan(0.0, |a, v| {
            *a += v;
            Some(*a)
        }))
        .collect();
    ms.iter()
        .map(|&m| {
            if x.len() < 2 * m + 1 {
                return 0.0;
            }
            let k = x.len() + 1 - 2 * m;
            (0..k)
                .map(|i| {
                    let d = (c[i + 2 * m] - 2.0 * c[i + m] + c[i]) / m as f64;
                    0.5 * d * d
                })
                .sum::<f64>()
                / k as f64
        })
        .collect()
}

/// Cluster sizes (blocks) of the Allan check: octaves up to a fifth of the record, where
/// the estimate still averages at least a few independent clusters.
pub fn check_clusters(nb: usize) -> Vec<usize> {
    (0..)
        .map(|k| 1usize << k)
        .take_while(|&m| 5 * m <= nb)
        .collect()
}

/// The fitted noise model against the residual's own Allan deviation.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AllanCheck {
    /// Cluster times, s.
    pub tau_s: Vec<f64>,
    /// Allan deviation of the baseline residual's 100 s means, °/h.
    pub adev_dph: Vec<f64>,
    /// Median of the same statistic over the bootstrap replicates of the fitted model, °/h.
    pub model_dph: Vec<f64>,
    /// Its 2.5 % and 97.5 % quantiles over the replicates (the 95 % band), °/h.
    pub band_lo_dph: Vec<f64>,
    /// See `band_lo_dph`.
    pub band_hi_dph: Vec<f64>,
    /// Largest standardised departure over the cluster sizes, |ln AVAR − mean|/sd with the
    /// replicates' mean and sd of ln AVAR at each size.
    pub statistic: f64,
    /// Share of replicates whose own largest departure is at least as large: the p-value of
    /// the model given the residual's Allan variance (every cluster size at once).
    pub p_value: f64,
}

/// Checks `gyro` against the baseline residual's block means `resid_b` (blocks of `block_s`
/// seconds): 200 replicates of the model's block means, each through the same baseline fit
/// (`residual`), give the band of the Allan variance at [`check_clusters`].
pub fn allan_check(
    gyro: &NoiseParams,
    resid_b: &[f64],
    block_s: f64,
    residual: impl Fn(&[f64]) -> Vec<f64> + Sync,
    seed: u64,
) -> Option<AllanCheck> {
    let nb = resid_b.len();
    let ms = check_clusters(nb);
    let reps: Vec<Vec<f64>> = (0..200u64)
        .into_par_iter()
        .map(|k| {
            let mut rng = replicate_rng(seed ^ 0xa11a, k);
            let x = simulate_block_means(gyro, nb, block_s, &mut rng, seed ^ 0xa11a ^ (k + 1));
            block_avar(&residual(&x), &ms)
        })
        .collect();
    AllanCheck::new(&block_avar(resid_b, &ms), &reps, &ms, block_s)
}

/// Significance below which the fitted noise model is declared not to describe the residual.
pub const ALLAN_CHECK_ALPHA: f64 = 0.01;

impl AllanCheck {
    /// Compares the residual's block-mean Allan variance `data` (at `ms`, blocks of
    /// `block_s`) with the replicates' `reps` (each the same statistic of one replicate).
    pub fn new(data: &[f64], reps: &[Vec<f64>], ms: &[usize], block_s: f64) -> Option<Self> {
        if ms.is_empty() || reps.len() < 20 || data.iter().any(|v| v.is_nan() || *v <= 0.0) {
            return None;
        }
        let k = ms.len();
        let ln = |v: f64| v.max(1e-300).ln();
        let (mut mean, mut sd) = (vec![0.0; k], vec![0.0; k]);
        for j in 0..k {
            let col: Vec<f64> = reps.iter().map(|r| ln(r[j])).collect();
            let m = col.iter().sum::<f64>() / col.len() as f64;
            let v = col.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (col.len() - 1) as f64;
            mean[j] = m;
            sd[j] = v.sqrt().max(1e-12);
        }
        let stat = |a: &[f64]| {
            (0..k)
                .map(|j| (ln(a[j]) - mean[j]).abs() / sd[j])
                .fold(0.0, f64::max)
        };
        let s = stat(data);
        let exceed = reps.iter().filter(|r| stat(r) >= s).count();
        let quant = |j: usize, q: f64| {
            let mut col: Vec<f64> = reps.iter().map(|r| r[j]).collect();
            col.sort_by(f64::total_cmp);
            col[((q * col.len() as f64) as usize).min(col.len() - 1)].sqrt()
        };
        Some(Self {
            tau_s: ms.iter().map(|&m| m as f64 * block_s).collect(),
            adev_dph: data.iter().map(|v| v.sqrt()).collect(),
            model_dph: (0..k).map(|j| quant(j, 0.5)).collect(),
            band_lo_dph: (0..k).map(|j| quant(j, 0.025)).collect(),
            band_hi_dph: (0..k).map(|j| quant(j, 0.975)).collect(),
            statistic: s,
            p_value: (1 + exceed) as f64 / (1 + reps.len()) as f64,
        })
    }

    /// Whether the model describes the residual at [`ALLAN_CHECK_ALPHA`].
    pub fn fits(&self) -> bool {
        self.p_value >= ALLAN_CHECK_ALPHA
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On white block means the check passes; on block means with a strong random walk that
    /// a white model was fitted to, it fails.
    #[test]
    fn allan_check_flags_a_wrong_model() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let nb = 800;
        let ms = check_clusters(nb);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let mut white = |n: usize| -> Vec<f64> {
            (0..n)
                .map(|_| <StandardNormal as Distribution<f64>>::sample(&StandardNormal, &mut rng))
                .collect()
        };
        let reps: Vec<Vec<f64>> = (0..200).map(|_| block_avar(&white(nb), &ms)).collect();
        let ok = AllanCheck::new(&block_avar(&white(nb), &ms), &reps, &ms, 100.0).expect("check");
        assert!(ok.fits(), "{ok:?}");
        let mut walk = white(nb);
        let mut level = 0.0;
        for v in &mut walk {
            level += 0.3 * *v;
            *v += level;
        }
        let bad = AllanCheck::new(&block_avar(&walk, &ms), &reps, &ms, 100.0).expect("check");
        assert!(!bad.fits(), "{bad:?}");
    }
}
