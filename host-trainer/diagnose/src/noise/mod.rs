//! The residual's noise model: what the tests whiten the block means by, and what the
//! bootstrap simulates.
//!
//! * [`whiten`]: the exact GLS whitener of the fitted noise's block-mean covariance, or an
//!   AR(p) filter where that is not available;
//! * [`reml`]: the gyro noise (white level, bias instability, rate random walk) fitted by
//!   REML on the block means, through the state-space form of their covariance
//!   ([`kalman`], [`covariance`]);
//! * [`allan_check`]: that model against the residual's own Allan deviation;
//! * [`allan_fit`]: the 1 Hz Allan fit that stands in for REML on records too long for it;
//! * [`replicates`]: the bootstrap's replicates of a fitted model, by the simulator's
//!   generator.

pub mod allan_check;
pub mod allan_fit;
pub mod covariance;
pub mod kalman;
pub mod reml;
pub mod replicates;
pub mod whiten;

pub use allan_check::AllanCheck;
pub use covariance::{block_mean_autocov, block_mean_cov};
pub use whiten::{ArModel, GlsWhitener, Whitener, GLS_MAX_BLOCKS};
