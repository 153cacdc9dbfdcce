//! The 1 Hz compensation step: (temperature °C, gyro rate °/h) → compensated rate + status.
//!
//! Rules, in order of precedence (each sets its [`Status`] bit):
//! 1. Table invalid (failed [`crate::ModelRef::validate`]): the raw rate passes through,
//!    `TABLE_FAULT`; nothing else is evaluated.
//! 2. Gyro rate non-finite or beyond `rate_limit_dph`: the last good compensated rate is held
//!    (0 before the first), `GYRO_FAULT`. The temperature path still runs.
//! 3. Temperature non-finite, outside `[temp_min_c, temp_max_c]` (open or shorted sensor), or
//!    jumping more than `max_temp_step_c` from the estimator's prediction: the sample is not
//!    absorbed (the estimator extrapolates, see [`crate::RateEstimator::skip`]), the raw rate
//!    passes through uncompensated, `TEMP_FAULT`. After `max_skipped` consecutive faulty
//!    samples the estimator is reset and re-warms on the next good sample.
//! 4. A feature outside the range seen in training: the feature is clamped to that range, the
//!    clamped model compensates, `OUT_OF_RANGE`.
//! 5. Fewer than `warmup_samples` good samples since (re)start: the model compensates with the
//!    estimate it has, `WARMING_UP`.
//!
//! Every output is finite: the raw rate is only passed through when it is finite, and the
//! model's output is finite for clamped finite features and a validated table.

use crate::rate::{RateEstimate, RateEstimator};
use crate::table::{Feature, ModelRef};

/// Bit set describing one output sample. `Status::OK` (no bit) means compensated normally.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status(pub u8);

impl Status {
    /// Compensated normally.
    pub const OK: Status = Status(0);
    /// The dT/dt estimator has not yet seen `warmup_samples` good samples.
    pub const WARMING_UP: Status = Status(1 << 0);
    /// A feature lay outside the trained range and was clamped.
    pub const OUT_OF_RANGE: Status = Status(1 << 1);
    /// The temperature sample was rejected; the raw rate is passed through.
    pub const TEMP_FAULT: Status = Status(1 << 2);
    /// The gyro sample was rejected; the last good output is held.
    pub const GYRO_FAULT: Status = Status(1 << 3);
    /// The model table failed validation; the raw rate is passed through.
    pub const TABLE_FAULT: Status = Status(1 << 4);

    /// Whether every bit of `other` is set in `self`.
    pub const fn contains(self, other: Status) -> bool {
        self.0 & other.0 == other.0
    }

    /// Whether the output is a fully trusted compensated rate.
    pub const fn is_ok(self) -> bool {
        self.0 == 0
    }

    /// Whether a fault (not just warm-up or clamping) was flagged.
    pub const fn is_fault(self) -> bool {
        self.0 & (Self::TEMP_FAULT.0 | Self::GYRO_FAULT.0 | Self::TABLE_FAULT.0) != 0
    }
}

impl core::ops::BitOr for Status {
    type Output = Status;
    fn bitor(self, rhs: Status) -> Status {
        Status(self.0 | rhs.0)
    }
}

impl core::ops::BitOrAssign for Status {
    fn bitor_assign(&mut self, rhs: Status) {
        self.0 |= rhs.0;
    }
}

/// Plausibility limits of the board's sensors.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorLimits {
    /// Lowest plausible temperature reading, °C (an open Pt sensor reads far below).
    pub temp_min_c: f32,
    /// Highest plausible temperature reading, °C.
    pub temp_max_c: f32,
    /// Largest plausible change from the predicted temperature in one sample, °C.
    pub max_temp_step_c: f32,
    /// Largest plausible gyro output magnitude, °/h.
    pub rate_limit_dph: f32,
    /// Consecutive rejected temperature samples after which the estimator restarts.
    pub max_skipped: u32,
}

impl SensorLimits {
    /// Limits for a navigation RLG in a −55…+125 °C environment: a gyro body cannot move
    /// 2 °C in a second, and ±1000 °/s bounds any vehicle.
    pub const DEFAULT: SensorLimits = SensorLimits {
        temp_min_c: -60.0,
        temp_max_c: 130.0,
        max_temp_step_c: 2.0,
        rate_limit_dph: 3.6e6,
        max_skipped: 30,
    };
}

impl Default for SensorLimits {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One output sample.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Compensated {
    /// Output rate, °/h (compensated unless `status` says otherwise).
    pub rate_dph: f32,
    /// The correction that was subtracted, °/h (0 when none was applied).
    pub correction_dph: f32,
    /// What happened to this sample.
    pub status: Status,
}

/// Runs the feature estimators and the model on each 1 Hz sample.
#[derive(Clone, Debug)]
pub struct Compensator<'a, const D: usize> {
    model: ModelRef<'a, D>,
    limits: SensorLimits,
    table_ok: bool,
    rate: RateEstimator,
    skipped: u32,
    last_good_dph: f32,
}

impl<'a, const D: usize> Compensator<'a, D> {
    /// A compensator for `model`; the table is validated once here.
    pub fn new(model: ModelRef<'a, D>, limits: SensorLimits) -> Self {
        let table_ok = model.validate().is_ok();
        Compensator {
            model,
            limits,
            table_ok,
            rate: RateEstimator::new(model.spec.rate_filter),
            skipped: 0,
            last_good_dph: 0.0,
        }
    }

    /// Whether the table passed validation.
    pub const fn table_ok(&self) -> bool {
        self.table_ok
    }

    /// The feature vector the model sees for a temperature estimate, before clamping.
    pub fn features(&self, temp_c: f32, est: &RateEstimate) -> [f32; D] {
        core::array::from_fn(|d| match self.model.spec.features[d] {
            Feature::TempC => temp_c,
            Feature::TempRateCPerS => est.rate_c_per_s,
        })
    }

    fn temp_is_plausible(&self, temp_c: f32) -> bool {
        let l = &self.limits;
        if !(temp_c >= l.temp_min_c && temp_c <= l.temp_max_c) {
            return false; // also rejects NaN
        }
        if self.rate.absorbed() == 0 {
            return true; // nothing to predict from yet
        }
        // The level was already extrapolated over skipped samples; allow the body to have
        // moved one step per elapsed period.
        let est = self.rate.estimate();
        let predicted = est.level_c + est.rate_c_per_s * self.rate.filter().dt_s;
        let periods = self.skipped.saturating_add(1) as f32;
        libm::fabsf(temp_c - predicted) <= l.max_temp_step_c * periods
    }

    /// Processes one 1 Hz sample.
    pub fn update(&mut self, temp_c: f32, gyro_dph: f32) -> Compensated {
        if !self.table_ok {
            let (rate_dph, status) = if gyro_dph.is_finite() {
                (gyro_dph, Status::TABLE_FAULT)
            } else {
                (self.last_good_dph, Status::TABLE_FAULT | Status::GYRO_FAULT)
            };
            if gyro_dph.is_finite() {
                self.last_good_dph = gyro_dph;
            }
            return Compensated { rate_dph, correction_dph: 0.0, status };
        }

        let mut status = Status::OK;
        let gyro_ok = gyro_dph.is_finite() && libm::fabsf(gyro_dph) <= self.limits.rate_limit_dph;
        if !gyro_ok {
            status |= Status::GYRO_FAULT;
        }

        let correction = if self.temp_is_plausible(temp_c) {
            self.skipped = 0;
            let est = self.rate.update(temp_c);
            if est.warming_up {
                status |= Status::WARMING_UP;
            }
            let mut x = self.features(temp_c, &est);
            let s = self.model.spec;
            for d in 0..D {
                // Written so that a NaN could never pass (it cannot reach here anyway).
                if !(x[d] >= s.input_lo[d] && x[d] <= s.input_hi[d]) {
                    status |= Status::OUT_OF_RANGE;
                    x[d] = if x[d] > s.input_hi[d] { s.input_hi[d] } else { s.input_lo[d] };
                }
            }
            Some(self.model.predict_dph(&x) - s.reference_dph)
        } else {
            status |= Status::TEMP_FAULT;
            self.skipped = self.skipped.saturating_add(1);
            if self.skipped >= self.limits.max_skipped {
                self.rate.reset();
            } else {
                self.rate.skip();
            }
            None
        };

        let (rate_dph, correction_dph) = match (gyro_ok, correction) {
            (false, _) => (self.last_good_dph, 0.0),
            (true, Some(c)) if c.is_finite() => (gyro_dph - c, c),
            (true, _) => (gyro_dph, 0.0),
        };
        if gyro_ok {
            self.last_good_dph = rate_dph;
        }
        Compensated { rate_dph, correction_dph, status }
    }
}
