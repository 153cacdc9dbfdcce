//! Fleet training: every recording in a folder (one per gyro or axis) trained in parallel
//! (rayon, one task per recording), one model file and one board table each.
//!
//! A recording that fails (unreadable, too short, singular) is reported in its row of the
//! summary; it does not stop the others.

use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;

use crate::dataset::{self, RecordingSelection};
use crate::export;
use crate::lssvm::sparse::{train_reduced, Reduction};
use crate::lssvm::Lssvm;
use crate::model::{write_atomic, ModelFile, Provenance};
use rlg_io::recording::Recording;

/// Why a fleet could not be trained at all (per-recording failures are in [`FleetEntry`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FleetError {
    /// The input folder could not be listed or the output folder created.
    #[error("{path}: {source}")]
    Io {
        /// The folder.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// No `*.csv` recording in the folder.
    #[error("no *.csv recording in {0}")]
    Empty(String),
}

/// How each recording is trained.
#[derive(Clone, Debug, PartialEq)]
pub struct FleetOptions {
    /// Kernel width σ, standardised units.
    pub sigma: f64,
    /// Regularisation c.
    pub c: f64,
    /// Block averaging of the training samples (1: raw 1 Hz).
    pub block: usize,
    /// Train on samples up to this time, s (e.g. the end of the first cycle); `None`: all.
    pub to_s: Option<f64>,
    /// dT/dt estimator time constant, s.
    pub rate_tau_s: f64,
    /// `None`: exact LS-SVM (every sample a support vector); otherwise a reduction to at
    /// most the given number of support vectors.
    pub reduction: Option<(Reduction, usize)>,
    /// The command line, recorded in each model's provenance and table header.
    pub command: String,
}

/// One recording's outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct FleetEntry {
    /// The recording's file name.
    pub name: String,
    /// Training samples, or 0 on failure.
    pub samples: usize,
    /// Support vectors, or 0 on failure.
    pub support_vectors: usize,
    /// RMS training residual, °/h (NaN on failure).
    pub train_rms_dph: f64,
    /// Wall time of this recording (read, features, train, write), s.
    pub wall_s: f64,
    /// The model file written.
    pub model: Option<PathBuf>,
    /// The table source written.
    pub table: Option<PathBuf>,
    /// What went wrong, if anything.
    pub error: Option<String>,
}

/// The `*.csv` files directly in `dir`, sorted by name.
pub fn recordings_in(dir: &Path) -> Result<Vec<PathBuf>, FleetError> {
    let io = |source| FleetError::Io {
        path: dir.display().to_string(),
        source,
    };
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).map_err(io)? {
        let p = e.map_err(io)?.path();
        if p.is_file() && p.extension().is_some_and(|x| x == "csv") {
            out.push(p);
        }
    }
    out.sort();
    if out.is_empty() {
        return Err(FleetError::Empty(dir.display().to_string()));
    }
    Ok(out)
}

fn train_one(path: &Path, out_dir: &Path, opts: &FleetOptions) -> anyhow::Result<FleetEntry> {
    let t0 = Instant::now();
    let rec = Recording::read_csv(path)?;
    let sel = RecordingSelection {
        from_s: None,
        to_s: opts.to_s,
        block: opts.block,
        rate_tau_s: opts.rate_tau_s,
    };
    let data = dataset::from_recording(&rec, &sel)?;
    let lssvm = match opts.reduction {
        None => Lssvm::train(&data.features, &data.x, &data.y_dph, opts.sigma, opts.c)?,
        Some((method, budget)) => train_reduced(
            &data.features,
            &data.x,
            &data.y_dph,
            opts.sigma,
            opts.c,
            budget,
            method,
        )?,
    };
    let prov = Provenance::from_file(path, &opts.command)?;
    let model = ModelFile::from_trained(
        lssvm,
        &data.x,
        &data.y_dph,
        opts.rate_tau_s,
        data.dt_s,
        None,
        prov,
    )?;
    let stem = path
        .file_stem()
        .map_or_else(|| "model".into(), |s| s.to_string_lossy().into_owned());
    let model_path = out_dir.join(format!("{stem}.json"));
    let table_path = out_dir.join(format!("{stem}_table.rs"));
    model.write(&model_path)?;
    let src = export::table_source(&model, &opts.command)?;
    write_atomic(&table_path, src.as_bytes())?;
    Ok(FleetEntry {
        name: path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
        samples: model.training.samples,
        support_vectors: model.lssvm.support.len(),
        train_rms_dph: model.training.rms_dph,
        wall_s: t0.elapsed().as_secs_f64(),
        model: Some(model_path),
        table: Some(table_path),
        error: None,
    })
}

/// Trains every recording of `dir` in parallel into `out_dir` (created if missing): for
/// `<stem>.csv`, `<stem>.json` (model) and `<stem>_table.rs` (board table). Returns one entry
/// per recording, in file-name order.
pub fn train_fleet(
    dir: &Path,
    out_dir: &Path,
    opts: &FleetOptions,
) -> Result<Vec<FleetEntry>, FleetError> {
    let files = recordings_in(dir)?;
    std::fs::create_dir_all(out_dir).map_err(|source| FleetError::Io {
        path: out_dir.display().to_string(),
        source,
    })?;
    Ok(files
        .par_iter()
        .map(|p| {
            let t0 = Instant::now();
            train_one(p, out_dir, opts).unwrap_or_else(|e| FleetEntry {
                name: p
                    .file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
                samples: 0,
                support_vectors: 0,
                train_rms_dph: f64::NAN,
                wall_s: t0.elapsed().as_secs_f64(),
                model: None,
                table: None,
                error: Some(format!("{e:#}")),
            })
        })
        .collect())
}

/// The summary table: one line per recording, then the totals.
pub fn summary(entries: &[FleetEntry], wall_s: f64) -> String {
    let mut s = format!(
        "{:<28} {:>8} {:>5} {:>12} {:>8}  {}\n",
        "recording", "samples", "SVs", "train rms", "wall s", "status"
    );
    for e in entries {
        s += &format!(
            "{:<28} {:>8} {:>5} {:>10.3e}°/h {:>8.2}  {}\n",
            e.name,
            e.samples,
            e.support_vectors,
            e.train_rms_dph,
            e.wall_s,
            e.error.as_deref().unwrap_or("ok")
        );
    }
    let ok = entries.iter().filter(|e| e.error.is_none()).count();
    s += &format!(
        "{ok} of {} trained in {wall_s:.2} s wall ({:.0} recordings/hour at this rate)\n",
        entries.len(),
        if wall_s > 0.0 {
            3600.0 * entries.len() as f64 / wall_s
        } else {
            f64::NAN
        }
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write_rec(path: &Path, slope: f64) {
        let n = 4000;
        let rec = Recording {
            time_s: (0..n).map(f64::from).collect(),
            temp_c: (0..n)
                .map(|k| 30.0 + 20.0 * (f64::from(k) / 600.0).sin())
                .collect(),
            rate_dph: (0..n)
                .map(|k| -7.1 + slope * (f64::from(k) / 600.0).sin())
                .collect(),
            ..Recording::default()
        };
        rec.write_csv(path).unwrap();
    }

    /// Each model written is the model trained on its own recording alone (the serial
    /// reference), and a bad file is a row with an error, not a failure of the fleet.
    #[test]
    fn fleet_matches_serial_training_and_isolates_failures() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        for (i, s) in [0.01, -0.02, 0.03].iter().enumerate() {
            write_rec(&dir.path().join(format!("gyro{i}.csv")), *s);
        }
        std::fs::write(dir.path().join("broken.csv"), "time_s,rate_dph\n1,2\n").unwrap();
        let opts = FleetOptions {
            sigma: 1.0,
            c: 100.0,
            block: 10,
            to_s: None,
            rate_tau_s: 60.0,
            reduction: Some((Reduction::FIXED_SIZE, 16)),
            command: "rlg train-fleet".into(),
        };
        let entries = train_fleet(dir.path(), &out, &opts).unwrap();
        assert_eq!(entries.len(), 4);
        assert_eq!(entries[0].name, "broken.csv");
        assert!(entries[0].error.is_some());
        for (i, e) in entries[1..].iter().enumerate() {
            assert!(e.error.is_none(), "{e:?}");
            let m = ModelFile::read(e.model.as_ref().unwrap()).unwrap();
            assert_eq!(m.lssvm.support.len(), 16);
            let rec = Recording::read_csv(&dir.path().join(format!("gyro{i}.csv"))).unwrap();
            let sel = RecordingSelection {
                from_s: None,
                to_s: None,
                block: 10,
                rate_tau_s: 60.0,
            };
            let d = dataset::from_recording(&rec, &sel).unwrap();
            let serial = train_reduced(
                &d.features,
                &d.x,
                &d.y_dph,
                1.0,
                100.0,
                16,
                Reduction::FIXED_SIZE,
            )
            .unwrap();
            assert_eq!(m.lssvm, serial);
            let table = std::fs::read_to_string(e.table.as_ref().unwrap()).unwrap();
            assert!(table.contains("ModelTable<16, 2>"));
        }
        let s = summary(&entries, 1.0);
        assert!(s.contains("3 of 4 trained"), "{s}");
    }

    #[test]
    fn empty_folder_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        assert!(matches!(
            recordings_in(dir.path()),
            Err(FleetError::Empty(_))
        ));
    }
}
