//! A fixed-point run over a temperature stream, identical on host and board, for comparing
//! the board's integer evaluation with the host's bit for bit through one digest.
//!
//! Scope: the features (dT/dt estimator, clamping to the trained range, standardisation) are
//! the f32 path of [`crate::Compensator`] (soft-float on an FPU-less core, IEEE-exact and so
//! identical to the host); only Eq. (10) is integer ([`FixedModel::predict`]).

use crate::crc::crc32;
use crate::features::FeatureBank;
use crate::fixed::{Dph, FixedModel, Q, Z};
use crate::rate::RateEstimator;
use crate::table::ModelRef;

/// Plausible sensor range for the trace, °C (as `SensorLimits::DEFAULT`).
const TEMP_MIN_C: f32 = -60.0;
const TEMP_MAX_C: f32 = 130.0;

/// Feature state and the running digest of every output.
#[derive(Clone, Debug)]
pub struct FixedTrace<'a, const D: usize> {
    model: ModelRef<'a, D>,
    est: RateEstimator,
    bank: FeatureBank<D>,
    digest: u32,
    count: u32,
}

impl<'a, const D: usize> FixedTrace<'a, D> {
    /// A trace over `model`'s features.
    pub fn new(model: ModelRef<'a, D>) -> Self {
        FixedTrace {
            model,
            est: RateEstimator::new(model.spec.rate_filter),
            bank: FeatureBank::new(model.spec.features, model.spec.rate_filter.dt_s),
            digest: 0,
            count: 0,
        }
    }

    /// Absorbs one temperature sample and returns the standardised, clamped features in Q24,
    /// or None when the sample is implausible (skipped, as the compensator does).
    pub fn features(&mut self, temp_c: f32) -> Option<[Z; D]> {
        if !(TEMP_MIN_C..=TEMP_MAX_C).contains(&temp_c) {
            let e = self.est.skip();
            self.bank.skip(&e);
            return None;
        }
        let e = self.est.update(temp_c);
        let s = self.model.spec;
        let raw = self.bank.update(temp_c, &e);
        let x: [f32; D] = core::array::from_fn(|d| {
            let v = raw[d];
            if v > s.input_hi[d] {
                s.input_hi[d]
            } else if v >= s.input_lo[d] {
                v
            } else {
                s.input_lo[d]
            }
        });
        let z = self.model.standardise(&x);
        let mut out = [Q(0); D];
        for (o, v) in out.iter_mut().zip(z) {
            // A validated table keeps clamped standardised inputs far inside ±128.
            *o = Q::from_f32_bits(v.to_bits())?;
        }
        Some(out)
    }

    /// Folds one output into the digest (chained CRC-32 of the previous digest and the value).
    pub fn fold(&mut self, out: Dph) {
        let mut b = [0u8; 8];
        b[..4].copy_from_slice(&self.digest.to_le_bytes());
        b[4..].copy_from_slice(&out.0.to_le_bytes());
        self.digest = crc32(&b);
        self.count = self.count.saturating_add(1);
    }

    /// One sample: features, Eq. (10) in fixed point, fold. None when skipped.
    pub fn step<const N: usize>(&mut self, fixed: &FixedModel<N, D>, temp_c: f32) -> Option<Dph> {
        let z = self.features(temp_c)?;
        let out = fixed.predict(&z);
        self.fold(out);
        Some(out)
    }

    /// The digest of all outputs so far.
    pub const fn digest(&self) -> u32 {
        self.digest
    }

    /// Outputs folded so far.
    pub const fn count(&self) -> u32 {
        self.count
    }
}
