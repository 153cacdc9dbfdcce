//! `rlg benchmark-diagnose`: the concealed-effect benchmark of the diagnosis.

use std::path::PathBuf;

use rlg_benchmarks::diagnose::{report_markdown, run_benchmark, BenchOptions};

/// Arguments of `rlg benchmark-diagnose`.
#[derive(Debug, clap::Args)]
pub struct BenchmarkDiagnoseArgs {
    /// Master seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Working directory for the recordings; `results.json` and `report.md` are written here.
    #[arg(long)]
    pub out: PathBuf,
    /// A few recordings per term instead of 20 (and 8 instead of 100 without a hidden term).
    #[arg(long)]
    pub quick: bool,
    /// Keep the recordings and truth sidecars.
    #[arg(long)]
    pub keep: bool,
    /// False-alarm probability of the diagnosis' significance test (default: the
    /// diagnosis' own); the report adds the verdicts at every smaller α of 0.25 … 5 %.
    #[arg(long)]
    pub alpha: Option<f64>,
    /// Only the cases hiding these terms (library names, comma-separated; `none` for the
    /// cases with nothing hidden). Each case keeps its number and recording.
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
}

/// Runs the subcommand.
pub fn run(args: &BenchmarkDiagnoseArgs) -> anyhow::Result<()> {
    let mut opts = if args.quick {
        BenchOptions::quick(args.seed)
    } else {
        BenchOptions::full(args.seed)
    };
    opts.keep = args.keep;
    for name in &args.only {
        opts.only.push(match name.as_str() {
            "none" => None,
            n => Some(rlg_diagnose::Family::from_name(n).ok_or_else(|| {
                let known: Vec<&str> = rlg_diagnose::Family::ALL.iter().map(|f| f.name()).collect();
                anyhow::anyhow!(
                    "--only: unknown term `{n}`; known: none, {}",
                    known.join(", ")
                )
            })?),
        });
    }
    if let Some(a) = args.alpha {
        anyhow::ensure!(
            a > 0.0 && a < 1.0,
            "--alpha must lie strictly between 0 and 1, got {a}"
        );
        let b = rlg_diagnose::Options::default().bootstrap;
        anyhow::ensure!(
            a * b as f64 >= 1.0,
            "--alpha {a} is below what the diagnosis' {b} bootstrap replicates resolve (1/{b})"
        );
        opts.alpha = a;
    }
    let t0 = std::time::Instant::now();
    let results = run_benchmark(&opts, &args.out)?;
    let md = report_markdown(&results);
    rlg_io::recording::write_atomic(
        &args.out.join("results.json"),
        serde_json::to_string_pretty(&results)?.as_bytes(),
    )?;
    rlg_io::recording::write_atomic(&args.out.join("report.md"), md.as_bytes())?;
    println!("{md}");
    eprintln!(
        "{} recordings in {:.1} s",
        results.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
