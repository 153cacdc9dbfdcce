//! The calibration folder: `report.md`, `summary.json` (schema in `SUMMARY.md` of this
//! crate, versioned by [`SCHEMA_VERSION`]), PNG figures, `model.json`, the board table in Rust
//! (`table.rs`) and C (`table.h`). Every file is written atomically; the folder is created
//! first, so a path that cannot hold it fails before any work.

mod figures;
mod imu;
mod markdown;
mod summary;

use std::path::{Path, PathBuf};

use serde::Serialize;

use rlg_train::export::{self, Format};
use rlg_train::export_c::CName;
use rlg_train::model::ModelFile;

use crate::static_cal::StaticCalibration;
use crate::{CalibrateError, Calibration};

pub use imu::{imu_header, imu_module, write_imu, ImuAxis};
pub use markdown::{comparison, console_tail, markdown, static_console, static_markdown};
pub use summary::{
    static_summary, summary, AllanReadOffs, BoardSummary, HeldOutSummary, Interval, ModelSummary,
    SplitSummary, Summary, TuningSummary, SCHEMA, SCHEMA_VERSION,
};

/// A data file named in the summary.
#[derive(Clone, Debug, Serialize)]
pub struct FileInfo {
    /// File name (no folder).
    pub file: String,
    /// SHA-256 of its bytes.
    pub sha256: String,
    /// Rows (samples) read.
    pub samples: usize,
}

/// What a report is written from, besides the result.
#[derive(Clone, Debug)]
pub struct Inputs {
    /// The command line.
    pub command: String,
    /// The calibration recording.
    pub recording: FileInfo,
    /// The test recording.
    pub test_recording: Option<FileInfo>,
}

fn write_text(path: &Path, text: &str) -> Result<(), CalibrateError> {
    rlg_io::atomic::write(path, text.as_bytes()).map_err(|source| CalibrateError::Write {
        path: path.display().to_string(),
        source,
    })
}

/// Writes `model{stem}.json`, `table{stem}.rs` and `table{stem}.h`, the header's symbols
/// prefixed `c_name`.
fn write_tables(
    dir: &Path,
    m: &ModelFile,
    command: &str,
    stem: &str,
    c_name: &CName,
) -> Result<Vec<String>, CalibrateError> {
    let names = [
        format!("model{stem}.json"),
        format!("table{stem}.rs"),
        format!("table{stem}.h"),
    ];
    m.write(&dir.join(&names[0]))?;
    export::write_board_table(m, command, &dir.join(&names[1]), Format::Rust)?;
    export::write_board_table_named(m, command, &dir.join(&names[2]), Format::C, c_name)?;
    Ok(names.to_vec())
}

/// Writes `summary.json` (the files listed include it).
fn write_summary(dir: &Path, sum: &Summary) -> Result<(), CalibrateError> {
    write_text(
        &dir.join("summary.json"),
        &(serde_json::to_string_pretty(sum)? + "\n"),
    )
}

/// Whether `name` is a file a calibration folder's writer makes (`report.md`, `summary.json`,
/// `model*.json`, `table*.rs`, `table*.h`, PNG figures, `imu.h`, `imu.rs`).
pub fn is_own_file(name: &str) -> bool {
    matches!(name, "report.md" | "summary.json" | "imu.h" | "imu.rs")
        || name.ends_with(".png")
        || (name.starts_with("model") && name.ends_with(".json"))
        || (name.starts_with("table") && (name.ends_with(".rs") || name.ends_with(".h")))
}

/// Prepares `--out` for a calibration: created when missing; an existing folder must be
/// empty, or with `force` the files of an earlier calibration are removed from it and from
/// its subfolders that hold a `summary.json` (the axes of `--every-axis`), so that no old
/// figure stays beside a new report; other files are left and named. Then a file is written
/// and removed, so a read-only folder fails before the work. Returns the files left.
pub fn prepare_out(dir: &Path, force: bool) -> Result<Vec<String>, CalibrateError> {
    prepare_dir(dir)?;
    let io = |message: String| {
        move |source| CalibrateError::OutputDir {
            message,
            source: Some(source),
        }
    };
    let listed = |d: &Path| -> Result<Vec<PathBuf>, CalibrateError> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(d)
            .map_err(io(format!("--out {}: cannot list the folder", d.display())))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .collect();
        v.sort();
        Ok(v)
    };
    let entries = listed(dir)?;
    if !entries.is_empty() && !force {
        return Err(CalibrateError::OutputDir {
            message: format!(
                "--out {} is not empty ({} entries, first `{}`): give a new or empty folder, or \
                 --force to replace an earlier calibration's files there",
                dir.display(),
                entries.len(),
                entries[0].file_name().unwrap_or_default().to_string_lossy()
            ),
            source: None,
        });
    }
    let mut left = Vec::new();
    for e in entries {
        let name = e
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        if e.is_dir() && e.join("summary.json").is_file() {
            for f in listed(&e)? {
                let n = f
                    .file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned();
                if f.is_file() && is_own_file(&n) {
                    std::fs::remove_file(&f)
                        .map_err(io(format!("--force: cannot remove {}", f.display())))?;
                } else {
                    left.push(format!("{name}/{n}"));
                }
            }
        } else if e.is_file() && is_own_file(&name) {
            std::fs::remove_file(&e)
                .map_err(io(format!("--force: cannot remove {}", e.display())))?;
        } else {
            left.push(name);
        }
    }
    let probe = dir.join(".rlg-write-probe");
    std::fs::write(&probe, b"")
        .and_then(|()| std::fs::remove_file(&probe))
        .map_err(io(format!(
            "--out {}: cannot write in the folder",
            dir.display()
        )))?;
    Ok(left)
}

/// Creates `dir` (a clear error when it cannot be a folder); done before the work.
pub fn prepare_dir(dir: &Path) -> Result<(), CalibrateError> {
    if dir.is_file() {
        return Err(CalibrateError::OutputDir {
            message: format!("--out {}: is a file; give a folder", dir.display()),
            source: None,
        });
    }
    std::fs::create_dir_all(dir).map_err(|source| CalibrateError::OutputDir {
        message: format!("--out {}: cannot create the folder", dir.display()),
        source: Some(source),
    })
}

/// Writes the folder of a dynamic calibration; returns the files written.
pub fn write(c: &Calibration, inputs: &Inputs, dir: &Path) -> Result<Vec<PathBuf>, CalibrateError> {
    write_named(c, inputs, dir, &CName::default())
}

/// [`write`] with the C headers' symbols prefixed `c_name` (`table_diagnosed.h`'s with
/// `{c_name}_diagnosed`), so that the headers of several gyros compile into one firmware.
pub fn write_named(
    c: &Calibration,
    inputs: &Inputs,
    dir: &Path,
    c_name: &CName,
) -> Result<Vec<PathBuf>, CalibrateError> {
    prepare_dir(dir)?;
    let mut files = write_tables(dir, &c.board_model, &inputs.command, "", c_name)?;
    if let Some(d) = &c.diagnosed_board {
        let name = CName::new(&format!("{c_name}_diagnosed"))
            .map_err(|e| CalibrateError::Option(e.to_string()))?;
        files.extend(write_tables(
            dir,
            &d.model,
            &inputs.command,
            "_diagnosed",
            &name,
        )?);
    }
    files.extend(figures::figures(c, dir)?);
    write_text(&dir.join("report.md"), &markdown(c, inputs))?;
    files.push("report.md".into());
    files.push("summary.json".into());
    write_summary(dir, &summary(c, inputs, &files))?;
    Ok(files.iter().map(|f| dir.join(f)).collect())
}

/// Writes the folder of a static calibration; returns the files written.
pub fn write_static(
    c: &StaticCalibration,
    inputs: &Inputs,
    dir: &Path,
) -> Result<Vec<PathBuf>, CalibrateError> {
    write_static_named(c, inputs, dir, &CName::default())
}

/// [`write_static`] with the C header's symbols prefixed `c_name`.
pub fn write_static_named(
    c: &StaticCalibration,
    inputs: &Inputs,
    dir: &Path,
    c_name: &CName,
) -> Result<Vec<PathBuf>, CalibrateError> {
    prepare_dir(dir)?;
    let mut files = write_tables(dir, &c.model, &inputs.command, "", c_name)?;
    files.push(figures::static_figure(c, dir)?);
    let md = static_markdown(c, inputs, &static_summary(c, inputs, &files));
    write_text(&dir.join("report.md"), &md)?;
    files.push("report.md".into());
    files.push("summary.json".into());
    write_summary(dir, &static_summary(c, inputs, &files))?;
    Ok(files.iter().map(|f| dir.join(f)).collect())
}
