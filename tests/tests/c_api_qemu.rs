//! A C firmware image (its own `main`, built with `arm-none-eabi-gcc` and linked with the
//! thumb library of the C API) replays the held-out record of the main job in QEMU: the f32
//! compensator on `mps2-an386` (Cortex-M4F, `thumbv7em-none-eabihf`), the fixed-point one on
//! `mps2-an385` (Cortex-M3, `thumbv7m-none-eabi`). Every output is compared bit for bit with the
//! Rust compensator run on the host over the same inputs, and the image is held to the Rust
//! image's budgets (`tests::budgets::limits`), measured the same way: SysTick under
//! `-icount shift=0` with the image's own calibration, flash and static RAM from the ELF
//! (replay data subtracted), the stack high-water mark from a painted stack.
//!
//! The library is built with `no-panic-proof`: its panic handler calls a function defined
//! nowhere, so the images link only if no panic is reachable from the C API functions they
//! call (all of them, between the two images: `main.c` exercises bad input on each). The
//! negative control (`no-panic-control`) must fail that link.
//!
//! Needs `qemu-system-arm`, the thumb targets and `arm-none-eabi-gcc` with newlib
//! (`bash tests/setup.sh`); without them the tests fail, unless `RLG_ALLOW_MISSING_TOOLS` is
//! set.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use compensator_core::fixed::{FixedCompensator, FixedModel};
use compensator_core::{Compensated, Compensator, SensorLimits};
use tests::budgets::{self, limits};
use tests::capi;
use tests::firmware::{self, log_field, QemuRun};
use tests::replay::{self, ReplaySample};

/// QEMU needs a few seconds for the record; this only catches a hung image.
const QEMU_TIMEOUT: Duration = Duration::from_secs(300);

/// One of the two images.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Image {
    /// f32 on the Cortex-M4F.
    F32,
    /// Fixed point on the Cortex-M3.
    Fixed,
}

impl Image {
    fn target(self) -> &'static str {
        match self {
            Image::F32 => firmware::TARGET,
            Image::Fixed => budgets::M3_TARGET,
        }
    }

    fn gcc_flags(self) -> &'static [&'static str] {
        match self {
            Image::F32 => &[
                "-mcpu=cortex-m4",
                "-mthumb",
                "-mfloat-abi=hard",
                "-mfpu=fpv4-sp-d16",
            ],
            Image::Fixed => &[
                "-mcpu=cortex-m3",
                "-mthumb",
                "-mfloat-abi=soft",
                "-DRLG_FIXED",
            ],
        }
    }

    fn machine(self) -> (&'static str, &'static str) {
        match self {
            Image::F32 => ("mps2-an386", "cortex-m4"),
            Image::Fixed => ("mps2-an385", "cortex-m3"),
        }
    }
}

/// The shared inputs: the record and its replay file, the table header, the work folder.
struct Inputs {
    dir: PathBuf,
    record: Vec<ReplaySample>,
    replay_file: PathBuf,
}

fn inputs() -> &'static Inputs {
    static INPUTS: OnceLock<Inputs> = OnceLock::new();
    INPUTS.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("c_api_qemu");
        std::fs::create_dir_all(&dir).unwrap();
        let table = tests::default_model_table();
        capi::write_table_header(&table.as_model(), "rlg", &dir, "rlg_model_table.h");
        let record = capi::held_out_record();
        let replay_file = dir.join("heldout.bin");
        replay::write(&replay_file, &record).unwrap();
        Inputs {
            dir,
            record,
            replay_file,
        }
    })
}

/// Whether every tool is there (a missing one fails, unless the opt-out is set).
fn tools(test: &str) -> bool {
    firmware::qemu_or_skip(test) && capi::tool_or_skip(test, capi::ARM_GCC)
}

/// Links the C image for `image` against `lib`; `Err` with the linker's words on failure.
fn link_image(image: Image, lib: &Path, elf: &Path) -> Result<(), String> {
    let i = inputs();
    let src = capi::c_dir().join("firmware");
    let mut cmd = Command::new(capi::ARM_GCC);
    cmd.args(image.gcc_flags())
        .args(["-std=c99", "-Os", "-g", "-Wall", "-Wextra", "-Werror"])
        .args(["-ffunction-sections", "-fdata-sections", "-nostartfiles"])
        .args(["--specs=nano.specs", "-Wl,--gc-sections"])
        .arg(format!("-DRLG_REPLAY_PATH=\"{}\"", i.replay_file.display()))
        .arg("-I")
        .arg(capi::include_dir())
        .arg("-I")
        .arg(&i.dir)
        .arg("-I")
        .arg(&src)
        .arg("-L")
        .arg(firmware::workspace_root())
        .arg("-T")
        .arg(src.join("link.ld"));
    for f in ["main.c", "startup.c", "semihosting.c", "replay.S"] {
        cmd.arg(src.join(f));
    }
    cmd.arg(lib).arg("-o").arg(elf);
    capi::run_compiler(&mut cmd)
}

/// Builds the proof library for `image`'s target and links the image.
fn build(image: Image) -> PathBuf {
    let dir = &inputs().dir;
    let lib = dir.join(format!("librlg_compensator_{image:?}.a"));
    capi::build_library(Some(image.target()), &["no-panic-proof"], &lib)
        .unwrap_or_else(|e| panic!("{e}"));
    let elf = dir.join(format!("c_firmware_{image:?}.elf"));
    link_image(image, &lib, &elf).unwrap_or_else(|e| {
        panic!("the C image does not link (a reachable panic names rlg_panic_is_reachable):\n{e}")
    });
    elf
}

fn line<'a>(run: &'a QemuRun, key: &str) -> &'a str {
    run.log
        .iter()
        .find(|l| l.starts_with(key))
        .unwrap_or_else(|| panic!("no {key} line in {:#?}", run.log))
}

/// Runs `image`, checks it against the Rust outputs `want`, and holds it to the budgets.
fn replay_and_check(image: Image, want: impl Iterator<Item = Compensated>) {
    let t0 = Instant::now();
    let elf = build(image);
    let t_built = Instant::now();
    let (machine, cpu) = image.machine();
    let run =
        firmware::run_qemu_text(&elf, machine, cpu, QEMU_TIMEOUT).unwrap_or_else(|e| panic!("{e}"));
    for l in &run.log {
        println!("  {l}");
    }
    assert_eq!(
        run.exit_code,
        Some(0),
        "{:#?} {:#?}",
        run.log,
        run.other_stderr
    );
    let checks = line(&run, "checks:");
    assert_eq!(log_field(checks, "failed"), Some(0), "{checks}");
    assert!(log_field(checks, "passed") >= Some(12), "{checks}");
    assert_eq!(log_field(line(&run, "init:"), "error"), Some(0));

    let record = &inputs().record;
    let n = record.len();
    assert_eq!(
        (run.begin_count, run.end_count),
        (Some(n as u32), Some(n as u32))
    );
    assert_eq!(run.records.len(), n);
    let mut identical = 0;
    let mut first = Vec::new();
    for ((k, (s, r)), w) in record.iter().enumerate().zip(&run.records).zip(want) {
        assert_eq!(r.index, k as u32);
        assert_eq!(
            (r.temp_c_bits, r.gyro_dph_bits),
            (s.temp_c.to_bits(), s.rate_dph.to_bits())
        );
        let got = (r.rate_dph_bits, r.correction_dph_bits, r.status);
        let exp = (w.rate_dph.to_bits(), w.correction_dph.to_bits(), w.status.0);
        if got == exp {
            identical += 1;
        } else if first.len() < 5 {
            first.push(format!("sample {k}: C image {got:08x?}, Rust {exp:08x?}"));
        }
    }
    println!("{image:?} image in QEMU {machine}: {identical} of {n} outputs bit-identical to the Rust compensator");
    assert_eq!(identical, n, "{first:#?}");

    let cal = line(&run, "calibration:");
    let per_tick =
        log_field(cal, "instructions").unwrap() as f64 / log_field(cal, "ticks").unwrap() as f64;
    assert!((per_tick / 40.0 - 1.0).abs() < 0.01, "{cal}");
    let cost = line(&run, "cost:");
    let step = log_field(cost, "total").unwrap() as f64 / log_field(cost, "calls").unwrap() as f64
        * per_tick;
    let sv = tests::DEFAULT_TABLE_SV as f64;
    let per_sv = step / sv;
    let size = budgets::image_size(&elf).expect("ELF sizes");
    let replay_bytes = std::fs::metadata(&inputs().replay_file).unwrap().len();
    let flash = size.flash - replay_bytes;
    let stack = log_field(line(&run, "stack:"), "high_water_bytes").unwrap();
    let heap = has_heap(&elf);
    println!(
        "{image:?} C image: one step (both readings and the update) {step:.0} instructions, {per_sv:.1} per \
         vector (≤ {}), flash {flash} B (≤ {}), static RAM {} B (≤ {}), stack {stack} B (≤ {}), heap {}; \
         build {:.1} s, QEMU {:.1} s",
        limits::F32_INSTR_PER_SV,
        limits::FLASH_BYTES,
        size.static_ram,
        limits::STATIC_RAM_BYTES,
        limits::STACK_BYTES,
        if heap { "yes" } else { "none" },
        (t_built - t0).as_secs_f64(),
        run.elapsed.as_secs_f64()
    );
    assert!(
        per_sv <= limits::F32_INSTR_PER_SV,
        "{per_sv:.1} instructions per vector"
    );
    assert!(flash <= limits::FLASH_BYTES, "flash {flash} B");
    assert!(
        size.static_ram <= limits::STATIC_RAM_BYTES,
        "static RAM {} B",
        size.static_ram
    );
    assert!(stack <= limits::STACK_BYTES, "stack {stack} B");
    assert!(!heap, "the C image links an allocator");
}

/// Whether an allocator (Rust's, or C's `malloc` / `_sbrk`) is linked into `elf`.
fn has_heap(elf: &Path) -> bool {
    use object::{Object, ObjectSymbol};
    let data = std::fs::read(elf).unwrap();
    let file = object::File::parse(&*data).unwrap();
    let found = file.symbols().any(|s| {
        s.name().is_ok_and(|n| {
            n.contains("__rust_alloc") || n == "malloc" || n == "_sbrk" || n == "_malloc_r"
        })
    });
    found || budgets::image_size(elf).is_ok_and(|s| s.has_heap)
}

#[test]
fn c_image_on_the_cortex_m4f_matches_rust_bit_for_bit_within_budgets() {
    if !tools("c_image_on_the_cortex_m4f_matches_rust_bit_for_bit_within_budgets") {
        return;
    }
    let table = tests::default_model_table();
    let mut rust = Compensator::from_table(table, SensorLimits::DEFAULT);
    let record = &inputs().record;
    replay_and_check(
        Image::F32,
        record.iter().map(|s| rust.update(s.temp_c, s.rate_dph)),
    );
}

#[test]
fn fixed_point_c_image_on_the_cortex_m3_matches_rust_bit_for_bit_within_budgets() {
    if !tools("fixed_point_c_image_on_the_cortex_m3_matches_rust_bit_for_bit_within_budgets") {
        return;
    }
    let table = tests::default_model_table();
    let fixed = FixedModel::from_table(table).expect("a Q24 form");
    let mut rust = FixedCompensator::from_table(table, &fixed, SensorLimits::DEFAULT).unwrap();
    let record = &inputs().record;
    replay_and_check(
        Image::Fixed,
        record.iter().map(|s| rust.update(s.temp_c, s.rate_dph)),
    );
}

/// The negative control: a library with a reachable panic in `rlg_update` does not link.
#[test]
fn a_reachable_panic_fails_the_c_link() {
    if !tools("a_reachable_panic_fails_the_c_link") {
        return;
    }
    let dir = &inputs().dir;
    let lib = dir.join("librlg_compensator_control.a");
    capi::build_library(
        Some(firmware::TARGET),
        &["no-panic-proof", "no-panic-control"],
        &lib,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let err = link_image(Image::F32, &lib, &dir.join("c_firmware_control.elf"))
        .expect_err("the control must not link");
    assert!(err.contains("rlg_panic_is_reachable"), "{err}");
}
