//! `rlg`, the host toolchain for temperature compensation of ring-laser-gyro (RLG) bias after
//! Yu et al., Chin. Opt. Lett. 9(5) 051201 (2011): the command line over the library crates.
//!
//! Everything the CLI does is callable from Rust, in the crates it calls: the product path
//! (`rlg-io` → `rlg-train` → `rlg-eval`, with `rlg-physics`) never depends on the lab
//! (`rlg-simulate`, `rlg-diagnose`, `rlg-closeloop`, `rlg-repro`, `rlg-benchmarks`); this
//! crate depends on both because the diagnosis is a user-facing command.

pub mod cli;
