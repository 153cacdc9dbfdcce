//! A C firmware image (its own `main`, built with `arm-none-eabi-gcc` and linked with the
//! thumb library of the C API) replays the held-out record of the main job in QEMU: the f32
//! compensator on `mps2-an386` (Cortex-M4F, `thumbv7em-none-eabihf`), the fixed-point one on
//! `mps2-an385` (Cortex-M3, `thumbv7m-none-eabi`). Every output is compared bit for bit with the
//! Rust compensator run on the host over the same inputs.
//!
//! The budgets (`tests::budgets::limits`) are measured as for the Rust image
//! (`board_budgets.rs`): an image with the synthetic 64-vector table (seed 2011) replaying
//! `firmware/replay/default.bin`, linked with the library built for the table's input count
//! (`inputs-2`, as the Rust image is compiled for its table); SysTick under `-icount shift=0`
//! with the image's own calibration, flash and static RAM from the ELF (replay data
//! subtracted), the stack high-water mark from a painted stack. The f32 step (both readings and
//! the update) per support vector is held to `F32_INSTR_PER_SV`; the fixed-point path's cost
//! per support vector, the difference between 128- and 64-vector images per added vector (the
//! integer evaluation of Eq. 10 alone, as the Rust figure), to `FIXED_INSTR_PER_SV`.
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
use compensator_core::{Compensator, ModelTable, SensorLimits};
use tests::budgets::{self, limits};
use tests::capi::{self, OutputBits};
use tests::firmware::{self, log_field, QemuRun};
use tests::replay::{self, ReplaySample};

/// QEMU needs a few seconds for the record; this only catches a hung image.
const QEMU_TIMEOUT: Duration = Duration::from_secs(300);

/// Features of the proof library: every input count, and the panic handler that never links.
const PROOF: &[&str] = &["no-panic-proof"];
/// Features of the budget library: the synthetic tables' input count only.
const BUDGET: &[&str] = &["no-panic-proof", "inputs-2"];

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

    /// The Rust compensator's outputs for `table` over `record`.
    fn reference<const N: usize>(
        self,
        table: &ModelTable<N, 2>,
        record: &[ReplaySample],
    ) -> Vec<OutputBits> {
        let bits = |c: compensator_core::Compensated| {
            (c.rate_dph.to_bits(), c.correction_dph.to_bits(), c.status.0)
        };
        match self {
            Image::F32 => {
                let mut c = Compensator::from_table(table, SensorLimits::DEFAULT);
                record
                    .iter()
                    .map(|s| bits(c.update(s.temp_c, s.rate_dph)))
                    .collect()
            }
            Image::Fixed => {
                let fixed = FixedModel::from_table(table).expect("a Q24 form");
                let mut c =
                    FixedCompensator::from_table(table, &fixed, SensorLimits::DEFAULT).unwrap();
                record
                    .iter()
                    .map(|s| bits(c.update(s.temp_c, s.rate_dph)))
                    .collect()
            }
        }
    }
}

/// The work folder, the held-out record and its replay file.
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

/// Links the C image for `image` with the table header in `table_dir` and the replay file
/// `replay`, against `lib`; `Err` with the linker's words on failure.
fn link_image(
    image: Image,
    lib: &Path,
    table_dir: &Path,
    replay: &Path,
    elf: &Path,
) -> Result<(), String> {
    let src = capi::c_dir().join("firmware");
    let mut cmd = Command::new(capi::ARM_GCC);
    cmd.args(image.gcc_flags())
        .args(["-std=c99", "-Os", "-g", "-Wall", "-Wextra", "-Werror"])
        .args(["-ffunction-sections", "-fdata-sections", "-nostartfiles"])
        .args(["--specs=nano.specs", "-Wl,--gc-sections"])
        .arg(format!("-DRLG_REPLAY_PATH=\"{}\"", replay.display()))
        .arg("-I")
        .arg(capi::include_dir())
        .arg("-I")
        .arg(table_dir)
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

/// The library for `image`'s target with `features`, built once per test binary and set.
fn library(image: Image, features: &[&str]) -> PathBuf {
    let lib = inputs().dir.join(format!(
        "librlg_compensator_{image:?}_{}.a",
        features.join("_")
    ));
    if !lib.exists() {
        capi::build_library(Some(image.target()), features, &lib).unwrap_or_else(|e| panic!("{e}"));
    }
    lib
}

/// What one image run measured.
struct Figures {
    /// Mean instructions of one step (both readings and the update).
    step: f64,
    flash: u64,
    static_ram: u64,
    stack: u64,
    heap: bool,
}

/// Builds and runs `image` with `table` over `record` (`features`: of the library), checks
/// every output against the Rust compensator, and returns the figures.
fn run_case<const N: usize>(
    image: Image,
    features: &[&str],
    tag: &str,
    table: &ModelTable<N, 2>,
    record: &[ReplaySample],
) -> Figures {
    let t0 = Instant::now();
    let dir = inputs().dir.join(format!("{image:?}_{tag}"));
    std::fs::create_dir_all(&dir).unwrap();
    capi::write_table_header(&table.as_model(), "rlg", &dir, "rlg_model_table.h");
    let replay_file = dir.join("replay.bin");
    replay::write(&replay_file, record).unwrap();
    let lib = library(image, features);
    let elf = dir.join("c_firmware.elf");
    link_image(image, &lib, &dir, &replay_file, &elf).unwrap_or_else(|e| {
        panic!("the C image does not link (a reachable panic names rlg_panic_is_reachable):\n{e}")
    });
    let t_built = Instant::now();
    let (machine, cpu) = image.machine();
    let run =
        firmware::run_qemu_text(&elf, machine, cpu, QEMU_TIMEOUT).unwrap_or_else(|e| panic!("{e}"));
    for l in &run.log {
        println!("  {tag}: {l}");
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

    let want = image.reference(table, record);
    let n = record.len();
    assert_eq!(
        (run.begin_count, run.end_count),
        (Some(n as u32), Some(n as u32))
    );
    assert_eq!(run.records.len(), n);
    let mut identical = 0;
    let mut first = Vec::new();
    for ((k, (s, r)), w) in record.iter().zip(&run.records).enumerate().zip(&want) {
        assert_eq!(r.index, k as u32);
        assert_eq!(
            (r.temp_c_bits, r.gyro_dph_bits),
            (s.temp_c.to_bits(), s.rate_dph.to_bits())
        );
        let got = (r.rate_dph_bits, r.correction_dph_bits, r.status);
        if got == *w {
            identical += 1;
        } else if first.len() < 5 {
            first.push(format!("sample {k}: C image {got:08x?}, Rust {w:08x?}"));
        }
    }
    println!(
        "{image:?} C image, {tag} (QEMU {machine}): {identical} of {n} outputs bit-identical to the Rust compensator; build {:.1} s, QEMU {:.1} s",
        (t_built - t0).as_secs_f64(),
        run.elapsed.as_secs_f64()
    );
    assert_eq!(identical, n, "{first:#?}");

    let cal = line(&run, "calibration:");
    let per_tick =
        log_field(cal, "instructions").unwrap() as f64 / log_field(cal, "ticks").unwrap() as f64;
    assert!((per_tick / 40.0 - 1.0).abs() < 0.01, "{cal}");
    let cost = line(&run, "cost:");
    let size = budgets::image_size(&elf).expect("ELF sizes");
    let replay_bytes = std::fs::metadata(&replay_file).unwrap().len();
    Figures {
        step: log_field(cost, "total").unwrap() as f64 / log_field(cost, "calls").unwrap() as f64
            * per_tick,
        flash: size.flash - replay_bytes,
        static_ram: size.static_ram,
        stack: log_field(line(&run, "stack:"), "high_water_bytes").unwrap(),
        heap: has_heap(&elf),
    }
}

fn line<'a>(run: &'a QemuRun, key: &str) -> &'a str {
    run.log
        .iter()
        .find(|l| l.starts_with(key))
        .unwrap_or_else(|| panic!("no {key} line in {:#?}", run.log))
}

/// Whether an allocator (Rust's, or C's `malloc` / `_sbrk`) is linked into `elf`.
fn has_heap(elf: &Path) -> bool {
    use object::{Object, ObjectSymbol};
    let data = std::fs::read(elf).unwrap();
    let file = object::File::parse(&*data).unwrap();
    file.symbols().any(|s| {
        s.name().is_ok_and(|n| {
            n.contains("__rust_alloc") || n == "malloc" || n == "_sbrk" || n == "_malloc_r"
        })
    })
}

/// The budget image's inputs: `firmware/replay/default.bin` and the synthetic table of `N`
/// vectors (seed 2011), as `board_budgets.rs` builds the Rust image.
fn budget_case<const N: usize>() -> (ModelTable<N, 2>, Vec<ReplaySample>) {
    let t = budgets::synthetic_table(N, 2011);
    let table = budgets::sized::<N>(&t).expect("N vectors");
    let bytes = std::fs::read(firmware::workspace_root().join("firmware/replay/default.bin"))
        .expect("firmware/replay/default.bin");
    (table, replay::decode(&bytes).expect("a replay file"))
}

/// Holds one budget image's memory figures to the Rust image's budgets.
fn assert_memory(image: Image, f: &Figures) {
    println!(
        "{image:?} C image (64 vectors, inputs-2 library): flash {} B (≤ {}), static RAM {} B (≤ {}), stack {} B (≤ {}), heap {}",
        f.flash,
        limits::FLASH_BYTES,
        f.static_ram,
        limits::STATIC_RAM_BYTES,
        f.stack,
        limits::STACK_BYTES,
        if f.heap { "yes" } else { "none" }
    );
    assert!(f.flash <= limits::FLASH_BYTES, "flash {} B", f.flash);
    assert!(
        f.static_ram <= limits::STATIC_RAM_BYTES,
        "static RAM {} B",
        f.static_ram
    );
    assert!(f.stack <= limits::STACK_BYTES, "stack {} B", f.stack);
    assert!(!f.heap, "the C image links an allocator");
}

#[test]
fn c_image_on_the_cortex_m4f_matches_rust_bit_for_bit_within_budgets() {
    if !tools("c_image_on_the_cortex_m4f_matches_rust_bit_for_bit_within_budgets") {
        return;
    }
    let held = run_case(
        Image::F32,
        PROOF,
        "held-out",
        tests::default_model_table(),
        &inputs().record,
    );
    let sv = tests::DEFAULT_TABLE_SV as f64;
    println!(
        "F32 C image, held-out record, all input counts: {:.0} instructions per step, {:.1} per vector; flash {} B, static RAM {} B, stack {} B",
        held.step,
        held.step / sv,
        held.flash,
        held.static_ram,
        held.stack
    );
    let (table, record) = budget_case::<{ limits::SUPPORT_VECTORS }>();
    let f = run_case(Image::F32, BUDGET, "budget-64", &table, &record);
    let per_sv = f.step / limits::SUPPORT_VECTORS as f64;
    println!(
        "F32 C image (64 vectors): {per_sv:.1} instructions per vector (≤ {})",
        limits::F32_INSTR_PER_SV
    );
    assert!(
        per_sv <= limits::F32_INSTR_PER_SV,
        "{per_sv:.1} instructions per vector"
    );
    assert_memory(Image::F32, &f);
}

#[test]
fn fixed_point_c_image_on_the_cortex_m3_matches_rust_bit_for_bit_within_budgets() {
    if !tools("fixed_point_c_image_on_the_cortex_m3_matches_rust_bit_for_bit_within_budgets") {
        return;
    }
    let held = run_case(
        Image::Fixed,
        PROOF,
        "held-out",
        tests::default_model_table(),
        &inputs().record,
    );
    let sv = tests::DEFAULT_TABLE_SV as f64;
    println!(
        "Fixed C image, held-out record, all input counts: {:.0} instructions per step, {:.1} per vector; flash {} B, static RAM {} B, stack {} B",
        held.step,
        held.step / sv,
        held.flash,
        held.static_ram,
        held.stack
    );
    let (t64, record) = budget_case::<{ limits::SUPPORT_VECTORS }>();
    let f64v = run_case(Image::Fixed, BUDGET, "budget-64", &t64, &record);
    let (t128, _) = budget_case::<{ 2 * limits::SUPPORT_VECTORS }>();
    let f128 = run_case(Image::Fixed, BUDGET, "budget-128", &t128, &record);
    let per_sv = (f128.step - f64v.step) / limits::SUPPORT_VECTORS as f64;
    println!(
        "Fixed C image: {per_sv:.1} instructions per added support vector (≤ {}); whole step at 64 vectors {:.0} ({:.1} per vector, soft-float features included)",
        limits::FIXED_INSTR_PER_SV,
        f64v.step,
        f64v.step / limits::SUPPORT_VECTORS as f64
    );
    assert!(
        per_sv <= limits::FIXED_INSTR_PER_SV,
        "{per_sv:.1} instructions per vector"
    );
    assert_memory(Image::Fixed, &f64v);
}

/// The negative control: a library with a reachable panic in `rlg_update` does not link.
#[test]
fn a_reachable_panic_fails_the_c_link() {
    if !tools("a_reachable_panic_fails_the_c_link") {
        return;
    }
    let lib = library(Image::F32, &["no-panic-proof", "no-panic-control"]);
    let dir = inputs().dir.join("control");
    std::fs::create_dir_all(&dir).unwrap();
    let table = tests::default_model_table();
    capi::write_table_header(&table.as_model(), "rlg", &dir, "rlg_model_table.h");
    let err = link_image(
        Image::F32,
        &lib,
        &dir,
        &inputs().replay_file,
        &dir.join("control.elf"),
    )
    .expect_err("the control must not link");
    assert!(err.contains("rlg_panic_is_reachable"), "{err}");
}
