//! The replay file: a recording compiled into the QEMU image by `build.rs`.
//!
//! Layout, all integers and floats little-endian:
//!
//! | offset | size      | field                                                   |
//! |--------|-----------|---------------------------------------------------------|
//! | 0      | 4         | magic `b"RLGR"`                                         |
//! | 4      | 2         | format version, `u16` = 1                               |
//! | 6      | 2         | reserved, `u16` = 0                                     |
//! | 8      | 4         | sample count, `u32`                                     |
//! | 12     | 8 × count | samples: `temp_c: f32` (°C), `rate_dph: f32` (°/h)      |
//!
//! One sample per 1 s period; the file is exactly `12 + 8 × count` bytes long. Floats are
//! stored as their exact bit patterns, so NaN and out-of-range readings replay as recorded.
//!
//! This file has no dependency on the rest of the crate: `build.rs` includes it with `#[path]`
//! to reject a malformed file at build time.

/// First four bytes of every replay file.
pub const MAGIC: [u8; 4] = *b"RLGR";
/// The format version this code reads and writes.
pub const VERSION: u16 = 1;
/// Header length, bytes.
pub const HEADER_LEN: usize = 12;
/// Length of one (temp_c, rate_dph) sample, bytes.
pub const SAMPLE_LEN: usize = 8;

/// Why a byte string is not a replay file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum FormatError {
    /// Shorter than the header.
    TooShort,
    /// The first four bytes are not [`MAGIC`].
    BadMagic,
    /// A version other than [`VERSION`].
    UnsupportedVersion(u16),
    /// The length disagrees with the sample count in the header.
    LengthMismatch {
        /// Samples announced by the header.
        count: u32,
        /// Actual file length, bytes.
        len: usize,
    },
}

impl core::fmt::Display for FormatError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FormatError::TooShort => write!(f, "shorter than the {HEADER_LEN}-byte header"),
            FormatError::BadMagic => write!(f, "does not start with the magic \"RLGR\""),
            FormatError::UnsupportedVersion(v) => {
                write!(f, "format version {v}, this build reads version {VERSION}")
            }
            FormatError::LengthMismatch { count, len } => write!(
                f,
                "header announces {count} samples ({} bytes) but the file has {len} bytes",
                HEADER_LEN as u64 + SAMPLE_LEN as u64 * u64::from(*count)
            ),
        }
    }
}

impl core::error::Error for FormatError {}

/// A parsed replay file borrowing its bytes.
#[derive(Clone, Copy, Debug)]
pub struct ReplayData<'a> {
    samples: &'a [u8],
}

impl<'a> ReplayData<'a> {
    /// Checks the header and the length.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, FormatError> {
        if bytes.len() < HEADER_LEN {
            return Err(FormatError::TooShort);
        }
        if bytes[0..4] != MAGIC {
            return Err(FormatError::BadMagic);
        }
        let version = u16::from_le_bytes([bytes[4], bytes[5]]);
        if version != VERSION {
            return Err(FormatError::UnsupportedVersion(version));
        }
        let count = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        let want = (count as usize)
            .checked_mul(SAMPLE_LEN)
            .and_then(|n| n.checked_add(HEADER_LEN));
        if want != Some(bytes.len()) {
            return Err(FormatError::LengthMismatch {
                count,
                len: bytes.len(),
            });
        }
        Ok(ReplayData {
            samples: &bytes[HEADER_LEN..],
        })
    }

    /// Number of samples.
    pub fn len(&self) -> u32 {
        // parse() checked that count · 8 fits the slice, and count came from a u32.
        (self.samples.len() / SAMPLE_LEN) as u32
    }

    /// Whether the file holds no sample.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Sample `index` as (temp_c °C, rate_dph °/h), or `None` past the end.
    pub fn sample(&self, index: u32) -> Option<(f32, f32)> {
        let start = (index as usize).checked_mul(SAMPLE_LEN)?;
        let s = self.samples.get(start..start.checked_add(SAMPLE_LEN)?)?;
        let temp_c = f32::from_le_bytes([s[0], s[1], s[2], s[3]]);
        let rate_dph = f32::from_le_bytes([s[4], s[5], s[6], s[7]]);
        Some((temp_c, rate_dph))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(count: u32, samples: &[(f32, f32)]) -> std::vec::Vec<u8> {
        let mut v = std::vec::Vec::new();
        v.extend_from_slice(&MAGIC);
        v.extend_from_slice(&VERSION.to_le_bytes());
        v.extend_from_slice(&0u16.to_le_bytes());
        v.extend_from_slice(&count.to_le_bytes());
        for (t, r) in samples {
            v.extend_from_slice(&t.to_le_bytes());
            v.extend_from_slice(&r.to_le_bytes());
        }
        v
    }

    #[test]
    fn round_trips_exact_bit_patterns() {
        let nan = f32::from_bits(0x7fc0_1234);
        let samples = [(25.0, -7.1), (nan, 1.0e-30), (-0.0, f32::INFINITY)];
        let bytes = file(3, &samples);
        let r = ReplayData::parse(&bytes).unwrap();
        assert_eq!(r.len(), 3);
        for (i, (t, g)) in samples.iter().enumerate() {
            let (t2, g2) = r.sample(i as u32).unwrap();
            assert_eq!((t.to_bits(), g.to_bits()), (t2.to_bits(), g2.to_bits()));
        }
        assert_eq!(r.sample(3), None);
        assert_eq!(r.sample(u32::MAX), None);
    }

    #[test]
    fn rejects_malformed_files() {
        assert_eq!(
            ReplayData::parse(b"RLGR").unwrap_err(),
            FormatError::TooShort
        );
        let mut bad = file(0, &[]);
        bad[0] = b'X';
        assert_eq!(ReplayData::parse(&bad).unwrap_err(), FormatError::BadMagic);
        let mut v2 = file(0, &[]);
        v2[4] = 2;
        assert_eq!(
            ReplayData::parse(&v2).unwrap_err(),
            FormatError::UnsupportedVersion(2)
        );
        let short = file(2, &[(1.0, 2.0)]);
        assert_eq!(
            ReplayData::parse(&short).unwrap_err(),
            FormatError::LengthMismatch { count: 2, len: 20 }
        );
        let huge = file(u32::MAX, &[]);
        assert!(matches!(
            ReplayData::parse(&huge),
            Err(FormatError::LengthMismatch { .. })
        ));
        assert!(ReplayData::parse(&file(0, &[])).unwrap().is_empty());
    }
}
