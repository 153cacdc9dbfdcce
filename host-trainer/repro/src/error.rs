//! Why a reproduction could not be made.

use rlg_calibrate::CalibrateError;
use rlg_eval::baselines::{PolyError, StepwiseError};
use rlg_io::table1::Table1Error;
use rlg_simulate::scenario::ScenarioError;
use rlg_train::dataset::DatasetError;
use rlg_train::export::ExportError;
use rlg_train::features::FeatureError;
use rlg_train::lssvm::tune::TuneError;
use rlg_train::lssvm::LssvmError;
use rlg_train::model::ModelError;

/// Why a reproduction (or its report) could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReproError {
    /// An option outside its range, or a run without the data the protocol needs.
    #[error("{0}")]
    Protocol(String),
    /// The shipped scenario could not be read or simulated.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// Table 1 could not be read.
    #[error(transparent)]
    Table1(#[from] Table1Error),
    /// The board's scoring path failed.
    #[error(transparent)]
    Calibrate(#[from] CalibrateError),
    /// The board's features could not be computed.
    #[error(transparent)]
    Features(#[from] FeatureError),
    /// The training set could not be made.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// The cross-validation failed.
    #[error(transparent)]
    Tune(#[from] TuneError),
    /// An LS-SVM could not be trained.
    #[error(transparent)]
    Lssvm(#[from] LssvmError),
    /// A model file could not be made.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A board table could not be exported.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// The stepwise regression failed.
    #[error(transparent)]
    Stepwise(#[from] StepwiseError),
    /// The static polynomial failed.
    #[error(transparent)]
    Poly(#[from] PolyError),
    /// A file of the report could not be written.
    #[error("{what}")]
    Write {
        /// What was being done, with the path.
        what: String,
        /// Why it failed.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}
