//! The C API (`compensator-core/capi`) from C: its library built for the host and the boards,
//! C programs compiled against it (the system `cc` on the host, `arm-none-eabi-gcc` for the
//! QEMU images), the tables they include, and the held-out record they replay.
//!
//! Missing tools fail the tests, unless `RLG_ALLOW_MISSING_TOOLS` is set
//! ([`crate::firmware::skip_for_missing`]).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;

use compensator_core::ModelRef;
use rlg_train::export_c::{c_header, CName};

use crate::firmware::{workspace_root, FirmwareError};
use crate::replay::ReplaySample;

/// The C API crate's package name.
pub const PACKAGE: &str = "compensator-capi";
/// The bare-metal C compiler.
pub const ARM_GCC: &str = "arm-none-eabi-gcc";
/// Libraries a std staticlib needs on x86-64 Linux (`rustc --print native-static-libs`).
pub const HOST_NATIVE_LIBS: [&str; 6] = ["-lgcc_s", "-lutil", "-lrt", "-lpthread", "-lm", "-ldl"];

/// `compensator-core/capi/include`, the committed header's folder.
pub fn include_dir() -> PathBuf {
    workspace_root().join("compensator-core/capi/include")
}

/// `tests/tests/c`, the C sources of the tests.
pub fn c_dir() -> PathBuf {
    workspace_root().join("tests/tests/c")
}

/// Whether `program --version` runs.
pub fn tool_available(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Whether a test that needs `program` can run ([`crate::firmware::skip_for_missing`]).
pub fn tool_or_skip(test: &str, program: &str) -> bool {
    tool_available(program)
        || !crate::firmware::skip_for_missing(test, program, "run `bash tests/setup.sh`")
}

/// Serialises the library builds of one test binary (one output path per target and profile).
static BUILD_LOCK: Mutex<()> = Mutex::new(());

/// Builds `librlg_compensator.a` with cargo and copies it to `dest`: for the host (dev
/// profile) when `target` is `None`, else for `target` with the board's `firmware` profile;
/// with `features` (an `inputs-*` feature among them replaces the default, all input counts).
pub fn build_library(
    target: Option<&str>,
    features: &[&str],
    dest: &Path,
) -> Result<(), FirmwareError> {
    let _guard = BUILD_LOCK.lock().unwrap_or_else(|p| p.into_inner());
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(workspace_root())
        .args(["build", "-p", PACKAGE, "--lib"])
        .args(["--message-format", "json-render-diagnostics"])
        .stdin(Stdio::null());
    if let Some(t) = target {
        cmd.args(["--profile", "firmware", "--target", t]);
    }
    if features.iter().any(|f| f.starts_with("inputs-")) {
        cmd.arg("--no-default-features");
    }
    if !features.is_empty() {
        cmd.args(["--features", &features.join(",")]);
    }
    let out = cmd.output().map_err(|source| FirmwareError::Spawn {
        program: "cargo".into(),
        source,
    })?;
    if !out.status.success() {
        return Err(FirmwareError::Build {
            status: out.status,
            stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        });
    }
    let lib = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v["reason"] == "compiler-artifact" && v["target"]["name"] == "rlg_compensator")
        .flat_map(|v| {
            v["filenames"]
                .as_array()
                .into_iter()
                .flatten()
                .filter_map(|f| f.as_str().map(PathBuf::from))
                .collect::<Vec<_>>()
        })
        .find(|p| p.extension().is_some_and(|e| e == "a"))
        .ok_or(FirmwareError::NoExecutable)?;
    std::fs::copy(&lib, dest).map_err(|source| FirmwareError::Io {
        path: lib.display().to_string(),
        source,
    })?;
    Ok(())
}

/// Runs a compiler command; `Err` with its diagnostics when it fails.
pub fn run_compiler(cmd: &mut Command) -> Result<(), String> {
    let out = cmd
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot start {cmd:?}: {e}"))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "{cmd:?} failed ({}):\n{}{}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ))
    }
}

/// Writes the C header of `t` with symbol prefix `name` to `dir/<file>`.
pub fn write_table_header<const D: usize>(t: &ModelRef<'_, D>, name: &str, dir: &Path, file: &str) {
    let name = CName::new(name).expect("a C name");
    let text = c_header(t, &name, "test table").expect("the table validates");
    std::fs::write(dir.join(file), text).expect("write the table header");
}

/// The held-out record of the README's main job: the reference dynamic run (seed 2011) after
/// its first temperature cycle, at 1 Hz, as the board reads it (f32).
pub fn held_out_record() -> Vec<ReplaySample> {
    let run = rlg_repro::pipeline::dynamic_run().expect("the reference run simulates");
    let rec = &run.recording;
    let split = rec.time_s.partition_point(|t| *t < run.train_end_s());
    (split..rec.len())
        .map(|k| ReplaySample {
            temp_c: rec.temp_c[k] as f32,
            rate_dph: rec.rate_dph[k] as f32,
        })
        .collect()
}

/// Outputs of one sample as the C programs write them: rate bits, correction bits, status.
pub type OutputBits = (u32, u32, u8);

/// Reads the little-endian (rate, correction, status) words the host replay program writes.
pub fn read_outputs(bytes: &[u8]) -> Vec<OutputBits> {
    bytes
        .chunks_exact(12)
        .map(|c| {
            let w = |i: usize| u32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
            (w(0), w(4), w(8) as u8)
        })
        .collect()
}
