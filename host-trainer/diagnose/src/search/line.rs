//! Whether the temperature itself oscillates at a period. A bias that repeats at the period
//! of the chamber's own oscillation (a controller hunting about its set point) is a response
//! to temperature as much as a periodic in time: the record cannot tell the two apart by
//! that period, and the thermal families, which predict the response from the temperature,
//! are the explanation to weigh.

use crate::linalg::Basis;

/// Power of dT/dt's sinusoid at the period over the median power at the periods from half to
/// twice it ([`line_ratio`]), above which the temperature oscillates at the period. Where the
/// spectrum is flat over those two octaves, a periodogram ordinate is exponential about its
/// mean and the median is ln 2 of the mean, so noise passes 20 with probability
/// e^(−20 ln 2), about 10⁻⁶.
pub(super) const LINE_RATIO: f64 = 20.0;

/// Periods of the comparison band, spread geometrically from half to twice the period.
const BAND: usize = 41;

/// Chunks the line is asked in: at least this many, each at least [`CHUNK_PERIODS`] periods
/// long.
const MIN_CHUNKS: usize = 3;
const CHUNK_PERIODS: f64 = 8.0;
/// Chunks of a record long enough for more.
const MAX_CHUNKS: usize = 6;

/// The median over chunks of the record of [`chunk_ratio`] at `period_s`, in the block means
/// of dT/dt `dtemp_b` at times `t_b`; 0 where the record holds fewer than [`MIN_CHUNKS`]
/// chunks of [`CHUNK_PERIODS`] periods. In chunks, not over the whole record: a ramp or a
/// staircase programme is periodic too, and its corners put harmonics at many periods of a
/// whole record, each a line against its neighbours; within a few hours, an oscillation of
/// the temperature's own recurs every period and a programme's corner does not.
pub(super) fn line_ratio(t_b: &[f64], dtemp_b: &[f64], period_s: f64) -> f64 {
    let (Some(first), Some(last)) = (t_b.first(), t_b.last()) else {
        return 0.0;
    };
    if !period_s.is_finite() || period_s <= 0.0 {
        return 0.0;
    }
    let span = last - first;
    let len = (CHUNK_PERIODS * period_s).max(span / MAX_CHUNKS as f64);
    let k = (span / len).floor() as usize;
    if k < MIN_CHUNKS {
        return 0.0;
    }
    let n = t_b.len();
    let mut ratios: Vec<f64> = (0..k)
        .map(|c| {
            let r = c * n / k..(c + 1) * n / k;
            chunk_ratio(&t_b[r.clone()], &dtemp_b[r], period_s)
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    ratios[k / 2]
}

/// The power of the least-squares sinusoid of period `period_s` in `y` at times `t`, beside
/// a quadratic in time (the programme's slow change within the chunk), over the median of
/// that power at [`BAND`] periods from half to twice `period_s`.
fn chunk_ratio(t: &[f64], y: &[f64], period_s: f64) -> f64 {
    let (t0, span) = (t[0], (t[t.len() - 1] - t[0]).max(f64::MIN_POSITIVE));
    let x: Vec<f64> = t.iter().map(|v| (v - t0) / span).collect();
    let power = |p: f64| -> f64 {
        let w = std::f64::consts::TAU / p;
        let cols = vec![
            vec![1.0; t.len()],
            x.clone(),
            x.iter().map(|v| v * v).collect(),
            t.iter().map(|v| (w * (v - t0)).sin()).collect(),
            t.iter().map(|v| (w * (v - t0)).cos()).collect(),
        ];
        let c = Basis::new(&cols).coefficients(y);
        c[3] * c[3] + c[4] * c[4]
    };
    let mut band: Vec<f64> = (0..BAND)
        .map(|k| {
            let e = -1.0 + 2.0 * k as f64 / (BAND - 1) as f64;
            power(period_s * 2f64.powf(e))
        })
        .collect();
    band.sort_by(f64::total_cmp);
    let median = band[BAND / 2];
    if median > 0.0 && median.is_finite() {
        power(period_s) / median
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::replicates::replicate_rng;
    use rand_distr::{Distribution, Normal};

    /// A day of 100 s means of dT/dt with reading noise: a day/night sine of ±15 °C with a
    /// hunting of ±0.05 °C every 1100 s shows a line at 1100 s and none at 2750 s; the sine
    /// alone shows none, and neither do ramps of 1 °C/min every other 2 h, whose corners put
    /// harmonics of the 4 h programme at many periods of the whole day.
    #[test]
    fn a_hunting_chamber_has_a_line_at_its_period_only() {
        use std::f64::consts::TAU;
        let nb = 864;
        let t_b: Vec<f64> = (0..nb).map(|b| (b as f64 + 0.5) * 100.0).collect();
        let normal = Normal::new(0.0, 2e-4).expect("σ > 0");
        let mut rng = replicate_rng(7, 0);
        let noise: Vec<f64> = (0..nb).map(|_| normal.sample(&mut rng)).collect();
        let series = |f: &dyn Fn(f64) -> f64| -> Vec<f64> {
            t_b.iter().zip(&noise).map(|(t, n)| f(*t) + n).collect()
        };
        let sine = |t: f64| 15.0 * TAU / 86_400.0 * (TAU * t / 86_400.0).cos();
        let hunting = |t: f64| 0.05 * TAU / 1100.0 * (TAU * t / 1100.0).cos();
        let ramps = |t: f64| {
            if (t / 7200.0) as usize % 2 == 0 {
                1.0 / 60.0
            } else {
                0.0
            }
        };
        let hunted = series(&|t| sine(t) + hunting(t));
        assert!(line_ratio(&t_b, &hunted, 1100.0) > LINE_RATIO);
        assert!(line_ratio(&t_b, &hunted, 2750.0) < LINE_RATIO);
        assert!(line_ratio(&t_b, &series(&sine), 1100.0) < LINE_RATIO);
        let ramped = series(&ramps);
        for p in [1100.0, 1108.0, 2057.0, 2750.0] {
            assert!(line_ratio(&t_b, &ramped, p) < LINE_RATIO, "{p} s");
        }
    }
}
