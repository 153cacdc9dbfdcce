//! What a pass reports besides its families' scores: where the baseline residual departs
//! from the noise, the generic structure test on the verdict's scale, the finding in the
//! contract's terms, and the verdict.

use std::collections::BTreeMap;

use super::families::{Fitted, Judge};
use super::noise_model::FittedNoise;
use super::significance::Significance;
use super::slow::{
    noise_beside, structure_beside, structure_under, structure_under_rrw, Refit,
    STRUCTURE_RRW_BELOW,
};
use crate::baseline::Baseline;
use crate::candidates::Family;
use crate::explain::explain;
use crate::linalg::{combine, Basis};
use crate::locate::{moving_average, peak_mask, spans};
use crate::noise::replicates::{replicate_rng, simulate_block_means};
use crate::ramp::neg2_log_likelihood;
use crate::scan::{Generic, Scan};
use crate::score::{nonlinear_of, ModelColumns};
use crate::{CandidateScore, DiagnoseError, Finding, Options, Span, Verdict};
use rlg_simulate::noise::NoiseParams;

/// Moving average (blocks) and threshold (σ of that average under the noise model) that
/// mark a located span of the baseline residual.
const LOCATE_WINDOW: usize = 5;
const LOCATE_Z: f64 = 3.5;

/// Spans where the moving average of the baseline residual's block means exceeds
/// [`LOCATE_Z`] times its σ under the fitted noise (that σ from a long simulation of it).
/// Where the white level changes in time, the white part of that σ's square follows the
/// level's moving average (a window's white variance is the mean of its blocks' over the
/// window's length).
pub(super) fn located(base: &Baseline<'_>, noise: &FittedNoise, opts: &Options) -> Vec<Span> {
    let prep = base.prep;
    let block_s = prep.block as f64 * prep.dt_s;
    let var_ma = {
        let sim = simulate_block_means(
            &noise.gyro,
            20_000,
            block_s,
            &mut replicate_rng(opts.seed ^ 0xa11ce, 0),
            opts.seed ^ 0xa11ce,
        );
        let ma = moving_average(&sim, LOCATE_WINDOW);
        ma.iter().map(|v| v * v).sum::<f64>() / ma.len() as f64
    };
    let white_ma = (noise.gyro.arw_dph_rt_h * 60.0).powi(2) / block_s / LOCATE_WINDOW as f64;
    let level = noise
        .white_level
        .as_ref()
        .map(|w| moving_average(w, LOCATE_WINDOW));
    let ma = moving_average(&base.resid_b, LOCATE_WINDOW);
    let mask: Vec<bool> = ma
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let var = level.as_ref().map_or(var_ma, |l| {
                (var_ma + white_ma * (l[i] - 1.0)).max(f64::MIN_POSITIVE)
            });
            v.abs() > LOCATE_Z * var.sqrt()
        })
        .collect();
    spans(prep, &mask, 2, &base.resid_b)
}

/// What the generic structure test is asked with.
pub(super) struct StructureQuestion<'a> {
    /// The model's fit.
    pub(super) base: &'a Baseline<'a>,
    /// The generic columns.
    pub(super) generic: &'a Generic,
    /// The pass's scan (its generic ΔBIC).
    pub(super) scan: &'a Scan,
    /// The fitted noise.
    pub(super) noise: &'a FittedNoise,
    /// The pass's significance scale.
    pub(super) sig: &'a Significance,
    /// Whether it is asked again under rate random walk: on the first pass, or where a slow
    /// function of time has just failed the slow-drift check (the drift it saw is then in
    /// the time chunks too, and under white + B alone it passed as structure the findings
    /// leave behind), or where the first pass found the generic structure to be slow drift
    /// ([`super::Pass::Later`]). A later pass otherwise keeps the test's one null.
    pub(super) reasked: bool,
}

/// The generic structure test's outcome.
pub(super) struct Structure {
    /// Its p-value on the verdict's scale.
    pub(super) p_value: f64,
    /// Whether it is significant at α.
    pub(super) significant: bool,
    /// Set where white + B found structure that the record's slow noise explains.
    pub(super) note: Option<String>,
    /// The scan under the refitted noise, where the test was asked beside an alternative.
    pub(super) refit: Option<Scan>,
}

/// The generic test asked again under the pass's noise refitted beside its best
/// alternative, where that is a step or a window in time (see [`structure_beside`] and
/// [`beside_which`]); `None` for any other best alternative, a noise model with a rate ramp,
/// a record too long for the GLS factor, or a pass that does not ask the test again under
/// rate random walk, where the pass's own null stands. Only beside that second null:
/// refitted beside a step, slow noise that one record cannot tell from a step is taken out
/// of the replicates, and on the passes after a right finding (1/f and rate random walk in
/// the record) the step alternative overturned it at p well under α.
fn structure_beside_best(q: &StructureQuestion<'_>, opts: &Options) -> Option<Refit> {
    if !q.reasked || q.noise.ramp.is_some() {
        return None;
    }
    let best = q
        .scan
        .gen_best
        .filter(|&i| q.generic.is_step_or_window(i))?;
    let (prep, white_level) = (q.base.prep, q.noise.white_level.as_deref());
    if q.noise.gyro.rrw_dph_per_rt_h > 0.0 {
        let g = beside_which(q)?;
        return structure_under(prep, &q.base.cols_b, &g, q.generic, white_level, opts);
    }
    structure_beside(
        prep,
        &q.base.cols_b,
        q.generic.columns(best, prep.nb()),
        q.generic,
        white_level,
        opts,
        false,
    )
}

/// The noise with rate random walk refitted beside the likeliest of the pass's best step,
/// best boxcar and best smooth window in time (−2 ln L of the block means under each one's
/// own REML noise, its fixed effects profiled by GLS, a window charged ln n for its second
/// edge); `None` where no refit keeps rate random walk, so the pass's null stands.
///
/// Under the pass's noise K whitens the record nearly to its differences, and there a step
/// hours away from a bump in time can fit about as well as the bump; refitted beside that
/// step, the noise keeps the bump as wander. Fitted together with the noise, the bump's own
/// window is the likelier.
fn beside_which(q: &StructureQuestion<'_>) -> Option<NoiseParams> {
    let prep = q.base.prep;
    let nb = prep.nb();
    let refit = |i: usize| {
        let alt = q.generic.columns(i, nb);
        let g = noise_beside(prep, &q.base.cols_b, alt.clone(), true)?;
        let cols: Vec<Vec<f64>> = q.base.cols_b.iter().cloned().chain(alt).collect();
        let l = neg2_log_likelihood(&g, &cols, &prep.y_b, prep.block, prep.dt_s)?;
        let edge = if q.generic.is_window(i) {
            (nb as f64).ln()
        } else {
            0.0
        };
        Some((g, l + edge))
    };
    q.scan
        .gen_tops
        .iter()
        .filter_map(|&i| refit(i))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(g, _)| g)
}

/// The generic structure test on the verdict's scale, the larger of its p-values under
/// the pass's noise (refitted beside a step or window, [`structure_beside_best`]) and under
/// rate random walk where the second is asked (see [`StructureQuestion::reasked`]).
pub(super) fn structure_test(q: &StructureQuestion<'_>, opts: &Options) -> Structure {
    let sig = q.sig;
    let beside = structure_beside_best(q, opts);
    let p1 = beside.as_ref().map_or(sig.structure_alone, |r| r.p_value);
    let p_rrw = (q.reasked && q.noise.without_slow_noise() && p1 <= STRUCTURE_RRW_BELOW)
        .then(|| {
            let best = q
                .scan
                .gen_best
                .filter(|&i| q.generic.is_window(i))
                .map_or_else(Vec::new, |i| q.generic.columns(i, q.base.prep.nb()));
            structure_under_rrw(
                q.base.prep,
                &q.base.cols_b,
                best,
                q.generic,
                q.noise.white_level.as_deref(),
                opts,
            )
        })
        .flatten();
    let p_value = sig.floor(sig.structure_p(p_rrw.map_or(p1, |p| p1.max(p))));
    // Refitted beside the best alternative, the test has its own null: its p-value decides.
    let significant =
        (beside.is_some() || q.scan.gen_dbic < sig.structure_threshold) && p_value <= opts.alpha;
    let note = p_rrw
        .map(|p| (sig.structure_p(p1), sig.structure_p(p)))
        .filter(|(p1, p)| *p1 <= opts.alpha && *p > opts.alpha)
        .map(|(p1, q)| {
            format!(
                "the generic structure test (time chunks, temperature and dT/dt bands, steps, \
                 windows in time and temperature) is significant under white noise and bias instability (p = \
                 {p1:.3}) but not under the same record's noise refitted with rate random walk \
                 (p = {q:.3}): slow drift, not separable from the record's own slow noise in a \
                 record this long"
            )
        });
    Structure {
        p_value,
        significant,
        note,
        refit: beside.map(|r| r.scan),
    }
}

/// The finding in the contract's terms: its parameters, where its fitted effect is at least
/// half its peak (for the noise scale, its log-variance change), and the plain-words
/// explanation.
pub(super) fn finding(found: &Fitted, judge: &Judge<'_>) -> Result<Finding, DiagnoseError> {
    let (f, i, term) = (found.family, found.point, &found.term);
    let base = judge.base;
    let prep = base.prep;
    let effect: Vec<f64> = match (f, judge.var) {
        (Family::Heteroscedastic, Some(v)) => v.effect(term),
        _ => {
            let cols_b = ModelColumns::new(
                prep,
                base.model,
                &base.drive,
                nonlinear_of(term).as_ref().map(|(f, nl)| (*f, &nl[..])),
            )?
            .blocks()?;
            let full = Basis::new(&cols_b);
            let nb = prep.nb();
            let fit1 = combine(&cols_b, &full.coefficients(&prep.y_b), nb);
            let fit0 = combine(&base.cols_b, &base.beta_b, nb);
            fit1.iter().zip(&fit0).map(|(a, b)| a - b).collect()
        }
    };
    let where_ = spans(prep, &peak_mask(&effect, 0.5), 2, &effect);
    let mut parameters = BTreeMap::new();
    for (k, v) in term.parameters() {
        parameters.insert(k, v);
    }
    let mut finding = Finding {
        mechanism: f.mechanism(),
        parameters,
        uncertainty: found.unc.clone(),
        where_,
        delta_bic: judge.scanned.scan.dbic[i],
        improved: found.heldout.figures.clone(),
        explanation: String::new(),
        close_alternatives: Vec::new(),
    };
    finding.explanation = explain(
        f,
        &finding,
        (judge.sig.threshold(f), judge.base.block_s()),
        &judge.base_ho.figures,
    );
    Ok(finding)
}

/// The verdict: a finding names missing physics; otherwise significant structure (a family
/// that counts, or the generic test) is unexplained; otherwise the record is consistent.
pub(super) fn verdict(findings: &[Finding], significant: bool) -> Verdict {
    if !findings.is_empty() {
        Verdict::MissingPhysics
    } else if significant {
        Verdict::UnexplainedStructure
    } else {
        Verdict::Consistent
    }
}

/// The note on a finding's close alternatives, each with its ΔBIC and held-out gain beside
/// the finding's.
pub(super) fn close_note(scores: &[CandidateScore], finding: &Finding) -> Option<String> {
    let score = |m| scores.iter().find(|c| c.mechanism == m);
    let own = score(finding.mechanism)?;
    let rivals: Vec<String> = finding
        .close_alternatives
        .iter()
        .filter_map(|&m| score(m))
        .map(|c| {
            format!(
                "{} (ΔBIC {:.1}, held-out gain {:.2e} (°/h)²)",
                c.mechanism.name(),
                c.delta_bic,
                c.heldout_gain
            )
        })
        .collect();
    (!rivals.is_empty()).then(|| {
        format!(
            "{} (ΔBIC {:.1}, held-out gain {:.2e} (°/h)²) is the finding, but {} {} nearly as \
             well: a ΔBIC difference under {} is less than strong evidence, so this record does \
             not tell them apart well",
            finding.mechanism.name(),
            own.delta_bic,
            own.heldout_gain,
            rivals.join(" and "),
            if rivals.len() == 1 { "fits" } else { "fit" },
            crate::CLOSE_DELTA_BIC
        )
    })
}
