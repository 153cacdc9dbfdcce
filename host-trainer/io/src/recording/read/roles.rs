//! Which header column plays which role: the columns the flags name first, then the format's
//! names (`time_s`, `rate_dph`, `temp_c`), then a few common names when exactly one column
//! has one. A role nobody can fill, or one several columns could fill, is an error that lists
//! the header's fields and names the flag that settles it.

use super::super::units::TimeUnit;
use super::super::RecordingError;
use super::columns::HeaderField;
use super::options::{ColumnRef, Delimiter, ReadOptions};
use super::sniff::Format;

/// Header fields listed in a message before it says how many more there are.
const FIELDS_LISTED: usize = 40;

/// The header and what messages about it need.
pub(super) struct Ctx<'a> {
    pub origin: &'a str,
    /// The header's line.
    pub line: usize,
    pub format: &'a Format,
    pub fields: &'a [HeaderField],
}

impl Ctx<'_> {
    /// An error on the header line; `column` 1-based, 0 for the whole line.
    pub(super) fn err(&self, column: usize, message: String) -> RecordingError {
        RecordingError::Format {
            path: self.origin.to_string(),
            line: self.line,
            column,
            message,
        }
    }

    /// `fields: a, b, c; separator: tab, detected`.
    fn found(&self) -> String {
        let mut list: Vec<&str> = self
            .fields
            .iter()
            .take(FIELDS_LISTED)
            .map(|f| f.raw.as_str())
            .collect();
        let more;
        if self.fields.len() > FIELDS_LISTED {
            more = format!("… ({} in all)", self.fields.len());
            list.push(&more);
        }
        format!("fields: {}; {}", list.join(", "), self.format.describe())
    }

    /// The column whose name is `name` (with or without the unit suffix); an error when
    /// several are.
    pub(super) fn by_name(&self, name: &str) -> Result<Option<usize>, RecordingError> {
        let mut hits = self
            .fields
            .iter()
            .enumerate()
            .filter(|(_, f)| f.raw == name || f.name == name)
            .map(|(i, _)| i);
        match (hits.next(), hits.next()) {
            (Some(a), Some(b)) => Err(self.err(
                b + 1,
                format!(
                    "duplicate column `{name}` (columns {} and {}): choose one by number",
                    a + 1,
                    b + 1
                ),
            )),
            (a, _) => Ok(a),
        }
    }

    /// The column a flag names: by number, by exact name, else by a unique name differing
    /// only in case.
    fn find(&self, r: &ColumnRef, flag: &str) -> Result<usize, RecordingError> {
        match r {
            ColumnRef::Index(i) if *i >= 1 && *i <= self.fields.len() => Ok(i - 1),
            ColumnRef::Index(i) => Err(self.err(
                0,
                format!(
                    "{flag} {i}: the header has {} columns ({})",
                    self.fields.len(),
                    self.found()
                ),
            )),
            ColumnRef::Name(n) => {
                if let Some(i) = self.by_name(n)? {
                    return Ok(i);
                }
                let lower = n.to_lowercase();
                let folded: Vec<usize> = (0..self.fields.len())
                    .filter(|&i| {
                        let f = &self.fields[i];
                        f.raw.to_lowercase() == lower || f.name.to_lowercase() == lower
                    })
                    .collect();
                match folded[..] {
                    [i] => Ok(i),
                    _ => Err(self.err(
                        0,
                        format!(
                            "{flag} {n}: no such column in the header ({}): give a header name \
                             or a column number from 1",
                            self.found()
                        ),
                    )),
                }
            }
        }
    }

    /// Every column a flag names, in order.
    fn find_all(&self, refs: &[ColumnRef], flag: &str) -> Result<Vec<usize>, RecordingError> {
        refs.iter().map(|r| self.find(r, flag)).collect()
    }

    /// The columns not `claimed` whose lower-case name (without unit suffix) `is_it` accepts.
    fn candidates(&self, claimed: &[usize], is_it: impl Fn(&str) -> bool) -> Vec<usize> {
        (0..self.fields.len())
            .filter(|i| !claimed.contains(i) && is_it(&self.fields[*i].name.to_lowercase()))
            .collect()
    }

    /// `` `a`, `b [rad/s]` ``.
    fn quoted(&self, columns: &[usize]) -> String {
        columns
            .iter()
            .map(|&i| format!("`{}`", self.fields[i].raw))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Common names of a time column, with the unit the name states.
pub(super) fn time_name(lower: &str) -> Option<Option<TimeUnit>> {
    match lower {
        "time" | "timestamp" | "t" => Some(None),
        "time_ms" | "timestamp_ms" | "timems" => Some(Some(TimeUnit::Ms)),
        "time_us" | "timestamp_us" | "timeus" => Some(Some(TimeUnit::Us)),
        "time_ns" | "timestamp_ns" | "timens" => Some(Some(TimeUnit::Ns)),
        _ => None,
    }
}

/// Common names of a temperature column: `temp`, `temperature`, or a name whose last part
/// (after `.` or `_`) is one of those (`imu.temperature`, `gyro_temp`).
fn is_temp_name(lower: &str) -> bool {
    let last = lower.rsplit(['.', '_']).next().unwrap_or(lower);
    matches!(last, "temp" | "temperature")
}

/// Common names of a gyro rate column: a part (between `.`, `_`, `-`, spaces) starting with
/// `gyr` (`gyro_x`, `imu.gyro.z`, `GyrX`), or `rate`, `omega`, `gx`…`gz`, `wx`…`wz`; never a
/// temperature's name (`gyro_temp`).
fn is_rate_name(lower: &str) -> bool {
    let gyro_part = lower
        .split(['.', '_', '-', ' '])
        .any(|p| p.starts_with("gyr"));
    let short = matches!(
        lower,
        "rate" | "omega" | "gx" | "gy" | "gz" | "wx" | "wy" | "wz"
    );
    (gyro_part || short) && !is_temp_name(lower)
}

/// The columns of each role, before units.
pub(super) struct Roles {
    pub time: usize,
    pub rates: Vec<usize>,
    pub temps: Vec<usize>,
}

/// A role a column of the format's name or one common name fills when no flag names it.
struct NamedRole<'n> {
    /// The format's name (`time_s`).
    own: &'n str,
    /// The role in messages (`time`).
    role: &'n str,
    /// The flag that names the column.
    flag: &'n str,
}

impl NamedRole<'_> {
    /// The format's column, else the one column with a common name (noted), else `None`;
    /// several with a common name are an error naming the flag. Columns `claimed` by a flag
    /// have no common name.
    fn find(
        &self,
        ctx: &Ctx,
        claimed: &[usize],
        is_it: impl Fn(&str) -> bool,
        notes: &mut Vec<String>,
    ) -> Result<Option<usize>, RecordingError> {
        // Taken even when a flag gave it another role: the error then says it is read twice.
        if let Some(i) = ctx.by_name(self.own)? {
            return Ok(Some(i));
        }
        match ctx.candidates(claimed, is_it)[..] {
            [] => Ok(None),
            [i] => {
                notes.push(format!(
                    "{}: column `{}` (a common name; {} chooses another)",
                    self.role, ctx.fields[i].raw, self.flag
                ));
                Ok(Some(i))
            }
            ref hits => Err(ctx.err(
                0,
                format!(
                    "several columns could be the {}: {} ({}): choose one with {}",
                    self.role,
                    ctx.quoted(hits),
                    ctx.found(),
                    self.flag
                ),
            )),
        }
    }
}

/// The rate columns when no flag names them: `rate_dph`, else the one column with a gyro's
/// name; several are an error that lists them and the `--rate-col` values that choose one,
/// unless `every_axis` asks for all of them.
fn default_rates(
    ctx: &Ctx,
    every_axis: bool,
    claimed: &[usize],
    notes: &mut Vec<String>,
) -> Result<Vec<usize>, RecordingError> {
    if let (Some(i), false) = (ctx.by_name("rate_dph")?, every_axis) {
        return Ok(vec![i]);
    }
    let hits = ctx.candidates(claimed, |n| n == "rate_dph" || is_rate_name(n));
    match (&hits[..], every_axis) {
        ([], _) => {}
        ([i], false) => notes.push(format!(
            "rate: column `{}` (a common name; --rate-col chooses another)",
            ctx.fields[*i].raw
        )),
        (_, true) => notes.push(format!(
            "rates: every gyro column, one axis each: {}",
            ctx.quoted(&hits)
        )),
        (_, false) => {
            let names: Vec<&str> = hits.iter().map(|&i| ctx.fields[i].name.as_str()).collect();
            return Err(ctx.err(
                0,
                format!(
                    "several columns could be the rate: {} ({}): choose one with --rate-col {} \
                     (or {}: one axis per run)",
                    ctx.quoted(&hits),
                    ctx.found(),
                    names[0],
                    names[1..].join(", ")
                ),
            ));
        }
    }
    Ok(hits)
}

/// Finds the time, rate and temperature columns; every role missing is named in one error.
/// The columns the flags name are found first, so that none of them is taken for another
/// role by its name (`t` for the time when `T` is the temperature given).
pub(super) fn roles(
    ctx: &Ctx,
    opts: &ReadOptions,
    notes: &mut Vec<String>,
) -> Result<Roles, RecordingError> {
    let time_flag = opts
        .time_col
        .as_ref()
        .map(|r| ctx.find(r, "--time-col"))
        .transpose()?;
    let rate_flags = ctx.find_all(&opts.rate_cols, "--rate-col")?;
    let temp_flags = ctx.find_all(&opts.temp_cols, "--temp-col")?;
    let mut claimed: Vec<usize> = time_flag
        .iter()
        .chain(&rate_flags)
        .chain(&temp_flags)
        .copied()
        .collect();
    let time = match time_flag {
        Some(i) => Some(i),
        None => NamedRole {
            own: "time_s",
            role: "time",
            flag: "--time-col",
        }
        .find(ctx, &claimed, |n| time_name(n).is_some(), notes)?,
    };
    claimed.extend(time);
    let temps = if temp_flags.is_empty() {
        let t = NamedRole {
            own: "temp_c",
            role: "temperature",
            flag: "--temp-col",
        }
        .find(ctx, &claimed, is_temp_name, notes)?;
        t.into_iter().collect()
    } else {
        temp_flags
    };
    claimed.extend(&temps);
    let rates = if rate_flags.is_empty() {
        default_rates(ctx, opts.every_axis, &claimed, notes)?
    } else {
        rate_flags
    };
    let missing: Vec<(&str, &str)> = [
        (time.is_none(), ("time_s", "--time-col")),
        (rates.is_empty(), ("rate_dph", "--rate-col")),
        (temps.is_empty(), ("temp_c", "--temp-col")),
    ]
    .into_iter()
    .filter_map(|(gone, what)| gone.then_some(what))
    .collect();
    if !missing.is_empty() {
        return Err(missing_error(ctx, &missing));
    }
    let time = time.unwrap_or_default();
    check_roles(ctx, time, &rates, &temps)?;
    Ok(Roles { time, rates, temps })
}

/// `no column `time_s` in the header (fields: …; separator: …): name the columns with …`.
fn missing_error(ctx: &Ctx, missing: &[(&str, &str)]) -> RecordingError {
    let names: Vec<String> = missing.iter().map(|(n, _)| format!("`{n}`")).collect();
    let flags: Vec<&str> = missing.iter().map(|(_, f)| *f).collect();
    let headerless = ctx.fields.iter().all(|f| f.raw.parse::<f64>().is_ok());
    // A header split at the wrong separator holds the right one inside its fields.
    let other = Delimiter::ALL.into_iter().find(|&d| {
        d != ctx.format.delimiter
            && d.byte()
                .is_some_and(|b| ctx.fields.iter().any(|f| f.raw.as_bytes().contains(&b)))
    });
    ctx.err(
        0,
        format!(
            "no column {} in the header ({}): name the columns with {} (a header name or a \
             column number from 1){}{}",
            names.join(", "),
            ctx.found(),
            flags.join(", "),
            if headerless {
                "; the first row holds numbers: the file needs a header row naming its columns"
            } else {
                ""
            },
            match other {
                Some(d) => format!(
                    "; the header holds {}: give --delimiter {} if that is the separator",
                    d.describe(),
                    d.name()
                ),
                None => String::new(),
            }
        ),
    )
}

/// One column per role, as many temperature columns as rate columns or one.
fn check_roles(
    ctx: &Ctx,
    time: usize,
    rates: &[usize],
    temps: &[usize],
) -> Result<(), RecordingError> {
    let name = |i: usize| ctx.fields[i].raw.as_str();
    let options = |message: String| RecordingError::Options {
        path: ctx.origin.to_string(),
        message,
    };
    if temps.len() != 1 && temps.len() != rates.len() {
        return Err(options(format!(
            "--temp-col names {} columns for {} rate columns: give one for every axis or one \
             per rate column, in the order of --rate-col",
            temps.len(),
            rates.len()
        )));
    }
    for (k, &r) in rates.iter().enumerate() {
        if r == time || rates[..k].contains(&r) || temps.contains(&r) {
            return Err(options(format!(
                "column `{}` is read twice (as a rate and as the time, a temperature or \
                 another rate): give each column one role with --time-col, --rate-col, \
                 --temp-col",
                name(r)
            )));
        }
    }
    if temps.contains(&time) {
        return Err(options(format!(
            "column `{}` is both the time and a temperature: choose them with --time-col and \
             --temp-col",
            name(time)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn common_names() {
        for n in [
            "gyro_x",
            "imu.gyro.z",
            "gyrx",
            "gyroscope y",
            "gx",
            "omega",
            "rate",
        ] {
            assert!(is_rate_name(n), "{n}");
        }
        for n in [
            "gyro_temp",
            "imu.temperature",
            "t",
            "accel_x",
            "rate_hz_gyro_temp",
        ] {
            assert!(!is_rate_name(n), "{n}");
        }
        assert!(is_temp_name("gyro_temp") && is_temp_name("imu.temperature"));
        assert_eq!(time_name("time_us"), Some(Some(TimeUnit::Us)));
        assert_eq!(time_name("timestamp"), Some(None));
        assert_eq!(time_name("times"), None);
    }
}
