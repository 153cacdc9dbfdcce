//! Board budgets: images built with tables of a chosen size, run in QEMU, and measured.
//!
//! * Instructions: the image times every 1 Hz step (sensor reads + `Compensator::update`) and,
//!   separately, the kernel sum of Eq. (10) per exp choice (`libm::expf`, and
//!   `compensator_core::fastexp::exp_neg`) with SysTick under `-icount shift=0`; the image's own
//!   calibration loop gives the instructions per tick (40).
//! * Flash and static RAM: from the ELF section headers (the `object` crate; no binutils for
//!   the target are needed). Flash = every allocated section with file contents (vector table,
//!   text, rodata, the load image of data); the replay recording compiled into the image is
//!   reported separately and subtracted. Static RAM = every allocated writable section (data,
//!   bss, uninit). Heap: the image has no allocator; the check is that no `__rust_alloc`
//!   symbol is linked.
//! * Stack: the image paints its stack at boot and reports the deepest word overwritten.
//!
//! Synthetic tables ([`synthetic_table`]) have the default table's spec and random support
//! vectors and coefficients over the trained range: cost does not depend on the numbers, and
//! accuracy is measured against an f64 evaluation of the same f32 numbers.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use compensator_core::fixed::{FixedModel, Q, Z};
use compensator_core::{ModelRef, ModelSpec, ModelTable, RateFilter};
use object::{Object, ObjectSection, ObjectSymbol, SectionFlags};
use rlg_train::export::{table_item, F32Model};

use crate::firmware::{self, log_field, FirmwareError, QemuRun};

/// Board budgets at 64 support vectors and two inputs, enforced by `tests/tests/board_budgets.rs`
/// and reported by `cargo run --release -p tests --bin budgets` (which exits non-zero when one
/// is not met). Measured values are in the test's output (`-- --nocapture`), the `budgets`
/// binary's table and the main job's board log (`host-trainer/results/paper.md`).
pub mod limits {
    /// Support vectors the budgets are stated for.
    pub const SUPPORT_VECTORS: usize = 64;
    /// Instructions of the whole 1 Hz step (both reads and `Compensator::update`, the board's
    /// fast exp) per support vector, f32 on the Cortex-M4F.
    pub const F32_INSTR_PER_SV: f64 = 50.0;
    /// Instructions of `FixedModel::predict` per support vector on the Cortex-M4F.
    pub const FIXED_INSTR_PER_SV: f64 = 45.0;
    /// Flash of the image without the replay data compiled into it, bytes.
    pub const FLASH_BYTES: u64 = 32 * 1024;
    /// Static RAM (.data + .bss), bytes.
    pub const STATIC_RAM_BYTES: u64 = 4 * 1024;
    /// Measured stack high-water mark, bytes.
    pub const STACK_BYTES: u64 = 8 * 1024;
}

/// How long one budget run may take in QEMU.
pub const QEMU_TIMEOUT: Duration = Duration::from_secs(120);

/// A table of `n` random support vectors in 2 inputs (T, dT/dt) with the default table's
/// scaling, kernel width, range and dT/dt filter; coefficients uniform in ±0.05 °/h.
/// Deterministic in `seed`.
pub fn synthetic_table(n: usize, seed: u64) -> F32Model<2> {
    let mut state = seed ^ 0x9E37_79B9_7F4A_7C15;
    let mut uniform = move |lo: f32, hi: f32| {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        lo + (hi - lo) * ((state >> 40) as f32 / (1u64 << 24) as f32)
    };
    let spec = ModelSpec {
        rate_filter: RateFilter::from_tau_s(60.0, 1.0),
        ..crate::fuzz_checks::SPEC2
    };
    let support = (0..n)
        .map(|_| [uniform(-1.06, 1.36), uniform(-2.6, 2.6)])
        .collect();
    let alpha_dph = (0..n).map(|_| uniform(-0.05, 0.05)).collect();
    F32Model {
        spec,
        support,
        alpha_dph,
    }
}

/// Rust source of `t` for `RLG_MODEL_TABLE` (the exporter's own table item, CRC included).
pub fn table_file(t: &F32Model<2>, what: &str) -> Result<String, rlg_train::export::ExportError> {
    Ok(format!("// {what}\n\n{}", table_item(t)?))
}

/// Eq. (10) in f64 over the table's f32 numbers, standardised input: the reference that
/// isolates the evaluator's own arithmetic error.
pub fn predict_f64<const D: usize>(m: &ModelRef<'_, D>, z: &[f32; D]) -> f64 {
    let g = f64::from(m.spec.gamma);
    let sum: f64 = m
        .support
        .iter()
        .zip(m.alpha_dph)
        .map(|(sv, a)| {
            let d2: f64 = (0..D)
                .map(|d| (f64::from(z[d]) - f64::from(sv[d])).powi(2))
                .sum();
            f64::from(*a) * (-g * d2).exp()
        })
        .sum();
    sum + f64::from(m.spec.bias_dph)
}

/// Largest |f32 evaluator − f64 reference| over a 121 × 121 grid of the trained range, °/h,
/// for the libm exp and for the fast exp.
pub fn max_errors_dph(m: &ModelRef<'_, 2>) -> (f64, f64) {
    let s = m.spec;
    let (mut e_libm, mut e_fast) = (0.0f64, 0.0f64);
    for i in 0..=120 {
        for j in 0..=120 {
            let x = [
                s.input_lo[0] + (s.input_hi[0] - s.input_lo[0]) * i as f32 / 120.0,
                s.input_lo[1] + (s.input_hi[1] - s.input_lo[1]) * j as f32 / 120.0,
            ];
            let z = m.standardise(&x);
            let want = predict_f64(m, &z);
            let a = f64::from(m.predict_standardised_dph_libm(&z));
            let b = f64::from(m.predict_standardised_dph(&z));
            e_libm = e_libm.max((a - want).abs());
            e_fast = e_fast.max((b - want).abs());
        }
    }
    (e_libm, e_fast)
}

/// What to build.
#[derive(Clone, Debug, Default)]
pub struct ImageOptions {
    /// Table source file for `RLG_MODEL_TABLE` (None: the committed default table).
    pub table_file: Option<PathBuf>,
    /// `RLG_FW_FAULT` value (None: a normal image).
    pub fault: Option<String>,
    /// Add the fixed-point pass (`RLG_FW_FIXED`).
    pub fixed_pass: bool,
    /// Target triple (None: [`firmware::TARGET`], the Cortex-M4F).
    pub target: Option<String>,
}

/// The FPU-less target of the fixed-point image, run on QEMU's `mps2-an385` (Cortex-M3).
pub const M3_TARGET: &str = "thumbv7m-none-eabi";

/// Builds the board image with `replay_bin` and `opts`, copying the ELF to `dest`.
pub fn build_image(
    replay_bin: &Path,
    opts: &ImageOptions,
    dest: &Path,
) -> Result<(), FirmwareError> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let abs = |p: &Path| {
        std::path::absolute(p).map_err(|source| FirmwareError::Io {
            path: p.display().to_string(),
            source,
        })
    };
    let mut cmd = Command::new(&cargo);
    cmd.current_dir(firmware::workspace_root())
        .args([
            "build",
            "-p",
            "firmware",
            "--profile",
            "firmware",
            "--bin",
            "firmware",
        ])
        .args([
            "--target",
            opts.target.as_deref().unwrap_or(firmware::TARGET),
        ])
        .args(["--message-format", "json-render-diagnostics"])
        .env("RLG_REPLAY_BIN", abs(replay_bin)?)
        .stdin(Stdio::null());
    match &opts.table_file {
        Some(t) => cmd.env("RLG_MODEL_TABLE", abs(t)?),
        None => cmd.env_remove("RLG_MODEL_TABLE"),
    };
    if opts.fixed_pass {
        cmd.env("RLG_FW_FIXED", "1");
    } else {
        cmd.env_remove("RLG_FW_FIXED");
    }
    match &opts.fault {
        Some(f) => cmd.env("RLG_FW_FAULT", f),
        None => cmd.env_remove("RLG_FW_FAULT"),
    };
    let out = cmd.output().map_err(|source| FirmwareError::Spawn {
        program: "cargo".into(),
        source,
    })?;
    let exe = firmware::built_executable(&out)?;
    std::fs::copy(&exe, dest).map_err(|source| FirmwareError::Io {
        path: exe.display().to_string(),
        source,
    })?;
    Ok(())
}

/// Memory of an image, bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageSize {
    /// Allocated sections with contents (what is programmed into flash).
    pub flash: u64,
    /// Allocated writable sections (static RAM: data + bss + uninit).
    pub static_ram: u64,
    /// Whether an allocator entry point (`__rust_alloc`) is linked.
    pub has_heap: bool,
}

/// Why an ELF could not be measured.
#[derive(Debug, thiserror::Error)]
pub enum SizeError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The file is not an ELF object.
    #[error("{0}")]
    Parse(#[from] object::Error),
}

/// Section-header sizes of `elf` ([`ImageSize`]); flags as in the ELF spec (SHF_WRITE = 1,
/// SHF_ALLOC = 2).
pub fn image_size(elf: &Path) -> Result<ImageSize, SizeError> {
    let data = std::fs::read(elf).map_err(|source| SizeError::Io {
        path: elf.display().to_string(),
        source,
    })?;
    let file = object::File::parse(&*data)?;
    let (mut flash, mut ram) = (0u64, 0u64);
    for s in file.sections() {
        let SectionFlags::Elf { sh_flags } = s.flags() else {
            continue;
        };
        if sh_flags & 2 == 0 {
            continue; // not loaded: debug info, defmt metadata
        }
        if s.file_range().is_some() {
            flash += s.size();
        }
        if sh_flags & 1 != 0 {
            ram += s.size();
        }
    }
    let has_heap = file
        .symbols()
        .any(|s| s.name().is_ok_and(|n| n.contains("__rust_alloc")));
    Ok(ImageSize {
        flash,
        static_ram: ram,
        has_heap,
    })
}

/// Figures from one run's log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunCost {
    /// Instructions per SysTick tick (calibration loop).
    pub per_tick: f64,
    /// Mean instructions of one 1 Hz step (reads + `Compensator::update`, the board's fast exp).
    pub step: f64,
    /// Mean instructions of the kernel sum with `libm::expf`.
    pub kernel_libm: f64,
    /// Mean instructions of the kernel sum with the fast exp.
    pub kernel_fast: f64,
    /// Deepest stack use, bytes.
    pub stack_bytes: u64,
}

fn line<'a>(run: &'a QemuRun, marker: &str) -> Option<&'a str> {
    run.log
        .iter()
        .find(|l| l.contains(marker))
        .map(String::as_str)
}

/// Reads the calibration, cost, kernel and stack lines of `run`; None when one is missing.
pub fn run_cost(run: &QemuRun) -> Option<RunCost> {
    let cal = line(run, "calibration:")?;
    let per_tick = log_field(cal, "instructions")? as f64 / log_field(cal, "ticks")? as f64;
    let cost = line(run, "cost:")?;
    let step = log_field(cost, "total")? as f64 / log_field(cost, "calls")? as f64 * per_tick;
    let k = line(run, "kernel:")?;
    let calls = log_field(k, "calls")? as f64;
    Some(RunCost {
        per_tick,
        step,
        kernel_libm: log_field(k, "libm_total")? as f64 / calls * per_tick,
        kernel_fast: log_field(k, "fast_total")? as f64 / calls * per_tick,
        stack_bytes: log_field(line(run, "stack:")?, "high_water_bytes")?,
    })
}

/// Largest |fixed-point − f64 reference| of Eq. (10) over the same 121 × 121 grid as
/// [`max_errors_dph`], °/h; None when `t` does not have exactly `N` vectors or no Q form.
pub fn max_fixed_error_dph<const N: usize>(t: &ModelTable<N, 2>) -> Option<f64> {
    let fixed = FixedModel::from_table(t).ok()?;
    let m = t.as_model();
    let s = m.spec;
    let mut worst = 0.0f64;
    for i in 0..=120 {
        for j in 0..=120 {
            let x = [
                s.input_lo[0] + (s.input_hi[0] - s.input_lo[0]) * i as f32 / 120.0,
                s.input_lo[1] + (s.input_hi[1] - s.input_lo[1]) * j as f32 / 120.0,
            ];
            let z = m.standardise(&x);
            let zq: [Z; 2] = [
                Q::from_f32_bits(z[0].to_bits())?,
                Q::from_f32_bits(z[1].to_bits())?,
            ];
            worst = worst.max((fixed.predict(&zq).to_f64() - predict_f64(&m, &z)).abs());
        }
    }
    Some(worst)
}

/// `t` as a const-size table (sealed with its CRC), if it has exactly `N` vectors.
pub fn sized<const N: usize>(t: &F32Model<2>) -> Option<ModelTable<N, 2>> {
    Some(
        ModelTable {
            spec: t.spec,
            support: t.support.as_slice().try_into().ok()?,
            alpha_dph: t.alpha_dph.as_slice().try_into().ok()?,
            crc32: 0,
        }
        .sealed(),
    )
}

/// Mean instructions of `FixedModel::predict` from a run of an `RLG_FW_FIXED` image.
pub fn fixed_cost(run: &QemuRun) -> Option<f64> {
    let cal = line(run, "calibration:")?;
    let per_tick = log_field(cal, "instructions")? as f64 / log_field(cal, "ticks")? as f64;
    let f = line(run, "fixed:")?;
    Some(log_field(f, "predict_total")? as f64 / log_field(f, "calls")? as f64 * per_tick)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synthetic_tables_validate_and_are_deterministic() {
        for n in [16, 128] {
            let t = synthetic_table(n, 7);
            t.as_model().validate().unwrap();
            assert_eq!(t, synthetic_table(n, 7));
            assert_ne!(t, synthetic_table(n, 8));
        }
    }

    /// The f64 reference agrees with the f32 evaluator to f32 accuracy (so it is evaluating
    /// the same function), but is not identical to it (so it is an independent computation).
    #[test]
    fn f64_reference_is_the_same_function() {
        let t = synthetic_table(64, 1);
        let (e_libm, e_fast) = max_errors_dph(&t.as_model());
        assert!(e_libm < 1e-5 && e_fast < 1e-5, "{e_libm} {e_fast}");
        assert!(e_libm > 0.0);
    }
}
