//! The averaging time of the fit and of the CV blocks, from the record rather than the RLG
//! convention of 100 s: a mean over B seconds should be long enough that its noise is no
//! larger than what the temperature moves the bias by within it, and no longer. With a 1 s
//! noise σ₁ (°/h) and the bias moving S °/h per second on the ramps, the noise of a mean,
//! σ₁/√B, equals the bias' change across it, S·B, at B* = (σ₁/S)^(2/3). B is the first value
//! of the 1-2-5 ladder at or above B*, at most 100 s (a navigation-grade RLG, whose bias moves
//! little against its noise, keeps the paper's 100 s means), and short enough that the
//! training span holds [`MIN_MEANS`] means.

/// The averaging times considered, s.
pub const LADDER_S: [usize; 7] = [1, 2, 5, 10, 20, 50, 100];
/// Fewest training means the averaging time leaves (a CV needs enough of them).
pub const MIN_MEANS: usize = 200;

/// The averaging time chosen and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Averaging {
    /// Seconds per mean (samples at 1 Hz).
    pub block_s: usize,
    /// The 1 s noise σ₁ of the rate, °/h (robust: from the median step-to-step change).
    pub noise_1s_dph: f64,
    /// How fast the temperature moves the bias on the ramps, °/h per s.
    pub drift_dph_per_s: f64,
}

impl Averaging {
    /// The sentence the report shows.
    pub fn describe(&self) -> String {
        format!(
            "means of {} s for training and tuning, chosen from the record: its 1 s noise is \
             {:.3e} °/h and on the ramps the temperature moves the bias by {:.3e} °/h per \
             second (the mean whose noise equals the bias' change across it lasts {:.1} s)",
            self.block_s,
            self.noise_1s_dph,
            self.drift_dph_per_s,
            self.balance_s()
        )
    }

    /// B* of the module doc, s (infinite when the bias does not move).
    pub fn balance_s(&self) -> f64 {
        (self.noise_1s_dph / self.drift_dph_per_s).powf(2.0 / 3.0)
    }
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    v.retain(|x| x.is_finite());
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied()
}

/// The least-squares slope of `y` on `x` (0 when `x` does not vary).
fn slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx) * (a - mx);
    }
    if sxx > 0.0 {
        sxy / sxx
    } else {
        0.0
    }
}

/// The averaging time for training samples (1 Hz) with rate `rate_dph`, temperature
/// `temp_c` and the board's dT/dt `rate_c_per_s` (see the module doc).
pub fn averaging_s(rate_dph: &[f64], temp_c: &[f64], rate_c_per_s: &[f64]) -> Averaging {
    let n = rate_dph.len();
    let noise_1s_dph = median(rate_dph.windows(2).map(|w| (w[1] - w[0]).abs()).collect())
        .map_or(f64::NAN, |m| 1.4826 * m / std::f64::consts::SQRT_2);
    // Ramps: |dT/dt| above a tenth of its 95th percentile (holds and turns left out).
    let mut mags: Vec<f64> = rate_c_per_s.iter().map(|v| v.abs()).collect();
    mags.sort_by(f64::total_cmp);
    let p95 = mags
        .get((mags.len() as f64 * 0.95) as usize)
        .copied()
        .unwrap_or(0.0);
    let ramp = median(mags.into_iter().filter(|m| *m > 0.1 * p95).collect()).unwrap_or(0.0);
    let drift_dph_per_s = slope(temp_c, rate_dph).abs() * ramp;
    let mut a = Averaging {
        block_s: 100,
        noise_1s_dph,
        drift_dph_per_s,
    };
    let b_star = a.balance_s();
    let mut block = LADDER_S
        .iter()
        .copied()
        .find(|&b| b as f64 >= b_star)
        .unwrap_or(100);
    while block > 1 && n / block < MIN_MEANS {
        block = LADDER_S
            .iter()
            .rev()
            .copied()
            .find(|&b| b < block)
            .unwrap_or(1);
    }
    a.block_s = block;
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A MEMS-like ramp (bias 100 °/h per °C, 3.5 °C/min, 30 °/h of noise) takes means of a
    /// few seconds; an RLG-like one (1e-4 °/h per °C, 1 °C/min, 0.01 °/h of noise) keeps
    /// 100 s; a short record is capped by the number of means.
    #[test]
    fn the_averaging_time_follows_noise_against_drift() {
        // A sum of 12 uniforms: near-Gaussian, unit variance, deterministic.
        let lcg = |state: &mut u64| {
            let mut s = 0.0;
            for _ in 0..12 {
                *state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                s += (*state >> 11) as f64 / (1u64 << 53) as f64;
            }
            s - 6.0
        };
        let run = |n: usize, rate_c_per_min: f64, k: f64, noise: f64| {
            let mut s = 7u64;
            let dtdt = rate_c_per_min / 60.0;
            let t: Vec<f64> = (0..n).map(|i| -20.0 + dtdt * i as f64).collect();
            let y: Vec<f64> = t.iter().map(|t| k * t + noise * lcg(&mut s)).collect();
            averaging_s(&y, &t, &vec![dtdt; n])
        };
        let mems = run(3_600, 3.5, 100.0, 30.0);
        assert!(mems.block_s <= 5, "{mems:?}");
        assert!((mems.noise_1s_dph / 30.0 - 1.0).abs() < 0.1, "{mems:?}");
        let rlg = run(100_000, 1.0, 1e-4, 0.01);
        assert_eq!(rlg.block_s, 100, "{rlg:?}");
        let short = run(3_000, 1.0, 1e-4, 0.01);
        assert_eq!(short.block_s, 10, "{short:?}");
    }
}
