//! Recursive input features beyond T and dT/dt, O(1) state each, identical on host and board.
//!
//! All run at the table's sample period dt (the rate filter's `dt_s`) on top of the shared
//! dT/dt estimator ([`crate::rate`]); `r` below is its estimate.
//!
//! * [`Feature::TempLeadC`] τ: T + τ·r. No state of its own; on a ramp of slope s, once the
//!   estimator has settled, it is exactly T + τ·s.
//! * [`Feature::TempGradLagCPerS`] τ: τ·dG/dt = −G + r, discretised exactly for an input held
//!   over each period (zero-order hold): G ← G + (1 − e^(−dt/τ))·(r − G), G₀ = 0. For r held at
//!   s from k = 0 this gives G_k = s·(1 − e^(−k·dt/τ)) at every step, the continuous
//!   solution sampled.
//! * [`Feature::TempPlayC`] w: the play (backlash) operator of half-width h = w/2,
//!   y ← max(T − h, min(T + h, y)), y₀ = T₀: the output follows T only after T has moved h past
//!   it in one direction.
//! * [`Feature::TimeOnS`]: k·dt after k periods since the first sample (skipped samples count:
//!   time passes), saturating.
//! * [`Feature::WarmupDecay`] τ: w ← w·e^(−dt/τ) per period, w = 1 at the first sample, so
//!   w_k = e^(−k·dt/τ) (to f32 rounding per step); skipped periods decay it too, restarts of
//!   the estimator do not reset it (power-on does).
//!
//! A rejected temperature sample ([`FeatureBank::skip`]) advances time and the lag with the
//! held estimate and leaves the play state; a restart of the estimator ([`FeatureBank::reset`])
//! clears lag and play but not the time since power-on.

use crate::physics::{decay, lead, play, FirstOrderLag};
use crate::rate::RateEstimate;
use crate::table::Feature;

/// Per-feature recursive state.
#[derive(Clone, Copy, Debug, PartialEq)]
enum State {
    None,
    Lag { keep: f32, lag: FirstOrderLag<f32> },
    Play { half_c: f32, y: Option<f32> },
    Decay { keep: f32, w: f32 },
}

/// The recursive state of every feature of a table.
#[derive(Clone, Debug, PartialEq)]
pub struct FeatureBank<const D: usize> {
    features: [Feature; D],
    states: [State; D],
    dt_s: f32,
    periods: u32,
}

impl<const D: usize> FeatureBank<D> {
    /// State for `features` at sample period `dt_s`.
    pub fn new(features: [Feature; D], dt_s: f32) -> Self {
        let states = features.map(|f| match f {
            Feature::TempGradLagCPerS { tau_s } => State::Lag {
                // 1 − e^(−dt/τ) is the gain; keep = e^(−dt/τ). τ = 0 (rejected by parse)
                // would give keep = 0, i.e. no lag, rather than a NaN.
                keep: decay(dt_s, tau_s as f32),
                lag: FirstOrderLag::new(0.0),
            },
            Feature::TempPlayC { width_mc } => State::Play {
                half_c: width_mc as f32 * 0.0005,
                y: None,
            },
            Feature::WarmupDecay { tau_s } => State::Decay {
                // τ = 0 is rejected by parse; it would give keep = 0 (an instant decay).
                keep: decay(dt_s, tau_s as f32),
                w: 1.0,
            },
            _ => State::None,
        });
        FeatureBank {
            features,
            states,
            dt_s,
            periods: 0,
        }
    }

    /// Absorbs one accepted temperature with the estimator's estimate after it, and returns
    /// the feature vector.
    // Inlined into the 1 Hz update: the C library's update, one function per input count, kept
    // it out of line at opt-level "s" and paid a call and spills per sample.
    #[inline(always)]
    pub fn update(&mut self, temp_c: f32, est: &RateEstimate) -> [f32; D] {
        let r = est.rate_c_per_s;
        for st in &mut self.states {
            match st {
                State::None | State::Decay { .. } => {}
                State::Lag { keep, lag } => {
                    lag.step_held(r, *keep);
                }
                State::Play { half_c, y } => *y = Some(play(y.unwrap_or(temp_c), temp_c, *half_c)),
            }
        }
        let x = self.values(temp_c, est);
        self.advance();
        x
    }

    /// One period passes: time on and the warm-up decay advance.
    #[inline(always)]
    fn advance(&mut self) {
        for st in &mut self.states {
            if let State::Decay { keep, w } = st {
                *w *= *keep;
            }
        }
        self.periods = self.periods.saturating_add(1);
    }

    /// One period without an accepted temperature: time passes, the lag follows the held
    /// estimate, the play state holds.
    pub fn skip(&mut self, est: &RateEstimate) {
        for st in &mut self.states {
            if let State::Lag { keep, lag } = st {
                lag.step_held(est.rate_c_per_s, *keep);
            }
        }
        self.advance();
    }

    /// Clears the lag and play states (after an estimator restart); time keeps running.
    pub fn reset(&mut self) {
        for st in &mut self.states {
            match st {
                State::None | State::Decay { .. } => {}
                State::Lag { lag, .. } => *lag = FirstOrderLag::new(0.0),
                State::Play { y, .. } => *y = None,
            }
        }
    }

    /// The feature vector for the current state, at temperature `temp_c` and estimate `est`
    /// (time since power-on is that of the sample being processed).
    pub fn values(&self, temp_c: f32, est: &RateEstimate) -> [f32; D] {
        // `get`, not indexing: no bounds check even where this is not inlined (the C library
        // holds five input counts); inlined, the `None` arm vanishes.
        core::array::from_fn(|d| match (self.features.get(d), self.states.get(d)) {
            (Some(f), Some(st)) => self.value(*f, *st, temp_c, est),
            _ => temp_c,
        })
    }

    /// One feature's value (see [`FeatureBank::values`]).
    #[inline(always)]
    fn value(&self, f: Feature, st: State, temp_c: f32, est: &RateEstimate) -> f32 {
        match (f, st) {
            (Feature::TempC, _) => temp_c,
            (Feature::TempRateCPerS, _) => est.rate_c_per_s,
            (Feature::TempLeadC { tau_s }, _) => lead(temp_c, tau_s as f32, est.rate_c_per_s),
            (_, State::Lag { lag, .. }) => lag.y,
            (_, State::Play { y, .. }) => y.unwrap_or(temp_c),
            (_, State::Decay { w, .. }) => w,
            (Feature::TimeOnS, _) => self.periods as f32 * self.dt_s,
            // A future feature this build does not compute: T, so the output stays finite.
            _ => temp_c,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn est(rate: f32) -> RateEstimate {
        RateEstimate {
            level_c: 0.0,
            rate_c_per_s: rate,
            warming_up: false,
        }
    }

    #[test]
    fn lag_follows_the_sampled_continuous_solution() {
        let tau = 300u32;
        let mut b = FeatureBank::new([Feature::TempGradLagCPerS { tau_s: tau }], 1.0);
        let s = 0.01f32;
        for k in 1..=3000u32 {
            let g = b.update(20.0, &est(s))[0];
            let want = f64::from(s) * (1.0 - (-f64::from(k) / f64::from(tau)).exp());
            assert!((f64::from(g) - want).abs() < 1e-7, "k={k}: {g} vs {want}");
        }
    }

    #[test]
    fn lead_is_t_plus_tau_times_rate() {
        let mut b = FeatureBank::new([Feature::TempLeadC { tau_s: 120 }], 1.0);
        let x = b.update(30.0, &est(0.02));
        assert_eq!(x[0], 30.0 + 120.0 * 0.02);
    }

    /// Triangle wave of amplitude A through a play operator of half-width h: after the first
    /// turn the output is a triangle of amplitude A − h lagging by h on each flank (closed form
    /// y = x − h rising, y = x + h falling, flat for 2h after each turn).
    #[test]
    fn play_operator_matches_the_triangle_wave_closed_form() {
        let w_mc = 400u32; // h = 0.2 °C
        let h = 0.2f64;
        let mut b = FeatureBank::new([Feature::TempPlayC { width_mc: w_mc }], 1.0);
        let (amp, period) = (2.0f64, 400usize);
        let tri = |k: usize| {
            let p = (k % period) as f64 / period as f64;
            if p < 0.5 {
                -amp + 4.0 * amp * p
            } else {
                3.0 * amp - 4.0 * amp * p
            }
        };
        let mut y_prev = tri(0);
        for k in 0..4 * period {
            let x = tri(k);
            let y = f64::from(b.update(x as f32, &est(0.0))[0]);
            // Independent closed form of one step of the operator in f64.
            let want = if k == 0 {
                x
            } else {
                (x - h).max((x + h).min(y_prev))
            };
            assert!((y - want).abs() < 1e-5, "k={k}: {y} vs {want}");
            if k > period {
                // Always within h of the input, and at the flanks' middle exactly x ∓ h.
                assert!((y - x).abs() <= h + 1e-5);
                if k % period == period / 4 {
                    assert!((y - (x - h)).abs() < 1e-5, "rising flank");
                }
                if k % period == 3 * period / 4 {
                    assert!((y - (x + h)).abs() < 1e-5, "falling flank");
                }
            }
            y_prev = want;
        }
    }

    #[test]
    fn time_counts_every_period_including_skipped() {
        let mut b = FeatureBank::new([Feature::TimeOnS], 1.0);
        assert_eq!(b.update(20.0, &est(0.0))[0], 0.0);
        b.skip(&est(0.0));
        b.reset();
        assert_eq!(b.update(20.0, &est(0.0))[0], 2.0);
    }

    /// e^(−k·dt/τ) sampled, through skipped periods and an estimator restart, to f32 rounding
    /// accumulated over the steps (k·2⁻²⁴ relative at most).
    #[test]
    fn warmup_decay_follows_the_exponential() {
        let tau = 900u32;
        let mut b = FeatureBank::new([Feature::WarmupDecay { tau_s: tau }], 1.0);
        for k in 0..6000u32 {
            let w = if k % 1000 == 500 {
                b.skip(&est(0.0));
                b.reset(); // an estimator restart leaves the warm-up state alone
                continue;
            } else {
                b.update(20.0, &est(0.0))[0]
            };
            let want = (-f64::from(k) / f64::from(tau)).exp();
            let tol = want * (f64::from(k) + 2.0) * 6e-8 + 1e-30;
            assert!((f64::from(w) - want).abs() <= tol, "k={k}: {w} vs {want}");
        }
    }

    #[test]
    fn names_round_trip() {
        for f in [
            Feature::TempC,
            Feature::TempRateCPerS,
            Feature::TempLeadC { tau_s: 600 },
            Feature::TempGradLagCPerS { tau_s: 45 },
            Feature::TempPlayC { width_mc: 150 },
            Feature::TimeOnS,
            Feature::WarmupDecay { tau_s: 1800 },
        ] {
            let s = f.to_string();
            assert_eq!(Feature::parse(&s), Some(f), "{s}");
        }
        assert_eq!(Feature::parse("temp_lead_c"), None);
        assert_eq!(Feature::parse("temp_grad_lag_c_per_s(tau_s=0)"), None);
        assert_eq!(Feature::parse("warmup_decay(tau_s=0)"), None);
        assert_eq!(Feature::parse("temp_c(tau_s=3)"), None);
    }
}
