//! Bias stability: 1σ of consecutive non-overlapping window means (the paper's "100 s
//! variance", quoted in °/h), plus the plain error summaries.

/// Means of consecutive non-overlapping windows of `window` samples; a trailing partial
/// window is dropped (it would be a mean of fewer samples and a different variance).
pub fn block_means(x: &[f64], window: usize) -> Vec<f64> {
    if window == 0 {
        return Vec::new();
    }
    x.chunks_exact(window)
        .map(|c| c.iter().sum::<f64>() / window as f64)
        .collect()
}

/// Bias stability, in the unit of `rate`: the sample standard deviation (n − 1) of the
/// consecutive non-overlapping `window`-sample means. For 1 Hz data, `window = 100` gives
/// the paper's 100 s bias stability. `None` with fewer than two full windows.
pub fn bias_stability_dph(rate: &[f64], window: usize) -> Option<f64> {
    let means = block_means(rate, window);
    if means.len() < 2 {
        return None;
    }
    let n = means.len() as f64;
    let mean = means.iter().sum::<f64>() / n;
    let ss = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>();
    Some((ss / (n - 1.0)).sqrt())
}

/// Root mean square; `None` for an empty slice.
pub fn rms(x: &[f64]) -> Option<f64> {
    if x.is_empty() {
        return None;
    }
    Some((x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt())
}

/// Largest magnitude; `None` for an empty slice.
pub fn max_abs(x: &[f64]) -> Option<f64> {
    x.iter().map(|v| v.abs()).reduce(f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hand-computed: windows of 2 over [1,3, 2,6, 4,4, 9] → means 2, 4, 4 (9 dropped);
    /// mean 10/3, squared deviations 16/9 + 4/9 + 4/9 = 24/9, / (3 − 1) → σ = √(4/3).
    #[test]
    fn stability_matches_hand_computation() {
        let x = [1.0, 3.0, 2.0, 6.0, 4.0, 4.0, 9.0];
        assert_eq!(block_means(&x, 2), vec![2.0, 4.0, 4.0]);
        let s = bias_stability_dph(&x, 2).unwrap();
        assert!((s - (4.0f64 / 3.0).sqrt()).abs() < 1e-15);
        assert_eq!(bias_stability_dph(&x, 4), None);
        assert_eq!(bias_stability_dph(&x, 0), None);
    }

    /// White noise of σ averaged over w samples has stability σ/√w.
    #[test]
    fn white_noise_stability_scales_as_inverse_sqrt_window() {
        // Deterministic ±1 sequence from an LCG: σ = 1 per sample.
        let mut s: u64 = 7;
        let x: Vec<f64> = (0..1_000_000)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                if s >> 63 == 1 {
                    1.0
                } else {
                    -1.0
                }
            })
            .collect();
        let b = bias_stability_dph(&x, 100).unwrap();
        assert!((b / 0.1 - 1.0).abs() < 0.05, "{b}");
    }

    #[test]
    fn rms_and_max() {
        assert_eq!(rms(&[3.0, -4.0]), Some((12.5f64).sqrt()));
        assert_eq!(max_abs(&[3.0, -4.0]), Some(4.0));
        assert_eq!(rms(&[]), None);
    }
}
