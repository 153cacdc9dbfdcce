//! `rlg diagnose`: where a recording departs from a physics model and which term is missing.

use std::path::PathBuf;

use anyhow::Context as _;

use rlg_diagnose::{diagnose, Options, PhysicsModel};

/// Arguments of `rlg diagnose`.
#[derive(Debug, clap::Args)]
pub struct DiagnoseArgs {
    /// Recording (CSV).
    #[arg(long, value_name = "FILE")]
    pub recording: PathBuf,
    /// How the recording is written (separator, columns, units).
    #[command(flatten)]
    pub input: super::InputArgs,
    /// Physics model (TOML `[[terms]]`, or a scenario file whose terms are taken; `rlg terms`
    /// lists the kinds); default: the paper's model (models/paper.toml).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Diagnose the samples from this time on, s.
    #[arg(long, value_name = "S")]
    pub from_s: Option<f64>,
    /// Diagnose the samples up to this time, s.
    #[arg(long, value_name = "S")]
    pub to_s: Option<f64>,
    /// Write the machine-readable result here (JSON).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the figures into this directory: residual vs time with the located spans,
    /// residual vs temperature by heating / cooling / hold, before / after (PNG).
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// Bootstrap replicates of the noise model.
    #[arg(long, value_name = "N", default_value_t = 400)]
    pub bootstrap: usize,
    /// False-alarm probability per recording of the significance test.
    #[arg(long, value_name = "P", default_value_t = Options::default().alpha)]
    pub alpha: f64,
    /// Block phases a verdict near its threshold is decided over: its first pass again with
    /// the 100 s blocks starting k/N of a block later, the phase with the median p-value
    /// kept (1: the blocks as they fall; at most 5).
    #[arg(long, value_name = "N", default_value_t = Options::default().phases as u8,
          value_parser = clap::value_parser!(u8).range(1..=5))]
    pub phases: u8,
}

/// Runs the subcommand.
pub fn run(args: &DiagnoseArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.alpha > 0.0 && args.alpha < 1.0,
        "--alpha must lie strictly between 0 and 1, got {}",
        args.alpha
    );
    let need = (1.0 / args.alpha).ceil();
    anyhow::ensure!(
        args.bootstrap as f64 >= need,
        "--bootstrap {} is too few for --alpha {}: its quantile needs at least {need} replicates",
        args.bootstrap,
        args.alpha
    );
    // Output paths are checked before the analysis, which takes seconds to minutes.
    if let Some(p) = &args.json {
        super::check_output_file(p, "--json")?;
    }
    if let Some(dir) = &args.plots {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("--plots {}: cannot create the directory", dir.display()))?;
    }
    let mut rec = super::read_recording(&args.recording, &args.input)?;
    if args.from_s.is_some() || args.to_s.is_some() {
        let lo = args.from_s.unwrap_or(f64::NEG_INFINITY);
        let hi = args.to_s.unwrap_or(f64::INFINITY);
        let a = rec.time_s.partition_point(|t| *t < lo);
        let b = rec.time_s.partition_point(|t| *t <= hi);
        anyhow::ensure!(
            b > a,
            "no samples between --from-s {lo} and --to-s {hi} (the recording spans {} … {} s)",
            rec.time_s.first().unwrap_or(&f64::NAN),
            rec.time_s.last().unwrap_or(&f64::NAN)
        );
        let cut = |v: &mut Vec<f64>| {
            v.truncate(b);
            v.drain(..a);
        };
        cut(&mut rec.time_s);
        cut(&mut rec.rate_dph);
        cut(&mut rec.temp_c);
        if let Some(c) = rec.chamber_c.as_mut() {
            cut(c);
        }
        rec.extra.clear();
    }
    let model = match &args.model {
        Some(p) => PhysicsModel::read(p)?,
        None => PhysicsModel::paper(),
    };
    let opts = Options {
        bootstrap: args.bootstrap,
        alpha: args.alpha,
        phases: usize::from(args.phases),
        ..Options::default()
    };
    let pb = rlg_io::progress::spinner("diagnosing");
    let d = diagnose(rec, &model, &opts);
    pb.finish_and_clear();
    let d = d?;
    println!(
        "verdict: {}",
        serde_json::to_value(d.verdict)?.as_str().unwrap_or("?")
    );
    println!(
        "baseline (held-out): rms {:.3e} °/h, 100 s stability {:.3e} °/h, BIC {:.1}",
        d.baseline.rms_dph, d.baseline.b100_dph, d.baseline.bic
    );
    for s in &d.located {
        println!(
            "significant residual: {:.0}–{:.0} s, {:.1}–{:.1} °C, {}, mean {:+.2e} °/h",
            s.t_start_s, s.t_end_s, s.temp_lo_c, s.temp_hi_c, s.phase, s.effect_dph
        );
    }
    for f in &d.findings {
        println!("{}", f.explanation);
    }
    for n in &d.evidence.notes {
        println!("note: {n}");
    }
    if let Some(p) = &args.json {
        let text = serde_json::to_string_pretty(&d)?;
        rlg_io::recording::write_atomic(p, text.as_bytes())?;
    }
    if let Some(dir) = &args.plots {
        for p in rlg_diagnose::plots::write(&d, dir)
            .with_context(|| format!("drawing into {}", dir.display()))?
        {
            println!("figure: {}", p.display());
        }
    }
    Ok(())
}
