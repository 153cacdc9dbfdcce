//! The calibration recording as the board sees it: a continuous 1 Hz stream, the span chosen,
//! the samples the board's sensor rules reject taken out, the board's own features.

use std::borrow::Cow;

use compensator_core::Feature;
use rlg_io::faults::{sensor_faults, FaultLimits, SensorFaults};
use rlg_io::recording::Recording;
use rlg_train::features::{self, FeatureSeries};

use crate::error::{ensure, CalibrateError};

/// The median sample step of `rec`, checked to be a continuous 1 Hz stream; `what` names the
/// recording in errors.
pub fn check_stream(rec: &Recording, what: &str) -> Result<f64, CalibrateError> {
    ensure!(
        rec.len() >= 2,
        Input,
        "{what} has {} sample(s); a calibration needs a 1 Hz stream",
        rec.len()
    );
    let mut steps: Vec<f64> = rec.time_s.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let dt = steps[steps.len() / 2];
    ensure!(
        dt <= 1.1,
        Input,
        "{what}: samples every {dt:.3} s (median step): not a continuous 1 Hz stream (burst \
         means?), so no dT/dt model can be trained from it; give --static for a \
         temperature-only model"
    );
    ensure!(
        dt >= 0.9,
        Input,
        "{what}: samples every {dt:.3} s (median step); the board runs at 1 Hz: bring it to \
         1 Hz first with `rlg resample --period-s 1`"
    );
    Ok(dt)
}

/// The recording without the temperature samples the board's sensor rules reject
/// ([`rlg_io::faults::sensor_faults`]); they become gaps, which the features bridge as the
/// board does. A glitch left in would reach the dT/dt model (and the cycle split: a +30 °C
/// sample made a one-cycle record of a two-cycle one).
pub(crate) fn without_sensor_faults(
    rec: Cow<'_, Recording>,
    dt: f64,
) -> (Cow<'_, Recording>, SensorFaults) {
    let (bad, f) = sensor_faults(&rec.time_s, &rec.temp_c, dt, &FaultLimits::BOARD);
    if f.total() == 0 {
        (rec, f)
    } else {
        (Cow::Owned(rec.without(&bad)), f)
    }
}

pub(crate) fn features_of(
    rec: &Recording,
    tau: f64,
    dt: f64,
) -> Result<FeatureSeries, CalibrateError> {
    Ok(features::compute(
        &[Feature::TempC, Feature::TempRateCPerS],
        &rec.temp_c,
        &rec.time_s,
        tau,
        dt,
    )?)
}

/// Restricts `rec` to `[from_s, to_s]`.
pub(crate) fn window_of(
    rec: &Recording,
    from_s: Option<f64>,
    to_s: Option<f64>,
) -> Result<Cow<'_, Recording>, CalibrateError> {
    if from_s.is_none() && to_s.is_none() {
        return Ok(Cow::Borrowed(rec));
    }
    let lo = from_s.unwrap_or(f64::NEG_INFINITY);
    let hi = to_s.unwrap_or(f64::INFINITY);
    let a = rec.time_s.partition_point(|t| *t < lo);
    let b = rec.time_s.partition_point(|t| *t <= hi);
    ensure!(
        b > a + 1,
        Input,
        "no samples between --from-s {lo} and --to-s {hi} (the recording spans {} … {} s)",
        rec.time_s.first().unwrap_or(&f64::NAN),
        rec.time_s.last().unwrap_or(&f64::NAN)
    );
    let pick = |v: &Vec<f64>| v[a..b].to_vec();
    Ok(Cow::Owned(Recording {
        time_s: pick(&rec.time_s),
        rate_dph: pick(&rec.rate_dph),
        temp_c: pick(&rec.temp_c),
        chamber_c: rec.chamber_c.as_ref().map(pick),
        extra: Vec::new(),
        comments: rec.comments.clone(),
    }))
}

/// The training span's 100 s means and the cycle each starts in, by the rule
/// [`rlg_train::dataset::from_recording`] uses (warm-up dropped, consecutive kept samples averaged).
pub(crate) fn cycle_labels(
    rec: &Recording,
    series: &FeatureSeries,
    to_s: f64,
    block: usize,
    cycles: &[(f64, f64)],
) -> Vec<usize> {
    let keep: Vec<usize> = (0..rec.len())
        .filter(|&k| !series.warming_up[k] && rec.time_s[k] <= to_s)
        .collect();
    keep.chunks_exact(block)
        .map(|c| {
            let t = rec.time_s[c[0]];
            cycles
                .iter()
                .position(|s| t < s.1)
                .unwrap_or(cycles.len() - 1)
        })
        .collect()
}
