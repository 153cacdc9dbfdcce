//! `rlg train`'s job: one LS-SVM model file from the paper's Table 1 or from a recording, σ
//! and c given or tuned (Table 1 by closed-form leave-one-out, a recording by the
//! calibration's CV, [`crate::tune_recording`]), exact or fixed-size.

use indicatif::ProgressBar;

use rlg_io::recording::Recording;
use rlg_train::dataset::{self, Dataset, RecordingSelection};
use rlg_train::features::FeatureRows;
use rlg_train::lssvm::solve::MAX_EXACT_SAMPLES;
use rlg_train::lssvm::sparse::{train_reduced, Reduction};
use rlg_train::lssvm::tune::{tune, Grid, Tuned, Validation};
use rlg_train::lssvm::LssvmError;
use rlg_train::model::{ModelFile, Provenance};

use crate::error::{ensure, CalibrateError};
use crate::stream::check_stream;

/// What a model is trained on.
#[derive(Debug)]
pub enum TrainData {
    /// The paper's Table 1 (or a file of its format): one feature, temp_c; its points are
    /// independent.
    Table1(Dataset),
    /// A recording (a continuous 1 Hz stream): features temp_c and temp_rate_c_per_s over the
    /// selection's span, as its means.
    Recording(Recording, RecordingSelection),
}

/// How the model is trained.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainOptions {
    /// σ and c; `None`: tuned by cross-validation.
    pub sigma_c: Option<(f64, f64)>,
    /// Support vectors of a fixed-size model; `None`: the exact model.
    pub budget: Option<usize>,
    /// Also compute the closed-form leave-one-out RMS (exact model only).
    pub loo: bool,
    /// Time constant of the dT/dt estimator written into the model, s.
    pub rate_tau_s: f64,
}

/// A trained model and, when σ and c were not given, their tuning.
#[derive(Clone, Debug)]
pub struct Trained {
    /// The model file.
    pub model: ModelFile,
    /// The tuning, when σ and c were not given.
    pub tuned: Option<Tuned>,
}

/// Table 1's rows in one block, as a recording's are.
fn flat(d: Dataset) -> Dataset<FeatureRows> {
    let mut x = FeatureRows::with_capacity(d.features.len(), d.x.len());
    for r in &d.x {
        x.push_row(r.iter().copied());
    }
    Dataset {
        x,
        features: d.features,
        y_dph: d.y_dph,
        dt_s: d.dt_s,
    }
}

/// Rows as vectors, for the solvers that take them (the exact solve, Table 1's tuning): a
/// training set held this way costs 56 bytes a row, so the large ones stay in one block.
fn vecs(x: &FeatureRows) -> Vec<Vec<f64>> {
    (0..x.len()).map(|k| x[k].to_vec()).collect()
}

/// Trains one model (see the module doc). `what` names the data in errors, `provenance` in
/// the model file; `progress` follows the tuning. The exact model's size is checked before
/// any tuning.
pub fn train_model(
    data: TrainData,
    opts: &TrainOptions,
    what: &str,
    provenance: Provenance,
    progress: &ProgressBar,
) -> Result<Trained, CalibrateError> {
    ensure!(
        !(opts.loo && opts.budget.is_some()),
        Option,
        "--loo is the exact model's closed-form leave-one-out; drop it with --budget"
    );
    let training = |source: CalibrateError| CalibrateError::Training {
        what: what.to_string(),
        source: Box::new(source),
    };
    let (rec, mut set) = match data {
        TrainData::Table1(d) => (None, (flat(d), None)),
        TrainData::Recording(mut r, sel) => {
            // Training reads time, rate and temperature only: the chamber's column and any
            // other are 80 MB each on 10⁷ samples.
            r.chamber_c = None;
            r.extra = Vec::new();
            let d = dataset::from_recording_rows(&r, &sel)?;
            (Some(r), (d, Some(sel)))
        }
    };
    // The exact solve's size is known now: refuse before minutes of tuning, not after.
    if opts.budget.is_none() && set.0.x.len() > MAX_EXACT_SAMPLES {
        return Err(training(CalibrateError::Lssvm(LssvmError::TooLarge {
            samples: set.0.x.len(),
            max: MAX_EXACT_SAMPLES,
        })));
    }
    if let Some(r) = &rec {
        // A dT/dt model needs the board's 1 Hz stream, with or without tuning.
        check_stream(r, what)?;
    }
    let tuned = match (opts.sigma_c, &rec, &set.1) {
        (Some(_), ..) => None,
        (None, Some(r), Some(sel)) => {
            // The tuning works on the recording: the training set is rebuilt after it rather
            // than held through it (240 MB on 10⁷ samples at --block 1).
            set.0.x = FeatureRows::with_capacity(set.0.x.dim(), 0);
            set.0.y_dph = Vec::new();
            let tuned = crate::tune_recording(
                r,
                sel.from_s,
                sel.to_s,
                sel.rate_tau_s,
                &Grid::default(),
                progress,
            )?;
            set.0 = dataset::from_recording_rows(r, sel)?;
            Some(tuned)
        }
        // Table 1's points are independent: closed-form leave-one-out.
        (None, ..) => Some(tune(
            &set.0.features,
            &vecs(&set.0.x),
            &set.0.y_dph,
            &Validation::LeaveOneOut,
            &Grid::default(),
            progress,
        )?),
    };
    progress.finish_and_clear();
    let (sigma, c) = opts
        .sigma_c
        .or(tuned.as_ref().map(|t| (t.sigma, t.c)))
        .unwrap_or((f64::NAN, f64::NAN));
    // The recording was needed for the stream check and the tuning only: on 10⁷ samples it
    // is 240 MB the training does not use.
    drop(rec);
    let data = set.0;
    let model = match opts.budget {
        // The exact solve is capped (checked above): its rows as vectors.
        None => ModelFile::train(
            &data.features,
            &vecs(&data.x),
            &data.y_dph,
            sigma,
            c,
            opts.rate_tau_s,
            data.dt_s,
            opts.loo,
            provenance,
        )
        .map_err(|e| training(e.into()))?,
        Some(budget) => {
            let l = train_reduced(
                &data.features,
                &data.x,
                &data.y_dph,
                sigma,
                c,
                budget,
                Reduction::FIXED_SIZE,
            )
            .map_err(|e| training(e.into()))?;
            ModelFile::from_trained(
                l,
                &data.x,
                &data.y_dph,
                opts.rate_tau_s,
                data.dt_s,
                None,
                provenance,
            )
            .map_err(|e| training(e.into()))?
        }
    };
    Ok(Trained { model, tuned })
}
