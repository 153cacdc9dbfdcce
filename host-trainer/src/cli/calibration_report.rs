//! `rlg calibration-report`: the p-value calibration of clean recordings pooled over several
//! runs of `rlg benchmark-diagnose` (seeds, block phases), as a table and a figure.

use std::path::PathBuf;

use rlg_benchmarks::diagnose::mismatch::{calibration_markdown, calibration_png_of, clean_results};
use rlg_benchmarks::diagnose::CaseResult;

/// Largest `results.json` read: a full run of either set writes well under 1 MB, so a larger
/// file is the wrong one, and reading it whole could exhaust the machine.
const MAX_RESULTS_BYTES: u64 = 64 << 20;

/// Arguments of `rlg calibration-report`.
#[derive(Debug, clap::Args)]
pub struct CalibrationReportArgs {
    /// Output directories of `rlg benchmark-diagnose` runs (each holds `results.json`); their
    /// clean recordings are pooled.
    #[arg(required = true, value_name = "RUN_DIR")]
    pub runs: Vec<PathBuf>,
    /// The set's name for the figure's caption.
    #[arg(long, default_value = "benchmark")]
    pub set: String,
    /// Write `calibration.md` and `calibration.png` here.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// Runs the subcommand.
pub fn run(args: &CalibrationReportArgs) -> anyhow::Result<()> {
    let mut clean: Vec<CaseResult> = Vec::new();
    let mut alphas = Vec::new();
    for dir in &args.runs {
        let path = dir.join("results.json");
        let size = std::fs::metadata(&path)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
            .len();
        anyhow::ensure!(
            size <= MAX_RESULTS_BYTES,
            "{}: {size} bytes is not a benchmark's results.json (at most {MAX_RESULTS_BYTES})",
            path.display()
        );
        let text = std::fs::read_to_string(&path)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        let c = clean_results(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        alphas.extend(c.iter().map(|r| r.alpha));
        clean.extend(c);
    }
    anyhow::ensure!(
        !clean.is_empty(),
        "no clean recordings in the runs given ({})",
        args.runs.len()
    );
    // Pooling runs made at different α would read each at a different exactness.
    let (lo, hi) = alphas
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(l, h), a| (l.min(*a), h.max(*a)));
    anyhow::ensure!(
        hi - lo < 1e-12,
        "the runs were made at different α ({lo} … {hi}); pool runs of one α"
    );
    std::fs::create_dir_all(&args.out)?;
    let refs: Vec<&CaseResult> = clean.iter().collect();
    let md = format!(
        "{} runs pooled: {}\n{}",
        args.runs.len(),
        args.runs
            .iter()
            .map(|d| format!("`{}`", d.display()))
            .collect::<Vec<_>>()
            .join(", "),
        calibration_markdown(&refs)
    );
    rlg_io::recording::write_atomic(&args.out.join("calibration.md"), md.as_bytes())?;
    calibration_png_of(&refs, &args.set, &args.out.join("calibration.png"))?;
    println!("{md}");
    Ok(())
}
