//! A recording replayed through the sensor traits, for the QEMU image and host tests.

pub mod format;

pub use format::{FormatError, ReplayData};

use crate::sensor::{ErrorKind, RateSensor, SensorError, TemperatureSensor};

/// Reading past the end of the recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Exhausted {
    /// The sample index that was asked for.
    pub index: u32,
}

impl SensorError for Exhausted {
    fn kind(&self) -> ErrorKind {
        ErrorKind::NoData
    }
}

impl core::fmt::Display for Exhausted {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "replay has no sample {}", self.index)
    }
}

/// The temperature channel of a replay: one recorded sample per read.
#[derive(Clone, Debug)]
pub struct ReplayTemperature<'a> {
    data: ReplayData<'a>,
    next: u32,
}

/// The gyro channel of a replay: one recorded sample per read.
#[derive(Clone, Debug)]
pub struct ReplayRate<'a> {
    data: ReplayData<'a>,
    next: u32,
}

/// Two independent cursors over the same recording, one per sensor.
pub fn channels(data: ReplayData<'_>) -> (ReplayTemperature<'_>, ReplayRate<'_>) {
    (
        ReplayTemperature { data, next: 0 },
        ReplayRate { data, next: 0 },
    )
}

impl TemperatureSensor for ReplayTemperature<'_> {
    type Error = Exhausted;
    fn read_temp_c(&mut self) -> Result<f32, Exhausted> {
        let index = self.next;
        let (temp_c, _) = self.data.sample(index).ok_or(Exhausted { index })?;
        self.next = index.saturating_add(1);
        Ok(temp_c)
    }
}

impl RateSensor for ReplayRate<'_> {
    type Error = Exhausted;
    fn read_rate_dph(&mut self) -> Result<f32, Exhausted> {
        let index = self.next;
        let (_, rate_dph) = self.data.sample(index).ok_or(Exhausted { index })?;
        self.next = index.saturating_add(1);
        Ok(rate_dph)
    }
}
