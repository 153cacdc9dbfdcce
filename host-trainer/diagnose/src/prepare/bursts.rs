//! A record sampled in bursts (a logger that wakes every few minutes for a few seconds),
//! recognised and reduced to one mean per burst.

use super::blocks::{BLOCK_S, MIN_BLOCKS};
use rlg_io::recording::Recording;

pub use rlg_io::sampling::Bursts;

/// The note the diagnosis gives on a record sampled in bursts.
pub fn describe(b: &Bursts) -> String {
    format!(
        "the record is sampled in bursts ({} of about {} samples over {:.1} s, one every \
         {:.0} s): each burst is reduced to its mean (time, rate, temperature) and the \
         diagnosis runs on the burst means; the noise-scale test, which needs several \
         samples within a block, is not run",
        b.count, b.samples, b.length_s, b.period_s
    )
}

/// The runs of a record sampled in bursts, or `None` for a record sampled throughout (gaps
/// and all): the shared rule ([`rlg_io::sampling::find_bursts`]) with at least
/// [`MIN_BLOCKS`] runs and the median run under half a block ([`BLOCK_S`]). In 100 s blocks
/// of consecutive samples each block would then span many bursts and hours (a day of 5 s
/// bursts at 1 Hz every 2 min gives 38 blocks, too few to diagnose). A record with dropouts
/// has runs of hours and stays as it is.
pub fn find_bursts(time_s: &[f64]) -> Option<(Vec<std::ops::Range<usize>>, Bursts)> {
    rlg_io::sampling::find_bursts(time_s, MIN_BLOCKS, 0.5 * BLOCK_S)
}

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
