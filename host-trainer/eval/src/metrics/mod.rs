//! Figures of merit of a rate series, as a gyro test lab reports them.

pub mod allan;
pub mod allan_edf;
pub mod stability;

pub use stability::{
    bias_stability_dph, bias_stability_gapless_dph, block_means, gapless_block_means, max_abs, rms,
};
pub mod compare;
