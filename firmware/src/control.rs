//! The 1 Hz loop: read both sensors, run [`Compensator::update`], count what happened.
//!
//! A failed reading is fed to the compensator as NaN, so the compensator's own fault rules
//! (hold the last good rate, pass the raw rate through) apply to a dead sensor exactly as to an
//! implausible reading; the loop only counts the driver errors.

use compensator_core::{Compensator, ModelTable, SensorLimits, Status};
use embedded_hal::delay::DelayNs;

use crate::record::Record;
use crate::sensor::{RateSensor, SensorError, TemperatureSensor};
use crate::summary::Summary;

/// The loop state: the compensator, both sensors and the running summary.
pub struct ControlLoop<'m, T, R, const D: usize> {
    compensator: Compensator<'m, D>,
    temp: T,
    rate: R,
    index: u32,
    summary: Summary,
    onset: Status,
}

impl<'m, T: TemperatureSensor, R: RateSensor, const D: usize> ControlLoop<'m, T, R, D> {
    /// A loop over `table` with the given sensors and plausibility limits; the table's CRC-32
    /// and content are checked here, once ([`Compensator::from_table`]).
    pub fn new<const N: usize>(
        table: &'m ModelTable<N, D>,
        limits: SensorLimits,
        temp: T,
        rate: R,
    ) -> Self {
        ControlLoop {
            compensator: Compensator::from_table(table, limits),
            temp,
            rate,
            index: 0,
            summary: Summary::default(),
            onset: Status::OK,
        }
    }

    /// Whether the model table passed validation (if not, every sample is `TABLE_FAULT`).
    pub fn table_ok(&self) -> bool {
        self.compensator.table_ok()
    }

    /// Why the table was rejected, if it was.
    pub fn table_error(&self) -> Option<compensator_core::TableError> {
        self.compensator.table_error()
    }

    /// Counts so far.
    pub fn summary(&self) -> &Summary {
        &self.summary
    }

    /// Processes one sample; never fails.
    pub fn step(&mut self) -> Record {
        let (temp_c, temp_error) = match self.temp.read_temp_c() {
            Ok(t) => (t, None),
            Err(e) => (f32::NAN, Some(e.kind())),
        };
        let (gyro_dph, rate_error) = match self.rate.read_rate_dph() {
            Ok(g) => (g, None),
            Err(e) => (f32::NAN, Some(e.kind())),
        };
        let out = self.compensator.update(temp_c, gyro_dph);
        let record = Record {
            index: self.index,
            temp_c,
            gyro_dph,
            out,
            temp_error,
            rate_error,
        };
        self.index = self.index.wrapping_add(1);
        self.onset = self.summary.add(&record);
        record
    }

    /// The fault bits the last [`ControlLoop::step`] set that the one before did not: what the
    /// board logs, once per fault episode.
    pub fn fault_onset(&self) -> Status {
        self.onset
    }

    /// Runs `samples` periods, waiting `period_ms` after each: pacing for a board without a
    /// timer interrupt, where the period also includes the processing time (the QEMU image's
    /// `cost:` log line measures it; about 830 instructions per step with the 6-vector
    /// placeholder table, growing with the number of support vectors).
    pub fn run_paced(
        &mut self,
        samples: u32,
        period_ms: u32,
        delay: &mut impl DelayNs,
        mut emit: impl FnMut(&Record),
    ) {
        for _ in 0..samples {
            let record = self.step();
            emit(&record);
            delay.delay_ms(period_ms);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::replay::{channels, ReplayData};
    use crate::sensor::ErrorKind;
    use compensator_core::{Feature, ModelSpec, RateFilter, Status};

    fn table() -> ModelTable<2, 2> {
        ModelTable {
            spec: ModelSpec {
                features: [Feature::TempC, Feature::TempRateCPerS],
                input_mean: [30.0, 0.0],
                input_inv_scale: [0.1, 100.0],
                linear_dph: [0.0, 0.0],
                input_lo: [0.0, -0.02],
                input_hi: [70.0, 0.02],
                gamma: 0.5,
                bias_dph: -7.0,
                reference_dph: -7.0,
                rate_filter: RateFilter::from_tau_s(60.0, 1.0),
            },
            support: [[-1.0, 0.0], [1.0, 0.0]],
            alpha_dph: [0.3, -0.2],
            crc32: 0,
        }
        .sealed()
    }

    struct Failing;
    #[derive(Debug)]
    struct BusError;
    impl SensorError for BusError {
        fn kind(&self) -> ErrorKind {
            ErrorKind::Bus
        }
    }
    impl TemperatureSensor for Failing {
        type Error = BusError;
        fn read_temp_c(&mut self) -> Result<f32, BusError> {
            Err(BusError)
        }
    }
    impl RateSensor for Failing {
        type Error = BusError;
        fn read_rate_dph(&mut self) -> Result<f32, BusError> {
            Err(BusError)
        }
    }

    fn replay_bytes(samples: &[(f32, f32)]) -> std::vec::Vec<u8> {
        let mut v = std::vec::Vec::from(*b"RLGR\x01\x00\x00\x00");
        v.extend_from_slice(&(samples.len() as u32).to_le_bytes());
        for (t, g) in samples {
            v.extend_from_slice(&t.to_le_bytes());
            v.extend_from_slice(&g.to_le_bytes());
        }
        v
    }

    /// The loop adds nothing to the compensator: its outputs equal a bare compensator's,
    /// bit for bit, over a ramp with a NaN in each channel.
    #[test]
    fn loop_output_equals_bare_compensator() {
        let t = table();
        let samples: std::vec::Vec<(f32, f32)> = (0..500)
            .map(|k| {
                let temp = if k == 200 {
                    f32::NAN
                } else {
                    20.0 + k as f32 / 60.0
                };
                let gyro = if k == 300 {
                    f32::NAN
                } else {
                    -7.1 + 0.01 * (k % 7) as f32
                };
                (temp, gyro)
            })
            .collect();
        let bytes = replay_bytes(&samples);
        let (temp, rate) = channels(ReplayData::parse(&bytes).unwrap());
        let mut ctl = ControlLoop::new(&t, SensorLimits::DEFAULT, temp, rate);
        let mut reference = Compensator::new(t.as_model(), SensorLimits::DEFAULT);
        for (k, (temp, gyro)) in samples.iter().enumerate() {
            let r = ctl.step();
            let want = reference.update(*temp, *gyro);
            assert_eq!(r.index, k as u32);
            assert_eq!(
                r.out.rate_dph.to_bits(),
                want.rate_dph.to_bits(),
                "sample {k}"
            );
            assert_eq!(r.out.status, want.status, "sample {k}");
        }
        let s = ctl.summary();
        assert_eq!(s.samples, 500);
        assert!(s.count(Status::TEMP_FAULT) >= 1 && s.count(Status::GYRO_FAULT) >= 1);
        // Past the end the replay reports NoData and the loop turns it into faults.
        let r = ctl.step();
        assert_eq!(
            (r.temp_error, r.rate_error),
            (Some(ErrorKind::NoData), Some(ErrorKind::NoData))
        );
        assert!(r
            .out
            .status
            .contains(Status::TEMP_FAULT | Status::GYRO_FAULT));
    }

    #[test]
    fn dead_sensors_become_faults_with_a_finite_output() {
        let t = table();
        let mut ctl = ControlLoop::new(&t, SensorLimits::DEFAULT, Failing, Failing);
        for _ in 0..50 {
            let r = ctl.step();
            assert!(r.out.rate_dph.is_finite());
            assert!(r
                .out
                .status
                .contains(Status::TEMP_FAULT | Status::GYRO_FAULT));
            assert_eq!(r.temp_error, Some(ErrorKind::Bus));
        }
        assert_eq!(ctl.summary().temp_sensor_errors, 50);
        assert_eq!(ctl.summary().rate_sensor_errors, 50);
    }

    #[test]
    fn paced_run_waits_one_period_per_sample() {
        struct CountingDelay(u64);
        impl DelayNs for CountingDelay {
            fn delay_ns(&mut self, ns: u32) {
                self.0 += u64::from(ns);
            }
        }
        let t = table();
        let bytes = replay_bytes(&[(25.0, -7.0); 10]);
        let (temp, rate) = channels(ReplayData::parse(&bytes).unwrap());
        let mut ctl = ControlLoop::new(&t, SensorLimits::DEFAULT, temp, rate);
        let mut delay = CountingDelay(0);
        let mut seen = 0;
        ctl.run_paced(10, 1000, &mut delay, |_| seen += 1);
        assert_eq!(seen, 10);
        assert_eq!(delay.0, 10 * 1_000_000_000);
        assert_eq!(ctl.summary().temp_sensor_errors, 0);
    }
}
