//! The held-out scorer every train-and-score pipeline shares (this crate's calibrations, the
//! paper's reproduction, the close loop): a model's compensated output on held-out samples
//! becomes its bias stability over the window (never across a gap), the improvement over the
//! raw output, the residual by thermal phase and the Allan deviation with 1σ intervals.

use rlg_eval::metrics::allan::{octave_clusters, overlapping_adev_ci, AdevCi, CONFIDENCE_1SIGMA};
use rlg_eval::metrics::compare::improvement_factor;
use rlg_eval::metrics::stability::{bias_stability_gapless_dph, gapless_block_means};

use crate::phases;
use crate::result::HeldOutScore;

/// Held-out samples (their times and the board's dT/dt) and the raw output's stability, against
/// which each model's output on the same samples is scored.
#[derive(Clone, Debug)]
pub struct HeldOutScorer<'a> {
    time_s: &'a [f64],
    rate_c_per_s: &'a [f64],
    window: usize,
    raw_stability_dph: Option<f64>,
}

impl<'a> HeldOutScorer<'a> {
    /// The held-out samples at `time_s` with the board's dT/dt estimate `rate_c_per_s` there
    /// (for the phases; may be empty when only stabilities are asked for), the raw output
    /// `raw_dph` at them, and the stability window in samples.
    pub fn new(time_s: &'a [f64], rate_c_per_s: &'a [f64], raw_dph: &[f64], window: usize) -> Self {
        HeldOutScorer {
            time_s,
            rate_c_per_s,
            window,
            raw_stability_dph: bias_stability_gapless_dph(time_s, raw_dph, window),
        }
    }

    /// Bias stability of the raw output over the window, °/h (`None`: fewer than two
    /// gap-free windows).
    pub fn raw_stability_dph(&self) -> Option<f64> {
        self.raw_stability_dph
    }

    /// Bias stability of `output` over the window, °/h.
    pub fn stability_dph(&self, output: &[f64]) -> Option<f64> {
        bias_stability_gapless_dph(self.time_s, output, self.window)
    }

    /// Raw stability / `stability_dph`.
    pub fn improvement(&self, stability_dph: f64) -> Option<f64> {
        self.raw_stability_dph
            .and_then(|r| improvement_factor(r, stability_dph))
    }

    /// Every held-out figure of `output`.
    pub fn score(&self, output: &[f64]) -> HeldOutScore {
        let b = self.stability_dph(output).unwrap_or(f64::NAN);
        HeldOutScore {
            stability_dph: b,
            improvement: self.improvement(b),
            phases: phases::phase_rms(self.time_s, self.rate_c_per_s, output, self.window),
            allan: allan_of(output),
        }
    }

    /// Means of `v` over the stability's gap-free windows.
    pub fn window_means(&self, v: &[f64]) -> Vec<f64> {
        gapless_block_means(self.time_s, v, self.window)
    }

    /// Phase of each window: 0 heating, 1 cooling, 2 hold ([`phases::window_phases`]).
    pub fn window_phases(&self) -> Vec<usize> {
        phases::window_phases(self.time_s, self.rate_c_per_s, self.window)
    }
}

/// Allan deviation of a held-out output with 1σ intervals from the equivalent degrees of
/// freedom, noise type identified per τ as Stable32 does (the held-out span is one continuous
/// stretch of the stream; gaps are not bridged).
pub fn allan_of(v: &[f64]) -> Vec<AdevCi> {
    overlapping_adev_ci(v, 1.0, &octave_clusters(v.len()), CONFIDENCE_1SIGMA)
}
