//! One processed sample of the 1 Hz loop: what [`crate::control`] produces and
//! [`crate::summary`] and [`crate::wire`] consume.

use compensator_core::Compensated;

use crate::sensor::ErrorKind;

/// One processed sample: inputs as read and the compensator's output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    /// Sample number since start (one per period).
    pub index: u32,
    /// Temperature as fed to the compensator, °C (NaN when the sensor failed).
    pub temp_c: f32,
    /// Gyro rate as fed to the compensator, °/h (NaN when the sensor failed).
    pub gyro_dph: f32,
    /// Compensated rate, correction and status bits.
    pub out: Compensated,
    /// The temperature driver's error, if it failed.
    pub temp_error: Option<ErrorKind>,
    /// The gyro driver's error, if it failed.
    pub rate_error: Option<ErrorKind>,
}
