//! The file format: reading (line by line, every field checked, errors with line and
//! column) and writing (fixed formats, atomic).

use std::path::Path;

use super::{Recording, RecordingError};

impl Recording {
    /// Reads and validates a recording.
    ///
    /// Fields are plain (no quoting): a field may not hold a comma. Blank lines are skipped;
    /// `#` lines anywhere are comments. Every field of a required or `chamber_c` column must
    /// be a finite number, every row must have as many fields as the header, and `time_s`
    /// must be strictly increasing. Errors name the file, the 1-based line and column.
    pub fn read_csv(path: &Path) -> Result<Recording, RecordingError> {
        use std::io::BufRead;
        // Read line by line, twice (once to count the rows, once to parse them): the whole
        // text in memory would double the peak of a long record (440 MB of text for 10⁷
        // samples beside their 240 MB of columns).
        let io = |source| RecordingError::Io {
            path: path.display().to_string(),
            source,
        };
        let lines = || -> Result<_, RecordingError> {
            let f = std::fs::File::open(path).map_err(io)?;
            Ok(std::io::BufReader::new(f)
                .lines()
                .map(move |l| l.map_err(io)))
        };
        let (mut content, mut total) = (0usize, 0usize);
        for l in lines()? {
            let l = l?;
            total += 1;
            if is_content(&l) {
                content += 1;
            }
        }
        Self::parse_lines(lines()?, content, total, &path.display().to_string())
    }

    /// Parses recording text; `origin` names the source in error messages.
    pub fn parse_csv(text: &str, origin: &str) -> Result<Recording, RecordingError> {
        let content = text.lines().filter(|l| is_content(l)).count();
        Self::parse_lines(
            text.lines().map(|l| Ok(l.to_string())),
            content,
            text.lines().count(),
            origin,
        )
    }

    /// Parses the lines of a recording (`content_lines` of them neither comments nor blank,
    /// `total_lines` in all); `origin` names the source in error messages.
    fn parse_lines(
        lines: impl Iterator<Item = Result<String, RecordingError>>,
        content_lines: usize,
        total_lines: usize,
        origin: &str,
    ) -> Result<Recording, RecordingError> {
        let err = |line: usize, column: usize, message: String| RecordingError::Format {
            path: origin.to_string(),
            line,
            column,
            message,
        };
        let mut rec = Recording::default();
        let mut header: Option<Vec<String>> = None;
        // Column index of each interpreted column; extras get the rest.
        let (mut i_time, mut i_rate, mut i_temp, mut i_chamber) = (0, 0, 0, None);
        let mut extra_idx: Vec<usize> = Vec::new();
        let mut chamber = Vec::new();
        let mut last_time: Option<(f64, usize)> = None;
        for (k, raw) in lines.enumerate() {
            let raw = raw?;
            let line_no = k + 1;
            let line = raw.trim_end_matches('\r');
            if let Some(c) = line.strip_prefix('#') {
                rec.comments.push(c.to_string());
                continue;
            }
            if line.trim().is_empty() {
                continue;
            }
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            let Some(names) = &header else {
                let names: Vec<String> = fields.iter().map(|s| s.to_string()).collect();
                let find = |want: &str| names.iter().position(|n| n == want);
                for (j, n) in names.iter().enumerate() {
                    if n.is_empty() {
                        return Err(err(line_no, j + 1, "empty column name in header".into()));
                    }
                    if names[..j].contains(n) {
                        return Err(err(line_no, j + 1, format!("duplicate column `{n}`")));
                    }
                }
                for want in ["time_s", "rate_dph", "temp_c"] {
                    if find(want).is_none() {
                        return Err(err(
                            line_no,
                            0,
                            format!("missing required column `{want}` in header `{line}`"),
                        ));
                    }
                }
                i_time = find("time_s").unwrap_or(0);
                i_rate = find("rate_dph").unwrap_or(0);
                i_temp = find("temp_c").unwrap_or(0);
                i_chamber = find("chamber_c");
                for (j, n) in names.iter().enumerate() {
                    if ![Some(i_time), Some(i_rate), Some(i_temp), i_chamber].contains(&Some(j)) {
                        extra_idx.push(j);
                        rec.extra.push((n.clone(), Vec::new()));
                    }
                }
                // Reserving for every row spares the columns the doubling growth, which can
                // leave each with up to twice the memory it needs (~540 MB instead of 320 MB
                // for 10⁷ samples of four columns).
                let rows = content_lines.saturating_sub(1);
                for col in [&mut rec.time_s, &mut rec.rate_dph, &mut rec.temp_c] {
                    col.reserve_exact(rows);
                }
                if i_chamber.is_some() {
                    chamber.reserve_exact(rows);
                }
                for (_, col) in &mut rec.extra {
                    col.reserve_exact(rows);
                }
                header = Some(names);
                continue;
            };
            if fields.len() != names.len() {
                return Err(err(
                    line_no,
                    0,
                    format!(
                        "row has {} fields, expected {} as in the header",
                        fields.len(),
                        names.len()
                    ),
                ));
            }
            let num = |j: usize| -> Result<f64, RecordingError> {
                let f = fields[j];
                match f.parse::<f64>() {
                    Ok(v) if v.is_finite() => Ok(v),
                    Ok(_) => Err(err(
                        line_no,
                        j + 1,
                        format!("`{}` is `{f}`, expected a finite number", names[j]),
                    )),
                    Err(_) => Err(err(
                        line_no,
                        j + 1,
                        format!("`{}` is `{f}`, expected a number", names[j]),
                    )),
                }
            };
            let t = num(i_time)?;
            if let Some((prev, prev_line)) = last_time {
                if t <= prev {
                    return Err(err(
                        line_no,
                        i_time + 1,
                        format!(
                            "time_s {t} does not increase (line {prev_line} has {prev}); expected strictly increasing times"
                        ),
                    ));
                }
            }
            last_time = Some((t, line_no));
            rec.time_s.push(t);
            rec.rate_dph.push(num(i_rate)?);
            rec.temp_c.push(num(i_temp)?);
            if let Some(j) = i_chamber {
                chamber.push(num(j)?);
            }
            for (slot, &j) in rec.extra.iter_mut().zip(&extra_idx) {
                slot.1.push(fields[j].to_string());
            }
        }
        if header.is_none() {
            return Err(err(
                total_lines.max(1),
                0,
                "empty file: expected a header row".into(),
            ));
        }
        if rec.is_empty() {
            return Err(err(
                total_lines.max(1),
                0,
                "no data rows after the header".into(),
            ));
        }
        if i_chamber.is_some() {
            rec.chamber_c = Some(chamber);
        }
        Ok(rec)
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

/// A line of a recording that is neither a comment (`#`) nor blank: the header or a row.
fn is_content(line: &str) -> bool {
    !line.starts_with('#') && !line.trim().is_empty()
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
