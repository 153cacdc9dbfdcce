//! Recording I/O for the RLG toolchain: the chamber recording (CSV in, CSV out), its sensor
//! faults, burst resampling, temperature-cycle spans, atomic file writes, the paper's Table 1, PNG plots and
//! progress bars.
//!
//! The bottom of the host crates: it depends on none of them.

pub mod atomic;
pub mod cycles;
pub mod faults;
pub mod plot;
pub mod progress;
pub mod recording;
pub mod resample;
pub mod sampling;
pub mod table1;
