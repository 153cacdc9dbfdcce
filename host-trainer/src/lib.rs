//! Host-side toolchain for temperature compensation of ring-laser-gyro (RLG) bias, after
//! Yu et al., Chin. Opt. Lett. 9(5) 051201 (2011).
//!
//! A library with a thin CLI (`rlg`) on top: everything the CLI does is callable from Rust.

pub mod recording;
pub mod metrics;
pub mod baselines;
pub mod table1;
pub mod plot;
