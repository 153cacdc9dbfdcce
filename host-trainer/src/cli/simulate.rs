//! `rlg simulate`: run a scenario and write the recording and its ground truth.

use std::path::PathBuf;

use anyhow::Context as _;
use rlg_simulate::{simulate, truth_path, write_simulation, Scenario};

/// Arguments of `rlg simulate`.
#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    /// Scenario file (TOML).
    #[arg(long, value_name = "FILE")]
    pub scenario: PathBuf,
    /// RNG seed; the same scenario and seed give byte-identical files.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// Output recording (CSV); the truth goes to `<stem>.truth.json` beside it.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Also draw temperatures and rate against time to this PNG.
    #[arg(long, value_name = "PNG")]
    pub plot: Option<PathBuf>,
}

/// Runs the subcommand.
pub fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    let scenario = Scenario::from_file(&args.scenario)?;
    let sim = simulate(&scenario, args.seed)?;
    write_simulation(&sim, &args.out).with_context(|| format!("writing {}", args.out.display()))?;
    eprintln!(
        "{}: {} samples over {:.0} s → {} (+ {})",
        scenario.name,
        sim.recording.len(),
        sim.recording.time_s.last().copied().unwrap_or(0.0),
        args.out.display(),
        truth_path(&args.out).display()
    );
    if let Some(png) = &args.plot {
        let fig = rlg_simulate::figure::scenario_figure(&scenario.name, &sim.recording);
        rlg_io::plot::render_png(&fig, png)
            .with_context(|| format!("drawing {}", png.display()))?;
        eprintln!("plot → {}", png.display());
    }
    Ok(())
}
