//! The recording format shared by every command that reads or writes gyro data.
//!
//! CSV with a header row; lines starting with `#` are comments (provenance). Required columns:
//! `time_s` (s, strictly increasing, not necessarily uniform), `rate_dph` (gyro output, °/h),
//! `temp_c` (gyro temperature sensor, °C). Optional: `chamber_c` (chamber air, °C). Column
//! order is free; unknown columns are kept and written back unchanged.
//!
//! The reader also takes what rigs and loggers write ([`read_axes`]): other separators,
//! decimal commas, a byte-order mark, units rows and header units, columns named by flag, and
//! several gyro axes in one file.

mod csv;
mod plausible;
mod read;
mod units;

pub use csv::write_atomic;
pub use read::{parse_axes, read_axes, Axes, Axis, ColumnRef, Delimiter, ReadOptions};
pub use units::{RateUnit, TempUnit, TimeUnit, UnitChoice, UnitName, Units, UnitsGiven};

/// One recording, column-major.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recording {
    /// Sample times, s, strictly increasing.
    pub time_s: Vec<f64>,
    /// Gyro output, °/h.
    pub rate_dph: Vec<f64>,
    /// Gyro temperature sensor, °C.
    pub temp_c: Vec<f64>,
    /// Chamber air temperature, °C, when recorded.
    pub chamber_c: Option<Vec<f64>>,
    /// Columns this crate does not interpret: (header, raw field per row).
    pub extra: Vec<(String, Vec<String>)>,
    /// Comment lines without the leading `#` (provenance), in file order.
    pub comments: Vec<String>,
}

/// Why a recording could not be read or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordingError {
    /// The file could not be opened, read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The content is malformed; `line` and `column` are 1-based (column 0: whole line).
    #[error("{path}:{line}:{column}: {message}")]
    Format {
        /// The file.
        path: String,
        /// 1-based line number in the file, comments included.
        line: usize,
        /// 1-based column (field) number, 0 when the whole line or file is at fault.
        column: usize,
        /// What was found and what was expected.
        message: String,
    },
    /// The options contradict each other or the file (decimal commas in a comma-separated
    /// file, two temperature columns for three rate columns, one column in two roles); the
    /// message names the flags.
    #[error("{path}: {message}")]
    Options {
        /// The file.
        path: String,
        /// What contradicts what, and the flags that fix it.
        message: String,
    },
    /// Columns whose values look like another unit than the one they are read in; each
    /// problem names the column and the flag that converts it.
    #[error("{path}: {}", .problems.join("; "))]
    Units {
        /// The file.
        path: String,
        /// One line per implausible column.
        problems: Vec<String>,
    },
}

/// A recording lent (`&rec`) or handed over (`rec`) to a consumer that takes
/// `impl Into<Cow<Recording>>`: handed over, its series are reused instead of copied.
impl<'a> From<&'a Recording> for std::borrow::Cow<'a, Recording> {
    fn from(r: &'a Recording) -> Self {
        std::borrow::Cow::Borrowed(r)
    }
}

impl From<Recording> for std::borrow::Cow<'_, Recording> {
    fn from(r: Recording) -> Self {
        std::borrow::Cow::Owned(r)
    }
}

impl Recording {
    /// Reads a recording with the format's columns (`time_s`, `rate_dph`, `temp_c`) in the
    /// units chosen, refusing implausible ones (every reason and the flag that converts it in
    /// one error): [`read_axes`] with those units. Returns the recording and the warnings that
    /// do not stop a command ([`Recording::unit_warnings`]), for the caller to show.
    pub fn read_checked(
        path: &std::path::Path,
        units: &UnitChoice,
    ) -> Result<(Recording, Vec<String>), RecordingError> {
        let opts = ReadOptions {
            units: *units,
            ..ReadOptions::default()
        };
        let axes = read_axes(path, &opts)?;
        // The default options read one rate column.
        let rec = axes.axes.into_iter().next().map(|a| a.recording);
        Ok((rec.unwrap_or_default(), axes.warnings))
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// The first `n` samples (all of them when `n` ≥ the length), every column and the
    /// comments kept: e.g. the training part of a calibration run.
    pub fn head(&self, n: usize) -> Recording {
        let n = n.min(self.len());
        Recording {
            time_s: self.time_s[..n].to_vec(),
            rate_dph: self.rate_dph[..n].to_vec(),
            temp_c: self.temp_c[..n].to_vec(),
            chamber_c: self.chamber_c.as_ref().map(|c| c[..n].to_vec()),
            extra: self
                .extra
                .iter()
                .map(|(h, v)| (h.clone(), v[..n.min(v.len())].to_vec()))
                .collect(),
            comments: self.comments.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn head_keeps_every_column_of_the_first_samples() {
        let text = "# kept\nrate_dph,note,temp_c,time_s,chamber_c\n-7.1,a,20.5,0,15\n-7.2,b,20.6,1,15.1\n-7.3,c,20.7,2,15.2\n";
        let r = Recording::parse_csv(text, "x.csv").unwrap();
        let h = r.head(2);
        assert_eq!(h.time_s, vec![0.0, 1.0]);
        assert_eq!(h.rate_dph, vec![-7.1, -7.2]);
        assert_eq!(h.temp_c, vec![20.5, 20.6]);
        assert_eq!(h.chamber_c, Some(vec![15.0, 15.1]));
        assert_eq!(
            h.extra,
            vec![("note".to_string(), vec!["a".to_string(), "b".to_string()])]
        );
        assert_eq!(h.comments, r.comments);
        assert_eq!(r.head(99), r);
        assert!(r.head(0).is_empty());
    }
}
