//! Where things happen: phases of the run (warm-up, heating ramp, cooling ramp, hold) from the
//! recorded temperature and its estimated rate, and contiguous spans of 100 s blocks.

use serde::{Deserialize, Serialize};

use super::prepare::Prepared;

/// Length of the warm-up phase after power-on (the first recorded sample), s.
pub const WARMUP_S: f64 = 3600.0;

/// |dT/dt| above which a block is on a ramp, °C/s (0.1 °C/min; the chamber ramps at 0.5 … 2).
pub const RAMP_RATE_C_PER_S: f64 = 0.1 / 60.0;

/// A time span with its temperature band, phase and effect size.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Span {
    /// Start, s (start of the first block).
    pub t_start_s: f64,
    /// End, s (end of the last block).
    pub t_end_s: f64,
    /// Lowest recorded temperature in the span (block means), °C.
    pub temp_lo_c: f64,
    /// Highest, °C.
    pub temp_hi_c: f64,
    /// The phase most of the span's blocks are in: `warm_up`, `heating`, `cooling`, `hold`.
    pub phase: String,
    /// Mean of the signal over the span, °/h (residual or fitted effect).
    #[serde(default)]
    pub effect_dph: f64,
}

/// Phase label of each block.
pub fn phase_labels(prep: &Prepared) -> Vec<&'static str> {
    let t0 = prep.full_drive.t_s[0];
    prep.t_b
        .iter()
        .zip(&prep.dtemp_b)
        .map(|(t, r)| {
            if t - t0 < WARMUP_S {
                "warm_up"
            } else if *r > RAMP_RATE_C_PER_S {
                "heating"
            } else if *r < -RAMP_RATE_C_PER_S {
                "cooling"
            } else {
                "hold"
            }
        })
        .collect()
}

/// The phases as spans (runs of equal labels).
pub fn phases(prep: &Prepared) -> Vec<Span> {
    let labels = phase_labels(prep);
    let mut out = Vec::new();
    let mut start = 0;
    for b in 1..=labels.len() {
        if b == labels.len() || labels[b] != labels[start] {
            out.push(span(prep, &labels, start, b, &vec![0.0; labels.len()]));
            start = b;
        }
    }
    out
}

/// Runs of `mask` as spans, runs closer than `merge_gap` blocks joined; `signal` gives the
/// effect size (its mean over the span).
pub fn spans(prep: &Prepared, mask: &[bool], merge_gap: usize, signal: &[f64]) -> Vec<Span> {
    let labels = phase_labels(prep);
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut b = 0;
    while b < mask.len() {
        if mask[b] {
            let s = b;
            while b < mask.len() && mask[b] {
                b += 1;
            }
            match runs.last_mut() {
                Some(last) if s - last.1 <= merge_gap => last.1 = b,
                _ => runs.push((s, b)),
            }
        } else {
            b += 1;
        }
    }
    runs.into_iter()
        .map(|(s, e)| span(prep, &labels, s, e, signal))
        .collect()
}

fn span(prep: &Prepared, labels: &[&'static str], s: usize, e: usize, signal: &[f64]) -> Span {
    let half = 0.5 * prep.block as f64 * prep.dt_s;
    let temps = &prep.temp_b[s..e];
    let mut counts: Vec<(&str, usize)> = Vec::new();
    for l in &labels[s..e] {
        match counts.iter_mut().find(|c| c.0 == *l) {
            Some(c) => c.1 += 1,
            None => counts.push((l, 1)),
        }
    }
    let phase = counts
        .iter()
        .max_by_key(|c| c.1)
        .map_or("hold", |c| c.0)
        .to_string();
    Span {
        t_start_s: prep.t_b[s] - half,
        t_end_s: prep.t_b[e - 1] + half,
        temp_lo_c: temps.iter().copied().fold(f64::INFINITY, f64::min),
        temp_hi_c: temps.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        phase,
        effect_dph: signal[s..e].iter().sum::<f64>() / (e - s) as f64,
    }
}

/// Blocks where |x| reaches at least `frac` of its largest magnitude.
pub fn peak_mask(x: &[f64], frac: f64) -> Vec<bool> {
    let m = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    x.iter().map(|v| m > 0.0 && v.abs() >= frac * m).collect()
}

/// Intersection over union of two block masks (0 when both are empty).
pub fn iou(a: &[bool], b: &[bool]) -> f64 {
    let inter = a.iter().zip(b).filter(|(x, y)| **x && **y).count();
    let union = a.iter().zip(b).filter(|(x, y)| **x || **y).count();
    if union == 0 {
        0.0
    } else {
        inter as f64 / union as f64
    }
}

/// Centred moving average over `w` blocks (shorter at the ends).
pub fn moving_average(x: &[f64], w: usize) -> Vec<f64> {
    let h = w / 2;
    (0..x.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(h), (i + h + 1).min(x.len()));
            x[a..b].iter().sum::<f64>() / (b - a) as f64
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iou_and_peak_mask_by_hand() {
        let a = [true, true, false, false];
        let b = [false, true, true, false];
        assert!((iou(&a, &b) - 1.0 / 3.0).abs() < 1e-15);
        assert_eq!(
            peak_mask(&[0.1, -1.0, 0.6, 0.4], 0.5),
            vec![false, true, true, false]
        );
        assert_eq!(moving_average(&[0.0, 3.0, 6.0], 3), vec![1.5, 3.0, 4.5]);
    }
}
