//! The two inputs of the 1 Hz loop, as small traits a board driver or a replay implements.

/// What went wrong with a reading, independent of the driver behind it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
#[non_exhaustive]
pub enum ErrorKind {
    /// No new sample is available (conversion not finished, recording exhausted).
    NoData,
    /// The bus or converter reported a failure.
    Bus,
    /// Anything else.
    Other,
}

/// A driver's error, mapped to an [`ErrorKind`] so the loop can count it.
pub trait SensorError: core::fmt::Debug {
    /// The kind of failure.
    fn kind(&self) -> ErrorKind;
}

/// The gyro body's temperature sensor.
pub trait TemperatureSensor {
    /// Driver error.
    type Error: SensorError;
    /// One reading, °C. Plausibility is judged by the compensator, not here.
    fn read_temp_c(&mut self) -> Result<f32, Self::Error>;
}

/// The gyro's rate output averaged over the last period.
pub trait RateSensor {
    /// Driver error.
    type Error: SensorError;
    /// One reading, °/h.
    fn read_rate_dph(&mut self) -> Result<f32, Self::Error>;
}
