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
    std_of(&block_means(rate, window))
}

/// Means of windows of `window` consecutive samples that hold no gap, for a record sampled at
/// times `time_s`: the record is cut at every gap (a step longer than 1.5 × the median step,
/// the reader's own gap rule), each piece is windowed from its start, and each piece's
/// trailing partial window is dropped. Without gaps this is [`block_means`]. A window never
/// spans a gap, so a "100 s mean" is always 100 s of data, not 100 samples spread over
/// hours. `time_s` and `x` must have equal lengths (else nothing is returned).
pub fn gapless_block_means(time_s: &[f64], x: &[f64], window: usize) -> Vec<f64> {
    if window == 0 || time_s.len() != x.len() || x.is_empty() {
        return Vec::new();
    }
    let mut steps: Vec<f64> = time_s.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.is_empty() {
        return block_means(x, window);
    }
    steps.sort_by(f64::total_cmp);
    let limit = 1.5 * steps[steps.len() / 2];
    let mut out = Vec::new();
    let mut start = 0;
    for k in 1..=x.len() {
        // A NaN step (a NaN time stamp) is no `Less`/`Equal`: it cuts too.
        let within = (time_s.get(k).copied().unwrap_or(f64::NAN) - time_s[k - 1])
            .partial_cmp(&limit)
            .is_some_and(|o| o.is_le());
        if k == x.len() || !within {
            out.extend(block_means(&x[start..k], window));
            start = k;
        }
    }
    out
}

/// [`bias_stability_dph`] of a time-stamped record under the gap rule of
/// [`gapless_block_means`]; `None` with fewer than two gap-free windows.
pub fn bias_stability_gapless_dph(time_s: &[f64], rate: &[f64], window: usize) -> Option<f64> {
    std_of(&gapless_block_means(time_s, rate, window))
}

/// Sample standard deviation (n − 1); `None` below two values.
fn std_of(means: &[f64]) -> Option<f64> {
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

    /// Hand-computed: 1 s steps with a gap after the 5th sample; windows of 2 → pieces
    /// [1,3,2,6,4] and [4,9,5] give means 2, 4 (4 dropped) and 6.5 (5 dropped), where plain
    /// windows of 2 would pair 4 with 4 across the gap.
    #[test]
    fn windows_never_span_a_gap() {
        let t = [0.0, 1.0, 2.0, 3.0, 4.0, 3600.0, 3601.0, 3602.0];
        let x = [1.0, 3.0, 2.0, 6.0, 4.0, 4.0, 9.0, 5.0];
        assert_eq!(gapless_block_means(&t, &x, 2), vec![2.0, 4.0, 6.5]);
        assert_eq!(block_means(&x, 2), vec![2.0, 4.0, 4.0, 7.0]);
        // mean 12.5/3; deviations² (−13/6)² + (−1/6)² + (14/6)² = 366/36; / 2 → σ² = 183/36.
        let s = bias_stability_gapless_dph(&t, &x, 2).unwrap();
        assert!((s - (183.0f64 / 36.0).sqrt()).abs() < 1e-14, "{s}");
        // Without gaps it is the plain statistic; mismatched lengths give nothing.
        let t1: Vec<f64> = (0..8).map(f64::from).collect();
        assert_eq!(gapless_block_means(&t1, &x, 2), block_means(&x, 2));
        assert_eq!(
            bias_stability_gapless_dph(&t1, &x, 2),
            bias_stability_dph(&x, 2)
        );
        assert!(gapless_block_means(&t1[..7], &x, 2).is_empty());
        // A NaN time stamp cuts on both sides, like a gap: [1,3,2,6] | [4] | [4,9,5].
        let mut tn = t1.clone();
        tn[4] = f64::NAN;
        assert_eq!(gapless_block_means(&tn, &x, 2), vec![2.0, 4.0, 6.5]);
    }

    #[test]
    fn rms_and_max() {
        assert_eq!(rms(&[3.0, -4.0]), Some((12.5f64).sqrt()));
        assert_eq!(max_abs(&[3.0, -4.0]), Some(4.0));
        assert_eq!(rms(&[]), None);
    }
}
