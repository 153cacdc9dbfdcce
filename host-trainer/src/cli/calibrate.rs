//! `rlg calibrate`: a chamber recording (and optionally a later test recording) to a tuned
//! board table, the comparison with the baselines, and a report folder.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use clap::Args;

use rlg_calibrate::report::{self, FileInfo, Inputs};
use rlg_calibrate::static_cal::{calibrate_static, StaticOptions};
use rlg_calibrate::{calibrate, Options};
use rlg_closeloop::calibrate_diagnosed;
use rlg_diagnose::PhysicsModel;
use rlg_io::progress::progress;
use rlg_train::model::Provenance;

/// Arguments of `rlg calibrate`.
#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// The calibration recording (time_s, rate_dph, temp_c; a continuous 1 Hz stream, or
    /// burst / plateau means with --static).
    #[arg(long, value_name = "FILE")]
    pub recording: PathBuf,
    /// A later recording of the same gyro, held out entirely (otherwise the later temperature
    /// cycles of --recording are held out).
    #[arg(long, value_name = "FILE")]
    pub test: Option<PathBuf>,
    /// How the recordings are written (separator, columns, units).
    #[command(flatten)]
    pub input: super::InputArgs,
    /// Output folder: report.md, summary.json, PNG figures, model.json, table.rs, table.h
    /// (with --diagnose, when the diagnosed inputs are adopted, also model_diagnosed.json,
    /// table_diagnosed.rs, table_diagnosed.h).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Support vectors of the board table (its capacity).
    #[arg(long, value_name = "M", default_value_t = rlg_train::protocol::SUPPORT_VECTORS as u64,
          value_parser = clap::value_parser!(u64).range(1..=rlg_calibrate::MAX_BUDGET as u64))]
    pub budget: u64,
    /// Temperature cycles of --recording that train [default: half of them, rounded up,
    /// leaving at least one held out].
    #[arg(long, value_name = "N", conflicts_with = "test")]
    pub train_cycles: Option<usize>,
    /// Window of the bias stability, samples at 1 Hz (100: the 100 s stability).
    #[arg(long, value_name = "S", default_value_t = 100,
          value_parser = clap::value_parser!(u64).range(2..=100_000))]
    pub window: u64,
    /// Train on means of N samples (100: the paper's 100 s means; 1: raw 1 Hz) [default: from
    /// the record: 100 s unless its noise or length asks for shorter means].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=3600))]
    pub block: Option<u64>,
    /// Use samples from this time on, s.
    #[arg(long, value_name = "S")]
    pub from_s: Option<f64>,
    /// Use samples up to this time, s.
    #[arg(long, value_name = "S")]
    pub to_s: Option<f64>,
    /// Time constant of the board's dT/dt estimator, s.
    #[arg(long, value_name = "S", default_value_t = rlg_train::protocol::RATE_TAU_S)]
    pub rate_tau_s: f64,
    /// Smallest c of the tuning grid (lower it when no c meets the board's f32 limit).
    #[arg(long, value_name = "C", default_value_t = 0.1)]
    pub c_min: f64,
    /// Weight training evenly over temperature: pool the training means into cells of one
    /// cycle, 1 °C and a tenth of the largest |dT/dt|, one mean each, so slow stretches of an
    /// uneven ramp do not dominate the fit.
    #[arg(long)]
    pub even_temperature: bool,
    /// Also diagnose the training span for missing physics and, where the close loop adopts
    /// the diagnosed features by cross-validation, compare that model on the same held-out
    /// samples (`rlg close-loop`'s protocol) and write its board table beside the
    /// [T, dT/dt] one.
    #[arg(long, conflicts_with = "static_only")]
    pub diagnose: bool,
    /// Physics model the diagnosis starts from (TOML `[[terms]]` or a scenario file; `rlg
    /// terms`) [default: the paper's].
    #[arg(long, value_name = "FILE", requires = "diagnose")]
    pub model: Option<PathBuf>,
    /// Static characterisation: a temperature-only model from burst or plateau means (a
    /// bursty log has no 1 Hz stream, so no dT/dt model).
    #[arg(long = "static")]
    pub static_only: bool,
    /// Also write the report (`report.md`) to this file, e.g. a results file kept in the
    /// repository, after a first line naming the command that wrote it.
    #[arg(long, value_name = "FILE")]
    pub results_md: Option<PathBuf>,
}

/// The flags of `rlg calibrate` that take a path, with their placeholders.
const PATH_FLAGS: &[(&str, &str)] = &[
    ("--recording", "FILE"),
    ("--test", "FILE"),
    ("--out", "DIR"),
    ("--model", "FILE"),
    ("--results-md", "FILE"),
];

/// `--results-md`: the report just written to `out`, after the line naming the command.
fn write_results_md(a: &CalibrateArgs) -> anyhow::Result<()> {
    if let Some(p) = &a.results_md {
        let report = a.out.join("report.md");
        let md = std::fs::read_to_string(&report)
            .with_context(|| format!("reading {}", report.display()))?;
        let header = super::results::header(std::env::args(), PATH_FLAGS, None);
        super::results::write(p, &header, &md)?;
    }
    Ok(())
}

fn file_info(path: &Path, samples: usize) -> anyhow::Result<FileInfo> {
    let p = Provenance::from_file(path, "")?;
    Ok(FileInfo {
        file: p.data_file,
        sha256: p.data_sha256,
        samples,
    })
}

/// Runs `rlg calibrate`.
pub fn run(a: &CalibrateArgs, command_line: &str) -> anyhow::Result<()> {
    // The folder first: a path that cannot hold it fails before minutes of work.
    report::prepare_dir(&a.out)?;
    if let Some(p) = &a.results_md {
        super::check_output_file(p, "--results-md")?;
    }
    anyhow::ensure!(
        a.c_min > 0.0 && a.c_min.is_finite(),
        "--c-min {}: c must be positive",
        a.c_min
    );
    let cal = super::read_recording(&a.recording, &a.input)?;
    let test = match &a.test {
        Some(p) => Some(super::read_recording(p, &a.input)?),
        None => None,
    };
    let inputs = Inputs {
        command: command_line.to_string(),
        recording: file_info(&a.recording, cal.len())?,
        test_recording: match (&a.test, &test) {
            (Some(p), Some(t)) => Some(file_info(p, t.len())?),
            _ => None,
        },
    };
    let provenance = Provenance::from_file(&a.recording, command_line)?;
    let mut grid = rlg_train::lssvm::tune::Grid::default();
    anyhow::ensure!(
        a.c_min < grid.c.1,
        "--c-min {} is above the grid's largest c {}",
        a.c_min,
        grid.c.1
    );
    grid.c.0 = a.c_min;
    if a.static_only {
        let opts = StaticOptions {
            block: a
                .block
                .map_or(rlg_train::protocol::TRAIN_BLOCK, |b| b as usize),
            budget: a.budget as usize,
            grid,
            rate_tau_s: a.rate_tau_s,
        };
        let pb = progress("tuning σ, c (static)");
        let c = calibrate_static(&cal, test.as_ref(), &opts, &provenance, &pb)?;
        let files = report::write_static(&c, &inputs, &a.out)?;
        print!(
            "{}",
            report::static_console(&report::static_summary(&c, &inputs, &[]))
        );
        println!("wrote {} files to {}", files.len(), a.out.display());
        return write_results_md(a);
    }
    let opts = Options {
        train_cycles: a.train_cycles,
        window: a.window as usize,
        block: a.block.map(|b| b as usize),
        budget: a.budget as usize,
        rate_tau_s: a.rate_tau_s,
        grid,
        from_s: a.from_s,
        to_s: a.to_s,
        even_temperature: a.even_temperature,
        ..Options::default()
    };
    let pb = progress("tuning σ, c");
    let c = if a.diagnose {
        let model = match &a.model {
            Some(p) => PhysicsModel::read(p)?,
            None => PhysicsModel::paper(),
        };
        calibrate_diagnosed(&cal, test.as_ref(), &opts, &model, &provenance, &pb)?
    } else {
        calibrate(&cal, test.as_ref(), &opts, &provenance, &pb)?
    };
    let files = report::write(&c, &inputs, &a.out)?;
    print!("{}{}", report::comparison(&c), report::console_tail(&c));
    println!(
        "wrote {} files to {} (report: {})",
        files.len(),
        a.out.display(),
        a.out.join("report.md").display()
    );
    write_results_md(a)
}
