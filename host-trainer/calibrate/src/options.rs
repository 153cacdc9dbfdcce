//! The options of a calibration and the limits of what it writes.

use rlg_eval::baselines::StepwiseOptions;
use rlg_train::lssvm::tune::Grid;
use rlg_train::model::Removal;
use rlg_train::protocol::{RATE_TAU_S, SUPPORT_VECTORS};

use crate::error::{ensure, CalibrateError};

/// Largest board table this tool writes, support vectors: at D = 2 a vector costs 12 bytes of
/// flash (two f32 coordinates and a coefficient), so 512 vectors are 6 KiB of the 32 KiB
/// flash budget and about 30 ms of a 1 Hz update on the Cortex-M4F.
pub const MAX_BUDGET: usize = 512;

/// Largest training set the exact LS-SVM row of the comparison is solved for; beyond it a
/// fixed-size model of [`LARGE_BUDGET`] vectors stands in (as in the reproduction).
pub const EXACT_MAX: usize = 4000;
/// See [`EXACT_MAX`].
pub const LARGE_BUDGET: usize = 512;

/// Most CV folds: beyond this many training cycles, runs of consecutive cycles are grouped.
pub const MAX_FOLDS: usize = 10;

/// Most means σ and c are tuned on (see [`crate::calibrate`]): 1 500 means of 100 s are 42 h.
pub const MAX_TUNE_MEANS: usize = 1500;

/// Highest polynomial degree in T the polynomial baseline is chosen from.
pub const MAX_POLY_DEGREE: usize = 5;

/// Options of [`crate::calibrate`].
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Cycles of the calibration recording that train (without a test recording); `None`:
    /// ⌈k/2⌉ of k, at most k − 1.
    pub train_cycles: Option<usize>,
    /// Stability window, samples (s at 1 Hz).
    pub window: usize,
    /// Training and tuning samples are means of this many 1 Hz samples (1: raw); `None`: from
    /// the record ([`crate::averaging_s`]).
    pub block: Option<usize>,
    /// Support vectors of the board table.
    pub budget: usize,
    /// dT/dt estimator time constant, s.
    pub rate_tau_s: f64,
    /// σ × c search grid.
    pub grid: Grid,
    /// Entry / removal levels of the stepwise regression.
    pub stepwise: StepwiseOptions,
    /// Use only samples from this time on, s.
    pub from_s: Option<f64>,
    /// Use only samples up to this time, s.
    pub to_s: Option<f64>,
    /// Pool the training means into cells of temperature and dT/dt ([`crate::pool_even`]) so that
    /// slow stretches of an uneven ramp do not dominate the fit.
    pub even_temperature: bool,
    /// What the board table removes: the bias' variation about its value at the reference
    /// (an RLG's convention) or the whole bias (a MEMS gyro's).
    pub remove: Removal,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            train_cycles: None,
            window: 100,
            block: None,
            budget: SUPPORT_VECTORS,
            rate_tau_s: RATE_TAU_S,
            grid: Grid::default(),
            stepwise: StepwiseOptions::default(),
            from_s: None,
            to_s: None,
            even_temperature: false,
            remove: Removal::Variation,
        }
    }
}

impl Options {
    pub(crate) fn validate(&self) -> Result<(), CalibrateError> {
        ensure!(
            self.window >= 2,
            Option,
            "the stability window must be at least 2 samples (got {})",
            self.window
        );
        ensure!(self.block != Some(0), Option, "--block must be at least 1");
        ensure!(
            (1..=MAX_BUDGET).contains(&self.budget),
            Option,
            "--budget {}: the board table holds 1 to {MAX_BUDGET} support vectors",
            self.budget
        );
        ensure!(
            self.rate_tau_s.is_finite() && self.rate_tau_s >= 1.0,
            Option,
            "--rate-tau-s {}: the dT/dt estimator needs a time constant of at least 1 s",
            self.rate_tau_s
        );
        ensure!(
            self.train_cycles != Some(0),
            Option,
            "--train-cycles 0: at least one cycle must train"
        );
        if let (Some(a), Some(b)) = (self.from_s, self.to_s) {
            ensure!(a < b, Option, "--from-s {a} is not before --to-s {b}");
        }
        Ok(())
    }
}
