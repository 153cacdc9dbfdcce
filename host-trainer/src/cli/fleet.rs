//! `rlg train-fleet`: `rlg calibrate` on every recording of a folder in parallel, each gyro
//! tuned on its own data, with a summary and pass / fail against the limits given.

use std::path::PathBuf;

use clap::Args;

use rlg_calibrate::fleet::{self, FleetModel, Limits};
use rlg_calibrate::static_cal::StaticOptions;
use rlg_calibrate::Options;
use rlg_io::progress::progress;

/// Arguments of `rlg train-fleet`.
#[derive(Debug, Args)]
pub struct TrainFleetArgs {
    /// Folder of recordings (`*.csv`, `*.tsv`, `*.txt`: time_s, rate_dph, temp_c, or as the
    /// reading flags say), one per gyro or axis.
    #[arg(long, value_name = "DIR")]
    pub dir: PathBuf,
    /// Output folder: one calibration folder per recording (`<stem>/`: report, model,
    /// tables) and `summary.csv`, `summary.md`.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// How the recordings are written (separator, columns, units).
    #[command(flatten)]
    pub input: super::InputArgs,
    /// Support vectors of each board table.
    #[arg(long, value_name = "M", default_value_t = rlg_train::protocol::SUPPORT_VECTORS as u64,
          value_parser = clap::value_parser!(u64).range(1..=rlg_calibrate::MAX_BUDGET as u64))]
    pub budget: u64,
    /// Window of the bias stability, samples at 1 Hz.
    #[arg(long, value_name = "S", default_value_t = 100,
          value_parser = clap::value_parser!(u64).range(2..=100_000))]
    pub window: u64,
    /// Use samples from this time on, s.
    #[arg(long, value_name = "S")]
    pub from_s: Option<f64>,
    /// Use samples up to this time, s.
    #[arg(long, value_name = "S")]
    pub to_s: Option<f64>,
    /// Fail a gyro whose board table's held-out stability exceeds this, °/h.
    #[arg(long, value_name = "DPH")]
    pub max_b100_dph: Option<f64>,
    /// Fail a gyro whose board table improves the held-out stability by less than this factor.
    #[arg(long, value_name = "FACTOR")]
    pub min_improvement: Option<f64>,
    /// Threads (default: all cores).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Training means of N s (default: from each record, as `calibrate`).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=3600))]
    pub block: Option<u64>,
    /// Time constant of the dT/dt estimator, s.
    #[arg(long, value_name = "S", default_value_t = rlg_train::protocol::RATE_TAU_S)]
    pub rate_tau_s: f64,
    /// Smallest c of the tuning grid (lower it when no c meets the f32 limit).
    #[arg(long, value_name = "C", default_value_t = 0.1)]
    pub c_min: f64,
    /// Pool the training means per cell of cycle, temperature and dT/dt (as `calibrate`).
    #[arg(long, conflicts_with = "static_only")]
    pub even_temperature: bool,
    /// What each board table removes (as `calibrate --remove`).
    #[arg(long, value_enum, default_value_t = super::calibrate::Remove::Variation)]
    pub remove: super::calibrate::Remove,
    /// Static characterisation of each gyro (as `calibrate --static`: temperature only, CV
    /// figures; a limit then fails every gyro, since nothing is held out).
    #[arg(long = "static")]
    pub static_only: bool,
}

/// Runs `rlg train-fleet`.
pub fn run(a: &TrainFleetArgs, command_line: &str) -> anyhow::Result<()> {
    for (flag, v) in [
        ("--max-b100-dph", a.max_b100_dph),
        ("--min-improvement", a.min_improvement),
    ] {
        if let Some(v) = v {
            anyhow::ensure!(v > 0.0 && v.is_finite(), "{flag} {v}: must be positive");
        }
    }
    if let Some(t) = a.threads {
        anyhow::ensure!(t >= 1, "--threads 0: give at least 1");
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()?;
    }
    let grid = super::calibrate::grid_of(a.c_min)?;
    let model = if a.static_only {
        FleetModel::Static(StaticOptions {
            block: a
                .block
                .map_or(rlg_train::protocol::TRAIN_BLOCK, |b| b as usize),
            budget: a.budget as usize,
            grid,
            rate_tau_s: a.rate_tau_s,
            remove: a.remove.into(),
        })
    } else {
        FleetModel::Dynamic(Options {
            budget: a.budget as usize,
            window: a.window as usize,
            from_s: a.from_s,
            to_s: a.to_s,
            block: a.block.map(|b| b as usize),
            rate_tau_s: a.rate_tau_s,
            grid,
            even_temperature: a.even_temperature,
            remove: a.remove.into(),
            ..Options::default()
        })
    };
    let limits = Limits {
        max_stability_dph: a.max_b100_dph,
        min_improvement: a.min_improvement,
    };
    let t0 = std::time::Instant::now();
    a.input.one_axis()?;
    let read_opts = a.input.options();
    let read = move |p: &std::path::Path| -> Result<_, rlg_calibrate::CalibrateError> {
        let axes = rlg_io::recording::read_axes(p, &read_opts)?;
        super::input::print_report(p, &axes);
        axes.axes
            .into_iter()
            .next()
            .map(|a| a.recording)
            .ok_or_else(|| {
                rlg_calibrate::CalibrateError::Internal("the reader returned no axis".into())
            })
    };
    let rows = fleet::calibrate_fleet(
        &a.dir,
        &a.out,
        &model,
        &limits,
        command_line,
        &read,
        &progress("calibrating the fleet"),
    )?;
    let md = fleet::write_summaries(&a.out, &rows, a.window as usize, &limits, t0.elapsed())?;
    print!("{md}");
    let failed = rows.iter().filter(|r| r.pass == Some(false)).count();
    anyhow::ensure!(
        failed == 0,
        "{failed} of {} gyro(s) failed (see {})",
        rows.len(),
        a.out.join("summary.md").display()
    );
    Ok(())
}
