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

/// Samples per block for `n` samples `dt_s` apart: [`BLOCK_S`], or the smallest whole
/// multiple of it that keeps the record within [`MAX_BLOCKS`] blocks.
pub fn block_samples(n: usize, dt_s: f64) -> usize {
    let base = (BLOCK_S / dt_s).round().max(1.0) as usize;
    let k = n.div_ceil(base * MAX_BLOCKS).max(1);
    base * k
}
