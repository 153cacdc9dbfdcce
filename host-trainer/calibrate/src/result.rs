//! What a calibration yields: the split, the choices made and why, the comparison's rows.

use rlg_eval::baselines::StepwiseFit;
use rlg_eval::metrics::allan::AdevCi;
use rlg_train::lssvm::tune::Tuned;
use rlg_train::model::ModelFile;

use crate::options::Options;
use crate::phases::PhaseRms;

/// What is held out.
#[derive(Clone, Debug, PartialEq)]
pub enum HeldOut {
    /// The later cycles of the calibration recording.
    Cycles {
        /// Cycles that train.
        train: usize,
        /// Cycles held out.
        test: usize,
    },
    /// A separate test recording.
    TestRecording,
    /// Nothing: one cycle and no test recording; only cross-validated figures exist.
    Nothing,
}

/// How the recording was split and the hyper-parameters scored.
#[derive(Clone, Debug, PartialEq)]
pub struct Split {
    /// What is held out.
    pub held_out: HeldOut,
    /// Temperature cycles found in the calibration recording.
    pub cycles: Vec<(f64, f64)>,
    /// Training span of the calibration recording, s.
    pub train_span_s: (f64, f64),
    /// Held-out span (of the calibration or the test recording), s.
    pub test_span_s: Option<(f64, f64)>,
    /// Training cycles that label the CV folds (1: blocked CV within the cycle).
    pub cv_groups: usize,
    /// The CV scheme, in words.
    pub validation: String,
}

/// The board table's hyper-parameters and why.
#[derive(Clone, Debug, PartialEq)]
pub struct BoardChoice {
    /// σ of the table.
    pub sigma: f64,
    /// c of the table.
    pub c: f64,
    /// CV RMS of the table at this σ, c, °/h.
    pub cv_rms_dph: f64,
    /// CV RMS of the table at the LS-SVM's σ, c, °/h.
    pub exact_choice_cv_rms_dph: f64,
    /// Support vectors.
    pub support_vectors: usize,
    /// |f32 − f64| of the table's correction over the trained range, °/h.
    pub f32_deviation_dph: f64,
    /// The export limit it was held to, °/h (its own departure when it was taken over the
    /// limit: `limit_raised_from_dph`).
    pub f32_limit_dph: f64,
    /// The limit the table departs beyond, when every table within it would have scored
    /// worse by more than the departure ([`crate::board::pick_table`]); None: within it.
    pub limit_raised_from_dph: Option<f64>,
    /// Whether the table stores b − reference ([`rlg_train::export::folds_reference`]).
    pub reference_folded: bool,
    /// Points of the CV curve refused for f32 precision before this one, (σ, c, deviation).
    pub refused: Vec<(f64, f64, f64)>,
}

/// Held-out scores of one model.
#[derive(Clone, Debug, PartialEq)]
pub struct HeldOutScore {
    /// Bias stability of the compensated held-out output over the window, °/h.
    pub stability_dph: f64,
    /// Raw stability / this one.
    pub improvement: Option<f64>,
    /// RMS of the window means of the compensated output about their mean, by phase.
    pub phases: PhaseRms,
    /// Allan deviation of the compensated held-out output, with 1σ χ² intervals.
    pub allan: Vec<AdevCi>,
}

/// The models a calibration compares, in the order of its rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Model {
    /// The uncompensated output.
    Raw,
    /// A polynomial in T, degree by CV.
    Polynomial,
    /// Stepwise regression over the paper's nine terms.
    Stepwise,
    /// The exact (or, on a long record, fixed-size) LS-SVM on [T, dT/dt].
    Lssvm,
    /// The board table through the board's f32 `Compensator`.
    Board,
    /// The close loop's model on the inputs a diagnosis added (`rlg calibrate --diagnose`).
    Diagnosed,
}

impl Model {
    /// The name reports print.
    pub const fn name(self) -> &'static str {
        match self {
            Model::Raw => "raw",
            Model::Polynomial => "polynomial in T",
            Model::Stepwise => "stepwise (paper's 9 terms)",
            Model::Lssvm => "LS-SVM on [T, dT/dt]",
            Model::Board => "board table (f32)",
            Model::Diagnosed => "diagnosed features (close loop)",
        }
    }
}

impl std::fmt::Display for Model {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One row of the comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelRow {
    /// Which model.
    pub model: Model,
    /// What it is, in a few words (terms, degree, σ and c).
    pub detail: String,
    /// TRAINING RMS on the training means, °/h (`None`: nothing fitted).
    pub train_rms_dph: Option<f64>,
    /// Cross-validated RMS on the tuning means, °/h (same folds for every fitted model).
    pub cv_rms_dph: Option<f64>,
    /// Held-out scores (`None` when nothing is held out).
    pub held_out: Option<HeldOutScore>,
}

/// The held-out stream as the figures need it: means over the stability's gap-free windows
/// (the 1 Hz series of a long record would hold most of the memory).
#[derive(Clone, Debug, PartialEq)]
pub struct HeldOutSeries {
    /// First held-out time, s.
    pub start_s: f64,
    /// Mean time of each window, s.
    pub time_s: Vec<f64>,
    /// Mean sensor temperature of each window, °C.
    pub temp_c: Vec<f64>,
    /// Phase of each window: 0 heating, 1 cooling, 2 hold ([`crate::phases::window_phases`]).
    pub phase: Vec<usize>,
    /// Window means of the output of each row of [`Calibration::rows`] (raw first), °/h.
    pub outputs: Vec<Vec<f64>>,
}

/// The result of [`crate::calibrate`].
#[derive(Clone, Debug)]
pub struct Calibration {
    /// Options used.
    pub options: Options,
    /// The split.
    pub split: Split,
    /// 1 Hz samples of the calibration recording.
    pub samples: usize,
    /// Training means (of `train_block_s` samples).
    pub train_samples: usize,
    /// Seconds per training mean (`--block`, else chosen from the record).
    pub train_block_s: usize,
    /// Seconds per tuning mean (the training means', longer on a long span).
    pub tune_block_s: usize,
    /// The LS-SVM's tuning.
    pub tuned: Tuned,
    /// The board table's choice.
    pub board: BoardChoice,
    /// The board table (what `model.json` and the exported tables hold).
    pub board_model: ModelFile,
    /// Degree of the polynomial baseline and the CV RMS of each degree tried.
    pub poly_degree: usize,
    /// CV RMS of degrees 1 … [`crate::MAX_POLY_DEGREE`], °/h.
    pub poly_cv_dph: Vec<f64>,
    /// The stepwise selection.
    pub stepwise: StepwiseFit,
    /// The comparison: raw, polynomial, stepwise, LS-SVM, board.
    pub rows: Vec<ModelRow>,
    /// The held-out stream (empty when nothing is held out).
    pub series: HeldOutSeries,
    /// Support vectors of the LS-SVM row.
    pub lssvm_support: usize,
    /// Lines the report must show (a changed choice, a caveat).
    pub notes: Vec<String>,
    /// The table on the diagnosed features, when the close loop adopts them (`rlg calibrate
    /// --diagnose`; [`crate::calibrate`] leaves it `None`).
    pub diagnosed_board: Option<DiagnosedBoard>,
}

/// A board table on the inputs the diagnosis of the training span added (a lagged gradient,
/// a play operator, …: `compensator_core::Feature`, which the board computes from T itself),
/// written beside the [T, dT/dt] table when the close loop adopts those inputs by
/// cross-validation.
#[derive(Clone, Debug)]
pub struct DiagnosedBoard {
    /// The model its tables hold.
    pub model: ModelFile,
    /// Largest |f32 − f64| of its correction over the trained range, °/h.
    pub f32_deviation_dph: f64,
    /// The export limit it was held to, °/h.
    pub f32_limit_dph: f64,
    /// Held-out bias stability of the output compensated through the board's f32
    /// `Compensator` (None when nothing is held out), °/h.
    pub board_stability_dph: Option<f64>,
}

impl Calibration {
    /// The row of `model`.
    pub fn row(&self, model: Model) -> Option<&ModelRow> {
        self.rows.iter().find(|r| r.model == model)
    }
}
