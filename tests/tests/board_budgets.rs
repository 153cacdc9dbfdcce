//! The board budgets as failing tests (`tests::budgets::limits`), at 64 support vectors and
//! two inputs: the image with a synthetic 64-vector table replays `firmware/replay/default.bin`
//! (900 samples) in QEMU on the Cortex-M4F; cost per support vector from its SysTick figures
//! (−icount shift=0, 40 instructions per tick), flash and static RAM from the ELF, the stack
//! high-water mark from the painted stack. Needs `qemu-system-arm` and the thumb target
//! (`bash tests/setup.sh`); without QEMU it fails, unless `RLG_ALLOW_MISSING_TOOLS` is set.

use std::path::Path;

use tests::budgets::{self, limits, ImageOptions};
use tests::firmware;

/// Builds the image for the 64-vector synthetic table (`fixed`: the fixed-point pass too),
/// runs it and returns the run and the image's sizes.
fn run_64(fixed: bool) -> (firmware::QemuRun, budgets::ImageSize) {
    let root = firmware::workspace_root();
    let dir = root.join("target").join("budget-tests");
    std::fs::create_dir_all(&dir).expect("target/budget-tests");
    let n = limits::SUPPORT_VECTORS;
    let t = budgets::synthetic_table(n, 2011);
    let table = dir.join(format!("table_{n}.rs"));
    let text = budgets::table_file(&t, &format!("synthetic table, N = {n}, seed 2011")).unwrap();
    std::fs::write(&table, text).expect("table file");
    let opts = ImageOptions {
        table_file: Some(table),
        fixed_pass: fixed,
        ..Default::default()
    };
    let elf = dir.join(format!(
        "firmware_{n}_{}.elf",
        if fixed { "fixed" } else { "f32" }
    ));
    let replay = root.join("firmware/replay/default.bin");
    budgets::build_image(&replay, &opts, &elf).expect("image builds");
    let run = firmware::run_qemu(&elf, budgets::QEMU_TIMEOUT).expect("QEMU runs");
    assert_eq!(run.exit_code, Some(0), "{:#?}", run.log);
    (
        run,
        budgets::image_size(Path::new(&elf)).expect("ELF sizes"),
    )
}

#[test]
fn f32_image_meets_cost_flash_ram_and_stack_budgets() {
    if !firmware::qemu_or_skip("f32_image_meets_cost_flash_ram_and_stack_budgets") {
        return;
    }
    let (run, size) = run_64(false);
    let cost = budgets::run_cost(&run).expect("cost lines");
    let replay_bytes =
        std::fs::metadata(firmware::workspace_root().join("firmware/replay/default.bin"))
            .unwrap()
            .len();
    let per_sv = cost.step / limits::SUPPORT_VECTORS as f64;
    let flash = size.flash - replay_bytes;
    println!(
        "64 vectors, f32: {per_sv:.1} instructions per vector (≤ {}), flash {flash} B (≤ {}), \
         static RAM {} B (≤ {}), stack {} B (≤ {}), heap {}",
        limits::F32_INSTR_PER_SV,
        limits::FLASH_BYTES,
        size.static_ram,
        limits::STATIC_RAM_BYTES,
        cost.stack_bytes,
        limits::STACK_BYTES,
        if size.has_heap { "yes" } else { "none" }
    );
    assert!(
        per_sv <= limits::F32_INSTR_PER_SV,
        "{per_sv} instructions per vector"
    );
    assert!(flash <= limits::FLASH_BYTES, "flash {flash} B");
    assert!(
        size.static_ram <= limits::STATIC_RAM_BYTES,
        "static RAM {} B",
        size.static_ram
    );
    assert!(
        cost.stack_bytes <= limits::STACK_BYTES,
        "stack {} B",
        cost.stack_bytes
    );
    assert!(!size.has_heap, "the image has a heap");
}

#[test]
fn fixed_point_predict_meets_its_cost_budget() {
    if !firmware::qemu_or_skip("fixed_point_predict_meets_its_cost_budget") {
        return;
    }
    let (run, _) = run_64(true);
    let per_sv = budgets::fixed_cost(&run).expect("fixed line") / limits::SUPPORT_VECTORS as f64;
    println!(
        "64 vectors, fixed point on the M4F: {per_sv:.1} instructions per vector (≤ {})",
        limits::FIXED_INSTR_PER_SV
    );
    assert!(
        per_sv <= limits::FIXED_INSTR_PER_SV,
        "{per_sv} instructions per vector"
    );
}
