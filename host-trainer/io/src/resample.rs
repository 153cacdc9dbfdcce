//! Logs that are not a uniform 1 Hz stream, brought to the recording the trainer reads, by
//! two documented rules (`rlg resample`):
//!
//! * [`bin_means`] (high-rate or jittered continuous logs, e.g. 50 Hz): samples are averaged
//!   in periods of P seconds aligned on the first sample, bin k covering
//!   [t₀ + kP, t₀ + (k+1)P) and stamped t₀ + kP; empty bins are left out, so gaps stay gaps
//!   (the features bridge them as the board bridges missing samples, and report them).
//! * [`burst_means`] (bursty logs, e.g. 250 samples at 50 Hz every 5 min): a burst is a run of
//!   samples whose steps are at most `burst_gap_factor` times the median step; each burst
//!   becomes one sample at its mean time with its mean rate and temperature, and two extra
//!   columns: `samples` (count) and `rate_sem_dph` (standard error of the mean rate, °/h).
//!   The result has one sample per burst: what a static or slow characterisation needs. A
//!   model on dT/dt needs the board's 1 Hz stream, which a bursty log does not hold; the
//!   trainer's feature pipeline then says so (the gaps restart its estimator).
//!
//! Columns other than `chamber_c` cannot be averaged and are dropped, with a comment saying so.

use crate::recording::Recording;

/// What a resampling did.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// Samples read.
    pub input_samples: usize,
    /// Samples written.
    pub output_samples: usize,
    /// Gaps in the output (steps longer than 1.5 output periods; for bursts: between bursts).
    pub gaps: usize,
    /// Longest gap, s.
    pub longest_gap_s: f64,
    /// Extra columns dropped.
    pub dropped_columns: Vec<String>,
}

/// Why a log could not be resampled.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ResampleError {
    /// The period or the burst factor is not a positive finite number.
    #[error("{what} = {value} must be a positive finite number")]
    Parameter {
        /// Which parameter.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// Fewer than two samples.
    #[error("a recording of {0} sample(s) cannot be resampled")]
    TooShort(usize),
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn gaps(times: &[f64], step: f64) -> (usize, f64) {
    times
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 1.5 * step)
        .fold((0, 0.0), |(n, m), d| (n + 1, f64::max(m, d)))
}

/// Groups the samples (given as index runs) into a recording of their means.
fn averaged(
    rec: &Recording,
    runs: &[(usize, usize)],
    stamp: impl Fn(usize, &[f64]) -> f64,
) -> Recording {
    // One sample per run: sized up front, as the input may hold 10⁷ samples.
    let n = runs.len();
    let mut out = Recording {
        time_s: Vec::with_capacity(n),
        rate_dph: Vec::with_capacity(n),
        temp_c: Vec::with_capacity(n),
        comments: rec.comments.clone(),
        chamber_c: rec.chamber_c.as_ref().map(|_| Vec::with_capacity(n)),
        ..Recording::default()
    };
    for (k, &(a, b)) in runs.iter().enumerate() {
        out.time_s.push(stamp(k, &rec.time_s[a..b]));
        out.rate_dph.push(mean(&rec.rate_dph[a..b]));
        out.temp_c.push(mean(&rec.temp_c[a..b]));
        if let (Some(o), Some(c)) = (out.chamber_c.as_mut(), rec.chamber_c.as_ref()) {
            o.push(mean(&c[a..b]));
        }
    }
    out
}

fn dropped(rec: &Recording, out: &mut Recording, rule: &str) -> Vec<String> {
    let names: Vec<String> = rec.extra.iter().map(|(n, _)| n.clone()).collect();
    out.comments.push(format!(" resampled: {rule}"));
    if !names.is_empty() {
        out.comments.push(format!(
            " columns not averaged, dropped: {}",
            names.join(", ")
        ));
    }
    names
}

/// Means over periods of `period_s` (see the module doc).
pub fn bin_means(rec: &Recording, period_s: f64) -> Result<(Recording, Report), ResampleError> {
    if !(period_s > 0.0 && period_s.is_finite()) {
        return Err(ResampleError::Parameter {
            what: "period_s",
            value: period_s,
        });
    }
    if rec.len() < 2 {
        return Err(ResampleError::TooShort(rec.len()));
    }
    let t0 = rec.time_s[0];
    let bin = |t: f64| ((t - t0) / period_s).floor() as u64;
    let mut runs = Vec::new();
    let mut keys = Vec::new();
    let mut a = 0;
    for i in 1..=rec.len() {
        if i == rec.len() || bin(rec.time_s[i]) != bin(rec.time_s[a]) {
            runs.push((a, i));
            keys.push(bin(rec.time_s[a]));
            a = i;
        }
    }
    let mut out = averaged(rec, &runs, |k, _| t0 + keys[k] as f64 * period_s);
    let dropped_columns = dropped(
        rec,
        &mut out,
        &format!("means over {period_s} s periods from t0 = {t0} s, stamped at the period start"),
    );
    let (n_gaps, longest) = gaps(&out.time_s, period_s);
    let report = Report {
        input_samples: rec.len(),
        output_samples: out.len(),
        gaps: n_gaps,
        longest_gap_s: longest,
        dropped_columns,
    };
    Ok((out, report))
}

/// One mean per burst (see the module doc).
pub fn burst_means(
    rec: &Recording,
    burst_gap_factor: f64,
) -> Result<(Recording, Report), ResampleError> {
    if !(burst_gap_factor > 0.0 && burst_gap_factor.is_finite()) {
        return Err(ResampleError::Parameter {
            what: "burst_gap_factor",
            value: burst_gap_factor,
        });
    }
    if rec.len() < 2 {
        return Err(ResampleError::TooShort(rec.len()));
    }
    let mut steps: Vec<f64> = rec.time_s.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let step = steps[steps.len() / 2];
    let mut runs = Vec::new();
    let mut a = 0;
    for i in 1..=rec.len() {
        if i == rec.len() || rec.time_s[i] - rec.time_s[i - 1] > burst_gap_factor * step {
            runs.push((a, i));
            a = i;
        }
    }
    let mut out = averaged(rec, &runs, |_, t| mean(t));
    let counts: Vec<String> = runs.iter().map(|(a, b)| (b - a).to_string()).collect();
    let sems: Vec<String> = runs
        .iter()
        .map(|&(a, b)| {
            let v = &rec.rate_dph[a..b];
            let n = v.len() as f64;
            if v.len() < 2 {
                return "nan".to_string();
            }
            let m = mean(v);
            let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
            format!("{:.3e}", (var / n).sqrt())
        })
        .collect();
    let dropped_columns = dropped(
        rec,
        &mut out,
        &format!(
            "one mean per burst (bursts split at steps over {burst_gap_factor} × the median step {step} s)"
        ),
    );
    out.extra.push(("samples".into(), counts));
    out.extra.push(("rate_sem_dph".into(), sems));
    // Every step between burst means is a gap by construction.
    let longest = out
        .time_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(0.0, f64::max);
    let report = Report {
        input_samples: rec.len(),
        output_samples: out.len(),
        gaps: out.len() - 1,
        longest_gap_s: longest,
        dropped_columns,
    };
    Ok((out, report))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 250 samples at 50 Hz every 300 s, for an hour: 12 bursts, each averaged to its mean
    /// time, rate and temperature (checked by hand on the first), with the count and the
    /// standard error; the output reads back as a recording.
    #[test]
    fn bursty_log_becomes_one_sample_per_burst() {
        let mut rec = Recording::default();
        for b in 0..12 {
            for k in 0..250 {
                let t = 300.0 * f64::from(b) + f64::from(k) / 50.0;
                rec.time_s.push(t);
                rec.rate_dph
                    .push(-7.1 + if k % 2 == 0 { 1e-3 } else { -1e-3 });
                rec.temp_c.push(20.0 + t / 600.0);
            }
        }
        let (out, rep) = burst_means(&rec, 10.0).unwrap();
        assert_eq!((rep.input_samples, rep.output_samples), (3000, 12));
        assert!((out.time_s[0] - 249.0 / 50.0 / 2.0).abs() < 1e-12);
        assert!((out.rate_dph[0] + 7.1).abs() < 1e-12);
        assert!((out.temp_c[1] - (20.0 + (300.0 + 2.49) / 600.0)).abs() < 1e-9);
        assert_eq!(out.extra[0].1[0], "250");
        // ±1e-3 alternating: sample std ≈ 1.002e-3, SEM ≈ 6.3e-5.
        let sem: f64 = out.extra[1].1[0].parse().unwrap();
        assert!((sem - 1e-3 * (250.0f64 / 249.0).sqrt() / 250f64.sqrt()).abs() < 1e-6);
        let back = Recording::parse_csv(&out.to_csv_string().unwrap(), "t").unwrap();
        assert_eq!(back.len(), 12);
    }

    /// A 50 Hz continuous log to 1 Hz: means per second, stamped at the second; a missing
    /// stretch stays a gap and is reported.
    #[test]
    fn high_rate_log_becomes_1_hz_means_with_gaps_kept() {
        let mut rec = Recording::default();
        for k in 0..(50 * 20) {
            if (500..650).contains(&k) {
                continue; // 3 s without data
            }
            let t = f64::from(k) / 50.0;
            rec.time_s.push(t);
            rec.rate_dph.push(f64::from(k));
            rec.temp_c.push(25.0);
        }
        let (out, rep) = bin_means(&rec, 1.0).unwrap();
        assert_eq!(out.len(), 17);
        assert_eq!(out.time_s[0], 0.0);
        assert!((out.rate_dph[0] - 24.5).abs() < 1e-12);
        assert_eq!((rep.gaps, rep.longest_gap_s), (1, 4.0));
        assert!(bin_means(&rec, 0.0).is_err());
        assert!(burst_means(&rec, f64::NAN).is_err());
    }
}
