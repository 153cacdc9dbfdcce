//! The recursive physics primitives, one definition each, generic over the float type: f32
//! on the board (the [`crate::features`] of a table), f64 on the host (the simulator's terms,
//! the diagnosis' candidates). A test holds the two instances together on a long random input.
//!
//! * [`FirstOrderLag`]: τ·dy/dt = u − y, with its two exact discretisations: the first-order
//!   hold ([`FirstOrderLag::step`], exact for an input linear between samples: the simulator's
//!   physics) and the zero-order hold ([`FirstOrderLag::step_held`], exact for an input held
//!   over the period: the board's lagged dT/dt estimate).
//! * [`play`]: the play (backlash) operator, p ← max(T − h, min(T + h, p)).
//! * [`lead`]: the sensor-lag inversion T_c = T_s + τ·dT_s/dt (first order).
//! * [`decay`]: the warm-up decay e^(−t/τ); the board runs it recursively, w ← w·[`decay`](dt).

use core::ops::{Add, Div, Mul, Neg, Sub};

/// The float arithmetic the primitives need.
pub trait Real:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// e^x.
    fn exp(self) -> Self;
}

impl Real for f32 {
    const ZERO: f32 = 0.0;
    const ONE: f32 = 1.0;
    /// `libm::expf`: the same bits on the board and on the host.
    fn exp(self) -> f32 {
        libm::expf(self)
    }
}

impl Real for f64 {
    const ZERO: f64 = 0.0;
    const ONE: f64 = 1.0;
    /// With `std` (the host crates), the platform's `exp`, which the simulator's recordings
    /// and the diagnosis' verdicts were made with; without it, `libm::exp`.
    fn exp(self) -> f64 {
        #[cfg(any(test, feature = "std"))]
        {
            f64::exp(self)
        }
        #[cfg(not(any(test, feature = "std")))]
        {
            libm::exp(self)
        }
    }
}

/// e^(−t/τ): the share of a first-order transient left after `t_s` (t, τ in one unit, τ > 0).
#[inline]
pub fn decay<T: Real>(t_s: T, tau_s: T) -> T {
    (-t_s / tau_s).exp()
}

/// The sensor-lag inversion: the body temperature T_s + τ·dT_s/dt read from a sensor that lags
/// it by τ (°C, s, °C/s).
#[inline]
pub fn lead<T: Real>(temp_c: T, tau_s: T, rate_c_per_s: T) -> T {
    temp_c + tau_s * rate_c_per_s
}

/// One step of the play operator of half-width `half` (≥ 0) at input `x` from state `prev`:
/// `prev` clamped to [x − half, x + half], so the output follows the input only when one of
/// the two edges pushes it. A NaN input keeps the state.
#[inline]
pub fn play<T: Real>(prev: T, x: T, half: T) -> T {
    let up = x - half;
    let down = x + half;
    if prev < up {
        up
    } else if prev > down {
        down
    } else {
        prev
    }
}

/// State of one first-order lag τ·dy/dt = u − y (τ is the caller's: the state is all the board
/// stores per lag).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstOrderLag<T> {
    /// Output, in the unit of the input.
    pub y: T,
    /// Previous input (for the first-order hold).
    u_prev: T,
}

impl<T: Real> FirstOrderLag<T> {
    /// A lag at rest at `y0` (output and input both `y0`).
    pub fn new(y0: T) -> Self {
        Self { y: y0, u_prev: y0 }
    }

    /// Advances by `dt_s` with the input moving linearly to `u` (first-order hold), time
    /// constant `tau_s`; returns the new output.
    ///
    /// With a = e^(−dt/τ): y₁ = a·y₀ + (1 − a)·u₀ + (u₁ − u₀)·(1 − τ·(1 − a)/dt), the exact
    /// solution for a linearly varying input, so a ramp is followed with a lag of exactly
    /// τ·rate. τ ≤ 0 or dt ≤ 0 gives y = u.
    pub fn step(&mut self, u: T, dt_s: T, tau_s: T) -> T {
        if tau_s <= T::ZERO || dt_s <= T::ZERO {
            self.y = u;
        } else {
            let a = decay(dt_s, tau_s);
            let ramp = T::ONE - tau_s * (T::ONE - a) / dt_s;
            self.y = a * self.y + (T::ONE - a) * self.u_prev + (u - self.u_prev) * ramp;
        }
        self.u_prev = u;
        self.y
    }

    /// Advances one period with the input held at `u` over it (zero-order hold), `keep` =
    /// [`decay`]`(dt, τ)`: y ← u + keep·(y − u). For u held at s from rest at 0 this gives
    /// y_k = s·(1 − e^(−k·dt/τ)), the continuous solution sampled.
    #[inline]
    pub fn step_held(&mut self, u: T, keep: T) -> T {
        self.y = u + keep * (self.y - u);
        self.u_prev = u;
        self.y
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::RngExt;
    use proptest::test_runner::{RngAlgorithm, TestRng};

    /// A reproducible uniform stream in [0, 1).
    struct Uniform(TestRng);
    impl Uniform {
        fn new() -> Self {
            Uniform(TestRng::deterministic_rng(RngAlgorithm::ChaCha))
        }
        fn next(&mut self) -> f64 {
            self.0.random()
        }
    }

    /// A long random chamber history at 1 Hz between −40 and +70 °C (°C): ramps of random
    /// slope up to ±3 °C/min that turn at the limits, holds, and reading noise; and its slope
    /// (°C/s).
    fn random_input(n: usize) -> (Vec<f64>, Vec<f64>) {
        let mut u = Uniform::new();
        let (mut temp, mut slope) = (20.0, 0.0);
        let mut t = Vec::with_capacity(n);
        let mut r = Vec::with_capacity(n);
        for _ in 0..n {
            if u.next() < 0.002 {
                slope = if u.next() < 0.3 {
                    0.0
                } else {
                    (u.next() - 0.5) * 0.1
                };
            }
            if (temp > 70.0 && slope > 0.0) || (temp < -40.0 && slope < 0.0) {
                slope = -slope;
            }
            temp += slope + (u.next() - 0.5) * 0.02;
            t.push(temp);
            r.push(slope);
        }
        (t, r)
    }

    /// |f32 − f64| budgets over 200 000 random samples, with ε = `f32::EPSILON`, X = max|T|
    /// (°C), R = max|dT/dt| (°C/s), dt = 1 s. Measured (X 70, R 0.05; τ 1 / 30 / 600 / 5 000 s):
    /// * first-order hold: ≤ ε·X·(4 + τ/dt); measured 1.4e-5 / 6.5e-5 / 2.0e-4 / 2.2e-3 °C. Its
    ///   ramp term 1 − τ·(1 − a)/dt cancels as τ/dt grows, so it is the f64 form (the
    ///   simulator's); the board's lag is the zero-order hold.
    /// * zero-order hold (the board's lag of dT/dt): ≤ ε·R·(4 + τ/dt); measured 4.3e-9 / 6.5e-8 /
    ///   2.9e-7 / 3.4e-7 °C/s.
    /// * lead: ≤ 2ε·(X + τ·R); measured 7.3e-6 / 7.6e-6 / 9.3e-6 / 3.2e-5 °C.
    /// * play: ≤ ε·X (it only selects among x ± h and its state); measured ≤ 3.8e-6 °C.
    fn budgets(x: f64, r: f64, tau: f64) -> [f64; 4] {
        let eps = f64::from(f32::EPSILON);
        [
            eps * x * (4.0 + tau),
            eps * r * (4.0 + tau),
            2.0 * eps * (x + tau * r),
            eps * x,
        ]
    }

    /// The f32 (board) and f64 (host) instances of each primitive agree on a long random
    /// input, the f32 one fed the f32-rounded input, within [`budgets`].
    #[test]
    fn f32_and_f64_instances_agree() {
        let (temp, rate) = random_input(200_000);
        let x_max = temp.iter().fold(0.0f64, |m, t| m.max(t.abs()));
        let r_max = rate.iter().fold(0.0f64, |m, t| m.max(t.abs()));
        for tau in [1.0f64, 30.0, 600.0, 5000.0] {
            let mut l64 = FirstOrderLag::new(temp[0]);
            let mut l32 = FirstOrderLag::new(temp[0] as f32);
            let mut h64 = FirstOrderLag::new(0.0);
            let mut h32 = FirstOrderLag::new(0.0f32);
            let (k64, k32) = (decay(1.0, tau), decay(1.0f32, tau as f32));
            let (mut p64, mut p32) = (temp[0], temp[0] as f32);
            let half = 0.5 * tau.sqrt();
            let mut worst = [0.0f64; 4];
            for (&x, &r) in temp.iter().zip(&rate) {
                let (x32, r32) = (x as f32, r as f32);
                p64 = play(p64, f64::from(x32), half);
                p32 = play(p32, x32, half as f32);
                let d = [
                    l64.step(x, 1.0, tau) - f64::from(l32.step(x32, 1.0, tau as f32)),
                    h64.step_held(r, k64) - f64::from(h32.step_held(r32, k32)),
                    lead(x, tau, r) - f64::from(lead(x32, tau as f32, r32)),
                    p64 - f64::from(p32),
                ];
                for (w, v) in worst.iter_mut().zip(d) {
                    *w = w.max(v.abs());
                }
            }
            let names = ["first-order hold", "zero-order hold", "lead", "play"];
            for ((w, b), name) in worst.iter().zip(budgets(x_max, r_max, tau)).zip(names) {
                assert!(*w <= b, "{name}, τ {tau} s: {w:e} > {b:e}");
            }
        }
        // The board's recursive decay (w ← w·keep) against the closed form: its f32 rounding
        // accumulates as k·ε (measured 6.0e-7 / 3.2e-5 / 3.5e-5 relative after 2 000 periods
        // at τ 60 / 600 / 3 600 s; bound (k + 1)·ε).
        for tau in [60.0f64, 600.0, 3600.0] {
            let keep = decay(1.0f32, tau as f32);
            let mut w = 1.0f32;
            for k in 0..2000 {
                let exact = decay(f64::from(k), tau);
                let bound = (f64::from(k) + 1.0) * f64::from(f32::EPSILON) * exact;
                assert!((f64::from(w) - exact).abs() <= bound, "τ {tau} k {k}");
                w *= keep;
            }
        }
    }

    /// The play operator is max(x − h, min(x + h, p)) (the host's former form) on every
    /// ordering of its inputs, and keeps its state on a NaN input.
    #[test]
    fn play_is_the_clamp() {
        let mut u = Uniform::new();
        for _ in 0..100_000 {
            let (p, x, h) = (u.next() * 10.0 - 5.0, u.next() * 10.0 - 5.0, u.next() * 3.0);
            assert_eq!(play(p, x, h), (x - h).max((x + h).min(p)));
        }
        assert_eq!(play(1.5, f64::NAN, 0.5), 1.5);
    }

    /// On a ramp of rate r the settled lag output is u − τ·r (closed form).
    #[test]
    fn ramp_lags_by_tau_times_rate() {
        let (tau, r, dt): (f64, f64, f64) = (120.0, 0.05, 1.0);
        let mut lag = FirstOrderLag::new(0.0);
        let mut u = 0.0;
        for _ in 0..5000 {
            u += r * dt;
            lag.step(u, dt, tau);
        }
        assert!((u - lag.y - tau * r).abs() < 1e-9, "{}", u - lag.y);
    }

    /// A step settles as 1 − exp(−t/τ), exactly at the samples after the step sample.
    #[test]
    fn step_response_matches_exponential() {
        let tau = 10.0;
        let mut lag = FirstOrderLag::new(0.0);
        lag.step(0.0, 1.0, tau);
        // Hold the input at 1 from t = 1 s; the first step sees a linear ramp 0→1.
        let y1 = lag.step(1.0, 1.0, tau);
        let expect1 = 1.0 - tau * (1.0 - (-0.1f64).exp());
        assert!((y1 - expect1).abs() < 1e-12);
        for k in 2..50 {
            let y = lag.step(1.0, 1.0, tau);
            let e = 1.0 - (1.0 - expect1) * (-((k - 1) as f64) / tau).exp();
            assert!((y - e).abs() < 1e-12);
        }
    }

    /// The zero-order hold from rest samples the continuous step response exactly.
    #[test]
    fn held_step_samples_the_continuous_response() {
        let (tau, s): (f64, f64) = (50.0, 0.02);
        let keep = decay(1.0, tau);
        let mut lag = FirstOrderLag::new(0.0);
        for k in 1..400 {
            let y = lag.step_held(s, keep);
            assert!((y - s * (1.0 - (-(k as f64) / tau).exp())).abs() < 1e-15);
        }
    }
}
