//! A temperature reading rounded to a quantum: the quantum read from the recorded values,
//! and the temperature reconstructed from the rounded reading.

/// The quantum of a temperature reading, °C, read from the recorded values: the 5th
/// percentile of the non-zero sample-to-sample changes, kept only if at least 95 % of all
/// non-zero changes are whole multiples of it (within 5 %) and it is above 1e-4 °C (the
/// CSV's resolution). `None`: the reading shows no quantum (a continuous or dithered sensor).
pub fn read_quantum(temp_c: &[f64]) -> Option<f64> {
    let mut d: Vec<f64> = temp_c
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|v| *v > 5e-5)
        .collect();
    if d.len() < 20 {
        return None;
    }
    d.sort_by(f64::total_cmp);
    let q = d[d.len() / 20];
    if q < 1e-4 {
        return None;
    }
    let whole = d
        .iter()
        .filter(|v| {
            let r = *v / q;
            (r - r.round()).abs() < 0.05
        })
        .count();
    // Rounded to the CSV's 1e-4 °C so that the same quantum reads the same on every record.
    (whole as f64 >= 0.95 * d.len() as f64).then(|| (q * 1e4).round() / 1e4)
}

/// Reconstructs a temperature rounded to multiples of `step_c`: where the reading changes
/// from one level to the next, the true temperature crossed the boundary between them half
/// a sample earlier; the reconstruction interpolates linearly between those crossings. Where
/// a level is left the way it was entered (the temperature turned inside it, e.g. a hold),
/// the crossings bound an excursion into that level: the reconstruction rises to the level's
/// centre within the shorter of half the excursion and the time the last crossing took, and
/// stays there. Before the first and after the last crossing it holds the reading.
///
/// Written here because it is the inverse of the physics library's own quantiser; a general
/// interpolation crate would not know where the boundaries are.
pub fn dequantise(temp_c: &[f64], step_c: f64) -> Vec<f64> {
    let n = temp_c.len();
    let mut out = temp_c.to_vec();
    if n < 2 || step_c.is_nan() || step_c <= 0.0 {
        return out;
    }
    // Knots (sample position, temperature) at each crossing.
    let mut knots: Vec<(f64, f64)> = Vec::new();
    for i in 1..n {
        let (a, b) = (temp_c[i - 1], temp_c[i]);
        if (b - a).abs() > 0.5 * step_c {
            let x = i as f64 - 0.5;
            // A jump over several levels in one sample: crossings spread over the sample.
            knots.push((x, 0.5 * (a + b)));
        }
    }
    if knots.is_empty() {
        return out;
    }
    // Excursions: consecutive crossings of the same boundary; add the level's centre.
    let mut full: Vec<(f64, f64)> = Vec::with_capacity(knots.len() * 2);
    for k in 0..knots.len() {
        full.push(knots[k]);
        if let Some(&(x1, v1)) = knots.get(k + 1) {
            let (x0, v0) = knots[k];
            if (v1 - v0).abs() < 0.5 * step_c {
                let level = temp_c[(x0.ceil() as usize).min(n - 1)];
                let prev = if k > 0 { x0 - knots[k - 1].0 } else { x1 - x0 };
                let ramp = (0.5 * (x1 - x0)).min(prev.max(1.0));
                full.push((x0 + ramp, level));
                if x1 - ramp > x0 + ramp {
                    full.push((x1 - ramp, level));
                }
            }
        }
    }
    let mut k = 0;
    for (i, o) in out.iter_mut().enumerate() {
        let x = i as f64;
        if x < full[0].0 || x > full[full.len() - 1].0 {
            continue;
        }
        while k + 1 < full.len() && full[k + 1].0 < x {
            k += 1;
        }
        let (x0, v0) = full[k];
        let (x1, v1) = full.get(k + 1).copied().unwrap_or(full[k]);
        *o = if x1 > x0 {
            v0 + (v1 - v0) * (x - x0) / (x1 - x0)
        } else {
            v0
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prepare::rate::estimate_rate;

    /// A body temperature heating towards 40 °C then cooling at 0.5 °C/min, then resting.
    fn smooth_temperature() -> Vec<f64> {
        (0..20_000)
            .map(|i| {
                let t = f64::from(i);
                if t < 8000.0 {
                    20.0 + 20.0 * (1.0 - (-t / 1200.0).exp())
                } else {
                    let top = 20.0 + 20.0 * (1.0 - (-8000.0f64 / 1200.0).exp());
                    (top - (t - 8000.0) / 120.0).max(-5.0)
                }
            })
            .collect()
    }

    /// The quantum is read from a rounded reading, and none from a continuous one.
    #[test]
    fn quantum_is_read_from_the_reading() {
        let body = smooth_temperature();
        for q in [0.01, 0.0625, 0.25] {
            let r: Vec<f64> = body.iter().map(|t| (t / q).round() * q).collect();
            assert_eq!(read_quantum(&r), Some((q * 1e4_f64).round() / 1e4), "q {q}");
        }
        let noisy: Vec<f64> = body
            .iter()
            .enumerate()
            .map(|(i, t)| t + 0.003 * (i as f64 * 1.7).sin() * (i as f64 * 0.37).cos())
            .collect();
        assert_eq!(read_quantum(&noisy), None);
        assert_eq!(read_quantum(&[1.0; 100]), None);
    }

    /// De-quantising a coarse reading recovers the temperature and its rate: errors a
    /// fraction of the rounding's.
    #[test]
    fn dequantise_recovers_temperature_and_rate() {
        let body = smooth_temperature();
        let t: Vec<f64> = (0..body.len()).map(|i| i as f64).collect();
        let q = 0.25;
        let read: Vec<f64> = body.iter().map(|v| (v / q).round() * q).collect();
        let rec = dequantise(&read, q);
        let rms = |a: &[f64], b: &[f64]| {
            let s: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
            (s / a.len() as f64).sqrt()
        };
        let (e_read, e_rec) = (rms(&read, &body), rms(&rec, &body));
        assert!(e_rec < 0.35 * e_read, "{e_rec} vs {e_read}");
        let rate_true = estimate_rate(&body, &t, 1.0).expect("rate");
        let rate_read = estimate_rate(&read, &t, 1.0).expect("rate");
        let rate_rec = estimate_rate(&rec, &t, 1.0).expect("rate");
        let err = |r: &[f64]| rms(r, &rate_true);
        assert!(
            err(&rate_rec) < 0.35 * err(&rate_read),
            "{} vs {}",
            err(&rate_rec),
            err(&rate_read)
        );
        // Nothing to undo: an unquantised series is returned as it is where it never jumps.
        assert_eq!(dequantise(&[1.0; 10], 0.1), vec![1.0; 10]);
    }
}
