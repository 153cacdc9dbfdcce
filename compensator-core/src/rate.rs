//! Recursive dT/dt estimator for 1 Hz temperature samples.
//!
//! A critically damped α-β tracker (Brown's double exponential smoothing written in
//! level/slope form), with discount θ = exp(−dt/τ): α = 1 − θ², β = (1 − θ)². State is two
//! f32 numbers; one update is six flops.
//!
//! Transfer characteristics (θ = exp(−1/60), i.e. τ = 60 s at 1 Hz; each figure is asserted
//! by a test in this module):
//! * Ramp: a type-2 loop, so on a steady ramp the slope estimate has **no** steady-state lag
//!   or error; after a step in slope it settles like (1 + k/τ)·e^(−k/τ): within 1 % after
//!   about 6.6 τ (≈ 400 s at τ = 60 s).
//! * White noise of σ on T gives a slope noise of σ·√(2β²/(α(4 − 2α − β)))/dt:
//!   1.08e-3·σ per second at τ = 60 s.
//! * 0.01 °C quantisation (σ = 0.01/√12 ≈ 2.9e-3 °C if it were white) would add 3.1e-6 °C/s
//!   rms; on a real 1 °C/min ramp the quantisation error is periodic, not white, and the
//!   measured figure is 5.8e-6 °C/s rms, 3.5e-4 of the ramp rate; on a constant reading the estimate
//!   decays to exactly 0 (no limit cycle), since the residual is then exactly 0 after
//!   convergence of the level.
//!
//! The trainer computes its dT/dt training feature by running this same code over the
//! recording, so the board and the training data see identical features.

/// Gains of the estimator, stored in the model table so the board uses exactly the filter
/// the trainer used.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RateFilter {
    /// Level gain α = 1 − θ².
    pub alpha: f32,
    /// Slope gain β = (1 − θ)².
    pub beta: f32,
    /// Sample period, s.
    pub dt_s: f32,
    /// Samples after start (or restart) before the estimate is trusted: about 5 τ/dt.
    pub warmup_samples: u32,
}

impl RateFilter {
    /// The critically damped filter with smoothing time constant `tau_s` at period `dt_s`.
    ///
    /// Non-finite or non-positive arguments give a filter that fails [`RateFilter::is_stable`].
    pub fn from_tau_s(tau_s: f32, dt_s: f32) -> Self {
        let theta = libm::expf(-dt_s / tau_s);
        let warm = libm::ceilf(5.0 * tau_s / dt_s);
        RateFilter {
            alpha: 1.0 - theta * theta,
            beta: (1.0 - theta) * (1.0 - theta),
            dt_s,
            // A saturating cast: NaN and negatives become 0, huge values u32::MAX.
            warmup_samples: warm as u32,
        }
    }

    /// Whether the gains lie inside the α-β stability triangle (0 < α < 2, 0 < β < 4 − 2α)
    /// and the period is a positive finite number.
    pub fn is_stable(&self) -> bool {
        let (a, b) = (self.alpha, self.beta);
        a > 0.0
            && a < 2.0
            && b > 0.0
            && b < 4.0 - 2.0 * a
            && self.dt_s > 0.0
            && self.dt_s.is_finite()
    }
}

/// One output of the estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RateEstimate {
    /// Smoothed temperature, °C.
    pub level_c: f32,
    /// dT/dt, °C/s.
    pub rate_c_per_s: f32,
    /// Fewer than `warmup_samples` samples have been absorbed since start.
    pub warming_up: bool,
}

/// The estimator's state.
#[derive(Clone, Copy, Debug)]
pub struct RateEstimator {
    filter: RateFilter,
    level_c: f32,
    /// Slope per sample (°C per dt), kept unscaled so the update is a pure α-β step.
    slope_c: f32,
    absorbed: u32,
}

impl RateEstimator {
    /// A new estimator; the first sample initialises the level, with zero slope.
    pub const fn new(filter: RateFilter) -> Self {
        RateEstimator {
            filter,
            level_c: 0.0,
            slope_c: 0.0,
            absorbed: 0,
        }
    }

    /// The gains in use.
    pub const fn filter(&self) -> &RateFilter {
        &self.filter
    }

    /// Absorbs one temperature sample taken one period after the previous one.
    ///
    /// The caller must pass finite samples; a missing or faulty sample is handled with
    /// [`RateEstimator::skip`] instead.
    // Inlined into the 1 Hz update: the C library's update, one function per input count, kept
    // it out of line at opt-level "s" and paid a call and spills per sample.
    #[inline(always)]
    pub fn update(&mut self, temp_c: f32) -> RateEstimate {
        if self.absorbed == 0 {
            self.level_c = temp_c;
            self.slope_c = 0.0;
        } else {
            let predicted = self.level_c + self.slope_c;
            let residual = temp_c - predicted;
            self.level_c = predicted + self.filter.alpha * residual;
            self.slope_c += self.filter.beta * residual;
        }
        self.absorbed = self.absorbed.saturating_add(1);
        self.estimate()
    }

    /// Advances one period without a measurement (sensor fault or dropout): the level is
    /// extrapolated along the current slope and the slope is held.
    pub fn skip(&mut self) -> RateEstimate {
        if self.absorbed > 0 {
            self.level_c += self.slope_c;
        }
        self.estimate()
    }

    /// Good samples absorbed since start or the last reset (saturating).
    pub const fn absorbed(&self) -> u32 {
        self.absorbed
    }

    /// Forgets everything; the next sample starts a new warm-up.
    pub fn reset(&mut self) {
        *self = RateEstimator::new(self.filter);
    }

    /// The current estimate without absorbing a sample.
    pub fn estimate(&self) -> RateEstimate {
        RateEstimate {
            level_c: self.level_c,
            rate_c_per_s: self.slope_c / self.filter.dt_s,
            warming_up: self.absorbed < self.filter.warmup_samples,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TAU_S: f32 = 60.0;

    fn filter() -> RateFilter {
        RateFilter::from_tau_s(TAU_S, 1.0)
    }

    #[test]
    fn tracks_a_ramp_without_steady_state_error() {
        let mut est = RateEstimator::new(filter());
        let rate = 1.0 / 60.0; // 1 °C/min
        let mut last = est.update(10.0);
        for k in 1..2000 {
            last = est.update(10.0 + rate * k as f32);
        }
        let rel = (last.rate_c_per_s - rate).abs() / rate;
        assert!(rel < 1e-3, "relative slope error {rel}");
        assert!(!last.warming_up);
    }

    #[test]
    fn slope_step_settles_within_one_percent_after_6_6_tau() {
        let mut est = RateEstimator::new(filter());
        let rate = 1.0 / 60.0;
        // Hold, then start a ramp at k = 0: the error after k samples is predicted as
        // (1 + k/τ)e^(−k/τ) of the step.
        for _ in 0..1000 {
            est.update(20.0);
        }
        let settle = (6.64 * TAU_S) as usize;
        let mut e = est.estimate();
        for k in 1..=settle {
            e = est.update(20.0 + rate * k as f32);
        }
        let err = (e.rate_c_per_s - rate).abs() / rate;
        assert!(err < 0.0101, "error after 6.6 τ: {err}");
        // and not much better than the prediction (the formula is the real law, not a loose bound)
        assert!(err > 0.005, "error after 6.6 τ: {err}");
    }

    /// White-noise gain against the closed form of the steady-state α-β tracker.
    #[test]
    fn noise_gain_matches_closed_form() {
        let f = filter();
        let (a, b) = (f64::from(f.alpha), f64::from(f.beta));
        let predicted = (2.0 * b * b / (a * (4.0 - 2.0 * a - b))).sqrt();
        assert!(
            (predicted - 1.08e-3).abs() < 0.01e-3,
            "documented gain {predicted}"
        );
        // Deterministic uniform noise from a 64-bit LCG (σ = 1/√12 per sample).
        let mut state: u64 = 0x2545_f491_4f6c_dd1d;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / ((1u64 << 24) as f32) - 0.5
        };
        let mut est = RateEstimator::new(f);
        for _ in 0..2000 {
            est.update(uniform());
        }
        let n = 400_000;
        let mut sum2 = 0.0f64;
        for _ in 0..n {
            let r = f64::from(est.update(uniform()).rate_c_per_s);
            sum2 += r * r;
        }
        let measured = (sum2 / n as f64).sqrt() * 12f64.sqrt();
        assert!(
            (measured / predicted - 1.0).abs() < 0.05,
            "{measured} vs {predicted}"
        );
    }

    #[test]
    fn quantised_constant_reading_decays_to_exactly_zero() {
        let mut est = RateEstimator::new(filter());
        // A ramp quantised to 0.01 °C, then a long constant reading.
        for k in 0..600 {
            est.update(libm::roundf((25.0 + k as f32 / 60.0) * 100.0) / 100.0);
        }
        for _ in 0..20_000 {
            est.update(35.0);
        }
        let e = est.estimate();
        assert!(
            e.rate_c_per_s.abs() < 1e-6,
            "rate on a constant reading {}",
            e.rate_c_per_s
        );
    }

    #[test]
    fn quantised_ramp_error_matches_budget() {
        let mut est = RateEstimator::new(filter());
        let rate = 1.0 / 60.0;
        let mut sum2 = 0.0f64;
        let mut n = 0;
        for k in 0..20_000 {
            let t = libm::roundf((10.0 + rate * k as f32) * 100.0) / 100.0;
            let e = est.update(t);
            if k > 1000 {
                sum2 += f64::from(e.rate_c_per_s - rate).powi(2);
                n += 1;
            }
        }
        let rms = (sum2 / f64::from(n)).sqrt();
        assert!(rms < 6.5e-6, "quantised ramp rms error {rms} °C/s");
    }

    #[test]
    fn skip_extrapolates_the_level_and_holds_the_slope() {
        let mut est = RateEstimator::new(filter());
        for k in 0..2000 {
            est.update(k as f32 * 0.01);
        }
        let before = est.estimate();
        let after = est.skip();
        assert_eq!(after.rate_c_per_s, before.rate_c_per_s);
        assert!((after.level_c - before.level_c - 0.01).abs() < 1e-4);
    }

    #[test]
    fn unstable_or_nonsense_filters_are_rejected() {
        assert!(filter().is_stable());
        assert!(!RateFilter::from_tau_s(f32::NAN, 1.0).is_stable());
        assert!(!RateFilter::from_tau_s(-5.0, 1.0).is_stable());
        assert!(!RateFilter::from_tau_s(60.0, 0.0).is_stable());
    }

    mod property {
        use super::super::*;
        use proptest::prelude::*;

        /// One step of a sequence: a reading, or a run of periods without one (long runs
        /// exercise the restart).
        #[derive(Clone, Debug)]
        enum Step {
            Read(f32),
            Skip(u32),
        }

        fn step() -> impl Strategy<Value = Step> {
            prop_oneof![
                8 => (-100.0f32..200.0).prop_map(Step::Read),
                1 => (1u32..60).prop_map(Step::Skip),
            ]
        }

        proptest! {
            /// For any sequence of plausible readings and missing periods, driven as the
            /// compensator drives it (a restart after 30 missing periods in a row), the
            /// estimate stays finite and bounded: the level within the readings' range widened
            /// by that range, the rate within range/dt (no input sequence makes it run away).
            #[test]
            fn estimator_is_stable_for_any_sequence(seq in proptest::collection::vec(step(), 1..2000)) {
                let f = RateFilter::from_tau_s(60.0, 1.0);
                let mut est = RateEstimator::new(f);
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                let mut skipped = 0;
                let mut estimates = Vec::new();
                for s in &seq {
                    match s {
                        Step::Read(t) => {
                            lo = lo.min(*t);
                            hi = hi.max(*t);
                            skipped = 0;
                            estimates.push(est.update(*t));
                        }
                        Step::Skip(n) => {
                            for _ in 0..*n {
                                skipped += 1;
                                if skipped >= 30 {
                                    est.reset();
                                } else {
                                    let e = est.skip();
                                    // Before any reading since a (re)start the estimate is
                                    // the placeholder 0, flagged warming up: no claim there.
                                    if est.absorbed() > 0 {
                                        estimates.push(e);
                                    }
                                }
                            }
                        }
                    }
                }
                for e in estimates {
                    prop_assert!(e.level_c.is_finite() && e.rate_c_per_s.is_finite(), "{e:?}");
                    if lo <= hi {
                        let range = (hi - lo).max(1.0);
                        prop_assert!(e.rate_c_per_s.abs() <= range / f.dt_s, "{e:?} range {range}");
                        prop_assert!(e.level_c >= lo - range && e.level_c <= hi + range, "{e:?}");
                    }
                }
            }
        }
    }
}
