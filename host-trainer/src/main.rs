//! `rlg`: the command-line front end of `host-trainer`.

mod cli;

use clap::{Parser, Subcommand};

/// Temperature compensation of ring-laser-gyro bias (Yu et al. 2011): simulate, train, export.
#[derive(Debug, Parser)]
#[command(name = "rlg", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate a thermal-chamber experiment: writes the recording and `<stem>.truth.json`.
    Simulate(cli::simulate::SimulateArgs),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::Simulate(a) => cli::simulate::run(&a),
    }
}
