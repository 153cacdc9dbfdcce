//! Calibrating a gyro of one's own: a chamber recording (and optionally a later test
//! recording) to a tuned board table, the baselines compared on the same split, and a report.
//!
//! The protocol, in the order [`calibrate`] runs it:
//! * **Input**: a continuous 1 Hz stream (time_s, rate_dph, temp_c). A bursty log (burst
//!   means minutes apart) carries no dT/dt, so it is refused here with that reason and goes
//!   to [`static_cal`], which fits a temperature-only model.
//! * **Split**: with a `--test` recording, all of the calibration recording trains and the
//!   test recording is held out. Otherwise the recording is cut into temperature cycles
//!   ([`rlg_io::cycles::cycle_spans`]); the first ⌈k/2⌉ of k cycles train (at most k − 1),
//!   the rest are held out. One cycle and no test recording: nothing is held out, and the
//!   report says so and shows cross-validated figures, labelled CV.
//! * **Inputs** of every model are the board's: recorded T and the board's causal dT/dt
//!   estimator, computed over the whole stream so its state at the split is the board's.
//! * **Tuning** of σ and c (and the polynomial's degree) on 100 s means of the training span,
//!   by leave-one-cycle-out when two or more cycles train (whole cycles, so neighbouring
//!   samples never score each other); within a single training cycle, blocked CV over
//!   runs of 10 means ([`rlg_train::protocol::CV`], the reproduction's choice).
//! * **Board table**: a fixed-size LS-SVM of at most `budget` support vectors with the tuned
//!   σ, c, exported to f32. When its f32 evaluation departs from the f64 model beyond the
//!   export limit, the next most regularised point of the CV curve that passes is taken
//!   and the report says which and why.
//! * **Comparison** on the held-out samples: raw, polynomial in T, stepwise over the paper's
//!   nine terms, the LS-SVM on [T, dT/dt] and the board table through the f32
//!   `Compensator`: bias stability over a selectable window, improvement factors, residual
//!   by heating / cooling / hold, Allan deviation.

mod averaging;
mod board;
mod compare;
mod cv;
mod error;
mod fit;
pub mod fleet;
mod heldout;
mod input;
mod options;
pub mod phases;
pub mod report;
mod result;
mod sets;
mod split;
pub mod static_cal;
mod stream;
pub mod train;
pub mod warnings;

use indicatif::ProgressBar;

use rlg_io::cycles::cycle_spans;
use rlg_io::recording::Recording;
use rlg_train::dataset::{self, RecordingSelection};
use rlg_train::lssvm::tune::{fold_indices, tune, Grid, Tuned};
use rlg_train::model::Provenance;
use rlg_train::protocol::TRAIN_BLOCK;

pub use averaging::{averaging_s, Averaging};
pub use board::board_output;
pub use cv::{blocked_within_a_cycle, pool_even};
pub use error::{chain, CalibrateError};
pub use heldout::{allan_of, HeldOutScorer};
pub use input::{at_board_rate, for_static, sampling, Sampling};
pub use options::{
    Options, EXACT_MAX, LARGE_BUDGET, MAX_BUDGET, MAX_FOLDS, MAX_POLY_DEGREE, MAX_TUNE_MEANS,
};
pub use result::{
    BoardChoice, Calibration, DiagnosedBoard, HeldOut, HeldOutScore, HeldOutSeries, Model,
    ModelRow, Split,
};
pub use stream::check_stream;

pub use board::{pick_table, Picked, DEPARTURE_MARGIN};
use cv::validation_of;
use error::ensure;
use stream::{cycle_labels, features_of, window_of, without_sensor_faults};

/// Runs the calibration (see the module doc). `cal` trains; `test`, when given, is held out.
/// `progress` follows the σ, c search. `provenance` labels the board table.
pub fn calibrate(
    cal: &Recording,
    test: Option<&Recording>,
    opts: &Options,
    provenance: &Provenance,
    progress: &ProgressBar,
) -> Result<Calibration, CalibrateError> {
    opts.validate()?;
    let mut notes = Vec::new();
    let cal = window_of(cal, opts.from_s, opts.to_s)?;
    let (cal, dt) = at_board_rate(cal, "the calibration recording", &mut notes)?;
    let (cal, cal_faults) = without_sensor_faults(cal, dt);
    let series = features_of(&cal, opts.rate_tau_s, dt)?;
    let cycles = cycle_spans(&cal.time_s, &cal.temp_c);
    if cal_faults.total() > 0 {
        notes.push(format!("Calibration recording: {}.", cal_faults.describe()));
    }
    let plan = split::plan(&cycles, test.is_some(), opts.train_cycles, &mut notes)?;
    let sets = sets::training_sets(&cal, &series, &cycles, &plan, opts, &mut notes)?;
    let (validation, cv_groups) = cv::validation_of(&sets.tune_labels, sets.tune_block_s)?;
    let folds = fold_indices(&validation, sets.tune.x.len())?;
    let fitted = fit::fit_models(
        &sets,
        (&validation, &folds),
        opts,
        provenance,
        progress,
        &mut notes,
    )?;
    let comparison = compare::compare(
        (&cal, &series),
        test,
        &plan,
        (&sets, &fitted),
        opts,
        &mut notes,
    )?;
    if let Some(row) = comparison.rows.iter().find(|r| r.model == Model::Lssvm) {
        notes.extend(warnings::tuning_notes(
            "The LS-SVM",
            (fitted.tuned.sigma, fitted.tuned.c),
            &opts.grid,
            (
                row.train_rms_dph.unwrap_or(f64::NAN),
                row.cv_rms_dph.unwrap_or(f64::NAN),
            ),
        ));
    }
    let t0 = cal.time_s[0];
    let t_end = *cal.time_s.last().unwrap_or(&t0);
    Ok(Calibration {
        options: opts.clone(),
        split: Split {
            held_out: plan.held_out,
            cycles,
            train_span_s: (t0, plan.train_end_s.min(t_end)),
            test_span_s: comparison.test_span_s,
            cv_groups,
            validation: validation.describe(),
        },
        samples: cal.len(),
        train_samples: sets.data.x.len(),
        train_block_s: sets.block_s,
        tune_block_s: sets.tune_block_s,
        lssvm_support: fitted.lssvm.support.len(),
        tuned: fitted.tuned,
        board: fitted.board,
        board_model: fitted.board_model,
        poly_degree: fitted.poly_degree,
        poly_cv_dph: fitted.poly_cv_dph,
        stepwise: fitted.stepwise,
        rows: comparison.rows,
        series: comparison.series,
        diagnosed_board: None,
        notes,
    })
}

/// σ and c of an exact LS-SVM on [T, dT/dt] for the span `[from_s, to_s]` of `rec`, by the
/// calibration's CV (whole cycles when the span holds two or more, see [`calibrate`]) on its
/// 100 s means (longer ones beyond [`MAX_TUNE_MEANS`], runs of cycles beyond [`MAX_FOLDS`]):
/// what `rlg train` uses when σ and c are not given.
pub fn tune_recording(
    rec: &Recording,
    from_s: Option<f64>,
    to_s: Option<f64>,
    rate_tau_s: f64,
    grid: &Grid,
    progress: &ProgressBar,
) -> Result<Tuned, CalibrateError> {
    let rec = window_of(rec, from_s, to_s)?;
    let dt = check_stream(&rec, "the recording")?;
    let series = features_of(&rec, rate_tau_s, dt)?;
    let cycles = cycle_spans(&rec.time_s, &rec.temp_c);
    let sel = |block| RecordingSelection {
        from_s: None,
        to_s: None,
        block,
        rate_tau_s,
    };
    // At most MAX_TUNE_MEANS means, as `calibrate` tunes.
    let mut block = TRAIN_BLOCK;
    let mut data = dataset::from_recording(&rec, &sel(block))?;
    if data.x.len() > MAX_TUNE_MEANS {
        block *= data.x.len().div_ceil(MAX_TUNE_MEANS);
        data = dataset::from_recording(&rec, &sel(block))?;
    }
    let t_end = *rec.time_s.last().unwrap_or(&0.0);
    let labels = cycle_labels(&rec, &series, t_end, block, &cycles);
    ensure!(
        labels.len() == data.x.len(),
        Internal,
        "internal: {} cycle labels for {} tuning means",
        labels.len(),
        data.x.len()
    );
    let (validation, _) = validation_of(&labels, block)?;
    let tuned = tune(
        &data.features,
        &data.x,
        &data.y_dph,
        &validation,
        grid,
        progress,
    )?;
    progress.finish_and_clear();
    Ok(tuned)
}

#[cfg(test)]
mod tests;
