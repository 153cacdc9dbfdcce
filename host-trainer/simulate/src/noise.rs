//! Stochastic gyro noise: angle random walk, bias instability (a bank of first-order
//! Gauss–Markov processes), rate random walk and angle quantisation. Seeded ChaCha8 and
//! sequential, so the same parameters and seed give the same series on every machine.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use rlg_eval::metrics::allan::FLICKER_FLOOR;

/// Noise parameters (all 0: noiseless).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseParams {
    /// Angle random walk N, °/√h: white rate noise with σ(τ) = N/√τ_h.
    #[serde(default)]
    pub arw_dph_rt_h: f64,
    /// Bias instability B, °/h: the Allan floor of the Gauss–Markov bank is 0.664·B.
    #[serde(default)]
    pub bias_instability_dph: f64,
    /// Shortest Gauss–Markov correlation time, s (default 100).
    #[serde(default)]
    pub bi_tau_min_s: Option<f64>,
    /// Longest Gauss–Markov correlation time, s (default 10 000).
    #[serde(default)]
    pub bi_tau_max_s: Option<f64>,
    /// Rate random walk K, °/h/√h: σ(τ) = K·√(τ_h/3).
    #[serde(default)]
    pub rrw_dph_per_rt_h: f64,
    /// Angle quantum, arcsec (one readout count); 0: none.
    #[serde(default)]
    pub angle_quantum_arcsec: f64,
}

/// Gauss–Markov processes per decade of correlation time: three keeps the Allan floor within
/// 12 % of its peak from 3·τ_min to τ_max (see the simulator tests).
const GM_PER_DECADE: f64 = 3.0;

impl NoiseParams {
    /// Checks that all values are finite and ≥ 0 and the Gauss–Markov span is ordered.
    pub fn validate(&self) -> Result<(), String> {
        let (lo, hi) = self.bi_span_s();
        let vals = [
            self.arw_dph_rt_h,
            self.bias_instability_dph,
            self.rrw_dph_per_rt_h,
            self.angle_quantum_arcsec,
        ];
        if vals.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(format!("noise parameters must be finite and ≥ 0: {self:?}"));
        }
        if !(lo > 0.0 && hi >= lo && hi.is_finite()) {
            return Err(format!(
                "need 0 < bi_tau_min_s ≤ bi_tau_max_s, got {lo}, {hi}"
            ));
        }
        Ok(())
    }

    /// Gauss–Markov correlation-time span, s.
    pub fn bi_span_s(&self) -> (f64, f64) {
        (
            self.bi_tau_min_s.unwrap_or(100.0),
            self.bi_tau_max_s.unwrap_or(10_000.0),
        )
    }

    /// Correlation times (s, log-spaced) and the common σ (°/h) of the Gauss–Markov bank,
    /// σ chosen so that the bank's analytic Allan deviation peaks at 0.664·B.
    pub fn gauss_markov_bank(&self) -> (Vec<f64>, f64) {
        let (lo, hi) = self.bi_span_s();
        let n = ((hi / lo).log10() * GM_PER_DECADE).round() as usize + 1;
        let taus: Vec<f64> = (0..n)
            .map(|k| {
                if n == 1 {
                    lo
                } else {
                    lo * (hi / lo).powf(k as f64 / (n - 1) as f64)
                }
            })
            .collect();
        let peak = bank_peak_adev(&taus, lo, hi);
        let sigma = if peak > 0.0 {
            FLICKER_FLOOR * self.bias_instability_dph / peak
        } else {
            0.0
        };
        (taus, sigma)
    }
}

/// The peak Allan deviation of a bank of unit-σ Gauss–Markov processes of correlation times
/// `taus`, searched on a log grid of 401 cluster times over 0.1·`lo` … 10·`hi` (the bank's
/// span): the σ that puts a bank's peak at 0.664·B is 0.664·B over this.
pub fn bank_peak_adev(taus: &[f64], lo: f64, hi: f64) -> f64 {
    (0..=400)
        .map(|i| 0.1 * lo * (100.0 * hi / lo).powf(f64::from(i) / 400.0))
        .map(|tau| {
            taus.iter()
                .map(|&t| gauss_markov_avar(1.0, t, tau))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max)
}

/// Allan variance at τ of a first-order Gauss–Markov process of steady-state σ and
/// correlation time T (IEEE Std 952 C.1): (2σ²T/τ)·[1 − (T/2τ)(3 − 4e^{−τ/T} + e^{−2τ/T})].
pub fn gauss_markov_avar(sigma: f64, corr_s: f64, tau_s: f64) -> f64 {
    let x = tau_s / corr_s;
    let bracket = if x < 1e-3 {
        // Series of the bracket, x²/3 − x³/4…, avoids cancellation at small τ.
        x * x / 3.0 - x * x * x / 4.0
    } else {
        1.0 - (3.0 - 4.0 * (-x).exp() + (-2.0 * x).exp()) / (2.0 * x)
    };
    2.0 * sigma * sigma / x * bracket
}

/// Running noise generator.
#[derive(Clone, Debug)]
pub struct NoiseGen {
    rng: ChaCha8Rng,
    white_per_rt_s: f64,
    gm_tau_s: Vec<f64>,
    gm_state: Vec<f64>,
    gm_sigma: f64,
    rrw_per_rt_s: f64,
    rrw_state: f64,
    quantum_arcsec: f64,
    angle_arcsec: f64,
    counted_arcsec: f64,
}

impl NoiseGen {
    /// A generator seeded with `seed`; the Gauss–Markov states start in steady state.
    pub fn new(p: &NoiseParams, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (taus, gm_sigma) = p.gauss_markov_bank();
        let gm_state = taus.iter().map(|_| gm_sigma * normal(&mut rng)).collect();
        Self {
            rng,
            // N °/√h = N·60 °/h·√s: white σ at period dt is N·60/√dt.
            white_per_rt_s: p.arw_dph_rt_h * 60.0,
            gm_tau_s: taus,
            gm_state,
            gm_sigma,
            // K °/h/√h: increment σ over dt is K·√(dt/3600).
            rrw_per_rt_s: p.rrw_dph_per_rt_h / 60.0,
            rrw_state: 0.0,
            quantum_arcsec: p.angle_quantum_arcsec,
            angle_arcsec: 0.0,
            counted_arcsec: 0.0,
        }
    }

    /// Noise to add to the rate over the next interval `dt_s`, °/h; `scale` multiplies the
    /// white part (heteroscedastic terms).
    pub fn step(&mut self, dt_s: f64, scale: f64) -> f64 {
        let mut v = 0.0;
        if self.white_per_rt_s > 0.0 && dt_s > 0.0 {
            v += scale * self.white_per_rt_s / dt_s.sqrt() * normal(&mut self.rng);
        }
        if self.gm_sigma > 0.0 {
            for (tau, x) in self.gm_tau_s.iter().zip(&mut self.gm_state) {
                // Exact discretisation: x ← a·x + σ·√(1 − a²)·z, a = exp(−dt/T).
                let a = (-dt_s / tau).exp();
                *x = a * *x + self.gm_sigma * (1.0 - a * a).sqrt() * normal(&mut self.rng);
                v += *x;
            }
        }
        if self.rrw_per_rt_s > 0.0 {
            self.rrw_state += self.rrw_per_rt_s * dt_s.sqrt() * normal(&mut self.rng);
            v += self.rrw_state;
        }
        v
    }

    /// Applies angle quantisation to a total rate over `dt_s`: accumulates the angle (°/h·s
    /// is arcsec), floors it to the quantum and returns the counted angle's difference as a
    /// rate, °/h. Without a quantum the rate passes through.
    pub fn quantise(&mut self, rate_dph: f64, dt_s: f64) -> f64 {
        if self.quantum_arcsec <= 0.0 || dt_s <= 0.0 {
            return rate_dph;
        }
        self.angle_arcsec += rate_dph * dt_s;
        let counted = (self.angle_arcsec / self.quantum_arcsec).floor() * self.quantum_arcsec;
        let out = (counted - self.counted_arcsec) / dt_s;
        self.counted_arcsec = counted;
        out
    }
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    <StandardNormal as Distribution<f64>>::sample(&StandardNormal, rng)
}
