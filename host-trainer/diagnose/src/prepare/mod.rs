//! From a recording and a physics model to the series the diagnosis fits: the driving series
//! (recorded temperature, dT/dt from the board's estimator), 100 s block means, and the
//! baseline model's columns (each linear parameter's unit contribution, computed by the
//! shared physics library).
//!
//! * [`model`]: the physics model read from a model or scenario file;
//! * [`prepared`]: the recording prepared for fitting ([`Prepared`]);
//! * [`blocks`]: how it is cut into blocks;
//! * [`bursts`]: a record sampled in bursts, reduced to burst means;
//! * [`rate`]: dT/dt by a centred difference, never across a gap;
//! * [`dequantise`]: a rounded temperature reading undone;
//! * [`drive`]: the driving series, the reading's lag or rounding undone;
//! * [`columns`]: the baseline model's columns.

pub mod blocks;
pub mod bursts;
pub mod columns;
pub mod dequantise;
pub mod drive;
pub mod model;
pub mod prepared;
pub mod rate;

pub use blocks::{block_samples, BLOCK_S, MAX_BLOCKS, MAX_SAMPLES, MIN_BLOCKS};
pub use bursts::{describe as describe_bursts, find_bursts, Bursts};
pub use columns::{baseline_columns, baseline_specs, baseline_values, Column};
pub use dequantise::{dequantise, read_quantum};
pub use drive::DriveSeries;
pub use model::{PhysicsModel, PAPER_MODEL_TOML};
pub use prepared::{model_drive, prepare, prepare_shifted, Prepared};
pub use rate::{estimate_rate, RATE_HALF_WIDTH_S};
