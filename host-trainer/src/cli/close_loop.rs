//! `rlg close-loop`: a diagnosis' findings become compensation features; the LS-SVM on the
//! augmented inputs is compared on held-out data with the paper's [T, dT/dt] LS-SVM and its
//! table exported. `rlg benchmark-close-loop`: the same on the concealed-effect benchmark.

use std::path::PathBuf;

use anyhow::Context as _;

use rlg_closeloop::{self, close_loop, session_text, HeldOutFrom, Protocol};
use rlg_diagnose::Diagnosis;
use rlg_train::model::Provenance;

/// Arguments of `rlg close-loop`.
#[derive(Debug, clap::Args)]
pub struct CloseLoopArgs {
    /// Calibration recording (CSV).
    #[arg(long, value_name = "FILE")]
    pub recording: PathBuf,
    /// How the recordings are written (separator, columns, units).
    #[command(flatten)]
    pub input: super::InputArgs,
    /// A later recording of the same gyro to judge the models on: the diagnosis and the
    /// training then use all of `--recording`. Without it, the later cycles of `--recording`
    /// are held out (see `--to-s`).
    #[arg(long, value_name = "FILE", conflicts_with = "train_to_s")]
    pub test: Option<PathBuf>,
    /// A diagnosis of the training data (`rlg diagnose --json`); default: diagnose the
    /// training data against the paper's model now. A diagnosis that saw the held-out part
    /// makes the held-out comparison optimistic.
    #[arg(long, value_name = "FILE")]
    pub diagnosis: Option<PathBuf>,
    /// Train on the samples up to this time, s (default: the end of the first temperature
    /// cycle, the paper's protocol); the rest is held out.
    #[arg(long = "to-s", visible_alias = "train-to-s", value_name = "S")]
    pub train_to_s: Option<f64>,
    /// Support vectors of the models (fixed-size LS-SVM; the board table's capacity).
    #[arg(long, value_name = "M", default_value_t = rlg_repro::pipeline::SUPPORT_VECTORS)]
    pub budget: usize,
    /// Write the chosen model file (JSON) here: the augmented one when cross-validation
    /// adopts it, else the [T, dT/dt] one.
    #[arg(long = "out", visible_alias = "out-model", value_name = "FILE")]
    pub out_model: Option<PathBuf>,
    /// Write the chosen model's board table (Rust const with its feature specification).
    #[arg(long = "table", visible_alias = "out-table", value_name = "FILE")]
    pub out_table: Option<PathBuf>,
}

fn read_diagnosis(p: &PathBuf) -> anyhow::Result<Diagnosis> {
    let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a diagnosis JSON", p.display()))
}

/// Runs `rlg close-loop`.
pub fn run(args: &CloseLoopArgs, command_line: &str) -> anyhow::Result<()> {
    let rec = super::read_recording(&args.recording, &args.input)?;
    let test = match &args.test {
        Some(p) => Some(super::read_recording(p, &args.input)?),
        None => None,
    };
    let held_out = match &test {
        Some(t) => HeldOutFrom::Test(t),
        None => HeldOutFrom::After(args.train_to_s),
    };
    let diagnosis = match &args.diagnosis {
        Some(p) => Some(read_diagnosis(p)?),
        None => None,
    };
    let protocol = Protocol {
        budget: Some(args.budget),
        ..Protocol::default()
    };
    let prov = Provenance::from_file(&args.recording, command_line)?;
    let s = close_loop(&rec, held_out, diagnosis, &protocol, &prov)?;
    let split = match &args.test {
        Some(p) => format!(
            "trained on all of {}, judged on {} (100 s stability, °/h):",
            args.recording.display(),
            p.display()
        ),
        None => format!(
            "trained on t ≤ {:.0} s, held out the rest (100 s stability, °/h):",
            s.train_end_s
        ),
    };
    print!("{}", session_text(&s, &split));
    if let Some(p) = &args.out_model {
        s.chosen().model.write(p)?;
        println!("wrote {}", p.display());
    }
    if let Some(p) = &args.out_table {
        rlg_train::export::write_table(&s.chosen().model, command_line, p)?;
        println!("wrote {}", p.display());
    }
    Ok(())
}

/// Arguments of `rlg benchmark-close-loop`.
#[derive(Debug, clap::Args)]
pub struct BenchmarkCloseLoopArgs {
    /// Master seeds of the benchmark (each as `rlg benchmark-diagnose --seed`), comma
    /// separated: the cases of every seed are pooled in the summary.
    #[arg(long, value_delimiter = ',', default_value = "1")]
    pub seed: Vec<u64>,
    /// Cases per hidden mechanism (the diagnosis benchmark uses 20).
    #[arg(long, default_value_t = 20)]
    pub per_term: usize,
    /// Write the Markdown report here as well.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also write the report to this file, e.g. a results file kept in the repository, after a
    /// first line naming the command that wrote it.
    #[arg(long, value_name = "FILE")]
    pub results_md: Option<PathBuf>,
}

/// Runs `rlg benchmark-close-loop`.
pub fn run_benchmark(args: &BenchmarkCloseLoopArgs) -> anyhow::Result<()> {
    // Checked before the run, which takes minutes.
    if let Some(p) = &args.results_md {
        super::check_output_file(p, "--results-md")?;
    }
    let t0 = std::time::Instant::now();
    let cases = rlg_benchmarks::closeloop::run(&args.seed, args.per_term)?;
    let md = rlg_benchmarks::closeloop::report_markdown(&cases);
    print!("{md}");
    println!(
        "\n{} cases in {:.0} s",
        cases.len(),
        t0.elapsed().as_secs_f64()
    );
    if let Some(p) = &args.out {
        rlg_io::atomic::write(p, md.as_bytes())
            .with_context(|| format!("writing {}", p.display()))?;
    }
    if let Some(p) = &args.results_md {
        let header = super::results::header(
            std::env::args(),
            &[("--out", "FILE"), ("--results-md", "FILE")],
            None,
        );
        super::results::write(p, &header, &md)?;
    }
    Ok(())
}
