//! The models of the comparison, each fitted on the training means and cross-validated on
//! the same folds: the LS-SVM (σ, c by CV), the board table, the polynomial in T (degree by
//! CV), stepwise regression over the paper's nine terms (selection re-run in every fold).

use indicatif::ProgressBar;

use rlg_eval::baselines::{paper_candidates, stepwise, PolyFit, StepwiseFit};
use rlg_train::lssvm::sparse::{train_reduced, Reduction};
use rlg_train::lssvm::tune::{tune, Tuned, Validation};
use rlg_train::lssvm::Lssvm;
use rlg_train::model::{ModelFile, Provenance};

use crate::board::choose_board;
use crate::cv::{col, cv_rms, poly_cv_dph, poly_degree, poly_of};
use crate::error::CalibrateError;
use crate::options::{Options, EXACT_MAX, LARGE_BUDGET};
use crate::result::BoardChoice;
use crate::sets::TrainingSets;

/// The fitted models and their CV figures.
pub(crate) struct Fitted {
    /// The LS-SVM's σ, c and CV curve.
    pub tuned: Tuned,
    /// The LS-SVM on the training means.
    pub lssvm: Lssvm,
    /// Why the board table has its σ, c.
    pub board: BoardChoice,
    /// The board table.
    pub board_model: ModelFile,
    /// The polynomial's degree.
    pub poly_degree: usize,
    /// CV RMS of each degree, °/h.
    pub poly_cv_dph: Vec<f64>,
    /// The polynomial on the training means.
    pub poly: PolyFit,
    /// The stepwise selection on the training means.
    pub stepwise: StepwiseFit,
    /// Its CV RMS (selection re-run per fold), °/h.
    pub stepwise_cv_dph: Option<f64>,
}

/// Fits every model on `sets` and scores it on `folds` (`validation` in words for the
/// LS-SVM's tuning); `notes` gains why the board table's σ, c differ from the LS-SVM's.
pub(crate) fn fit_models(
    sets: &TrainingSets,
    (validation, folds): (&Validation, &[Vec<usize>]),
    opts: &Options,
    provenance: &Provenance,
    progress: &ProgressBar,
    notes: &mut Vec<String>,
) -> Result<Fitted, CalibrateError> {
    let (tuned, lssvm) = fit_lssvm(sets, validation, opts, progress)?;
    let (board, board_model) = choose_board(sets, folds, &tuned, opts, provenance, progress)?;
    notes.extend(board_note(&tuned, &board));
    let (poly_degree, poly_cv_dph, poly) = fit_polynomial(sets, folds)?;
    let (stepwise, stepwise_cv_dph) = fit_stepwise(sets, folds, opts)?;
    Ok(Fitted {
        tuned,
        lssvm,
        board,
        board_model,
        poly_degree,
        poly_cv_dph,
        poly,
        stepwise,
        stepwise_cv_dph,
    })
}

/// σ and c by CV on the tuning means, then the LS-SVM on the training means: exact up to
/// [`EXACT_MAX`] of them, else fixed-size with [`LARGE_BUDGET`] vectors.
fn fit_lssvm(
    sets: &TrainingSets,
    validation: &Validation,
    opts: &Options,
    progress: &ProgressBar,
) -> Result<(Tuned, Lssvm), CalibrateError> {
    let t = &sets.tune;
    let tuned = tune(
        &t.features,
        &t.x,
        &t.y_dph,
        validation,
        &opts.grid,
        progress,
    )?;
    progress.finish_and_clear();
    let (names, x, y) = (&sets.data.features, &sets.data.x, &sets.data.y_dph);
    let lssvm = if x.len() <= EXACT_MAX {
        Lssvm::train(names, x, y, tuned.sigma, tuned.c)?
    } else {
        train_reduced(
            names,
            x,
            y,
            tuned.sigma,
            tuned.c,
            LARGE_BUDGET,
            Reduction::FIXED_SIZE,
        )?
    };
    Ok((tuned, lssvm))
}

/// Why the board table's σ, c are not the LS-SVM's, when they are not.
fn board_note(tuned: &Tuned, board: &BoardChoice) -> Option<String> {
    let exact_refused = board
        .refused
        .iter()
        .find(|r| (r.0, r.1) == (tuned.sigma, tuned.c));
    let passed_over = |n: usize| {
        format!(
            "{n} better-scoring point(s) of the grid passed over: their tables depart in f32 by \
             up to {:.2e} °/h",
            board.refused.iter().map(|r| r.2).fold(0.0, f64::max)
        )
    };
    if let Some(base) = board.limit_raised_from_dph {
        return Some(format!(
            "The {}-vector board table (σ = {:.3}, c = {:.3}) departs in f32 from its f64 model \
             by {:.2e} °/h, over the limit of {:.1e}, and is taken all the same: its CV rms plus \
             {m} times that departure (measured at a few hundred points of the trained range), \
             {:.3e} + {m} × {:.2e} °/h, bounds what the f32 table scores and is below the CV rms of \
             every point of the grid left to try, so any table within the limit would fit worse \
             by more than this one departs. Its model file carries the raised limit, {:.2e} \
             °/h{}.",
            board.support_vectors,
            board.sigma,
            board.c,
            board.f32_deviation_dph,
            base,
            board.cv_rms_dph,
            board.f32_deviation_dph,
            board.f32_limit_dph,
            if board.refused.is_empty() {
                String::new()
            } else {
                format!(" ({})", passed_over(board.refused.len()))
            },
            m = crate::board::DEPARTURE_MARGIN,
        ));
    }
    if let Some(r) = exact_refused {
        Some(format!(
            "At the LS-SVM's σ = {:.3}, c = {:.3} the {}-vector table's f32 evaluation departs \
             from its f64 model by {:.2e} °/h (limit {:.1e}); the table uses σ = {:.3}, c = {:.3}, \
             the best point of the table's own CV that meets the limit (CV rms {:.3e} °/h; {}).",
            tuned.sigma,
            tuned.c,
            board.support_vectors,
            r.2,
            board.f32_limit_dph,
            board.sigma,
            board.c,
            board.cv_rms_dph,
            passed_over(board.refused.len())
        ))
    } else if (board.sigma, board.c) != (tuned.sigma, tuned.c) {
        Some(format!(
            "The board table uses σ = {:.3}, c = {:.3}, chosen by the CV of the {}-vector table \
             itself (CV rms {:.3e} °/h; at the LS-SVM's σ = {:.3}, c = {:.3} the table scores \
             {:.3e} °/h){}.",
            board.sigma,
            board.c,
            board.support_vectors,
            board.cv_rms_dph,
            tuned.sigma,
            tuned.c,
            board.exact_choice_cv_rms_dph,
            if board.refused.is_empty() {
                String::new()
            } else {
                format!("; {}", passed_over(board.refused.len()))
            }
        ))
    } else {
        None
    }
}

/// The polynomial in T: degree by CV on the tuning means, fitted on the training means.
fn fit_polynomial(
    sets: &TrainingSets,
    folds: &[Vec<usize>],
) -> Result<(usize, Vec<f64>, PolyFit), CalibrateError> {
    let poly_cv_dph = poly_cv_dph(folds, &col(&sets.tune.x, 0), &sets.tune.y_dph);
    let degree = poly_degree(&poly_cv_dph)?;
    let (x, y) = (&sets.data.x, &sets.data.y_dph);
    let all: Vec<usize> = (0..y.len()).collect();
    let poly = poly_of(&col(x, 0), y, &all, degree).ok_or_else(|| {
        CalibrateError::Input("the polynomial in T could not be fitted".to_string())
    })?;
    Ok((degree, poly_cv_dph, poly))
}

/// Stepwise over the paper's nine terms on the training means; its CV re-runs the selection
/// in every fold of the tuning means.
fn fit_stepwise(
    sets: &TrainingSets,
    folds: &[Vec<usize>],
    opts: &Options,
) -> Result<(StepwiseFit, Option<f64>), CalibrateError> {
    let (x, y) = (&sets.data.x, &sets.data.y_dph);
    let cand = paper_candidates(&col(x, 0), &col(x, 1))?;
    let sw = stepwise(&cand, y, &opts.stepwise)?;
    let t = &sets.tune;
    let tune_cand = paper_candidates(&col(&t.x, 0), &col(&t.x, 1))?;
    let sw_cv = cv_rms(folds, t.x.len(), &t.y_dph, |tr, te| {
        let pick = |idx: &[usize]| -> Vec<_> {
            tune_cand
                .iter()
                .map(|c| {
                    let mut c = c.clone();
                    c.values = idx.iter().map(|&i| c.values[i]).collect();
                    c
                })
                .collect()
        };
        let ytr: Vec<f64> = tr.iter().map(|&i| t.y_dph[i]).collect();
        let f = stepwise(&pick(tr), &ytr, &opts.stepwise).ok()?;
        f.fit.predict(&pick(te)).ok()
    });
    Ok((sw, sw_cv))
}
