//! What a pass reports besides its families' scores: where the baseline residual departs
//! from the noise, the generic structure test on the verdict's scale, the finding in the
//! contract's terms, and the verdict.

use std::collections::BTreeMap;

use super::families::{Fitted, Judge};
use super::noise_model::FittedNoise;
use super::significance::Significance;
use super::slow::{structure_beside, STRUCTURE_REFIT_BELOW};
use crate::baseline::Baseline;
use crate::candidates::Family;
use crate::explain::explain;
use crate::linalg::{combine, Basis};
use crate::locate::{moving_average, peak_mask, spans};
use crate::noise::replicates::{replicate_rng, simulate_block_means};
use crate::scan::{Generic, Scan};
use crate::score::{nonlinear_of, ModelColumns};
use crate::{CandidateScore, DiagnoseError, Finding, Options, Span, Verdict};

/// Moving average (blocks) and threshold (σ of that average under the noise model) that
/// mark a located span of the baseline residual.
const LOCATE_WINDOW: usize = 5;
const LOCATE_Z: f64 = 3.5;

/// Spans where the moving average of the baseline residual's block means exceeds
/// [`LOCATE_Z`] times its σ under the fitted noise (that σ from a long simulation of it).
pub(super) fn located(base: &Baseline<'_>, noise: &FittedNoise, opts: &Options) -> Vec<Span> {
    let prep = base.prep;
    let sigma_ma = {
        let sim = simulate_block_means(
            &noise.gyro,
            20_000,
            prep.block as f64 * prep.dt_s,
            &mut replicate_rng(opts.seed ^ 0xa11ce, 0),
            opts.seed ^ 0xa11ce,
        );
        let ma = moving_average(&sim, LOCATE_WINDOW);
        (ma.iter().map(|v| v * v).sum::<f64>() / ma.len() as f64).sqrt()
    };
    let ma = moving_average(&base.resid_b, LOCATE_WINDOW);
    let mask: Vec<bool> = ma.iter().map(|v| v.abs() > LOCATE_Z * sigma_ma).collect();
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
    pub(super) slow_drift: Option<String>,
    /// Set where the test is significant under the noise refitted beside the windows in
    /// time only.
    pub(super) beside_windows: Option<String>,
}

/// The generic structure test on the verdict's scale. Where its p-value under the pass's
/// noise is at most [`STRUCTURE_REFIT_BELOW`] and no rate ramp stands in that noise, it is
/// asked again under the noise refitted beside the windows in time that fit best (see
/// [`structure_beside`]):
///
/// - where the pass's noise has rate random walk, under that noise refitted (or under
///   white + B, where beside the windows the likeliest K is 0), in place of the first
///   p-value;
/// - where it has none and the test is re-asked (see [`StructureQuestion::reasked`]), also
///   under rate random walk, the larger p-value counting; K is refitted beside the windows
///   only where a window is the best alternative. Beside a step it is not: a step is the
///   shape the wander itself takes over a record, and refitted beside the windows wherever
///   the best alternative was a step, clean records with rate random walk and a noise level
///   that changes in time were flagged (1 of 60 more on one seed; earlier, K refitted beside
///   the step itself, 3 of 60 more on another).
///
/// Under white + B the first p-value stands: refitted beside the windows, B fell on clean
/// records with 1/f-like wander, and 3 of 60 more were flagged on one seed.
pub(super) fn structure_test(q: &StructureQuestion<'_>, opts: &Options) -> Structure {
    let (sig, p1) = (q.sig, q.sig.structure_alone);
    let prep = q.base.prep;
    let windows = &q.scan.win_best;
    let beside =
        |w: &[usize], rrw: bool| structure_beside(prep, &q.base.cols_b, w, q.generic, rrw, opts);
    let asked = p1 <= STRUCTURE_REFIT_BELOW && q.noise.ramp.is_none();
    let (refitted, p_rrw) = match (asked, q.noise.without_slow_noise()) {
        (false, _) => (None, None),
        (true, true) => {
            let best_is_window = q.scan.gen_best.is_some_and(|i| q.generic.is_window(i));
            let w: &[usize] = if best_is_window { windows } else { &[] };
            let p = q.reasked.then(|| beside(w, true)).flatten();
            (None, p.map(|r| r.p_value))
        }
        (true, false) if !windows.is_empty() => (
            beside(windows, true).or_else(|| beside(windows, false)),
            None,
        ),
        (true, false) => (None, None),
    };
    let p_main = refitted.as_ref().map_or(p1, |r| r.p_value);
    let p_value = sig.floor(sig.structure_p(p_rrw.map_or(p_main, |p| p_main.max(p))));
    let significant =
        (refitted.is_some() || q.scan.gen_dbic < sig.structure_threshold) && p_value <= opts.alpha;
    let slow_drift = p_rrw
        .map(|p| (sig.structure_p(p_main), sig.structure_p(p)))
        .filter(|(p1, p)| *p1 <= opts.alpha && *p > opts.alpha)
        .map(|(p1, q)| {
            format!(
                "the generic structure test (time chunks, temperature and dT/dt bands, steps, \
                 windows in time) is significant under white noise and bias instability (p = \
                 {p1:.3}) but not under the same record's noise refitted with rate random walk \
                 (p = {q:.3}): slow drift, not separable from the record's own slow noise in a \
                 record this long"
            )
        });
    let beside_windows = refitted.filter(|_| significant).map(|r| {
        format!(
            "under the noise fitted to the model's residual (K = {:.2e} °/h/√h) the generic \
             structure test has p = {:.3}; under the noise refitted beside the {} in time that \
             fit best ({}) it has p = {:.3}: the noise had taken a transient as wander",
            q.noise.gyro.rrw_dph_per_rt_h,
            sig.structure_p(p1),
            if windows.len() == 1 {
                "window"
            } else {
                "windows"
            },
            match r.noise.rrw_dph_per_rt_h {
                0.0 => "no rate random walk".to_string(),
                k => format!("K = {k:.2e} °/h/√h"),
            },
            p_value
        )
    });
    Structure {
        p_value,
        significant,
        slow_drift,
        beside_windows,
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
