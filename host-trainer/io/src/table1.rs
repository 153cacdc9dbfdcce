//! Reader of the paper's Table 1 (static temperature test) as CSV: `#` comment lines, a
//! header, then one row per temperature point. A copy ships in `data/` and is embedded as
//! [`BUNDLED_CSV`].

use std::path::Path;

/// The Table 1 CSV shipped with the crate (Yu et al. 2011, Table 1; citation in its header).
pub const BUNDLED_CSV: &str = include_str!("../../data/yu2011_table1_static.csv");

/// Column names, in the order of [`Table1Row`]'s fields.
pub const COLUMNS: [&str; 5] = [
    "chamber_c",
    "temp_c",
    "rate_dph",
    "quad_err_1e4_dph",
    "lssvm_err_1e4_dph",
];

/// One temperature point of Table 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Table1Row {
    /// Chamber set temperature, °C.
    pub chamber_c: f64,
    /// Gyro body temperature, °C (a few °C above the chamber: self-heating).
    pub temp_c: f64,
    /// Gyro output averaged over 1 h, °/h (includes the Earth-rate component).
    pub rate_dph: f64,
    /// The paper's least-squares-quadratic model error (prediction − measurement), 1e-4 °/h.
    pub quad_err_1e4_dph: f64,
    /// The paper's LS-SVM model error (prediction − measurement), 1e-4 °/h.
    pub lssvm_err_1e4_dph: f64,
}

/// Why a Table 1 CSV could not be read. Lines are 1-based lines of the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Table1Error {
    /// The file could not be opened or read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The path given.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A required column is missing from the header.
    #[error("header (line {line}) has no column `{column}`")]
    MissingColumn {
        /// Line of the header.
        line: u64,
        /// The missing column.
        column: &'static str,
    },
    /// A field is not a finite number.
    #[error("line {line}, column `{column}`: `{value}` is not a finite number")]
    BadNumber {
        /// Line of the record.
        line: u64,
        /// Column name.
        column: &'static str,
        /// The text found.
        value: String,
    },
    /// Malformed CSV (e.g. a row with the wrong number of fields).
    #[error("line {line}: {message}")]
    Csv {
        /// Line of the problem (0 if unknown).
        line: u64,
        /// What the CSV parser said.
        message: String,
    },
    /// No data rows.
    #[error("no data rows")]
    Empty,
}

fn csv_error(e: csv::Error) -> Table1Error {
    let line = e.position().map_or(0, |p| p.line());
    Table1Error::Csv {
        line,
        message: e.to_string(),
    }
}

/// Parses Table 1 CSV text. Column order is free; extra columns are ignored.
pub fn parse_table1(text: &str) -> Result<Vec<Table1Row>, Table1Error> {
    let mut rdr = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let header_line = rdr.position().line().max(1);
    let headers = rdr.headers().map_err(csv_error)?.clone();
    let header_line = headers.position().map_or(header_line, |p| p.line());
    let mut idx = [0usize; 5];
    for (k, name) in COLUMNS.iter().enumerate() {
        idx[k] = headers
            .iter()
            .position(|h| h == *name)
            .ok_or(Table1Error::MissingColumn {
                line: header_line,
                column: name,
            })?;
    }
    let mut rows = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(csv_error)?;
        let line = rec.position().map_or(0, |p| p.line());
        let mut v = [0.0; 5];
        for (k, column) in COLUMNS.iter().enumerate() {
            let text = rec.get(idx[k]).unwrap_or("");
            v[k] = text
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| Table1Error::BadNumber {
                    line,
                    column,
                    value: text.to_string(),
                })?;
        }
        rows.push(Table1Row {
            chamber_c: v[0],
            temp_c: v[1],
            rate_dph: v[2],
            quad_err_1e4_dph: v[3],
            lssvm_err_1e4_dph: v[4],
        });
    }
    if rows.is_empty() {
        return Err(Table1Error::Empty);
    }
    Ok(rows)
}

/// Reads a Table 1 CSV file.
pub fn read_table1(path: &Path) -> Result<Vec<Table1Row>, Table1Error> {
    let text = std::fs::read_to_string(path).map_err(|source| Table1Error::Io {
        path: path.display().to_string(),
        source,
    })?;
    parse_table1(&text)
}

/// The bundled Table 1 (11 points, −40 … 60 °C chamber).
pub fn bundled() -> Result<Vec<Table1Row>, Table1Error> {
    parse_table1(BUNDLED_CSV)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Checked against the printed table: 11 rows, first and last rows as published.
    #[test]
    fn bundled_table_matches_paper() {
        let t = bundled().unwrap();
        assert_eq!(t.len(), 11);
        assert_eq!(
            t[0],
            Table1Row {
                chamber_c: -40.0,
                temp_c: -34.80,
                rate_dph: -7.0771,
                quad_err_1e4_dph: -13.8,
                lssvm_err_1e4_dph: -1.67
            }
        );
        assert_eq!(t[10].temp_c, 63.59);
        assert_eq!(t[10].rate_dph, -7.1184);
        // The paper: "bias values at high and low temperature spots differ by 0.0413 °/h".
        assert!((t[0].rate_dph - t[10].rate_dph - 0.0413).abs() < 1e-12);
    }

    #[test]
    fn errors_name_line_and_column() {
        let text = "# c\nchamber_c,temp_c,rate_dph,quad_err_1e4_dph,lssvm_err_1e4_dph\n1,2,3,4,5\n1,2,x,4,5\n";
        let e = parse_table1(text).unwrap_err();
        assert!(
            matches!(
                e,
                Table1Error::BadNumber {
                    line: 4,
                    column: "rate_dph",
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("line 4") && e.to_string().contains("rate_dph"));

        let e = parse_table1("chamber_c,temp_c,rate_dph,quad_err_1e4_dph\n1,2,3,4\n").unwrap_err();
        assert!(
            matches!(
                e,
                Table1Error::MissingColumn {
                    column: "lssvm_err_1e4_dph",
                    ..
                }
            ),
            "{e}"
        );

        let e =
            parse_table1("chamber_c,temp_c,rate_dph,quad_err_1e4_dph,lssvm_err_1e4_dph\n1,2,3\n")
                .unwrap_err();
        assert!(matches!(e, Table1Error::Csv { line: 2, .. }), "{e}");

        let e = parse_table1("chamber_c,temp_c,rate_dph,quad_err_1e4_dph,lssvm_err_1e4_dph\n")
            .unwrap_err();
        assert!(matches!(e, Table1Error::Empty));
    }
}
