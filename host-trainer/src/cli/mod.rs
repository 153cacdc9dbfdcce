//! The `rlg` command line: argument parsing and printing on top of the library.

pub mod benchmark_diagnose;
pub mod diagnose;
pub mod export;
pub mod simulate;
pub mod train;

use clap::{Parser, Subcommand};

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
    /// Train an LS-SVM model and write the model file (JSON).
    Train(train::TrainArgs),
    /// Write a model file as a Rust const table for the board.
    Export(export::ExportArgs),
    /// Simulate a thermal-chamber experiment: writes the recording and `<stem>.truth.json`.
    Simulate(simulate::SimulateArgs),
    /// Diagnose where a recording departs from a physics model and which term is missing.
    Diagnose(diagnose::DiagnoseArgs),
    /// Run the concealed-effect benchmark of the diagnosis and print its table.
    BenchmarkDiagnose(benchmark_diagnose::BenchmarkDiagnoseArgs),
}

impl Cli {
    /// Runs the command; `command_line` is recorded as provenance.
    pub fn run(self, command_line: &str) -> anyhow::Result<()> {
        match self.command {
            Command::Train(a) => train::run(&a, command_line),
            Command::Export(a) => export::run(&a, command_line),
            Command::Simulate(a) => simulate::run(&a),
            Command::Diagnose(a) => diagnose::run(&a),
            Command::BenchmarkDiagnose(a) => benchmark_diagnose::run(&a),
        }
    }
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
