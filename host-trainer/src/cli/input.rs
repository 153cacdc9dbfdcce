//! The flags every subcommand that reads a recording shares (how the file is written: its
//! separator, decimal mark, columns and units), and the reading itself, with what was
//! detected and the warnings on standard error.

use std::path::Path;

use anyhow::Context as _;
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};

use rlg_io::recording::{
    read_axes, Axes, ColumnRef, Delimiter, RateUnit, ReadOptions, Recording, TempUnit, TimeUnit,
    UnitChoice, UnitName,
};

/// How a recording file is written, when it is not the format's own (comma-separated,
/// `time_s`, `rate_dph`, `temp_c` in s, °/h, °C). Whatever is not given is detected: the
/// separator, decimal commas, a units row under the header, units in the header (`[rad/s]`,
/// `(degC)`). A column whose unit nobody states is checked for plausibility and refused, with
/// the flag that converts it, when it looks like another unit.
#[derive(Clone, Debug, Default, clap::Args)]
#[command(next_help_heading = "Reading the recording")]
pub struct InputArgs {
    /// Field separator [default: detected among comma, semicolon, tab and whitespace].
    #[arg(long, value_name = "SEP", value_parser = names::<Delimiter>(), ignore_case = true)]
    pub delimiter: Option<Delimiter>,
    /// Numbers use a decimal comma (`20,5`); `--decimal-comma false`: they do not
    /// [default: detected in files not separated by commas].
    #[arg(long, value_name = "BOOL", num_args = 0..=1, default_missing_value = "true")]
    pub decimal_comma: Option<bool>,
    /// Time column: its header name or its number from 1 [default: time_s, else the one
    /// column named time, timestamp or t, or time_us, TimeUS…].
    #[arg(long, value_name = "COL")]
    pub time_col: Option<ColumnRef>,
    /// Rate column, one gyro axis: its header name or its number from 1 (`imu.gyro.x`, `3`);
    /// the commands read one axis per run [default: rate_dph, else the one column with a
    /// gyro's name: gyro_x, imu.gyro.z, gx, omega].
    // A list, so that the reader's several axes stay one flag; `one_axis` refuses more than
    // one for the commands that read one.
    #[arg(long, value_name = "COL", value_delimiter = ',')]
    pub rate_col: Vec<ColumnRef>,
    /// Temperature column: its header name or its number from 1 [default: temp_c, else the
    /// one column named temp or temperature, or ending so: imu.temperature, gyro_temp].
    #[arg(long, value_name = "COL", value_delimiter = ',')]
    pub temp_col: Vec<ColumnRef>,
    /// Unit of the time column; overrides the file's [default: the header's or the units
    /// row's, else s, checked].
    #[arg(long, value_name = "UNIT", value_parser = names::<TimeUnit>(), ignore_case = true)]
    pub time_unit: Option<TimeUnit>,
    /// Unit of the rate columns; overrides the file's [default: the header's or the units
    /// row's, else dph, checked].
    #[arg(long, value_name = "UNIT", value_parser = names::<RateUnit>(), ignore_case = true)]
    pub rate_unit: Option<RateUnit>,
    /// Unit of the temperature columns; overrides the file's [default: the header's or the
    /// units row's, else c, checked].
    #[arg(long, value_name = "UNIT", value_parser = names::<TempUnit>(), ignore_case = true)]
    pub temp_unit: Option<TempUnit>,
}

impl InputArgs {
    /// The options as the reader takes them.
    pub fn options(&self) -> ReadOptions {
        ReadOptions {
            delimiter: self.delimiter,
            decimal_comma: self.decimal_comma,
            time_col: self.time_col.clone(),
            rate_cols: self.rate_col.clone(),
            temp_cols: self.temp_col.clone(),
            units: UnitChoice {
                time: self.time_unit,
                temp: self.temp_unit,
                rate: self.rate_unit,
            },
            // The commands read one axis: several gyro columns are an error naming them.
            every_axis: false,
        }
    }

    /// An error naming `--rate-col` when it names several columns: for the commands that
    /// read one axis.
    pub fn one_axis(&self) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.rate_col.len() <= 1,
            "--rate-col names {} columns ({}): this command reads one axis; give one rate \
             column (and one --temp-col), or run it once per axis",
            self.rate_col.len(),
            self.rate_col
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        );
        Ok(())
    }
}

/// Reads a recording for a command that takes one axis ([`read_axes_cli`]); several rate
/// columns are an error naming the flag.
pub fn read_recording(path: &Path, input: &InputArgs) -> anyhow::Result<Recording> {
    input.one_axis()?;
    let axes = read_axes_cli(path, input)?;
    axes.axes
        .into_iter()
        .next()
        .map(|a| a.recording)
        .context("the reader returned no axis")
}

/// Reads every gyro axis of a recording (`--every-axis`): the rate columns `--rate-col`
/// names, else every column with a gyro's name.
pub fn read_every_axis(path: &Path, input: &InputArgs) -> anyhow::Result<Axes> {
    let mut opts = input.options();
    opts.every_axis = true;
    let pb = rlg_io::progress::spinner(&format!("reading {}", path.display()));
    let axes = read_axes(path, &opts);
    pb.finish_and_clear();
    let axes = axes?;
    print_report(path, &axes);
    Ok(axes)
}

/// Reads every axis of a recording as `input` says ([`read_axes`]: implausible units are
/// refused) and prints on standard error what was detected (`note:`) and the warnings that
/// do not stop a command (`warning:`), each naming the file.
pub fn read_axes_cli(path: &Path, input: &InputArgs) -> anyhow::Result<Axes> {
    let pb = rlg_io::progress::spinner(&format!("reading {}", path.display()));
    let axes = read_axes(path, &input.options());
    pb.finish_and_clear();
    let axes = axes?;
    print_report(path, &axes);
    Ok(axes)
}

/// The notes and warnings of a read on standard error.
pub fn print_report(path: &Path, axes: &Axes) {
    for n in &axes.notes {
        eprintln!("note: {}: {n}", path.display());
    }
    for w in &axes.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
}

/// A value a flag takes by any of its names: units and separators.
pub trait FlagValue: Copy + Send + Sync + 'static {
    /// Every value, in the order help lists them.
    fn all() -> &'static [Self];
    /// Its names; the first is the one help shows, the others are accepted aliases.
    fn names(self) -> &'static [&'static str];
    /// What it is, in words.
    fn describe(self) -> &'static str;
}

macro_rules! unit_flag_value {
    ($($t:ty),*) => {$(
        impl FlagValue for $t {
            fn all() -> &'static [Self] {
                <$t as UnitName>::ALL
            }
            fn names(self) -> &'static [&'static str] {
                UnitName::names(self)
            }
            fn describe(self) -> &'static str {
                UnitName::describe(self)
            }
        }
    )*};
}
unit_flag_value!(TimeUnit, RateUnit, TempUnit);

impl FlagValue for Delimiter {
    fn all() -> &'static [Self] {
        &Delimiter::ALL
    }
    fn names(self) -> &'static [&'static str] {
        Delimiter::names(self)
    }
    fn describe(self) -> &'static str {
        Delimiter::describe(self)
    }
}

/// The parser of a flag taking a [`FlagValue`]: clap's possible-values parser (help lists the
/// values, an unknown one gets the list), over every name the reader itself knows, so a flag
/// and a header suffix accept the same spellings (`dps`, `deg/s`, `°/s`).
pub fn names<V: FlagValue>() -> impl TypedValueParser<Value = V> {
    let values = V::all().iter().map(|v| {
        let n = v.names();
        let aliases: Vec<&str> = n[1..].to_vec();
        // A tab or a space as a value is accepted but would print as nothing.
        let shown: Vec<&str> = aliases
            .iter()
            .copied()
            .filter(|a| !a.trim().is_empty())
            .collect();
        let help = if shown.is_empty() {
            v.describe().to_string()
        } else {
            format!("{} (also {})", v.describe(), shown.join(", "))
        };
        PossibleValue::new(n[0]).aliases(aliases).help(help)
    });
    // The possible-values parser checks the value and hands it on as typed (`µs`, `RAD/S`),
    // not as its canonical name: the value is looked up among every name again.
    PossibleValuesParser::new(values).try_map(|given: String| {
        let lower = given.to_lowercase();
        V::all()
            .iter()
            .copied()
            .find(|v| v.names().iter().any(|n| n.to_lowercase() == lower))
            .ok_or_else(|| format!("`{given}` is none of the values"))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cmd {
        #[command(flatten)]
        input: InputArgs,
    }

    fn parse(args: &[&str]) -> Result<InputArgs, clap::Error> {
        Cmd::try_parse_from(std::iter::once("rlg").chain(args.iter().copied())).map(|c| c.input)
    }

    /// `dps` is degrees per second (not a misspelt `dph`: 3600× apart); the reader's aliases
    /// and any case are accepted; lists split at commas; a bare `--decimal-comma` is true.
    #[test]
    fn flags_take_the_readers_names() {
        let a = parse(&[
            "--rate-unit",
            "dps",
            "--time-unit",
            "µs",
            "--temp-unit",
            "degC",
            "--delimiter",
            ";",
            "--decimal-comma",
            "--rate-col",
            "imu.gyro.x,imu.gyro.y,3",
        ])
        .unwrap();
        assert_eq!(a.rate_unit, Some(RateUnit::Dps));
        assert_eq!(a.time_unit, Some(TimeUnit::Us));
        assert_eq!(a.temp_unit, Some(TempUnit::C));
        assert_eq!(a.delimiter, Some(Delimiter::Semicolon));
        assert_eq!(a.decimal_comma, Some(true));
        assert_eq!(
            a.rate_col,
            vec![
                ColumnRef::Name("imu.gyro.x".into()),
                ColumnRef::Name("imu.gyro.y".into()),
                ColumnRef::Index(3)
            ]
        );
        assert!(a
            .one_axis()
            .unwrap_err()
            .to_string()
            .contains("--rate-col names 3"));
        for (flag, value, want) in [
            ("--rate-unit", "RAD/S", RateUnit::RadS),
            ("--rate-unit", "rad-s", RateUnit::RadS),
            ("--rate-unit", "deg-s", RateUnit::Dps),
            ("--rate-unit", "°/h", RateUnit::Dph),
        ] {
            assert_eq!(
                parse(&[flag, value]).unwrap().rate_unit,
                Some(want),
                "{value}"
            );
        }
        for (value, want) in [
            ("tab", Delimiter::Tab),
            ("\\t", Delimiter::Tab),
            ("\t", Delimiter::Tab),
            (",", Delimiter::Comma),
            ("Whitespace", Delimiter::Whitespace),
            (" ", Delimiter::Whitespace),
        ] {
            let d = parse(&["--delimiter", value]).unwrap().delimiter;
            assert_eq!(d, Some(want), "{value:?}");
        }
        assert_eq!(
            parse(&["--time-unit", "NS"]).unwrap().time_unit,
            Some(TimeUnit::Ns)
        );
        assert_eq!(
            parse(&["--temp-unit", "°F"]).unwrap().temp_unit,
            Some(TempUnit::F)
        );
        assert_eq!(
            parse(&["--decimal-comma", "false"]).unwrap().decimal_comma,
            Some(false)
        );
        let e = parse(&["--rate-unit", "furlongs"]).unwrap_err().to_string();
        assert!(e.contains("dps") && e.contains("rad/s"), "{e}");
        assert!(parse(&["--time-col", "0"]).is_err());
    }
}
