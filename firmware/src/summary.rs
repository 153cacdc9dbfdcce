//! Counts per status bit and per sensor failure, for the log summary.

use compensator_core::Status;

use crate::control::Record;

/// Every status bit with the name used in the log summary, in bit order.
pub const STATUS_BITS: [(Status, &str); 5] = [
    (Status::WARMING_UP, "warming_up"),
    (Status::OUT_OF_RANGE, "out_of_range"),
    (Status::TEMP_FAULT, "temp_fault"),
    (Status::GYRO_FAULT, "gyro_fault"),
    (Status::TABLE_FAULT, "table_fault"),
];

/// Running counts over the processed samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    /// Samples processed.
    pub samples: u32,
    /// Samples with no status bit set.
    pub ok: u32,
    /// Samples with each bit of [`STATUS_BITS`] set, same order.
    pub per_bit: [u32; 5],
    /// Failed temperature reads.
    pub temp_sensor_errors: u32,
    /// Failed gyro reads.
    pub rate_sensor_errors: u32,
}

impl Summary {
    /// Counts one record.
    pub fn add(&mut self, r: &Record) {
        self.samples = self.samples.saturating_add(1);
        if r.out.status.is_ok() {
            self.ok = self.ok.saturating_add(1);
        }
        for (count, (bit, _)) in self.per_bit.iter_mut().zip(STATUS_BITS) {
            if r.out.status.contains(bit) {
                *count = count.saturating_add(1);
            }
        }
        self.temp_sensor_errors = self
            .temp_sensor_errors
            .saturating_add(r.temp_error.is_some() as u32);
        self.rate_sensor_errors = self
            .rate_sensor_errors
            .saturating_add(r.rate_error.is_some() as u32);
    }

    /// Samples with `bit` set (0 for a value that is not one of [`STATUS_BITS`]).
    pub fn count(&self, bit: Status) -> u32 {
        STATUS_BITS
            .iter()
            .position(|(b, _)| *b == bit)
            .map_or(0, |i| self.per_bit[i])
    }
}

/// Running SysTick statistics of one update, in ticks of the core clock's SysTick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cost {
    /// Fewest ticks of one measured call.
    pub min: u32,
    /// Most ticks of one measured call.
    pub max: u32,
    /// Sum over all calls.
    pub total: u64,
    /// Number of calls.
    pub calls: u32,
}

impl Default for Cost {
    fn default() -> Self {
        Cost {
            min: u32::MAX,
            max: 0,
            total: 0,
            calls: 0,
        }
    }
}

impl Cost {
    /// Records one measurement.
    pub fn add(&mut self, ticks: u32) {
        self.min = self.min.min(ticks);
        self.max = self.max.max(ticks);
        self.total += u64::from(ticks);
        self.calls = self.calls.saturating_add(1);
    }

    /// Mean ticks per call (0 before the first).
    pub fn mean(&self) -> u32 {
        if self.calls == 0 {
            0
        } else {
            (self.total / u64::from(self.calls)) as u32
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cost_statistics() {
        let mut c = Cost::default();
        assert_eq!(c.mean(), 0);
        for t in [10, 30, 20] {
            c.add(t);
        }
        assert_eq!((c.min, c.max, c.mean(), c.calls), (10, 30, 20, 3));
    }
}
