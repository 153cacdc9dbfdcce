//! Temperature cycles of a recording, found from the recorded temperature alone.
//!
//! The paper trains on "the data in the first temperature cycle" and tests on the others. A
//! cycle boundary is put in the middle of each low hold: halfway between a downward crossing
//! of the mid temperature (the midpoint of the recorded range) and the next upward crossing.
//! The first cycle therefore holds the initial soak, one heating ramp, the hot hold, one
//! cooling ramp and half of the next cold hold.

/// Half-open time spans `[start_s, end_s)` of each cycle, in recording order. The last span
/// ends at the last sample time (inclusive in practice). A record without a complete
/// up-down-up pattern is one span.
pub fn cycle_spans(time_s: &[f64], temp_c: &[f64]) -> Vec<(f64, f64)> {
    let n = time_s.len().min(temp_c.len());
    if n == 0 {
        return Vec::new();
    }
    let (lo, hi) = temp_c[..n]
        .iter()
        .filter(|t| t.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &t| {
            (a.min(t), b.max(t))
        });
    let mid = 0.5 * (lo + hi);
    // Hysteresis of 10 % of the range so that noise near `mid` cannot make false crossings.
    let band = 0.1 * (hi - lo);
    let mut above = temp_c[0] > mid;
    let mut last_down: Option<f64> = None;
    let mut bounds = vec![time_s[0]];
    for k in 1..n {
        let t = temp_c[k];
        if !t.is_finite() {
            continue;
        }
        if !above && t > mid + band {
            above = true;
            if let Some(down) = last_down.take() {
                bounds.push(0.5 * (down + time_s[k]));
            }
        } else if above && t < mid - band {
            above = false;
            last_down = Some(time_s[k]);
        }
    }
    bounds.push(time_s[n - 1]);
    bounds.windows(2).map(|w| (w[0], w[1])).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A trapezoid cycle of period 1000 s: hold low 0-250, up 250-500, hold high 500-750,
    /// down 750-1000, three times. Boundaries fall mid-way through the low holds after the
    /// first cycle: between the down-crossing of mid − band and the next up-crossing of mid + band.
    #[test]
    fn splits_trapezoid_cycles_in_the_low_holds() {
        let temp = |t: f64| {
            let p = t % 1000.0;
            match p {
                p if p < 250.0 => 10.0,
                p if p < 500.0 => 10.0 + (p - 250.0) / 250.0 * 50.0,
                p if p < 750.0 => 60.0,
                p => 60.0 - (p - 750.0) / 250.0 * 50.0,
            }
        };
        let time: Vec<f64> = (0..3000).map(f64::from).collect();
        let tc: Vec<f64> = time.iter().map(|&t| temp(t)).collect();
        let spans = cycle_spans(&time, &tc);
        assert_eq!(spans.len(), 3, "{spans:?}");
        // Down-crossing of 30 °C at 900 s, up-crossing of 40 °C at 1400 s → boundary 1150 s.
        assert!((spans[0].1 - 1150.0).abs() < 1.5, "{spans:?}");
        assert!((spans[1].1 - 2150.0).abs() < 1.5, "{spans:?}");
        assert_eq!(spans[2].1, 2999.0);
    }

    #[test]
    fn a_single_ramp_is_one_span() {
        let time: Vec<f64> = (0..100).map(f64::from).collect();
        let tc: Vec<f64> = time.iter().map(|t| 10.0 + t).collect();
        assert_eq!(cycle_spans(&time, &tc), vec![(0.0, 99.0)]);
        assert!(cycle_spans(&[], &[]).is_empty());
    }
}
