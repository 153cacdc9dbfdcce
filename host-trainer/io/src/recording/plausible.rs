//! Plausibility of a recording's units: the checks that refuse a column which looks like
//! another unit than the one it is read in (each naming the flag value that converts it), the
//! conversion to the format's units, and the warnings that do not stop a command.

use super::units::{RateUnit, TempUnit, TimeUnit, UnitName, Units, UnitsGiven};
use super::Recording;

/// Median of the finite values, `None` when there are none.
fn median(v: &[f64]) -> Option<f64> {
    let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    s.sort_by(f64::total_cmp);
    s.get(s.len() / 2).copied()
}

/// A temperature column (°C) whose median is above 150 looks like kelvin.
pub(crate) fn temp_problem(name: &str, temp_c: &[f64]) -> Option<String> {
    let m = median(temp_c).filter(|m| *m > 150.0)?;
    Some(format!(
        "{name}: median {m:.2} looks like kelvin, not °C: convert with {flag} {k} (or {flag} {c} \
         if the values are right)",
        flag = TempUnit::FLAG,
        k = TempUnit::K.name(),
        c = TempUnit::C.name(),
    ))
}

/// A rate column (°/h) whose values all stay within ±1e-3 looks like rad/s: an RLG's bias and
/// the Earth rate are several °/h, i.e. 1e-5 … 1e-4 rad/s, and the 1 s noise alone exceeds
/// 1e-3 °/h.
pub(crate) fn rate_problem(name: &str, rate_dph: &[f64]) -> Option<String> {
    let peak = rate_dph
        .iter()
        .filter(|v| v.is_finite())
        .fold(0.0f64, |a, v| a.max(v.abs()));
    (!rate_dph.is_empty() && peak < 1e-3).then(|| {
        format!(
            "{name}: every value within ±{peak:.1e}, which looks like rad/s, not °/h: convert \
             with {flag} {rad} (or {flag} {dph} if the values are right)",
            flag = RateUnit::FLAG,
            rad = RateUnit::RadS.name(),
            dph = RateUnit::Dph.name(),
        )
    })
}

/// A rate column other than the format's own `rate_dph` whose unit nobody stated: an IMU
/// logger writes rad/s, °/s or mdps, and a MEMS gyro's bias of 0.01 rad/s read as °/h passes
/// every range check while being wrong by 2·10⁵, so the unit is asked for, not guessed.
pub(crate) fn rate_unit_unstated(name: &str) -> Option<String> {
    (name != "rate_dph").then(|| {
        format!(
            "{name}: the unit of the rate column is not stated (no unit in its header or a \
             units row): give it with {flag} ({units})",
            flag = RateUnit::FLAG,
            units = RateUnit::ALL
                .iter()
                .map(|u| u.name())
                .collect::<Vec<_>>()
                .join("|")
        )
    })
}

/// A time column (s) whose median step is above 100 s looks like a finer unit when the record
/// would then span over 20 days or its stamps are whole multiples of 10 as a millisecond or
/// microsecond clock writes them (burst or plateau means minutes apart, with their fractional
/// mean times, are seconds). The message names every finer unit that makes the median step a
/// gyro log's (1 ms … 100 s), with the step it gives. A median step below 10 µs is faster than
/// any gyro log.
pub(crate) fn time_problem(name: &str, time_s: &[f64]) -> Option<String> {
    let steps: Vec<f64> = time_s.windows(2).map(|w| w[1] - w[0]).collect();
    let step = median(&steps)?;
    let span = time_s.last().unwrap_or(&0.0) - time_s.first().unwrap_or(&0.0);
    let whole = time_s.iter().all(|t| t.fract() == 0.0);
    if step > 100.0 && (span > 20.0 * 86_400.0 || (whole && step % 10.0 == 0.0)) {
        let fits: Vec<(TimeUnit, f64)> = TimeUnit::ALL
            .iter()
            .map(|&u| (u, step / u.per_second()))
            .filter(|(u, s)| *u != TimeUnit::S && (1e-3..=100.0).contains(s))
            .collect();
        let (words, flags) = if fits.is_empty() {
            // Steps of over 100 s even in nanoseconds: no unit the reader knows explains them.
            (
                "a finer unit".to_string(),
                format!("{} ms|us|ns", TimeUnit::FLAG),
            )
        } else {
            (
                fits.iter()
                    .map(|(u, s)| format!("{} ({s} s steps)", u.describe()))
                    .collect::<Vec<_>>()
                    .join(" or "),
                fits.iter()
                    .map(|(u, _)| format!("{} {}", TimeUnit::FLAG, u.name()))
                    .collect::<Vec<_>>()
                    .join(" or "),
            )
        };
        Some(format!(
            "{name}: median step {step} looks like {words}, not seconds: convert with {flags} \
             (or {} s if the steps are right)",
            TimeUnit::FLAG
        ))
    } else if step < 1e-5 {
        Some(format!(
            "{name}: median step {step} s is below 10 µs, faster than a gyro log: the column is \
             not in seconds (the reader converts s, ms, us, ns; convert longer units to \
             seconds) or not the time (choose it with --time-col); give {} s if the steps are \
             right",
            TimeUnit::FLAG
        ))
    } else {
        None
    }
}

impl Recording {
    /// Columns whose values look like another unit than the file format's (seconds, °C,
    /// °/h), each with the reason and the flag value that converts it; empty when all is
    /// plausible. A temperature (temp_c, chamber_c) whose median is above 150 looks like
    /// kelvin; a rate whose values all stay within ±1e-3 looks like rad/s; a median time step
    /// above 100 s looks like a finer unit (when the record would span over 20 days or its
    /// stamps are whole multiples of 10), one below 10 µs like no gyro log. A column whose
    /// unit the user gave is not second-guessed (`checked`).
    pub fn unit_errors(&self, checked: UnitsGiven) -> Vec<String> {
        let mut out = Vec::new();
        if !checked.temp {
            out.extend(temp_problem("temp_c", &self.temp_c));
            if let Some(c) = &self.chamber_c {
                out.extend(temp_problem("chamber_c", c));
            }
        }
        if !checked.rate {
            out.extend(rate_problem("rate_dph", &self.rate_dph));
        }
        if !checked.time {
            out.extend(time_problem("time_s", &self.time_s));
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
        let per_s = u.time.per_second();
        if per_s != 1.0 {
            self.time_s.iter_mut().for_each(|t| *t /= per_s);
        }
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

#[cfg(test)]
mod tests {
    use super::*;

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

    /// Kelvin temperatures, a rate in rad/s and millisecond time stamps are each refused
    /// with the flag that converts them; converted, the same recording passes; a unit the
    /// user gave is not second-guessed; a gap is a warning. Plausible data give nothing.
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
            "--rate-unit rad/s",
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

    /// The time check names the unit that makes the steps a gyro log's, never one 1000×
    /// off: 2 Hz in µs suggests `us` (0.5 s steps), not `ms` (500 s); 1 Hz in ms suggests `ms`
    /// (and `us`, 1 ms steps, which a 1 kHz log has); too-small steps suggest no finer unit.
    #[test]
    fn time_check_names_the_unit_that_fits() {
        let us_2hz: Vec<f64> = (0..8400).map(|i| f64::from(i) * 500_000.0).collect();
        let e = time_problem("timestamp", &us_2hz).unwrap();
        assert!(
            e.contains("--time-unit us") && !e.contains("--time-unit ms"),
            "{e}"
        );
        assert!(e.contains("timestamp: median step 500000"), "{e}");
        let ms_1hz: Vec<f64> = (0..100).map(|i| f64::from(i) * 1000.0).collect();
        let e = time_problem("t", &ms_1hz).unwrap();
        assert!(
            e.contains("--time-unit ms") && e.contains("(1 s steps)"),
            "{e}"
        );
        let tiny: Vec<f64> = (0..100).map(|i| f64::from(i) * 1e-6).collect();
        let e = time_problem("t", &tiny).unwrap();
        assert!(
            !e.contains("--time-unit ms") && !e.contains("--time-unit us"),
            "{e}"
        );
        assert!(e.contains("--time-unit s"), "{e}");
    }
}
