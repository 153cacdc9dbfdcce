//! The 1 Hz compensation step: (temperature °C, gyro rate °/h) → compensated rate + status.
//!
//! Rules, in order of precedence (each sets its [`Status`] bit):
//! 1. Table invalid (failed [`crate::ModelRef::validate`], or, for a compensator built with
//!    [`Compensator::from_table`], a CRC-32 mismatch): the raw rate passes through,
//!    `TABLE_FAULT`; nothing else is evaluated.
//! 2. Gyro rate non-finite or beyond `rate_limit_dph`: the last good compensated rate is held
//!    (0 before the first), `GYRO_FAULT`. The temperature path still runs.
//! 3. Temperature non-finite, outside `[temp_min_c, temp_max_c]` (open or shorted sensor), or
//!    jumping more than `max_temp_step_c` from the estimator's prediction: the sample is not
//!    absorbed (the estimator extrapolates, see [`crate::RateEstimator::skip`]), the raw rate
//!    passes through uncompensated, `TEMP_FAULT`. After `max_skipped` consecutive faulty
//!    samples the estimator is reset and re-warms on the next good sample.
//! 4. Temperature bit-identical to the previous `stuck_samples` accepted readings although,
//!    when that reading appeared, the warmed-up estimator had the body moving fast enough to
//!    change by `stuck_min_change_c` over that many samples (a sensor or ADC frozen on a
//!    ramp; a body in a chamber cannot stop dead within minutes): `TEMP_STUCK`. A steady hold,
//!    which can read one code for hours on a quantised sensor, is never flagged; a sensor that
//!    freezes during a hold cannot be told from the hold and costs nothing until the body
//!    moves. While flagged the model keeps compensating at the held reading (the best estimate
//!    left; the estimator's dT/dt decays to 0). When the reading moves again by more than
//!    `max_temp_step_c` from the held value, the frozen span is discarded: the estimator
//!    restarts at the new reading (`WARMING_UP`) instead of treating the jump as a fault or
//!    absorbing it as a ramp; a smaller move is absorbed as usual.
//! 5. A feature outside the range seen in training: the feature is clamped to that range, the
//!    clamped model compensates, `OUT_OF_RANGE`.
//! 6. Fewer than `warmup_samples` good samples since (re)start: the model compensates with the
//!    estimate it has, `WARMING_UP`.
//!
//! Every output is finite: the raw rate is only passed through when it is finite, and the
//! model's output is finite for clamped finite features and a validated table.

use core::borrow::Borrow;

use crate::features::FeatureBank;
use crate::rate::{RateEstimate, RateEstimator};
use crate::table::{ModelRef, ModelSpec, ModelTable, TableError};

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
    /// The temperature has read bit-identical for `stuck_samples` accepted samples although
    /// the body was moving when that reading appeared (a frozen sensor, rule 4); the model
    /// compensates at the held reading.
    pub const TEMP_STUCK: Status = Status(1 << 5);

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
        self.0
            & (Self::TEMP_FAULT.0 | Self::GYRO_FAULT.0 | Self::TABLE_FAULT.0 | Self::TEMP_STUCK.0)
            != 0
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
    /// Repeats of one bit-identical temperature reading after which it is flagged
    /// `TEMP_STUCK` (0: never), if the body was moving when it appeared (`stuck_min_change_c`).
    pub stuck_samples: u32,
    /// Smallest change, °C, that the dT/dt estimated when a reading appeared must predict over
    /// `stuck_samples` periods for its repeats to count as a frozen sensor.
    pub stuck_min_change_c: f32,
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
        // 5 min without a single code change where the body was moving at ≥ 0.1 °C/min: even
        // if the chamber stopped at that moment, a body with a 10 min time constant still
        // moves 0.1 °C/min · 10 min · (1 − e^(−1/2)) ≈ 0.4 °C, 40 codes of a 0.01 °C sensor.
        stuck_samples: 300,
        stuck_min_change_c: 0.5,
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
///
/// `S` holds the table's [`ModelSpec`]: by default a reference (a Rust table in flash, which
/// the optimiser sees through), or the spec itself ([`Compensator::from_parts`]: a table laid
/// out by C code, so that the state borrows only the support vectors and coefficients and a C
/// caller may move or copy it).
#[derive(Clone, Debug)]
pub struct Compensator<'a, const D: usize, S: Borrow<ModelSpec<D>> = &'a ModelSpec<D>> {
    spec: S,
    support: &'a [[f32; D]],
    alpha_dph: &'a [f32],
    limits: SensorLimits,
    table_ok: bool,
    table_error: Option<TableError>,
    rate: RateEstimator,
    bank: FeatureBank<D>,
    skipped: u32,
    last_good_dph: f32,
    /// Bits of the last accepted temperature reading (meaningless while `repeats` is 0 and
    /// nothing was accepted yet).
    last_temp_bits: u32,
    /// How many accepted readings in a row repeated `last_temp_bits`.
    repeats: u32,
    /// Whether a reading has been accepted since the last restart of the estimator.
    have_last: bool,
    /// Whether the body was moving fast enough, when `last_temp_bits` appeared, for its
    /// repeats to mean a frozen sensor (rule 4).
    stuck_armed: bool,
    /// Whether the table has linear terms (else their sum, exactly 0, is skipped).
    linear: bool,
}

impl<'a, const D: usize> Compensator<'a, D> {
    /// A compensator for `model`; the table is validated once here.
    /// No CRC is checked here (a [`ModelRef`] carries none; host-built models need none); the
    /// board uses [`Compensator::from_table`].
    pub fn new(model: ModelRef<'a, D>, limits: SensorLimits) -> Self {
        Self::with_check(model, limits, model.validate().err())
    }

    /// A compensator for a flashed table: the stored CRC-32 and then the content are checked
    /// once here ([`ModelTable::verify`]); on any failure every sample is `TABLE_FAULT` with
    /// the raw rate passed through, and [`Compensator::table_error`] says why.
    pub fn from_table<const N: usize>(table: &'a ModelTable<N, D>, limits: SensorLimits) -> Self {
        Self::with_check(table.as_model(), limits, table.verify().err())
    }

    fn with_check(model: ModelRef<'a, D>, limits: SensorLimits, err: Option<TableError>) -> Self {
        Self::build(model.spec, model.support, model.alpha_dph, limits, err)
    }
}

impl<'a, const D: usize> Compensator<'a, D, ModelSpec<D>> {
    /// A compensator for a table given as its parts (a table laid out by C code, whose
    /// [`ModelSpec`] the caller assembled and the compensator keeps): the stored `crc32` and
    /// then the content are checked once here, as by [`Compensator::from_table`].
    pub fn from_parts(
        spec: ModelSpec<D>,
        support: &'a [[f32; D]],
        alpha_dph: &'a [f32],
        crc32: u32,
        limits: SensorLimits,
    ) -> Self {
        let model = ModelRef {
            spec: &spec,
            support,
            alpha_dph,
        };
        let err = model.verify(crc32).err();
        Self::build(spec, support, alpha_dph, limits, err)
    }
}

impl<'a, const D: usize, S: Borrow<ModelSpec<D>>> Compensator<'a, D, S> {
    fn build(
        spec: S,
        support: &'a [[f32; D]],
        alpha_dph: &'a [f32],
        limits: SensorLimits,
        err: Option<TableError>,
    ) -> Self {
        let s: &ModelSpec<D> = spec.borrow();
        let (rate, bank) = (
            RateEstimator::new(s.rate_filter),
            FeatureBank::new(s.features, s.rate_filter.dt_s),
        );
        let linear = s.linear_dph.iter().any(|b| *b != 0.0);
        Compensator {
            spec,
            support,
            alpha_dph,
            limits,
            table_ok: err.is_none(),
            table_error: err,
            rate,
            bank,
            skipped: 0,
            last_good_dph: 0.0,
            last_temp_bits: 0,
            repeats: 0,
            have_last: false,
            stuck_armed: false,
            linear,
        }
    }

    /// The model: the spec and the borrowed arrays.
    #[inline(always)]
    fn model(&self) -> ModelRef<'_, D> {
        ModelRef {
            spec: self.spec.borrow(),
            support: self.support,
            alpha_dph: self.alpha_dph,
        }
    }

    /// Whether the table passed validation.
    pub const fn table_ok(&self) -> bool {
        self.table_ok
    }

    /// Why the table was rejected, if it was.
    pub const fn table_error(&self) -> Option<TableError> {
        self.table_error
    }

    /// The table's spec.
    pub fn spec(&self) -> &ModelSpec<D> {
        self.spec.borrow()
    }

    /// The feature vector the model sees for a temperature estimate, before clamping, with
    /// the recursive features ([`crate::features`]) at their current state.
    pub fn features(&self, temp_c: f32, est: &RateEstimate) -> [f32; D] {
        self.bank.values(temp_c, est)
    }

    // Inlined into the 1 Hz update: the C library's update, one function per input count, kept
    // it out of line at opt-level "s" and paid a call and spills per sample.
    #[inline(always)]
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
        (temp_c - predicted).abs() <= l.max_temp_step_c * periods
    }

    /// Whether the last accepted temperature reading has repeated `stuck_samples` times
    /// although the body was moving when it appeared.
    #[inline(always)]
    fn is_stuck(&self) -> bool {
        self.stuck_armed
            && self.limits.stuck_samples > 0
            && self.repeats >= self.limits.stuck_samples
    }

    /// Forgets the temperature history: the estimator and the recursive features restart and
    /// warm up again on the next accepted reading.
    fn restart_estimator(&mut self) {
        self.rate.reset();
        self.bank.skip(&self.rate.estimate());
        self.bank.reset();
        self.repeats = 0;
        self.have_last = false;
        self.stuck_armed = false;
    }

    /// Processes one 1 Hz sample.
    #[inline]
    pub fn update(&mut self, temp_c: f32, gyro_dph: f32) -> Compensated {
        let linear = self.linear;
        self.update_with(temp_c, gyro_dph, |model, x| {
            let f = if linear {
                model.predict_dph(x)
            } else {
                // The same value: predict_dph adds a linear sum of exactly 0.
                model.predict_standardised_dph(&model.standardise(x))
            };
            f - model.spec.reference_dph
        })
    }

    /// [`Compensator::update`] with the model evaluated by `correction_dph`, which receives the
    /// model and the feature vector clamped to the trained range and returns the correction
    /// f(x) − reference, °/h (a non-finite value leaves the raw rate uncompensated). Every rule
    /// of the module doc applies unchanged; `correction_dph` is called only for an accepted
    /// temperature of a valid table. The fixed-point compensator
    /// ([`crate::fixed::FixedCompensator`]) evaluates Eq. (10) in integers through it.
    #[inline(always)]
    pub fn update_with(
        &mut self,
        temp_c: f32,
        gyro_dph: f32,
        correction_dph: impl FnOnce(&ModelRef<'_, D>, &[f32; D]) -> f32,
    ) -> Compensated {
        if !self.table_ok {
            let (rate_dph, status) = if gyro_dph.is_finite() {
                (gyro_dph, Status::TABLE_FAULT)
            } else {
                (self.last_good_dph, Status::TABLE_FAULT | Status::GYRO_FAULT)
            };
            if gyro_dph.is_finite() {
                self.last_good_dph = gyro_dph;
            }
            return Compensated {
                rate_dph,
                correction_dph: 0.0,
                status,
            };
        }

        let mut status = Status::OK;
        let gyro_ok = gyro_dph.is_finite() && gyro_dph.abs() <= self.limits.rate_limit_dph;
        if !gyro_ok {
            status |= Status::GYRO_FAULT;
        }

        if self.is_stuck() && temp_c.to_bits() != self.last_temp_bits {
            let held = f32::from_bits(self.last_temp_bits);
            let l = &self.limits;
            let in_band = temp_c >= l.temp_min_c && temp_c <= l.temp_max_c; // false for NaN
            if in_band && (temp_c - held).abs() > l.max_temp_step_c {
                // Rule 4: the frozen span ends with a jump; restart at the new reading.
                self.restart_estimator();
            }
        }
        let correction = if self.temp_is_plausible(temp_c) {
            self.skipped = 0;
            let est = self.rate.update(temp_c);
            let bits = temp_c.to_bits();
            if self.have_last && bits == self.last_temp_bits {
                self.repeats = self.repeats.saturating_add(1);
            } else {
                self.repeats = 0;
                let l = &self.limits;
                let window_s = l.stuck_samples as f32 * self.rate.filter().dt_s;
                self.stuck_armed =
                    !est.warming_up && est.rate_c_per_s.abs() * window_s >= l.stuck_min_change_c;
            }
            self.last_temp_bits = bits;
            self.have_last = true;
            if self.is_stuck() {
                status |= Status::TEMP_STUCK;
            }
            if est.warming_up {
                status |= Status::WARMING_UP;
            }
            let mut x = self.bank.update(temp_c, &est);
            let s: &ModelSpec<D> = self.spec.borrow();
            for ((v, lo), hi) in x.iter_mut().zip(s.input_lo).zip(s.input_hi) {
                // Written so that a NaN could never pass (it cannot reach here anyway).
                if !(*v >= lo && *v <= hi) {
                    status |= Status::OUT_OF_RANGE;
                    *v = if *v > hi { hi } else { lo };
                }
            }
            Some(correction_dph(&self.model(), &x))
        } else {
            status |= Status::TEMP_FAULT;
            self.skipped = self.skipped.saturating_add(1);
            if self.skipped >= self.limits.max_skipped {
                self.restart_estimator();
            } else {
                let est = self.rate.skip();
                self.bank.skip(&est);
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
        Compensated {
            rate_dph,
            correction_dph,
            status,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rate::RateFilter;
    use crate::table::{Feature, ModelSpec, ModelTable};
    use proptest::prelude::*;

    /// A 2-input model whose correction is 0.01·z_T at the support vector: simple enough to
    /// reason about, real enough to exercise clamping.
    const TABLE: ModelTable<3, 2> = ModelTable {
        spec: ModelSpec {
            features: [Feature::TempC, Feature::TempRateCPerS],
            input_mean: [40.0, 0.0],
            input_inv_scale: [0.05, 50.0],
            linear_dph: [0.0, 0.0],
            input_lo: [10.0, -0.02],
            input_hi: [65.0, 0.02],
            gamma: 0.5,
            bias_dph: -7.1,
            reference_dph: -7.1,
            rate_filter: RateFilter {
                alpha: 0.0327,
                beta: 0.000_272,
                dt_s: 1.0,
                warmup_samples: 300,
            },
        },
        support: [[-1.0, 0.0], [0.0, 0.0], [1.0, 0.5]],
        alpha_dph: [-0.01, 0.002, 0.01],
        crc32: 0,
    };

    fn comp() -> Compensator<'static, 2> {
        Compensator::new(TABLE.as_model(), SensorLimits::DEFAULT)
    }

    #[test]
    fn compensates_with_the_model_after_warm_up() {
        let mut c = comp();
        let mut out = c.update(30.0, -7.0);
        assert!(out.status.contains(Status::WARMING_UP));
        for _ in 0..400 {
            out = c.update(30.0, -7.0);
        }
        assert!(out.status.is_ok(), "{:?}", out.status);
        let model = TABLE.as_model();
        let want = model.predict_dph(&[30.0, 0.0]) - TABLE.spec.reference_dph;
        assert!((out.correction_dph - want).abs() < 1e-7);
        assert_eq!(out.rate_dph, -7.0 - out.correction_dph);
    }

    #[test]
    fn temperature_fault_passes_raw_rate_and_recovers() {
        let mut c = comp();
        for _ in 0..400 {
            c.update(30.0, -7.0);
        }
        for bad in [f32::NAN, f32::INFINITY, -273.0, 850.0, 60.0] {
            let out = c.update(bad, -7.05);
            assert!(
                out.status.contains(Status::TEMP_FAULT),
                "{bad}: {:?}",
                out.status
            );
            assert_eq!(out.rate_dph, -7.05);
            assert_eq!(out.correction_dph, 0.0);
        }
        let out = c.update(30.0, -7.0);
        assert!(out.status.is_ok(), "{:?}", out.status);
    }

    #[test]
    fn long_fault_restarts_the_estimator() {
        let mut c = comp();
        for _ in 0..400 {
            c.update(30.0, -7.0);
        }
        for _ in 0..SensorLimits::DEFAULT.max_skipped {
            c.update(f32::NAN, -7.0);
        }
        // A new temperature far from the old one is accepted after the restart, and warms up.
        let out = c.update(50.0, -7.0);
        assert!(!out.status.contains(Status::TEMP_FAULT));
        assert!(out.status.contains(Status::WARMING_UP));
    }

    /// Warm up on a 0.6 °C/min ramp from 20 °C; returns the compensator and the last reading.
    fn on_a_ramp() -> (Compensator<'static, 2>, f32) {
        let mut c = comp();
        let mut t = 20.0f32;
        for k in 0..400 {
            t = 20.0 + 0.01 * k as f32;
            c.update(t, -7.0);
        }
        (c, t)
    }

    /// A temperature frozen on a ramp is flagged once it has repeated `stuck_samples` times,
    /// the model keeps compensating at it, and a jump away from it restarts the estimator. A
    /// hold reading one code for hours is never flagged, nor is a slow approach that stops.
    #[test]
    fn stuck_temperature_is_flagged_and_recovers() {
        let n = SensorLimits::DEFAULT.stuck_samples;
        let (mut c, held) = on_a_ramp();
        for k in 1..=n {
            let out = c.update(held, -7.0);
            assert_eq!(
                out.status.contains(Status::TEMP_STUCK),
                k >= n,
                "repeat {k}"
            );
            assert!(!out.status.contains(Status::TEMP_FAULT));
        }
        let out = c.update(held, -7.0);
        assert!(out.status.contains(Status::TEMP_STUCK) && out.status.is_fault());
        // Still compensated, at the held reading and the estimator's (decaying) dT/dt.
        let mut est = RateEstimator::new(TABLE.spec.rate_filter);
        for k in 0..400 {
            est.update(20.0 + 0.01 * k as f32);
        }
        let mut e = est.estimate();
        for _ in 0..=n {
            e = est.update(held);
        }
        let model = TABLE.as_model();
        let x = c.features(held, &e);
        let want = model.predict_dph(&x) - TABLE.spec.reference_dph;
        assert!((out.correction_dph - want).abs() < 1e-6);
        assert_eq!(out.rate_dph, -7.0 - out.correction_dph);
        // The sensor comes back 6 °C away: no fault, a restart (warm-up), no stuck flag.
        let back = c.update(held + 6.0, -7.0);
        assert!(!back.status.is_fault(), "{:?}", back.status);
        assert!(back.status.contains(Status::WARMING_UP));

        // A hold from power-on, and a ramp that slows to a stop, read one code for an hour
        // without a flag.
        let mut c = comp();
        for _ in 0..3600 {
            assert!(!c.update(30.0, -7.0).status.contains(Status::TEMP_STUCK));
        }
        let (mut c, _) = on_a_ramp();
        let mut t = 24.0f64;
        for k in 0..4000 {
            // Exponential approach to 25 °C (τ = 600 s), read to 0.01 °C.
            t = 25.0 - 1.0 * (-(k as f64) / 600.0).exp();
            let code = ((t * 100.0).round() / 100.0) as f32;
            let out = c.update(code, -7.0);
            assert!(
                !out.status.contains(Status::TEMP_STUCK),
                "approach sample {k}: {code}"
            );
        }
        assert!(t > 24.99);

        // A NaN inside a frozen span is a temperature fault and does not clear the count.
        let (mut c, held) = on_a_ramp();
        for _ in 0..=n {
            c.update(held, -7.0);
        }
        assert!(c.update(f32::NAN, -7.0).status.contains(Status::TEMP_FAULT));
        assert!(c.update(held, -7.0).status.contains(Status::TEMP_STUCK));
        // Disabled with 0.
        let limits = SensorLimits {
            stuck_samples: 0,
            ..SensorLimits::DEFAULT
        };
        let mut c = Compensator::new(TABLE.as_model(), limits);
        let mut out = c.update(20.0, -7.0);
        for k in 0..400 {
            out = c.update(20.0 + 0.01 * k as f32, -7.0);
        }
        for _ in 0..2 * n {
            out = c.update(23.99, -7.0);
        }
        assert!(!out.status.contains(Status::TEMP_STUCK));
    }

    #[test]
    fn gyro_fault_holds_last_good_output() {
        let mut c = comp();
        for _ in 0..400 {
            c.update(30.0, -7.0);
        }
        let good = c.update(30.0, -7.0).rate_dph;
        for bad in [f32::NAN, f32::NEG_INFINITY, 1.0e9] {
            let out = c.update(30.0, bad);
            assert!(out.status.contains(Status::GYRO_FAULT));
            assert_eq!(out.rate_dph, good);
        }
    }

    #[test]
    fn out_of_range_is_clamped_and_flagged() {
        let mut c = comp();
        for _ in 0..400 {
            c.update(64.0, -7.0);
        }
        // Walk slowly (within the step limit) up to 80 °C.
        let mut out = c.update(64.0, -7.0);
        for k in 0..1600 {
            out = c.update(64.0 + k as f32 * 0.01, -7.0);
        }
        assert!(out.status.contains(Status::OUT_OF_RANGE));
        // dT/dt is 0.01 °C/s, inside the range, so only T is clamped.
        let m = TABLE.as_model();
        let want = m.predict_dph(&[65.0, 0.01]) - TABLE.spec.reference_dph;
        assert!(
            (out.correction_dph - want).abs() < 2e-6,
            "{} vs {want}",
            out.correction_dph
        );
    }

    #[test]
    fn invalid_table_passes_through() {
        let mut bad = TABLE;
        bad.alpha_dph[1] = f32::NAN;
        let mut c = Compensator::new(bad.as_model(), SensorLimits::DEFAULT);
        assert!(!c.table_ok());
        let out = c.update(30.0, -7.0);
        assert_eq!(out.status, Status::TABLE_FAULT);
        assert_eq!(out.rate_dph, -7.0);
        let out = c.update(30.0, f32::NAN);
        assert!(out.rate_dph.is_finite());
    }

    /// A flipped bit in one coefficient of a sealed table is caught by the CRC even though the
    /// corrupted table is otherwise valid (finite, right shape), and the compensator then passes
    /// the raw rate through with `TABLE_FAULT` only.
    #[test]
    fn corrupted_coefficient_is_a_table_fault() {
        let good = TABLE.sealed();
        let c = Compensator::from_table(&good, SensorLimits::DEFAULT);
        assert!(c.table_ok() && c.table_error().is_none());
        for (k, bit) in [(0usize, 0u32), (1, 17), (2, 31)] {
            let mut bad = good;
            bad.alpha_dph[k] = f32::from_bits(bad.alpha_dph[k].to_bits() ^ (1 << bit));
            assert!(bad.as_model().validate().is_ok(), "still a valid shape");
            let mut c = Compensator::from_table(&bad, SensorLimits::DEFAULT);
            assert!(
                matches!(c.table_error(), Some(TableError::Checksum { stored, .. }) if stored == good.crc32),
                "{:?}",
                c.table_error()
            );
            for _ in 0..5 {
                let out = c.update(30.0, -7.0);
                assert_eq!(out.status, Status::TABLE_FAULT);
                assert_eq!((out.rate_dph, out.correction_dph), (-7.0, 0.0));
            }
        }
        // A stale stored CRC (any content change, e.g. the bias) is caught the same way.
        let mut bad = good;
        bad.spec.bias_dph += 1e-3;
        assert!(matches!(bad.verify(), Err(TableError::Checksum { .. })));
    }

    /// A table on the recursive features: the compensator feeds the model T + τ·dT/dt and the
    /// time since power-on computed from the same estimator, and the CRC covers τ.
    #[test]
    fn recursive_features_reach_the_model() {
        let mut t = TABLE;
        t.spec.features = [Feature::TempLeadC { tau_s: 100 }, Feature::TimeOnS];
        t.spec.input_mean = [40.0, 500.0];
        t.spec.input_inv_scale = [0.05, 0.002];
        t.spec.input_lo = [0.0, 0.0];
        t.spec.input_hi = [80.0, 1.0e6];
        let t = t.sealed();
        let mut other = t;
        other.spec.features[0] = Feature::TempLeadC { tau_s: 101 };
        assert_ne!(other.as_model().content_crc32(), t.crc32);

        let mut c = Compensator::from_table(&t, SensorLimits::DEFAULT);
        let mut est = RateEstimator::new(t.spec.rate_filter);
        let m = t.as_model();
        for k in 0..600u32 {
            let temp = 20.0 + 0.01 * k as f32;
            let e = est.update(temp);
            let out = c.update(temp, -7.0);
            let x = [temp + 100.0 * e.rate_c_per_s, k as f32];
            let want = m.predict_dph(&x) - t.spec.reference_dph;
            assert_eq!(out.correction_dph, want, "k={k}");
        }
    }

    fn any_f32() -> impl Strategy<Value = f32> {
        prop_oneof![
            4 => -100.0f32..150.0,
            1 => proptest::num::f32::ANY,
            1 => Just(f32::NAN),
        ]
    }

    proptest! {
        /// Whatever the inputs, every output is finite, and finite in-range input is never
        /// flagged as a fault.
        #[test]
        fn outputs_are_always_finite(seq in proptest::collection::vec((any_f32(), any_f32()), 1..400)) {
            let mut c = comp();
            let l = SensorLimits::DEFAULT;
            for (t, r) in seq {
                let out = c.update(t, r);
                prop_assert!(out.rate_dph.is_finite() && out.correction_dph.is_finite());
                // Bounded: a Gaussian kernel is at most 1, so |correction| ≤ Σ|a| + |b − ref|.
                let bound = TABLE.alpha_dph.iter().map(|a| a.abs()).sum::<f32>()
                    + (TABLE.spec.bias_dph - TABLE.spec.reference_dph).abs();
                prop_assert!(out.correction_dph.abs() <= bound * (1.0 + 1e-5), "{out:?}");
                // Non-finite or implausible input is flagged, and its output is the safe one:
                // a rejected temperature passes the raw rate through uncompensated.
                if !(r.is_finite() && r.abs() <= l.rate_limit_dph) {
                    prop_assert!(out.status.contains(Status::GYRO_FAULT));
                }
                if !(t >= l.temp_min_c && t <= l.temp_max_c) {
                    prop_assert!(out.status.contains(Status::TEMP_FAULT));
                    prop_assert_eq!(out.correction_dph, 0.0);
                    if !out.status.contains(Status::GYRO_FAULT) {
                        prop_assert_eq!(out.rate_dph, r);
                    }
                }
                // A temperature outside the table's trained range (but plausible) is clamped
                // and flagged.
                let (lo, hi) = (TABLE.spec.input_lo[0], TABLE.spec.input_hi[0]);
                let in_trained_range = t >= lo && t <= hi;
                if !out.status.contains(Status::TEMP_FAULT) && !in_trained_range {
                    prop_assert!(out.status.contains(Status::OUT_OF_RANGE));
                }
            }
        }
    }
}
