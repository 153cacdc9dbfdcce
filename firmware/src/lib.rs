//! Logic of the RLG readout board's firmware, built and tested on the host as well.
//!
//! * [`sensor`]: the `TemperatureSensor` / `RateSensor` traits a board driver implements.
//! * [`replay`]: a recording replayed through those traits (the QEMU image's input).
//! * [`control`]: the 1 Hz loop around [`compensator_core::Compensator`].
//! * [`summary`]: counts per status bit and update cost, for the log summary.
//! * [`wire`]: the line format of the sample stream the QEMU image writes.
//! * [`model_table`]: the model flashed with the image.
//!
//! The board-only code (runtime, semihosting, logging) is in `main.rs` behind
//! `#[cfg(target_os = "none")]`.
#![cfg_attr(not(test), no_std)]

pub mod control;
pub mod model_table;
pub mod replay;
pub mod sensor;
pub mod summary;
pub mod wire;

pub use control::{ControlLoop, Record};
pub use sensor::{ErrorKind, RateSensor, SensorError, TemperatureSensor};
