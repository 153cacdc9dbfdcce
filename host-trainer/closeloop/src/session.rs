//! `rlg close-loop`'s job: a recording (and optionally a later one), a diagnosis of its
//! training part (given, or made now against the paper's model), the suggested features, the
//! base and augmented models judged held out, and which one cross-validation adopts.

use std::fmt::Write as _;

use rlg_calibrate::CalibrateError;
use rlg_diagnose::{diagnose, DiagnoseError, Diagnosis, Options, PhysicsModel};
use rlg_io::recording::Recording;
use rlg_train::model::Provenance;

use crate::calibrate::CloseLoopError;
use crate::features::{augmented_features, Inputs, Suggestion};
use crate::score::{first_cycle_end_s, train_and_score, train_and_score_on, Protocol, Scored};

/// Where the held-out samples come from.
#[derive(Clone, Copy, Debug)]
pub enum HeldOutFrom<'a> {
    /// The samples of the recording after this time, s (`None`: the end of its first
    /// temperature cycle, the paper's protocol).
    After(Option<f64>),
    /// A later recording of the same gyro; all of the first trains.
    Test(&'a Recording),
}

/// What a close loop found and chose.
#[derive(Clone, Debug)]
pub struct Session {
    /// End of the training part, s.
    pub train_end_s: f64,
    /// Why there is no diagnosis, when the training part could not be diagnosed.
    pub undiagnosed: Option<String>,
    /// The diagnosis' verdict, when there is one.
    pub verdict: Option<rlg_diagnose::Verdict>,
    /// What each finding suggests.
    pub suggestions: Vec<Suggestion>,
    /// The paper's [T, dT/dt] model.
    pub base: Scored,
    /// The model on the augmented inputs (the base again when nothing was added).
    pub augmented: Scored,
    /// Whether cross-validation adopts the augmented model.
    pub adopted: bool,
}

impl Session {
    /// The adopted model: the augmented one, else the base.
    pub fn chosen(&self) -> &Scored {
        if self.adopted {
            &self.augmented
        } else {
            &self.base
        }
    }
}

/// Runs the close loop on `rec` (see the module doc). `diagnosis` is a diagnosis of the
/// training part made elsewhere; without it the training part is diagnosed here, and only
/// there, so that the held-out data judge a pipeline that never saw them.
pub fn close_loop(
    rec: &Recording,
    held_out: HeldOutFrom<'_>,
    diagnosis: Option<Diagnosis>,
    protocol: &Protocol,
    provenance: &Provenance,
) -> Result<Session, CloseLoopError> {
    let end = match held_out {
        HeldOutFrom::Test(_) => rec.time_s.last().copied().unwrap_or(f64::NAN),
        HeldOutFrom::After(Some(t)) => t,
        HeldOutFrom::After(None) => first_cycle_end_s(rec)?,
    };
    if !end.is_finite() {
        return Err(CalibrateError::Option("--to-s must be finite".to_string()).into());
    }
    let mut undiagnosed = None;
    let d = match diagnosis {
        Some(d) => Some(d),
        None => {
            let train_part = rec.head(rec.time_s.partition_point(|t| *t <= end));
            match diagnose(&train_part, &PhysicsModel::paper(), &Options::default()) {
                Ok(d) => Some(d),
                Err(e @ DiagnoseError::TooShort { .. }) => {
                    undiagnosed = Some(e.to_string());
                    None
                }
                Err(e) => return Err(e.into()),
            }
        }
    };
    let (feats, suggestions) = d
        .as_ref()
        .map_or_else(|| (Inputs::base(), Vec::new()), augmented_features);
    let score = |inputs: &Inputs| match held_out {
        HeldOutFrom::Test(t) => train_and_score_on(rec, t, inputs, protocol, provenance),
        HeldOutFrom::After(_) => train_and_score(rec, end, inputs, protocol, provenance),
    };
    let base = score(&Inputs::base())?;
    let augmented = if feats != Inputs::base() {
        score(&feats)?
    } else {
        base.clone()
    };
    Ok(Session {
        train_end_s: end,
        undiagnosed,
        verdict: d.map(|d| d.verdict),
        suggestions,
        adopted: protocol.adopts(&base, &augmented),
        base,
        augmented,
    })
}

/// What `rlg close-loop` prints: the diagnosis' suggestions, both models' figures and the
/// choice; `split` says what trained and what was judged.
pub fn session_text(s: &Session, split: &str) -> String {
    let mut out = String::new();
    if let Some(e) = &s.undiagnosed {
        let _ = writeln!(
            out,
            "the training data cannot be diagnosed ({e}): the [T, dT/dt] model only; \
             give a longer --to-s or a later recording with --test"
        );
    }
    for g in &s.suggestions {
        let _ = match g.feature {
            Some(f) => writeln!(
                out,
                "{} → feature {f} ({:?}): {}",
                g.mechanism, g.role, g.reason
            ),
            None => writeln!(out, "{} → no feature: {}", g.mechanism, g.reason),
        };
    }
    if let (Some(v), true) = (&s.verdict, s.suggestions.is_empty()) {
        let _ = writeln!(out, "the diagnosis names no missing mechanism ({v:?})");
    }
    let _ = writeln!(out, "{split}");
    for (name, m) in [("[T, dT/dt]", &s.base), ("augmented", &s.augmented)] {
        let f = m.inputs.describe();
        let _ = writeln!(
            out,
            "  {name:<11} {:<52} σ = {:.3}, c = {:.3e}: TRAINING rms {:.3e}, CV rms {:.3e}, HELD-OUT {:.4e} (board f32: {}, max |f32 − f64| {:.1e})",
            f.join(", "),
            m.sigma,
            m.c,
            m.train_rms_dph,
            m.cv_rms_dph,
            m.test_b100_dph,
            m.board_b100_dph
                .map_or("—".to_string(), |b| format!("{b:.4e}")),
            m.board_deviation_dph
        );
    }
    let _ = writeln!(
        out,
        "  {}: held-out change of the augmented model {:+.1} % (for the record; the held-out data do not decide)",
        if s.adopted {
            "augmented model ADOPTED (cross-validated error lower)"
        } else {
            "augmented model NOT adopted (cross-validated error not lower); [T, dT/dt] kept"
        },
        100.0 * (s.augmented.test_b100_dph / s.base.test_b100_dph - 1.0)
    );
    out
}
