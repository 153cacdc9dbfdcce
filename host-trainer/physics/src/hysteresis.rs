//! Path-dependent terms: the play (backlash) operator and a two-threshold relay.

use compensator_core::physics::play;

/// Play operator of width `width_c`: the output follows the input only when it is pushed by
/// one of the two edges, p = max(T − w/2, min(T + w/2, p_prev))
/// ([`compensator_core::physics::play`], the board's definition).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Play {
    /// Full width of the dead band, °C.
    pub width_c: f64,
    /// Operator output, °C.
    pub p: f64,
}

impl Play {
    /// Starts centred on `temp_c`.
    pub fn new(width_c: f64, temp_c: f64) -> Self {
        Self { width_c, p: temp_c }
    }

    /// Advances to `temp_c`; returns (T − p)/(w/2) ∈ [−1, 1] (+1 on a rising branch).
    pub fn step(&mut self, temp_c: f64) -> f64 {
        let half = 0.5 * self.width_c;
        self.p = play(self.p, temp_c, half);
        if half > 0.0 {
            (temp_c - self.p) / half
        } else {
            0.0
        }
    }
}

/// Relay: switches on when the input rises above `on_c`, off when it falls below `off_c`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Relay {
    /// Upper threshold, °C.
    pub on_c: f64,
    /// Lower threshold, °C (≤ `on_c`).
    pub off_c: f64,
    /// Current state.
    pub on: bool,
}

impl Relay {
    /// Starts in the state the input implies (on only above `on_c`).
    pub fn new(on_c: f64, off_c: f64, temp_c: f64) -> Self {
        Self {
            on_c,
            off_c,
            on: temp_c > on_c,
        }
    }

    /// Advances to `temp_c`; returns the state.
    pub fn step(&mut self, temp_c: f64) -> bool {
        if temp_c > self.on_c {
            self.on = true;
        } else if temp_c < self.off_c {
            self.on = false;
        }
        self.on
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// After a full sweep, the rising and falling branches at the same temperature give +1
    /// and −1: a bias h·(T − p)/(w/2) differs by 2h between them.
    #[test]
    fn play_branches_differ_by_two() {
        let mut p = Play::new(4.0, 0.0);
        let mut up = None;
        for i in 0..=400 {
            let t = -20.0 + 0.1 * i as f64;
            let v = p.step(t);
            if (t - 5.0).abs() < 1e-9 {
                up = Some(v);
            }
        }
        let mut down = None;
        for i in 0..=400 {
            let t = 20.0 - 0.1 * i as f64;
            let v = p.step(t);
            if (t - 5.0).abs() < 1e-9 {
                down = Some(v);
            }
        }
        assert!((up.unwrap() - 1.0).abs() < 1e-12 && (down.unwrap() + 1.0).abs() < 1e-12);
        // Inside the band after a reversal the output is linear in T with slope 1/(w/2).
        let v0 = p.step(-20.0);
        let v1 = p.step(-19.0);
        assert!((v1 - v0 - 0.5).abs() < 1e-12);
    }

    #[test]
    fn relay_switches_at_the_two_thresholds() {
        let mut r = Relay::new(30.0, 28.0, 20.0);
        assert!(!r.on);
        assert!(!r.step(30.0));
        assert!(r.step(30.01));
        assert!(r.step(28.5));
        assert!(r.step(28.0));
        assert!(!r.step(27.99));
        assert!(!r.step(29.9));
    }
}
