//! How a record is cut into blocks: the 100 s means the diagnosis fits, longer blocks on a
//! long record, and the shortest and longest records it takes.

/// Length of the averaging blocks, s (the paper's 100 s means).
pub const BLOCK_S: f64 = 100.0;

/// Most samples a diagnosis takes (46 days at 1 Hz): its per-sample series then stay within
/// about 1.2 GB (0.8 GB at 30 days).
pub const MAX_SAMPLES: usize = 4_000_000;

/// Minimum number of 100 s blocks for a diagnosis (about 5.5 h).
pub const MIN_BLOCKS: usize = 200;

/// Most blocks a diagnosis works on (4.6 days of 100 s blocks). A longer record is averaged
/// over longer blocks, whole multiples of [`BLOCK_S`], so that the work on block means (the
/// scan, the bootstrap, the noise fit) and the periodic grid, whose resolution follows the
/// record's length, stay bounded: time and memory then grow with the record only through the
/// per-sample columns. Slow effects keep their power (a 30-day record in 700 s blocks still
/// has 3 700 of them); effects faster than a block were already beyond 100 s means.
pub const MAX_BLOCKS: usize = 4000;

/// Shorter blocks a record too short for [`MIN_BLOCKS`] of [`BLOCK_S`] is cut into, longest
/// first, s: a MEMS chamber run of an hour or two still gives [`MIN_BLOCKS`] means of 10 or
/// 20 s, and its bias, moving fast against its noise, is resolved by them (the 100 s block is
/// an RLG convention). Below 10 s the noise model's block means would no longer be near
/// Gaussian on a quantised output, so a record under [`MIN_BLOCKS`] × 10 s stays refused.
pub const SHORT_BLOCKS_S: [f64; 3] = [50.0, 20.0, 10.0];

/// Samples per block for `n` samples `dt_s` apart: [`BLOCK_S`], or the smallest whole
/// multiple of it that keeps the record within [`MAX_BLOCKS`] blocks, or on a record with
/// fewer than [`MIN_BLOCKS`] of them the longest of [`SHORT_BLOCKS_S`] that gives that many.
pub fn block_samples(n: usize, dt_s: f64) -> usize {
    let samples = |s: f64| (s / dt_s).round().max(1.0) as usize;
    let base = samples(BLOCK_S);
    if n / base < MIN_BLOCKS {
        if let Some(b) = SHORT_BLOCKS_S
            .iter()
            .map(|&s| samples(s))
            // A margin for the samples the dT/dt estimate drops at the start.
            .find(|&b| n / b >= MIN_BLOCKS + 10)
        {
            return b;
        }
    }
    let k = n.div_ceil(base * MAX_BLOCKS).max(1);
    base * k
}
