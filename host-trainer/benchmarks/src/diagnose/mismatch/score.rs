//! Scoring a diagnosis of a mismatched case against what the case hid.

use super::gen::Case;
use super::hidden::Hidden;
use crate::diagnose::{CaseResult, Label, PValues};
use rlg_diagnose::candidates::Family;
use rlg_diagnose::Diagnosis;
use rlg_physics::Term;

/// The scored outcome: the truth label, D and the figures of the draw, the verdict, its
/// p-values, and for a correct identification of a library term its key parameter.
pub(super) fn score(case: &Case, d: &Diagnosis, seconds: f64, alpha: f64) -> CaseResult {
    let truth = case.hidden.label();
    let predicted = Label::of(d);
    let mut r = CaseResult {
        id: case.id,
        profile: case.describe(),
        truth,
        detectability: case.d,
        detectability_marginal: case.marginal,
        peak_over_sigma1: case.peak_over_sigma1,
        energy_in_span: case.energy_in_span,
        predicted,
        param_ok: None,
        param_rel_err: None,
        param: None,
        iou: None,
        gain_fraction: None,
        seconds,
        best_delta_bic: CaseResult::best_of(d),
        p_values: PValues::of(d),
        alpha,
        shift: 0,
    };
    let mechanism = match &case.hidden {
        Hidden::Library { term } => term.mechanism(),
        Hidden::Shaped { shape } => shape.family().mechanism(),
        _ => return r,
    };
    r.p_values.true_family_alone = d
        .evidence
        .candidates
        .iter()
        .find(|c| c.mechanism == mechanism)
        .map(|c| c.p_value_alone);
    // A form other than the term has no parameter comparable with the finding's.
    let Hidden::Library { term } = &case.hidden else {
        return r;
    };
    if r.predicted != r.truth {
        return r;
    }
    let Some(fam) = Family::from_name(term.name()) else {
        return r;
    };
    let (key, tol) = fam.key_parameter();
    let get = |t: &Term| t.parameters().into_iter().find(|p| p.0 == key).map(|p| p.1);
    let Some(found) = d.findings.first() else {
        return r;
    };
    if let (Some(tv), Some(fv)) = (get(term), found.parameters.get(key)) {
        let rel = ((fv - tv) / tv).abs();
        r.param_rel_err = Some(rel);
        r.param_ok = Some(rel <= tol);
        r.param = Some((
            tv,
            *fv,
            found.uncertainty.get(key).copied().unwrap_or(f64::NAN),
        ));
    }
    r
}
