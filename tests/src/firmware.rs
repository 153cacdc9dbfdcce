//! Build the firmware image for a replay file, run it in QEMU, decode what it wrote.
//!
//! The image writes two semihosting streams (see `firmware/src/wire.rs`): binary defmt frames
//! on stdout, decoded here with `defmt-decoder` against the image's own `.defmt` table, and
//! the sample lines on stderr, parsed here into [`OutputRecord`]s.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The firmware's target triple.
pub const TARGET: &str = "thumbv7em-none-eabihf";
/// The QEMU binary.
pub const QEMU: &str = "qemu-system-arm";
/// QEMU arguments before the image path; the same as the runner in `.cargo/config.toml`.
pub const QEMU_ARGS: [&str; 14] = [
    "-machine",
    "mps2-an386",
    "-cpu",
    "cortex-m4",
    "-nographic",
    "-monitor",
    "none",
    "-serial",
    "none",
    "-icount",
    "shift=0",
    "-semihosting-config",
    "enable=on,target=native",
    "-kernel",
];

/// What went wrong building, running or reading the image.
#[derive(Debug, thiserror::Error)]
pub enum FirmwareError {
    /// A program could not be started.
    #[error("cannot start {program}: {source}")]
    Spawn {
        /// The program.
        program: String,
        /// The cause.
        source: std::io::Error,
    },
    /// `cargo build` of the image failed.
    #[error("building the firmware failed ({status}); run `bash tests/setup.sh` if the thumb target is missing:\n{stderr}")]
    Build {
        /// Exit status of cargo.
        status: std::process::ExitStatus,
        /// Cargo's diagnostics.
        stderr: String,
    },
    /// Cargo reported no executable for the firmware.
    #[error("cargo built no firmware executable")]
    NoExecutable,
    /// QEMU ran longer than allowed and was killed.
    #[error("QEMU did not finish within {0:?} and was killed (firmware hung?)")]
    Timeout(Duration),
    /// The ELF has no usable defmt table.
    #[error("cannot read the defmt table of {path}: {reason}")]
    DefmtTable {
        /// The image.
        path: String,
        /// Why.
        reason: String,
    },
    /// The defmt stream is corrupt.
    #[error("defmt stream is malformed after {0} frames")]
    DefmtMalformed(usize),
    /// A sample line does not follow the wire format.
    #[error("bad sample line {line}: {text:?}")]
    BadLine {
        /// 1-based line number on stderr.
        line: usize,
        /// The line.
        text: String,
    },
    /// File system error.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> FirmwareError + '_ {
    move |source| FirmwareError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// The workspace root (parent of this crate).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap_or(Path::new(".."))
        .to_path_buf()
}

/// Whether `qemu-system-arm` can be started.
pub fn qemu_available() -> bool {
    Command::new(QEMU)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// The variable that lets a test whose tool (QEMU, a C compiler) is missing skip instead of
/// fail. Nothing in the project sets it, the test command included: a missing tool fails the
/// tests unless whoever runs them opts out by hand.
pub const ALLOW_MISSING_TOOLS: &str = "RLG_ALLOW_MISSING_TOOLS";

/// Whether a test may skip for a missing `tool` ([`ALLOW_MISSING_TOOLS`] set to anything but
/// empty, `0` or `false`); otherwise it panics with what to install and how to opt out.
/// Returns `false` (skip) after saying so loudly, for the caller to return early.
pub fn skip_for_missing(test: &str, tool: &str, install: &str) -> bool {
    let allowed =
        std::env::var(ALLOW_MISSING_TOOLS).is_ok_and(|v| !v.is_empty() && v != "0" && v != "false");
    assert!(
        allowed,
        "{test}: {tool} is missing: {install} (or set {ALLOW_MISSING_TOOLS}=1 to skip the tests that need it)"
    );
    eprintln!("\n!!! SKIPPED {test}: {tool} not found and {ALLOW_MISSING_TOOLS} is set !!!\n");
    true
}

/// Serialises builds in this process: the image path is shared, so build and copy must not
/// interleave with another build for a different replay file.
static BUILD_LOCK: Mutex<()> = Mutex::new(());

/// A failure the image can be built to provoke right after its start line, to test that it
/// exits QEMU with a failure code instead of hanging.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultInjection {
    /// `panic!`.
    Panic,
    /// An undefined instruction, escalated to HardFault.
    HardFault,
}

/// Builds the image (`--profile firmware`) with `replay_bin` compiled in, and copies the ELF to
/// `dest` so that later builds do not change it.
pub fn build_image(replay_bin: &Path, dest: &Path) -> Result<(), FirmwareError> {
    build(replay_bin, dest, None)
}

/// Like [`build_image`], with a fault injected after the start line.
pub fn build_faulty_image(
    replay_bin: &Path,
    dest: &Path,
    fault: FaultInjection,
) -> Result<(), FirmwareError> {
    build(replay_bin, dest, Some(fault))
}

fn build(
    replay_bin: &Path,
    dest: &Path,
    fault: Option<FaultInjection>,
) -> Result<(), FirmwareError> {
    let _guard = BUILD_LOCK.lock().unwrap_or_else(|p| p.into_inner());
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let replay = std::path::absolute(replay_bin).map_err(io_err(replay_bin))?;
    let mut cmd = Command::new(&cargo);
    match fault {
        None => cmd.env_remove("RLG_FW_FAULT"),
        Some(FaultInjection::Panic) => cmd.env("RLG_FW_FAULT", "panic"),
        Some(FaultInjection::HardFault) => cmd.env("RLG_FW_FAULT", "hardfault"),
    };
    let out = cmd
        .current_dir(workspace_root())
        .args([
            "build",
            "-p",
            "firmware",
            "--profile",
            "firmware",
            "--target",
            TARGET,
            "--bin",
            "firmware",
        ])
        .args(["--message-format", "json-render-diagnostics"])
        .env("RLG_REPLAY_BIN", &replay)
        .stdin(Stdio::null())
        .output()
        .map_err(|source| FirmwareError::Spawn {
            program: "cargo".into(),
            source,
        })?;
    let exe = built_executable(&out)?;
    std::fs::copy(&exe, dest).map_err(io_err(&exe))?;
    Ok(())
}

/// The firmware executable named by a `cargo build --message-format json…` run, or the
/// build's diagnostics when it failed.
pub fn built_executable(out: &std::process::Output) -> Result<PathBuf, FirmwareError> {
    if !out.status.success() {
        return Err(FirmwareError::Build {
            status: out.status,
            stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        });
    }
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v["reason"] == "compiler-artifact" && v["target"]["name"] == "firmware")
        .filter_map(|v| v["executable"].as_str().map(PathBuf::from))
        .next_back()
        .ok_or(FirmwareError::NoExecutable)
}

/// Whether a QEMU test can run: `true` when `qemu-system-arm` is installed. Without it the
/// test fails, unless [`ALLOW_MISSING_TOOLS`] is set ([`skip_for_missing`]).
pub fn qemu_or_skip(test: &str) -> bool {
    qemu_available() || !skip_for_missing(test, QEMU, "run `bash tests/setup.sh`")
}

/// One `S` line of the image's output: inputs and outputs as exact bit patterns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputRecord {
    /// Sample index.
    pub index: u32,
    /// Input temperature, °C, as f32 bits.
    pub temp_c_bits: u32,
    /// Input gyro rate, °/h, as f32 bits.
    pub gyro_dph_bits: u32,
    /// Compensated rate, °/h, as f32 bits.
    pub rate_dph_bits: u32,
    /// Correction, °/h, as f32 bits.
    pub correction_dph_bits: u32,
    /// `compensator_core::Status` bits.
    pub status: u8,
}

/// Everything one QEMU run produced.
#[derive(Clone, Debug)]
pub struct QemuRun {
    /// QEMU's exit code (0 = the image's EXIT_SUCCESS, 1 = EXIT_FAILURE); `None` if killed
    /// by a signal.
    pub exit_code: Option<i32>,
    /// Decoded defmt log lines, level first.
    pub log: Vec<String>,
    /// The sample records in order.
    pub records: Vec<OutputRecord>,
    /// Count announced by the `B` line.
    pub begin_count: Option<u32>,
    /// Count announced by the `E` line.
    pub end_count: Option<u32>,
    /// Lines on stderr that were not part of the sample stream (QEMU's own messages).
    pub other_stderr: Vec<String>,
    /// Wall-clock time of the run.
    pub elapsed: Duration,
}

/// Runs `elf` in QEMU, killing it after `timeout`.
pub fn run_qemu(elf: &Path, timeout: Duration) -> Result<QemuRun, FirmwareError> {
    run_qemu_on(elf, QEMU_ARGS[1], QEMU_ARGS[3], timeout)
}

/// Like [`run_qemu`] on another machine and CPU (e.g. `mps2-an385`, `cortex-m3`); the other
/// arguments are those of [`QEMU_ARGS`].
pub fn run_qemu_on(
    elf: &Path,
    machine: &str,
    cpu: &str,
    timeout: Duration,
) -> Result<QemuRun, FirmwareError> {
    let raw = spawn_qemu(elf, machine, cpu, timeout)?;
    let elf_bytes = std::fs::read(elf).map_err(io_err(elf))?;
    let log = decode_defmt(&elf_bytes, &raw.stdout).map_err(|e| match e {
        DefmtFailure::Table(reason) => FirmwareError::DefmtTable {
            path: elf.display().to_string(),
            reason,
        },
        DefmtFailure::Malformed(n) => FirmwareError::DefmtMalformed(n),
    })?;
    finish_run(raw, log)
}

/// Like [`run_qemu_on`] for an image that logs plain text lines on stdout (the C images of
/// the C API's tests) instead of defmt frames.
pub fn run_qemu_text(
    elf: &Path,
    machine: &str,
    cpu: &str,
    timeout: Duration,
) -> Result<QemuRun, FirmwareError> {
    let raw = spawn_qemu(elf, machine, cpu, timeout)?;
    let log = String::from_utf8_lossy(&raw.stdout)
        .lines()
        .map(str::to_owned)
        .collect();
    finish_run(raw, log)
}

/// What QEMU left: its exit code, both streams and the wall-clock time.
struct RawRun {
    exit_code: Option<i32>,
    stdout: Vec<u8>,
    stderr: Vec<u8>,
    elapsed: Duration,
}

fn finish_run(raw: RawRun, log: Vec<String>) -> Result<QemuRun, FirmwareError> {
    let mut run = QemuRun {
        exit_code: raw.exit_code,
        log,
        records: Vec::new(),
        begin_count: None,
        end_count: None,
        other_stderr: Vec::new(),
        elapsed: raw.elapsed,
    };
    parse_lines(&String::from_utf8_lossy(&raw.stderr), &mut run)?;
    Ok(run)
}

/// Runs `elf` in QEMU with [`QEMU_ARGS`] on `machine` and `cpu`, killing it after `timeout`.
fn spawn_qemu(
    elf: &Path,
    machine: &str,
    cpu: &str,
    timeout: Duration,
) -> Result<RawRun, FirmwareError> {
    let mut args = QEMU_ARGS;
    args[1] = machine;
    args[3] = cpu;
    let start = Instant::now();
    let mut child = Command::new(QEMU)
        .args(args)
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|source| FirmwareError::Spawn {
            program: QEMU.into(),
            source,
        })?;
    // Both pipes are drained on threads so that neither can fill up and stall QEMU.
    let drain = |mut r: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut v = Vec::new();
            let _ = r.read_to_end(&mut v);
            v
        })
    };
    let out_t = drain(Box::new(child.stdout.take().expect("piped")));
    let err_t = drain(Box::new(child.stderr.take().expect("piped")));
    let status = loop {
        if let Some(s) = child.try_wait().map_err(io_err(Path::new(QEMU)))? {
            break s;
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            return Err(FirmwareError::Timeout(timeout));
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Ok(RawRun {
        exit_code: status.code(),
        stdout: out_t.join().unwrap_or_default(),
        stderr: err_t.join().unwrap_or_default(),
        elapsed: start.elapsed(),
    })
}

enum DefmtFailure {
    Table(String),
    Malformed(usize),
}

fn decode_defmt(elf: &[u8], stream: &[u8]) -> Result<Vec<String>, DefmtFailure> {
    let table = defmt_decoder::Table::parse(elf)
        .map_err(|e| DefmtFailure::Table(e.to_string()))?
        .ok_or_else(|| DefmtFailure::Table("no .defmt section".into()))?;
    let mut decoder = table.new_stream_decoder();
    decoder.received(stream);
    let mut log = Vec::new();
    loop {
        match decoder.decode() {
            Ok(frame) => log.push(frame.display(false).to_string()),
            Err(defmt_decoder::DecodeError::UnexpectedEof) => return Ok(log),
            Err(defmt_decoder::DecodeError::Malformed) => {
                return Err(DefmtFailure::Malformed(log.len()))
            }
        }
    }
}

fn hex_u32(field: Option<&str>) -> Option<u32> {
    let f = field?;
    if f.len() != 8 {
        return None;
    }
    u32::from_str_radix(f, 16).ok()
}

fn parse_lines(text: &str, run: &mut QemuRun) -> Result<(), FirmwareError> {
    for (i, line) in text.lines().enumerate() {
        let bad = || FirmwareError::BadLine {
            line: i + 1,
            text: line.to_owned(),
        };
        let mut f = line.split(' ');
        match f.next() {
            Some("S") => {
                let mut words = [0u32; 5];
                for w in &mut words {
                    *w = hex_u32(f.next()).ok_or_else(bad)?;
                }
                let status = f
                    .next()
                    .filter(|s| s.len() == 2)
                    .and_then(|s| u8::from_str_radix(s, 16).ok());
                let status = status.ok_or_else(bad)?;
                if f.next().is_some() {
                    return Err(bad());
                }
                run.records.push(OutputRecord {
                    index: words[0],
                    temp_c_bits: words[1],
                    gyro_dph_bits: words[2],
                    rate_dph_bits: words[3],
                    correction_dph_bits: words[4],
                    status,
                });
            }
            Some("B") => run.begin_count = Some(hex_u32(f.next()).ok_or_else(bad)?),
            Some("E") => run.end_count = Some(hex_u32(f.next()).ok_or_else(bad)?),
            _ => run.other_stderr.push(line.to_owned()),
        }
    }
    Ok(())
}

/// Reads `key=value` (decimal) from a log line, e.g. `samples` from the summary line.
pub fn log_field(line: &str, key: &str) -> Option<u64> {
    line.split_whitespace()
        .filter_map(|w| w.split_once('='))
        .find(|(k, _)| *k == key)
        .and_then(|(_, v)| v.trim_end_matches([',', ')']).parse().ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn empty_run() -> QemuRun {
        QemuRun {
            exit_code: Some(0),
            log: vec![],
            records: vec![],
            begin_count: None,
            end_count: None,
            other_stderr: vec![],
            elapsed: Duration::ZERO,
        }
    }

    #[test]
    fn parses_the_wire_format() {
        let mut run = empty_run();
        let text = "B 00000001\nS 00000000 41cc0000 7fc00000 c0e40000 00000000 09\nqemu: note\nE 00000001\n";
        parse_lines(text, &mut run).unwrap();
        assert_eq!((run.begin_count, run.end_count), (Some(1), Some(1)));
        let r = run.records[0];
        assert_eq!(f32::from_bits(r.temp_c_bits), 25.5);
        assert!(f32::from_bits(r.gyro_dph_bits).is_nan());
        assert_eq!(f32::from_bits(r.rate_dph_bits), -7.125);
        assert_eq!(r.status, 9);
        assert_eq!(run.other_stderr, ["qemu: note"]);
        for bad in [
            "S 0 1 2 3 4 5",
            "S 00000000 41cc0000 7fc00000 c0e40000 00000000 09 extra",
            "B xyz",
        ] {
            assert!(parse_lines(bad, &mut empty_run()).is_err(), "{bad}");
        }
    }

    #[test]
    fn reads_log_fields() {
        let l = "INFO summary: samples=8400 ok=12 warming_up=300 (x)";
        assert_eq!(log_field(l, "samples"), Some(8400));
        assert_eq!(log_field(l, "warming_up"), Some(300));
        assert_eq!(log_field(l, "missing"), None);
    }
}
