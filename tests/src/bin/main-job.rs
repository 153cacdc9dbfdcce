//! The README's main job: `cargo run --release -p tests --bin main-job`.
//!
//! Reproduces the paper (static and dynamic tests) and prints the published figures beside the
//! measured ones, writes the report folder, then trains the board's default model on the
//! shipped data, exports its table, runs the Cortex-M4F image in QEMU on the held-out cycles
//! and prints the agreement with the host. Its figures are also written to
//! `host-trainer/results/paper.md` ([`RESULTS_FILE`]), once the board agrees with the host.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context as _;
use rlg_eval::metrics::compare::markdown_table;
use rlg_io::progress::progress;
use rlg_repro::{dynamic, report, static_test};
use tests::e2e::E2eReport;

/// The results file the main job writes, relative to the workspace root.
const RESULTS_FILE: &str = "host-trainer/results/paper.md";

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
    let paper = tests::firmware::workspace_root().join(RESULTS_FILE);
    if let Some(dir) = paper.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let md = report::tables_markdown(&st, &dy) + &board_markdown(&r);
    rlg_io::atomic::write(
        &paper,
        format!("Written by `cargo run --release -p tests --bin main-job`.\n\n{md}").as_bytes(),
    )
    .with_context(|| format!("writing {}", paper.display()))?;
    Ok(())
}

/// The results file's section on the board's default table: the figures printed under
/// "Dynamic test", "Export" and "Board" above.
fn board_markdown(r: &E2eReport) -> String {
    let mut s = format!(
        "\n## The board's default table\n\n\
         Trained on the first cycle of the dynamic test's run (seed {}) and exported as the \
         board's f32 table; the held-out cycles compensated by the board's f32 code on the \
         host and by the Cortex-M4F image in QEMU (`mps2-an386`), against the f64 trainer.\n\n\
         | | |\n|---|---:|\n",
        rlg_repro::pipeline::DYNAMIC_SEED
    );
    let rows = [
        ("support vectors", r.support_vectors.to_string()),
        (
            "TRAINING rms, first-cycle 100 s means, °/h",
            format!("{:.2e}", r.train_rms_dph),
        ),
        ("held-out samples, 1 Hz", r.test_samples.to_string()),
        (
            "HELD-OUT 100 s stability, raw, °/h",
            format!("{:.5}", r.test_b100_raw_dph),
        ),
        (
            "HELD-OUT 100 s stability, compensated (board f32 path on the host), °/h",
            format!("{:.5}", r.test_b100_comp_dph),
        ),
        (
            "max \\|f32 board − f64 trainer\\| correction, °/h",
            format!("{:.2e}", r.max_f32_vs_f64_dph),
        ),
        (
            "exported table identical to the committed `firmware/src/model_table.rs`",
            r.committed_table_fresh.to_string(),
        ),
        (
            "board samples (QEMU), bit-identical to the host",
            format!("{} of {}", r.board_identical, r.board_samples),
        ),
        (
            "HELD-OUT 100 s stability of the board's output, °/h",
            format!("{:.5}", r.board_b100_dph),
        ),
    ];
    for (what, value) in rows {
        let _ = writeln!(s, "| {what} | {value} |");
    }
    s += "\nThe image's log (defmt, decoded; costs in SysTick ticks under `-icount shift=0`):\n\n```text\n";
    for line in &r.board_log {
        let _ = writeln!(s, "{line}");
    }
    s += "```\n";
    s
}
