//! The header: which column holds the time, the rates and the temperatures (named by flag,
//! else the format's names, else a few unambiguous common names) and each one's unit (flag,
//! else the header's suffix, else the units row, else the column's name, else the format's,
//! then checked for plausibility).

use super::super::units::{RateUnit, TempUnit, TimeUnit, UnitName};
use super::super::RecordingError;
use super::options::ReadOptions;
use super::roles::{roles, time_name, Ctx};
use super::sniff::{is_unit, Format};

/// The format's own column names.
const OWN_COLUMNS: [&str; 4] = ["time_s", "rate_dph", "temp_c", "chamber_c"];

/// One field of the header.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct HeaderField {
    /// As written (`imu.gyro.x [rad/s]`).
    pub raw: String,
    /// Without its unit suffix (`imu.gyro.x`): the column's name in flags and messages.
    pub name: String,
    /// The unit suffix, when there is one.
    pub suffix: Option<String>,
}

impl HeaderField {
    /// Splits a unit suffix off: anything in square brackets at the end (`x [counts]`: units
    /// by convention, refused later when not a unit the reader converts), or a known unit in
    /// parentheses (`timestamp (us)`; `temp (sensor 2)` keeps its parentheses in its name).
    pub(super) fn new(raw: &str) -> HeaderField {
        let t = raw.trim();
        let split = |open: char, close: char| {
            let inner_end = t.strip_suffix(close)?;
            let i = inner_end.rfind(open)?;
            let (base, inner) = (inner_end[..i].trim(), inner_end[i + 1..].trim());
            (!base.is_empty() && (open == '[' || is_unit(inner))).then_some((base, inner))
        };
        match split('[', ']').or_else(|| split('(', ')')) {
            Some((base, inner)) => HeaderField {
                raw: t.to_string(),
                name: base.to_string(),
                suffix: Some(inner.to_string()),
            },
            None => HeaderField {
                raw: t.to_string(),
                name: t.to_string(),
                suffix: None,
            },
        }
    }
}

/// Where a column's unit came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum UnitFrom {
    /// A `--*-unit` flag.
    Flag,
    /// The header's suffix.
    Header,
    /// The units row.
    UnitsRow,
    /// The column's name (`time_us`, `TimeUS`).
    Name,
    /// Nothing: the format's unit, checked for plausibility.
    Assumed,
}

/// A column in a role, with its unit.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Column<U> {
    /// 0-based position in the row.
    pub index: usize,
    /// Its name (the header's, without the unit suffix).
    pub name: String,
    /// The unit its values are written in.
    pub unit: U,
    /// Where that unit came from.
    pub from: UnitFrom,
}

impl<U> Column<U> {
    /// Whether the unit was stated (by flag or file): such columns are not second-guessed.
    pub(super) fn stated(&self) -> bool {
        self.from != UnitFrom::Assumed
    }
}

/// Which column plays which role, and what else the reader keeps.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Plan {
    /// Fields in the header (every row must have as many).
    pub width: usize,
    /// The time column.
    pub time: Column<TimeUnit>,
    /// The rate columns, one axis each.
    pub rates: Vec<Column<RateUnit>>,
    /// The temperature columns: one for all axes, or one per axis.
    pub temps: Vec<Column<TempUnit>>,
    /// The chamber air temperature (`chamber_c`), when there is one.
    pub chamber: Option<Column<TempUnit>>,
    /// Columns kept uninterpreted (only when one axis is read): position and header.
    pub extras: Vec<(usize, String)>,
    /// The time column is the format's `time_s`: its clock is kept (converted when its unit
    /// is not seconds), so `--from-s`/`--to-s` and the rows written back mean what they meant
    /// in the file. Other time columns start at 0: their first stamp is subtracted exactly,
    /// as epoch stamps in µs or ns lose their last digits in f64 seconds.
    pub keeps_clock: bool,
    /// What was chosen without being asked for.
    pub notes: Vec<String>,
}

impl Plan {
    /// The position in `temps` of the temperature of axis `axis`.
    pub(super) fn temp_of(&self, axis: usize) -> usize {
        if self.temps.len() == 1 {
            0
        } else {
            axis
        }
    }
}

/// Where units were found, for the notes.
#[derive(Default)]
struct UnitNotes {
    header: Vec<String>,
    row: Vec<String>,
    name: Vec<String>,
    assumed: Vec<String>,
    overridden: Vec<String>,
}

/// The unit of column `i` in role `U`: the flag, else the header's suffix, else the units
/// row, else the one its name states, else the format's (assumed, checked for plausibility).
/// A unit the file states that is not one of `U`'s is an error unless a flag overrides it.
fn unit_of<U: UnitName + PartialEq + Default>(
    ctx: &Ctx,
    units_row: Option<(usize, &[String])>,
    i: usize,
    flag: Option<U>,
    implied: Option<U>,
    notes: &mut UnitNotes,
) -> Result<(U, UnitFrom), RecordingError> {
    let field = &ctx.fields[i];
    let from_header = field
        .suffix
        .as_deref()
        .filter(|s| !s.is_empty())
        .map(|s| (s, UnitFrom::Header, ctx.line));
    let from_row = units_row.and_then(|(line, row)| {
        row.get(i)
            .map(String::as_str)
            .filter(|s| !s.is_empty() && *s != "-")
            .map(|s| (s, UnitFrom::UnitsRow, line))
    });
    let said = from_header.or(from_row);
    let where_ = |from: UnitFrom| match from {
        UnitFrom::Header => "header",
        _ => "units row",
    };
    match (flag, said) {
        (Some(u), Some((text, from, _))) => {
            if U::parse(text) != Some(u) {
                notes.overridden.push(format!(
                    "{} {} overrides the {}'s `{text}` for `{}`",
                    U::FLAG,
                    u.name(),
                    where_(from),
                    field.name
                ));
            }
            Ok((u, UnitFrom::Flag))
        }
        (Some(u), None) => Ok((u, UnitFrom::Flag)),
        (None, Some((text, from, line))) => {
            match U::parse(text) {
                Some(u) => {
                    let list = if from == UnitFrom::Header {
                        &mut notes.header
                    } else {
                        &mut notes.row
                    };
                    list.push(format!("{} {}", field.name, u.name()));
                    Ok((u, from))
                }
                None => {
                    Err(RecordingError::Format {
                        path: ctx.origin.to_string(),
                        line,
                        column: i + 1,
                        message: format!(
                    "`{}` is read as a {} column, but its {} says `{text}`, not a {} unit the \
                     reader converts ({}): give {} to read it in one of them, or choose \
                     another column",
                    field.name,
                    U::KIND,
                    where_(from),
                    U::KIND,
                    U::ALL.iter().map(|u| u.name()).collect::<Vec<_>>().join(", "),
                    U::FLAG
                ),
                    })
                }
            }
        }
        (None, None) => match implied {
            Some(u) => {
                notes.name.push(format!("{} {}", field.name, u.name()));
                Ok((u, UnitFrom::Name))
            }
            None => {
                if !OWN_COLUMNS.contains(&field.name.as_str()) {
                    notes.assumed.push(format!(
                        "`{}` in {} ({})",
                        field.name,
                        U::default().name(),
                        U::FLAG
                    ));
                }
                Ok((U::default(), UnitFrom::Assumed))
            }
        },
    }
}

impl UnitNotes {
    fn into_notes(self, units_row: Option<usize>, out: &mut Vec<String>) {
        if !self.header.is_empty() {
            out.push(format!("units from the header: {}", self.header.join(", ")));
        }
        if !self.row.is_empty() {
            out.push(format!(
                "units from the units row (line {}): {}",
                units_row.unwrap_or(0),
                self.row.join(", ")
            ));
        }
        if !self.name.is_empty() {
            out.push(format!(
                "units from the column names: {}",
                self.name.join(", ")
            ));
        }
        out.extend(self.overridden);
        if !self.assumed.is_empty() {
            out.push(format!(
                "no unit stated (header suffix, units row or flag), read in the format's and \
                 checked for plausibility: {}",
                self.assumed.join(", ")
            ));
        }
    }
}

/// The plan for a file whose header (on line `line`) has `header` fields and, when
/// `units_row` is given, a units row under it.
pub(super) fn plan(
    header: &[String],
    line: usize,
    units_row: Option<(usize, &[String])>,
    format: &Format,
    opts: &ReadOptions,
    origin: &str,
) -> Result<Plan, RecordingError> {
    let fields: Vec<HeaderField> = header.iter().map(|h| HeaderField::new(h)).collect();
    let ctx = Ctx {
        origin,
        line,
        format,
        fields: &fields,
    };
    let mut notes = Vec::new();
    let r = roles(&ctx, opts, &mut notes)?;
    let chamber = ctx
        .by_name("chamber_c")?
        .filter(|i| *i != r.time && !r.rates.contains(i) && !r.temps.contains(i));
    let mut un = UnitNotes::default();
    let u = &opts.units;
    let implied = time_name(&fields[r.time].name.to_lowercase()).flatten();
    let (unit, from) = unit_of(&ctx, units_row, r.time, u.time, implied, &mut un)?;
    let time = Column {
        index: r.time,
        name: fields[r.time].name.clone(),
        unit,
        from,
    };
    let column = |i: usize, un: &mut UnitNotes| -> Result<Column<TempUnit>, RecordingError> {
        let (unit, from) = unit_of(&ctx, units_row, i, u.temp, None, un)?;
        Ok(Column {
            index: i,
            name: fields[i].name.clone(),
            unit,
            from,
        })
    };
    let temps = r
        .temps
        .iter()
        .map(|&i| column(i, &mut un))
        .collect::<Result<Vec<_>, _>>()?;
    let chamber = chamber.map(|i| column(i, &mut un)).transpose()?;
    let rates = r
        .rates
        .iter()
        .map(|&i| {
            let (unit, from) = unit_of(&ctx, units_row, i, u.rate, None, &mut un)?;
            Ok(Column {
                index: i,
                name: fields[i].name.clone(),
                unit,
                from,
            })
        })
        .collect::<Result<Vec<_>, RecordingError>>()?;
    un.into_notes(units_row.map(|(l, _)| l), &mut notes);
    let used = |i: usize| {
        i == r.time
            || r.rates.contains(&i)
            || r.temps.contains(&i)
            || chamber.as_ref().is_some_and(|c| c.index == i)
    };
    let extras = extras(&ctx, used, rates.len() == 1, &mut notes)?;
    Ok(Plan {
        width: fields.len(),
        keeps_clock: time.name == "time_s",
        time,
        rates,
        temps,
        chamber,
        extras,
        notes,
    })
}

/// The columns no role reads (`used` says which are read): kept as they came when one axis is
/// read (`one_axis`), else only noted. Unnamed ones (a trailing separator) are left out. A
/// name the format gives its own columns is left out too, and a name twice is refused:
/// written back, either would read as another column than it was.
fn extras(
    ctx: &Ctx,
    used: impl Fn(usize) -> bool,
    one_axis: bool,
    notes: &mut Vec<String>,
) -> Result<Vec<(usize, String)>, RecordingError> {
    let fields = ctx.fields;
    let unread: Vec<usize> = (0..fields.len()).filter(|&i| !used(i)).collect();
    let (named, unnamed): (Vec<usize>, Vec<usize>) =
        unread.into_iter().partition(|&i| !fields[i].raw.is_empty());
    if !unnamed.is_empty() {
        let list: Vec<String> = unnamed.iter().map(|i| (i + 1).to_string()).collect();
        notes.push(format!(
            "column(s) {} have no name in the header: not read",
            list.join(", ")
        ));
    }
    let (own, named): (Vec<usize>, Vec<usize>) = named
        .into_iter()
        .partition(|&i| OWN_COLUMNS.contains(&fields[i].raw.as_str()));
    if !own.is_empty() {
        let list: Vec<&str> = own.iter().map(|&i| fields[i].raw.as_str()).collect();
        notes.push(format!(
            "not read (another column has the role the format gives this name): {}",
            list.join(", ")
        ));
    }
    if !one_axis {
        if !named.is_empty() {
            let list: Vec<&str> = named.iter().map(|&i| fields[i].raw.as_str()).collect();
            notes.push(format!(
                "not read (several axes keep no other columns): {}",
                list.join(", ")
            ));
        }
        return Ok(Vec::new());
    }
    for (k, &i) in named.iter().enumerate() {
        if let Some(&first) = named[..k].iter().find(|&&j| fields[j].raw == fields[i].raw) {
            return Err(ctx.err(
                i + 1,
                format!(
                    "duplicate column `{}` (columns {} and {}): rename one",
                    fields[i].raw,
                    first + 1,
                    i + 1
                ),
            ));
        }
    }
    Ok(named.iter().map(|&i| (i, fields[i].raw.clone())).collect())
}
