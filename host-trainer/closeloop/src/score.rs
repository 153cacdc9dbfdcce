//! Training a feature set and judging it on held-out samples: σ and c by cross-validation on
//! the training part's 100 s means, the LS-SVM within the board's f32 budget, and the held-out
//! 100 s stability through the shared scorer (f64 on the host, and the board's f32 path).

use compensator_core::{Compensator, SensorLimits};
use indicatif::ProgressBar;

use rlg_calibrate::{pick_table, CalibrateError, HeldOutScorer, Picked};
use rlg_io::recording::Recording;
use rlg_train::dataset::{self, RecordingSelection};
use rlg_train::export;
use rlg_train::features;
use rlg_train::lssvm::sparse::train_fixed_size_partially_linear;
use rlg_train::lssvm::tune::{tune_partially_linear, CvPoint, Grid, Tuned, Validation};
use rlg_train::lssvm::Lssvm;
use rlg_train::model::{ModelFile, Provenance};
use rlg_train::protocol;

use crate::features::Inputs;

/// How the close loop trains and judges a feature set.
#[derive(Clone, Debug, PartialEq)]
pub struct Protocol {
    /// σ × c search grid.
    pub grid: Grid,
    /// Cross-validation of σ and c, and of whether an augmentation helps.
    pub validation: Validation,
    /// Support vectors (fixed-size LS-SVM), or exact with `None`.
    pub budget: Option<usize>,
    /// An augmented model is adopted only when its CV RMS is below the base model's by this
    /// fraction.
    pub adopt_margin: f64,
    /// Seconds per training mean.
    pub block: usize,
    /// The largest |board f32 − model f64| a chosen model may show, °/h (a MEMS gyro's
    /// calibration allows a coarser one than an RLG's, `rlg_calibrate`'s board limit).
    pub f32_limit_dph: f64,
}

impl Default for Protocol {
    /// The project's cross-validation ([`protocol::CV`], as the paper reproduction and the
    /// default table use), the board table's capacity, a 2 % margin. (Contiguous folds,
    /// `Validation::Contiguous`, were measured on the benchmark too: they choose smoother
    /// models and adopt fewer augmentations, with the same median outcome.)
    fn default() -> Self {
        Protocol {
            grid: Grid::default(),
            validation: protocol::CV,
            budget: Some(protocol::SUPPORT_VECTORS),
            adopt_margin: 0.02,
            block: protocol::TRAIN_BLOCK,
            f32_limit_dph: export::F32_BUDGET_DPH,
        }
    }
}

impl Protocol {
    /// Whether `aug` is adopted over `base`: cross-validated, never by the held-out data.
    pub fn adopts(&self, base: &Scored, aug: &Scored) -> bool {
        aug.inputs != base.inputs && aug.cv_rms_dph < (1.0 - self.adopt_margin) * base.cv_rms_dph
    }
}

/// One feature set trained on the training part and judged on the rest.
#[derive(Clone, Debug)]
pub struct Scored {
    /// The inputs.
    pub inputs: Inputs,
    /// σ, c and the CV evidence.
    pub tuned: Tuned,
    /// The σ of the model: the tuned one, or the best-scoring one the board's f32 budget
    /// allows.
    pub sigma: f64,
    /// The c of the model (as σ).
    pub c: f64,
    /// The cross-validated RMS of the model at that (σ, c), °/h (what adoption compares).
    pub cv_rms_dph: f64,
    /// Largest |board f32 − model f64| over the trained range, °/h.
    pub board_deviation_dph: f64,
    /// The model (LS-SVM on the training part's 100 s means, exact or within the budget).
    pub model: ModelFile,
    /// TRAINING rms on those means, °/h.
    pub train_rms_dph: f64,
    /// HELD-OUT 100 s stability of the output compensated in f64 on the host features, °/h.
    pub test_b100_dph: f64,
    /// First held-out sample (the training part is the samples before it).
    pub test_from: usize,
    /// The f64 model's correction at each held-out sample, °/h (what `test_b100_dph`
    /// subtracts from the recorded rate).
    pub test_correction_dph: Vec<f64>,
    /// The same through the board's f32 `Compensator` (up to five features), °/h.
    pub board_b100_dph: Option<f64>,
}

/// A model trained and its (σ, c) chosen, not yet judged.
struct Fitted {
    tuned: Tuned,
    point: CvPoint,
    model: ModelFile,
    board_deviation_dph: f64,
    dt_s: f64,
}

/// Trains on the samples of `rec` up to `train_to_s` with `inputs`; `provenance` names the
/// recording and the command in the model file. With a budget, the model is the fixed-size
/// LS-SVM of at most that many support vectors (the board table's capacity), with the σ and
/// c cross-validated for the exact one.
fn fit(
    rec: &Recording,
    train_to_s: f64,
    inputs: &Inputs,
    protocol: &Protocol,
    provenance: &Provenance,
) -> Result<Fitted, CalibrateError> {
    let (grid, budget) = (&protocol.grid, protocol.budget);
    let (feats, linear) = (&inputs.features, &inputs.linear);
    let sel = RecordingSelection {
        from_s: None,
        to_s: Some(train_to_s),
        block: protocol.block,
        rate_tau_s: protocol::RATE_TAU_S,
    };
    let data = dataset::from_recording_with(rec, &sel, feats)?;
    let tuned = tune_partially_linear(
        &data.features,
        &data.x,
        &data.y_dph,
        linear,
        &protocol.validation,
        grid,
        &ProgressBar::hidden(),
    )?;
    let train = |sigma: f64, c: f64| -> Result<ModelFile, CalibrateError> {
        let lssvm = match budget {
            Some(m) if data.x.len() > m => train_fixed_size_partially_linear(
                &data.features,
                &data.x,
                &data.y_dph,
                sigma,
                c,
                m,
                linear,
            )?,
            _ => Lssvm::train_partially_linear(
                &data.features,
                &data.x,
                &data.y_dph,
                sigma,
                c,
                linear,
            )?,
        };
        Ok(ModelFile::from_trained(
            lssvm,
            &data.x,
            &data.y_dph,
            protocol::RATE_TAU_S,
            data.dt_s,
            None,
            provenance.clone(),
        )?)
    };
    // The board must evaluate the model within its f32 budget: large cancelling
    // coefficients (a large c on a wide kernel) lose it. The chosen (σ, c) is the tuned one
    // if the board can evaluate it, else the best-scoring evaluated point it can, or one
    // whose departure costs less than that (`rlg_calibrate::pick_table`).
    let mut candidates: Vec<CvPoint> = std::iter::once(CvPoint {
        sigma: tuned.sigma,
        c: tuned.c,
        cv_rms_dph: tuned.cv_rms_dph,
    })
    .chain(tuned.curve.iter().chain(&tuned.refined).copied())
    .filter(|p| p.cv_rms_dph.is_finite())
    .collect();
    candidates[1..].sort_by(|a, b| a.cv_rms_dph.total_cmp(&b.cv_rms_dph));
    let limit = protocol.f32_limit_dph;
    let picked = pick_table(candidates, |p| {
        // A point the solver cannot train is passed over like one the board cannot evaluate.
        let Ok(model) = train(p.sigma, p.c) else {
            return Ok((None, f64::INFINITY, limit));
        };
        let dev = export::f32_deviation_dph(&model)?;
        Ok((Some(model), dev, limit))
    })?;
    let Some(Picked {
        point,
        table: Some(mut model),
        deviation_dph: board_deviation_dph,
        over_limit,
        ..
    }) = picked
    else {
        return Err(CalibrateError::NoBoardTable(format!(
            "no (sigma, c) of the grid gives a model the board evaluates within {limit:.0e} °/h"
        )));
    };
    if over_limit {
        model.f32_limit_dph = Some(rlg_calibrate::DEPARTURE_MARGIN * board_deviation_dph);
    }
    Ok(Fitted {
        tuned,
        point,
        model,
        board_deviation_dph,
        dt_s: data.dt_s,
    })
}

/// Trains on the samples up to `train_to_s` with `inputs` and scores the rest of the same
/// recording (see [`train_and_score_on`]).
pub fn train_and_score(
    rec: &Recording,
    train_to_s: f64,
    inputs: &Inputs,
    protocol: &Protocol,
    provenance: &Provenance,
) -> Result<Scored, CalibrateError> {
    let fitted = fit(rec, train_to_s, inputs, protocol, provenance)?;
    let split = rec.time_s.partition_point(|t| *t <= train_to_s);
    judge(fitted, inputs, rec, split)
}

/// Trains on all of `rec` with `inputs` and scores it by cross-validation only: a record of one
/// temperature cycle holds nothing to hold out. The held-out fields are empty (`test_from` is
/// the record's length, the stabilities NaN / `None`).
pub fn train_and_cv(
    rec: &Recording,
    inputs: &Inputs,
    protocol: &Protocol,
    provenance: &Provenance,
) -> Result<Scored, CalibrateError> {
    let end = rec.time_s.last().copied().unwrap_or(f64::NAN);
    let Fitted {
        tuned,
        point,
        model,
        board_deviation_dph,
        ..
    } = fit(rec, end, inputs, protocol, provenance)?;
    Ok(Scored {
        inputs: inputs.clone(),
        sigma: point.sigma,
        c: point.c,
        cv_rms_dph: point.cv_rms_dph,
        board_deviation_dph,
        train_rms_dph: model.training.rms_dph,
        tuned,
        model,
        test_b100_dph: f64::NAN,
        test_from: rec.len(),
        test_correction_dph: Vec::new(),
        board_b100_dph: None,
    })
}

/// Trains on all of `calibration` with `inputs` and scores all of `test`: a later recording
/// of the same gyro, which the training (and any diagnosis of `calibration`) never saw.
pub fn train_and_score_on(
    calibration: &Recording,
    test: &Recording,
    inputs: &Inputs,
    protocol: &Protocol,
    provenance: &Provenance,
) -> Result<Scored, CalibrateError> {
    let end = calibration.time_s.last().copied().unwrap_or(f64::NAN);
    let fitted = fit(calibration, end, inputs, protocol, provenance)?;
    judge(fitted, inputs, test, 0)
}

/// Scores a fitted model on the samples of `rec` from `split` on.
fn judge(
    fitted: Fitted,
    inputs: &Inputs,
    rec: &Recording,
    split: usize,
) -> Result<Scored, CalibrateError> {
    let Fitted {
        tuned,
        point,
        model,
        board_deviation_dph,
        dt_s,
    } = fitted;
    let feats = &inputs.features;
    let (sigma, c, cv_rms_dph) = (point.sigma, point.c, point.cv_rms_dph);
    let series = features::compute(feats, &rec.temp_c, &rec.time_s, protocol::RATE_TAU_S, dt_s)?;
    if rec.len() < split + 2 * protocol::TRAIN_BLOCK {
        return Err(CalibrateError::Input(
            "less than two 100 s windows after the training part".to_string(),
        ));
    }
    // Inputs clamped into the trained range, as the board clamps them.
    let test_correction_dph: Vec<f64> = (split..rec.len())
        .map(|k| {
            let x: Vec<f64> = series.rows[k]
                .iter()
                .zip(model.input_lo.iter().zip(&model.input_hi))
                .map(|(v, (lo, hi))| v.clamp(*lo, *hi))
                .collect();
            model.correction_dph(&x)
        })
        .collect();
    let host: Vec<f64> = rec.rate_dph[split..]
        .iter()
        .zip(&test_correction_dph)
        .map(|(r, c)| r - c)
        .collect();
    let scorer = HeldOutScorer::new(
        &rec.time_s[split..],
        &[],
        &rec.rate_dph[split..],
        protocol::TRAIN_BLOCK,
    );
    let test_b100_dph = scorer.stability_dph(&host).unwrap_or(f64::NAN);
    let board_b100_dph = match feats.len() {
        2 => board_b100::<2>(rec, split, &model, &scorer)?,
        3 => board_b100::<3>(rec, split, &model, &scorer)?,
        4 => board_b100::<4>(rec, split, &model, &scorer)?,
        5 => board_b100::<5>(rec, split, &model, &scorer)?,
        _ => None,
    };
    Ok(Scored {
        inputs: inputs.clone(),
        sigma,
        c,
        cv_rms_dph,
        board_deviation_dph,
        train_rms_dph: model.training.rms_dph,
        tuned,
        model,
        test_b100_dph,
        test_from: split,
        test_correction_dph,
        board_b100_dph,
    })
}

/// The board's f32 path over the whole record, 100 s stability from `split` on.
fn board_b100<const D: usize>(
    rec: &Recording,
    split: usize,
    model: &ModelFile,
    scorer: &HeldOutScorer<'_>,
) -> Result<Option<f64>, CalibrateError> {
    let t = export::to_f32::<D>(model)?;
    let mut comp = Compensator::new(t.as_model(), SensorLimits::DEFAULT);
    if !comp.table_ok() {
        return Err(CalibrateError::Internal(
            "exported table fails validation".to_string(),
        ));
    }
    let out: Vec<f64> = (0..rec.len())
        .map(|k| {
            f64::from(
                comp.update(rec.temp_c[k] as f32, rec.rate_dph[k] as f32)
                    .rate_dph,
            )
        })
        .collect();
    Ok(scorer.stability_dph(&out[split..]))
}

/// The end of the first temperature cycle, s: the paper's training span.
pub fn first_cycle_end_s(rec: &Recording) -> Result<f64, CalibrateError> {
    let cycles = rlg_io::cycles::cycle_spans(&rec.time_s, &rec.temp_c);
    if cycles.len() < 2 {
        return Err(CalibrateError::Input(format!(
            "the recording has {} temperature cycle(s); holding one out needs at least two (or give the training span)",
            cycles.len()
        )));
    }
    Ok(cycles[0].1)
}
