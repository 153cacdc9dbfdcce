//! The fixed-point evaluator on an FPU-less Cortex-M3 (`thumbv7m-none-eabi`, QEMU
//! `mps2-an385`) matches the host's fixed-point run bit for bit: the image folds every output
//! of `FixedModel::predict` over the QEMU scenario into a chained CRC-32 digest
//! (`compensator_core::fixed::FixedTrace`), and the host computes the same digest.
//!
//! Needs `qemu-system-arm` and the thumbv7m target (`bash tests/setup.sh`); without QEMU the
//! test fails, unless `RLG_ALLOW_MISSING_TOOLS` is set (then it is skipped with a message).

use compensator_core::fixed::{FixedModel, FixedTrace};
use tests::budgets::{self, ImageOptions};
use tests::{firmware, replay};

#[test]
fn cortex_m3_fixed_point_matches_host_bit_for_bit() {
    if !firmware::qemu_or_skip("cortex_m3_fixed_point_matches_host_bit_for_bit") {
        return;
    }
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let bin = dir.join("fixed_scenario.bin");
    let elf = dir.join("fixed_m3_firmware.elf");
    let input = replay::scenario();
    replay::write(&bin, &input).unwrap();
    let opts = ImageOptions {
        fixed_pass: true,
        target: Some(budgets::M3_TARGET.into()),
        ..Default::default()
    };
    budgets::build_image(&bin, &opts, &elf).unwrap_or_else(|e| panic!("{e}"));
    let run = firmware::run_qemu_on(&elf, "mps2-an385", "cortex-m3", budgets::QEMU_TIMEOUT)
        .unwrap_or_else(|e| panic!("{e}"));
    for l in &run.log {
        println!("  {l}");
    }
    assert_eq!(run.exit_code, Some(0));

    let table = tests::default_model_table();
    let fixed = FixedModel::from_table(table).unwrap();
    let mut host = FixedTrace::new(table.as_model());
    let mut outputs = Vec::new();
    for s in &input {
        if let Some(y) = host.step(&fixed, s.temp_c) {
            outputs.push(y);
        }
    }
    let line = run
        .log
        .iter()
        .find(|l| l.contains("fixed:"))
        .expect("fixed-point line in the log");
    assert_eq!(
        firmware::log_field(line, "outputs"),
        Some(u64::from(host.count())),
        "{line}"
    );
    assert_eq!(
        firmware::log_field(line, "digest"),
        Some(u64::from(host.digest())),
        "{line}"
    );
    // The digest depends on every output: changing one by one unit changes it.
    let mut other = FixedTrace::new(table.as_model());
    for (k, y) in outputs.iter().enumerate() {
        let y = if k == outputs.len() / 2 {
            compensator_core::fixed::Q(y.0 ^ 1)
        } else {
            *y
        };
        other.fold(y);
    }
    assert_ne!(other.digest(), host.digest());
    // The f32 path ran on the M3 too (soft-float): its sample stream is complete.
    assert_eq!(run.records.len(), input.len());
    let per_tick = {
        let cal = run.log.iter().find(|l| l.contains("calibration:")).unwrap();
        firmware::log_field(cal, "instructions").unwrap() as f64
            / firmware::log_field(cal, "ticks").unwrap() as f64
    };
    let instr = firmware::log_field(line, "predict_total").unwrap() as f64
        / firmware::log_field(line, "calls").unwrap() as f64
        * per_tick;
    println!(
        "{} fixed-point outputs bit-identical on the Cortex-M3; FixedModel::predict ≈ {instr:.0} instructions ({:.1} per SV)",
        host.count(),
        instr / table.support.len() as f64
    );
}
