//! The concealed-effect benchmark: recordings from the simulator with one hidden term each
//! (or none), concealed and set to a chosen detectability, diagnosed from the CSV alone and
//! scored from the truth sidecar alone.
//!
//! Detectability of a hidden effect e(t) (°/h) on a recording: the part of its 100 s means
//! ē (over the diagnosis' blocks) orthogonal to the baseline model's columns X (offset, T,
//! T², T³, Ṫ, Ṫ³, T·Ṫ on the recorded drive, the diagnosis' own design), measured in the
//! metric of the simulated noise's exact block-mean covariance Σ (from its parameters,
//! [`block_mean_autocov`]): D² = ēᵀ(Σ⁻¹ − Σ⁻¹X(XᵀΣ⁻¹X)⁻¹XᵀΣ⁻¹)ē. D is the signal-to-noise
//! ratio of the best test for that one effect with its shape and the noise known, i.e. what
//! no diagnosis can beat. The marginal ratio ‖P⊥ē‖/σ₁₀₀ (σ₁₀₀ the marginal σ of one 100 s
//! mean) is not the detectability: it ignores that the bias-instability bank makes
//! neighbouring means correlated (correlation times up to 10⁴ s), and it overstates D, most
//! for slow terms such as aging (up to two or three times); it is reported beside D
//! (`detectability_marginal`). For a bias term e is its contribution; for `sensor_lag`, e
//! is the true baseline driven by the body temperature minus the same baseline driven by
//! the lagged reading; for `temp_quantization` minus the same baseline driven by the
//! rounded reading (its dT/dt by the diagnosis' estimator). Concealment: the peak of e is
//! below half the 1 s noise σ.
//!
//! `heteroscedastic` changes no mean: its detectability is that of the best test for its
//! exact shape on the 1 Hz samples, D² = ½·Σ(gᵢ − ḡ)² with gᵢ = 2·ln(1 + k·xᵢ) the
//! log-variance it adds ([`heteroscedastic_detectability`]); concealed when the change of
//! the noise σ at its peak, σ_w·k·x_max, is below half the 1 s σ.

mod cases;
mod detectability;
mod label;
pub mod mismatch;
mod report;
mod result;
mod score;
#[cfg(test)]
mod tests;
mod truth;

pub use cases::{case_id, case_runs, case_simulation};
pub use label::Label;
pub use report::report_markdown;
pub use result::{CaseResult, PValues};
pub use truth::read_truth;

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use rlg_diagnose::candidates::Family;
use rlg_diagnose::prepare::PhysicsModel;
use rlg_diagnose::{diagnose, Options};
use rlg_io::recording::{write_atomic, Recording};
use rlg_simulate::{truth_path, write_simulation};
use score::score;

/// Benchmark size and seed.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchOptions {
    /// Master seed.
    pub seed: u64,
    /// Recordings per hidden term.
    pub per_term: usize,
    /// Recordings with nothing hidden.
    pub nulls: usize,
    /// Keep the recordings, their sidecars and their diagnoses in the output directory.
    pub keep: bool,
    /// False-alarm probability of the diagnosis' significance test.
    pub alpha: f64,
    /// Run only these hidden terms (None: nothing-hidden cases); empty: every case. Each
    /// case keeps its number, so a subset reproduces the full run's recordings.
    pub only: Vec<Option<Family>>,
    /// Samples cut from the start of each recording before it is diagnosed ([`cut_start`]).
    pub shift: usize,
    /// The diagnosis' [`Options::phases`].
    pub phases: usize,
}

impl BenchOptions {
    /// The full benchmark: 20 per term, 100 without a hidden term.
    pub fn full(seed: u64) -> Self {
        Self {
            seed,
            per_term: 20,
            nulls: 100,
            keep: false,
            alpha: Options::default().alpha,
            only: Vec::new(),
            shift: 0,
            phases: Options::default().phases,
        }
    }

    /// A quick run for tests: 2 per term, 8 without.
    pub fn quick(seed: u64) -> Self {
        Self {
            seed,
            per_term: 2,
            nulls: 8,
            keep: false,
            alpha: Options::default().alpha,
            only: Vec::new(),
            shift: 0,
            phases: Options::default().phases,
        }
    }
}

/// Why the benchmark failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BenchError {
    /// Simulation failed.
    #[error(transparent)]
    Scenario(#[from] rlg_simulate::ScenarioError),
    /// Reading or writing a recording failed.
    #[error(transparent)]
    Recording(#[from] rlg_io::recording::RecordingError),
    /// Diagnosis failed.
    #[error(transparent)]
    Diagnose(#[from] rlg_diagnose::DiagnoseError),
    /// The truth sidecar could not be read.
    #[error("{path}: {message}")]
    Truth {
        /// File.
        path: String,
        /// What went wrong.
        message: String,
    },
}

/// `rec` without its first `n` samples: the same recording, its 100 s blocks starting `n`
/// samples later. A verdict whose tests sit near a threshold can depend on where the blocks
/// start; diagnosing the same records cut by a few tens of samples measures how much.
pub fn cut_start(rec: &Recording, n: usize) -> std::borrow::Cow<'_, Recording> {
    if n == 0 {
        return std::borrow::Cow::Borrowed(rec);
    }
    let drop: Vec<bool> = (0..rec.time_s.len()).map(|i| i < n).collect();
    std::borrow::Cow::Owned(rec.without(&drop))
}

/// Runs the benchmark, writing recordings to `out_dir` (deleted after scoring unless kept).
pub fn run_benchmark(opts: &BenchOptions, out_dir: &Path) -> Result<Vec<CaseResult>, BenchError> {
    std::fs::create_dir_all(out_dir).map_err(|e| BenchError::Truth {
        path: out_dir.display().to_string(),
        message: e.to_string(),
    })?;
    let model = PhysicsModel::paper();
    let mut plan: Vec<Option<Family>> = Vec::new();
    for f in Family::ALL {
        plan.extend(std::iter::repeat_n(Some(f), opts.per_term));
    }
    plan.extend(std::iter::repeat_n(None, opts.nulls));
    let plan: Vec<(usize, Option<Family>)> = plan
        .into_iter()
        .enumerate()
        .filter(|(_, f)| opts.only.is_empty() || opts.only.contains(f))
        .collect();
    plan.into_par_iter()
        .map(|(id, fam)| {
            // The same recording as `case_simulation` gives the close loop and the tests.
            let (profile, _, sim) = case_simulation(id, fam, opts.seed)?;
            let csv: PathBuf = out_dir.join(format!("case{id:04}.csv"));
            write_simulation(&sim, &csv)?;
            // The diagnosis sees the CSV only.
            let rec = Recording::read_csv(&csv)?;
            let t0 = std::time::Instant::now();
            let dopts = Options {
                alpha: opts.alpha,
                phases: opts.phases,
                ..Options::default()
            };
            let d = diagnose(cut_start(&rec, opts.shift), &model, &dopts)?;
            let secs = t0.elapsed().as_secs_f64();
            // Scored on the whole recording: its truth sidecar describes all of it, and the
            // samples cut change its D by a share of the order of the shift over its length.
            let r = score(id, profile, &rec, &truth_path(&csv), &d, &model, secs).map(|mut r| {
                r.alpha = opts.alpha;
                r.shift = opts.shift;
                r
            });
            if opts.keep {
                write_report_beside(&csv, &d)?;
            } else {
                let _ = std::fs::remove_file(&csv);
                let _ = std::fs::remove_file(truth_path(&csv));
            }
            r
        })
        .collect()
}

/// Writes the diagnosis `d` of the kept recording `csv` beside it (`<stem>.diagnosis.json`),
/// as `rlg diagnose --json` writes it: why a case was missed is read there without
/// diagnosing the recording again.
pub(crate) fn write_report_beside(
    csv: &Path,
    d: &rlg_diagnose::Diagnosis,
) -> Result<(), BenchError> {
    let report = csv.with_extension("diagnosis.json");
    let json = serde_json::to_vec_pretty(d).map_err(|e| BenchError::Truth {
        path: report.display().to_string(),
        message: e.to_string(),
    })?;
    write_atomic(&report, &json)?;
    Ok(())
}
