//! `rlg default-table`: regenerate the board's default table from the shipped scenario.

use std::path::PathBuf;

use clap::Args;

use rlg_repro::pipeline;

/// Arguments of `rlg default-table`.
#[derive(Debug, Args)]
pub struct DefaultTableArgs {
    /// Output Rust source file (the committed one is `firmware/src/model_table.rs`).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

/// Runs `rlg default-table`.
pub fn run(a: &DefaultTableArgs) -> anyhow::Result<()> {
    let (run, model) = pipeline::default_model()?;
    let source = rlg_train::export::table_source(&model, pipeline::DEFAULT_TABLE_COMMAND)?;
    rlg_train::model::write_atomic(&a.out, source.as_bytes())?;
    println!(
        "wrote {}: {} support vectors trained on {:.0} s of {} s (first of {} cycles); \
         TRAINING rms {:.2e} °/h, max {:.2e} °/h",
        a.out.display(),
        model.lssvm.support.len(),
        run.train_end_s(),
        run.recording.time_s.last().copied().unwrap_or(0.0),
        run.cycles.len(),
        model.training.rms_dph,
        model.training.max_abs_dph,
    );
    Ok(())
}
