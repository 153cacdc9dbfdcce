//! The units a recording's columns can be written in, their names (as flags, header suffixes
//! and units rows write them) and the conversion to the format's (s, °/h, °C).

/// A unit of one kind of column, known by the names files and flags write it with.
pub trait UnitName: Copy + Sized + 'static {
    /// Every unit of the kind, in the order help texts list them.
    const ALL: &'static [Self];
    /// What the unit measures, for messages (`time`, `rate`, `temperature`).
    const KIND: &'static str;
    /// The flag that states the unit of such columns.
    const FLAG: &'static str;

    /// The names the unit is written with; the first is the canonical one (the flag value
    /// messages suggest), the others are accepted aliases.
    fn names(self) -> &'static [&'static str];

    /// What the unit is, in words, for help texts.
    fn describe(self) -> &'static str;

    /// The canonical name.
    fn name(self) -> &'static str {
        self.names()[0]
    }

    /// The unit a name (a flag value, a header suffix, a units-row field) stands for:
    /// case-insensitive, surrounding brackets and spaces ignored (`[rad/s]`, `(degC)`, `°C`).
    fn parse(text: &str) -> Option<Self> {
        let t = strip_brackets(text).to_lowercase();
        Self::ALL
            .iter()
            .copied()
            .find(|u| u.names().iter().any(|n| n.to_lowercase() == t))
    }
}

/// `text` without surrounding spaces and one pair of surrounding brackets or parentheses.
fn strip_brackets(text: &str) -> &str {
    let t = text.trim();
    t.strip_prefix('[')
        .and_then(|s| s.strip_suffix(']'))
        .or_else(|| t.strip_prefix('(').and_then(|s| s.strip_suffix(')')))
        .map_or(t, str::trim)
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
    /// Nanoseconds.
    Ns,
}

impl TimeUnit {
    /// Stamps per second: a stamp difference divided by this is seconds (a division, so that
    /// whole stamps convert to the nearest f64 second).
    pub fn per_second(self) -> f64 {
        match self {
            TimeUnit::S => 1.0,
            TimeUnit::Ms => 1e3,
            TimeUnit::Us => 1e6,
            TimeUnit::Ns => 1e9,
        }
    }
}

impl UnitName for TimeUnit {
    const ALL: &'static [Self] = &[TimeUnit::S, TimeUnit::Ms, TimeUnit::Us, TimeUnit::Ns];
    const KIND: &'static str = "time";
    const FLAG: &'static str = "--time-unit";

    fn names(self) -> &'static [&'static str] {
        match self {
            TimeUnit::S => &["s", "sec", "secs", "second", "seconds"],
            TimeUnit::Ms => &["ms", "msec", "millisecond", "milliseconds"],
            // The micro sign (U+00B5) and the Greek mu (U+03BC) look alike; files use both.
            TimeUnit::Us => &["us", "µs", "μs", "usec", "microsecond", "microseconds"],
            TimeUnit::Ns => &["ns", "nsec", "nanosecond", "nanoseconds"],
        }
    }

    fn describe(self) -> &'static str {
        match self {
            TimeUnit::S => "seconds",
            TimeUnit::Ms => "milliseconds",
            TimeUnit::Us => "microseconds",
            TimeUnit::Ns => "nanoseconds",
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
    /// Degrees Fahrenheit.
    F,
}

impl TempUnit {
    /// (factor, offset) to °C: `c = x · factor + offset`.
    pub fn to_celsius(self) -> (f64, f64) {
        match self {
            TempUnit::C => (1.0, 0.0),
            TempUnit::K => (1.0, -273.15),
            TempUnit::F => (5.0 / 9.0, -32.0 * 5.0 / 9.0),
        }
    }
}

impl UnitName for TempUnit {
    const ALL: &'static [Self] = &[TempUnit::C, TempUnit::K, TempUnit::F];
    const KIND: &'static str = "temperature";
    const FLAG: &'static str = "--temp-unit";

    fn names(self) -> &'static [&'static str] {
        match self {
            TempUnit::C => &["c", "degc", "°c", "deg c", "deg_c", "celsius", "℃"],
            TempUnit::K => &["k", "kelvin"],
            TempUnit::F => &["f", "degf", "°f", "deg f", "deg_f", "fahrenheit", "℉"],
        }
    }

    fn describe(self) -> &'static str {
        match self {
            TempUnit::C => "degrees Celsius",
            TempUnit::K => "kelvin",
            TempUnit::F => "degrees Fahrenheit",
        }
    }
}

/// Unit of the rate columns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RateUnit {
    /// Degrees per hour (the format's).
    #[default]
    Dph,
    /// Degrees per second.
    Dps,
    /// Radians per second.
    RadS,
    /// Millidegrees per second.
    Mdps,
    /// Milliradians per second.
    MradS,
}

impl RateUnit {
    /// The factor to °/h.
    pub fn to_dph(self) -> f64 {
        // rad → °: × 180/π; per second → per hour: × 3600.
        let rad_s = 3600.0 * 180.0 / std::f64::consts::PI;
        match self {
            RateUnit::Dph => 1.0,
            RateUnit::Dps => 3600.0,
            RateUnit::RadS => rad_s,
            RateUnit::Mdps => 3.6,
            RateUnit::MradS => rad_s * 1e-3,
        }
    }
}

impl UnitName for RateUnit {
    const ALL: &'static [Self] = &[
        RateUnit::Dph,
        RateUnit::Dps,
        RateUnit::RadS,
        RateUnit::Mdps,
        RateUnit::MradS,
    ];
    const KIND: &'static str = "rate";
    const FLAG: &'static str = "--rate-unit";

    fn names(self) -> &'static [&'static str] {
        match self {
            RateUnit::Dph => &["dph", "deg/h", "°/h", "deg/hr", "deg-h", "deg_h"],
            RateUnit::Dps => &["dps", "deg/s", "°/s", "deg/sec", "deg-s", "deg_s"],
            RateUnit::RadS => &["rad/s", "rad-s", "rad_s", "rads", "rad/sec"],
            RateUnit::Mdps => &["mdps", "mdeg/s", "mdeg-s", "mdeg_s"],
            RateUnit::MradS => &["mrad/s", "mrad-s", "mrad_s", "mrads"],
        }
    }

    fn describe(self) -> &'static str {
        match self {
            RateUnit::Dph => "degrees per hour",
            RateUnit::Dps => "degrees per second",
            RateUnit::RadS => "radians per second",
            RateUnit::Mdps => "millidegrees per second",
            RateUnit::MradS => "milliradians per second",
        }
    }
}

/// Which columns' units the user stated (those are not second-guessed by
/// [`super::Recording::unit_errors`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UnitsGiven {
    /// The time unit was given.
    pub time: bool,
    /// The temperature unit was given.
    pub temp: bool,
    /// The rate unit was given.
    pub rate: bool,
}

/// The units a recording's columns were written in ([`super::Recording::convert_units`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Units {
    /// Time column.
    pub time: TimeUnit,
    /// Temperature columns.
    pub temp: TempUnit,
    /// Rate column.
    pub rate: RateUnit,
}

/// The units a user stated for a recording's columns (flags); `None` for a column means the
/// unit its header or units row states, else the format's (s, °C, °/h), checked for
/// plausibility. A unit given is trusted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UnitChoice {
    /// Unit of the time column.
    pub time: Option<TimeUnit>,
    /// Unit of the temperature columns.
    pub temp: Option<TempUnit>,
    /// Unit of the rate columns.
    pub rate: Option<RateUnit>,
}

impl UnitChoice {
    /// The units the columns are read in (the format's where none was given).
    pub fn units(&self) -> Units {
        Units {
            time: self.time.unwrap_or_default(),
            temp: self.temp.unwrap_or_default(),
            rate: self.rate.unwrap_or_default(),
        }
    }

    /// Which units were given (those columns are not second-guessed).
    pub fn given(&self) -> UnitsGiven {
        UnitsGiven {
            time: self.time.is_some(),
            temp: self.temp.is_some(),
            rate: self.rate.is_some(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every alias names its own unit and no other: a name shared by two units would make a
    /// header suffix ambiguous.
    #[test]
    fn names_parse_back_to_their_unit() {
        fn check<U: UnitName + PartialEq + std::fmt::Debug>() {
            for &u in U::ALL {
                for n in u.names() {
                    assert_eq!(U::parse(n), Some(u), "{n}");
                    assert_eq!(U::parse(&format!(" [{}] ", n.to_uppercase())), Some(u));
                }
            }
        }
        check::<TimeUnit>();
        check::<RateUnit>();
        check::<TempUnit>();
        assert_eq!(RateUnit::parse("dps"), Some(RateUnit::Dps));
        assert_eq!(TempUnit::parse("(degC)"), Some(TempUnit::C));
        assert_eq!(TempUnit::parse("°C"), Some(TempUnit::C));
        assert_eq!(TimeUnit::parse("µs"), Some(TimeUnit::Us));
        assert_eq!(TimeUnit::parse("rad/s"), None);
        assert_eq!(RateUnit::parse("g"), None);
    }

    /// The conversions against hand-computed values: 1 rad/s is 206 264.8 °/h (the arcseconds
    /// in a radian), 1 °/s is 3600 °/h, 212 °F is 100 °C.
    #[test]
    fn conversions_match_hand_values() {
        assert!((RateUnit::RadS.to_dph() - 206_264.806_247).abs() < 1e-6);
        assert!((RateUnit::MradS.to_dph() - 206.264_806).abs() < 1e-6);
        assert_eq!(RateUnit::Dps.to_dph(), 3600.0);
        assert_eq!(RateUnit::Mdps.to_dph(), 3.6);
        let (k, add) = TempUnit::F.to_celsius();
        assert!((212.0 * k + add - 100.0).abs() < 1e-12);
        assert!((32.0 * k + add).abs() < 1e-12);
        assert_eq!(1_500_000.0 / TimeUnit::Us.per_second(), 1.5);
    }
}
