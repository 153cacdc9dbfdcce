//! `rlg calibrate --diagnose`: the close loop on a calibration's own split. The training span
//! is diagnosed, the findings become board features, and where cross-validation adopts them
//! their model joins the comparison, scored on the held-out samples by the calibration's own
//! scorer; otherwise a note says why not.

use compensator_core::Feature;
use indicatif::ProgressBar;

use rlg_calibrate::{
    calibrate, CalibrateError, Calibration, DiagnosedBoard, HeldOut, HeldOutScorer, Model,
    ModelRow, Options,
};
use rlg_diagnose::{diagnose, DiagnoseError, Options as DiagnoseOptions, PhysicsModel};
use rlg_io::progress::progress;
use rlg_io::recording::Recording;
use rlg_train::export;
use rlg_train::model::Provenance;

use crate::features::{augmented_features, Inputs};
use crate::score::{train_and_cv, train_and_score, train_and_score_on, Protocol, Scored};

/// Why the close loop on a calibration failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CloseLoopError {
    /// The calibration, or a model's training or scoring, failed.
    #[error(transparent)]
    Calibrate(#[from] CalibrateError),
    /// The diagnosis of the training span failed.
    #[error(transparent)]
    Diagnose(#[from] DiagnoseError),
}

/// [`calibrate`], then the diagnosed-feature model on the same split ([`diagnosed_row`]).
pub fn calibrate_diagnosed(
    cal: &Recording,
    test: Option<&Recording>,
    opts: &Options,
    model: &PhysicsModel,
    provenance: &Provenance,
    progress: &ProgressBar,
) -> Result<Calibration, CloseLoopError> {
    let mut c = calibrate(cal, test, opts, provenance, progress)?;
    diagnosed_row(cal, test, &mut c, model, provenance)?;
    Ok(c)
}

/// Diagnoses the training span of `c` against `model`, turns the findings into board
/// features and, where cross-validation adopts them, adds their model's row (scored on the
/// held-out samples as the others are) and board table to `c`; otherwise adds a note saying
/// why not.
pub fn diagnosed_row(
    cal: &Recording,
    test: Option<&Recording>,
    c: &mut Calibration,
    model: &PhysicsModel,
    provenance: &Provenance,
) -> Result<(), CloseLoopError> {
    let one_cycle = matches!(c.split.held_out, HeldOut::Nothing);
    let end = c.split.train_span_s.1;
    let Some(feats) = diagnosed_inputs(cal, end, model, c)? else {
        return Ok(());
    };
    let mut protocol = Protocol {
        budget: Some(c.options.budget),
        ..Protocol::default()
    };
    if one_cycle {
        // Nothing to hold out: both models are judged by the calibration's own blocked CV
        // on its own means, under its board's f32 limit.
        let n = c.samples / c.train_block_s.max(1);
        protocol.block = c.train_block_s;
        protocol.validation = rlg_calibrate::blocked_within_a_cycle(n, c.train_block_s);
        protocol.f32_limit_dph = c
            .board
            .limit_raised_from_dph
            .unwrap_or(c.board.f32_limit_dph);
    }
    let score = |inputs: &Inputs| match test {
        _ if one_cycle => train_and_cv(cal, inputs, &protocol, provenance),
        Some(t) => train_and_score_on(cal, t, inputs, &protocol, provenance),
        None => train_and_score(cal, end, inputs, &protocol, provenance),
    };
    let pb = progress("close loop: base and diagnosed features");
    let base = score(&Inputs::base())?;
    let mut aug = score(&feats)?;
    pb.finish_and_clear();
    if !protocol.adopts(&base, &aug) {
        c.notes.push(format!(
            "--diagnose: the diagnosed features [{}] are not adopted: their CV rms \
             {:.3e} °/h is not {:.0} % below the [T, dT/dt] model's {:.3e} °/h{}.",
            aug.inputs.describe().join(", "),
            aug.cv_rms_dph,
            100.0 * protocol.adopt_margin,
            base.cv_rms_dph,
            if one_cycle {
                " (one cycle: nothing held out)".to_string()
            } else {
                format!(
                    " (held out, for the record: {:.3e} against {:.3e} °/h)",
                    aug.test_b100_dph, base.test_b100_dph
                )
            }
        ));
        return Ok(());
    }
    if one_cycle && protocol.f32_limit_dph > export::EXPORT_LIMIT_DPH {
        // Not below a limit the table was taken over (`rlg_calibrate::pick_table`).
        let raised = aug.model.f32_limit_dph.unwrap_or(0.0);
        aug.model.f32_limit_dph = Some(protocol.f32_limit_dph.max(raised));
    }
    aug.model.removes = c.options.remove;
    let table = diagnosed_table(&aug, c);
    if one_cycle {
        cv_row(&base, &aug, &table, c);
        return Ok(());
    }
    add_row(test.unwrap_or(cal), &base, &aug, &table, c)?;
    Ok(())
}

/// The inputs the diagnosis of the training span (samples up to `end` s) adds; `None`, with a
/// note in `c`, when it cannot be diagnosed or names nothing a board feature carries.
fn diagnosed_inputs(
    cal: &Recording,
    end: f64,
    model: &PhysicsModel,
    c: &mut Calibration,
) -> Result<Option<Inputs>, CloseLoopError> {
    let train_part = cal.head(cal.time_s.partition_point(|t| *t <= end));
    let pb = progress("diagnosing the training span");
    let d = match diagnose(&train_part, model, &DiagnoseOptions::default()) {
        Ok(d) => d,
        Err(e @ DiagnoseError::TooShort { .. }) => {
            pb.finish_and_clear();
            c.notes.push(format!(
                "--diagnose: the training span cannot be diagnosed ({e})."
            ));
            return Ok(None);
        }
        Err(e) => return Err(e.into()),
    };
    pb.finish_and_clear();
    let (feats, suggestions) = augmented_features(&d);
    if feats == Inputs::base() {
        c.notes.push(format!(
            "--diagnose: the diagnosis of the training span names no mechanism a board feature \
             carries (verdict {:?}{}); no diagnosed-feature model.",
            d.verdict,
            suggestions
                .iter()
                .map(|s| format!("; {}: {}", s.mechanism, s.reason))
                .collect::<String>()
        ));
        return Ok(None);
    }
    Ok(Some(feats))
}

/// The adopted model's board table, under the same f32 limit as the [T, dT/dt] table's: kept
/// in `c` when it meets it; the sentence the note ends with either way.
fn diagnosed_table(aug: &Scored, c: &mut Calibration) -> String {
    match rlg_train::export::precision(&aug.model) {
        Ok(p) if p.deviation_dph <= p.limit_dph => {
            c.diagnosed_board = Some(DiagnosedBoard {
                model: aug.model.clone(),
                f32_deviation_dph: p.deviation_dph,
                f32_limit_dph: p.limit_dph,
                board_stability_dph: aug.board_b100_dph,
            });
            "Its board table: `table_diagnosed.rs`, `table_diagnosed.h`, \
             `model_diagnosed.json`."
                .to_string()
        }
        Ok(p) => format!(
            "Its board table is not written: its f32 evaluation departs by {:.2e} °/h, beyond \
             the limit {:.1e} °/h (lower --c-min).",
            p.deviation_dph, p.limit_dph
        ),
        Err(e) => format!("Its board table is not written: {e}."),
    }
}

/// The adopted model's row on a record of one cycle: TRAINING and CV only, and the note that
/// says so.
fn cv_row(base: &Scored, aug: &Scored, table: &str, c: &mut Calibration) {
    let described = aug.inputs.describe().join(", ");
    c.notes.push(format!(
        "--diagnose: the close loop adopts the diagnosed features [{described}] (CV rms {:.3e} \
         against {:.3e} °/h for [T, dT/dt] on the same {} s means and folds); one cycle holds \
         nothing to hold out, so the row has CV figures only. {table}",
        aug.cv_rms_dph, base.cv_rms_dph, c.train_block_s
    ));
    c.rows.push(ModelRow {
        model: Model::Diagnosed,
        detail: format!("[{described}], σ = {:.3}, c = {:.3}", aug.sigma, aug.c),
        train_rms_dph: Some(aug.train_rms_dph),
        cv_rms_dph: Some(aug.cv_rms_dph),
        held_out: None,
    });
}

/// The adopted model's row: its output on `stream`'s held-out samples (from the close loop's
/// split) scored as the calibration scores its own rows, and the note that says so.
fn add_row(
    stream: &Recording,
    base: &Scored,
    aug: &Scored,
    table: &str,
    c: &mut Calibration,
) -> Result<(), CalibrateError> {
    let k0 = aug.test_from;
    let time = &stream.time_s[k0..];
    let out: Vec<f64> = stream.rate_dph[k0..]
        .iter()
        .zip(&aug.test_correction_dph)
        .map(|(r, k)| r - k)
        .collect();
    let rate = rlg_train::features::compute(
        &[Feature::TempRateCPerS],
        &stream.temp_c,
        &stream.time_s,
        c.options.rate_tau_s,
        1.0,
    )?;
    let rate: Vec<f64> = rate.rows.iter().skip(k0).map(|r| r[0]).collect();
    let scorer = HeldOutScorer::new(time, &rate, &stream.rate_dph[k0..], c.options.window);
    let described = aug.inputs.describe().join(", ");
    c.notes.push(format!(
        "--diagnose: the close loop adopts the diagnosed features [{described}] (CV rms {:.3e} \
         against {:.3e} °/h); their model is scored on the held-out samples from {:.0} s (the \
         close loop's split: {} sample(s) from the other rows'). {}",
        aug.cv_rms_dph,
        base.cv_rms_dph,
        time[0],
        {
            let k = stream.time_s.partition_point(|t| *t < c.series.start_s);
            k.abs_diff(k0)
        },
        table
    ));
    c.rows.push(ModelRow {
        model: Model::Diagnosed,
        detail: format!("[{described}], σ = {:.3}, c = {:.3}", aug.sigma, aug.c),
        train_rms_dph: Some(aug.train_rms_dph),
        cv_rms_dph: Some(aug.cv_rms_dph),
        held_out: Some(scorer.score(&out)),
    });
    Ok(())
}
