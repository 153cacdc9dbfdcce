//! `rlg train-fleet`: train every recording of a folder in parallel, one model and one table
//! each, and print a summary.

use std::path::PathBuf;

use clap::Args;

use rlg_repro::pipeline;
use rlg_train::fleet::{self, FleetOptions};
use rlg_train::lssvm::sparse::{Reduction, DEFAULT_BUDGET};

/// Arguments of `rlg train-fleet`.
#[derive(Debug, Args)]
pub struct TrainFleetArgs {
    /// Folder of recordings (`*.csv`: time_s, rate_dph, temp_c), one per gyro or axis.
    #[arg(long, value_name = "DIR")]
    pub dir: PathBuf,
    /// Output folder: `<stem>.json` and `<stem>_table.rs` per recording.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Gaussian kernel width σ, standardised units.
    #[arg(long, default_value_t = pipeline::SIGMA)]
    pub sigma: f64,
    /// Regularisation c.
    #[arg(long, default_value_t = pipeline::C)]
    pub c: f64,
    /// Average over blocks of N samples (1: raw 1 Hz).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub block: usize,
    /// Train on samples up to this time, s.
    #[arg(long, value_name = "S")]
    pub to_s: Option<f64>,
    /// Time constant of the dT/dt estimator, s.
    #[arg(long, value_name = "S", default_value_t = pipeline::RATE_TAU_S)]
    pub rate_tau_s: f64,
    /// Largest number of support vectors (the board table's capacity); 0 trains the exact
    /// model with every sample a support vector.
    #[arg(long, value_name = "M", default_value_t = DEFAULT_BUDGET)]
    pub budget: usize,
    /// Threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// Runs `rlg train-fleet`.
pub fn run(a: &TrainFleetArgs, command_line: &str) -> anyhow::Result<()> {
    if let Some(t) = a.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()?;
    }
    let opts = FleetOptions {
        sigma: a.sigma,
        c: a.c,
        block: a.block,
        to_s: a.to_s,
        rate_tau_s: a.rate_tau_s,
        reduction: (a.budget > 0).then_some((Reduction::FIXED_SIZE, a.budget)),
        command: command_line.to_string(),
    };
    let t0 = std::time::Instant::now();
    let entries = fleet::train_fleet(&a.dir, &a.out, &opts)?;
    print!("{}", fleet::summary(&entries, t0.elapsed().as_secs_f64()));
    let failed = entries.iter().filter(|e| e.error.is_some()).count();
    anyhow::ensure!(failed == 0, "{failed} recording(s) failed");
    Ok(())
}
