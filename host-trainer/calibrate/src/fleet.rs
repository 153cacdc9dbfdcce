//! A fleet: every recording of a folder (one per gyro or axis) calibrated in parallel (rayon,
//! one task per recording), each tuned on its own data by [`crate::calibrate`], each with its
//! own report folder; a summary (CSV and Markdown) with pass / fail against the user's limits.
//!
//! A recording that fails (unreadable, too short, no table within the f32 limit) is reported
//! in its row; it does not stop the others.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::ProgressBar;
use rayon::prelude::*;

use rlg_io::recording::Recording;
use rlg_train::model::Provenance;

use crate::error::{chain, ensure, CalibrateError};
use crate::report::{self, FileInfo, Inputs};
use crate::static_cal::{calibrate_static, StaticOptions};
use crate::{calibrate, HeldOut, Model, Options};

/// What each gyro of the fleet gets: the dynamic calibration or the static (temperature-only)
/// characterisation, with their options.
#[derive(Clone, Debug, PartialEq)]
pub enum FleetModel {
    /// [`crate::calibrate`].
    Dynamic(Options),
    /// [`calibrate_static`].
    Static(StaticOptions),
}

/// Reads and checks one recording of the fleet (units, plausibility).
pub type ReadRecording = dyn Fn(&Path) -> Result<Recording, CalibrateError> + Sync;

/// Acceptance limits on the board table's held-out figures; `None`: not checked.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Limits {
    /// Largest held-out bias stability of the board's output over the window, °/h.
    pub max_stability_dph: Option<f64>,
    /// Smallest held-out improvement factor (raw / board).
    pub min_improvement: Option<f64>,
}

impl Limits {
    fn any(&self) -> bool {
        self.max_stability_dph.is_some() || self.min_improvement.is_some()
    }
}

/// One gyro's outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct FleetRow {
    /// The recording's file name.
    pub name: String,
    /// Why it failed, if it did (then the figures are NaN).
    pub error: Option<String>,
    /// What was held out (`cycles k/n`, `nothing`).
    pub held_out: String,
    /// σ, c of the board table.
    pub sigma: f64,
    /// See [`FleetRow::sigma`].
    pub c: f64,
    /// Held-out stability, °/h: raw, stepwise, LS-SVM, board.
    pub stability_dph: [f64; 4],
    /// Held-out improvement of the board table.
    pub improvement: f64,
    /// |f32 − f64| of the board table, °/h.
    pub f32_deviation_dph: f64,
    /// `None` without limits; otherwise whether every limit holds.
    pub pass: Option<bool>,
    /// The limits that failed, in words.
    pub failures: Vec<String>,
    /// Wall time of this gyro, s.
    pub wall_s: f64,
}

/// File name extensions taken as recordings.
pub const RECORDING_EXTENSIONS: [&str; 3] = ["csv", "tsv", "txt"];

/// The recordings of `dir` (`*.csv`, `*.tsv`, `*.txt`), sorted by name.
pub fn recordings_in(dir: &Path) -> Result<Vec<PathBuf>, CalibrateError> {
    let rd = std::fs::read_dir(dir)
        .map_err(|e| CalibrateError::Option(format!("--dir {}: {e}", dir.display())))?;
    let mut v: Vec<PathBuf> = rd
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .is_some_and(|e| RECORDING_EXTENSIONS.iter().any(|x| e == *x))
        })
        .collect();
    v.sort();
    ensure!(
        !v.is_empty(),
        Input,
        "no recording (*.csv, *.tsv, *.txt) in {}",
        dir.display()
    );
    Ok(v)
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map_or_else(|| "recording".into(), |s| s.to_string_lossy().into_owned())
}

fn one(
    path: &Path,
    out: &Path,
    model: &FleetModel,
    limits: &Limits,
    command: &str,
    read: &ReadRecording,
) -> Result<FleetRow, CalibrateError> {
    let t0 = Instant::now();
    let rec = read(path)?;
    let provenance = Provenance::from_file(path, command)?;
    let opts = match model {
        FleetModel::Dynamic(o) => o,
        FleetModel::Static(o) => {
            return one_static(&rec, &out.join(stem(path)), o, limits, &provenance, t0);
        }
    };
    let c = calibrate(&rec, None, opts, &provenance, &ProgressBar::hidden())?;
    let inputs = Inputs {
        command: command.to_string(),
        recording: FileInfo {
            file: provenance.data_file.clone(),
            sha256: provenance.data_sha256.clone(),
            samples: rec.len(),
        },
        test_recording: None,
    };
    report::write(&c, &inputs, &out.join(stem(path)))?;
    let b = |n: Model| {
        c.row(n)
            .and_then(|r| r.held_out.as_ref())
            .map_or(f64::NAN, |h| h.stability_dph)
    };
    let improvement = c
        .row(Model::Board)
        .and_then(|r| r.held_out.as_ref())
        .and_then(|h| h.improvement)
        .unwrap_or(f64::NAN);
    let mut failures = Vec::new();
    if limits.any() && matches!(c.split.held_out, HeldOut::Nothing) {
        failures.push("no held-out data to judge (one temperature cycle)".to_string());
    }
    if let Some(m) = limits.max_stability_dph {
        if b(Model::Board).is_nan() || b(Model::Board) > m {
            failures.push(format!("stability {:.3e} > {m:.3e} °/h", b(Model::Board)));
        }
    }
    if let Some(m) = limits.min_improvement {
        if improvement.is_nan() || improvement < m {
            failures.push(format!("improvement {improvement:.2} < {m:.2}"));
        }
    }
    Ok(FleetRow {
        name: provenance.data_file,
        error: None,
        held_out: match c.split.held_out {
            HeldOut::Cycles { train, test } => format!("last {test} of {} cycles", train + test),
            HeldOut::TestRecording => "test recording".into(),
            HeldOut::Nothing => "nothing".into(),
        },
        sigma: c.board.sigma,
        c: c.board.c,
        stability_dph: [
            b(Model::Raw),
            b(Model::Stepwise),
            b(Model::Lssvm),
            b(Model::Board),
        ],
        improvement,
        f32_deviation_dph: c.board.f32_deviation_dph,
        pass: limits.any().then_some(failures.is_empty()),
        failures,
        wall_s: t0.elapsed().as_secs_f64(),
    })
}

/// One gyro's static characterisation into `dir`: CV figures only, so any limit fails it.
fn one_static(
    rec: &Recording,
    dir: &Path,
    opts: &StaticOptions,
    limits: &Limits,
    provenance: &Provenance,
    t0: Instant,
) -> Result<FleetRow, CalibrateError> {
    let c = calibrate_static(rec, None, opts, provenance, &ProgressBar::hidden())?;
    let inputs = Inputs {
        command: provenance.command.clone(),
        recording: FileInfo {
            file: provenance.data_file.clone(),
            sha256: provenance.data_sha256.clone(),
            samples: rec.len(),
        },
        test_recording: None,
    };
    report::write_static(&c, &inputs, dir)?;
    let failures = if limits.any() {
        vec!["no held-out data to judge (static: CV figures only)".to_string()]
    } else {
        Vec::new()
    };
    Ok(FleetRow {
        name: provenance.data_file.clone(),
        error: None,
        held_out: "nothing (static)".into(),
        sigma: c.table_point.sigma,
        c: c.table_point.c,
        stability_dph: [f64::NAN; 4],
        improvement: f64::NAN,
        f32_deviation_dph: c.f32_deviation_dph,
        pass: limits.any().then_some(failures.is_empty()),
        failures,
        wall_s: t0.elapsed().as_secs_f64(),
    })
}

/// Calibrates every recording of `dir` into `out/<stem>/` (see the module doc); `read` reads
/// and checks one recording (units, plausibility).
pub fn calibrate_fleet(
    dir: &Path,
    out: &Path,
    model: &FleetModel,
    limits: &Limits,
    command: &str,
    read: &ReadRecording,
    progress: &ProgressBar,
) -> Result<Vec<FleetRow>, CalibrateError> {
    let files = recordings_in(dir)?;
    report::prepare_dir(out)?;
    progress.set_length(files.len() as u64);
    let rows = files
        .par_iter()
        .map(|p| {
            let r = one(p, out, model, limits, command, read).unwrap_or_else(|e| FleetRow {
                name: p
                    .file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
                error: Some(chain(&e)),
                held_out: "—".into(),
                sigma: f64::NAN,
                c: f64::NAN,
                stability_dph: [f64::NAN; 4],
                improvement: f64::NAN,
                f32_deviation_dph: f64::NAN,
                pass: Some(false),
                failures: vec!["calibration failed".into()],
                wall_s: 0.0,
            });
            progress.inc(1);
            r
        })
        .collect();
    progress.finish_and_clear();
    Ok(rows)
}

/// The summary as CSV (one row per gyro; NaN for a failed one).
pub fn summary_csv(rows: &[FleetRow]) -> String {
    let mut s = String::from(
        "recording,held_out,sigma,c,raw_stability_dph,stepwise_stability_dph,\
         lssvm_stability_dph,board_stability_dph,board_improvement,f32_deviation_dph,pass,\
         failures,error,wall_s\n",
    );
    let q = |t: &str| format!("\"{}\"", t.replace('"', "\"\""));
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{:.2}",
            q(&r.name),
            q(&r.held_out),
            r.sigma,
            r.c,
            r.stability_dph[0],
            r.stability_dph[1],
            r.stability_dph[2],
            r.stability_dph[3],
            r.improvement,
            r.f32_deviation_dph,
            r.pass.map_or("", |p| if p { "pass" } else { "fail" }),
            q(&r.failures.join("; ")),
            q(r.error.as_deref().unwrap_or("")),
            r.wall_s
        );
    }
    s
}

/// The summary as a Markdown table.
pub fn summary_markdown(rows: &[FleetRow], window: usize, limits: &Limits, wall_s: f64) -> String {
    let mut s = format!(
        "| recording | held out | σ | c | HELD-OUT {window} s stability raw / stepwise / LS-SVM / \
         board (°/h) | board improvement | result |\n|---|---|---:|---:|---|---:|---|\n"
    );
    for r in rows {
        let result = match (&r.error, r.pass) {
            (Some(e), _) => format!("FAILED: {e}"),
            (None, Some(true)) => "pass".into(),
            (None, Some(false)) => format!("FAIL: {}", r.failures.join("; ")),
            (None, None) => "— (no limits given)".into(),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {:.3} | {:.3} | {:.2e} / {:.2e} / {:.2e} / {:.2e} | {:.2} | {} |",
            r.name,
            r.held_out,
            r.sigma,
            r.c,
            r.stability_dph[0],
            r.stability_dph[1],
            r.stability_dph[2],
            r.stability_dph[3],
            r.improvement,
            result
        );
    }
    let failed = rows.iter().filter(|r| r.pass == Some(false)).count();
    let _ = writeln!(
        s,
        "\n{} gyros in {wall_s:.1} s; limits: stability ≤ {}, improvement ≥ {}; {} failed.",
        rows.len(),
        limits
            .max_stability_dph
            .map_or("—".into(), |v| format!("{v:.2e} °/h")),
        limits
            .min_improvement
            .map_or("—".into(), |v| format!("{v:.2}")),
        failed
    );
    s
}

/// Writes `summary.csv` and `summary.md` into `out`; returns the Markdown.
pub fn write_summaries(
    out: &Path,
    rows: &[FleetRow],
    window: usize,
    limits: &Limits,
    wall: std::time::Duration,
) -> Result<String, CalibrateError> {
    let md = summary_markdown(rows, window, limits, wall.as_secs_f64());
    for (name, text) in [
        ("summary.csv", summary_csv(rows)),
        ("summary.md", md.clone()),
    ] {
        let p = out.join(name);
        rlg_io::atomic::write(&p, text.as_bytes()).map_err(|source| CalibrateError::Write {
            path: p.display().to_string(),
            source,
        })?;
    }
    Ok(md)
}
