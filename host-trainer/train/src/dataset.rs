//! Training sets: the paper's Table 1 (static test, one feature) and recordings (features
//! from the board's pipeline, see [`crate::features`]).

use std::path::Path;

use compensator_core::Feature;

use crate::features::{self, FeatureError, FeatureRows};
use rlg_io::recording::Recording;

/// Raw training inputs and targets; the rows one vector each, or one block
/// ([`FeatureRows`], for training sets too long to hold as separate vectors).
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset<X = Vec<Vec<f64>>> {
    /// Feature names in column order (`Feature::name` strings).
    pub features: Vec<String>,
    /// One row of raw features per training sample.
    pub x: X,
    /// Target gyro output per sample, °/h.
    pub y_dph: Vec<f64>,
    /// Sample period of the underlying 1 Hz stream, s (the board's dT/dt filter runs at it).
    pub dt_s: f64,
}

/// Why a training set could not be built.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DatasetError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The CSV is malformed.
    #[error("{path}: {message}")]
    Csv {
        /// The file.
        path: String,
        /// What is wrong, with the line where known.
        message: String,
    },
    /// Feature computation failed.
    #[error(transparent)]
    Features(#[from] FeatureError),
    /// Nothing is left to train on after selection.
    #[error("no training samples left: {0}")]
    Empty(String),
}

/// Parses the Table 1 CSV (`#` comments; columns `temp_c` and `rate_dph` by header name,
/// others ignored): one feature, `temp_c`; target `rate_dph`. `path` only labels errors.
pub fn table1_from_csv_text(text: &str, path: &str) -> Result<Dataset, DatasetError> {
    let err = |message: String| DatasetError::Csv {
        path: path.to_string(),
        message,
    };
    let mut rdr = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let headers = rdr.headers().map_err(|e| err(e.to_string()))?.clone();
    let col = |name: &str| {
        headers
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| err(format!("no column {name}")))
    };
    let (ti, ri) = (col("temp_c")?, col("rate_dph")?);
    let mut x = Vec::new();
    let mut y = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| err(e.to_string()))?;
        let line = rec.position().map_or(0, |p| p.line());
        let num = |i: usize, name: &str| -> Result<f64, DatasetError> {
            let s = rec.get(i).unwrap_or("");
            match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(err(format!(
                    "line {line}: {name} = {s:?} is not a finite number"
                ))),
            }
        };
        x.push(vec![num(ti, "temp_c")?]);
        y.push(num(ri, "rate_dph")?);
    }
    if x.is_empty() {
        return Err(DatasetError::Empty(format!("{path} has no data rows")));
    }
    Ok(Dataset {
        features: vec![Feature::TempC.name().to_string()],
        x,
        y_dph: y,
        dt_s: 1.0,
    })
}

/// Reads the Table 1 CSV from a file; see [`table1_from_csv_text`].
pub fn table1_from_csv(path: &Path) -> Result<Dataset, DatasetError> {
    let text = std::fs::read_to_string(path).map_err(|source| DatasetError::Io {
        path: path.display().to_string(),
        source,
    })?;
    table1_from_csv_text(&text, &path.display().to_string())
}

/// Which part of a recording to train on, and how.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordingSelection {
    /// Keep samples with `time_s >= from_s`, s.
    pub from_s: Option<f64>,
    /// Keep samples with `time_s <= to_s`, s.
    pub to_s: Option<f64>,
    /// Average features and targets over consecutive blocks of this many kept samples
    /// (1: no averaging; the paper uses 100).
    pub block: usize,
    /// dT/dt estimator time constant, s.
    pub rate_tau_s: f64,
}

/// Builds the two-feature training set [T, dT/dt] → `rate_dph` from a recording
/// ([`from_recording_with`] with the paper's inputs).
pub fn from_recording(rec: &Recording, sel: &RecordingSelection) -> Result<Dataset, DatasetError> {
    from_recording_with(rec, sel, &[Feature::TempC, Feature::TempRateCPerS])
}

/// [`from_recording`] with the rows in one block.
pub fn from_recording_rows(
    rec: &Recording,
    sel: &RecordingSelection,
) -> Result<Dataset<FeatureRows>, DatasetError> {
    from_recording_rows_with(rec, sel, &[Feature::TempC, Feature::TempRateCPerS])
}

/// Builds the training set `features` → `rate_dph` from a recording.
///
/// The features are computed over the whole recording (so the estimator's state at `from_s`
/// is what the board's would be), then samples flagged as warming up or outside
/// `[from_s, to_s]` are dropped, then blocks are averaged. The sample period is the median
/// step of `time_s`.
pub fn from_recording_with(
    rec: &Recording,
    sel: &RecordingSelection,
    features: &[Feature],
) -> Result<Dataset, DatasetError> {
    let d = from_recording_rows_with(rec, sel, features)?;
    Ok(Dataset {
        x: (0..d.x.len()).map(|k| d.x[k].to_vec()).collect(),
        features: d.features,
        y_dph: d.y_dph,
        dt_s: d.dt_s,
    })
}

/// [`from_recording_with`] with the rows in one block.
pub fn from_recording_rows_with(
    rec: &Recording,
    sel: &RecordingSelection,
    features: &[Feature],
) -> Result<Dataset<FeatureRows>, DatasetError> {
    let n = rec.len();
    if n < 2 || rec.temp_c.len() != n || rec.rate_dph.len() != n {
        return Err(DatasetError::Empty(format!(
            "recording has {n} time stamps, {} temperatures and {} rates (need ≥ 2, equal)",
            rec.temp_c.len(),
            rec.rate_dph.len()
        )));
    }
    let dt_s = {
        let mut steps: Vec<f64> = rec.time_s.windows(2).map(|w| w[1] - w[0]).collect();
        steps.sort_by(f64::total_cmp);
        steps[steps.len() / 2]
    };
    let series = features::compute(features, &rec.temp_c, &rec.time_s, sel.rate_tau_s, dt_s)?;
    let (lo, hi) = (
        sel.from_s.unwrap_or(f64::NEG_INFINITY),
        sel.to_s.unwrap_or(f64::INFINITY),
    );
    let keep: Vec<usize> = (0..n)
        .filter(|&k| !series.warming_up[k] && rec.time_s[k] >= lo && rec.time_s[k] <= hi)
        .collect();
    if keep.is_empty() {
        return Err(DatasetError::Empty(format!(
            "no sample in [{lo}, {hi}] s after the {} s dT/dt warm-up",
            f64::from(series.warming_up.iter().filter(|w| **w).count() as u32) * dt_s
        )));
    }
    // Averaged straight from the series: one vector per kept sample would be most of the
    // memory of a long record.
    let (x, y) = if sel.block > 1 {
        if keep.len() < sel.block {
            return Err(features::FeatureError::Block {
                len: keep.len(),
                block: sel.block,
            }
            .into());
        }
        let dim = series.rows.dim();
        let mut x = FeatureRows::with_capacity(dim, keep.len() / sel.block);
        let mut y = Vec::with_capacity(keep.len() / sel.block);
        for c in keep.chunks_exact(sel.block) {
            let m = c.len() as f64;
            x.push_row((0..dim).map(|d| c.iter().map(|&k| series.rows[k][d]).sum::<f64>() / m));
            y.push(c.iter().map(|&k| rec.rate_dph[k]).sum::<f64>() / m);
        }
        (x, y)
    } else {
        let mut x = FeatureRows::with_capacity(series.rows.dim(), keep.len());
        for &k in &keep {
            x.push_row(series.rows[k].iter().copied());
        }
        (x, keep.iter().map(|&k| rec.rate_dph[k]).collect())
    };
    Ok(Dataset {
        features: series.names(),
        x,
        y_dph: y,
        dt_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table1_parses_by_header_and_skips_comments() {
        let text = "# comment\nchamber_c,temp_c,rate_dph,x\n-40,-34.80,-7.0771,1\n# mid\n60,63.59,-7.1184,2\n";
        let d = table1_from_csv_text(text, "t.csv").unwrap();
        assert_eq!(d.x, vec![vec![-34.80], vec![63.59]]);
        assert_eq!(d.y_dph, vec![-7.0771, -7.1184]);
        assert!(table1_from_csv_text("temp_c\n1\n", "t.csv")
            .unwrap_err()
            .to_string()
            .contains("rate_dph"));
        let bad = table1_from_csv_text("temp_c,rate_dph\n1,abc\n", "t.csv")
            .unwrap_err()
            .to_string();
        assert!(bad.contains("line 2") && bad.contains("abc"), "{bad}");
    }

    #[test]
    fn recording_selection_drops_warm_up_and_window_then_averages() {
        let n = 1000;
        let rec = Recording {
            time_s: (0..n).map(f64::from).collect(),
            rate_dph: (0..n).map(|k| -7.1 + 1e-5 * f64::from(k)).collect(),
            temp_c: (0..n).map(|k| 20.0 + 0.01 * f64::from(k)).collect(),
            ..Recording::default()
        };
        let sel = RecordingSelection {
            from_s: Some(100.0),
            to_s: Some(899.0),
            block: 100,
            rate_tau_s: 60.0,
        };
        let d = from_recording(&rec, &sel).unwrap();
        // Warm-up ends at sample 299 (5τ), so samples 299..=899 remain: 601 → 6 blocks.
        assert_eq!(d.x.len(), 6);
        assert_eq!(d.dt_s, 1.0);
        let want_y: f64 = (299..399).map(|k| -7.1 + 1e-5 * f64::from(k)).sum::<f64>() / 100.0;
        assert!((d.y_dph[0] - want_y).abs() < 1e-12);
        assert!((d.x[5][1] - 0.01).abs() < 1e-4, "ramp rate {}", d.x[5][1]);
    }
}
