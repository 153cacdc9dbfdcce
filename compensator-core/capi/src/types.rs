//! The types of the C API, `#[repr(C)]`, as the generated header declares them.

// The C names are the API: lower-case with the `rlg_` prefix, as C code spells its types.
#![allow(non_camel_case_types)]

/// The largest number of input features a table may have (the exporter's limit).
pub const RLG_MAX_FEATURES: u32 = 5;

/// 64-bit words of an `rlg_compensator`.
pub const RLG_COMPENSATOR_WORDS: usize = 64;
/// Bytes of an `rlg_compensator` (the caller allocates it; no heap is used).
pub const RLG_COMPENSATOR_SIZE: usize = RLG_COMPENSATOR_WORDS * 8;
/// 64-bit words of an `rlg_fixed_compensator`.
pub const RLG_FIXED_COMPENSATOR_WORDS: usize = 72;
/// Bytes of an `rlg_fixed_compensator`.
pub const RLG_FIXED_COMPENSATOR_SIZE: usize = RLG_FIXED_COMPENSATOR_WORDS * 8;
/// Alignment of both states, bytes (that of `uint64_t`).
pub const RLG_STATE_ALIGN: usize = 8;

/// Status bit: the dT/dt estimator has not yet seen `rate_warmup_samples` good samples since
/// (re)start; the model compensates with the estimate it has.
pub const RLG_STATUS_WARMING_UP: u8 = 1;
/// Status bit: a feature lay outside the trained range and was clamped to it.
pub const RLG_STATUS_OUT_OF_RANGE: u8 = 2;
/// Status bit: the temperature was rejected (NaN, outside −60…130 °C, or more than 2 °C from
/// the estimator's prediction per elapsed period); the raw rate is passed through.
pub const RLG_STATUS_TEMP_FAULT: u8 = 4;
/// Status bit: the gyro rate was rejected (non-finite or beyond ±3.6e6 °/h); the last good
/// output is held (0 before the first).
pub const RLG_STATUS_GYRO_FAULT: u8 = 8;
/// Status bit: the table failed its check at init (CRC, content, layout) or the state was never
/// initialised; the raw rate is passed through uncompensated.
pub const RLG_STATUS_TABLE_FAULT: u8 = 16;
/// Status bit: the temperature has read bit-identical for 300 accepted samples although the
/// body was moving when that reading appeared (a frozen sensor); the model compensates at it.
pub const RLG_STATUS_TEMP_STUCK: u8 = 32;
/// The status bits that mark a fault (not just warm-up or clamping).
pub const RLG_STATUS_FAULTS: u8 = 4 | 8 | 16 | 32;

/// What a call did. Every function returns one; only `RLG_OK` means it did what was asked.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum rlg_error {
    /// Done.
    RLG_OK = 0,
    /// A required pointer argument (or a pointer inside the table) is NULL.
    RLG_ERR_NULL = 1,
    /// A pointer is not aligned for its type.
    RLG_ERR_ALIGNMENT = 2,
    /// The state was never set up by its `init` function (an update before init).
    RLG_ERR_NOT_INITIALIZED = 3,
    /// `n_features` is outside 1…`RLG_MAX_FEATURES` (or a count the library was built
    /// without), `n_support` is 0 or too large for memory, or the arrays disagree in length.
    RLG_ERR_TABLE_SHAPE = 4,
    /// A feature code is unknown, or its parameter is invalid for it.
    RLG_ERR_TABLE_FEATURE = 5,
    /// The table's stored CRC-32 does not match its content (corrupted flash or an edited
    /// table).
    RLG_ERR_TABLE_CRC = 6,
    /// The content fails validation: a NaN or infinite number, a negative scale, γ ≤ 0, a
    /// range with lo > hi, or an unstable dT/dt filter.
    RLG_ERR_TABLE_INVALID = 7,
    /// The fixed-point form is missing, or is not the conversion of the table's f32 numbers,
    /// or the table has none (linear terms, a number outside its Q range).
    RLG_ERR_FIXED_FORM = 8,
}

/// One input feature of a table: its code and parameter, as `compensator_core::crc` hashes
/// them. Codes: 0 T (°C), 1 dT/dt (°C/s), 2 lead T + τ·dT/dt (param τ, s), 3 lagged gradient
/// (param τ, s, > 0), 4 play operator (param width, m°C), 5 time since power-on (s),
/// 6 warm-up decay e^(−t/τ) (param τ, s, > 0). Parameterless features take 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct rlg_feature {
    /// Feature code.
    pub code: u32,
    /// Its parameter (0 for a feature without one).
    pub param: u32,
}

/// A model table as C code holds it: the exported f32 numbers, in flash. Generated per axis by
/// the table export (`<name>_model`); every pointer must stay valid, and the numbers
/// unchanged, for as long as a state initialised from it is used.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct rlg_table {
    /// N, the number of support vectors (≥ 1).
    pub n_support: u32,
    /// D, the number of input features (1…`RLG_MAX_FEATURES`).
    pub n_features: u32,
    /// D features.
    pub features: *const rlg_feature,
    /// D means for standardisation, z = (x − mean)·inv_scale, in each feature's unit.
    pub input_mean: *const f32,
    /// D inverse scales (0: the feature enters through its linear term only).
    pub input_inv_scale: *const f32,
    /// D coefficients of linear terms, °/h per feature unit (all 0: Eq. 10 alone).
    pub linear_dph: *const f32,
    /// D lower ends of the trained range.
    pub input_lo: *const f32,
    /// D upper ends of the trained range.
    pub input_hi: *const f32,
    /// γ = 1/(2σ²) of the Gaussian kernel, standardised units.
    pub gamma: f32,
    /// Bias b of Eq. (10), °/h.
    pub bias_dph: f32,
    /// Model output at the reference condition, °/h: the output is raw − (f(x) − reference).
    pub reference_dph: f32,
    /// dT/dt estimator: level gain α.
    pub rate_alpha: f32,
    /// dT/dt estimator: slope gain β.
    pub rate_beta: f32,
    /// Sample period, s: the period at which `rlg_update` must be called.
    pub rate_dt_s: f32,
    /// Samples after (re)start before dT/dt is trusted (`RLG_STATUS_WARMING_UP` until then).
    pub rate_warmup_samples: u32,
    /// N × D standardised support vectors, row by row.
    pub support: *const f32,
    /// N coefficients aᵢ of Eq. (10), °/h.
    pub alpha_dph: *const f32,
    /// CRC-32/ISO-HDLC of the numeric content, checked by `rlg_init`.
    pub crc32: u32,
}

/// The fixed-point form of a table (exported beside it as `<name>_fixed_model` when the table
/// has one): the f32 table, whose CRC covers it, and its integer parts, which `rlg_fixed_init`
/// checks against the conversion of the f32 numbers.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct rlg_fixed_table {
    /// The f32 table (features, scaling, range, dT/dt filter, CRC).
    pub table: *const rlg_table,
    /// N × D support vectors times √γ, Q24 (value · 2^24), row by row.
    pub support_q24: *const i32,
    /// N coefficients aᵢ, °/h, Q24.
    pub alpha_q24: *const i32,
    /// √γ, Q28.
    pub sqrt_gamma_q28: u32,
    /// Bias b, °/h, Q24.
    pub bias_q24: i32,
}

/// One output sample.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct rlg_output {
    /// Output rate, °/h: compensated unless `status` says otherwise; always finite.
    pub rate_dph: f32,
    /// The correction that was subtracted, °/h (0 when none was applied).
    pub correction_dph: f32,
    /// `RLG_STATUS_*` bits (0: compensated normally).
    pub status: u8,
}

/// The state of one axis's f32 compensator: opaque, `RLG_COMPENSATOR_SIZE` bytes aligned to
/// `RLG_STATE_ALIGN`, allocated by the caller (static, or on the stack). It holds no pointer
/// into itself, so it may be copied; it points into its table.
#[repr(C)]
pub struct rlg_compensator {
    opaque: [u64; RLG_COMPENSATOR_WORDS],
}

/// The state of one axis's fixed-point compensator: opaque, `RLG_FIXED_COMPENSATOR_SIZE`
/// bytes aligned to `RLG_STATE_ALIGN`, allocated by the caller.
#[repr(C)]
pub struct rlg_fixed_compensator {
    opaque: [u64; RLG_FIXED_COMPENSATOR_WORDS],
}

#[cfg(test)]
mod tests {
    use super::*;
    use compensator_core::Status;

    /// The C status bits are the compensator's.
    #[test]
    fn status_bits_are_the_cores() {
        let pairs = [
            (RLG_STATUS_WARMING_UP, Status::WARMING_UP),
            (RLG_STATUS_OUT_OF_RANGE, Status::OUT_OF_RANGE),
            (RLG_STATUS_TEMP_FAULT, Status::TEMP_FAULT),
            (RLG_STATUS_GYRO_FAULT, Status::GYRO_FAULT),
            (RLG_STATUS_TABLE_FAULT, Status::TABLE_FAULT),
            (RLG_STATUS_TEMP_STUCK, Status::TEMP_STUCK),
        ];
        let mut faults = 0;
        for (c, s) in pairs {
            assert_eq!(c, s.0);
            if Status(c).is_fault() {
                faults |= c;
            }
        }
        assert_eq!(faults, RLG_STATUS_FAULTS);
    }
}
