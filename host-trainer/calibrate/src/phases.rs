//! The residual by thermal phase: heating, cooling and hold. A model fitted where the gyro
//! heats may leave its error where it cools (hysteresis, a lag); one number for the whole
//! record hides that, three do not.
//!
//! The compensated output is cut into gap-free windows ([`gapless_block_means`], the
//! stability's own windows); each window is classed by the mean of the board's dT/dt
//! estimate over it: hold when |dT/dt| is below [`HOLD_FRACTION`] of the record's 95th
//! percentile of |dT/dt| (and never above [`HOLD_MAX_C_PER_S`]), else heating or cooling by
//! its sign. Each class's figure is the RMS of its window means about the mean of all windows.

use serde::Serialize;

use rlg_eval::metrics::stability::gapless_block_means;

/// A window is a hold when its |dT/dt| is below this fraction of the 95th percentile of |dT/dt|.
pub const HOLD_FRACTION: f64 = 0.1;
/// ... and below this, °C/s (0.6 °C/min would be a ramp on any chamber).
pub const HOLD_MAX_C_PER_S: f64 = 0.01;

/// RMS of window means about the record's mean, by phase, °/h (`None`: no window in it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PhaseRms {
    /// Windows with T rising.
    pub heating_dph: Option<f64>,
    /// Windows with T falling.
    pub cooling_dph: Option<f64>,
    /// Windows with T held.
    pub hold_dph: Option<f64>,
    /// Windows in each phase: heating, cooling, hold.
    pub windows: [usize; 3],
}

/// Phase of each window of `window` samples: 0 heating, 1 cooling, 2 hold.
pub fn window_phases(time_s: &[f64], rate_c_per_s: &[f64], window: usize) -> Vec<usize> {
    let r = gapless_block_means(time_s, rate_c_per_s, window);
    classify(&r, rate_c_per_s)
}

/// Phase of each rate of `rates` (°C/s): 0 heating, 1 cooling, 2 hold, the hold threshold from
/// the record's own rates `all` (see the module doc).
pub fn classify(rates: &[f64], all: &[f64]) -> Vec<usize> {
    let mut mags: Vec<f64> = all.iter().map(|v| v.abs()).collect();
    mags.sort_by(f64::total_cmp);
    let p95 = mags
        .get((mags.len() as f64 * 0.95) as usize)
        .copied()
        .unwrap_or(0.0);
    let hold = (HOLD_FRACTION * p95).min(HOLD_MAX_C_PER_S);
    rates
        .iter()
        .map(|v| {
            if v.abs() <= hold {
                2
            } else if *v > 0.0 {
                0
            } else {
                1
            }
        })
        .collect()
}

/// [`PhaseRms`] of `output` (see the module doc).
pub fn phase_rms(time_s: &[f64], rate_c_per_s: &[f64], output: &[f64], window: usize) -> PhaseRms {
    let means = gapless_block_means(time_s, output, window);
    let phase = window_phases(time_s, rate_c_per_s, window);
    if means.is_empty() || means.len() != phase.len() {
        return PhaseRms::default();
    }
    let mean = means.iter().sum::<f64>() / means.len() as f64;
    let mut ss = [0.0f64; 3];
    let mut count = [0usize; 3];
    for (m, p) in means.iter().zip(&phase) {
        ss[*p] += (m - mean).powi(2);
        count[*p] += 1;
    }
    let of = |i: usize| (count[i] > 0).then(|| (ss[i] / count[i] as f64).sqrt());
    PhaseRms {
        heating_dph: of(0),
        cooling_dph: of(1),
        hold_dph: of(2),
        windows: count,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ramp up, a hold and a ramp down: an output that is off only while cooling shows up
    /// in the cooling figure alone.
    #[test]
    fn an_error_while_cooling_is_reported_as_cooling() {
        let n = 3000;
        let time: Vec<f64> = (0..n).map(f64::from).collect();
        let rate: Vec<f64> = (0..n)
            .map(|k| match k {
                k if k < 1000 => 0.01,
                k if k < 2000 => 0.0,
                _ => -0.01,
            })
            .collect();
        let out: Vec<f64> = (0..n).map(|k| if k >= 2000 { 1.0 } else { 0.0 }).collect();
        let p = phase_rms(&time, &rate, &out, 100);
        assert_eq!(p.windows, [10, 10, 10]);
        // Mean of all windows 1/3: heating and hold sit 1/3 below, cooling 2/3 above.
        assert!((p.heating_dph.unwrap() - 1.0 / 3.0).abs() < 1e-12);
        assert!((p.hold_dph.unwrap() - 1.0 / 3.0).abs() < 1e-12);
        assert!((p.cooling_dph.unwrap() - 2.0 / 3.0).abs() < 1e-12);
    }
}
