//! Host-side toolchain for temperature compensation of ring-laser-gyro (RLG) bias, after
//! Yu et al., Chin. Opt. Lett. 9(5) 051201 (2011).
//!
//! A library with a thin CLI (`rlg`) on top: everything the CLI does is callable from Rust.

pub mod atomic;
pub mod baselines;
pub mod bench;
pub mod cli;
pub mod closeloop;
pub mod cycles;
pub mod diagnose;
pub mod export;
pub mod export_c;
pub mod features;
pub mod fleet;
pub mod lssvm;
pub mod metrics;
pub mod model;
pub mod physics;
pub mod pipeline;
pub mod plot;
pub mod recording;
pub mod repro;
pub mod resample;
pub mod simulate;
pub mod sparse_eval;
pub mod table1;
