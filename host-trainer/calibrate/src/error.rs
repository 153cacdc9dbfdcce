//! Why a calibration could not be made.

use rlg_eval::baselines::{PolyError, StepwiseError};
use rlg_io::plot::PlotError;
use rlg_io::recording::RecordingError;
use rlg_train::dataset::DatasetError;
use rlg_train::export::ExportError;
use rlg_train::features::FeatureError;
use rlg_train::lssvm::tune::TuneError;
use rlg_train::lssvm::LssvmError;
use rlg_train::model::ModelError;

/// Why a calibration (or its report) could not be made. Each message says what was found and,
/// where there is one, the option that changes it.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibrateError {
    /// An option outside its range.
    #[error("{0}")]
    Option(String),
    /// The recording cannot be calibrated as it is (too short, not a stream, too few cycles).
    #[error("{0}")]
    Input(String),
    /// No point of the σ × c grid gives a table the board evaluates within its f32 limit.
    #[error("{0}")]
    NoBoardTable(String),
    /// A broken invariant of this crate (a bug, not the input's fault).
    #[error("{0}")]
    Internal(String),
    /// A recording could not be read.
    #[error(transparent)]
    Read(#[from] RecordingError),
    /// The board's features could not be computed.
    #[error(transparent)]
    Features(#[from] FeatureError),
    /// The training set could not be made.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// The cross-validation could not be set up or run.
    #[error(transparent)]
    Tune(#[from] TuneError),
    /// An LS-SVM could not be trained.
    #[error(transparent)]
    Lssvm(#[from] LssvmError),
    /// A model file could not be made, read or written.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A board table could not be exported.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// The stepwise baseline failed.
    #[error(transparent)]
    Stepwise(#[from] StepwiseError),
    /// The polynomial baseline failed.
    #[error(transparent)]
    Poly(#[from] PolyError),
    /// A figure could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// The summary could not be serialised.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// The output folder cannot hold the report.
    #[error("{message}")]
    OutputDir {
        /// What is wrong, with the flag.
        message: String,
        /// The underlying error, when there is one.
        #[source]
        source: Option<std::io::Error>,
    },
    /// Training on a data file failed.
    #[error("training on {what}")]
    Training {
        /// The data file.
        what: String,
        /// Why.
        #[source]
        source: Box<CalibrateError>,
    },
    /// A file of the report could not be written.
    #[error("writing {path}")]
    Write {
        /// The file.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// `Err(CalibrateError::$variant(format!(...)))` unless `$cond`.
macro_rules! ensure {
    ($cond:expr, $variant:ident, $($fmt:tt)+) => {
        // Bound first: a NaN comparison fails the check, as it should.
        let holds: bool = $cond;
        if !holds {
            return Err($crate::CalibrateError::$variant(format!($($fmt)+)));
        }
    };
}
pub(crate) use ensure;

/// An error and its causes on one line, `a: b: c` (how a fleet row shows why a gyro failed).
pub fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        s.push_str(": ");
        s.push_str(&c.to_string());
        cause = c.source();
    }
    s
}
