//! `rlg benchmark-diagnose`: the concealed-effect benchmark of the diagnosis, on the
//! simulator's recordings (`matched`) or on an independent generator's (`mismatched`).

use std::path::{Path, PathBuf};

use clap::ValueEnum;
use rlg_benchmarks::diagnose::mismatch::{
    calibration_png, calibration_png_of, detection_png, mismatch_report_markdown, run_mismatched,
    Kind, MismatchOptions, Variant,
};
use rlg_benchmarks::diagnose::{report_markdown, run_benchmark, BenchOptions, CaseResult, Label};

/// Which recordings the benchmark diagnoses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Set {
    /// The simulator's: the noise model, thermal model and profiles the diagnosis assumes.
    Matched,
    /// An independent generator's: other profiles, chamber control, a two-node body, noise
    /// the diagnosis' model does not describe, and effects outside the term library.
    Mismatched,
}

/// Arguments of `rlg benchmark-diagnose`.
#[derive(Debug, clap::Args)]
pub struct BenchmarkDiagnoseArgs {
    /// Master seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Working directory for the recordings; `results.json` and `report.md` are written here.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the report (`report.md`) to this file, e.g. a results file kept in the
    /// repository, after a first line naming the command that wrote it.
    #[arg(long, value_name = "FILE")]
    pub results_md: Option<PathBuf>,
    /// Which recordings: the simulator's (`matched`) or the independent generator's
    /// (`mismatched`; also writes `calibration.png` and the detection curve `detection.png`).
    #[arg(long, value_enum, default_value_t = Set::Matched)]
    pub set: Set,
    /// A few recordings per term: 2 instead of 20 (mismatched: 12) per term, 8 instead of
    /// 100 (mismatched: 60) without a hidden term.
    #[arg(long)]
    pub quick: bool,
    /// Keep the recordings, their truth sidecars and their diagnoses (`<name>.diagnosis.json`,
    /// as `rlg diagnose --json` writes them).
    #[arg(long)]
    pub keep: bool,
    /// False-alarm probability of the diagnosis' significance test (default: the
    /// diagnosis' own); the matched report adds the verdicts at every smaller α of
    /// 0.25 … 5 %, the mismatched one its calibration at 1, 2, 5 and 10 % (exact up to this α).
    #[arg(long)]
    pub alpha: Option<f64>,
    /// Only the cases hiding these terms (library names, comma-separated; `none` for the
    /// cases with nothing hidden; in the mismatched set also `step` and `rate_squared`, the
    /// effects outside the library, and with `--outside-kinds` `bump_in_time`, `telegraph`
    /// and `bump_in_temperature`). Each case keeps its number and recording.
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
    /// Mismatched set only: hide warm-up, aging, mode hop, backscatter, periodic, hysteresis
    /// and gradient lag in forms other than the library's terms (two-exponential and
    /// power-law warm-ups, logarithmic and square-root aging, …); the report adds top-1 by
    /// form.
    #[arg(long)]
    pub other_shapes: bool,
    /// Mismatched set only: drive each hidden mechanism of the bias by the body's other node
    /// (the core when the sensor is on the case, the case when it is on the core), not the
    /// node the temperature sensor reads; the base bias stays on the sensor's node.
    #[arg(long)]
    pub effect_elsewhere: bool,
    /// Mismatched set only: beside each hidden library term of the bias, a second term of
    /// another mechanism at a detectability of its own; the report adds how often each of
    /// the two is found.
    #[arg(long)]
    pub two_effects: bool,
    /// Mismatched set only: one artefact of a chamber's data logger on each recording
    /// (dropouts of minutes, short gaps, means of a few seconds, Unix time stamps from a
    /// drifting, jittery clock, temperature readings at a sensor's error values); each case
    /// keeps its conditions, hidden effect and D, and the report counts each artefact.
    #[arg(long)]
    pub logger: bool,
    /// Mismatched set only: the temperature read at a 9- to 12-bit sensor's quantum (0.5,
    /// 0.25, 0.125 or 0.0625 °C) beside each hidden effect; the report adds how often the
    /// effect is found beside the reading's artefact.
    #[arg(long)]
    pub coarse_reading: bool,
    /// Mismatched set only: on the clean recordings, a white noise level that drifts, steps
    /// or passes through 0.5–2.5× its level in time, unrelated to temperature; the report
    /// adds how often it is named `heteroscedastic`.
    #[arg(long)]
    pub noise_in_time: bool,
    /// Mismatched set only: after the clean recordings, 12 each of three more effects
    /// outside the library (a transient bump in time, a random telegraph, a bump at one
    /// temperature; `--only bump_in_time,telegraph,bump_in_temperature` runs them alone).
    #[arg(long)]
    pub outside_kinds: bool,
    /// Diagnose each recording without its first N samples (0–3600): the same records with
    /// their 100 s blocks starting N samples later, to measure how much the verdicts depend
    /// on where the blocks start. Scored against the whole recording's truth.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u16).range(0..=3600))]
    pub shift: u16,
    /// Block phases a verdict near its threshold is decided over (`rlg diagnose --phases`).
    #[arg(long, default_value_t = rlg_diagnose::Options::default().phases as u8,
          value_parser = clap::value_parser!(u8).range(1..=5))]
    pub phases: u8,
}

/// The α given on the command line, checked against what the bootstrap resolves.
fn checked_alpha(alpha: Option<f64>) -> anyhow::Result<Option<f64>> {
    let Some(a) = alpha else { return Ok(None) };
    anyhow::ensure!(
        a > 0.0 && a < 1.0,
        "--alpha must lie strictly between 0 and 1, got {a}"
    );
    let b = rlg_diagnose::Options::default().bootstrap;
    anyhow::ensure!(
        a * b as f64 >= 1.0,
        "--alpha {a} is below what the diagnosis' {b} bootstrap replicates resolve (1/{b})"
    );
    Ok(Some(a))
}

/// The flags of `rlg benchmark-diagnose` that take a path, with their placeholders.
const PATH_FLAGS: &[(&str, &str)] = &[("--out", "DIR"), ("--results-md", "FILE")];

/// The first line of the results file: this command, and the quick set named as such.
fn results_header(args: &BenchmarkDiagnoseArgs) -> String {
    super::results::header(
        std::env::args(),
        PATH_FLAGS,
        args.quick
            .then_some("the quick set: a few recordings per term, a check rather than a measure"),
    )
}

/// Writes `results.json` and `report.md` (`md`) into `out`, and `md` after the line
/// `header` to `results_md`.
fn write_report(
    out: &Path,
    results_json: &str,
    md: &str,
    results_md: Option<(&Path, &str)>,
) -> anyhow::Result<()> {
    rlg_io::recording::write_atomic(&out.join("results.json"), results_json.as_bytes())?;
    rlg_io::recording::write_atomic(&out.join("report.md"), md.as_bytes())?;
    if let Some((p, header)) = results_md {
        super::results::write(p, header, md)?;
    }
    Ok(())
}

/// Runs the subcommand.
pub fn run(args: &BenchmarkDiagnoseArgs) -> anyhow::Result<()> {
    // Checked before the run, which takes minutes.
    if let Some(p) = &args.results_md {
        super::check_output_file(p, "--results-md")?;
    }
    if args.set == Set::Mismatched {
        return run_mismatched_set(args);
    }
    anyhow::ensure!(
        !args.other_shapes && !args.effect_elsewhere && !args.logger,
        "--other-shapes, --effect-elsewhere and --logger apply to --set mismatched only"
    );
    let mut opts = if args.quick {
        BenchOptions::quick(args.seed)
    } else {
        BenchOptions::full(args.seed)
    };
    opts.keep = args.keep;
    opts.shift = usize::from(args.shift);
    opts.phases = usize::from(args.phases);
    for name in &args.only {
        opts.only.push(match name.as_str() {
            "none" => None,
            n => Some(rlg_diagnose::Family::from_name(n).ok_or_else(|| {
                let known: Vec<&str> = rlg_diagnose::Family::ALL.iter().map(|f| f.name()).collect();
                anyhow::anyhow!(
                    "--only: unknown term `{n}`; known: none, {} (step and rate_squared only \
                     with --set mismatched)",
                    known.join(", ")
                )
            })?),
        });
    }
    if let Some(a) = checked_alpha(args.alpha)? {
        opts.alpha = a;
    }
    let t0 = std::time::Instant::now();
    let results = run_benchmark(&opts, &args.out)?;
    let md = report_markdown(&results);
    let header = results_header(args);
    write_report(
        &args.out,
        &serde_json::to_string_pretty(&results)?,
        &md,
        args.results_md.as_deref().map(|p| (p, header.as_str())),
    )?;
    let clean: Vec<&CaseResult> = results.iter().filter(|r| r.truth == Label::None).collect();
    if !clean.is_empty() {
        calibration_png_of(&clean, "matched", &args.out.join("calibration.png"))?;
    }
    println!("{md}");
    eprintln!(
        "{} recordings in {:.1} s",
        results.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The mismatched set: results, report and calibration figure.
fn run_mismatched_set(args: &BenchmarkDiagnoseArgs) -> anyhow::Result<()> {
    let mut opts = if args.quick {
        MismatchOptions::quick(args.seed)
    } else {
        MismatchOptions::full(args.seed)
    };
    opts.keep = args.keep;
    opts.variant = Variant {
        other_shapes: args.other_shapes,
        effect_elsewhere: args.effect_elsewhere,
        logger: args.logger,
        second_effect: args.two_effects,
        coarse_reading: args.coarse_reading,
        noise_in_time: args.noise_in_time,
        outside_kinds: args.outside_kinds,
    };
    opts.shift = usize::from(args.shift);
    opts.phases = usize::from(args.phases);
    for name in &args.only {
        opts.only.push(Kind::from_name(name).ok_or_else(|| {
            let known: Vec<&str> = rlg_diagnose::Family::ALL.iter().map(|f| f.name()).collect();
            anyhow::anyhow!(
                "--only: unknown term `{name}`; known: none, step, rate_squared, bump_in_time, \
                 telegraph, bump_in_temperature, {}",
                known.join(", ")
            )
        })?);
    }
    if let Some(a) = checked_alpha(args.alpha)? {
        opts.alpha = a;
    }
    let t0 = std::time::Instant::now();
    let results = run_mismatched(&opts, &args.out)?;
    let md = mismatch_report_markdown(&results);
    let header = results_header(args);
    write_report(
        &args.out,
        &serde_json::to_string_pretty(&results)?,
        &md,
        args.results_md.as_deref().map(|p| (p, header.as_str())),
    )?;
    if results.iter().any(|r| r.kind == Kind::Clean) {
        calibration_png(&results, &args.out.join("calibration.png"))?;
    }
    if results.iter().any(|r| r.kind != Kind::Clean) {
        detection_png(
            &results,
            &opts.variant.describe(),
            &args.out.join("detection.png"),
        )?;
    }
    println!("{md}");
    eprintln!(
        "{} recordings in {:.1} s",
        results.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--results-md` gets the very report `report.md` gets, after the line naming the
    /// command.
    #[test]
    fn the_results_file_is_the_report() {
        let dir = tempfile::tempdir().expect("temporary directory");
        let kept = dir.path().join("kept.md");
        let header = "Written by `rlg benchmark-diagnose`.";
        write_report(dir.path(), "[]", "| a | b |\n", Some((&kept, header))).expect("writes");
        let report = std::fs::read_to_string(dir.path().join("report.md")).expect("report.md");
        assert_eq!(
            std::fs::read_to_string(&kept).expect("results file"),
            format!("{header}\n\n{report}")
        );
        assert_eq!(
            std::fs::read_to_string(dir.path().join("results.json")).expect("results.json"),
            "[]"
        );
    }
}
