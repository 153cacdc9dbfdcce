//! A corpus of plausible-but-wrong recordings (milliseconds, kelvin, rad/s, a 30-day gap,
//! 10⁷ samples, a 1 kHz log, a constant temperature, a single sample, NaN rates) through every
//! subcommand that reads a recording, each run as a child process under a resident-memory limit
//! of 1.5 GiB and a wall-clock limit.
//!
//! The limit is on resident memory, the memory a run takes from the machine, watched in
//! `/proc` and enforced by a kill. An address-space limit (`ulimit -v`) would measure
//! something else: faer's x86 GEMM reserves, untouched, two L3-sized packing buffers per thread
//! that multiplies, so a host that reports a large L3 (480 MiB on one of ours) needs ~1 GiB of
//! address space per thread before any memory is used, and a run aborted under 2 GiB without
//! ever being above 0.3 GiB resident.
//!
//! Each run must end with status 0 or 1 (never a panic, an abort on a failed allocation or a
//! kill), within both limits, without a backtrace; a failed run must say `error: …` once per
//! line (no cause repeating its message), name no temporary file, and leave no output behind.
//! Every violation across the matrix is collected and reported at the end in one message, so
//! one run of the test shows them all; `--nocapture` prints the table of every run (exit code,
//! wall time, peak resident memory, first line of stderr).

use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write as _};
use std::os::unix::process::CommandExt as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The resident-memory limit of every run, KiB: 1.5 GiB. The largest run measured on these
/// machines (resampling the 10⁷-sample file to 1 s) peaks at 1.04 GiB.
const RESIDENT_LIMIT_KIB: u64 = 1536 * 1024;

/// How often the watchdog reads the resident memory of a run's processes. A run that grows
/// faster than the machine can touch pages overshoots the limit by at most one interval.
const POLL: Duration = Duration::from_millis(20);

/// Wall-clock limit of one run. The slowest legitimate run is a subcommand on the 10⁷-sample
/// file; three minutes is far beyond what any user would wait for a refusal, and a run that
/// needs longer is a finding in itself.
const WALL_LIMIT: Duration = Duration::from_secs(180);

/// GNU time, when installed, gives the peak resident set size of the run.
const GNU_TIME: &str = "/usr/bin/time";

/// Text in stderr that means a bug, not a user's error, whatever the exit code.
const FORBIDDEN: [&str; 4] = [
    "panicked",
    "backtrace",
    "memory allocation",
    "RUST_BACKTRACE",
];

/// A 64-bit linear congruential generator (Knuth's MMIX constants): the corpus must be the
/// same on every run and machine, and needs no statistical quality beyond looking like noise.
struct Lcg(u64);

impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        // The top 53 bits, in (0, 1) so that the logarithm below is finite.
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// A standard normal deviate (Box–Muller, one of the pair).
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// A thermal-chamber run: the chamber holds 10 °C for an hour, ramps to 60 °C at 1 °C/min,
/// holds an hour, ramps back down, and so on; the gyro's sensor follows the chamber through a
/// 15-minute lag and 2 °C of self-heating; the output is −7.1 °/h with 0.2 mdph/°C of
/// temperature dependence (±5 mdph over the range), a little dT/dt dependence and 3 mdph of
/// white noise. A held chamber keeps the gyro settled at one temperature throughout.
struct Chamber {
    rng: Lcg,
    last_t: Option<f64>,
    gyro_c: f64,
    /// The gyro's temperature when the chamber holds it there from the start, °C.
    held_c: Option<f64>,
}

impl Chamber {
    const HOLD_S: f64 = 3600.0;
    const RAMP_S: f64 = 3000.0;
    const TAU_S: f64 = 900.0;

    const SELF_HEATING_C: f64 = 2.0;

    fn new(seed: u64, held_c: Option<f64>) -> Self {
        Chamber {
            rng: Lcg(seed),
            last_t: None,
            gyro_c: held_c.unwrap_or(10.0 + Self::SELF_HEATING_C),
            held_c,
        }
    }

    fn chamber_c(&self, t: f64) -> f64 {
        if let Some(c) = self.held_c {
            return c - Self::SELF_HEATING_C;
        }
        let period = 2.0 * (Self::HOLD_S + Self::RAMP_S);
        let p = t.rem_euclid(period);
        let (h, r) = (Self::HOLD_S, Self::RAMP_S);
        if p < h {
            10.0
        } else if p < h + r {
            10.0 + 50.0 * (p - h) / r
        } else if p < 2.0 * h + r {
            60.0
        } else {
            60.0 - 50.0 * (p - 2.0 * h - r) / r
        }
    }

    /// (rate °/h, gyro temperature °C, chamber °C) at time `t` s; times must increase.
    fn sample(&mut self, t: f64) -> (f64, f64, f64) {
        let chamber = self.chamber_c(t);
        let target = chamber + Self::SELF_HEATING_C;
        let dt = self.last_t.map_or(0.0, |l| t - l);
        let before = self.gyro_c;
        self.gyro_c += (target - self.gyro_c) * (1.0 - (-dt / Self::TAU_S).exp());
        self.last_t = Some(t);
        let slope_c_per_s = if dt > 0.0 {
            (self.gyro_c - before) / dt
        } else {
            0.0
        };
        let rate =
            -7.1 + 2e-4 * (self.gyro_c - 35.0) + 0.05 * slope_c_per_s + 3e-3 * self.rng.normal();
        (rate, self.gyro_c, chamber)
    }
}

/// How a corpus file departs from a good recording.
#[derive(Clone, Copy)]
enum Flaw {
    /// Time stamps in milliseconds.
    Milliseconds,
    /// Temperatures in kelvin.
    Kelvin,
    /// Rate in rad/s.
    RadPerS,
    /// Every rate written as `NaN`.
    NanRate,
    /// A plausible file; the flaw is in the times (a gap, the length, the rate) or in the
    /// temperature being constant.
    None,
}

/// Writes a recording of the chamber sampled at `times` (s), with `flaw`, and a comment saying
/// what is wrong with it; `held_c`: the chamber holds the gyro at this temperature.
fn write_recording(
    path: &Path,
    what: &str,
    times: impl Iterator<Item = f64>,
    time_decimals: usize,
    flaw: Flaw,
    held_c: Option<f64>,
) {
    let mut w = BufWriter::with_capacity(1 << 20, File::create(path).unwrap());
    writeln!(w, "# corpus: {what}").unwrap();
    writeln!(w, "time_s,rate_dph,temp_c,chamber_c").unwrap();
    let mut ch = Chamber::new(0x5eed_c0ff_ee00_0001, held_c);
    let mut line = String::with_capacity(64);
    for t in times {
        let (rate, temp, chamber) = ch.sample(t);
        line.clear();
        // The toolchain's own precision (recording::to_csv_string) for rate and temperatures.
        match flaw {
            Flaw::Milliseconds => write!(line, "{:.0}", t * 1000.0),
            _ => write!(line, "{t:.time_decimals$}"),
        }
        .unwrap();
        match flaw {
            Flaw::RadPerS => write!(line, ",{:.6e}", rate.to_radians() / 3600.0),
            Flaw::NanRate => write!(line, ",NaN"),
            _ => write!(line, ",{rate:.9}"),
        }
        .unwrap();
        let k = if matches!(flaw, Flaw::Kelvin) {
            273.15
        } else {
            0.0
        };
        writeln!(line, ",{:.4},{:.4}", temp + k, chamber + k).unwrap();
        w.write_all(line.as_bytes()).unwrap();
    }
    w.flush().unwrap();
}

/// One file of the corpus.
struct CorpusFile {
    path: PathBuf,
    stem: &'static str,
    /// A folder holding only this file, for `train-fleet --dir`.
    fleet_dir: PathBuf,
}

/// Writes the corpus into `dir`: the files and, per file, a fleet folder holding it alone (a
/// hard link, so the 10⁷-sample file is not copied).
fn write_corpus(dir: &Path) -> Vec<CorpusFile> {
    const HOUR: f64 = 3600.0;
    const DAY: f64 = 86_400.0;
    let hz1 = |n: u64| (0..n).map(|i| i as f64);
    let mut out = Vec::new();
    let mut add = |stem: &'static str, write: &dyn Fn(&Path)| {
        let path = dir.join(format!("{stem}.csv"));
        let t0 = Instant::now();
        write(&path);
        let fleet_dir = dir.join("fleet").join(stem);
        std::fs::create_dir_all(&fleet_dir).unwrap();
        let link = fleet_dir.join(format!("{stem}.csv"));
        if std::fs::hard_link(&path, &link).is_err() {
            std::fs::copy(&path, &link).unwrap();
        }
        println!(
            "wrote {stem}.csv: {:.1} MB in {:.1} s",
            std::fs::metadata(&path).unwrap().len() as f64 / 1e6,
            t0.elapsed().as_secs_f64()
        );
        out.push(CorpusFile {
            path,
            stem,
            fleet_dir,
        });
    };
    // Two chamber cycles at 1 Hz: the shape behind the unit and NaN flaws.
    let cycles2 = 4 * (Chamber::HOLD_S + Chamber::RAMP_S) as u64;
    add("ms", &|p| {
        write_recording(
            p,
            "time stamps in milliseconds",
            hz1(12_000),
            0,
            Flaw::Milliseconds,
            None,
        )
    });
    add("gap30d", &|p| {
        let piece = (4.0 * HOUR) as u64;
        let times = hz1(piece).chain(hz1(piece).map(|t| t + 4.0 * HOUR + 30.0 * DAY));
        write_recording(
            p,
            "two 4 h pieces 30 days apart",
            times,
            0,
            Flaw::None,
            None,
        )
    });
    add("big1e7", &|p| {
        write_recording(
            p,
            "10^7 samples at 1 Hz (116 days)",
            hz1(10_000_000),
            0,
            Flaw::None,
            None,
        )
    });
    add("khz", &|p| {
        // Ten minutes from the start of a heating ramp, so that the temperature moves.
        write_recording(
            p,
            "a 1 kHz log, 10 minutes",
            (0..600_000u64).map(|i| Chamber::HOLD_S + i as f64 * 1e-3),
            3,
            Flaw::None,
            None,
        )
    });
    add("kelvin", &|p| {
        write_recording(
            p,
            "temperatures in kelvin",
            hz1(cycles2),
            0,
            Flaw::Kelvin,
            None,
        )
    });
    add("rads", &|p| {
        write_recording(p, "rate in rad/s", hz1(cycles2), 0, Flaw::RadPerS, None)
    });
    add("const_temp", &|p| {
        write_recording(
            p,
            "constant temperature for 6 h",
            hz1((6.0 * HOUR) as u64),
            0,
            Flaw::None,
            Some(25.0),
        )
    });
    add("single", &|p| {
        write_recording(p, "a single sample", hz1(1), 0, Flaw::None, None)
    });
    add("nan_rate", &|p| {
        write_recording(p, "every rate NaN", hz1(cycles2), 0, Flaw::NanRate, None)
    });
    out
}

/// Removes files when the test ends, passed or failed: the 10⁷-sample file (~370 MB) and its
/// fleet link. The rest of the corpus and the logs of every run stay for inspection.
struct RemoveOnDrop(Vec<PathBuf>);

impl Drop for RemoveOnDrop {
    fn drop(&mut self) {
        for p in &self.0 {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// What a subcommand writes, which must not exist after a failed run.
enum Output {
    File(PathBuf),
    /// A folder; one the tool created but left empty counts as no output (`calibrate` and
    /// `train-fleet` create theirs before reading the recording, so that a path that cannot
    /// hold it fails before minutes of work).
    Folder(PathBuf),
    /// `train-fleet`'s folder: after a failed gyro it holds the summary that reports the
    /// failure (`summary.csv`, `summary.md`, by design) and nothing else.
    FleetFolder(PathBuf),
}

/// A subcommand that reads a recording: its name in the table and its arguments for a
/// recording (and its fleet folder), writing into `run_dir`.
type ArgsFn = fn(&CorpusFile, &Path) -> (Vec<String>, Vec<Output>);

struct Subcommand {
    name: &'static str,
    args: ArgsFn,
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

#[allow(
    clippy::too_many_lines,
    reason = "a table: one entry per subcommand that reads a recording, each its arguments and outputs"
)]
fn subcommands() -> Vec<Subcommand> {
    vec![
        Subcommand {
            name: "train",
            args: |f, d| {
                let out = d.join("model.json");
                (
                    vec![
                        "train".into(),
                        "--recording".into(),
                        s(&f.path),
                        "--out".into(),
                        s(&out),
                    ],
                    vec![Output::File(out)],
                )
            },
        },
        Subcommand {
            name: "train σ,c",
            args: |f, d| {
                let out = d.join("model.json");
                (
                    [
                        "train",
                        "--recording",
                        &s(&f.path),
                        "--sigma",
                        "0.67",
                        "--c",
                        "42",
                        "--out",
                        &s(&out),
                    ]
                    .map(String::from)
                    .to_vec(),
                    vec![Output::File(out)],
                )
            },
        },
        Subcommand {
            name: "calibrate",
            args: |f, d| {
                let out = d.join("cal");
                (
                    ["calibrate", "--recording", &s(&f.path), "--out", &s(&out)]
                        .map(String::from)
                        .to_vec(),
                    vec![Output::Folder(out)],
                )
            },
        },
        Subcommand {
            name: "calibrate --static",
            args: |f, d| {
                let out = d.join("cal");
                (
                    [
                        "calibrate",
                        "--recording",
                        &s(&f.path),
                        "--static",
                        "--out",
                        &s(&out),
                    ]
                    .map(String::from)
                    .to_vec(),
                    vec![Output::Folder(out)],
                )
            },
        },
        Subcommand {
            name: "diagnose",
            args: |f, d| {
                let out = d.join("diagnosis.json");
                (
                    ["diagnose", "--recording", &s(&f.path), "--json", &s(&out)]
                        .map(String::from)
                        .to_vec(),
                    vec![Output::File(out)],
                )
            },
        },
        Subcommand {
            name: "close-loop",
            args: |f, d| {
                let (model, table) = (d.join("model.json"), d.join("table.rs"));
                (
                    [
                        "close-loop",
                        "--recording",
                        &s(&f.path),
                        "--out-model",
                        &s(&model),
                        "--out-table",
                        &s(&table),
                    ]
                    .map(String::from)
                    .to_vec(),
                    vec![Output::File(model), Output::File(table)],
                )
            },
        },
        Subcommand {
            name: "resample 1 s",
            args: |f, d| {
                let out = d.join("resampled.csv");
                (
                    [
                        "resample",
                        "--recording",
                        &s(&f.path),
                        "--period-s",
                        "1",
                        "--out",
                        &s(&out),
                    ]
                    .map(String::from)
                    .to_vec(),
                    vec![Output::File(out)],
                )
            },
        },
        Subcommand {
            name: "resample bursts",
            args: |f, d| {
                let out = d.join("resampled.csv");
                (
                    [
                        "resample",
                        "--recording",
                        &s(&f.path),
                        "--bursts",
                        "10",
                        "--out",
                        &s(&out),
                    ]
                    .map(String::from)
                    .to_vec(),
                    vec![Output::File(out)],
                )
            },
        },
        Subcommand {
            name: "train-fleet",
            args: |f, d| {
                let out = d.join("fleet");
                (
                    ["train-fleet", "--dir", &s(&f.fleet_dir), "--out", &s(&out)]
                        .map(String::from)
                        .to_vec(),
                    vec![Output::FleetFolder(out)],
                )
            },
        },
    ]
}

/// How one run ended.
struct Run {
    /// `None` when it was killed at a limit.
    code: Option<i32>,
    /// Why it was killed, when it was.
    killed: Option<String>,
    wall_s: f64,
    /// The larger of GNU time's peak (exact, when installed) and the watchdog's.
    peak_mb: f64,
    stderr: String,
}

/// A process's group and its resident set, current and peak, in KiB, from `/proc/<pid>`.
fn proc_memory(pid: &str) -> Option<(i32, u64, u64)> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The command name in parentheses may hold spaces; the fields after it are fixed:
    // state, ppid, pgrp.
    let pgrp = stat[stat.rfind(')')? + 1..]
        .split_whitespace()
        .nth(2)?
        .parse()
        .ok()?;
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let field = |name: &str| -> Option<u64> {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))?
            .split_whitespace()
            .next()?
            .parse()
            .ok()
    };
    // A zombie has no VmRSS line; it holds no memory.
    Some((
        pgrp,
        field("VmRSS:").unwrap_or(0),
        field("VmHWM:").unwrap_or(0),
    ))
}

/// The summed resident set of the processes in group `pgrp`, and the largest peak among them,
/// KiB.
fn group_memory(pgrp: i32) -> (u64, u64) {
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return (0, 0);
    };
    let mut rss = 0;
    let mut hwm = 0;
    for e in dir.flatten() {
        let name = e.file_name();
        let Some(pid) = name
            .to_str()
            .filter(|n| n.bytes().all(|b| b.is_ascii_digit()))
        else {
            continue;
        };
        if let Some((g, r, h)) = proc_memory(pid) {
            if g == pgrp {
                rss += r;
                hwm = hwm.max(h);
            }
        }
    }
    (rss, hwm)
}

/// Runs `rlg args` in `cwd` with stdout and stderr in files of `logs` (a pipe left undrained
/// while polling would stall a chatty run), killing its process group at the wall-clock or the
/// resident-memory limit.
fn run_limited(args: &[String], cwd: &Path, logs: &Path, tag: &str) -> Run {
    let timed = Path::new(GNU_TIME).exists();
    let time_file = logs.join(format!("{tag}.time"));
    let rlg = env!("CARGO_BIN_EXE_rlg");
    let mut cmd = if timed {
        let mut c = Command::new(GNU_TIME);
        c.args(["-f", "%M", "-o"]).arg(&time_file).arg(rlg);
        c
    } else {
        Command::new(rlg)
    };
    let stderr_file = logs.join(format!("{tag}.stderr"));
    cmd.args(args)
        .current_dir(cwd)
        .env("RUST_BACKTRACE", "1")
        .stdin(Stdio::null())
        .stdout(File::create(logs.join(format!("{tag}.stdout"))).unwrap())
        .stderr(File::create(&stderr_file).unwrap())
        // Its own process group, so that the watchdog finds `rlg` under GNU time and a kill
        // reaches it.
        .process_group(0);
    let t0 = Instant::now();
    let mut child = cmd.spawn().expect("spawn rlg");
    let pgrp = i32::try_from(child.id()).expect("a pid fits an i32");
    let mut watched_hwm_kib = 0;
    let mut killed = None;
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break Some(st);
        }
        let (rss, hwm) = group_memory(pgrp);
        watched_hwm_kib = watched_hwm_kib.max(hwm);
        if rss > RESIDENT_LIMIT_KIB {
            killed = Some(format!(
                "killed at {:.0} MB resident, above the {:.0} MB limit",
                rss as f64 / 1024.0,
                RESIDENT_LIMIT_KIB as f64 / 1024.0
            ));
        } else if t0.elapsed() > WALL_LIMIT {
            killed = Some(format!(
                "timed out: killed after {:.0} s",
                WALL_LIMIT.as_secs_f64()
            ));
        }
        if killed.is_some() {
            let _ = Command::new("kill")
                .args(["-KILL", "--", &format!("-{pgrp}")])
                .status();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(POLL);
    };
    let wall_s = t0.elapsed().as_secs_f64();
    // GNU time exits with the command's status, or 128 + the signal that ended it.
    let code = status.map(|st| {
        st.code().unwrap_or_else(|| {
            128 + std::os::unix::process::ExitStatusExt::signal(&st).unwrap_or(0)
        })
    });
    // Its file ends with the format's line (`Command exited with …` may precede it).
    let timed_kib = std::fs::read_to_string(&time_file)
        .ok()
        .and_then(|t| t.lines().last()?.trim().parse::<f64>().ok())
        .unwrap_or(0.0);
    let peak_mb = timed_kib.max(watched_hwm_kib as f64) / 1024.0;
    Run {
        code,
        killed,
        wall_s,
        peak_mb,
        stderr: std::fs::read_to_string(&stderr_file).unwrap_or_default(),
    }
}

/// A temporary file's name in `text`: the `.tmpXXXXXX` of `tempfile` or the `.….tmp.<ext>` of
/// `atomic::write_with`.
fn names_a_temporary_file(text: &str) -> bool {
    text.match_indices(".tmp").any(|(i, m)| {
        text[i + m.len()..]
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphanumeric() || c == '.')
    })
}

/// The message of an `error: ` or `  caused by: ` line, for comparing a cause with what was
/// already said.
fn message(line: &str) -> &str {
    let l = line.trim();
    l.strip_prefix("error:")
        .or_else(|| l.strip_prefix("caused by:"))
        .unwrap_or(l)
        .trim()
}

/// What a folder holds, recursively, as paths relative to it; empty when it does not exist.
fn contents(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in rd.filter_map(Result::ok) {
            let p = e.path();
            out.push(
                p.strip_prefix(dir)
                    .unwrap_or(&p)
                    .to_string_lossy()
                    .into_owned(),
            );
            if p.is_dir() {
                stack.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The contract's violations by one run; empty when it kept it.
fn violations(run: &Run, outputs: &[Output], run_dir: &Path) -> Vec<String> {
    let mut v = Vec::new();
    match run.code {
        None => v.push(run.killed.clone().unwrap_or_else(|| "killed".to_string())),
        Some(0 | 1) => {}
        Some(c) => v.push(format!("exit code {c}, expected 0 or 1")),
    }
    // GNU time's exact peak may show what a 20 ms watchdog missed.
    if run.peak_mb > RESIDENT_LIMIT_KIB as f64 / 1024.0 && run.killed.is_none() {
        v.push(format!(
            "peak resident memory {:.0} MB, above the {:.0} MB limit",
            run.peak_mb,
            RESIDENT_LIMIT_KIB as f64 / 1024.0
        ));
    }
    for bad in FORBIDDEN {
        if run.stderr.contains(bad) {
            v.push(format!("stderr contains `{bad}`"));
        }
    }
    // Leftovers of an atomic write, whatever the outcome.
    let temporaries: Vec<String> = contents(run_dir)
        .into_iter()
        .filter(|p| names_a_temporary_file(p))
        .collect();
    if !temporaries.is_empty() {
        v.push(format!("temporary files left: {temporaries:?}"));
    }
    if run.code == Some(0) {
        return v;
    }
    // A failed run (exit 1, a crash or a timeout). Warnings about the data (e.g. gaps) may
    // come first; the first other line must be the error.
    let lines: Vec<&str> = run.stderr.lines().collect();
    let first = lines.iter().find(|l| !l.starts_with("warning: "));
    if !first.is_some_and(|l| l.starts_with("error: ")) {
        v.push(format!(
            "first non-warning line of stderr is {:?}, expected `error: …`",
            first.copied().unwrap_or("")
        ));
    }
    // A line that repeats an earlier one, or a cause that an earlier message already ends
    // with (`error: f: Is a directory` / `caused by: Is a directory`).
    // Lines without a letter or digit (the `|` gutter of a quoted source line) may repeat.
    for (i, l) in lines.iter().enumerate() {
        let m = message(l);
        if !m.chars().any(char::is_alphanumeric) {
            continue;
        }
        if let Some(e) = lines[..i]
            .iter()
            .find(|e| *e == l || (l.trim().starts_with("caused by:") && message(e).ends_with(m)))
        {
            v.push(format!("stderr line {:?} repeats {:?}", l.trim(), e.trim()));
        }
    }
    if names_a_temporary_file(&run.stderr) {
        v.push("stderr names a temporary file".to_string());
    }
    for o in outputs {
        match o {
            Output::File(p) if p.exists() => v.push(format!("output {} exists", p.display())),
            Output::Folder(p) if !contents(p).is_empty() => v.push(format!(
                "output folder {} holds {:?}",
                p.display(),
                contents(p)
            )),
            Output::FleetFolder(p) => {
                let other: Vec<String> = contents(p)
                    .into_iter()
                    .filter(|f| f != "summary.csv" && f != "summary.md")
                    .collect();
                if !other.is_empty() {
                    v.push(format!(
                        "fleet folder {} holds {other:?} besides its summary",
                        p.display()
                    ));
                }
            }
            _ => {}
        }
    }
    v
}

/// The first line of `stderr` for the table, the corpus folder written `$CORPUS`, cut to
/// `n` characters; when it is a warning, the first other line follows it.
fn first_line(stderr: &str, corpus: &Path, n: usize) -> String {
    let cut = |l: &str| {
        let l = l.replace(corpus.to_str().unwrap(), "$CORPUS");
        if l.chars().count() > n {
            format!("{}…", l.chars().take(n).collect::<String>())
        } else {
            l
        }
    };
    let mut lines = stderr.lines();
    let first = lines.next().unwrap_or("");
    match lines.find(|l| !l.starts_with("warning: ")) {
        Some(next) if first.starts_with("warning: ") => {
            format!("{} ⏎ {}", cut(first), cut(next))
        }
        _ => cut(first),
    }
}

/// The corpus file whose runs go one at a time in a lane of their own.
const HEAVY_FILE: &str = "big1e7";

/// One subcommand on one file of the corpus: its row of the table, and its violations of the
/// contract in one message (`None`: none).
fn run_one(f: &CorpusFile, sub: &Subcommand, root: &Path, logs: &Path) -> (String, Option<String>) {
    let tag = format!("{}-{}", f.stem, sub.name.replace([' ', ',', '-'], "_"));
    let run_dir = root.join("out").join(&tag);
    std::fs::create_dir_all(&run_dir).unwrap();
    let (args, outputs) = (sub.args)(f, &run_dir);
    let run = run_limited(&args, &run_dir, logs, &tag);
    let peak = format!("{:.0}", run.peak_mb);
    let code = run
        .code
        .map_or_else(|| "kill".to_string(), |c| c.to_string());
    let row = format!(
        "{:<11} {:<19} {:>4} {:>7.1} {:>8}  {}",
        f.stem,
        sub.name,
        code,
        run.wall_s,
        peak,
        first_line(&run.stderr, root, 110)
    );
    let v = violations(&run, &outputs, &run_dir);
    let bad = (!v.is_empty()).then(|| {
        let head: Vec<&str> = run.stderr.lines().take(4).collect();
        format!(
            "rlg {}\n    exit {code}, {:.1} s, peak {peak} MB\n    violations: {}\n    stderr: {}",
            args.join(" "),
            run.wall_s,
            v.join("; "),
            head.join("\n            ")
        )
    });
    // The outputs of a successful run are not needed, and the 10⁷-sample file's resampled
    // copies alone would hold ~1 GB.
    let _ = std::fs::remove_dir_all(&run_dir);
    (row, bad)
}

#[test]
fn corpus_of_wrong_recordings_through_every_subcommand() {
    let t_all = Instant::now();
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("corpus");
    // A fresh corpus, so that no output of an earlier run exists before its run.
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let _cleanup = RemoveOnDrop(vec![
        root.join("big1e7.csv"),
        root.join("fleet").join("big1e7").join("big1e7.csv"),
    ]);
    let files = write_corpus(&root);
    let logs = root.join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    if !Path::new(GNU_TIME).exists() {
        println!("{GNU_TIME} not found: peak memory from the watchdog's {POLL:?} readings");
    }

    // Two lanes at once: the 10⁷-sample file's runs one after another in one, every other
    // run in the other. Most runs are a process start and a refusal; two 10⁷-sample runs at
    // once would share the cores and could pass the wall-clock limit on a slow machine.
    let subs = subcommands();
    let jobs: Vec<(&CorpusFile, &Subcommand)> = files
        .iter()
        .flat_map(|f| subs.iter().map(move |sub| (f, sub)))
        .collect();
    let results = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for heavy_lane in [true, false] {
            let (jobs, results, root, logs) = (&jobs, &results, &root, &logs);
            scope.spawn(move || {
                for (i, &(f, sub)) in jobs.iter().enumerate() {
                    if (f.stem == HEAVY_FILE) == heavy_lane {
                        let outcome = run_one(f, sub, root, logs);
                        println!("{}", outcome.0);
                        results.lock().unwrap().push((i, outcome));
                    }
                }
            });
        }
    });
    let mut results = results.into_inner().unwrap();
    results.sort_by_key(|r| r.0);
    let mut table = String::new();
    writeln!(
        table,
        "{:<11} {:<19} {:>4} {:>7} {:>8}  first line of stderr",
        "file", "subcommand", "exit", "wall s", "peak MB"
    )
    .unwrap();
    let mut bad = Vec::new();
    for (_, (row, violation)) in results {
        writeln!(table, "{row}").unwrap();
        bad.extend(violation);
    }
    println!("\n{table}");
    println!(
        "{} runs, {} violating, whole test {:.0} s",
        jobs.len(),
        bad.len(),
        t_all.elapsed().as_secs_f64()
    );
    assert!(
        bad.is_empty(),
        "{} of {} runs broke the contract:\n\n{}",
        bad.len(),
        jobs.len(),
        bad.join("\n\n")
    );
}

/// The watchdog reads real figures: the group of this test process holds at least the
/// resident set of this process, and a buffer of 64 MiB touched here raises it by that much.
/// Without this, a reader that found no process would pass every run.
#[test]
fn watchdog_sees_the_resident_memory_of_a_group() {
    let me = std::process::id().to_string();
    let (pgrp, rss0, _) = proc_memory(&me).expect("/proc/self readable");
    let (group_rss0, _) = group_memory(pgrp);
    assert!(
        rss0 > 0 && group_rss0 >= rss0,
        "rss {rss0} KiB, group {group_rss0} KiB"
    );
    let buf = vec![1u8; 64 << 20];
    let (_, rss1, hwm1) = proc_memory(&me).unwrap();
    assert!(
        rss1 >= rss0 + 60 * 1024 && hwm1 >= rss1,
        "rss {rss0} → {rss1} KiB, peak {hwm1} KiB after touching 64 MiB"
    );
    assert_eq!(buf.iter().map(|&b| u64::from(b)).sum::<u64>(), 64 << 20);
}
