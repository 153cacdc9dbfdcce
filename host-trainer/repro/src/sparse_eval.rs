//! Held-out comparison of reduced models against the full one on the reference dynamic run
//! ([`crate::pipeline::dynamic_run`]): train on the first temperature cycle, compensate the
//! other cycles and compare the 100 s bias stability.
//!
//! Two evaluations of each model on the held-out samples:
//! * the board's path: the model converted by [`export::to_f32`] and run sample by sample
//!   through `compensator_core::Compensator` from the start of the record (so the dT/dt
//!   estimator state at the split is the board's), outputs kept from the split on;
//! * the f64 model on the same features ([`features::compute`]), output raw − (f(x) − ref).

use compensator_core::Feature;

use crate::pipeline::{self, DynamicRun, Recipe};
use crate::ReproError;
use rlg_eval::metrics::stability::bias_stability_dph;
use rlg_train::features;
use rlg_train::lssvm::sparse::Reduction;
use rlg_train::model::ModelFile;

/// The stability window, samples (100 s at 1 Hz).
pub const WINDOW: usize = 100;

/// Held-out result of one model.
#[derive(Clone, Debug, PartialEq)]
pub struct HeldOut {
    /// What was trained.
    pub label: String,
    /// Training samples.
    pub train_samples: usize,
    /// Support vectors of the model.
    pub support_vectors: usize,
    /// Wall time of the training, s.
    pub train_s: f64,
    /// Largest |a_i|, °/h: large coefficients that cancel cost f32 precision on the board.
    pub max_abs_alpha_dph: f64,
    /// 100 s stability of the raw held-out output, °/h.
    pub raw_b100_dph: f64,
    /// 100 s stability after the board's f32 compensator, °/h.
    pub board_b100_dph: f64,
    /// 100 s stability after the f64 model on the host features, °/h.
    pub f64_b100_dph: f64,
}

/// The board's output on the held-out cycles of `run`: `model` converted to the f32 table
/// and run sample by sample through `compensator_core::Compensator` from the start of the
/// record (so the estimator's state at the split is the board's), outputs from the split on.
pub fn board_output(run: &DynamicRun, model: &ModelFile) -> Result<Vec<f64>, ReproError> {
    let rec = &run.recording;
    let split = rec.time_s.partition_point(|t| *t < run.train_end_s());
    let keep: Vec<usize> = (split..rec.len()).collect();
    Ok(rlg_calibrate::board_output(rec, model, &keep)?)
}

/// Compensates the held-out cycles of `run` with `model` both ways (see the module doc);
/// returns the 100 s stabilities of the raw, board and f64 outputs.
pub fn evaluate(run: &DynamicRun, model: &ModelFile) -> Result<(f64, f64, f64), ReproError> {
    let rec = &run.recording;
    let split = rec.time_s.partition_point(|t| *t < run.train_end_s());
    let board = board_output(run, model)?;
    let series = features::compute(
        &[Feature::TempC, Feature::TempRateCPerS],
        &rec.temp_c,
        &rec.time_s,
        model.rate_tau_s,
        model.dt_s,
    )?;
    let host: Vec<f64> = (split..rec.len())
        .map(|k| rec.rate_dph[k] - model.correction_dph(&series.rows[k]))
        .collect();
    let b = |v: &[f64]| bias_stability_dph(v, WINDOW).unwrap_or(f64::NAN);
    Ok((b(&rec.rate_dph[split..]), b(&board), b(&host)))
}

/// Trains with `recipe` on the first cycle and evaluates on the others.
pub fn held_out(
    run: &DynamicRun,
    recipe: &Recipe,
    sigma: f64,
    c: f64,
) -> Result<HeldOut, ReproError> {
    let t0 = std::time::Instant::now();
    let model = pipeline::train_first_cycle(
        run,
        recipe,
        sigma,
        c,
        &format!("rlg sparse-report ({})", recipe.label()),
    )?;
    let train_s = t0.elapsed().as_secs_f64();
    let (raw, board, f64_b100) = evaluate(run, &model)?;
    Ok(HeldOut {
        label: recipe.label(),
        train_samples: model.training.samples,
        support_vectors: model.lssvm.support.len(),
        train_s,
        max_abs_alpha_dph: model
            .lssvm
            .alpha_dph
            .iter()
            .fold(0.0, |m, a| f64::max(m, a.abs())),
        raw_b100_dph: raw,
        board_b100_dph: board,
        f64_b100_dph: f64_b100,
    })
}

/// The recipes of the standard comparison at budget `m`: the exact model on 100 s means (the
/// default table's), both reductions on 100 s means, and fixed-size on the raw 1 Hz cycle.
pub fn standard_recipes(m: usize) -> Vec<Recipe> {
    let b = pipeline::TRAIN_BLOCK;
    vec![
        Recipe {
            reduction: None,
            block: b,
        },
        Recipe {
            reduction: Some((Reduction::FIXED_SIZE, m)),
            block: b,
        },
        Recipe {
            reduction: Some((Reduction::PRUNE, m)),
            block: b,
        },
        Recipe {
            reduction: Some((Reduction::PRUNE_REFIT, m)),
            block: b,
        },
        Recipe {
            reduction: Some((Reduction::FIXED_SIZE, m)),
            block: 1,
        },
    ]
}

/// Formats results as a plain-text table, with each model's board stability relative to the
/// first row's (the full model).
pub fn table(rows: &[HeldOut]) -> String {
    let mut s = format!(
        "{:<32} {:>7} {:>5} {:>8} {:>9} {:>11} {:>11} {:>11} {:>8}\n",
        "model",
        "train n",
        "SVs",
        "train s",
        "max|a|",
        "raw °/h",
        "board °/h",
        "f64 °/h",
        "vs full"
    );
    let full = rows.first().map_or(f64::NAN, |r| r.board_b100_dph);
    for r in rows {
        s += &format!(
            "{:<32} {:>7} {:>5} {:>8.3} {:>9.2e} {:>11.3e} {:>11.3e} {:>11.3e} {:>+7.1}%\n",
            r.label,
            r.train_samples,
            r.support_vectors,
            r.train_s,
            r.max_abs_alpha_dph,
            r.raw_b100_dph,
            r.board_b100_dph,
            r.f64_b100_dph,
            100.0 * (r.board_b100_dph / full - 1.0)
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On the reference run, the 64-vector fixed-size models hold the held-out 100 s stability
    /// within 5 % of the full model's (issue target), the board's f32 path agrees with the f64
    /// path, and they improve on the raw output.
    #[test]
    fn reduced_models_stay_within_5_percent_of_the_full_model() {
        let run = pipeline::dynamic_run().unwrap();
        let rows: Vec<HeldOut> = standard_recipes(64)
            .iter()
            .map(|r| held_out(&run, r, pipeline::SIGMA, pipeline::C).unwrap())
            .collect();
        let full = &rows[0];
        for r in &rows {
            assert!(r.support_vectors <= 64 || r.label.starts_with("exact"));
            assert!(
                (r.board_b100_dph / r.f64_b100_dph - 1.0).abs() < 0.01,
                "{}",
                table(&rows)
            );
        }
        // Fixed-size, on 100 s means and on raw 1 Hz. Pruning, plain or with refit, is
        // reported, not held to the target (CHANGELOG.md, "Reduced models": +499 %, +15 % with
        // a refit, on the reference run).
        for r in [&rows[1], &rows[4]] {
            assert!(r.board_b100_dph < 0.5 * r.raw_b100_dph, "{}", table(&rows));
            assert!(
                r.board_b100_dph <= 1.05 * full.board_b100_dph,
                "{}",
                table(&rows)
            );
        }
    }
}
