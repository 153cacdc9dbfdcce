//! `rlg export`: write a model file as a Rust const table for the board.

use std::path::PathBuf;

use clap::Args;

use rlg_train::model::ModelFile;

/// Arguments of `rlg export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// Model file written by `rlg train`.
    #[arg(long, value_name = "FILE")]
    pub model: PathBuf,
    /// Output Rust source file.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

/// Runs `rlg export`.
pub fn run(a: &ExportArgs, command_line: &str) -> anyhow::Result<()> {
    let m = ModelFile::read(&a.model)?;
    rlg_train::export::write_table(&m, command_line, &a.out)?;
    println!(
        "wrote {} ({} support vectors, {} features)",
        a.out.display(),
        m.lssvm.support.len(),
        m.lssvm.dim()
    );
    Ok(())
}
