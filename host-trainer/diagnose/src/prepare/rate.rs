//! dT/dt of the recorded temperature, and the least-squares slope that un-lags it; neither
//! ever spans a gap in the record.

use crate::DiagnoseError;

/// The runs of samples with no gap between them, as inclusive index ranges: a gap is a step
/// longer than 1.5 sample periods (the reader's rule, `rlg_io` reports them). A window of
/// samples that spans a gap would mix times far apart as if they were `dt_s` apart.
pub(super) fn gapless_runs(t_s: &[f64], dt_s: f64) -> Vec<(usize, usize)> {
    let n = t_s.len();
    let mut runs = Vec::new();
    let mut lo = 0;
    for i in 1..n {
        if t_s[i] - t_s[i - 1] > 1.5 * dt_s {
            runs.push((lo, i - 1));
            lo = i;
        }
    }
    if n > 0 {
        runs.push((lo, n - 1));
    }
    runs
}

/// Least-squares slope of `x` (samples `dt_s` apart, time stamps `t_s`) over a window of
/// ±`half_width_s` around each sample, truncated at the ends and at gaps (one-sided next to
/// them); 0 for a single sample. O(n) by prefix sums. (The Savitzky–Golay first derivative
/// of order 1 and 2; a dozen lines, so not a crate.)
pub(super) fn local_slope(x: &[f64], t_s: &[f64], dt_s: f64, half_width_s: f64) -> Vec<f64> {
    let n = x.len();
    let h = ((half_width_s / dt_s).round() as usize).max(1);
    let x0 = x.first().copied().unwrap_or(0.0);
    // Prefix sums of (x − x₀) and i·(x − x₀); x₀ keeps the sums small.
    let (mut s, mut si) = (vec![0.0; n + 1], vec![0.0; n + 1]);
    for (i, v) in x.iter().enumerate() {
        s[i + 1] = s[i] + (v - x0);
        si[i + 1] = si[i] + i as f64 * (v - x0);
    }
    let mut out = Vec::with_capacity(n);
    for (lo, hi) in gapless_runs(&t_s[..n], dt_s) {
        out.extend((lo..=hi).map(|i| {
            let (a, b) = (i.saturating_sub(h).max(lo), (i + h).min(hi));
            let m = (b - a + 1) as f64;
            if m < 2.0 {
                return 0.0;
            }
            let kbar = 0.5 * (a + b) as f64;
            let sx = s[b + 1] - s[a];
            let sxi = si[b + 1] - si[a];
            // Σ(k − k̄)² over m consecutive integers.
            let skk = m * (m * m - 1.0) / 12.0;
            (sxi - kbar * sx) / skk / dt_s
        }));
    }
    out
}

/// Half-width of the centred difference that estimates dT/dt, s.
pub const RATE_HALF_WIDTH_S: f64 = 30.0;

/// dT/dt by a centred difference over ±30 s (one-sided at the ends and next to gaps), °C/s.
///
/// Not the board's causal α-β estimator (`compensator_core::RateEstimator`): on the body's
/// curved temperature at the ends of each ramp that estimator lags by an amount ∝ d²T/dt²,
/// and through the rate terms (2.16 °/h per °C/s) this lag is itself a model mismatch — on a
/// simulated recording with nothing hidden it scored ΔBIC −30 as a "sensor lag". The
/// diagnosis tests the physics, which is written in the true dT/dt; the centred difference
/// has no phase lag, and with 0.01 °C readings its noise is 0.01/60/√6 ≈ 7e-5 °C/s per
/// sample, 0.2 % of a 1 °C/min ramp, before the 100 s averaging.
pub fn estimate_rate(temp_c: &[f64], t_s: &[f64], dt_s: f64) -> Result<Vec<f64>, DiagnoseError> {
    let n = temp_c.len();
    if let Some(i) = temp_c.iter().chain(t_s).position(|v| !v.is_finite()) {
        return Err(DiagnoseError::NonFinite {
            index: i % n.max(1),
        });
    }
    let runs = gapless_runs(&t_s[..n], dt_s);
    // The mean step; across gaps it would count the gaps' time, so the period given.
    let dt = if runs.len() > 1 {
        dt_s
    } else if n > 1 {
        (t_s[n - 1] - t_s[0]) / (n - 1) as f64
    } else {
        1.0
    };
    let h = ((RATE_HALF_WIDTH_S / dt).round() as usize).max(1);
    let mut out = Vec::with_capacity(n);
    for (lo, hi) in runs {
        // Never across a gap: a difference over it is the chord of what the gap hides.
        out.extend((lo..=hi).map(|i| {
            let (a, b) = (i.saturating_sub(h).max(lo), (i + h).min(hi));
            if b > a {
                (temp_c[b] - temp_c[a]) / (t_s[b] - t_s[a])
            } else {
                0.0
            }
        }));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The least-squares slope is exact on a line everywhere (ends included) and on a
    /// parabola wherever its window is whole (a symmetric window cancels the curvature).
    #[test]
    fn local_slope_is_exact_on_lines_and_centred_parabolas() {
        let dt = 2.0;
        let t: Vec<f64> = (0..300).map(|i| f64::from(i) * dt).collect();
        let line: Vec<f64> = t.iter().map(|t| 3.0 - 0.01 * t).collect();
        for s in local_slope(&line, &t, dt, 45.0) {
            assert!((s + 0.01).abs() < 1e-12, "{s}");
        }
        let par: Vec<f64> = t.iter().map(|t| 1.0 + 0.02 * t + 1e-4 * t * t).collect();
        let s = local_slope(&par, &t, dt, 45.0);
        let h = 23; // 45 s / 2 s, rounded
        for i in h..t.len() - h {
            let want = 0.02 + 2e-4 * t[i];
            assert!((s[i] - want).abs() < 1e-9, "{i}: {} vs {want}", s[i]);
        }
        // A truncated window at the ends is still a least-squares slope, biased only by
        // the curvature: for this parabola by 2e-4·(window centre − t).
        assert!((s[0] - (0.02 + 2e-4 * 0.5 * (h as f64) * dt)).abs() < 1e-9);
        assert_eq!(local_slope(&[5.0], &[0.0], 1.0, 45.0), vec![0.0]);
    }

    /// Next to a gap the slope and dT/dt come from the samples on the same side only: on a
    /// ramp that reverses during a 30 min gap, every estimate is the ramp's own slope, where a
    /// window across the gap would take the chord over what the gap hides (0 here) or, for
    /// the slope, divide the jump by the samples' count.
    #[test]
    fn slopes_and_rates_never_span_a_gap() {
        // 1 °C/min up for 1 000 s, a gap of 1 800 s, then 1 °C/min down.
        let mut t: Vec<f64> = (0..1000).map(f64::from).collect();
        t.extend((0..1000).map(|i| 2800.0 + f64::from(i)));
        let temp: Vec<f64> = t
            .iter()
            .map(|&t| {
                if t < 1400.0 {
                    20.0 + t / 60.0
                } else {
                    20.0 + (2800.0 - t) / 60.0
                }
            })
            .collect();
        let want = |t: f64| if t < 1400.0 { 1.0 / 60.0 } else { -1.0 / 60.0 };
        let slope = local_slope(&temp, &t, 1.0, 45.0);
        let rate = estimate_rate(&temp, &t, 1.0).expect("rate");
        for i in 0..t.len() {
            assert!(
                (slope[i] - want(t[i])).abs() < 1e-12,
                "slope at {}: {}",
                t[i],
                slope[i]
            );
            assert!(
                (rate[i] - want(t[i])).abs() < 1e-12,
                "rate at {}: {}",
                t[i],
                rate[i]
            );
        }
        // Without the gap the same code gives the bits it always gave (jitter below 1.5 steps).
        let tj: Vec<f64> = (0..500)
            .map(|i| f64::from(i) + 0.3 * f64::from(i % 3))
            .collect();
        let xj: Vec<f64> = tj.iter().map(|t| (t / 200.0).sin()).collect();
        assert_eq!(gapless_runs(&tj, 1.0), vec![(0, 499)]);
        let rj = estimate_rate(&xj, &tj, 1.0).expect("rate");
        let h = 30;
        for i in [0usize, 17, 250, 499] {
            let (a, b) = (i.saturating_sub(h), (i + h).min(499));
            assert_eq!(rj[i], (xj[b] - xj[a]) / (tj[b] - tj[a]));
        }
    }
}
