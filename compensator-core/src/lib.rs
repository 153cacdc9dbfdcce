//! Temperature compensation of ring-laser-gyro (RLG) bias on the gyro's readout board.
//!
//! Evaluates the LS-SVM regression of Yu et al., Chin. Opt. Lett. 9(5) 051201 (2011),
//! Eq. (10) with the Gaussian kernel of Eq. (8), from a const table exported by `host-trainer`,
//! and computes its input features recursively at 1 Hz with O(1) state.
//!
//! `no_std`, no heap, no panics on any input: the hot path clamps or passes the raw rate
//! through and reports what it did in a [`Status`] bit set.
//!
//! * [`table`]: the exported model table and its validation.
//! * [`features`]: recursive lead, lagged-gradient, play and time-on features.
//! * [`fastexp`]: a faster kernel exp, offered with its measured accuracy cost.
//! * [`fixed`]: integer-only evaluation of Eq. (10) for FPU-less boards, and the compensator
//!   around it ([`fixed::FixedCompensator`]).
//! * [`crc`]: the table's CRC-32, computed at export and checked at boot.
//! * [`lssvm`]: f32 evaluation of Eq. (10).
//! * [`physics`]: the recursive physics primitives (lag, play, lead, decay), generic over
//!   the float type: f32 here, f64 in the host's simulator and diagnosis.
//! * [`rate`]: the recursive dT/dt estimator shared by the trainer and the board.
//! * [`compensator`]: the 1 Hz update that turns (temperature, gyro rate) into a compensated rate.
#![cfg_attr(not(any(test, feature = "std")), no_std)]

pub mod compensator;
pub mod crc;
pub mod fastexp;
pub mod features;
pub mod fixed;
pub mod lssvm;
pub mod physics;
pub mod rate;
pub mod table;

pub use compensator::{Compensated, Compensator, SensorLimits, Status};
pub use rate::{RateEstimate, RateEstimator, RateFilter};
pub use table::{Feature, ModelRef, ModelSpec, ModelTable, TableError};
