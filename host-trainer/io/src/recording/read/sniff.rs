//! The file's format from its first lines: the separator, the decimal mark, and whether the
//! row under the header holds units. What the user stated is taken as stated.

use super::super::units::{RateUnit, TempUnit, TimeUnit, UnitName};
use super::super::RecordingError;
use super::options::{Delimiter, ReadOptions};
use super::scan::Scan;

/// Rows after the header that the separator must split like the header.
const ROWS_CHECKED: usize = 20;

/// The format of a file, as detected or stated.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct Format {
    /// The field separator.
    pub delimiter: Delimiter,
    /// The separator was detected (not given with `--delimiter`).
    pub delimiter_detected: bool,
    /// Numbers use a decimal comma.
    pub decimal_comma: bool,
    /// The decimal comma was detected (not given with `--decimal-comma`).
    pub decimal_comma_detected: bool,
    /// Line number of the units row right under the header, when there is one.
    pub units_row: Option<usize>,
    /// A UTF-8 byte-order mark was removed.
    pub bom: bool,
}

impl Format {
    /// What was found, for error messages: `separator: tab, detected; UTF-8 BOM removed`.
    pub(super) fn describe(&self) -> String {
        let mut s = format!(
            "separator: {}, {}",
            self.delimiter.name(),
            if self.delimiter_detected {
                "detected"
            } else {
                "--delimiter"
            }
        );
        if self.decimal_comma {
            s.push_str(if self.decimal_comma_detected {
                "; decimal commas, detected"
            } else {
                "; decimal commas, --decimal-comma"
            });
        }
        if self.bom {
            s.push_str("; UTF-8 BOM removed");
        }
        s
    }
}

/// The fields of one line split at `d` as the reader splits them (the csv crate's quoting and
/// trimming; runs of whitespace for [`Delimiter::Whitespace`]).
pub(super) fn split(line: &str, d: Delimiter) -> Vec<String> {
    let Some(byte) = d.byte() else {
        return line.split_whitespace().map(str::to_string).collect();
    };
    let mut r = csv::ReaderBuilder::new()
        .delimiter(byte)
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(line.as_bytes());
    let mut rec = csv::StringRecord::new();
    match r.read_record(&mut rec) {
        Ok(true) => rec.iter().map(str::to_string).collect(),
        _ => Vec::new(),
    }
}

/// Whether `field` is a number written with a decimal comma: one comma, no dot
/// (`-0,0123`, `1,5e-3`).
pub(super) fn is_decimal_comma_number(field: &str) -> bool {
    field.matches(',').count() == 1
        && !field.contains('.')
        && field.bytes().any(|b| b.is_ascii_digit())
        && field.replacen(',', ".", 1).parse::<f64>().is_ok()
}

/// Whether `field` reads as a number with either decimal mark.
fn is_number(field: &str) -> bool {
    field.parse::<f64>().is_ok() || is_decimal_comma_number(field)
}

/// Whether `field` names a unit the reader knows, of any kind.
pub(super) fn is_unit(field: &str) -> bool {
    TimeUnit::parse(field).is_some()
        || RateUnit::parse(field).is_some()
        || TempUnit::parse(field).is_some()
}

/// The separator that splits the header into the most fields and every row checked into as
/// many (ties: comma, semicolon, tab, whitespace). When none splits every row alike, the one
/// that splits the header into the most fields (a ragged row is then reported with its line);
/// comma when nothing splits the header. A comma-separated header holding the format's own
/// columns is the format's, whatever its other columns hold.
fn detect_delimiter(sample: &[(usize, String)]) -> Delimiter {
    let Some((_, header)) = sample.first() else {
        return Delimiter::Comma;
    };
    let own = split(header, Delimiter::Comma);
    if ["time_s", "rate_dph", "temp_c"]
        .iter()
        .all(|n| own.iter().any(|f| f == n))
    {
        return Delimiter::Comma;
    }
    let rows = &sample[1..sample.len().min(ROWS_CHECKED + 1)];
    let mut consistent: Option<(usize, Delimiter)> = None;
    let mut widest: Option<(usize, Delimiter)> = None;
    for d in Delimiter::ALL {
        let n = split(header, d).len();
        if n < 2 {
            continue;
        }
        if widest.is_none_or(|(m, _)| n > m) {
            widest = Some((n, d));
        }
        let alike = rows.iter().all(|(_, r)| split(r, d).len() == n);
        if alike && consistent.is_none_or(|(m, _)| n > m) {
            consistent = Some((n, d));
        }
    }
    consistent.or(widest).map_or(Delimiter::Comma, |(_, d)| d)
}

/// Whether the line under the header is a units row: no field in it is a number and at
/// least one names a unit (`s;rad/s;rad/s;°C`, `[us]\t[rad/s]`).
fn is_units_row(fields: &[String]) -> bool {
    !fields.iter().any(|f| is_number(f)) && fields.iter().any(|f| is_unit(f))
}

/// Decimal commas are detected when the rows checked hold numbers with one comma and no dot,
/// and none with a dot.
fn detect_decimal_comma(rows: &[Vec<String>]) -> bool {
    let (mut comma, mut dot) = (0usize, 0usize);
    for f in rows.iter().flatten() {
        if is_decimal_comma_number(f) {
            comma += 1;
        } else if f.contains('.') && f.parse::<f64>().is_ok() {
            dot += 1;
        }
    }
    comma > 0 && dot == 0
}

/// The format of the scanned file under the options; `origin` names it in errors.
pub(super) fn sniff(
    scan: &Scan,
    opts: &ReadOptions,
    origin: &str,
) -> Result<Format, RecordingError> {
    let delimiter = opts
        .delimiter
        .unwrap_or_else(|| detect_delimiter(&scan.sample));
    let mut f = Format {
        delimiter,
        delimiter_detected: opts.delimiter.is_none(),
        decimal_comma: false,
        decimal_comma_detected: opts.decimal_comma.is_none(),
        units_row: None,
        bom: scan.bom,
    };
    let second = scan.sample.get(1).map(|(l, s)| (*l, split(s, delimiter)));
    f.units_row = second
        .filter(|(_, fields)| is_units_row(fields))
        .map(|(l, _)| l);
    let first_row = if f.units_row.is_some() { 2 } else { 1 };
    f.decimal_comma = match opts.decimal_comma {
        Some(true) if delimiter == Delimiter::Comma => {
            return Err(RecordingError::Options {
                path: origin.to_string(),
                message: format!(
                    "--decimal-comma: a comma-separated file cannot have decimal commas \
                     ({}); give --delimiter semicolon, tab or whitespace if the fields are \
                     separated so",
                    f.describe()
                ),
            })
        }
        Some(b) => b,
        None if delimiter == Delimiter::Comma => false,
        None => {
            let rows: Vec<Vec<String>> = scan
                .sample
                .iter()
                .skip(first_row)
                .take(ROWS_CHECKED)
                .map(|(_, s)| split(s, delimiter))
                .collect();
            detect_decimal_comma(&rows)
        }
    };
    Ok(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(text: &str) -> Vec<(usize, String)> {
        text.lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.to_string()))
            .collect()
    }

    #[test]
    fn separators_are_detected() {
        let d = |t: &str| detect_delimiter(&sample(t));
        assert_eq!(d("time_s,rate_dph,temp_c\n0,1,2\n"), Delimiter::Comma);
        assert_eq!(d("t;r;T\n0,5;1,25;20,5\n"), Delimiter::Semicolon);
        assert_eq!(d("t\tr\tT\n0,5\t1,25\t20,5\n"), Delimiter::Tab);
        assert_eq!(d("t   r  T\n0.5  1.25   20.5\n"), Delimiter::Whitespace);
        assert_eq!(d("timestamp (us), gyro x\n1, 2\n"), Delimiter::Comma);
        // The format's own header decides, whatever its extra columns hold.
        assert_eq!(
            d("time_s,rate_dph,temp_c,a;b;c;d\n0,1,2,e;f;g;h\n"),
            Delimiter::Comma
        );
        assert_eq!(d("time\n0\n"), Delimiter::Comma);
    }

    #[test]
    fn units_rows_and_decimal_commas_are_detected() {
        let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        assert!(is_units_row(&s(&["s", "[rad/s]", "°C", ""])));
        assert!(!is_units_row(&s(&["0", "rad/s"])));
        assert!(!is_units_row(&s(&["a", "b"])));
        assert!(detect_decimal_comma(&[s(&["12", "-0,5", "20,25"])]));
        assert!(!detect_decimal_comma(&[s(&["12", "-0,5", "20.25"])]));
        assert!(!detect_decimal_comma(&[s(&["12", "3"])]));
        assert!(is_decimal_comma_number("1,5e-3"));
        assert!(!is_decimal_comma_number("1,234,5"));
    }
}
