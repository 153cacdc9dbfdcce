//! The README's main job: `cargo run --release -p tests --bin main-job`.
//!
//! Trains the board's default model on the shipped data, exports its table, runs the
//! Cortex-M4F image in QEMU on the held-out cycles and prints the agreement with the host.

use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "out".to_string()));
    let r = tests::e2e::run(&out)?;
    println!(
        "== Dynamic test (yu2011-dynamic, seed {}), LS-SVM on [T, dT/dt]",
        host_trainer::pipeline::DYNAMIC_SEED
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
