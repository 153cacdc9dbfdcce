//! `rlg train-fleet`: `rlg calibrate` on every recording of a folder in parallel, each gyro
//! tuned on its own data, with a summary and pass / fail against the limits given.

use std::path::PathBuf;

use clap::Args;

use rlg_calibrate::fleet::{self, Limits};
use rlg_calibrate::Options;
use rlg_io::progress::progress;

/// Arguments of `rlg train-fleet`.
#[derive(Debug, Args)]
pub struct TrainFleetArgs {
    /// Folder of recordings (`*.csv`: time_s, rate_dph, temp_c at 1 Hz, or as the reading
    /// flags say), one per gyro or axis.
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
    let opts = Options {
        budget: a.budget as usize,
        window: a.window as usize,
        from_s: a.from_s,
        to_s: a.to_s,
        ..Options::default()
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
        &opts,
        &limits,
        command_line,
        &read,
        &progress("calibrating the fleet"),
    )?;
    let md = fleet::write_summaries(&a.out, &rows, opts.window, &limits, t0.elapsed())?;
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
