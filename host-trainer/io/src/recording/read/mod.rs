//! Reading what rigs and loggers write, not only the format's own files: comma, semicolon,
//! tab or whitespace separators (detected or stated), decimal commas, a UTF-8 byte-order mark,
//! CR LF line ends, `#` comment lines anywhere, a units row under the header, columns chosen
//! by name or number with units from flags, header suffixes (`[rad/s]`, `(degC)`) or the
//! units row, and several rate columns at once (one recording per axis).
//!
//! The steps: [`scan`] (one pass over the lines: comments, BOM, row count, the first lines),
//! [`sniff`] (the separator, the decimal mark, a units row), [`rows`] (the second pass:
//! header → [`columns::plan`], then every row checked and converted), then the plausibility
//! checks on the columns whose unit nobody stated.
//!
//! What the file must still be: a header row naming its columns; every row as many fields as
//! the header; times strictly increasing; every number finite. An empty field in a rate,
//! temperature or chamber column leaves that sample out of the axes that read it (counted in
//! the notes); `NaN` and text are refused.

mod columns;
mod options;
mod roles;
mod rows;
mod scan;
mod sniff;
mod stamp;
#[cfg(test)]
mod tests;

use std::io::BufRead;
use std::path::Path;

pub use options::{ColumnRef, Delimiter, ReadOptions};

use super::plausible::{rate_problem, rate_unit_unstated, temp_problem, time_problem};
use super::{Recording, RecordingError};

/// One gyro axis of a file: the recording of one rate column.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// The rate column's name in the header, without its unit suffix (`imu.gyro.x`;
    /// `rate_dph` in the format's own files).
    pub name: String,
    /// Its samples in the format's units (s, °/h, °C), with the file's comments.
    pub recording: Recording,
}

/// What [`read_axes`] read.
#[derive(Clone, Debug, PartialEq)]
pub struct Axes {
    /// One per rate column, in the order they were asked for (at least one).
    pub axes: Vec<Axis>,
    /// What was detected or chosen without being asked: the separator, a byte-order mark
    /// removed, decimal commas, units from the header or a units row, a time origin
    /// subtracted, columns taken by a common name, samples left out. Empty for the format's
    /// own files.
    pub notes: Vec<String>,
    /// Warnings that do not stop a command ([`Recording::unit_warnings`]), the axis named
    /// when they are not the same for every axis.
    pub warnings: Vec<String>,
}

/// Reads a recording file as `opts` says: one [`Axis`] per rate column, converted to the
/// format's units; columns whose unit nobody stated (flag, header, units row, name) are
/// checked for plausibility and refused, with the flag value that converts them, when they
/// look like another unit.
pub fn read_axes(path: &Path, opts: &ReadOptions) -> Result<Axes, RecordingError> {
    let open = || -> std::io::Result<Box<dyn BufRead>> {
        Ok(Box::new(std::io::BufReader::with_capacity(
            1 << 16,
            std::fs::File::open(path)?,
        )))
    };
    let parsed = parse(&open, &path.display().to_string(), opts)?;
    checked(parsed, &path.display().to_string())
}

/// [`read_axes`] on text in memory; `origin` names it in messages.
pub fn parse_axes(text: &str, origin: &str, opts: &ReadOptions) -> Result<Axes, RecordingError> {
    let open = || -> std::io::Result<Box<dyn BufRead + '_>> { Ok(Box::new(text.as_bytes())) };
    checked(parse(&open, origin, opts)?, origin)
}

/// The axes without the plausibility checks (the format's own files, read as written).
pub(super) fn parse_unchecked<'a>(
    open: &dyn Fn() -> std::io::Result<Box<dyn BufRead + 'a>>,
    origin: &str,
) -> Result<Recording, RecordingError> {
    let p = parse(open, origin, &ReadOptions::default())?;
    // The default options read one rate column: `rate_dph`.
    Ok(p.axes
        .into_iter()
        .next()
        .map(|a| a.recording)
        .unwrap_or_default())
}

/// What the passes yield before the checks.
struct Parsed {
    axes: Vec<Axis>,
    notes: Vec<String>,
    /// For the checks: per axis, the columns whose unit nobody stated.
    unstated: Vec<Unstated>,
}

/// The names of the columns of one axis whose unit was not stated (`None`: stated).
struct Unstated {
    time: Option<String>,
    rate: Option<String>,
    temp: Option<(usize, String)>,
    chamber: Option<String>,
}

/// The passes: scan, sniff, rows.
fn parse<'a>(
    open: &dyn Fn() -> std::io::Result<Box<dyn BufRead + 'a>>,
    origin: &str,
    opts: &ReadOptions,
) -> Result<Parsed, RecordingError> {
    let io = |source| RecordingError::Io {
        path: origin.to_string(),
        source,
    };
    let s = scan::scan(&mut *open().map_err(io)?, origin)?;
    let format = sniff::sniff(&s, opts, origin)?;
    let mut notes = format_notes(&format);
    let p = rows::read(open, s, &format, opts, origin)?;
    notes.extend(p.plan.notes.iter().cloned());
    notes.extend(p.notes);
    let plan = &p.plan;
    let unstated = (0..plan.rates.len())
        .map(|k| {
            let t = &plan.temps[plan.temp_of(k)];
            Unstated {
                time: (!plan.time.stated()).then(|| plan.time.name.clone()),
                rate: (!plan.rates[k].stated()).then(|| plan.rates[k].name.clone()),
                temp: (!t.stated()).then(|| (t.index, t.name.clone())),
                chamber: plan
                    .chamber
                    .as_ref()
                    .filter(|c| !c.stated())
                    .map(|c| c.name.clone()),
            }
        })
        .collect();
    let axes = plan
        .rates
        .iter()
        .zip(p.axes)
        .map(|(c, recording)| Axis {
            name: c.name.clone(),
            recording,
        })
        .collect();
    Ok(Parsed {
        axes,
        notes,
        unstated,
    })
}

/// Notes on what was detected in the format (nothing for a comma-separated file as the
/// format writes it).
fn format_notes(f: &sniff::Format) -> Vec<String> {
    let mut notes = Vec::new();
    if f.bom {
        notes.push("UTF-8 byte-order mark removed".to_string());
    }
    if f.delimiter_detected && f.delimiter != Delimiter::Comma {
        notes.push(format!(
            "separator: {} (detected; --delimiter sets it)",
            f.delimiter.name()
        ));
    }
    if f.decimal_comma && f.decimal_comma_detected {
        notes.push("decimal commas (detected; --decimal-comma false turns them off)".to_string());
    }
    if let Some(l) = f.units_row {
        notes.push(format!("line {l} is a units row, under the header"));
    }
    notes
}

/// The plausibility checks on the columns whose unit nobody stated (each column once), then
/// the warnings.
fn checked(p: Parsed, origin: &str) -> Result<Axes, RecordingError> {
    let mut problems = Vec::new();
    let mut temps_seen = Vec::new();
    for (k, (ax, u)) in p.axes.iter().zip(&p.unstated).enumerate() {
        let r = &ax.recording;
        if let Some((i, name)) = &u.temp {
            if !temps_seen.contains(i) {
                temps_seen.push(*i);
                problems.extend(temp_problem(name, &r.temp_c));
            }
        }
        // One chamber column for every axis: checked once.
        if let (0, Some(name), Some(c)) = (k, &u.chamber, &r.chamber_c) {
            problems.extend(temp_problem(name, c));
        }
        if let Some(name) = &u.rate {
            problems.extend(rate_problem(name, &r.rate_dph));
            problems.extend(rate_unit_unstated(name));
        }
    }
    if let (Some(ax), Some(Some(name))) = (p.axes.first(), p.unstated.first().map(|u| &u.time)) {
        problems.extend(time_problem(name, &ax.recording.time_s));
    }
    if !problems.is_empty() {
        return Err(RecordingError::Units {
            path: origin.to_string(),
            problems,
        });
    }
    let per_axis: Vec<Vec<String>> = p.axes.iter().map(|a| a.recording.unit_warnings()).collect();
    let mut warnings: Vec<String> = Vec::new();
    for (k, ws) in per_axis.iter().enumerate() {
        for w in ws {
            let everywhere = per_axis.iter().all(|o| o.contains(w));
            let w = if everywhere || p.axes.len() == 1 {
                w.clone()
            } else {
                format!("{}: {w}", p.axes[k].name)
            };
            if !warnings.contains(&w) {
                warnings.push(w);
            }
        }
    }
    Ok(Axes {
        axes: p.axes,
        notes: p.notes,
        warnings,
    })
}
