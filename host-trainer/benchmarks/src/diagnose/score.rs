//! Scoring one diagnosis against the truth sidecar.

use std::path::Path;

use super::detectability::{
    case_detectability, effect, noise_scale_peak, noise_sigmas, orthogonal_part,
};
use super::label::Label;
use super::result::{CaseResult, PValues};
use super::truth::{hidden_from_truth, read_truth, term_from_finding};
use super::BenchError;
use rlg_diagnose::candidates::Family;
use rlg_diagnose::linalg::dot;
use rlg_diagnose::locate::{iou, peak_mask};
use rlg_diagnose::prepare::{prepare, PhysicsModel};
use rlg_diagnose::variance::{heldout_variance, log_scale};
use rlg_diagnose::{heldout_metrics, Diagnosis};
use rlg_io::recording::Recording;
use rlg_physics::Term;

/// Scores one diagnosis from the truth sidecar (and the recording, for the block grid).
pub(super) fn score(
    id: usize,
    profile: String,
    rec: &Recording,
    truth_file: &Path,
    d: &Diagnosis,
    model: &PhysicsModel,
    seconds: f64,
) -> Result<CaseResult, BenchError> {
    let truth = read_truth(truth_file)?;
    let prep = prepare(rec)?;
    let hidden = hidden_from_truth(&truth);
    let predicted = Label::of(d);
    let (s1, s100) = noise_sigmas(&truth.scenario.noise);
    let mut r = CaseResult {
        id,
        profile,
        truth: hidden
            .as_ref()
            .map_or(Label::None, |t| Label::Mechanism(t.mechanism())),
        detectability: 0.0,
        detectability_marginal: 0.0,
        peak_over_sigma1: 0.0,
        energy_in_span: 0.0,
        predicted,
        param_ok: None,
        param_rel_err: None,
        param: None,
        iou: None,
        gain_fraction: None,
        seconds,
        best_delta_bic: CaseResult::best_of(d),
        p_values: PValues::of(d),
        alpha: 0.0,
        shift: 0,
    };
    let Some(h) = hidden else { return Ok(r) };
    r.p_values.true_family_alone = d
        .evidence
        .candidates
        .iter()
        .find(|c| c.mechanism == h.mechanism())
        .map(|c| c.p_value_alone);
    let e = effect(&h, &truth);
    let (dperp, e2, perp) = orthogonal_part(&prep, model, &e);
    r.detectability = case_detectability(&h, &truth, &prep, model).unwrap_or(f64::NAN);
    r.detectability_marginal = dperp / s100;
    r.peak_over_sigma1 = e.iter().fold(0.0f64, |a, v| a.max(v.abs())) / s1;
    r.energy_in_span = if e2 > 0.0 {
        1.0 - dperp * dperp / e2
    } else {
        0.0
    };
    // A noise scale: its effect is on the log-variance, whose constant the noise level takes.
    let perp = match &h {
        Term::Heteroscedastic { k, ref_c } => {
            let body = &truth.body_c[prep.range.clone()];
            r.detectability_marginal = r.detectability;
            r.peak_over_sigma1 = noise_scale_peak(&h, body, &truth.scenario.noise) / s1;
            let g = log_scale(body, *k, *ref_c);
            let m = g.iter().sum::<f64>() / g.len().max(1) as f64;
            let g2 = dot(&g, &g);
            r.energy_in_span = if g2 > 0.0 {
                m * m * g.len() as f64 / g2
            } else {
                0.0
            };
            log_scale(&prep.temp_b, *k, *ref_c)
                .iter()
                .map(|v| v - m)
                .collect()
        }
        _ => perp,
    };
    if r.predicted != r.truth {
        return Ok(r);
    }
    let fam = Family::from_name(h.name()).expect("hidden terms are candidate families");
    let (key, tol) = fam.key_parameter();
    let get = |t: &Term| t.parameters().into_iter().find(|p| p.0 == key).map(|p| p.1);
    let found = &d.findings[0];
    if let (Some(tv), Some(fv)) = (get(&h), found.parameters.get(key)) {
        let rel = ((fv - tv) / tv).abs();
        r.param_rel_err = Some(rel);
        r.param_ok = Some(rel <= tol);
        r.param = Some((
            tv,
            *fv,
            found.uncertainty.get(key).copied().unwrap_or(f64::NAN),
        ));
    }
    // Localisation: blocks whose centre lies in a finding span vs. the truth's orthogonal
    // effect at ≥ half its peak.
    let mask_d: Vec<bool> = prep
        .t_b
        .iter()
        .map(|t| {
            found
                .where_
                .iter()
                .any(|w| *t >= w.t_start_s && *t <= w.t_end_s)
        })
        .collect();
    r.iou = Some(iou(&mask_d, &peak_mask(&perp, 0.5)));
    if matches!(h, Term::Heteroscedastic { .. }) {
        // Held-out gain of the block log-variance model (the mean model is unchanged).
        if let (Some((b0, bt)), Some(t)) = (heldout_variance(&prep, &h), term_from_finding(d)) {
            if let Some((_, bd)) = heldout_variance(&prep, &t) {
                if b0 - bt > 0.0 {
                    r.gain_fraction = Some((b0 - bd) / (b0 - bt));
                }
            }
        }
        return Ok(r);
    }
    let base = heldout_metrics(&prep, model, None)?.rss_b;
    let truem = heldout_metrics(&prep, model, Some(&h))?.rss_b;
    if let Some(t) = term_from_finding(d) {
        let diag = heldout_metrics(&prep, model, Some(&t))?.rss_b;
        if base - truem > 0.0 {
            r.gain_fraction = Some((base - diag) / (base - truem));
        }
    }
    Ok(r)
}
