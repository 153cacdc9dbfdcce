//! The recording prepared for fitting: faults dropped, bursts averaged, dT/dt estimated,
//! the samples cut into whole blocks whose means the diagnosis fits, and the drive the model
//! sees on them.

use std::borrow::Cow;

use super::blocks::{block_samples, MAX_SAMPLES, MIN_BLOCKS};
use super::bursts::{burst_means, find_bursts, Bursts};
use super::columns::{baseline_specs, baseline_values};
use super::dequantise::read_quantum;
use super::drive::DriveSeries;
use super::model::PhysicsModel;
use super::rate::{estimate_rate, RATE_HALF_WIDTH_S};
use crate::DiagnoseError;
use rlg_eval::metrics::block_means;
use rlg_io::faults::{sensor_faults, FaultLimits, SensorFaults};
use rlg_io::recording::Recording;
use rlg_physics::Term;

/// The recording prepared for fitting.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// Sample period, s.
    pub dt_s: f64,
    /// Samples per block.
    pub block: usize,
    /// The drive (starting after the estimator's warm-up), whole blocks only.
    pub drive: DriveSeries,
    /// Recorded rate over the same samples, °/h.
    pub rate_dph: Vec<f64>,
    /// The drive over the whole recording (the estimator's warm-up included).
    pub full_drive: DriveSeries,
    /// The samples of `full_drive` that `drive` holds.
    pub range: std::ops::Range<usize>,
    /// Block means of the rate, °/h.
    pub y_b: Vec<f64>,
    /// Block means of time (s), temperature (°C), dT/dt (°C/s).
    pub t_b: Vec<f64>,
    /// °C.
    pub temp_b: Vec<f64>,
    /// °C/s.
    pub dtemp_b: Vec<f64>,
    /// Temperature samples dropped as sensor faults before anything else
    /// ([`rlg_io::faults::sensor_faults`]).
    pub faults: SensorFaults,
    /// Set when the record was sampled in bursts and each burst reduced to its mean
    /// ([`find_bursts`]).
    pub bursts: Option<Bursts>,
    /// The quantum the temperature is read at ([`read_quantum`]), where it is rounded.
    pub temp_quantum_c: Option<f64>,
}

impl Prepared {
    /// Number of blocks.
    pub fn nb(&self) -> usize {
        self.y_b.len()
    }

    /// The drive un-lagged by `tau_s` (see [`DriveSeries::unlagged`]), computed over the
    /// whole recording so the estimator's warm-up falls outside the fitted samples.
    pub fn drive_unlagged(&self, tau_s: f64) -> Result<DriveSeries, DiagnoseError> {
        Ok(self.fitted_part(
            self.full_drive
                .unlagged(tau_s, self.dt_s, self.temp_quantum_c)?,
        ))
    }

    /// The fitted samples of a drive over the whole recording, cut in place: a month's
    /// drive is 60 MB, and a copy would double it while both live.
    pub fn fitted_part(&self, mut full: DriveSeries) -> DriveSeries {
        let r = self.range.clone();
        for v in [&mut full.t_s, &mut full.temp_c, &mut full.dtemp_c_per_s] {
            v.truncate(r.end);
            v.drain(..r.start);
        }
        full
    }

    /// The drive de-quantised at `step_c` (see [`DriveSeries::dequantised`]), computed over
    /// the whole recording.
    pub fn drive_dequantised(&self, step_c: f64) -> Result<DriveSeries, DiagnoseError> {
        Ok(self.fitted_part(self.full_drive.dequantised(step_c, self.dt_s)?))
    }

    /// Block means of a per-sample series.
    pub fn blocks(&self, x: &[f64]) -> Vec<f64> {
        block_means(x, self.block)
    }

    /// Block means of [`baseline_columns`] on `drive`, one column at a time: a month's
    /// record then holds one 20 MB per-sample column, not one per linear parameter.
    pub fn baseline_blocks(&self, model: &PhysicsModel, drive: &DriveSeries) -> Vec<Vec<f64>> {
        baseline_specs(model)
            .iter()
            .map(|(_, unit)| self.blocks(&baseline_values(unit.as_ref(), drive)))
            .collect()
    }

    /// The recorded rate less `beta` times [`baseline_columns`] on `drive`, per sample, the
    /// columns computed one at a time (the bits of the sum over all of them at once).
    pub fn baseline_residual(
        &self,
        model: &PhysicsModel,
        drive: &DriveSeries,
        beta: &[f64],
    ) -> Vec<f64> {
        let mut fit = vec![0.0; self.rate_dph.len()];
        for ((_, unit), b) in baseline_specs(model).iter().zip(beta) {
            if *b != 0.0 {
                let c = baseline_values(unit.as_ref(), drive);
                fit.iter_mut().zip(&c).for_each(|(o, v)| *o += b * v);
            }
        }
        self.rate_dph.iter().zip(&fit).map(|(a, f)| a - f).collect()
    }
}

/// The sample period of time stamps: the mean step, unless gaps make it differ from the
/// median step by more than 1 % (a long gap would otherwise pass for a slow sample rate and
/// the blocks would span hours).
fn sample_period(time_s: &[f64]) -> f64 {
    let n = time_s.len();
    let mean_step = (time_s[n - 1] - time_s[0]) / (n - 1) as f64;
    let mut steps: Vec<f64> = time_s.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let median_step = steps[steps.len() / 2];
    if (mean_step / median_step - 1.0).abs() > 0.01 {
        median_step
    } else {
        mean_step
    }
}

/// Prepares a recording: computes dT/dt by a centred difference, drops the first 30 s and any
/// partial last block. A recording given by value lends its series to the result instead of
/// being copied (a month at 1 Hz: 80 MB less while the diagnosis runs).
pub fn prepare<'a>(rec: impl Into<Cow<'a, Recording>>) -> Result<Prepared, DiagnoseError> {
    prepare_shifted(rec, 0)
}

/// [`prepare`] with the 100 s blocks starting `shift` samples later (of the record as
/// prepared: after faults are dropped and bursts averaged); the samples before the first
/// block are still used for dT/dt.
pub fn prepare_shifted<'a>(
    rec: impl Into<Cow<'a, Recording>>,
    shift: usize,
) -> Result<Prepared, DiagnoseError> {
    let mut rec = rec.into();
    if rec.len() < 3 {
        return Err(DiagnoseError::TooShort {
            blocks: 0,
            min: MIN_BLOCKS,
        });
    }
    let (bad, faults) = sensor_faults(
        &rec.time_s,
        &rec.temp_c,
        sample_period(&rec.time_s),
        &FaultLimits::BOARD,
    );
    if faults.total() > 0 {
        // Dropped, so that they become gaps, which every step bridges.
        rec = Cow::Owned(rec.without(&bad));
    }
    let bursts = find_bursts(&rec.time_s).map(|(runs, b)| {
        rec = Cow::Owned(burst_means(&rec, &runs));
        b
    });
    let n = rec.len();
    if n < 3 {
        return Err(DiagnoseError::TooShort {
            blocks: 0,
            min: MIN_BLOCKS,
        });
    }
    let dt_s = sample_period(&rec.time_s);
    if n > MAX_SAMPLES {
        return Err(DiagnoseError::TooLong {
            samples: n,
            max: MAX_SAMPLES,
            days: n as f64 * dt_s / 86_400.0,
        });
    }
    let rate_all = estimate_rate(&rec.temp_c, &rec.time_s, dt_s)?;
    let block = block_samples(n, dt_s);
    // The first and last ±30 s have one-sided differences; the start is dropped (the end is
    // usually cut by the partial last block).
    let skip = ((RATE_HALF_WIDTH_S / dt_s).ceil() as usize + shift).min(n);
    let usable = (n - skip) / block * block;
    let nb = usable / block;
    if nb < MIN_BLOCKS {
        return Err(DiagnoseError::TooShort {
            blocks: nb,
            min: MIN_BLOCKS,
        });
    }
    let r = skip..skip + usable;
    let drive = DriveSeries {
        t_s: rec.time_s[r.clone()].to_vec(),
        temp_c: rec.temp_c[r.clone()].to_vec(),
        dtemp_c_per_s: rate_all[r.clone()].to_vec(),
    };
    let (t_s, temp_c, mut rate_dph) = match rec {
        Cow::Owned(x) => (x.time_s, x.temp_c, x.rate_dph),
        Cow::Borrowed(x) => (x.time_s.clone(), x.temp_c.clone(), x.rate_dph.clone()),
    };
    rate_dph.truncate(r.end);
    rate_dph.drain(..r.start);
    let temp_quantum_c = read_quantum(&temp_c);
    let full_drive = DriveSeries {
        t_s,
        temp_c,
        dtemp_c_per_s: rate_all,
    };
    Ok(Prepared {
        temp_quantum_c,
        faults,
        bursts,
        full_drive,
        range: r,
        dt_s,
        block,
        y_b: block_means(&rate_dph, block),
        t_b: block_means(&drive.t_s, block),
        temp_b: block_means(&drive.temp_c, block),
        dtemp_b: block_means(&drive.dtemp_c_per_s, block),
        drive,
        rate_dph,
    })
}

/// The drive the model sees: the recorded one, de-quantised when the model has a
/// `temp_quantization`, then un-lagged when it has a `sensor_lag` (the physics library applies
/// the lag first and the rounding to the lagged reading, so the diagnosis undoes them in the
/// reverse order).
pub fn model_drive<'a>(
    model: &PhysicsModel,
    prep: &'a Prepared,
) -> Result<Cow<'a, DriveSeries>, DiagnoseError> {
    let tau = model.terms.iter().find_map(|t| match t {
        Term::SensorLag { tau_s } if *tau_s > 0.0 => Some(*tau_s),
        _ => None,
    });
    let step = model.terms.iter().find_map(|t| match t {
        Term::TempQuantization { step_c } if *step_c > 0.0 => Some(*step_c),
        _ => None,
    });
    let dequantised = step
        .map(|q| prep.full_drive.dequantised(q, prep.dt_s))
        .transpose()?;
    let full = match (tau, dequantised) {
        (None, None) => return Ok(Cow::Borrowed(&prep.drive)),
        (None, Some(d)) => d,
        (Some(tau), Some(d)) => d.unlagged(tau, prep.dt_s, None)?,
        (Some(tau), None) => prep
            .full_drive
            .unlagged(tau, prep.dt_s, prep.temp_quantum_c)?,
    };
    Ok(Cow::Owned(prep.fitted_part(full)))
}
