//! `rlg close-loop`: a diagnosis' findings become compensation features; the LS-SVM on the
//! augmented inputs is compared on held-out data with the paper's [T, dT/dt] LS-SVM and its
//! table exported. `rlg benchmark-close-loop`: the same on the concealed-effect benchmark.

use std::path::PathBuf;

use anyhow::Context as _;

use crate::closeloop::{
    self, augmented_features, first_cycle_end_s, train_and_score, Inputs, Protocol,
};
use crate::diagnose::{diagnose, Diagnosis, Options, PhysicsModel};
use crate::model::Provenance;
use crate::recording::Recording;

/// Arguments of `rlg close-loop`.
#[derive(Debug, clap::Args)]
pub struct CloseLoopArgs {
    /// Recording (CSV).
    #[arg(long)]
    pub recording: PathBuf,
    /// A diagnosis of it (`rlg diagnose --json`); default: diagnose it against the paper's
    /// model now.
    #[arg(long)]
    pub diagnosis: Option<PathBuf>,
    /// Train on the samples up to this time, s (default: the end of the first temperature
    /// cycle, the paper's protocol); the rest is held out.
    #[arg(long)]
    pub train_to_s: Option<f64>,
    /// Support vectors of the models (fixed-size LS-SVM; the board table's capacity).
    #[arg(long, default_value_t = crate::pipeline::SUPPORT_VECTORS)]
    pub budget: usize,
    /// Write the chosen model file (JSON) here: the augmented one when cross-validation
    /// adopts it, else the [T, dT/dt] one.
    #[arg(long)]
    pub out_model: Option<PathBuf>,
    /// Write the chosen model's board table (Rust const with its feature specification).
    #[arg(long)]
    pub out_table: Option<PathBuf>,
}

fn read_diagnosis(p: &PathBuf) -> anyhow::Result<Diagnosis> {
    let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a diagnosis JSON", p.display()))
}

/// Runs `rlg close-loop`.
pub fn run(args: &CloseLoopArgs, command_line: &str) -> anyhow::Result<()> {
    let rec = Recording::read_csv(&args.recording)?;
    super::warn_units(&args.recording, &rec);
    let d = match &args.diagnosis {
        Some(p) => read_diagnosis(p)?,
        None => diagnose(&rec, &PhysicsModel::paper(), &Options::default())?,
    };
    let (feats, suggestions) = augmented_features(&d);
    for s in &suggestions {
        match s.feature {
            Some(f) => println!("{} → feature {f} ({:?}): {}", s.mechanism, s.role, s.reason),
            None => println!("{} → no feature: {}", s.mechanism, s.reason),
        }
    }
    if suggestions.is_empty() {
        println!("the diagnosis names no missing mechanism ({:?})", d.verdict);
    }
    let end = match args.train_to_s {
        Some(t) => t,
        None => first_cycle_end_s(&rec)?,
    };
    anyhow::ensure!(end.is_finite(), "--train-to-s must be finite");
    let protocol = Protocol {
        budget: Some(args.budget),
        ..Protocol::default()
    };
    let prov = Provenance::from_file(&args.recording, command_line)?;
    let base = train_and_score(&rec, end, &Inputs::base(), &protocol, &prov)?;
    let aug = if feats != Inputs::base() {
        train_and_score(&rec, end, &feats, &protocol, &prov)?
    } else {
        base.clone()
    };
    println!("trained on t ≤ {end:.0} s, held out the rest (100 s stability, °/h):");
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
        crate::export::write_table(&chosen.model, command_line, p)?;
        println!("wrote {}", p.display());
    }
    Ok(())
}

/// Arguments of `rlg benchmark-close-loop`.
#[derive(Debug, clap::Args)]
pub struct BenchmarkCloseLoopArgs {
    /// Master seed of the benchmark (as `rlg benchmark-diagnose --seed`).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
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
    let cases = closeloop::bench::run(args.seed, args.per_term)?;
    let md = closeloop::bench::report_markdown(&cases);
    print!("{md}");
    println!(
        "\n{} cases in {:.0} s",
        cases.len(),
        t0.elapsed().as_secs_f64()
    );
    if let Some(p) = &args.out {
        crate::atomic::write(p, md.as_bytes())
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}
