//! One case's scored outcome and the verdict it implies at a smaller α.

use serde::{Deserialize, Serialize};

use super::label::Label;
use rlg_diagnose::Diagnosis;

/// The scored outcome of one recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaseResult {
    /// Case number.
    pub id: usize,
    /// Profile description.
    pub profile: String,
    /// The hidden mechanism, `none` when nothing is hidden.
    pub truth: Label,
    /// Detectability D (see the module doc), from the truth.
    pub detectability: f64,
    /// The marginal ratio ‖P⊥ē‖/σ₁₀₀ (orthogonal part over the marginal σ of a 100 s mean):
    /// it ignores the noise's correlation, so it overstates slow effects and understates fast
    /// ones (see the module doc).
    #[serde(default)]
    pub detectability_marginal: f64,
    /// Peak of the hidden effect over the 1 s noise σ (concealed when < 0.5).
    pub peak_over_sigma1: f64,
    /// Share of the effect's 100 s-mean energy inside the baseline's span.
    pub energy_in_span: f64,
    /// The diagnosis' top mechanism, or its verdict when it names none.
    pub predicted: Label,
    /// Key parameter within tolerance (only for correct identifications).
    pub param_ok: Option<bool>,
    /// Relative error of the key parameter.
    pub param_rel_err: Option<f64>,
    /// Key parameter: (true, found, reported 1σ uncertainty).
    pub param: Option<(f64, f64, f64)>,
    /// Time IoU of the finding's spans with the truth's (only for correct identifications).
    pub iou: Option<f64>,
    /// Held-out gain of the diagnosed model over the true model's (correct identifications).
    pub gain_fraction: Option<f64>,
    /// Diagnosis wall time, s.
    pub seconds: f64,
    /// Best candidate's ΔBIC and its bootstrap threshold (the evidence of the verdict).
    pub best_delta_bic: (Label, f64, f64),
    /// Bootstrap p-values behind the verdict: the best candidate's, the reported finding's
    /// (if any) and the generic structure test's. With them [`CaseResult::predicted_at`]
    /// gives the verdict at any α up to the one the benchmark ran at.
    #[serde(default)]
    pub p_values: PValues,
    /// The α the diagnosis ran at.
    #[serde(default)]
    pub alpha: f64,
    /// Samples cut from the start of the recording before it was diagnosed (its 100 s
    /// blocks start that much later; see [`super::cut_start`]).
    #[serde(default)]
    pub shift: usize,
}

/// See [`CaseResult::p_values`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PValues {
    /// The most significant candidate's p-value.
    pub best: f64,
    /// The finding's p-value (None: no finding).
    pub finding: Option<f64>,
    /// The generic structure test's p-value.
    pub structure: f64,
    /// The verdict's p-value: the smallest α at which it would not be `none` (None in
    /// results written before it was reported: then the smaller of `best` and `structure`).
    #[serde(default)]
    pub verdict: Option<f64>,
    /// The true family's p-value had it been the only family tested (None: nothing hidden).
    #[serde(default)]
    pub true_family_alone: Option<f64>,
}

impl PValues {
    /// The p-values of a diagnosis (`true_family_alone` is the scorer's, left None).
    pub fn of(d: &Diagnosis) -> Self {
        PValues {
            best: d.evidence.candidates.first().map_or(1.0, |c| c.p_value),
            finding: d.findings.first().and_then(|f| {
                d.evidence
                    .candidates
                    .iter()
                    .find(|c| c.mechanism == f.mechanism)
                    .map(|c| c.p_value)
            }),
            structure: d.evidence.structure_p_value,
            verdict: Some(d.evidence.p_value),
            true_family_alone: None,
        }
    }
}

impl CaseResult {
    /// The best candidate of a diagnosis, its ΔBIC and the threshold it was compared with.
    pub fn best_of(d: &Diagnosis) -> (Label, f64, f64) {
        d.evidence
            .candidates
            .first()
            .map_or((Label::None, 0.0, 0.0), |c| {
                (
                    Label::Mechanism(c.mechanism),
                    c.delta_bic,
                    d.evidence.delta_bic_threshold,
                )
            })
    }

    /// The verdict the diagnosis would give at a smaller false-alarm probability `alpha`
    /// (for `alpha` ≥ the run's α, the run's verdict). Exact up to the bootstrap's
    /// resolution: candidates are significant in the order of their ΔBIC, so at a smaller α
    /// the finding is the run's finding if its p-value is at most α, and otherwise there is
    /// none (every candidate before it failed its held-out check).
    pub fn predicted_at(&self, alpha: f64) -> Label {
        if alpha >= self.alpha {
            return self.predicted;
        }
        let p = &self.p_values;
        if p.finding.is_some_and(|v| v <= alpha) {
            self.predicted
        } else if p.verdict.unwrap_or(p.best.min(p.structure)) <= alpha {
            Label::Unexplained
        } else {
            Label::None
        }
    }
}
