//! The `rlg` command line: argument parsing and printing on top of the library.

pub mod bench_length;
pub mod benchmark_diagnose;
pub mod benchmark_lssvm;
pub mod calibrate;
pub mod calibration_report;
pub mod close_loop;
pub mod default_table;
pub mod diagnose;
pub mod export;
pub mod fleet;
pub mod input;
pub mod report;
pub mod resample;
pub mod results;
pub mod simulate;
pub mod static_repro;
pub mod terms;
pub mod train;

use clap::{Parser, Subcommand};

pub use input::{read_axes_cli, read_every_axis, read_recording, InputArgs};

/// Toolchain for LS-SVM temperature compensation of RLG bias.
#[derive(Debug, Parser)]
#[command(name = "rlg", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Sub-commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Calibrate a gyro from a chamber recording: tune, compare with the baselines on held-out
    /// data, write the report, the model and the board tables (Rust and C).
    Calibrate(calibrate::CalibrateArgs),
    /// Train an LS-SVM model and write the model file (JSON).
    Train(train::TrainArgs),
    /// Write a model file as a Rust const table for the board.
    Export(export::ExportArgs),
    /// Regenerate the board's default table from the shipped dynamic scenario.
    DefaultTable(default_table::DefaultTableArgs),
    /// Simulate a thermal-chamber experiment: writes the recording and `<stem>.truth.json`.
    Simulate(simulate::SimulateArgs),
    /// Train every recording of a folder in parallel: one model and one table each.
    TrainFleet(fleet::TrainFleetArgs),
    /// Time training a reduced model from a simulated multi-day 1 Hz campaign; peak memory.
    BenchScale(benchmark_lssvm::BenchScaleArgs),
    /// Time the exact LS-SVM path on data files shared with the Python reference.
    BenchLssvm(benchmark_lssvm::BenchLssvmArgs),
    /// Held-out stability of reduced models vs the full one on the reference dynamic run.
    SparseReport(benchmark_lssvm::SparseReportArgs),
    /// Diagnose where a recording departs from a physics model and which term is missing.
    Diagnose(diagnose::DiagnoseArgs),
    /// Time and peak memory of the diagnosis against the record's length (default 30 days).
    BenchDiagnoseLength(bench_length::BenchLengthArgs),
    /// Run the concealed-effect benchmark of the diagnosis and print its table.
    BenchmarkDiagnose(benchmark_diagnose::BenchmarkDiagnoseArgs),
    /// Pool the clean recordings of several benchmark runs (seeds, block phases): the
    /// p-value calibration as a table and a figure.
    CalibrationReport(calibration_report::CalibrationReportArgs),
    /// Turn a diagnosis into compensation features, retrain on them and compare held out.
    CloseLoop(close_loop::CloseLoopArgs),
    /// Run the close loop on the concealed-effect benchmark's lag, hysteresis and warm-up cases.
    BenchmarkCloseLoop(close_loop::BenchmarkCloseLoopArgs),
    /// Bring a high-rate, jittered or bursty log to a recording: period means or burst means.
    Resample(resample::ResampleArgs),
    /// Reproduce the static least-squares quadratic of Table 1 / Fig. 2(a).
    StaticRepro(static_repro::Args),
    /// Reproduce every result of the paper, print it beside the published values and write
    /// the report folder (Markdown summary and PNG figures).
    Report(report::ReportArgs),
    /// List the physics terms a model file can use: parameters, units, equations.
    Terms(terms::TermsArgs),
}

impl Cli {
    /// Runs the command; `command_line` is recorded as provenance.
    pub fn run(self, command_line: &str) -> anyhow::Result<()> {
        match self.command {
            Command::Calibrate(a) => calibrate::run(&a, command_line),
            Command::Train(a) => train::run(&a, command_line),
            Command::Export(a) => export::run(&a, command_line),
            Command::Simulate(a) => simulate::run(&a),
            Command::DefaultTable(a) => default_table::run(&a),
            Command::TrainFleet(a) => fleet::run(&a, command_line),
            Command::BenchScale(a) => benchmark_lssvm::run_scale(&a),
            Command::BenchLssvm(a) => benchmark_lssvm::run_lssvm(&a),
            Command::SparseReport(a) => benchmark_lssvm::run_sparse(&a),
            Command::Diagnose(a) => diagnose::run(&a),
            Command::BenchmarkDiagnose(a) => benchmark_diagnose::run(&a),
            Command::CalibrationReport(a) => calibration_report::run(&a),
            Command::BenchDiagnoseLength(a) => bench_length::run(&a),
            Command::CloseLoop(a) => close_loop::run(&a, command_line),
            Command::BenchmarkCloseLoop(a) => close_loop::run_benchmark(&a),
            Command::Resample(a) => resample::run(&a),
            Command::StaticRepro(a) => static_repro::run(&a),
            Command::Report(a) => report::run(&a),
            Command::Terms(a) => terms::run(&a),
        }
    }
}

/// Checks before the work that `path` can be written as a file: not a directory, its
/// directory exists. The write itself is atomic (a temporary beside it, then a rename).
pub fn check_output_file(path: &std::path::Path, flag: &str) -> anyhow::Result<()> {
    anyhow::ensure!(
        !path.is_dir(),
        "{flag} {}: is a directory; give a file name",
        path.display()
    );
    let parent = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    anyhow::ensure!(
        parent.is_dir(),
        "{flag} {}: directory {} does not exist",
        path.display(),
        parent.display()
    );
    Ok(())
}

/// The command line as a reproducible string: `rlg` followed by the arguments, each quoted
/// when it holds a space (the program's own path is not recorded).
pub fn command_line<I: IntoIterator<Item = String>>(args: I) -> String {
    let mut out = String::from("rlg");
    for a in args.into_iter().skip(1) {
        out.push(' ');
        if a.is_empty() || a.contains(char::is_whitespace) {
            out.push_str(&format!("{a:?}"));
        } else {
            out.push_str(&a);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_line_drops_the_program_path_and_quotes() {
        let args = ["/x/y/rlg", "train", "--out", "my model.json"].map(String::from);
        assert_eq!(command_line(args), "rlg train --out \"my model.json\"");
    }

    #[test]
    fn cli_definition_is_consistent() {
        use clap::CommandFactory;
        Cli::command().debug_assert();
    }
}
