//! CRC-32 over a model table's numeric content, computed by the exporter and checked at boot.
//!
//! Algorithm: CRC-32/ISO-HDLC (the zlib / Ethernet CRC: polynomial 0x04C11DB7 reflected,
//! init and xorout 0xFFFFFFFF; check value 0xCBF43926 for `"123456789"`), from the `crc` crate
//! without a lookup table, so the check costs no flash beyond its code; it runs once at boot.
//!
//! The checksummed byte stream is defined here once and used by the trainer's export and by
//! the board, so both compute it identically. Every item is little-endian, in this order:
//!
//! 1. N (support vectors) and D (inputs), `u32` each;
//! 2. each feature's code ([`feature_code`]), `u32` each, followed by its parameter (`u32`)
//!    for parameterised features;
//! 3. `input_mean`, `input_inv_scale`, `input_lo`, `input_hi`: D f32 bit patterns each;
//! 4. `gamma`, `bias_dph`, `reference_dph`: f32 bit patterns;
//! 5. the rate filter: `alpha`, `beta`, `dt_s` as f32 bit patterns, `warmup_samples` as `u32`;
//! 6. the support vectors row by row (N·D f32 bit patterns), then the N coefficients `alpha_dph`.
//!
//! Bit patterns, not values, are hashed: −0.0 and 0.0 differ, and any NaN payload is caught.

use crc::{Crc, Digest, NoTable, CRC_32_ISO_HDLC};

use crate::table::{Feature, ModelRef};

/// The CRC engine (bitwise, no table).
const ENGINE: Crc<u32, NoTable> = Crc::<u32, NoTable>::new(&CRC_32_ISO_HDLC);

/// The stable code of a feature in the checksummed stream (never reused). A parameterised
/// feature's parameter follows its code as one more `u32`.
pub const fn feature_code(f: Feature) -> u32 {
    match f {
        Feature::TempC => 0,
        Feature::TempRateCPerS => 1,
        Feature::TempLeadC { .. } => 2,
        Feature::TempGradLagCPerS { .. } => 3,
        Feature::TempPlayC { .. } => 4,
        Feature::TimeOnS => 5,
        Feature::WarmupDecay { .. } => 6,
    }
}

/// The feature of a code and parameter ([`feature_code`], [`Feature::parameter`]): how a table
/// laid out by C code names its features. `None` for an unknown code, a parameter given to a
/// feature that has none, or a zero time constant (as [`Feature::parse`] refuses).
pub const fn feature_from_code(code: u32, param: u32) -> Option<Feature> {
    let f = match code {
        0 => Feature::TempC,
        1 => Feature::TempRateCPerS,
        2 => Feature::TempLeadC { tau_s: param },
        3 => Feature::TempGradLagCPerS { tau_s: param },
        4 => Feature::TempPlayC { width_mc: param },
        5 => Feature::TimeOnS,
        6 => Feature::WarmupDecay { tau_s: param },
        _ => return None,
    };
    let ok = match f {
        Feature::TempC | Feature::TempRateCPerS | Feature::TimeOnS => param == 0,
        Feature::TempGradLagCPerS { .. } | Feature::WarmupDecay { .. } => param > 0,
        Feature::TempLeadC { .. } | Feature::TempPlayC { .. } => true,
    };
    if ok {
        Some(f)
    } else {
        None
    }
}

fn put_u32(d: &mut Digest<'_, u32, NoTable>, v: u32) {
    d.update(&v.to_le_bytes());
}

fn put_f32s(d: &mut Digest<'_, u32, NoTable>, v: &[f32]) {
    for x in v {
        put_u32(d, x.to_bits());
    }
}

/// CRC-32 of `bytes` with the table's algorithm (exposed for the check-value test and for
/// other exporters).
pub fn crc32(bytes: &[u8]) -> u32 {
    ENGINE.checksum(bytes)
}

impl<const D: usize> ModelRef<'_, D> {
    /// CRC-32 of the model's numeric content in the stream order of [`crate::crc`].
    ///
    /// A table whose `support` and `alpha_dph` differ in length still gets a checksum (both
    /// lengths are hashed through N = `support.len()` and the coefficient stream), so a shape
    /// error cannot collide with a valid table by construction of the stream alone.
    pub fn content_crc32(&self) -> u32 {
        let s = self.spec;
        let mut d = ENGINE.digest();
        // Lengths beyond u32 cannot exist on the board; saturate rather than wrap on a host.
        put_u32(
            &mut d,
            u32::try_from(self.support.len()).unwrap_or(u32::MAX),
        );
        put_u32(&mut d, u32::try_from(D).unwrap_or(u32::MAX));
        for f in s.features {
            put_u32(&mut d, feature_code(f));
            if let Some((_, v)) = f.parameter() {
                put_u32(&mut d, v);
            }
        }
        put_f32s(&mut d, &s.input_mean);
        put_f32s(&mut d, &s.input_inv_scale);
        put_f32s(&mut d, &s.linear_dph);
        put_f32s(&mut d, &s.input_lo);
        put_f32s(&mut d, &s.input_hi);
        put_f32s(&mut d, &[s.gamma, s.bias_dph, s.reference_dph]);
        let r = &s.rate_filter;
        put_f32s(&mut d, &[r.alpha, r.beta, r.dt_s]);
        put_u32(&mut d, r.warmup_samples);
        for sv in self.support {
            put_f32s(&mut d, sv);
        }
        put_f32s(&mut d, self.alpha_dph);
        d.finalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rate::RateFilter;
    use crate::table::{ModelSpec, ModelTable};

    /// Every feature's code and parameter map back to it; unknown codes, stray parameters and
    /// zero time constants are refused.
    #[test]
    fn feature_codes_round_trip() {
        let all = [
            Feature::TempC,
            Feature::TempRateCPerS,
            Feature::TempLeadC { tau_s: 0 },
            Feature::TempLeadC { tau_s: 600 },
            Feature::TempGradLagCPerS { tau_s: 90 },
            Feature::TempPlayC { width_mc: 150 },
            Feature::TimeOnS,
            Feature::WarmupDecay { tau_s: 1200 },
        ];
        for f in all {
            let param = f.parameter().map_or(0, |(_, v)| v);
            assert_eq!(feature_from_code(feature_code(f), param), Some(f), "{f}");
        }
        assert_eq!(feature_from_code(7, 0), None);
        assert_eq!(feature_from_code(0, 1), None);
        assert_eq!(feature_from_code(3, 0), None);
        assert_eq!(feature_from_code(6, 0), None);
    }

    /// The published check value of CRC-32/ISO-HDLC.
    #[test]
    fn check_value_matches_the_catalogue() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    /// An independent bitwise CRC-32 (reflected polynomial 0xEDB88320), written from the
    /// definition, over the stream built by hand for a 2×1 table.
    #[test]
    fn table_crc_matches_a_hand_built_stream() {
        fn reference(bytes: &[u8]) -> u32 {
            let mut c = 0xFFFF_FFFFu32;
            for b in bytes {
                c ^= u32::from(*b);
                for _ in 0..8 {
                    c = if c & 1 != 0 {
                        (c >> 1) ^ 0xEDB8_8320
                    } else {
                        c >> 1
                    };
                }
            }
            !c
        }
        let t = ModelTable {
            spec: ModelSpec {
                features: [Feature::TempRateCPerS],
                input_mean: [1.5],
                input_inv_scale: [2.0],
                linear_dph: [0.125],
                input_lo: [-1.0],
                input_hi: [3.0],
                gamma: 0.5,
                bias_dph: -7.0,
                reference_dph: -7.25,
                rate_filter: RateFilter {
                    alpha: 0.25,
                    beta: 0.125,
                    dt_s: 1.0,
                    warmup_samples: 300,
                },
            },
            support: [[0.5], [-0.75]],
            alpha_dph: [1.0e-3, -2.0e-3],
            crc32: 0,
        };
        let mut s: Vec<u8> = Vec::new();
        let words: [u32; 19] = [
            2,
            1,
            1,
            1.5f32.to_bits(),
            2.0f32.to_bits(),
            0.125f32.to_bits(),
            (-1.0f32).to_bits(),
            3.0f32.to_bits(),
            0.5f32.to_bits(),
            (-7.0f32).to_bits(),
            (-7.25f32).to_bits(),
            0.25f32.to_bits(),
            0.125f32.to_bits(),
            1.0f32.to_bits(),
            300,
            0.5f32.to_bits(),
            (-0.75f32).to_bits(),
            1.0e-3f32.to_bits(),
            (-2.0e-3f32).to_bits(),
        ];
        for w in words {
            s.extend_from_slice(&w.to_le_bytes());
        }
        assert_eq!(t.as_model().content_crc32(), reference(&s));
    }
}
