//! Counts per status bit and per sensor failure, for the log summary.

use compensator_core::Status;

use crate::record::Record;

/// Every status bit with the name used in the log summary, in bit order.
pub const STATUS_BITS: [(Status, &str); 6] = [
    (Status::WARMING_UP, "warming_up"),
    (Status::OUT_OF_RANGE, "out_of_range"),
    (Status::TEMP_FAULT, "temp_fault"),
    (Status::GYRO_FAULT, "gyro_fault"),
    (Status::TABLE_FAULT, "table_fault"),
    (Status::TEMP_STUCK, "temp_stuck"),
];

/// Running counts over the processed samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    /// Samples processed.
    pub samples: u32,
    /// Samples with no status bit set.
    pub ok: u32,
    /// Samples with each bit of [`STATUS_BITS`] set, same order.
    pub per_bit: [u32; 6],
    /// Failed temperature reads.
    pub temp_sensor_errors: u32,
    /// Failed gyro reads.
    pub rate_sensor_errors: u32,
    /// Fault bits of the previous record.
    last_faults: Status,
}

/// The status bits that mark a fault ([`Status::is_fault`]).
const FAULT_BITS: Status = Status(
    Status::TEMP_FAULT.0 | Status::GYRO_FAULT.0 | Status::TABLE_FAULT.0 | Status::TEMP_STUCK.0,
);

impl Summary {
    /// Counts one record; returns the fault bits that this record sets and the previous one
    /// did not (the onsets the board logs), `Status::OK` when none.
    pub fn add(&mut self, r: &Record) -> Status {
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
        let faults = Status(r.out.status.0 & FAULT_BITS.0);
        let onset = Status(faults.0 & !self.last_faults.0);
        self.last_faults = faults;
        onset
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
    fn fault_onsets_are_reported_once() {
        use compensator_core::Compensated;
        let rec = |status: Status| Record {
            index: 0,
            temp_c: 20.0,
            gyro_dph: -7.0,
            out: Compensated {
                rate_dph: -7.0,
                correction_dph: 0.0,
                status,
            },
            temp_error: None,
            rate_error: None,
        };
        let mut s = Summary::default();
        let seq = [
            (Status::WARMING_UP, Status::OK),
            (Status::TEMP_FAULT, Status::TEMP_FAULT),
            (Status::TEMP_FAULT, Status::OK),
            (Status::TEMP_FAULT | Status::GYRO_FAULT, Status::GYRO_FAULT),
            (Status::OK, Status::OK),
            (
                Status::TEMP_STUCK | Status::OUT_OF_RANGE,
                Status::TEMP_STUCK,
            ),
        ];
        for (status, onset) in seq {
            assert_eq!(s.add(&rec(status)), onset, "{status:?}");
        }
        assert_eq!(s.count(Status::TEMP_FAULT), 3);
        assert_eq!(s.count(Status::TEMP_STUCK), 1);
        assert_eq!((s.samples, s.ok), (6, 1));
    }

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
