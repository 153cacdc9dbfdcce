//! The comparison on the held-out samples: every model's output made, scored by the shared
//! [`HeldOutScorer`] and reduced to window means in turn (only one 1 Hz output is held at a
//! time), and the rows of the report.

use std::borrow::Cow;

use rayon::prelude::*;

use rlg_eval::baselines::paper_candidates;
use rlg_eval::metrics::stability::rms;
use rlg_io::recording::Recording;
use rlg_train::features::FeatureSeries;

use crate::board::board_output;
use crate::error::{ensure, CalibrateError};
use crate::fit::Fitted;
use crate::heldout::HeldOutScorer;
use crate::input::at_board_rate;
use crate::options::{Options, MAX_POLY_DEGREE};
use crate::result::{HeldOut, HeldOutScore, HeldOutSeries, Model, ModelRow};
use crate::sets::TrainingSets;
use crate::split::Plan;
use crate::stream::{features_of, without_sensor_faults};

/// The comparison's outcome.
pub(crate) struct Comparison {
    /// One row per model.
    pub rows: Vec<ModelRow>,
    /// The held-out window means the figures draw.
    pub series: HeldOutSeries,
    /// The held-out span, s.
    pub test_span_s: Option<(f64, f64)>,
}

/// The stream the held-out samples come from and which of its samples they are (after the
/// dT/dt estimator's warm-up).
struct HeldOutPart<'a> {
    stream: Cow<'a, Recording>,
    series: Cow<'a, FeatureSeries>,
    keep: Vec<usize>,
}

/// The held-out part: all of `test` (its sensor faults dropped, with a note), or the samples
/// of `cal` from the end of the training span on.
fn held_out_part<'a>(
    cal: &'a Recording,
    series: &'a FeatureSeries,
    test: Option<&'a Recording>,
    plan: &Plan,
    opts: &Options,
    notes: &mut Vec<String>,
) -> Result<HeldOutPart<'a>, CalibrateError> {
    let (stream, series, start) = match test {
        Some(t) => {
            let (t, dt_t) = at_board_rate(Cow::Borrowed(t), "the test recording", notes)?;
            let (t, f) = without_sensor_faults(t, dt_t);
            if f.total() > 0 {
                notes.push(format!("Test recording: {}.", f.describe()));
            }
            let s = features_of(&t, opts.rate_tau_s, dt_t)?;
            (t, Cow::Owned(s), 0)
        }
        None => {
            // The reproduction's rule: samples from the cycle boundary on are held out.
            let s = cal.time_s.partition_point(|t| *t < plan.train_end_s);
            (Cow::Borrowed(cal), Cow::Borrowed(series), s)
        }
    };
    let keep: Vec<usize> = (start..stream.len())
        .filter(|&k| !series.warming_up[k])
        .collect();
    Ok(HeldOutPart {
        stream,
        series,
        keep,
    })
}

/// Compares every model of `fitted` on the held-out samples (see the module doc).
pub(crate) fn compare(
    (cal, series): (&Recording, &FeatureSeries),
    test: Option<&Recording>,
    plan: &Plan,
    (sets, fitted): (&TrainingSets, &Fitted),
    opts: &Options,
    notes: &mut Vec<String>,
) -> Result<Comparison, CalibrateError> {
    let part = held_out_part(cal, series, test, plan, opts, notes)?;
    let (stream, keep) = (&*part.stream, &part.keep);
    let has_test = !matches!(plan.held_out, HeldOut::Nothing);
    ensure!(
        !has_test || keep.len() >= 2 * opts.window,
        Input,
        "the held-out part has {} samples after the dT/dt warm-up, fewer than two stability \
         windows of {}",
        keep.len(),
        opts.window
    );
    let time: Vec<f64> = keep.iter().map(|&k| stream.time_s[k]).collect();
    let rate: Vec<f64> = keep.iter().map(|&k| part.series.rows[k][1]).collect();
    let raw: Vec<f64> = keep.iter().map(|&k| stream.rate_dph[k]).collect();
    let scorer = HeldOutScorer::new(&time, &rate, &raw, opts.window);
    // The board's output is made on one thread (its dT/dt estimator runs through the stream
    // in order) beside the others, each of which is scored while the next is made (the
    // scoring runs on one thread, the models' outputs on all): at most three 1 Hz outputs
    // are held at a time.
    let judge = |out: Vec<f64>| -> (Option<HeldOutScore>, Vec<f64>) {
        if has_test && !out.is_empty() {
            (Some(scorer.score(&out)), scorer.window_means(&out))
        } else {
            (None, Vec::new())
        }
    };
    let lssvm_at = fitted.lssvm.predictor();
    type Make<'m> = &'m (dyn Fn() -> Result<Vec<f64>, CalibrateError> + Sync);
    let makers: [Make<'_>; 4] = [
        &|| Ok(raw.clone()),
        &|| Ok(compensate(&part, &|r| fitted.poly.predict(r[0]))),
        &|| stepwise_output(&part, fitted, has_test),
        &|| Ok(compensate(&part, &|r| lssvm_at.predict(r))),
    ];
    let (board, judged) = rayon::join(
        || {
            if has_test {
                board_output(stream, &fitted.board_model, keep)
            } else {
                Ok(Vec::new())
            }
        },
        || -> Result<Vec<_>, CalibrateError> {
            let mut judged = Vec::with_capacity(makers.len() + 1);
            let mut last: Option<Vec<f64>> = None;
            for make in makers {
                let (scored, next) = rayon::join(|| last.take().map(judge), make);
                judged.extend(scored);
                last = Some(next?);
            }
            judged.extend(last.map(judge));
            Ok(judged)
        },
    );
    let mut judged = judged?;
    judged.push(judge(board?));
    let (held, means): (Vec<Option<HeldOutScore>>, Vec<Vec<f64>>) = judged.into_iter().unzip();
    let held: [Option<HeldOutScore>; 5] = held
        .try_into()
        .map_err(|_| CalibrateError::Internal("five held-out outputs".to_string()))?;
    let rows = rows(sets, fitted, held);
    let (test_span_s, series) = if has_test {
        let temp: Vec<f64> = keep.iter().map(|&k| stream.temp_c[k]).collect();
        (
            Some((time[0], *time.last().unwrap_or(&time[0]))),
            HeldOutSeries {
                start_s: time[0],
                time_s: scorer.window_means(&time),
                temp_c: scorer.window_means(&temp),
                phase: scorer.window_phases(),
                outputs: means,
            },
        )
    } else {
        (
            None,
            HeldOutSeries {
                start_s: f64::NAN,
                time_s: Vec::new(),
                temp_c: Vec::new(),
                phase: Vec::new(),
                outputs: Vec::new(),
            },
        )
    };
    Ok(Comparison {
        rows,
        series,
        test_span_s,
    })
}

/// The recorded rate minus a model's prediction at each held-out sample. In parallel: a
/// 512-vector LS-SVM over a million held-out samples is 5·10⁸ kernel values; the outputs are
/// the serial ones (each sample on its own).
fn compensate(part: &HeldOutPart<'_>, pred: &(dyn Fn(&[f64]) -> f64 + Sync)) -> Vec<f64> {
    part.keep
        .par_iter()
        .map(|&k| part.stream.rate_dph[k] - pred(&part.series.rows[k]))
        .collect()
}

/// The stepwise model's output; its nine candidate columns are formed a chunk of samples at a
/// time. Empty when nothing is held out and the span cannot form them.
fn stepwise_output(
    part: &HeldOutPart<'_>,
    fitted: &Fitted,
    has_test: bool,
) -> Result<Vec<f64>, CalibrateError> {
    let mut out = Vec::with_capacity(part.keep.len());
    for chunk in part.keep.chunks(1 << 16) {
        let col =
            |d: usize| -> Vec<f64> { chunk.iter().map(|&k| part.series.rows[k][d]).collect() };
        match paper_candidates(&col(0), &col(1)) {
            Ok(c) => {
                let p = fitted.stepwise.fit.predict(&c)?;
                out.extend(
                    chunk
                        .iter()
                        .zip(&p)
                        .map(|(&k, p)| part.stream.rate_dph[k] - p),
                );
            }
            // A held-out span with constant T cannot form the candidates.
            Err(e) if has_test => return Err(e.into()),
            Err(_) => {
                out.clear();
                break;
            }
        }
    }
    Ok(out)
}

/// The comparison's rows, in [`Model`] order, with their TRAINING and CV figures and the
/// held-out scores `held` (raw, polynomial, stepwise, LS-SVM, board).
fn rows(sets: &TrainingSets, f: &Fitted, held: [Option<HeldOutScore>; 5]) -> Vec<ModelRow> {
    let (x, y) = (&sets.data.x, &sets.data.y_dph);
    let resid = |pred: &dyn Fn(&[f64]) -> f64| -> Option<f64> {
        let r: Vec<f64> = x.iter().zip(y).map(|(r, y)| y - pred(r)).collect();
        rms(&r)
    };
    let [held_raw, held_poly, held_sw, held_ls, held_board] = held;
    vec![
        ModelRow {
            model: Model::Raw,
            detail: "uncompensated output".into(),
            train_rms_dph: None,
            cv_rms_dph: None,
            held_out: held_raw,
        },
        ModelRow {
            model: Model::Polynomial,
            detail: format!(
                "degree {} (by CV of degrees 1–{MAX_POLY_DEGREE})",
                f.poly_degree
            ),
            train_rms_dph: resid(&|r| f.poly.predict(r[0])),
            cv_rms_dph: Some(f.poly_cv_dph[f.poly_degree - 1]),
            held_out: held_poly,
        },
        ModelRow {
            model: Model::Stepwise,
            detail: if f.stepwise.fit.terms.is_empty() {
                "intercept only".into()
            } else {
                f.stepwise.fit.terms.join(", ")
            },
            train_rms_dph: rms(&f.stepwise.fit.residuals),
            cv_rms_dph: f.stepwise_cv_dph,
            held_out: held_sw,
        },
        ModelRow {
            model: Model::Lssvm,
            detail: format!(
                "σ = {:.3}, c = {:.3}, {} support vectors",
                f.tuned.sigma,
                f.tuned.c,
                f.lssvm.support.len()
            ),
            train_rms_dph: resid(&|r| f.lssvm.predict(r)),
            cv_rms_dph: Some(f.tuned.cv_rms_dph),
            held_out: held_ls,
        },
        ModelRow {
            model: Model::Board,
            detail: format!(
                "fixed-size, {} vectors, σ = {:.3}, c = {:.3}",
                f.board.support_vectors, f.board.sigma, f.board.c
            ),
            train_rms_dph: Some(f.board_model.training.rms_dph),
            cv_rms_dph: Some(f.board.cv_rms_dph),
            held_out: held_board,
        },
    ]
}
