//! How a log was sampled: a stream (its median step) or bursts (a logger that wakes every few
//! minutes for a few seconds at tens of Hz, as MEMS thermal logs are made). Shared by the
//! calibration, which averages a fast stream to the board's 1 Hz and takes a bursty log to a
//! temperature-only model, and the diagnosis, which works on burst means.

use std::ops::Range;

/// A step between bursts is at least this many median steps (steps within a burst jitter).
pub const BURST_GAP: f64 = 10.0;

/// A record sampled in bursts: how many, and their typical shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bursts {
    /// Number of bursts.
    pub count: usize,
    /// Median samples per burst.
    pub samples: usize,
    /// Median duration of a burst, s.
    pub length_s: f64,
    /// Median time from one burst's start to the next's, s.
    pub period_s: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The median step of `time_s`, s (`None` below two samples).
pub fn median_step_s(time_s: &[f64]) -> Option<f64> {
    (time_s.len() >= 2).then(|| median(time_s.windows(2).map(|w| w[1] - w[0]).collect()))
}

/// The bursts of a record sampled at `time_s` and their index ranges, when it is sampled in
/// bursts: runs split at steps over [`BURST_GAP`] median steps, at least `min_runs` of them,
/// the median run shorter than `max_length_s`, and runs starting at least twice their length
/// apart. A record with dropouts has runs of hours and is not one.
pub fn find_bursts(
    time_s: &[f64],
    min_runs: usize,
    max_length_s: f64,
) -> Option<(Vec<Range<usize>>, Bursts)> {
    let n = time_s.len();
    if n < 3 {
        return None;
    }
    let step = median_step_s(time_s)?;
    let mut runs = Vec::new();
    let mut start = 0;
    for i in 1..n {
        if time_s[i] - time_s[i - 1] > BURST_GAP * step {
            runs.push(start..i);
            start = i;
        }
    }
    runs.push(start..n);
    if runs.len() < min_runs.max(2) {
        return None;
    }
    let length_s = median(
        runs.iter()
            .map(|r| time_s[r.end - 1] - time_s[r.start] + step)
            .collect(),
    );
    let period_s = median(
        runs.windows(2)
            .map(|w| time_s[w[1].start] - time_s[w[0].start])
            .collect(),
    );
    if length_s >= max_length_s || period_s < 2.0 * length_s {
        return None;
    }
    let mut sizes: Vec<usize> = runs.iter().map(|r| r.len()).collect();
    sizes.sort_unstable();
    let b = Bursts {
        count: runs.len(),
        samples: sizes[sizes.len() / 2],
        length_s,
        period_s,
    };
    Some((runs, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Five seconds at 50 Hz every three minutes is bursty; a 1 Hz stream with two dropouts
    /// is not.
    #[test]
    fn bursts_and_dropouts_are_told_apart() {
        let mut t = Vec::new();
        for b in 0..40 {
            for k in 0..250 {
                t.push(180.0 * f64::from(b) + f64::from(k) / 50.0);
            }
        }
        let (runs, b) = find_bursts(&t, 5, 50.0).expect("bursty");
        assert_eq!((runs.len(), b.count, b.samples), (40, 40, 250));
        assert!((b.period_s - 180.0).abs() < 1e-9 && (b.length_s - 5.0).abs() < 1e-9);
        let mut s: Vec<f64> = (0..20_000).map(f64::from).collect();
        for v in &mut s[5_000..] {
            *v += 3_600.0;
        }
        for v in &mut s[12_000..] {
            *v += 900.0;
        }
        assert!(find_bursts(&s, 5, 50.0).is_none());
        assert_eq!(median_step_s(&s), Some(1.0));
    }
}
