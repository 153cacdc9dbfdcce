//! `rlg close-loop`: a diagnosis' findings become compensation features; the LS-SVM on the
//! augmented inputs is compared on held-out data with the paper's [T, dT/dt] LS-SVM and its
//! table exported. `rlg benchmark-close-loop`: the same on the concealed-effect benchmark.

use std::path::PathBuf;

use anyhow::Context as _;

use rlg_closeloop::{
    self, augmented_features, first_cycle_end_s, train_and_score, train_and_score_on, Inputs,
    Protocol,
};
use rlg_diagnose::{diagnose, DiagnoseError, Diagnosis, Options, PhysicsModel};
use rlg_train::model::Provenance;

/// Arguments of `rlg close-loop`.
#[derive(Debug, clap::Args)]
pub struct CloseLoopArgs {
    /// Calibration recording (CSV).
    #[arg(long, value_name = "FILE")]
    pub recording: PathBuf,
    /// Units of the recordings' columns.
    #[command(flatten)]
    pub units: super::UnitArgs,
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
    let rec = super::read_recording(&args.recording, &args.units)?;
    let test = match &args.test {
        Some(p) => Some(super::read_recording(p, &args.units)?),
        None => None,
    };
    let end = match (&test, args.train_to_s) {
        (Some(_), _) => rec.time_s.last().copied().unwrap_or(f64::NAN),
        (None, Some(t)) => t,
        (None, None) => first_cycle_end_s(&rec)?,
    };
    anyhow::ensure!(end.is_finite(), "--to-s must be finite");
    // The diagnosis sees the training data only, so that the held-out data judge a
    // pipeline (the feature, its parameter, the model) that never saw them.
    let train_part = rec.head(rec.time_s.partition_point(|t| *t <= end));
    let d = match &args.diagnosis {
        Some(p) => Some(read_diagnosis(p)?),
        None => match diagnose(&train_part, &PhysicsModel::paper(), &Options::default()) {
            Ok(d) => Some(d),
            Err(e @ DiagnoseError::TooShort { .. }) => {
                println!(
                    "the training data cannot be diagnosed ({e}): the [T, dT/dt] model only; \
                     give a longer --to-s or a later recording with --test"
                );
                None
            }
            Err(e) => return Err(e.into()),
        },
    };
    let (feats, suggestions) = d
        .as_ref()
        .map_or_else(|| (Inputs::base(), Vec::new()), augmented_features);
    for s in &suggestions {
        match s.feature {
            Some(f) => println!("{} → feature {f} ({:?}): {}", s.mechanism, s.role, s.reason),
            None => println!("{} → no feature: {}", s.mechanism, s.reason),
        }
    }
    if let (Some(d), true) = (&d, suggestions.is_empty()) {
        println!("the diagnosis names no missing mechanism ({:?})", d.verdict);
    }
    let protocol = Protocol {
        budget: Some(args.budget),
        ..Protocol::default()
    };
    let prov = Provenance::from_file(&args.recording, command_line)?;
    let score = |inputs: &Inputs| match &test {
        Some(t) => train_and_score_on(&rec, t, inputs, &protocol, &prov),
        None => train_and_score(&rec, end, inputs, &protocol, &prov),
    };
    let base = score(&Inputs::base())?;
    let aug = if feats != Inputs::base() {
        score(&feats)?
    } else {
        base.clone()
    };
    match &args.test {
        Some(p) => println!(
            "trained on all of {}, judged on {} (100 s stability, °/h):",
            args.recording.display(),
            p.display()
        ),
        None => println!("trained on t ≤ {end:.0} s, held out the rest (100 s stability, °/h):"),
    }
    for (name, s) in [("[T, dT/dt]", &base), ("augmented", &aug)] {
        let f = s.inputs.describe();
        println!(
            "  {name:<11} {:<52} σ = {:.3}, c = {:.3e}: TRAINING rms {:.3e}, CV rms {:.3e}, HELD-OUT {:.4e} (board f32: {}, max |f32 − f64| {:.1e})",
            f.join(", "),
            s.sigma,
            s.c,
            s.train_rms_dph,
            s.cv_rms_dph,
            s.test_b100_dph,
            s.board_b100_dph
                .map_or("—".to_string(), |b| format!("{b:.4e}")),
            s.board_deviation_dph
        );
    }
    let adopted = protocol.adopts(&base, &aug);
    let chosen = if adopted { &aug } else { &base };
    println!(
        "  {}: held-out change of the augmented model {:+.1} % (for the record; the held-out data do not decide)",
        if adopted {
            "augmented model ADOPTED (cross-validated error lower)"
        } else {
            "augmented model NOT adopted (cross-validated error not lower); [T, dT/dt] kept"
        },
        100.0 * (aug.test_b100_dph / base.test_b100_dph - 1.0)
    );
    if let Some(p) = &args.out_model {
        chosen.model.write(p)?;
        println!("wrote {}", p.display());
    }
    if let Some(p) = &args.out_table {
        rlg_train::export::write_table(&chosen.model, command_line, p)?;
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
}

/// Runs `rlg benchmark-close-loop`.
pub fn run_benchmark(args: &BenchmarkCloseLoopArgs) -> anyhow::Result<()> {
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
    Ok(())
}
