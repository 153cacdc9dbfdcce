//! A record sampled in bursts (a logger that wakes every few minutes for a few seconds),
//! recognised and reduced to one mean per burst.

use super::blocks::{BLOCK_S, MIN_BLOCKS};
use rlg_io::recording::Recording;

/// A record sampled in bursts (a logger that wakes every few minutes for a few seconds at
/// tens of Hz, as MEMS thermal logs are made): how many, and their typical shape.
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

impl Bursts {
    /// The note the diagnosis gives.
    pub fn describe(&self) -> String {
        format!(
            "the record is sampled in bursts ({} of about {} samples over {:.1} s, one every \
             {:.0} s): each burst is reduced to its mean (time, rate, temperature) and the \
             diagnosis runs on the burst means; the noise-scale test, which needs several \
             samples within a block, is not run",
            self.count, self.samples, self.length_s, self.period_s
        )
    }
}

/// The runs of a record sampled in bursts, or `None` for a record sampled throughout (gaps
/// and all). Runs are split at steps over [`BURST_GAP`] times the median step (not the
/// reader's 1.5: a logger's time stamps jitter within a burst, and a burst split in two would
/// be two means a fraction of a second apart). A record is taken as burst-sampled when it
/// has at least [`MIN_BLOCKS`] runs, its median run lasts under half a block ([`BLOCK_S`])
/// and runs start at least twice their length apart: in 100 s blocks of consecutive samples
/// each block would then span many bursts and hours (a day of 5 s bursts at 1 Hz every
/// 2 min gives 38 blocks, too few to diagnose).
/// A record with dropouts has runs of hours and stays as it is.
pub fn find_bursts(time_s: &[f64]) -> Option<(Vec<std::ops::Range<usize>>, Bursts)> {
    let n = time_s.len();
    if n < 3 {
        return None;
    }
    let median = |mut v: Vec<f64>| -> f64 {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let step = median(time_s.windows(2).map(|w| w[1] - w[0]).collect());
    let mut runs = Vec::new();
    let mut start = 0;
    for i in 1..n {
        if time_s[i] - time_s[i - 1] > BURST_GAP * step {
            runs.push(start..i);
            start = i;
        }
    }
    runs.push(start..n);
    if runs.len() < MIN_BLOCKS {
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
    if length_s >= 0.5 * BLOCK_S || period_s < 2.0 * length_s {
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

/// A step between bursts is at least this many median steps.
const BURST_GAP: f64 = 10.0;

/// The recording of one sample per run of `runs`: the means of its time, rate, temperature
/// and chamber temperature. Columns this crate does not interpret are not carried.
pub(super) fn burst_means(rec: &Recording, runs: &[std::ops::Range<usize>]) -> Recording {
    let mean = |v: &[f64]| -> Vec<f64> {
        runs.iter()
            .map(|r| v[r.clone()].iter().sum::<f64>() / r.len() as f64)
            .collect()
    };
    Recording {
        time_s: mean(&rec.time_s),
        rate_dph: mean(&rec.rate_dph),
        temp_c: mean(&rec.temp_c),
        chamber_c: rec.chamber_c.as_deref().map(mean),
        extra: Vec::new(),
        comments: rec.comments.clone(),
    }
}
