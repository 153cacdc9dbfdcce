//! The README's main job: `cargo run --release -p tests --bin main-job`.
//!
//! Reproduces the paper (static and dynamic tests) and prints the published figures beside the
//! measured ones, writes the report folder, then trains the board's default model on the
//! shipped data, exports its table, runs the Cortex-M4F image in QEMU on the held-out cycles
//! and prints the agreement with the host.

use std::path::PathBuf;

use rlg_eval::metrics::compare::markdown_table;
use rlg_io::progress::progress;
use rlg_repro::{dynamic, report, static_test};

fn main() -> anyhow::Result<()> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "out".to_string()));

    let opts = dynamic::DynamicOptions::default();
    let st = static_test::reproduce(
        &rlg_io::table1::bundled()?,
        &opts.grid,
        &progress("static LS-SVM: LOO grid"),
    )?;
    let dy = dynamic::reproduce(&opts, &progress("dynamic LS-SVM: blocked CV"))?;
    println!("== Reproduction of Yu et al. 2011 (paper value beside measured value)");
    print!("{}", markdown_table(&report::headline(&st, &dy)));
    println!();
    print!("{}", dy.to_markdown());
    let dir = out.join("report");
    let files = report::write(&dir, &st, &dy)?;
    println!(
        "  report: {} ({} files)\n",
        dir.join("README.md").display(),
        files.len()
    );

    let r = tests::e2e::run(&out)?;
    println!(
        "== Dynamic test (yu2011-dynamic, seed {}), LS-SVM on [T, dT/dt]",
        rlg_repro::pipeline::DYNAMIC_SEED
    );
    println!(
        "  support vectors                      {}",
        r.support_vectors
    );
    println!(
        "  TRAINING rms, first-cycle 100 s means {:.2e} °/h",
        r.train_rms_dph
    );
    println!("  held-out samples (cycles 2..)        {}", r.test_samples);
    println!(
        "  HELD-OUT 100 s stability, raw         {:.5} °/h",
        r.test_b100_raw_dph
    );
    println!(
        "  HELD-OUT 100 s stability, compensated {:.5} °/h (board f32 path on the host)",
        r.test_b100_comp_dph
    );
    println!(
        "  max |f32 board − f64 trainer| correction {:.2e} °/h",
        r.max_f32_vs_f64_dph
    );
    println!("== Export");
    println!(
        "  {}/model_table.rs identical to the committed firmware table: {}",
        out.display(),
        r.committed_table_fresh
    );
    println!("== Board (Cortex-M4F image in QEMU mps2-an386, held-out cycles replayed)");
    for line in &r.board_log {
        println!("  log: {line}");
    }
    println!(
        "  samples {}, bit-identical to the host {} ({})",
        r.board_samples,
        r.board_identical,
        if r.board_samples == r.board_identical && r.board_samples == r.test_samples {
            "all"
        } else {
            "MISMATCH"
        }
    );
    println!(
        "  board output 100 s stability          {:.5} °/h",
        r.board_b100_dph
    );
    anyhow::ensure!(
        r.board_samples == r.test_samples && r.board_identical == r.board_samples,
        "the board's output differs from the host reference"
    );
    Ok(())
}
