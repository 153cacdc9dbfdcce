//! Writer (and an independent reader) of the firmware's replay file, and the deterministic
//! test scenario replayed in QEMU.
//!
//! Layout, little-endian (the firmware's reader is `firmware/src/replay/format.rs`):
//! magic `b"RLGR"`, version `u16` = 1, reserved `u16` = 0, count `u32`, then `count` samples of
//! (`temp_c: f32` °C, `rate_dph: f32` °/h), one per 1 s period, as exact bit patterns.

use std::fs;
use std::path::Path;

/// First four bytes of a replay file.
pub const MAGIC: [u8; 4] = *b"RLGR";
/// Format version written.
pub const VERSION: u16 = 1;
/// Header length, bytes.
pub const HEADER_LEN: usize = 12;

/// One replayed sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReplaySample {
    /// Temperature sensor reading, °C (may be NaN or implausible on purpose).
    pub temp_c: f32,
    /// Gyro rate, °/h (may be NaN on purpose).
    pub rate_dph: f32,
}

/// Why a replay file could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// More samples than the `u32` count can hold.
    #[error("{0} samples do not fit the u32 count of the replay format")]
    TooMany(usize),
    /// The bytes are not a version-1 replay file.
    #[error("not a replay file: {0}")]
    Malformed(&'static str),
    /// File system error.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
}

/// The file contents for `samples`.
pub fn encode(samples: &[ReplaySample]) -> Result<Vec<u8>, ReplayError> {
    let count = u32::try_from(samples.len()).map_err(|_| ReplayError::TooMany(samples.len()))?;
    let mut out = Vec::with_capacity(HEADER_LEN + 8 * samples.len());
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes());
    out.extend_from_slice(&count.to_le_bytes());
    for s in samples {
        out.extend_from_slice(&s.temp_c.to_bits().to_le_bytes());
        out.extend_from_slice(&s.rate_dph.to_bits().to_le_bytes());
    }
    Ok(out)
}

/// Parses file contents back into samples.
pub fn decode(bytes: &[u8]) -> Result<Vec<ReplaySample>, ReplayError> {
    let header = bytes
        .get(..HEADER_LEN)
        .ok_or(ReplayError::Malformed("shorter than the header"))?;
    if header[..4] != MAGIC {
        return Err(ReplayError::Malformed("bad magic"));
    }
    if u16::from_le_bytes([header[4], header[5]]) != VERSION {
        return Err(ReplayError::Malformed("unsupported version"));
    }
    let count = u32::from_le_bytes([header[8], header[9], header[10], header[11]]) as usize;
    let body = &bytes[HEADER_LEN..];
    if count.checked_mul(8) != Some(body.len()) {
        return Err(ReplayError::Malformed(
            "length disagrees with the sample count",
        ));
    }
    Ok(body
        .chunks_exact(8)
        .map(|c| ReplaySample {
            temp_c: f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
            rate_dph: f32::from_le_bytes([c[4], c[5], c[6], c[7]]),
        })
        .collect())
}

/// Writes `samples` to `path`.
pub fn write(path: &Path, samples: &[ReplaySample]) -> Result<(), ReplayError> {
    let bytes = encode(samples)?;
    fs::write(path, bytes).map_err(|source| ReplayError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// SplitMix64 (Steele et al. 2014), written out so the scenario's bits cannot change with a
/// random-number crate's version: the committed default replay must stay reproducible.
#[derive(Clone, Debug)]
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [−0.5, 0.5) with 24 bits.
    fn centred(&mut self) -> f64 {
        (self.next_u64() >> 40) as f64 / (1u64 << 24) as f64 - 0.5
    }
}

/// Constant gyro bias of the scenario, °/h.
pub const SCENARIO_BIAS_DPH: f64 = -7.1;
/// Peak-to-peak of the scenario's uniform rate noise, °/h.
pub const SCENARIO_NOISE_PP_DPH: f64 = 0.02;

/// A fault injected into the scenario at a sample index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Injected {
    /// Temperature reading is NaN (open sensor, failed conversion).
    NanTemp,
    /// Gyro reading is NaN.
    NanRate,
    /// Temperature reads 150 °C, above any plausible gyro temperature.
    TempOutOfRange,
    /// Temperature reads 30 °C above the true value for one sample.
    TempSpike,
    /// Temperature repeats the reading before the fault (a frozen sensor or ADC), then jumps
    /// back to the true value.
    StuckTemp,
}

/// Where the scenario's faults are: (first sample, number of samples, fault).
pub const SCENARIO_FAULTS: [(usize, usize, Injected); 6] = [
    (1000, 1, Injected::NanTemp),
    (2000, 1, Injected::NanRate),
    (3000, 1, Injected::TempOutOfRange),
    (4000, 1, Injected::TempSpike),
    // Longer than the compensator's 30-sample skip limit: forces an estimator restart.
    (6000, 40, Injected::NanTemp),
    // On the 1 °C/min down-ramp, frozen at 38.35 °C for 1300 s (longer than the 300-repeat
    // stuck limit), back at 16.67 °C.
    (6400, 1300, Injected::StuckTemp),
];

/// The thermal profile, °C, at second `k`: 600 s hold at 10 °C, ramp to 65 °C at 1 °C/min,
/// 600 s hold, ramp back to 10 °C, 600 s hold (8400 s in all).
pub fn scenario_temp_c(k: usize) -> f64 {
    let ramp_s = 55.0 * 60.0;
    let t = k as f64;
    let segments = [600.0, ramp_s, 600.0, ramp_s, 600.0];
    let (mut start, mut level) = (0.0, 10.0);
    for (i, len) in segments.iter().enumerate() {
        if t < start + len {
            let into = t - start;
            return match i {
                1 => 10.0 + into / 60.0,
                3 => 65.0 - into / 60.0,
                _ => level,
            };
        }
        start += len;
        level = if i == 1 {
            65.0
        } else if i == 3 {
            10.0
        } else {
            level
        };
    }
    10.0
}

/// Number of samples in [`scenario`].
pub const SCENARIO_LEN: usize = 8400;

/// Thermal time constant of the gyro body behind the chamber profile, s.
pub const SCENARIO_BODY_TAU_S: f64 = 300.0;

/// The body temperature, °C, for each second of [`scenario`]: [`scenario_temp_c`] through a
/// first-order lag of [`SCENARIO_BODY_TAU_S`] (exact for a profile linear over each second),
/// starting settled. A real body never stops dead at the end of a ramp; the board's
/// frozen-sensor rule relies on that.
pub fn scenario_body_temp_c() -> Vec<f64> {
    let a = (-1.0 / SCENARIO_BODY_TAU_S).exp();
    let mut body = scenario_temp_c(0);
    (0..SCENARIO_LEN)
        .map(|k| {
            if k > 0 {
                // Chamber linear from k − 1 to k: the exact lag step for a ramp input.
                let (c0, c1) = (scenario_temp_c(k - 1), scenario_temp_c(k));
                let slope = c1 - c0;
                body = c1 - slope * SCENARIO_BODY_TAU_S
                    + (body - c0 + slope * SCENARIO_BODY_TAU_S) * a;
            }
            body
        })
        .collect()
}

/// The QEMU replay scenario: [`scenario_body_temp_c`] quantised to 0.01 °C like the board's
/// ADC driver, a gyro at [`SCENARIO_BIAS_DPH`] with uniform noise of [`SCENARIO_NOISE_PP_DPH`]
/// peak-to-peak, and the faults of [`SCENARIO_FAULTS`].
pub fn scenario() -> Vec<ReplaySample> {
    let mut noise = SplitMix64(0x5eed_0001);
    let body = scenario_body_temp_c();
    let mut out: Vec<ReplaySample> = (0..SCENARIO_LEN)
        .map(|k| ReplaySample {
            temp_c: ((body[k] * 100.0).round() / 100.0) as f32,
            rate_dph: (SCENARIO_BIAS_DPH + SCENARIO_NOISE_PP_DPH * noise.centred()) as f32,
        })
        .collect();
    for (first, len, fault) in SCENARIO_FAULTS {
        let before = out[first - 1].temp_c;
        for s in &mut out[first..first + len] {
            match fault {
                Injected::StuckTemp => s.temp_c = before,
                Injected::NanTemp => s.temp_c = f32::NAN,
                Injected::NanRate => s.rate_dph = f32::NAN,
                Injected::TempOutOfRange => s.temp_c = 150.0,
                Injected::TempSpike => s.temp_c += 30.0,
            }
        }
    }
    out
}

/// The short replay committed as `firmware/replay/default.bin` (the image's input when
/// `RLG_REPLAY_BIN` is unset): the first 900 s of [`scenario`].
pub fn default_replay() -> Vec<ReplaySample> {
    scenario().into_iter().take(900).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encode_decode_round_trip_keeps_bits() {
        let s = scenario();
        let back = decode(&encode(&s).unwrap()).unwrap();
        assert_eq!(s.len(), back.len());
        for (a, b) in s.iter().zip(&back) {
            assert_eq!(a.temp_c.to_bits(), b.temp_c.to_bits());
            assert_eq!(a.rate_dph.to_bits(), b.rate_dph.to_bits());
        }
        assert!(decode(&encode(&s).unwrap()[..20]).is_err());
    }

    #[test]
    fn header_layout() {
        let bytes = encode(&[ReplaySample {
            temp_c: 1.0,
            rate_dph: -2.0,
        }])
        .unwrap();
        // 1.0 = 0x3f800000, −2.0 = 0xc0000000 (IEEE-754 single).
        assert_eq!(
            bytes,
            b"RLGR\x01\x00\x00\x00\x01\x00\x00\x00\x00\x00\x80\x3f\x00\x00\x00\xc0"
        );
    }

    #[test]
    fn scenario_profile() {
        assert_eq!(scenario_temp_c(0), 10.0);
        assert_eq!(scenario_temp_c(600 + 1800), 40.0); // 30 min into the up-ramp
        assert_eq!(scenario_temp_c(600 + 3300 + 100), 65.0);
        assert!((scenario_temp_c(600 + 3300 + 600 + 60) - 64.0).abs() < 1e-12);
        assert_eq!(scenario_temp_c(SCENARIO_LEN - 1), 10.0);
        let s = scenario();
        // Quantised to 0.01 °C wherever no fault was injected.
        let q = s[1234].temp_c as f64 * 100.0;
        assert!((q - q.round()).abs() < 1e-3);
        let mean: f64 = s
            .iter()
            .filter(|x| x.rate_dph.is_finite())
            .map(|x| x.rate_dph as f64)
            .sum::<f64>()
            / (SCENARIO_LEN - 1) as f64;
        assert!((mean - SCENARIO_BIAS_DPH).abs() < 1e-3, "mean rate {mean}");
        assert!(s[1000].temp_c.is_nan() && s[2000].rate_dph.is_nan() && s[3000].temp_c == 150.0);
        assert!(s[6399..7700].iter().all(|x| x.temp_c == s[6399].temp_c));
        assert!((s[6399].temp_c - 38.35).abs() < 0.02, "{}", s[6399].temp_c);
        assert!((s[7700].temp_c - 16.67).abs() < 0.02, "{}", s[7700].temp_c);
        // The body lags the chamber by ramp rate × τ = 5 °C on a ramp and settles in holds.
        let body = scenario_body_temp_c();
        assert_eq!(body[0], 10.0);
        // 30 min into the up-ramp: 5 °C behind, less the start transient 5·e^(−1800/300).
        let want = 40.0 - 5.0 + 5.0 * (-6.0f64).exp();
        assert!((body[600 + 1800] - want).abs() < 1e-9, "{}", body[2400]);
        assert!((body[600 + 3300 + 599] - 65.0).abs() < 5.0 * (-599.0f64 / 300.0).exp() + 1e-6);
    }
}
