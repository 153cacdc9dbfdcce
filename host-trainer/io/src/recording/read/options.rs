//! What the user may say about a file: its separator, its decimal mark, which columns hold
//! the time, the rates and the temperatures, and their units.

use super::super::units::UnitChoice;

/// Field separator of a recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Delimiter {
    /// `,` (the format's).
    Comma,
    /// `;` (spreadsheet exports where the comma is the decimal mark).
    Semicolon,
    /// A tab.
    Tab,
    /// Runs of spaces or tabs (aligned text tables).
    Whitespace,
}

impl Delimiter {
    /// Every separator; on a tie, detection prefers the earlier one.
    pub const ALL: [Delimiter; 4] = [
        Delimiter::Comma,
        Delimiter::Semicolon,
        Delimiter::Tab,
        Delimiter::Whitespace,
    ];

    /// The names `--delimiter` takes; the first is the canonical one.
    pub fn names(self) -> &'static [&'static str] {
        match self {
            Delimiter::Comma => &["comma", ","],
            Delimiter::Semicolon => &["semicolon", ";"],
            Delimiter::Tab => &["tab", "\\t", "\t"],
            Delimiter::Whitespace => &["whitespace", "space", "spaces", " "],
        }
    }

    /// The canonical name (`--delimiter` value, messages).
    pub fn name(self) -> &'static str {
        self.names()[0]
    }

    /// What the separator is, in words, for help texts.
    pub fn describe(self) -> &'static str {
        match self {
            Delimiter::Comma => "`,`",
            Delimiter::Semicolon => "`;`",
            Delimiter::Tab => "a tab",
            Delimiter::Whitespace => "runs of spaces or tabs",
        }
    }

    /// The separator a name stands for (case-insensitive).
    pub fn parse(text: &str) -> Option<Delimiter> {
        let t = text.to_lowercase();
        let t = if t.trim().is_empty() {
            t
        } else {
            t.trim().to_string()
        };
        Delimiter::ALL
            .into_iter()
            .find(|d| d.names().contains(&t.as_str()))
    }

    /// The byte the csv reader splits on; `None` for runs of whitespace.
    pub(crate) fn byte(self) -> Option<u8> {
        match self {
            Delimiter::Comma => Some(b','),
            Delimiter::Semicolon => Some(b';'),
            Delimiter::Tab => Some(b'\t'),
            Delimiter::Whitespace => None,
        }
    }
}

/// A column named on the command line: by its header name, or by its 1-based number.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ColumnRef {
    /// The header's name, with or without its unit suffix (`imu.gyro.x`, `imu.gyro.x [rad/s]`).
    Name(String),
    /// The column's number, from 1.
    Index(usize),
}

impl std::str::FromStr for ColumnRef {
    type Err = String;

    /// A number is a column number (from 1), anything else a name: `3`, `imu.gyro.x`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim();
        if s.is_empty() {
            return Err("empty column: give a header name or a column number from 1".into());
        }
        if s.bytes().all(|b| b.is_ascii_digit()) {
            return match s.parse::<usize>() {
                Ok(0) => Err("column numbers start at 1".into()),
                Ok(i) => Ok(ColumnRef::Index(i)),
                Err(_) => Err(format!("column number {s} is too large")),
            };
        }
        Ok(ColumnRef::Name(s.to_string()))
    }
}

impl std::fmt::Display for ColumnRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ColumnRef::Name(n) => f.write_str(n),
            ColumnRef::Index(i) => write!(f, "{i}"),
        }
    }
}

/// How to read a recording; the default reads the format's own files (and detects the
/// separator, a decimal comma, a units row and a few common column names in others).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReadOptions {
    /// The field separator; `None`: detected from the header and the first rows.
    pub delimiter: Option<Delimiter>,
    /// Whether numbers use a decimal comma (`20,5`); `None`: detected (only in files not
    /// separated by commas).
    pub decimal_comma: Option<bool>,
    /// The time column; `None`: `time_s`, else a single column named `time`, `timestamp`,
    /// `t` (or one of those with a unit: `time_us`, `TimeUS`…).
    pub time_col: Option<ColumnRef>,
    /// The rate columns, one axis each; empty: `rate_dph`, else the one column with a gyro's
    /// name (`gyro_x`, `imu.gyro.z`, `gx`, `omega`); several such are an error listing them.
    pub rate_cols: Vec<ColumnRef>,
    /// With no `rate_cols`: read every column with a gyro's name (and `rate_dph`), one axis
    /// each, instead of refusing several.
    pub every_axis: bool,
    /// The temperature columns: one for every axis, or one per rate column; empty:
    /// `temp_c`, else a single column named `temp`, `temperature` or ending so
    /// (`imu.temperature`, `gyro_temp`).
    pub temp_cols: Vec<ColumnRef>,
    /// Units stated by the user; they override the header's.
    pub units: UnitChoice,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn column_refs_and_separators_parse() {
        assert_eq!("3".parse::<ColumnRef>(), Ok(ColumnRef::Index(3)));
        assert_eq!(
            " imu.gyro.x ".parse::<ColumnRef>(),
            Ok(ColumnRef::Name("imu.gyro.x".into()))
        );
        assert!("0".parse::<ColumnRef>().unwrap_err().contains("start at 1"));
        assert!("".parse::<ColumnRef>().is_err());
        for d in Delimiter::ALL {
            for n in d.names() {
                assert_eq!(Delimiter::parse(n), Some(d), "{n:?}");
            }
        }
        assert_eq!(Delimiter::parse("TAB"), Some(Delimiter::Tab));
        assert_eq!(Delimiter::parse("|"), None);
    }
}
