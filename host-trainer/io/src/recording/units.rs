//! The units a recording's columns were written in: conversion to the format's (s, °C,
//! °/h), and the plausibility checks that refuse a column which looks like another unit.

use std::path::Path;

use super::{Recording, RecordingError};

impl Recording {
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

/// The units a user stated for a recording's columns; `None` for a column means the format's
/// unit (s, °C, °/h), checked for plausibility by [`Recording::read_checked`]. A unit given is
/// trusted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UnitChoice {
    /// Unit of the time column.
    pub time: Option<TimeUnit>,
    /// Unit of the temperature columns.
    pub temp: Option<TempUnit>,
    /// Unit of the rate column.
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

impl Recording {
    /// Reads a recording, converts it from the units chosen and refuses implausible ones (every
    /// reason and the flag that converts it in one error). Returns the recording and the
    /// warnings that do not stop a command ([`Recording::unit_warnings`]), for the caller to
    /// show.
    pub fn read_checked(
        path: &Path,
        units: &UnitChoice,
    ) -> Result<(Recording, Vec<String>), RecordingError> {
        let mut rec = Recording::read_csv(path)?;
        rec.convert_units(units.units());
        let problems = rec.unit_errors(units.given());
        if !problems.is_empty() {
            return Err(RecordingError::Units {
                path: path.display().to_string(),
                problems,
            });
        }
        let warnings = rec.unit_warnings();
        Ok((rec, warnings))
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
}
