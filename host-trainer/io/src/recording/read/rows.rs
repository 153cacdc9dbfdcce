//! The second pass: the header, the units row and every row, split by the csv crate
//! (separator, quoting, trimming, comments) or, for runs of whitespace, by
//! [`Source::Words`]; every field of a column read is checked and converted to the format's
//! units as it is read, so the columns are the only thing that grows.

use std::io::BufRead;

use csv::ByteRecord;

use super::super::units::UnitName;
use super::super::{Recording, RecordingError};
use super::columns::{self, Column, Plan};
use super::options::{Delimiter, ReadOptions};
use super::scan::{is_blank, LineNumbers, Scan, BOM};
use super::sniff::{is_decimal_comma_number, is_unit, Format};
use super::stamp::Stamp;

/// Where the rows come from.
enum Source<'a> {
    /// The csv crate's reader.
    Csv(csv::Reader<Box<dyn BufRead + 'a>>),
    /// Lines split at runs of whitespace. The csv crate takes one separator byte and would
    /// make every further space of an aligned table an empty field; this split is all it
    /// takes, and the only parsing done here (no quoting in such files).
    Words {
        input: Box<dyn BufRead + 'a>,
        line: Vec<u8>,
    },
}

impl<'a> Source<'a> {
    fn new(input: Box<dyn BufRead + 'a>, d: Delimiter) -> Source<'a> {
        match d.byte() {
            Some(b) => Source::Csv(
                csv::ReaderBuilder::new()
                    .delimiter(b)
                    .has_headers(false)
                    .flexible(true)
                    .trim(csv::Trim::All)
                    .comment(Some(b'#'))
                    .from_reader(input),
            ),
            None => Source::Words {
                input,
                line: Vec::new(),
            },
        }
    }

    /// The next row that is not blank, into `rec`; false at the end. Comment and blank lines
    /// are passed over exactly as the first pass counted them ([`Scan::skipped`]).
    fn next(&mut self, rec: &mut ByteRecord) -> std::io::Result<bool> {
        match self {
            Source::Csv(r) => loop {
                if !r.read_byte_record(rec).map_err(std::io::Error::from)? {
                    return Ok(false);
                }
                if !rec.iter().all(is_blank) {
                    return Ok(true);
                }
            },
            Source::Words { input, line } => loop {
                line.clear();
                if input.read_until(b'\n', line)? == 0 {
                    return Ok(false);
                }
                let l = line.strip_suffix(b"\n").unwrap_or(line);
                let l = l.strip_suffix(b"\r").unwrap_or(l);
                if l.starts_with(b"#") || is_blank(l) {
                    continue;
                }
                rec.clear();
                for w in l.split(u8::is_ascii_whitespace).filter(|w| !w.is_empty()) {
                    rec.push_field(w);
                }
                return Ok(true);
            },
        }
    }
}

/// The fields of a record as text.
fn strings(rec: &ByteRecord, line: usize, origin: &str) -> Result<Vec<String>, RecordingError> {
    (0..rec.len())
        .map(|i| text(rec, i, line, origin).map(str::to_string))
        .collect()
}

/// Field `i` of a record as text.
fn text<'r>(
    rec: &'r ByteRecord,
    i: usize,
    line: usize,
    origin: &str,
) -> Result<&'r str, RecordingError> {
    std::str::from_utf8(rec.get(i).unwrap_or_default()).map_err(|_| RecordingError::Format {
        path: origin.to_string(),
        line,
        column: i + 1,
        message: "not UTF-8 text: save the file as UTF-8".into(),
    })
}

/// A column read as numbers: where, its name, and the conversion `x · k + add` to the
/// format's unit.
struct Numeric {
    index: usize,
    name: String,
    k: f64,
    add: f64,
}

impl Numeric {
    fn rate(c: &Column<super::super::RateUnit>) -> Numeric {
        Numeric {
            index: c.index,
            name: c.name.clone(),
            k: c.unit.to_dph(),
            add: 0.0,
        }
    }

    fn temp(c: &Column<super::super::TempUnit>) -> Numeric {
        let (k, add) = c.unit.to_celsius();
        Numeric {
            index: c.index,
            name: c.name.clone(),
            k,
            add,
        }
    }
}

/// The time column's state across rows.
struct Clock {
    index: usize,
    name: String,
    /// Keep the values as written (the format's `time_s`); else subtract the first stamp.
    keeps: bool,
    per_second: f64,
    unit: &'static str,
    /// The first stamp and its line, once read.
    origin: Option<(Stamp, usize, String)>,
    /// The previous time (file units, after the origin), its line and its field.
    last: Option<(f64, usize)>,
    last_field: String,
}

/// What every field parse needs to explain a failure.
struct Row<'r> {
    rec: &'r ByteRecord,
    line: usize,
    /// The first row after the header (a units row not recognised would be here).
    first: bool,
    format: &'r Format,
    origin: &'r str,
    /// Reused for decimal commas.
    scratch: String,
}

impl Row<'_> {
    fn err(&self, column: usize, message: String) -> RecordingError {
        RecordingError::Format {
            path: self.origin.to_string(),
            line: self.line,
            column,
            message,
        }
    }

    /// Field `i` with a decimal comma made a point; `Ok(None)` when empty.
    fn field(&mut self, i: usize, name: &str) -> Result<Option<&str>, RecordingError> {
        let f = text(self.rec, i, self.line, self.origin)?;
        if f.is_empty() {
            return Ok(None);
        }
        if self.format.decimal_comma {
            if f.contains('.') {
                return Err(self.err(
                    i + 1,
                    format!(
                        "`{name}` is `{f}`: a dot in a file read with decimal commas ({}); \
                         give --decimal-comma false if dots are the decimal mark",
                        self.format.describe()
                    ),
                ));
            }
            if f.contains(',') {
                self.scratch.clear();
                self.scratch
                    .extend(f.chars().map(|c| if c == ',' { '.' } else { c }));
                return Ok(Some(self.scratch.as_str()));
            }
        }
        Ok(Some(f))
    }

    /// Why `f` in column `i` (`name`) is not a number, with the likely cause and its flag.
    fn not_a_number(&self, i: usize, name: &str) -> RecordingError {
        let f = text(self.rec, i, self.line, self.origin).unwrap_or_default();
        let fmt = self.format;
        let mut m = format!("`{name}` is `{f}`, expected a number");
        let other_separator = Delimiter::ALL.into_iter().find(|&d| {
            d != fmt.delimiter
                && match d.byte() {
                    Some(b) => f.as_bytes().contains(&b),
                    None => f.contains(' '),
                }
        });
        if !fmt.decimal_comma && fmt.delimiter != Delimiter::Comma && is_decimal_comma_number(f) {
            m.push_str(&format!(
                ": a decimal comma? give --decimal-comma ({})",
                fmt.describe()
            ));
        } else if let Some(d) = other_separator {
            m.push_str(&format!(
                ": the separator may be {} ({}): give --delimiter {}",
                d.name(),
                fmt.describe(),
                d.name()
            ));
        } else if is_unit(f) && self.first {
            m.push_str(
                ": a units row? The row right under the header is read as units when none of \
                 its fields is a number; else give --time-unit, --rate-unit, --temp-unit and \
                 remove the row",
            );
        } else if is_unit(f) {
            m.push_str(": units are read only from the row right under the header");
        }
        self.err(i + 1, m)
    }

    /// Column `c` as a number in the format's unit; `Ok(None)` for an empty field.
    fn number(&mut self, c: &Numeric) -> Result<Option<f64>, RecordingError> {
        let Some(f) = self.field(c.index, &c.name)? else {
            return Ok(None);
        };
        match f.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(if c.k != 1.0 || c.add != 0.0 {
                v * c.k + c.add
            } else {
                v
            })),
            Ok(_) => {
                let raw = text(self.rec, c.index, self.line, self.origin)?;
                Err(self.err(
                    c.index + 1,
                    format!("`{}` is `{raw}`, expected a finite number", c.name),
                ))
            }
            Err(_) => Err(self.not_a_number(c.index, &c.name)),
        }
    }

    /// The row's time in seconds, checked to increase.
    fn time(&mut self, clock: &mut Clock) -> Result<f64, RecordingError> {
        let (i, name) = (clock.index, clock.name.clone());
        let raw = text(self.rec, i, self.line, self.origin)?;
        let line = self.line;
        let Some(f) = self.field(i, &name)? else {
            return Err(self.err(i + 1, format!("`{name}` is empty: every row needs a time")));
        };
        let value = if clock.keeps {
            match f.parse::<f64>() {
                Ok(v) if v.is_finite() => v,
                Ok(_) => {
                    return Err(self.err(
                        i + 1,
                        format!("`{name}` is `{raw}`, expected a finite number"),
                    ))
                }
                Err(_) => return Err(self.not_a_number(i, &name)),
            }
        } else {
            let Some(stamp) = Stamp::parse(f) else {
                return Err(self.not_a_number(i, &name));
            };
            match &clock.origin {
                Some((o, _, _)) => stamp.minus(*o),
                None => {
                    clock.origin = Some((stamp, line, raw.to_string()));
                    0.0
                }
            }
        };
        if let Some((prev, prev_line)) = clock.last {
            if value <= prev {
                return Err(self.err(
                    i + 1,
                    format!(
                        "`{name}` {raw} does not increase (line {prev_line} has {}); expected \
                         strictly increasing times",
                        clock.last_field
                    ),
                ));
            }
        }
        clock.last = Some((value, self.line));
        clock.last_field.clear();
        clock.last_field.push_str(raw);
        Ok(if clock.per_second == 1.0 {
            value
        } else {
            value / clock.per_second
        })
    }
}

/// One axis being read.
struct AxisBuf {
    rec: Recording,
    extra: Vec<Vec<String>>,
    /// Rows left out for an empty field, and the first one's line.
    gaps: usize,
    first_gap: usize,
}

/// What the second pass yields: the plan, one recording per rate column, and notes.
pub(super) struct Parsed {
    pub plan: Plan,
    pub axes: Vec<Recording>,
    pub notes: Vec<String>,
}

/// Reads the file `open` gives once more, as `scan` and `format` describe it.
pub(super) fn read<'a>(
    open: &dyn Fn() -> std::io::Result<Box<dyn BufRead + 'a>>,
    scan: Scan,
    format: &Format,
    opts: &ReadOptions,
    origin: &str,
) -> Result<Parsed, RecordingError> {
    let io = |source| RecordingError::Io {
        path: origin.to_string(),
        source,
    };
    let mut input = open().map_err(io)?;
    if scan.bom && input.fill_buf().map_err(io)?.starts_with(BOM) {
        input.consume(BOM.len());
    }
    let mut src = Source::new(input, format.delimiter);
    let mut lines = LineNumbers::new(&scan.skipped);
    let mut rec = ByteRecord::new();
    let empty = |message: &str| RecordingError::Format {
        path: origin.to_string(),
        line: scan.total_lines.max(1),
        column: 0,
        message: message.to_string(),
    };
    if !src.next(&mut rec).map_err(io)? {
        return Err(empty("empty file: expected a header row"));
    }
    let header_line = lines.next_line();
    let header = strings(&rec, header_line, origin)?;
    let mut units = None;
    if format.units_row.is_some() && src.next(&mut rec).map_err(io)? {
        let l = lines.next_line();
        units = Some((l, strings(&rec, l, origin)?));
    }
    let plan = columns::plan(
        &header,
        header_line,
        units.as_ref().map(|(l, f)| (*l, f.as_slice())),
        format,
        opts,
        origin,
    )?;
    let rows = scan
        .content_lines
        .saturating_sub(1 + usize::from(units.is_some()));
    let mut axes = allocate(&plan, rows, scan.comments);
    let rates: Vec<Numeric> = plan.rates.iter().map(Numeric::rate).collect();
    let temps: Vec<Numeric> = plan.temps.iter().map(Numeric::temp).collect();
    let chamber = plan.chamber.as_ref().map(Numeric::temp);
    let mut clock = Clock {
        index: plan.time.index,
        name: plan.time.name.clone(),
        keeps: plan.keeps_clock,
        per_second: plan.time.unit.per_second(),
        unit: plan.time.unit.name(),
        origin: None,
        last: None,
        last_field: String::new(),
    };
    let mut temp_values: Vec<Option<f64>> = Vec::with_capacity(temps.len());
    let mut scratch = String::new();
    let mut read_any = false;
    while src.next(&mut rec).map_err(io)? {
        let line = lines.next_line();
        let mut row = Row {
            rec: &rec,
            line,
            first: !read_any && units.is_none(),
            format,
            origin,
            scratch: std::mem::take(&mut scratch),
        };
        if rec.len() != plan.width {
            return Err(ragged(&row, plan.width));
        }
        let t = row.time(&mut clock)?;
        let ch = chamber.as_ref().map(|c| row.number(c)).transpose()?;
        temp_values.clear();
        for c in &temps {
            temp_values.push(row.number(c)?);
        }
        for (k, ax) in axes.iter_mut().enumerate() {
            let rate = row.number(&rates[k])?;
            let temp = temp_values[plan.temp_of(k)];
            push(ax, &plan, &row, (t, rate, temp, ch))?;
        }
        scratch = row.scratch;
        read_any = true;
    }
    if !read_any {
        return Err(empty(if units.is_some() {
            "no data rows after the header and its units row"
        } else {
            "no data rows after the header"
        }));
    }
    finish(plan, axes, &clock, origin)
}

/// A row with another number of fields than the header.
fn ragged(row: &Row, width: usize) -> RecordingError {
    let n = row.rec.len();
    let hint = if n > width && row.format.delimiter == Delimiter::Comma {
        ": a comma inside a field, or decimal commas in a comma-separated file (export with \
         another separator and give --delimiter)?"
    } else {
        ""
    };
    row.err(
        0,
        format!(
            "row has {n} fields, expected {width} as in the header ({}){hint}",
            row.format.describe()
        ),
    )
}

/// Empty columns for every axis, each reserved for `rows` samples: reserving spares the
/// columns the doubling growth, which can leave each with up to twice the memory it needs
/// (~540 MB instead of 320 MB for 10⁷ samples of four columns).
fn allocate(plan: &Plan, rows: usize, comments: Vec<String>) -> Vec<AxisBuf> {
    let n = plan.rates.len();
    let mut comments = Some(comments);
    (0..n)
        .map(|k| {
            let col = || Vec::with_capacity(rows);
            AxisBuf {
                rec: Recording {
                    time_s: col(),
                    rate_dph: col(),
                    temp_c: col(),
                    chamber_c: plan.chamber.as_ref().map(|_| col()),
                    extra: Vec::new(),
                    // The last axis takes the comments; the others copy them.
                    comments: if k + 1 == n {
                        comments.take().unwrap_or_default()
                    } else {
                        comments.clone().unwrap_or_default()
                    },
                },
                extra: plan
                    .extras
                    .iter()
                    .map(|_| Vec::with_capacity(rows))
                    .collect(),
                gaps: 0,
                first_gap: 0,
            }
        })
        .collect()
}

/// Adds a row's sample to an axis, or counts it left out when its rate, temperature or
/// chamber field is empty (`chamber`: `Some(None)`); a logger's dropped value becomes a gap,
/// which the features bridge as the board bridges a missing sample.
fn push(
    ax: &mut AxisBuf,
    plan: &Plan,
    row: &Row,
    sample: (f64, Option<f64>, Option<f64>, Option<Option<f64>>),
) -> Result<(), RecordingError> {
    let (t, rate, temp, chamber) = sample;
    let (Some(r), Some(c), false) = (rate, temp, matches!(chamber, Some(None))) else {
        ax.gaps += 1;
        if ax.first_gap == 0 {
            ax.first_gap = row.line;
        }
        return Ok(());
    };
    ax.rec.time_s.push(t);
    ax.rec.rate_dph.push(r);
    ax.rec.temp_c.push(c);
    if let (Some(v), Some(Some(x))) = (ax.rec.chamber_c.as_mut(), chamber) {
        v.push(x);
    }
    for (slot, (j, _)) in ax.extra.iter_mut().zip(&plan.extras) {
        slot.push(text(row.rec, *j, row.line, row.origin)?.to_string());
    }
    Ok(())
}

/// The recordings and the notes about origin and gaps.
fn finish(
    plan: Plan,
    axes: Vec<AxisBuf>,
    clock: &Clock,
    origin: &str,
) -> Result<Parsed, RecordingError> {
    let mut notes = Vec::new();
    if let (false, Some((o, line, raw))) = (clock.keeps, &clock.origin) {
        if !o.is_zero() {
            notes.push(format!(
                "time: the first stamp, {raw} {} (line {line}), is subtracted: times are \
                 seconds since the first sample",
                clock.unit
            ));
        }
    }
    let mut out = Vec::with_capacity(axes.len());
    for (k, mut ax) in axes.into_iter().enumerate() {
        let name = &plan.rates[k].name;
        if ax.gaps > 0 {
            notes.push(format!(
                "`{name}`: {} row(s) with an empty rate, temperature or chamber field left \
                 out (first at line {})",
                ax.gaps, ax.first_gap
            ));
        }
        if ax.rec.is_empty() {
            return Err(RecordingError::Format {
                path: origin.to_string(),
                line: 0,
                column: plan.rates[k].index + 1,
                message: format!(
                    "`{name}`: no row has both a rate and a temperature (every one has an \
                     empty field)"
                ),
            });
        }
        ax.rec.extra = plan
            .extras
            .iter()
            .zip(ax.extra)
            .map(|((_, raw), v)| (raw.clone(), v))
            .collect();
        out.push(ax.rec);
    }
    Ok(Parsed {
        plan,
        axes: out,
        notes,
    })
}
