//! `rlg calibrate`: a chamber recording (and optionally a later test recording) to a tuned
//! board table, the comparison with the baselines, and a report folder.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use clap::Args;

use rlg_calibrate::report::{self, FileInfo, Inputs};
use rlg_calibrate::static_cal::{calibrate_static, StaticOptions};
use rlg_calibrate::{calibrate, Options};
use rlg_calibrate::{sampling, Sampling};
use rlg_closeloop::calibrate_diagnosed;
use rlg_diagnose::PhysicsModel;
use rlg_io::progress::progress;
use rlg_io::recording::{Axis, Recording};
use rlg_train::export_c::CName;
use rlg_train::lssvm::tune::Grid;
use rlg_train::model::{Provenance, Removal};

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
    /// bursty log has no 1 Hz stream, so no dT/dt model; one is calibrated so without the
    /// flag, with a note).
    #[arg(long = "static")]
    pub static_only: bool,
    /// Prefix of the C header's symbols (`rlg` → `rlg_support`, `RLG_N`); with --every-axis
    /// each axis' header takes `{NAME}_{axis}`, so the headers of one IMU compile together.
    #[arg(long, value_name = "NAME", default_value = CName::DEFAULT)]
    pub name: CName,
    /// Use a non-empty --out: the files an earlier calibration wrote there are removed first
    /// (other files are left and named).
    #[arg(long)]
    pub force: bool,
    /// Calibrate every gyro axis of the recording (the columns --rate-col names, else every
    /// column with a gyro's name), each into its own folder `--out/{axis}/`, with `imu.h`
    /// including their headers.
    #[arg(long)]
    pub every_axis: bool,
    /// Also write the report (`report.md`) to this file, e.g. a results file kept in the
    /// repository, after a first line naming the command that wrote it.
    #[arg(long, value_name = "FILE", conflicts_with = "every_axis")]
    pub results_md: Option<PathBuf>,
    /// What the board removes: `variation`, the bias' change from its value at 25 °C (an
    /// RLG, whose constant holds the Earth rate and is calibrated at each start; the output
    /// stays centred on that value), or `whole`, the whole bias (a MEMS gyro, whose turn-on
    /// bias dominates; the output is centred on zero). Tables state both the value and the
    /// choice.
    #[arg(long, value_enum, default_value_t = Remove::Variation)]
    pub remove: Remove,
}

/// `--remove`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Remove {
    /// Only the variation about the bias at the reference temperature.
    Variation,
    /// The whole bias.
    Whole,
}

impl From<Remove> for Removal {
    fn from(r: Remove) -> Self {
        match r {
            Remove::Variation => Removal::Variation,
            Remove::Whole => Removal::Whole,
        }
    }
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
    let grid = grid_of(a.c_min)?;
    if let Some(t) = &a.test {
        let same = t == &a.recording
            || Provenance::from_file(t, "")?.data_sha256
                == Provenance::from_file(&a.recording, "")?.data_sha256;
        anyhow::ensure!(
            !same,
            "--test {} holds the same bytes as --recording: held-out figures need another \
             recording (or leave --test out to hold out the later cycles)",
            t.display()
        );
    }
    if let Some(p) = &a.results_md {
        super::check_output_file(p, "--results-md")?;
    }
    // The folder before the work: a path that cannot hold it fails before minutes of work.
    for f in report::prepare_out(&a.out, a.force)? {
        println!(
            "note: --force left `{f}` in {} (not a file of this tool)",
            a.out.display()
        );
    }
    if !a.every_axis {
        let cal = super::read_recording(&a.recording, &a.input)?;
        let test = match &a.test {
            Some(p) => Some(super::read_recording(p, &a.input)?),
            None => None,
        };
        let job = Job {
            args: a,
            command_line,
            grid: &grid,
        };
        job.axis(&cal, test.as_ref(), &a.out, &a.name, &[])?;
        return write_results_md(a);
    }
    every_axis(a, command_line, &grid)
}

/// The tuning grid with `--c-min` as its smallest c.
pub(super) fn grid_of(c_min: f64) -> anyhow::Result<Grid> {
    let mut grid = Grid::default();
    anyhow::ensure!(
        c_min > 0.0 && c_min.is_finite(),
        "--c-min {c_min}: c must be positive"
    );
    anyhow::ensure!(
        c_min < grid.c.1,
        "--c-min {c_min} is above the grid's largest c {}",
        grid.c.1
    );
    grid.c.0 = c_min;
    Ok(grid)
}

/// The folder and C name of an axis: its column name in lower case, every character that
/// is not a letter, a digit or '_' as '_' (`imu.gyro.x` → `imu_gyro_x`).
fn axis_slug(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect()
}

/// `--every-axis`: each axis calibrated into its own folder; an axis that fails does not
/// stop the others, and the command fails naming it.
fn every_axis(a: &CalibrateArgs, command_line: &str, grid: &Grid) -> anyhow::Result<()> {
    let axes = super::read_every_axis(&a.recording, &a.input)?.axes;
    let tests = match &a.test {
        Some(p) => Some(super::read_every_axis(p, &a.input)?.axes),
        None => None,
    };
    let slugs: Vec<String> = axes.iter().map(|x| axis_slug(&x.name)).collect();
    for (i, s) in slugs.iter().enumerate() {
        anyhow::ensure!(
            !slugs[..i].contains(s),
            "axes {:?} and {:?} would share the folder and C name {s:?}; name the rate columns \
             with --rate-col",
            axes[slugs.iter().position(|o| o == s).unwrap_or(0)].name,
            axes[i].name
        );
    }
    let job = Job {
        args: a,
        command_line,
        grid,
    };
    let mut done = Vec::new();
    let mut failed = Vec::new();
    for (axis, slug) in axes.iter().zip(&slugs) {
        println!(
            "\n== axis {} ({} of {}) ==",
            axis.name,
            done.len() + failed.len() + 1,
            axes.len()
        );
        let test = match &tests {
            Some(t) => Some(test_axis(t, &axis.name)?),
            None => None,
        };
        let name = CName::new(&format!("{}_{slug}", a.name))?;
        let note = format!(
            "Axis `{}` of `{}` ({} gyro axes in the file, each calibrated on its own).",
            axis.name,
            a.recording.display(),
            axes.len()
        );
        match job.axis(&axis.recording, test, &a.out.join(slug), &name, &[note]) {
            Ok(()) => done.push(report::ImuAxis {
                slug: slug.clone(),
                c_name: name,
            }),
            Err(e) => {
                eprintln!("error: axis {}: {e:#}", axis.name);
                failed.push(axis.name.clone());
            }
        }
    }
    if !done.is_empty() {
        let [h, rs] = report::write_imu(&a.out, &done)?;
        println!(
            "\nwrote {h} and {rs} to {} (the C header and the Rust module of every calibrated \
             axis)",
            a.out.display()
        );
    }
    anyhow::ensure!(
        failed.is_empty(),
        "{} of {} axes failed ({}); the others' folders are written",
        failed.len(),
        axes.len(),
        failed.join(", ")
    );
    Ok(())
}

/// The test recording's axis of the same name.
fn test_axis<'a>(tests: &'a [Axis], name: &str) -> anyhow::Result<&'a Recording> {
    tests
        .iter()
        .find(|t| t.name == name)
        .map(|t| &t.recording)
        .ok_or_else(|| {
            anyhow::anyhow!(
                "the test recording has no axis {name:?} (it has {})",
                tests
                    .iter()
                    .map(|t| t.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
}

/// One calibration's settings.
struct Job<'a> {
    args: &'a CalibrateArgs,
    command_line: &'a str,
    grid: &'a Grid,
}

impl Job<'_> {
    /// Calibrates one axis `cal` (and its `test`) into `out`, its C header's symbols prefixed
    /// `name`; `notes` go to the report first.
    fn axis(
        &self,
        cal: &Recording,
        test: Option<&Recording>,
        out: &Path,
        name: &CName,
        notes: &[String],
    ) -> anyhow::Result<()> {
        let a = self.args;
        let inputs = Inputs {
            command: self.command_line.to_string(),
            recording: file_info(&a.recording, cal.len())?,
            test_recording: match (&a.test, test) {
                (Some(p), Some(t)) => Some(file_info(p, t.len())?),
                _ => None,
            },
        };
        let provenance = Provenance::from_file(&a.recording, self.command_line)?;
        let bursty = matches!(sampling(cal), Sampling::Bursts(_));
        if a.static_only || (bursty && !a.diagnose) {
            if bursty && !a.static_only {
                println!(
                    "note: the recording is sampled in bursts: it holds no 1 Hz stream, so the \
                     model is the static one (temperature only; --static)"
                );
            }
            return self.static_axis(cal, test, (&inputs, &provenance), out, name, notes);
        }
        let opts = Options {
            train_cycles: a.train_cycles,
            window: a.window as usize,
            block: a.block.map(|b| b as usize),
            budget: a.budget as usize,
            rate_tau_s: a.rate_tau_s,
            grid: *self.grid,
            from_s: a.from_s,
            to_s: a.to_s,
            even_temperature: a.even_temperature,
            remove: a.remove.into(),
            ..Options::default()
        };
        let pb = progress("tuning σ, c");
        let mut c = if a.diagnose {
            let model = match &a.model {
                Some(p) => PhysicsModel::read(p)?,
                None => PhysicsModel::paper(),
            };
            calibrate_diagnosed(cal, test, &opts, &model, &provenance, &pb)?
        } else {
            calibrate(cal, test, &opts, &provenance, &pb)?
        };
        c.notes.splice(0..0, notes.iter().cloned());
        let files = report::write_named(&c, &inputs, out, name)?;
        print!("{}{}", report::comparison(&c), report::console_tail(&c));
        println!(
            "wrote {} files to {} (report: {})",
            files.len(),
            out.display(),
            out.join("report.md").display()
        );
        Ok(())
    }

    /// The static characterisation of one axis.
    fn static_axis(
        &self,
        cal: &Recording,
        test: Option<&Recording>,
        (inputs, provenance): (&Inputs, &Provenance),
        out: &Path,
        name: &CName,
        notes: &[String],
    ) -> anyhow::Result<()> {
        let a = self.args;
        let opts = StaticOptions {
            block: a
                .block
                .map_or(rlg_train::protocol::TRAIN_BLOCK, |b| b as usize),
            budget: a.budget as usize,
            grid: *self.grid,
            rate_tau_s: a.rate_tau_s,
            remove: a.remove.into(),
        };
        let pb = progress("tuning σ, c (static)");
        let mut c = calibrate_static(cal, test, &opts, provenance, &pb)?;
        c.notes.splice(0..0, notes.iter().cloned());
        let files = report::write_static_named(&c, inputs, out, name)?;
        print!(
            "{}",
            report::static_console(&report::static_summary(&c, inputs, &[]))
        );
        for n in &c.notes {
            println!("note: {n}");
        }
        println!("wrote {} files to {}", files.len(), out.display());
        Ok(())
    }
}
