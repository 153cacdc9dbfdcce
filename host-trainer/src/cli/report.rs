//! `rlg report`: reproduces the paper (static and dynamic tests), prints the table of
//! published against measured figures and writes the report folder.

use std::path::PathBuf;

use rlg_io::progress::progress;

use rlg_eval::metrics::compare::markdown_table;
use rlg_io::table1;
use rlg_repro::{dynamic, report, static_test};

/// Arguments of `rlg report`.
#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// Folder to write `README.md` and the PNG figures into (created if missing).
    #[arg(long, value_name = "DIR", default_value = "report")]
    pub out: PathBuf,
    /// Not an option of `report`, which reproduces the paper on its own scenario: a
    /// recording of your own goes to `rlg calibrate --recording FILE --out DIR`.
    #[arg(long, value_name = "FILE", hide = true)]
    pub recording: Option<PathBuf>,
    /// Seed of the simulated dynamic test.
    #[arg(long, value_name = "N", default_value_t = rlg_repro::pipeline::DYNAMIC_SEED)]
    pub seed: u64,
    /// Train on means of this many 1 Hz samples (100: the paper's averaging; 1: raw 1 Hz).
    #[arg(long, value_name = "N", default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..=3600))]
    pub block: u64,
    /// Window of the bias stability, samples at 1 Hz (100: the paper's 100 s stability).
    #[arg(long, value_name = "S", default_value_t = 100, value_parser = clap::value_parser!(u64).range(2..=100_000))]
    pub window: u64,
    /// Stepwise entry significance.
    #[arg(long, value_name = "P", default_value_t = 0.05)]
    pub alpha_enter: f64,
    /// Stepwise removal significance.
    #[arg(long, value_name = "P", default_value_t = 0.10)]
    pub alpha_remove: f64,
    /// Table 1 CSV (default: the copy shipped with the crate).
    #[arg(long, value_name = "FILE")]
    pub table: Option<PathBuf>,
}

/// Runs both reproductions, prints the comparison and writes the folder.
pub fn run(args: &ReportArgs) -> anyhow::Result<()> {
    if let Some(r) = &args.recording {
        anyhow::bail!(
            "rlg report reproduces the paper on its shipped scenario; for a recording of your \
             own run `rlg calibrate --recording {} --out {}`",
            r.display(),
            args.out.display()
        );
    }
    let rows = match &args.table {
        Some(p) => table1::read_table1(p)?,
        None => table1::bundled()?,
    };
    let opts = dynamic::DynamicOptions {
        seed: args.seed,
        block: args.block as usize,
        window: args.window as usize,
        stepwise: rlg_eval::baselines::StepwiseOptions {
            alpha_enter: args.alpha_enter,
            alpha_remove: args.alpha_remove,
            ..Default::default()
        },
        ..Default::default()
    };
    let st = static_test::reproduce(&rows, &opts.grid, &progress("static LS-SVM: LOO grid"))?;
    let dy = dynamic::reproduce(&opts, &progress("dynamic LS-SVM: blocked CV"))?;
    println!("== Reproduction of Yu et al. 2011 (paper value beside measured value)");
    print!("{}", markdown_table(&report::headline(&st, &dy)));
    println!("\n== Dynamic test, per model");
    print!("{}", dy.to_markdown());
    let files = report::write(&args.out, &st, &dy)?;
    println!(
        "\nwrote {} files to {} (summary: {})",
        files.len(),
        args.out.display(),
        args.out.join("README.md").display()
    );
    Ok(())
}
