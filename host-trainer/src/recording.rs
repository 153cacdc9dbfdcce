//! The recording format shared by every command that reads or writes gyro data.
//!
//! CSV with a header row; lines starting with `#` are comments (provenance). Required columns:
//! `time_s` (s, strictly increasing, not necessarily uniform), `rate_dph` (gyro output, °/h),
//! `temp_c` (gyro temperature sensor, °C). Optional: `chamber_c` (chamber air, °C). Column
//! order is free; unknown columns are kept and written back unchanged.

use std::path::Path;

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
}

impl Recording {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// Reads and validates a recording.
    pub fn read_csv(path: &Path) -> Result<Recording, RecordingError> {
        let _ = path;
        unimplemented!("owned by the simulator work")
    }

    /// Writes the recording (comments first, then header and rows) atomically: to a temporary
    /// file beside `path`, then renamed over it.
    pub fn write_csv(&self, path: &Path) -> Result<(), RecordingError> {
        let _ = path;
        unimplemented!("owned by the simulator work")
    }
}
