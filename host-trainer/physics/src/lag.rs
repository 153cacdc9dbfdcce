//! First-order lag τ·dy/dt = u − y, discretised exactly for an input that is linear between
//! samples (first-order hold), so a ramp is followed with a lag of exactly τ·rate.

/// State of one first-order lag.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstOrderLag {
    /// Time constant, s (0: no lag, the output is the input).
    pub tau_s: f64,
    /// Output, in the unit of the input.
    pub y: f64,
    /// Previous input (for the first-order hold).
    u_prev: f64,
}

impl FirstOrderLag {
    /// A lag at rest at `y0` (output and input both `y0`).
    pub fn new(tau_s: f64, y0: f64) -> Self {
        Self {
            tau_s,
            y: y0,
            u_prev: y0,
        }
    }

    /// Advances by `dt_s` with the input moving linearly to `u`; returns the new output.
    ///
    /// With a = exp(−dt/τ): y₁ = a·y₀ + (1 − a)·u₀ + (u₁ − u₀)·(1 − τ·(1 − a)/dt), the exact
    /// solution for a linearly varying input.
    pub fn step(&mut self, u: f64, dt_s: f64) -> f64 {
        if self.tau_s <= 0.0 || dt_s <= 0.0 {
            self.y = u;
        } else {
            let a = (-dt_s / self.tau_s).exp();
            let ramp = 1.0 - self.tau_s * (1.0 - a) / dt_s;
            self.y = a * self.y + (1.0 - a) * self.u_prev + (u - self.u_prev) * ramp;
        }
        self.u_prev = u;
        self.y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a ramp of rate r the settled lag output is u − τ·r (closed form).
    #[test]
    fn ramp_lags_by_tau_times_rate() {
        let (tau, r, dt) = (120.0, 0.05, 1.0);
        let mut lag = FirstOrderLag::new(tau, 0.0);
        let mut u = 0.0;
        for _ in 0..5000 {
            u += r * dt;
            lag.step(u, dt);
        }
        assert!((u - lag.y - tau * r).abs() < 1e-9, "{}", u - lag.y);
    }

    /// A step settles as 1 − exp(−t/τ) — exactly at the samples after the step sample.
    #[test]
    fn step_response_matches_exponential() {
        let tau = 10.0;
        let mut lag = FirstOrderLag::new(tau, 0.0);
        lag.step(0.0, 1.0);
        // Hold the input at 1 from t = 1 s; the first step sees a linear ramp 0→1.
        let y1 = lag.step(1.0, 1.0);
        let expect1 = 1.0 - tau * (1.0 - (-0.1f64).exp());
        assert!((y1 - expect1).abs() < 1e-12);
        for k in 2..50 {
            let y = lag.step(1.0, 1.0);
            let e = 1.0 - (1.0 - expect1) * (-((k - 1) as f64) / tau).exp();
            assert!((y - e).abs() < 1e-12);
        }
    }
}
