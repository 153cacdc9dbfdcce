//! `rlg export`: write a model file as the board's table, a Rust const table or a C header.

use std::path::PathBuf;

use clap::Args;

use rlg_train::export::Format;
use rlg_train::export_c::CName;
use rlg_train::model::ModelFile;

/// Arguments of `rlg export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// Model file written by `rlg train`.
    #[arg(long, value_name = "FILE")]
    pub model: PathBuf,
    /// Output file: `.rs` for a Rust const table, `.h` for a C header.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Table language; by default the one `--out`'s extension names (an error when they
    /// disagree).
    #[arg(long, value_enum, value_name = "LANG")]
    pub format: Option<FormatArg>,
    /// Prefix of the C header's symbols (`rlg` → `rlg_support`, `RLG_N`): give each gyro its
    /// own (`rlg_gyro_x`) so that several headers compile into one firmware.
    #[arg(long, value_name = "NAME", default_value = CName::DEFAULT)]
    pub name: CName,
}

/// `--format` values.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum FormatArg {
    /// Rust const table for compensator-core.
    Rust,
    /// C header (same f32 numbers).
    C,
}

/// Runs `rlg export`.
pub fn run(a: &ExportArgs, command_line: &str) -> anyhow::Result<()> {
    let given = a.format.map(|f| match f {
        FormatArg::Rust => Format::Rust,
        FormatArg::C => Format::C,
    });
    // Checked before the model is read, so a wrong name costs nothing.
    let format = Format::resolve(given, &a.out).map_err(anyhow::Error::msg)?;
    super::check_output_file(&a.out, "--out")?;
    let m = ModelFile::read(&a.model)?;
    rlg_train::export::write_board_table_named(&m, command_line, &a.out, format, &a.name)?;
    println!(
        "wrote {} ({}, {} support vectors, {} features)",
        a.out.display(),
        format.name(),
        m.lssvm.support.len(),
        m.lssvm.dim()
    );
    Ok(())
}
