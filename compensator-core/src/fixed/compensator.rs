//! The 1 Hz compensator with Eq. (10) in integers: [`crate::Compensator`]'s rules, features
//! and status bits unchanged (f32, soft-float on an FPU-less core and IEEE-exact, so identical
//! to the host), the model evaluated by [`FixedModelRef::predict`].
//!
//! At an accepted temperature the clamped features are standardised in f32 and converted to
//! Q24 (saturating: a validated table's clamped inputs never reach ±128), the model gives f(x)
//! in Q24, and the correction is f(x) − reference in Q24 (saturating), handed on as the f32
//! nearest to it (exact below 1 °/h; an `i32` → f32 conversion, IEEE round to nearest). The
//! output rate is the raw rate minus that correction in f32, as on the f32 path.

use core::borrow::Borrow;

use super::{Dph, FixedError, FixedModel, FixedModelRef, Q, Z};
use crate::compensator::{Compensated, Compensator, SensorLimits};
use crate::table::{ModelSpec, ModelTable};

/// 2^−24: one Q24 unit, °/h.
const Q24_UNIT: f32 = 1.0 / 16_777_216.0;

/// The Q24 value nearest to `v`, saturating at the `i32` range (NaN gives the lower end).
fn q24_saturating(v: f32) -> Z {
    match Q::from_f32_bits(v.to_bits()) {
        Some(q) => q,
        None if v > 0.0 => Q(i32::MAX),
        None => Q(i32::MIN),
    }
}

/// [`Compensator`] with Eq. (10) evaluated in fixed point (`S`: how the compensator holds the
/// table's spec, as for [`Compensator`]).
#[derive(Clone, Debug)]
pub struct FixedCompensator<'a, const D: usize, S: Borrow<ModelSpec<D>> = &'a ModelSpec<D>> {
    comp: Compensator<'a, D, S>,
    model: FixedModelRef<'a, D>,
    reference: Dph,
}

impl<'a, const D: usize, S: Borrow<ModelSpec<D>>> FixedCompensator<'a, D, S> {
    /// The compensator `comp` (its table already checked) with `model`, the fixed-point form
    /// of the same table; fails when the reference output has no Q24 form (beyond ±128 °/h).
    pub fn new(
        comp: Compensator<'a, D, S>,
        model: FixedModelRef<'a, D>,
    ) -> Result<Self, FixedError> {
        let reference = Q::from_f32_bits(comp.spec().reference_dph.to_bits())
            .ok_or(FixedError::Range("reference_dph"))?;
        Ok(FixedCompensator {
            comp,
            model,
            reference,
        })
    }

    /// The f32 compensator underneath (table status, spec).
    pub const fn compensator(&self) -> &Compensator<'a, D, S> {
        &self.comp
    }

    /// Processes one 1 Hz sample ([`Compensator::update`]'s rules).
    pub fn update(&mut self, temp_c: f32, gyro_dph: f32) -> Compensated {
        let (model, reference) = (&self.model, self.reference);
        self.comp.update_with(temp_c, gyro_dph, |m, x| {
            let z = m.standardise(x).map(q24_saturating);
            let correction = model.predict(&z).saturating_sub(reference);
            correction.0 as f32 * Q24_UNIT
        })
    }
}

impl<'a, const D: usize> FixedCompensator<'a, D> {
    /// A compensator for a flashed table and its conversion (`FixedModel::from_table(table)`),
    /// the CRC checked as by [`Compensator::from_table`].
    pub fn from_table<const N: usize>(
        table: &'a ModelTable<N, D>,
        fixed: &'a FixedModel<N, D>,
        limits: SensorLimits,
    ) -> Result<Self, FixedError> {
        Self::new(Compensator::from_table(table, limits), fixed.as_model())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixed::FixedTrace;
    use crate::rate::RateFilter;
    use crate::table::{Feature, ModelSpec};
    use crate::Status;

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
            reference_dph: -7.09,
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

    /// On a ramp with faults, the fixed compensator's status bits are the f32 compensator's,
    /// its correction is the fixed-point model of `FixedTrace` (the board's integer reference)
    /// minus the reference, and it stays within a few Q24 units of the f32 correction.
    #[test]
    fn follows_the_f32_rules_with_the_integer_model() {
        let t = TABLE.sealed();
        let fixed = FixedModel::from_table(&t).unwrap();
        let mut fc = FixedCompensator::from_table(&t, &fixed, SensorLimits::DEFAULT).unwrap();
        let mut f32c = Compensator::from_table(&t, SensorLimits::DEFAULT);
        let mut trace = FixedTrace::new(t.as_model());
        let reference = Q::<24>::from_f32_bits(t.spec.reference_dph.to_bits()).unwrap();
        let mut compared = 0;
        for k in 0..3000u32 {
            let temp = if k == 1500 {
                f32::NAN
            } else {
                5.0 + 0.02 * k as f32
            };
            let gyro = if k == 2000 { f32::INFINITY } else { -7.0 };
            let a = fc.update(temp, gyro);
            let b = f32c.update(temp, gyro);
            assert_eq!(a.status, b.status, "k={k}");
            let y = trace.step(&fixed, temp);
            if !a.status.contains(Status::TEMP_FAULT) && !a.status.contains(Status::GYRO_FAULT) {
                let want = y.unwrap().saturating_sub(reference).0 as f32 * Q24_UNIT;
                assert_eq!(a.correction_dph.to_bits(), want.to_bits(), "k={k}");
                assert_eq!(a.rate_dph, gyro - a.correction_dph);
                assert!((a.correction_dph - b.correction_dph).abs() < 1e-6, "k={k}");
                compared += 1;
            }
        }
        assert!(compared > 2900, "{compared}");
    }

    /// A corrupted table is a table fault on the fixed path too (raw rate passed through).
    #[test]
    fn corrupted_table_passes_the_raw_rate() {
        let t = TABLE.sealed();
        let fixed = FixedModel::from_table(&t).unwrap();
        let mut bad = t;
        bad.alpha_dph[0] = f32::from_bits(bad.alpha_dph[0].to_bits() ^ 1);
        let mut fc = FixedCompensator::from_table(&bad, &fixed, SensorLimits::DEFAULT).unwrap();
        let out = fc.update(30.0, -7.0);
        assert_eq!(out.status, Status::TABLE_FAULT);
        assert_eq!(out.rate_dph, -7.0);
    }

    #[test]
    fn saturating_conversion() {
        assert_eq!(q24_saturating(1.0).0, 1 << 24);
        assert_eq!(q24_saturating(1e9).0, i32::MAX);
        assert_eq!(q24_saturating(-1e9).0, i32::MIN);
        assert_eq!(q24_saturating(f32::NAN).0, i32::MIN);
    }
}
