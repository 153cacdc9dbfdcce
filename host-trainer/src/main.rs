//! `rlg`: the command-line front end of `host-trainer`.
use clap::Parser;

fn main() -> anyhow::Result<()> {
    let line = host_trainer::cli::command_line(std::env::args());
    host_trainer::cli::Cli::parse().run(&line)
}
