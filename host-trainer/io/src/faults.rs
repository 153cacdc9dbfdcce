//! Sensor faults in a recorded temperature, found offline by the board's own rules
//! (`compensator_core::Compensator`, rules 3 and 4): an open or shorted sensor, a glitch, a
//! reading frozen on a moving body. The host tools drop such samples, which become gaps, and
//! say so: a single +30 °C glitch reaches a dT/dt model through its centred difference
//! (±0.5 °C/s in two samples), and a reading frozen on a ramp looks like a lag.

use crate::recording::Recording;

/// The limits of the rules, in the board's units (°C, samples).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultLimits {
    /// Lowest plausible temperature reading, °C.
    pub temp_min_c: f64,
    /// Highest plausible temperature reading, °C.
    pub temp_max_c: f64,
    /// Largest plausible change from the last good reading in one sample, °C.
    pub max_temp_step_c: f64,
    /// Consecutive rejected samples, agreeing with each other, after which they are the
    /// reading.
    pub max_skipped: usize,
    /// Repeats of one reading (in sample periods) after which it counts as frozen, if the body
    /// was moving when it appeared.
    pub stuck_samples: usize,
    /// Smallest change, °C, that the body's rate when the reading appeared must predict over
    /// `stuck_samples` periods.
    pub stuck_min_change_c: f64,
}

impl FaultLimits {
    /// The board's limits (`compensator_core::SensorLimits::DEFAULT`; this crate depends on
    /// none of the others, and a test of `rlg-calibrate` holds the two equal).
    pub const BOARD: FaultLimits = FaultLimits {
        temp_min_c: -60.0,
        temp_max_c: 130.0,
        max_temp_step_c: 2.0,
        max_skipped: 30,
        stuck_samples: 300,
        stuck_min_change_c: 0.5,
    };
}

/// What [`sensor_faults`] found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SensorFaults {
    /// Outside the plausible range (an open or shorted sensor).
    pub out_of_range: usize,
    /// Away from the last good reading by more than the largest plausible step (a glitch).
    pub spikes: usize,
    /// Repeats of one frozen reading where the body was moving when it froze.
    pub frozen: usize,
    /// Time of the first, s.
    pub first_s: Option<f64>,
}

impl SensorFaults {
    /// All the samples rejected.
    pub fn total(&self) -> usize {
        self.out_of_range + self.spikes + self.frozen
    }

    /// One line for a note or a warning; empty when nothing was found.
    pub fn describe(&self) -> String {
        if self.total() == 0 {
            return String::new();
        }
        format!(
            "{} temperature sample(s) rejected by the board's sensor rules and dropped as gaps: \
             {} out of range, {} glitch(es) beyond {} °C per sample, {} frozen on a moving body; \
             the first at {:.0} s",
            self.total(),
            self.out_of_range,
            self.spikes,
            FaultLimits::BOARD.max_temp_step_c,
            self.frozen,
            self.first_s.unwrap_or(f64::NAN)
        )
    }
}

/// Marks the temperature samples the board would reject (with [`FaultLimits::BOARD`]), offline (the whole record is
/// known, so a frozen span is marked from its start, not from its 300th repeat):
/// - out of `[temp_min_c, temp_max_c]`;
/// - more than `max_temp_step_c` from the last good reading (more across a gap, in
///   proportion to the time missing, so that a gap's change is not a glitch), unless
///   `max_skipped` such samples in a row agree with each other: then the reading really
///   moved (a re-seated sensor, the end of a frozen span), and they are taken back;
/// - bit-identical repeats lasting `stuck_samples` periods or more where the readings before
///   the span had the body moving fast enough to change by `stuck_min_change_c` in that time,
///   and the first reading after it is at least that far from the held one (a settled hold
///   reads one code for hours, and an ideal trapezoid resumes where it stopped: neither is
///   marked; a span still frozen at the end of the record cannot be told from a hold).
///
/// A glitch of +30 °C in one sample otherwise reaches the rate terms through dT/dt (its
/// centred difference puts ±0.5 °C/s into two samples); a sensor frozen on a ramp reads as
/// a lag. Both made a clean record `unexplained_structure`. `dt_s` is the sample period.
pub fn sensor_faults(
    time_s: &[f64],
    temp_c: &[f64],
    dt_s: f64,
    l: &FaultLimits,
) -> (Vec<bool>, SensorFaults) {
    let n = temp_c.len().min(time_s.len());
    let mut bad = vec![false; n];
    let mut f = SensorFaults::default();
    let (lo, hi) = (l.temp_min_c, l.temp_max_c);
    let step = l.max_temp_step_c;
    // The last good reading: (index, time, value).
    let mut last: Option<(usize, f64, f64)> = None;
    let mut rejected: Vec<usize> = Vec::new();
    for i in 0..n {
        let (t, x) = (time_s[i], temp_c[i]);
        if !(x >= lo && x <= hi) {
            bad[i] = true;
            f.out_of_range += 1;
            continue;
        }
        // The limit grows with time missing since the last good reading (a gap), not with
        // the rejected samples in between: a glitch stays a glitch however long it lasts.
        let ok = last.is_none_or(|(k0, t0, x0)| {
            let missing = (t - t0) - (i - k0 - 1) as f64 * dt_s;
            (x - x0).abs() <= step * (missing / dt_s).max(1.0)
        });
        if ok {
            rejected.clear();
            last = Some((i, t, x));
            continue;
        }
        // A new level that holds for `max_skipped` samples is the reading, not a glitch.
        if rejected
            .last()
            .is_some_and(|&j| (x - temp_c[j]).abs() > step * ((t - time_s[j]) / dt_s).max(1.0))
        {
            rejected.clear();
        }
        rejected.push(i);
        bad[i] = true;
        if rejected.len() >= l.max_skipped {
            for &j in &rejected {
                bad[j] = false;
            }
            rejected.clear();
            last = Some((i, t, x));
        }
    }
    f.spikes = bad.iter().filter(|b| **b).count() - f.out_of_range;
    // Frozen spans: runs of one bit-identical good reading.
    let span_s = l.stuck_samples as f64 * dt_s;
    let mut i = 0;
    while i < n {
        if bad[i] {
            i += 1;
            continue;
        }
        let mut j = i;
        while j + 1 < n && !bad[j + 1] && temp_c[j + 1].to_bits() == temp_c[i].to_bits() {
            j += 1;
        }
        if time_s[j] - time_s[i] >= span_s {
            // The body's rate when the reading froze: the good readings' changes over the
            // last minute, a step beyond the per-sample limit left out (a re-seated sensor,
            // not a moving body).
            let mut k0 = i;
            let mut moved = 0.0;
            while k0 > 0 && time_s[i] - time_s[k0] < 60.0 {
                let d = temp_c[k0] - temp_c[k0 - 1];
                let limit = step * ((time_s[k0] - time_s[k0 - 1]) / dt_s).max(1.0);
                if !bad[k0] && !bad[k0 - 1] && d.abs() <= limit {
                    moved += d;
                }
                k0 -= 1;
            }
            // And when it thawed, the reading jumped to where the body had gone: a reading
            // that resumes where it stopped (a setpoint-like trapezoid) was a hold.
            let thawed = (j + 1..n).find(|&m| !bad[m]).map(|m| temp_c[m]);
            let jumped = thawed.is_some_and(|x| (x - temp_c[i]).abs() >= l.stuck_min_change_c);
            if k0 < i && jumped {
                let rate = moved / (time_s[i] - time_s[k0]);
                if rate.abs() * span_s >= l.stuck_min_change_c {
                    for b in &mut bad[i + 1..=j] {
                        *b = true;
                    }
                    f.frozen += j - i;
                }
            }
        }
        i = j + 1;
    }
    f.first_s = bad.iter().position(|b| *b).map(|i| time_s[i]);
    (bad, f)
}

impl Recording {
    /// The recording without the samples marked in `drop` (every column, the unknown ones
    /// too).
    pub fn without(&self, drop: &[bool]) -> Recording {
        let keep = |v: &[f64]| -> Vec<f64> {
            v.iter()
                .zip(drop)
                .filter(|(_, d)| !**d)
                .map(|(x, _)| *x)
                .collect()
        };
        Recording {
            time_s: keep(&self.time_s),
            rate_dph: keep(&self.rate_dph),
            temp_c: keep(&self.temp_c),
            chamber_c: self.chamber_c.as_deref().map(keep),
            extra: self
                .extra
                .iter()
                .map(|(name, v)| {
                    let kept = v
                        .iter()
                        .zip(drop)
                        .filter(|(_, d)| !**d)
                        .map(|(x, _)| x.clone())
                        .collect();
                    (name.clone(), kept)
                })
                .collect(),
            comments: self.comments.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The board's sensor rules, offline: a glitch and an open-circuit reading are marked, a
    /// frozen reading on a ramp is marked from its second sample, a settled hold's long run
    /// of one code is not, nor is a gap's change, and a new level held for `max_skipped`
    /// samples is taken as the reading.
    #[test]
    fn sensor_faults_follow_the_boards_rules() {
        let t: Vec<f64> = (0..4000).map(f64::from).collect();
        // 1 °C/min ramp for 1 000 s, then the body settles (τ 150 s) and the 0.01 °C reading
        // keeps one code for its last minutes.
        let mut x: Vec<f64> = t
            .iter()
            .map(|&t| {
                let body = if t < 1000.0 {
                    20.0 + t / 60.0
                } else {
                    20.0 + 1000.0 / 60.0 + 10.0 * (1.0 - (-(t - 1000.0) / 150.0).exp())
                };
                (body * 100.0).round() / 100.0
            })
            .collect();
        x[300] += 25.0;
        x[310] = 150.0;
        let frozen = x[499];
        for v in &mut x[500..900] {
            *v = frozen;
        }
        // A real step of 5 °C held from 3 000 s on (a sensor re-seated).
        for v in &mut x[3000..] {
            *v += 5.0;
        }
        let (bad, f) = sensor_faults(&t, &x, 1.0, &FaultLimits::BOARD);
        assert_eq!((f.out_of_range, f.frozen), (1, 400));
        assert!(bad[300] && bad[310] && bad[500] && bad[899] && !bad[499]);
        // The settling body reads one code for minutes: never marked.
        assert!(x[2000..3000].iter().filter(|v| **v == x[2999]).count() > 300);
        assert!(!bad[1001..3000].iter().any(|b| *b));
        // The new level is the reading after `max_skipped` samples (those taken back).
        assert!(!bad[3000..].iter().any(|b| *b), "{f:?}");
        // The jump back after the frozen span is a new level that holds: taken back.
        assert_eq!(f.spikes, 1, "{f:?}");
        assert!(!bad[900..1000].iter().any(|b| *b));
        // A reading that stops dead after a ramp and resumes where it stopped (an ideal
        // trapezoid, as a setpoint is) is a hold, not a frozen sensor.
        let tz: Vec<f64> = (0..2000).map(f64::from).collect();
        let xz: Vec<f64> = tz
            .iter()
            .map(|&t| 20.0 + t.min(600.0) / 60.0 + (t - 1400.0).max(0.0) / 60.0)
            .collect();
        assert_eq!(
            sensor_faults(&tz, &xz, 1.0, &FaultLimits::BOARD).1.total(),
            0
        );
        // Across a gap of 10 min a change of 10 °C is not a glitch.
        let tg = vec![0.0, 1.0, 2.0, 602.0, 603.0];
        let xg = vec![20.0, 20.0, 20.0, 30.0, 30.0];
        assert_eq!(
            sensor_faults(&tg, &xg, 1.0, &FaultLimits::BOARD).1.total(),
            0
        );
    }
}
