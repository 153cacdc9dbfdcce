//! The format's own files: reading them (through the general reader, `read`) and writing
//! them (fixed formats, atomic).

use std::path::Path;

use super::{Recording, RecordingError};

impl Recording {
    /// Reads and validates a recording with the default [`super::ReadOptions`], without the
    /// plausibility checks: a column whose unit the file does not state (header suffix,
    /// units row, column name) is taken in the format's unit and not second-guessed
    /// ([`Recording::read_checked`] and [`super::read_axes`] check it).
    ///
    /// `#` lines anywhere are comments, kept; blank lines are skipped. Every field of a
    /// required or `chamber_c` column must be a finite number (an empty one leaves the sample
    /// out), every row must have as many fields as the header, and `time_s` must be strictly
    /// increasing. Errors name the file, the 1-based line and column. Other separators, a
    /// byte-order mark and decimal commas are detected ([`super::read_axes`]).
    pub fn read_csv(path: &Path) -> Result<Recording, RecordingError> {
        let open = || -> std::io::Result<Box<dyn std::io::BufRead>> {
            Ok(Box::new(std::io::BufReader::with_capacity(
                1 << 16,
                std::fs::File::open(path)?,
            )))
        };
        super::read::parse_unchecked(&open, &path.display().to_string())
    }

    /// Parses recording text as [`Recording::read_csv`] reads a file; `origin` names the
    /// source in error messages.
    pub fn parse_csv(text: &str, origin: &str) -> Result<Recording, RecordingError> {
        let open =
            || -> std::io::Result<Box<dyn std::io::BufRead + '_>> { Ok(Box::new(text.as_bytes())) };
        super::read::parse_unchecked(&open, origin)
    }

    /// Checks that every column has one entry per sample and that extra fields can be
    /// written without quoting; the message says which column is at fault.
    fn check_writable(&self) -> Result<(), String> {
        let n = self.len();
        let mut cols: Vec<(&str, usize)> = vec![
            ("rate_dph", self.rate_dph.len()),
            ("temp_c", self.temp_c.len()),
        ];
        if let Some(c) = &self.chamber_c {
            cols.push(("chamber_c", c.len()));
        }
        for (name, v) in &self.extra {
            cols.push((name, v.len()));
            if name.is_empty() || name.contains([',', '\n', '\r', '"']) || name.starts_with('#') {
                return Err(format!("column name `{name}` cannot be written unquoted"));
            }
            if let Some(f) = v.iter().find(|f| f.contains([',', '\n', '\r', '"'])) {
                return Err(format!(
                    "column `{name}` holds `{f}`, which cannot be written unquoted"
                ));
            }
        }
        if let Some((name, len)) = cols.iter().find(|(_, len)| *len != n) {
            return Err(format!("column `{name}` has {len} entries, time_s has {n}"));
        }
        if let Some(c) = self.comments.iter().find(|c| c.contains(['\n', '\r'])) {
            return Err(format!("comment `{c}` spans lines"));
        }
        Ok(())
    }

    /// Renders the file content: comments, header, rows with fixed formats (time `{:.6}` s,
    /// rate `{:.9}` °/h, temperatures `{:.4}` °C), so the same data give the same bytes on
    /// every machine.
    pub fn to_csv_string(&self) -> Result<String, String> {
        use std::fmt::Write as _;
        self.check_writable()?;
        let mut s = String::with_capacity(64 * (self.len() + 4));
        for c in &self.comments {
            let _ = writeln!(s, "#{c}");
        }
        s.push_str("time_s,rate_dph,temp_c");
        if self.chamber_c.is_some() {
            s.push_str(",chamber_c");
        }
        for (name, _) in &self.extra {
            let _ = write!(s, ",{name}");
        }
        s.push('\n');
        for i in 0..self.len() {
            let _ = write!(
                s,
                "{:.6},{:.9},{:.4}",
                self.time_s[i], self.rate_dph[i], self.temp_c[i]
            );
            if let Some(c) = &self.chamber_c {
                let _ = write!(s, ",{:.4}", c[i]);
            }
            for (_, v) in &self.extra {
                let _ = write!(s, ",{}", v[i]);
            }
            s.push('\n');
        }
        Ok(s)
    }

    /// Writes the recording (comments first, then header and rows) atomically: to a temporary
    /// file beside `path`, then renamed over it.
    pub fn write_csv(&self, path: &Path) -> Result<(), RecordingError> {
        let text = self
            .to_csv_string()
            .map_err(|message| RecordingError::Format {
                path: path.display().to_string(),
                line: 0,
                column: 0,
                message,
            })?;
        write_atomic(path, text.as_bytes())
    }
}

/// Writes `bytes` to `path` atomically ([`crate::atomic::write`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), RecordingError> {
    crate::atomic::write(path, bytes).map_err(|source| RecordingError::Io {
        path: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Recording, RecordingError> {
        Recording::parse_csv(text, "x.csv")
    }

    /// The error's (line, column) and that its message contains `needle`.
    fn fails_at(text: &str, line: usize, column: usize, needle: &str) {
        match parse(text) {
            Err(RecordingError::Format {
                path,
                line: l,
                column: c,
                message,
            }) => {
                assert_eq!(path, "x.csv");
                assert_eq!((l, c), (line, column), "{message}");
                assert!(message.contains(needle), "`{message}` lacks `{needle}`");
            }
            other => panic!("expected a format error, got {other:?}"),
        }
    }

    #[test]
    fn reads_columns_in_any_order_with_comments_and_extras() {
        let text = "# made by hand\nrate_dph,note,temp_c,time_s,chamber_c\n-7.1,a,20.5,0,15\n# mid\n-7.2,b,20.6,1.5,15.1\n";
        let r = parse(text).unwrap();
        assert_eq!(r.time_s, vec![0.0, 1.5]);
        assert_eq!(r.rate_dph, vec![-7.1, -7.2]);
        assert_eq!(r.temp_c, vec![20.5, 20.6]);
        assert_eq!(r.chamber_c, Some(vec![15.0, 15.1]));
        assert_eq!(
            r.extra,
            vec![("note".to_string(), vec!["a".to_string(), "b".to_string()])]
        );
        assert_eq!(
            r.comments,
            vec![" made by hand".to_string(), " mid".to_string()]
        );
    }

    #[test]
    fn rejects_missing_required_column() {
        fails_at("time_s,rate_dph\n0,1\n", 1, 0, "temp_c");
    }

    #[test]
    fn rejects_non_numeric_field() {
        fails_at(
            "time_s,rate_dph,temp_c\n0,1,2\n1,abc,2\n",
            3,
            2,
            "expected a number",
        );
    }

    #[test]
    fn rejects_nan_and_inf() {
        fails_at("time_s,rate_dph,temp_c\n0,1,NaN\n", 2, 3, "finite");
        fails_at("temp_c,time_s,rate_dph\n0,1,inf\n", 2, 3, "finite");
    }

    #[test]
    fn rejects_empty_file_and_header_only() {
        fails_at("", 1, 0, "empty file");
        fails_at("# only a comment\n\n", 2, 0, "empty file");
        fails_at("time_s,rate_dph,temp_c\n", 1, 0, "no data rows");
    }

    #[test]
    fn rejects_duplicate_and_decreasing_times() {
        fails_at(
            "time_s,rate_dph,temp_c\n0,1,2\n1,1,2\n1,1,2\n",
            4,
            1,
            "strictly increasing",
        );
        fails_at(
            "rate_dph,time_s,temp_c\n1,5,2\n1,4,2\n",
            3,
            2,
            "does not increase",
        );
    }

    #[test]
    fn rejects_ragged_rows() {
        fails_at(
            "time_s,rate_dph,temp_c\n0,1,2\n1,1\n",
            3,
            0,
            "2 fields, expected 3",
        );
        fails_at("time_s,rate_dph,temp_c\n0,1,2,3\n", 2, 0, "4 fields");
    }

    #[test]
    fn rejects_duplicate_header_names() {
        fails_at(
            "time_s,rate_dph,temp_c,time_s\n0,1,2,3\n",
            1,
            4,
            "duplicate",
        );
    }

    #[test]
    fn io_error_names_the_file() {
        let e = Recording::read_csv(Path::new("does/not/exist.csv")).unwrap_err();
        assert!(matches!(e, RecordingError::Io { .. }));
        assert!(e.to_string().contains("does/not/exist.csv"));
    }

    /// Write → read gives the data back to the written precision, and writing the read-back
    /// recording gives the very same bytes (the format is a fixed point of read ∘ write).
    #[test]
    fn round_trip_is_exact_to_format_and_bytes_are_stable() {
        let n = 50;
        let rec = Recording {
            time_s: (0..n).map(|i| i as f64 * 1.000_001).collect(),
            rate_dph: (0..n)
                .map(|i| -7.1 + 1e-7 * i as f64 + (i as f64).sin() * 1e-3)
                .collect(),
            temp_c: (0..n).map(|i| 20.0 + 0.01 * i as f64).collect(),
            chamber_c: Some((0..n).map(|i| 15.0 - 0.02 * i as f64).collect()),
            extra: vec![(
                "phase".into(),
                (0..n).map(|i| format!("p{}", i % 3)).collect(),
            )],
            comments: vec![" seed = 1".into()],
        };
        let dir = std::env::temp_dir().join(format!("rlg-rec-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("r.csv");
        rec.write_csv(&p).unwrap();
        let back = Recording::read_csv(&p).unwrap();
        for i in 0..n {
            assert!((back.time_s[i] - rec.time_s[i]).abs() <= 5e-7);
            assert!((back.rate_dph[i] - rec.rate_dph[i]).abs() <= 5e-10);
            assert!((back.temp_c[i] - rec.temp_c[i]).abs() <= 5e-5);
        }
        assert_eq!(back.extra, rec.extra);
        assert_eq!(back.comments, rec.comments);
        let first = std::fs::read(&p).unwrap();
        back.write_csv(&p).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), first);
        // No temporary file is left behind.
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn writer_rejects_inconsistent_columns() {
        let rec = Recording {
            time_s: vec![0.0, 1.0],
            rate_dph: vec![1.0],
            temp_c: vec![1.0, 2.0],
            ..Default::default()
        };
        let e = rec.to_csv_string().unwrap_err();
        assert!(e.contains("rate_dph"), "{e}");
    }
}

#[cfg(test)]
mod fuzz {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Any text, however malformed, gives a recording or an error — never a panic — and
        /// an accepted recording satisfies the format's invariants.
        #[test]
        fn parse_never_panics(text in "(time_s,rate_dph,temp_c\n)?(time_s|rate_dph|temp_c|chamber_c|x|#|,|-?[0-9.e]{0,5}|NaN|\n){0,40}") {
            if let Ok(r) = Recording::parse_csv(&text, "fuzz.csv") {
                prop_assert!(!r.is_empty());
                prop_assert!(r.time_s.windows(2).all(|w| w[0] < w[1]));
                prop_assert!(r.rate_dph.iter().chain(&r.temp_c).all(|v| v.is_finite()));
            }
        }
    }
}
