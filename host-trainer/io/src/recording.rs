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

    /// Columns whose values look like another unit than the file format's (seconds, °C,
    /// °/h), each with the reason and the flag that converts it; empty when all is plausible.
    /// A temperature column whose median is above 150 looks like Kelvin; a rate whose values
    /// all stay within ±1e-3 looks like rad/s (an RLG's bias and the Earth rate are several
    /// °/h, i.e. 1e-5 … 1e-4 rad/s, and the 1 s noise alone exceeds 1e-3 °/h); a median time
    /// step above 100 s looks like milliseconds (1 Hz in ms steps by 1000) when the record would
    /// then span over 20 days or its stamps are whole multiples of 10 as a millisecond clock
    /// writes them (burst or plateau means minutes apart, with their fractional mean times, are
    /// seconds); one below 10 µs looks like another unit. A column whose unit the user gave is not second-guessed: the
    /// caller skips it (`checked`).
    pub fn unit_errors(&self, checked: UnitsGiven) -> Vec<String> {
        let mut out = Vec::new();
        let median = |v: &[f64]| {
            let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
            s.sort_by(f64::total_cmp);
            s.get(s.len() / 2).copied()
        };
        if !checked.temp {
            for (name, col) in [
                ("temp_c", Some(&self.temp_c)),
                ("chamber_c", self.chamber_c.as_ref()),
            ] {
                if let Some(m) = col.and_then(|c| median(c)).filter(|m| *m > 150.0) {
                    out.push(format!(
                        "{name}: median {m:.2} looks like kelvin, not °C: convert with \
                         --temp-unit k (or --temp-unit c if the values are right)"
                    ));
                }
            }
        }
        let peak = self
            .rate_dph
            .iter()
            .filter(|v| v.is_finite())
            .fold(0.0f64, |a, v| a.max(v.abs()));
        if !checked.rate && !self.rate_dph.is_empty() && peak < 1e-3 {
            out.push(format!(
                "rate_dph: every value within ±{peak:.1e}, which looks like rad/s, not °/h: \
                 convert with --rate-unit rad-s (or --rate-unit dph if the values are right)"
            ));
        }
        let steps: Vec<f64> = self.time_s.windows(2).map(|w| w[1] - w[0]).collect();
        if let (false, Some(step)) = (checked.time, median(&steps)) {
            let span = self.time_s.last().unwrap_or(&0.0) - self.time_s.first().unwrap_or(&0.0);
            let whole = self.time_s.iter().all(|t| t.fract() == 0.0);
            if step > 100.0 && (span > 20.0 * 86_400.0 || (whole && step % 10.0 == 0.0)) {
                out.push(format!(
                    "time_s: median step {step} looks like milliseconds, not seconds: convert \
                     with --time-unit ms (or --time-unit s if the steps are right)"
                ));
            } else if step < 1e-5 {
                out.push(format!(
                    "time_s: median step {step} s is below 10 µs: convert with --time-unit \
                     ms|us, or give --time-unit s if the steps are right"
                ));
            }
        }
        out
    }

    /// Converts the columns from the units `u` the file was written in to seconds, °C and
    /// °/h.
    pub fn convert_units(&mut self, u: Units) {
        let scale = |v: &mut Vec<f64>, k: f64, add: f64| {
            if k != 1.0 || add != 0.0 {
                v.iter_mut().for_each(|x| *x = *x * k + add);
            }
        };
        scale(&mut self.time_s, u.time.to_seconds(), 0.0);
        let (k, add) = u.temp.to_celsius();
        scale(&mut self.temp_c, k, add);
        if let Some(c) = self.chamber_c.as_mut() {
            scale(c, k, add);
        }
        scale(&mut self.rate_dph, u.rate.to_dph(), 0.0);
    }

    /// Warnings that do not stop a command: gaps (steps over 1.5 × the median). Empty when
    /// there are none.
    pub fn unit_warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        let mut steps: Vec<f64> = self.time_s.windows(2).map(|w| w[1] - w[0]).collect();
        let all = steps.clone();
        steps.sort_by(f64::total_cmp);
        if let Some(&step) = steps.get(steps.len() / 2) {
            let gaps = all.iter().filter(|s| **s > 1.5 * step).count();
            if gaps > 0 {
                out.push(format!(
                    "time_s: {gaps} gap(s) longer than 1.5 sample periods; features bridge them as the board bridges missing samples; held-out 100 s stabilities never average across a gap (metrics::gapless_block_means); the diagnosis averages consecutive samples, or each burst of a record sampled in bursts"
                ));
            }
        }
        out
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

/// Which columns' units the user stated (those are not second-guessed by
/// [`Recording::unit_errors`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UnitsGiven {
    /// The time unit was given.
    pub time: bool,
    /// The temperature unit was given.
    pub temp: bool,
    /// The rate unit was given.
    pub rate: bool,
}

/// The units a recording's columns were written in ([`Recording::convert_units`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Units {
    /// Time column.
    pub time: TimeUnit,
    /// Temperature columns.
    pub temp: TempUnit,
    /// Rate column.
    pub rate: RateUnit,
}

/// Unit of the time column.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TimeUnit {
    /// Seconds (the format's).
    #[default]
    S,
    /// Milliseconds.
    Ms,
    /// Microseconds.
    Us,
}

impl TimeUnit {
    fn to_seconds(self) -> f64 {
        match self {
            TimeUnit::S => 1.0,
            TimeUnit::Ms => 1e-3,
            TimeUnit::Us => 1e-6,
        }
    }
}

/// Unit of the temperature columns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TempUnit {
    /// Degrees Celsius (the format's).
    #[default]
    C,
    /// Kelvin.
    K,
}

impl TempUnit {
    /// (factor, offset) to °C.
    fn to_celsius(self) -> (f64, f64) {
        match self {
            TempUnit::C => (1.0, 0.0),
            TempUnit::K => (1.0, -273.15),
        }
    }
}

/// Unit of the rate column.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RateUnit {
    /// Degrees per hour (the format's).
    #[default]
    Dph,
    /// Radians per second.
    RadS,
    /// Degrees per second.
    DegS,
}

impl RateUnit {
    fn to_dph(self) -> f64 {
        match self {
            RateUnit::Dph => 1.0,
            // rad/s → °/h: × 180/π × 3600.
            RateUnit::RadS => 3600.0 * 180.0 / std::f64::consts::PI,
            RateUnit::DegS => 3600.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Kelvin temperatures, a rate in rad/s and millisecond time stamps are each refused
    /// with the flag that converts them; converted, the same recording passes; a unit the
    /// user gave is not second-guessed; a gap is a warning. Plausible data give nothing.
    #[test]
    fn burst_means_minutes_apart_are_seconds() {
        // One mean per burst of 250 samples at 50 Hz every 300 s: mean times 2.49 s into each
        // burst, over 8 h. A millisecond clock would write whole numbers.
        let t: Vec<f64> = (0..96).map(|k| 300.0 * f64::from(k) + 2.49).collect();
        let rec = Recording {
            rate_dph: vec![-7000.0; t.len()],
            temp_c: vec![20.0; t.len()],
            time_s: t,
            ..Recording::default()
        };
        assert!(rec.unit_errors(UnitsGiven::default()).is_empty());
        let ms = Recording {
            time_s: rec.time_s.iter().map(|t| (t * 1000.0).round()).collect(),
            ..rec.clone()
        };
        assert_eq!(ms.unit_errors(UnitsGiven::default()).len(), 1);
    }

    #[test]
    fn implausible_units_are_refused_with_the_flag() {
        let ok = Recording {
            time_s: vec![0.0, 1.0, 2.0, 3.0],
            rate_dph: vec![-7.1, -7.11, -7.09, -7.1],
            temp_c: vec![25.0, 25.1, 25.2, 25.3],
            ..Recording::default()
        };
        assert!(ok.unit_errors(UnitsGiven::default()).is_empty());
        assert!(ok.unit_warnings().is_empty(), "{:?}", ok.unit_warnings());
        let mut bad = Recording {
            time_s: vec![0.0, 1000.0, 2000.0, 5000.0],
            rate_dph: vec![-3.4e-5, -3.5e-5, -3.4e-5, -3.3e-5],
            temp_c: vec![298.15, 298.25, 298.35, 298.45],
            ..Recording::default()
        };
        let e = bad.unit_errors(UnitsGiven::default()).join("\n");
        for want in [
            "temp_c: median 298",
            "--temp-unit k",
            "rad/s",
            "--rate-unit rad-s",
            "milliseconds",
            "--time-unit ms",
        ] {
            assert!(e.contains(want), "{want} missing in:\n{e}");
        }
        let given = UnitsGiven {
            time: true,
            temp: true,
            rate: true,
        };
        assert!(bad.unit_errors(given).is_empty());
        bad.convert_units(Units {
            time: TimeUnit::Ms,
            temp: TempUnit::K,
            rate: RateUnit::RadS,
        });
        assert!(bad.unit_errors(UnitsGiven::default()).is_empty());
        assert_eq!(bad.time_s, vec![0.0, 1.0, 2.0, 5.0]);
        assert!((bad.temp_c[0] - 25.0).abs() < 1e-9, "{:?}", bad.temp_c);
        assert!((bad.rate_dph[0] + 7.013).abs() < 1e-3, "{:?}", bad.rate_dph);
        assert!(bad.unit_warnings().join("").contains("1 gap"));
    }

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
    fn head_keeps_every_column_of_the_first_samples() {
        let text = "# kept\nrate_dph,note,temp_c,time_s,chamber_c\n-7.1,a,20.5,0,15\n-7.2,b,20.6,1,15.1\n-7.3,c,20.7,2,15.2\n";
        let r = parse(text).unwrap();
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
