//! Measures the board budgets and prints them as a table: `cargo run --release -p tests --bin
//! budgets`. Needs `qemu-system-arm` and the thumb target (`bash tests/setup.sh`).
//!
//! For the committed default table and for synthetic tables of 16, 32, 64 and 128 support
//! vectors (2 inputs) it builds the board image, replays `firmware/replay/default.bin` (900
//! samples) in QEMU, and reads the image's SysTick figures; flash and RAM come from the ELF
//! section headers. Method and definitions: `tests/src/budgets.rs`.

use std::path::Path;

use anyhow::{bail, Context};
use tests::budgets::{self, ImageOptions};
use tests::firmware;

use budgets::limits::{
    F32_INSTR_PER_SV as MAX_INSTR_PER_SV, FIXED_INSTR_PER_SV as MAX_FIXED_INSTR_PER_SV,
    FLASH_BYTES as MAX_FLASH_BYTES, STACK_BYTES as MAX_STACK_BYTES,
    STATIC_RAM_BYTES as MAX_RAM_BYTES,
};

fn main() -> anyhow::Result<()> {
    if !firmware::qemu_available() {
        bail!("{} not found: run `bash tests/setup.sh`", firmware::QEMU);
    }
    let root = firmware::workspace_root();
    let dir = root.join("target").join("budgets");
    std::fs::create_dir_all(&dir).context("create target/budgets")?;
    let replay = root.join("firmware/replay/default.bin");
    let replay_bytes = std::fs::metadata(&replay)
        .with_context(|| replay.display().to_string())?
        .len();

    println!("replay data compiled into each image: {replay_bytes} bytes (subtracted from flash)");
    let rows = f32_images(&dir, &replay, replay_bytes)?;
    let fixed_64 = fixed_images(&dir, &replay, replay_bytes)?;
    println!();
    println!(
        "units: instructions per call (SysTick ticks × {:.2} instructions/tick from the calibration loop, -icount shift=0); \
         bytes; errors = max |f32 − f64| of Eq. (10) over a 121×121 grid of the trained range, °/h",
        rows[0].1.per_tick
    );
    targets(&rows, fixed_64, replay_bytes)
}

/// One f32 image's figures: support vectors, cost, size.
type Row = (usize, budgets::RunCost, budgets::ImageSize);

/// The f32 images of the synthetic tables and the committed one, built, run and printed.
fn f32_images(dir: &Path, replay: &Path, replay_bytes: u64) -> anyhow::Result<Vec<Row>> {
    println!(
        "{:>5} {:>10} {:>9} {:>11} {:>9} {:>11} {:>9} {:>9} {:>10} {:>9} {:>7} {:>6} {:>11} {:>11}",
        "N",
        "step",
        "step/SV",
        "kern libm",
        "libm/SV",
        "kern fast",
        "fast/SV",
        "flash",
        "flash-rep",
        "RAM",
        "stack",
        "heap",
        "err libm",
        "err fast"
    );
    let mut rows = Vec::new();
    for n in [16usize, 32, 64, 128, 0] {
        let (opts, model_owned);
        if n == 0 {
            opts = ImageOptions::default();
            model_owned = None;
        } else {
            let t = budgets::synthetic_table(n, 2011);
            let path = dir.join(format!("table_{n}.rs"));
            let text = budgets::table_file(&t, &format!("synthetic table, N = {n}, seed 2011"))?;
            std::fs::write(&path, text).with_context(|| path.display().to_string())?;
            opts = ImageOptions {
                table_file: Some(path),
                fault: None,
                ..Default::default()
            };
            model_owned = Some(t);
        }
        let elf = dir.join(format!("firmware_{n}.elf"));
        budgets::build_image(replay, &opts, &elf)?;
        let run = firmware::run_qemu(&elf, budgets::QEMU_TIMEOUT)?;
        if run.exit_code != Some(0) {
            bail!(
                "N={n}: image exited with {:?}: {:#?}",
                run.exit_code,
                run.log
            );
        }
        let cost = budgets::run_cost(&run).with_context(|| format!("N={n}: {:#?}", run.log))?;
        let size = budgets::image_size(Path::new(&elf))?;
        let (n_sv, (e_libm, e_fast)) = match &model_owned {
            Some(t) => (n, budgets::max_errors_dph(&t.as_model())),
            None => {
                let m = tests::default_model_table();
                (m.support.len(), budgets::max_errors_dph(&m.as_model()))
            }
        };
        let nf = n_sv as f64;
        println!(
            "{:>5} {:>10.0} {:>9.1} {:>11.0} {:>9.1} {:>11.0} {:>9.1} {:>9} {:>10} {:>9} {:>7} {:>6} {:>11.2e} {:>11.2e}",
            if n == 0 { format!("{n_sv}*") } else { n_sv.to_string() },
            cost.step,
            cost.step / nf,
            cost.kernel_libm,
            cost.kernel_libm / nf,
            cost.kernel_fast,
            cost.kernel_fast / nf,
            size.flash,
            size.flash - replay_bytes,
            size.static_ram,
            cost.stack_bytes,
            if size.has_heap { "yes" } else { "none" },
            e_libm,
            e_fast
        );
        rows.push((n_sv, cost, size));
    }
    println!("* the committed default table (firmware/src/model_table.rs)");

    Ok(rows)
}

/// The fixed-point images (Cortex-M4F and M3) of the same tables, built, run and printed;
/// `FixedModel::predict` instructions per vector at 64 vectors on each.
fn fixed_images(dir: &Path, replay: &Path, replay_bytes: u64) -> anyhow::Result<[f64; 2]> {
    // Fixed point: the same tables, `FixedModel::predict` timed in an RLG_FW_FIXED image on
    // the Cortex-M4F and on the FPU-less Cortex-M3 (where the f32 step is soft-float).
    println!();
    println!(
        "{:>5} {:>12} {:>9} {:>12} {:>9} {:>13} {:>9} {:>9} {:>7} {:>11}",
        "N",
        "fixed M4F",
        "/SV",
        "fixed M3",
        "/SV",
        "f32 step M3",
        "/SV",
        "flash M3",
        "RAM M3",
        "err fixed"
    );
    // Fixed-point predict per vector at 64 vectors, M4F and M3, for the targets.
    let mut fixed_64 = [f64::NAN; 2];
    for n in [16usize, 32, 64, 128, 0] {
        let table_file = (n > 0).then(|| dir.join(format!("table_{n}.rs")));
        let mut fixed_instr = [0.0f64; 2];
        let mut m3 = None;
        for (slot, target) in [(0usize, None), (1, Some(budgets::M3_TARGET.to_string()))] {
            let opts = ImageOptions {
                table_file: table_file.clone(),
                fixed_pass: true,
                target: target.clone(),
                ..Default::default()
            };
            let elf = dir.join(format!("firmware_fixed_{n}_{slot}.elf"));
            budgets::build_image(replay, &opts, &elf)?;
            let run = if target.is_some() {
                firmware::run_qemu_on(&elf, "mps2-an385", "cortex-m3", budgets::QEMU_TIMEOUT)?
            } else {
                firmware::run_qemu(&elf, budgets::QEMU_TIMEOUT)?
            };
            if run.exit_code != Some(0) {
                bail!(
                    "N={n} fixed: image exited with {:?}: {:#?}",
                    run.exit_code,
                    run.log
                );
            }
            fixed_instr[slot] = budgets::fixed_cost(&run).context("fixed line")?;
            if target.is_some() {
                let c = budgets::run_cost(&run).context("cost lines")?;
                m3 = Some((c.step, budgets::image_size(&elf)?));
            }
        }
        let (n_sv, err) = if n == 0 {
            let t = tests::default_model_table();
            (t.support.len(), budgets::max_fixed_error_dph(t))
        } else {
            let t = budgets::synthetic_table(n, 2011);
            let e = match n {
                16 => budgets::sized::<16>(&t).and_then(|t| budgets::max_fixed_error_dph(&t)),
                32 => budgets::sized::<32>(&t).and_then(|t| budgets::max_fixed_error_dph(&t)),
                64 => budgets::sized::<64>(&t).and_then(|t| budgets::max_fixed_error_dph(&t)),
                _ => budgets::sized::<128>(&t).and_then(|t| budgets::max_fixed_error_dph(&t)),
            };
            (n, e)
        };
        let nf = n_sv as f64;
        if n == 64 {
            fixed_64 = [fixed_instr[0] / nf, fixed_instr[1] / nf];
        }
        let (m3_step, m3_size) = m3.context("M3 run")?;
        println!(
            "{:>5} {:>12.0} {:>9.1} {:>12.0} {:>9.1} {:>13.0} {:>9.1} {:>9} {:>7} {:>11.2e}",
            if n == 0 {
                format!("{n_sv}*")
            } else {
                n_sv.to_string()
            },
            fixed_instr[0],
            fixed_instr[0] / nf,
            fixed_instr[1],
            fixed_instr[1] / nf,
            m3_step,
            m3_step / nf,
            m3_size.flash - replay_bytes,
            m3_size.static_ram,
            err.unwrap_or(f64::NAN)
        );
    }
    println!(
        "fixed = FixedModel::predict only (Eq. 10, integer); f32 step M3 = the whole soft-float step;          flash M3 excludes the replay data and includes the fixed-point pass; err = max |fixed − f64|, °/h"
    );
    Ok(fixed_64)
}

/// The targets at 64 vectors, 2 inputs, printed; an error when one is not met.
fn targets(rows: &[Row], fixed_64: [f64; 2], replay_bytes: u64) -> anyhow::Result<()> {
    // Marginal cost per support vector: slope of the step between 16 and 128 vectors.
    let (c16, c128) = (&rows[0].1, &rows[3].1);
    let slope = |a: f64, b: f64| (b - a) / 112.0;
    println!(
        "marginal instructions per support vector (16 → 128): step {:.1}, kernel libm {:.1}, kernel fast {:.1}",
        slope(c16.step, c128.step),
        slope(c16.kernel_libm, c128.kernel_libm),
        slope(c16.kernel_fast, c128.kernel_fast)
    );
    let (_, c64, s64) = &rows[2];
    let per_sv = c64.step / 64.0;
    let libm_step = c64.step - c64.kernel_fast + c64.kernel_libm;
    let verdict = |ok: bool| if ok { "met" } else { "NOT met" };
    println!("targets at 64 SVs / 2 inputs:");
    println!(
        "  instructions per SV ≤ {MAX_INSTR_PER_SV}: shipped (fast exp) whole step / 64 = {:.1} → {}; with libm expf instead {:.1} → {}",
        per_sv,
        verdict(per_sv <= MAX_INSTR_PER_SV),
        libm_step / 64.0,
        verdict(libm_step / 64.0 <= MAX_INSTR_PER_SV)
    );
    println!(
        "  instructions per SV ≤ {MAX_FIXED_INSTR_PER_SV}, fixed point (predict alone): M4F {:.1} → {}, M3 {:.1} → {}",
        fixed_64[0],
        verdict(fixed_64[0] <= MAX_FIXED_INSTR_PER_SV),
        fixed_64[1],
        verdict(fixed_64[1] <= MAX_FIXED_INSTR_PER_SV)
    );
    let flash = s64.flash - replay_bytes;
    println!(
        "  flash ≤ {MAX_FLASH_BYTES} B excluding replay data: {flash} B → {}",
        verdict(flash <= MAX_FLASH_BYTES)
    );
    println!(
        "  static RAM ≤ {MAX_RAM_BYTES} B: {} B → {}; stack high-water {} B (not static RAM)",
        s64.static_ram,
        verdict(s64.static_ram <= MAX_RAM_BYTES),
        c64.stack_bytes
    );
    println!(
        "  stack high-water ≤ {MAX_STACK_BYTES} B: {} B → {}",
        c64.stack_bytes,
        verdict(c64.stack_bytes <= MAX_STACK_BYTES)
    );
    println!("  no heap: {}", verdict(!s64.has_heap));
    let met = [
        per_sv <= MAX_INSTR_PER_SV,
        fixed_64[0] <= MAX_FIXED_INSTR_PER_SV && fixed_64[1] <= MAX_FIXED_INSTR_PER_SV,
        flash <= MAX_FLASH_BYTES,
        s64.static_ram <= MAX_RAM_BYTES,
        c64.stack_bytes <= MAX_STACK_BYTES,
        !s64.has_heap,
    ];
    if met.contains(&false) {
        bail!("a board budget is NOT met (above)");
    }
    Ok(())
}
