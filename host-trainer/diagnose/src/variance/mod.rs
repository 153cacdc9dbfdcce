//! The noise-scale test (`heteroscedastic`: white-noise σ multiplier 1 + k·((T − ref)/30)²),
//! on the 1 Hz samples' variance within each block:
//!
//! * [`hetero`]: the test itself, its bootstrap replicate and held-out check;
//! * [`fit`]: the term's parameters fitted to the block log-scales;
//! * [`detrend`]: each block's variance about its line, or a polynomial where the rate
//!   curves within blocks;
//! * [`counts`]: an undithered count's own variance, taken out of each block's;
//! * [`tails`]: heavy-tailed white noise and the log-scale taken on it.

pub mod counts;
pub mod detrend;
mod fit;
pub mod hetero;
pub mod tails;

#[cfg(test)]
mod tests;

pub use counts::{output_quantum, MIN_COUNT_SIGMA};
pub use detrend::line_variance;
pub use hetero::{
    heldout_variance, heteroscedastic_detectability, log_scale, LevelInTime, VarianceTest,
};
