//! One pass of the search, as a pipeline whose stages each take what they need and return
//! what they found:
//!
//! 1. the baseline: the model's linear parameters fitted to the block means ([`Baseline`]);
//! 2. the grid: every candidate point's block columns, and the noise-scale test
//!    ([`grid::Grid`]);
//! 3. the noise model the tests whiten and bootstrap by ([`noise_model::FittedNoise`]),
//!    fitted under the null after a first scan whitened by an AR fit;
//! 4. the scan of the grid in that whitening ([`crate::scan::scan`]) and its bootstrap
//!    thresholds ([`significance::Significance`]);
//! 5. each family's best point, judged in order of significance: its fit and held-out gain,
//!    its evidence that does not rest on the noise model, the single step and the record's
//!    own slow noise as other explanations ([`families`]);
//! 6. the report: located spans, the generic structure test, the finding and the verdict
//!    ([`report`]).
//!
//! A later pass (after a finding, with the term added to the model) runs the same pipeline
//! on what is left.

mod bump;
mod cache;
mod families;
mod grid;
mod line;
mod noise_model;
mod report;
mod significance;
mod slow;
mod step;

use super::baseline::Baseline;
use super::locate::phases;
use super::prepare::{PhysicsModel, Prepared};
use super::scan::{Generic, Scanned};
use super::score::heldout_metrics;
use super::{BlockSeries, DiagnoseError, Diagnosis, Evidence, Options};
use significance::Significance;

pub(crate) use cache::ColumnCache;

/// How the note on structure no term explains begins (a later pass' note is carried to the
/// diagnosis by it).
pub(crate) const UNEXPLAINED_LOOKS: &str = "what no library term explains looks like ";

/// What the note on a finding named beside another family's term says after the family's
/// name (carried from a later pass with its finding, whose other notes are not).
pub(crate) const ALONE_NO_GAIN: &str = "lowers no held-out error alone";
pub(crate) use step::step_times;

/// Which pass of the search a run is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Pass {
    /// The pass on the user's model.
    First,
    /// A pass after a finding, the term added to the model: it asks whether the findings
    /// account for the structure. `slow_drift`: the first pass found the generic structure
    /// to be the record's own slow noise (significant under white + B, not under rate random
    /// walk); a finding does not change that noise, so this pass asks under both too.
    Later {
        /// See [`Evidence::structure_slow_drift`](crate::Evidence::structure_slow_drift).
        slow_drift: bool,
    },
}

/// One pass of the search. On a later pass the generic test keeps its one null unless a
/// slow function of time fails the slow-drift check or the first pass found the generic
/// structure to be slow drift (see [`Pass`] and [`slow::structure_under_rrw`]).
pub(crate) fn run(
    prep: &Prepared,
    model: &PhysicsModel,
    opts: &Options,
    cache: &ColumnCache,
    pass: Pass,
) -> Result<Diagnosis, DiagnoseError> {
    let base = Baseline::fit(prep, model)?;
    let mut grid = grid::Grid::build(&base, cache)?;
    let mut notes = grid.reading_notes(prep);
    let generic = Generic::new(prep);
    let ar_fit = noise_model::first_pass_ar(&base, &grid.points, &generic);
    let white_level = grid
        .var
        .as_ref()
        .and_then(|v| v.white_level_in_time(&prep.t_b, super::score::cycle_folds(prep).is_some()));
    if let Some((level, w)) = &white_level {
        let (lo, hi) = w
            .iter()
            .fold((f64::INFINITY, 0.0_f64), |(a, b), v| (a.min(*v), b.max(*v)));
        notes.push(format!(
            "the 1 Hz white-noise level {} (its variance {lo:.2} to {hi:.2} times the \
             record's mean): the bootstrap draws the white noise at that level",
            level.describe(&prep.t_b)
        ));
    }
    let noise = noise_model::FittedNoise::fit(
        &base,
        &grid.points,
        white_level.map(|(_, w)| w),
        opts,
        &mut notes,
    );
    let whitener = noise.whitener(prep, &ar_fit);
    let scan = grid.scan(&whitener, &base, &generic);
    let scanned = Scanned {
        whitener: &whitener,
        scan: &scan,
        points: &grid.points,
    };
    let sig = Significance::new(&scanned, &noise, grid.var.as_ref(), prep, opts);
    let best = families::best_points(&scanned, &grid.families, &sig, prep, &mut notes);
    let judge = families::Judge {
        base: &base,
        scanned: &scanned,
        var: grid.var.as_ref(),
        noise: &noise,
        sig: &sig,
        opts,
        cache,
        base_ho: heldout_metrics(prep, model, None)?,
    };
    let judged = judge.judge(&best)?;
    notes.extend(judged.notes.iter().cloned());
    notes.extend(judged.unattributed_notes());
    let located = report::located(&base, &noise, opts);
    let question = report::StructureQuestion {
        base: &base,
        generic: &generic,
        scan: &scan,
        noise: &noise,
        sig: &sig,
        reasked: pass != Pass::Later { slow_drift: false } || !judged.slow_drift.is_empty(),
    };
    let structure = report::structure_test(&question, opts);
    notes.extend(structure.note.iter().cloned());
    let unexplained = structure.significant && judged.finding.is_none();
    // The shape reported is the best alternative of the scan whose null decided the test.
    let tested = structure.refit.as_ref().unwrap_or(&scan);
    let shape = unexplained.then(|| tested.unexplained(prep)).flatten();
    notes.extend(shape.as_ref().map(|s| {
        format!(
            "{UNEXPLAINED_LOOKS}{} (generic test p = {:.3}; the located spans say where)",
            s.describe(),
            structure.p_value
        )
    }));
    let findings = match &judged.finding {
        Some(found) => {
            let mut finding = report::finding(found, &judge)?;
            finding.close_alternatives = close_alternatives(&judged, &finding, opts);
            notes.extend(report::close_note(&judged.scores, &finding));
            vec![finding]
        }
        None => Vec::new(),
    };
    Ok(Diagnosis {
        verdict: report::verdict(&findings, judged.counted || structure.significant),
        baseline: judge.base_ho.figures.clone(),
        findings,
        located,
        phases: phases(prep),
        evidence: Evidence {
            noise_ar: ar_fit.phi.clone(),
            noise_sigma_dph: ar_fit.sigma,
            whitening: whitener.name().to_string(),
            noise_fit: noise.components(),
            noise_check: noise.check.clone(),
            notes,
            p_value: sig.floor(judged.p_counted.min(structure.p_value)),
            delta_bic_threshold: best
                .first()
                .map_or(f64::NEG_INFINITY, |&(f, _)| sig.threshold(f)),
            structure_threshold: sig.structure_threshold,
            structure_delta_bic: scan.gen_dbic,
            structure_p_value: structure.p_value,
            structure_slow_drift: structure.note.is_some(),
            step: judged.step,
            bump: judged.bump,
            rate_ramp: noise.ramp.clone(),
            unexplained: shape,
            candidates: judged.scores,
        },
        series: BlockSeries {
            unexplained_dph: if unexplained {
                tested.generic_fit(&generic, &base.cols_b)
            } else {
                Vec::new()
            },
            ..BlockSeries::default()
        },
    })
}

/// The families beside `finding` that are significant at α, lower the held-out residual,
/// fit within [`crate::CLOSE_DELTA_BIC`] of it and may be attributed.
fn close_alternatives(
    judged: &families::Judged,
    finding: &crate::Finding,
    opts: &Options,
) -> Vec<rlg_physics::Mechanism> {
    judged
        .scores
        .iter()
        .filter(|c| {
            c.mechanism != finding.mechanism
                && !judged
                    .unattributable
                    .iter()
                    .any(|f| f.mechanism() == c.mechanism)
                && c.p_value <= opts.alpha
                && c.heldout_gain > 0.0
                && c.delta_bic - finding.delta_bic < crate::CLOSE_DELTA_BIC
        })
        .map(|c| c.mechanism)
        .collect()
}
