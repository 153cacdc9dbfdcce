//! Integer-only evaluation of Eq. (10) for FPU-less boards (Cortex-M0+/M3).
//!
//! Q formats are in the types: [`Q<F>`] is an `i32` holding value·2^F. The model is held as
//!
//! * support vectors scaled by √γ, s̃ᵢ = √γ·zᵢ, and inputs scaled the same way once per
//!   update: [`Z`] = `Q<24>`, both within ±32 (checked at conversion, inputs clamped), so
//!   differences fit an `i32` and squares a `u64` without saturating; the kernel argument is
//!   then ‖s̃ − s̃ᵢ‖² = γ‖z − zᵢ‖² with no multiply by γ per vector (√γ: `u32` Q28);
//! * coefficients, bias and output, °/h: [`Dph`] = `Q<24>` (±128 °/h, resolution 6.0e-8 °/h);
//! * the kernel argument: `u32` Q27 (terms at or above 31 are skipped: e^−31 = 3.4e-14 is below
//!   every coefficient's resolution); the kernel value: [`Kernel`] = `Q<28>`.
//!
//! exp(−x) ([`exp_neg_q27`]) splits x = i/32 + r: e^(−i/32) from a 1024-entry table (Q29,
//! built at compile time), e^(−r), 0 ≤ r < 1/32, by a degree-4 Taylor polynomial in Q31
//! (truncation ≤ (1/32)⁵/5! = 2.5e-10), one multiply-high per step. Per support vector the
//! loop is two subtractions, a multiply and a multiply-accumulate for the distance, one
//! compare, the table load, five multiply-highs and one multiply-accumulate of aᵢ·kᵢ into an
//! `i64` (Q52, rounded once at the end; the conversion checks Σ|aᵢ| < 2048 °/h, so the sum
//! cannot overflow).
//!
//! The table is converted from the f32 table ([`FixedModel::from_table`]) with integer bit
//! manipulation only (round to nearest), in a `const fn`, so a board holds the converted table
//! in flash and never touches a float. Accuracy against the f64 reference is measured by
//! `tests/tests/fixed_point.rs`.

use crate::table::ModelTable;

pub mod compensator;
pub mod parts;
pub mod trace;
pub use compensator::FixedCompensator;
pub use parts::{scaled_vector, sqrt_gamma_q28, FixedModelRef};
pub use trace::FixedTrace;

/// A signed fixed-point number: the `i32` holds value·2^F (laid out as that `i32`, so C code
/// can hand over an `int32_t` array).
#[repr(transparent)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Q<const F: u32>(pub i32);

/// Standardised feature value.
pub type Z = Q<24>;
/// A rate, °/h.
pub type Dph = Q<24>;
/// A kernel value in [0, 1].
pub type Kernel = Q<28>;

impl<const F: u32> Q<F> {
    /// Saturating addition.
    pub const fn saturating_add(self, o: Self) -> Self {
        Q(self.0.saturating_add(o.0))
    }

    /// Saturating subtraction.
    pub const fn saturating_sub(self, o: Self) -> Self {
        Q(self.0.saturating_sub(o.0))
    }

    /// The value as f64 (host-side checks; exact).
    pub fn to_f64(self) -> f64 {
        f64::from(self.0) / (1u64 << F) as f64
    }

    /// The nearest `Q<F>` to an f32 given by its bits, ties away from zero, integer
    /// arithmetic only; None for NaN/infinity or a value outside the i32 range.
    pub const fn from_f32_bits(bits: u32) -> Option<Self> {
        // value = mant·2^(e − 150); in Q<F>: mant·2^(e − 150 + F).
        match round_scaled(bits, 1, F as i32 - 150, i32::MAX as u128) {
            Some(v) => Some(Q(v)),
            None => None,
        }
    }
}

/// round(mant·factor·2^(e + shift)) with the sign of the f32 whose bits are given
/// (value = ±mant·2^(e − 150)), ties away from zero; None for NaN/infinity or a magnitude
/// above `limit` (≤ i32::MAX). `factor` < 2^32.
const fn round_scaled(bits: u32, factor: u128, shift: i32, limit: u128) -> Option<i32> {
    let neg = bits >> 31 != 0;
    let exp = ((bits >> 23) & 0xff) as i32;
    if exp == 0xff {
        return None;
    }
    let (mant, e) = if exp == 0 {
        ((bits & 0x7f_ffff) as u128, 1)
    } else {
        (((bits & 0x7f_ffff) | 0x80_0000) as u128, exp)
    };
    let p = mant * factor; // < 2^56
    let shift = e + shift;
    let mag: u128 = if shift >= 0 {
        if shift > 40 {
            return None;
        }
        p << shift
    } else if -shift >= 127 {
        0
    } else {
        let s = (-shift) as u32;
        (p + (1 << (s - 1))) >> s
    };
    if mag > limit {
        return None;
    }
    let v = mag as i32;
    Some(if neg { -v } else { v })
}

/// e^(−1/32) in Q62.
const EXP_STEP_Q62: u128 = 4_469_799_356_029_710_115;
/// Kernel arguments at or above 31 (Q27) give 0 (e^−31 = 3.4e-14).
const X_MAX_Q27: u32 = 31 << 27;
/// The high word of a squared distance (Q48) at or above which the argument is ≥ 31.
const CUT_HI: u32 = 31 << 16;
/// Bound of Σ|aᵢ| in Q24 (2048 °/h): Σ|aᵢ|·2^24 times kernels below 2^28 stays below 2^63.
pub(crate) const ABS_ALPHA_SUM_LIMIT: i64 = 1 << 35;
/// Bound of scaled support vectors and inputs: ±32 in Q24.
pub(crate) const Z_LIM: i32 = 1 << 29;

/// e^(−i/32) in Q29 for i = 0..1024 (i ≥ 992 is never used: x < 31), by repeated
/// multiplication in Q62 (the accumulated error, ≤ 1024·2^−62, is far below Q29's step).
static EXP_STEPS: [u32; 1024] = exp_steps();

const fn exp_steps() -> [u32; 1024] {
    let mut t = [0u32; 1024];
    let mut v: u128 = 1 << 62;
    let mut i = 0;
    while i < 1024 {
        t[i] = ((v + (1 << 32)) >> 33) as u32;
        v = (v * EXP_STEP_Q62 + (1 << 61)) >> 62;
        i += 1;
    }
    t
}

/// (a·b) >> 32 for unsigned 32-bit operands: one `UMULL` on a Cortex-M3/M4.
const fn mul_hi(a: u32, b: u32) -> u32 {
    (((a as u64) * (b as u64)) >> 32) as u32
}

/// 1/24 and 1/6 in Q31.
const C4_Q31: u32 = 89_478_485;
const C3_Q31: u32 = 357_913_941;

/// exp(−x) for x ≥ 0 given in Q27 (unsigned), as a [`Kernel`] (Q28); 0 from x = 31 on.
///
/// x = i/32 + r with i = x >> 22; e^(−r) = 1 − r(1 − r(½ − r(⅙ − r/24))) by Horner in Q31
/// with r in Q32 (every partial value in (0, 1], so it fits a `u32`); then the table entry
/// (Q29) times that (Q31), high word: Q28.
pub const fn exp_neg_q27(x: u32) -> Kernel {
    if x >= X_MAX_Q27 {
        return Q(0);
    }
    Q(exp_below_31(x) as i32)
}

/// [`exp_neg_q27`] for x < 31·2^27, the Q28 value as a `u32` (< 2^28 + 1).
#[inline(always)]
const fn exp_below_31(x: u32) -> u32 {
    let i = (x >> 22) as usize & 1023;
    // The low 22 bits of x (Q27) as a Q32 fraction < 1/32 (two shifts: no mask constant).
    let r = (x << 10) >> 5;
    let mut t = C3_Q31 - mul_hi(r, C4_Q31);
    t = (1 << 30) - mul_hi(r, t);
    t = (1 << 31) - mul_hi(r, t);
    t = (1 << 31) - mul_hi(r, t);
    mul_hi(EXP_STEPS[i], t)
}

/// The input of Eq. (10) scaled by √γ (Q28) into Q24 and clamped to ±32.
#[inline(always)]
fn scale_inputs<const D: usize>(z: &[Z; D], sqrt_gamma: u32) -> [i32; D] {
    let sg = i64::from(sqrt_gamma);
    // |z| < 2^31 and √γ < 2^32 (Q28): the product fits an i64. Zipped, not indexed: no bounds
    // check even where this is not inlined.
    let mut zs = [0; D];
    for (o, v) in zs.iter_mut().zip(z) {
        let v = (i64::from(v.0) * sg + (1 << 27)) >> 28;
        *o = v.clamp(-i64::from(Z_LIM), i64::from(Z_LIM)) as i32;
    }
    zs
}

/// −aᵢ·kᵢ of one support vector in Q52 (Q24·Q28), or `None` when its kernel argument reaches
/// 31 (the term is below every coefficient's resolution).
#[inline(always)]
fn neg_term<const D: usize>(zs: &[i32; D], sv: &[Z; D], a: Dph) -> Option<i64> {
    // γ‖z − zᵢ‖² in Q48: differences within ±2^30, squares below 2^60, and fewer than 16 of
    // them (`D_FITS`): no overflow. The first two inputs are written out: at the board's
    // opt-level "s" a loop over D is not unrolled (it cost 8 instructions per input and
    // vector).
    let sq = |d: usize| {
        let diff = i64::from(zs[d] - sv[d].0);
        (diff * diff) as u64
    };
    let mut d2: u64 = 0;
    if D > 0 {
        d2 += sq(0);
    }
    if D > 1 {
        d2 += sq(1);
    }
    for d in 2..D {
        d2 += sq(d);
    }
    if (d2 >> 32) as u32 >= CUT_HI {
        return None;
    }
    // Q48 → Q27, below 31·2^27 after the cut.
    // The sum is kept negated: −k ∈ [−2^28, 0] has no known sign bit, so aᵢ·(−kᵢ) is one
    // signed `SMLAL`; with k itself (sign bit known 0) the compiler emits the signed ×
    // unsigned sequence, four instructions more.
    let neg_k = -(exp_below_31((d2 >> 21) as u32) as i32);
    Some(i64::from(a.0) * i64::from(neg_k))
}

/// Q52 → Q24 with rounding, then + b, saturating into i32.
#[inline(always)]
fn finish(neg_acc: i64, bias: Dph) -> Dph {
    let sum = (-neg_acc + (1 << 27)) >> 28;
    let sum = sum.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
    Q(sum).saturating_add(bias)
}

/// Why a table has no fixed-point form.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FixedError {
    /// A number is NaN, infinite or outside its Q format's range (the name of the field).
    Range(&'static str),
    /// The table has linear terms (`ModelSpec::linear_dph`), which the integer path does
    /// not evaluate: Eq. (10) alone is converted.
    LinearTerms,
    /// A fixed-point form given as parts is not the conversion of its f32 table (the name of
    /// the field that differs, or `"length"`).
    Mismatch(&'static str),
}

impl core::fmt::Display for FixedError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FixedError::Range(what) => write!(f, "{what} is outside its fixed-point range"),
            FixedError::LinearTerms => f.write_str("the table has linear terms"),
            FixedError::Mismatch(what) => {
                write!(
                    f,
                    "the fixed-point {what} is not the conversion of the f32 table"
                )
            }
        }
    }
}

impl core::error::Error for FixedError {}

/// A table in fixed point: N support vectors of dimension D. Built by
/// [`FixedModel::from_table`] only, which establishes the bounds [`FixedModel::predict`]
/// relies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FixedModel<const N: usize, const D: usize> {
    /// Standardised support vectors times √γ, within ±32.
    support: [[Z; D]; N],
    /// Coefficients a_i, °/h; Σ|a_i| < 2048 °/h.
    alpha: [Dph; N],
    /// √γ of Eq. (8) in standardised units, Q28.
    sqrt_gamma: u32,
    /// Bias b, °/h.
    bias: Dph,
}

/// ⌊√v⌉, the integer square root rounded to nearest.
const fn isqrt_round(v: u128) -> u128 {
    // Bit by bit: s is the largest integer with s² ≤ v.
    let mut s: u128 = 0;
    let mut bit: i32 = 63;
    while bit >= 0 {
        let c = s | (1u128 << bit);
        if c * c <= v {
            s = c;
        }
        bit -= 1;
    }
    // Round: s + ½ ≤ √v ⟺ s² + s < v (integers).
    if s * s + s < v {
        s + 1
    } else {
        s
    }
}

/// √γ in Q28 from γ's f32 bits, rounded to nearest; None unless 2^−32 ≤ γ < 256.
pub(crate) const fn sqrt_q28(bits: u32) -> Option<u32> {
    let exp = ((bits >> 23) & 0xff) as i32;
    if bits >> 31 != 0 || exp == 0xff || exp < 95 || exp >= 135 {
        return None;
    }
    // γ = mant·2^(exp − 150); (√γ·2^28)² = mant·2^(exp − 94), exp − 94 ≥ 1.
    let mant = ((bits & 0x7f_ffff) | 0x80_0000) as u128;
    // An integer whatever the parity of the shift: its root rounded to nearest is the Q28
    // value rounded to nearest.
    let r = isqrt_round(mant << (exp - 94));
    if r == 0 || r > u32::MAX as u128 {
        None
    } else {
        Some(r as u32)
    }
}

/// A standardised value given by its f32 bits times √γ (Q28), in Q24 rounded to nearest;
/// None for NaN/infinity or a result outside ±32.
pub(crate) const fn scaled_q24(bits: u32, sqrt_gamma: u32) -> Option<i32> {
    // value·√γ·2^24 = mant·sg·2^(e − 150 − 28 + 24) = mant·sg·2^(e − 154).
    round_scaled(bits, sqrt_gamma as u128, -154, Z_LIM as u128)
}

const fn conv<const F: u32>(v: f32, what: &'static str) -> Result<Q<F>, FixedError> {
    match Q::<F>::from_f32_bits(v.to_bits()) {
        Some(q) => Ok(q),
        None => Err(FixedError::Range(what)),
    }
}

impl<const N: usize, const D: usize> FixedModel<N, D> {
    /// The fixed-point form of `t` (integer arithmetic only; usable in a `const` item).
    ///
    /// Fails with [`FixedError::Range`] when γ is outside [2^−32, 256), a scaled support
    /// vector √γ·zᵢ outside ±32, Σ|aᵢ| ≥ 2048 °/h, or the bias outside ±128 °/h.
    pub const fn from_table(t: &ModelTable<N, D>) -> Result<Self, FixedError> {
        let () = Self::D_FITS;
        let mut d = 0;
        while d < D {
            if t.spec.linear_dph[d] != 0.0 {
                return Err(FixedError::LinearTerms);
            }
            d += 1;
        }
        let sqrt_gamma = match sqrt_q28(t.spec.gamma.to_bits()) {
            Some(v) => v,
            None => return Err(FixedError::Range("gamma")),
        };
        let mut out = FixedModel {
            support: [[Q(0); D]; N],
            alpha: [Q(0); N],
            sqrt_gamma,
            bias: Q(0),
        };
        let mut abs_sum: i64 = 0;
        let mut i = 0;
        while i < N {
            let mut d = 0;
            while d < D {
                out.support[i][d] = match scaled_q24(t.support[i][d].to_bits(), sqrt_gamma) {
                    Some(v) => Q(v),
                    None => return Err(FixedError::Range("support")),
                };
                d += 1;
            }
            out.alpha[i] = match conv(t.alpha_dph[i], "alpha_dph") {
                Ok(q) => q,
                Err(e) => return Err(e),
            };
            abs_sum += (out.alpha[i].0 as i64).abs();
            i += 1;
        }
        // Σ|aᵢ|·2^24 (Q24) times kernels < 2^28 stays below 2^63.
        if abs_sum >= ABS_ALPHA_SUM_LIMIT {
            return Err(FixedError::Range("alpha_dph"));
        }
        out.bias = match conv(t.spec.bias_dph, "bias_dph") {
            Ok(q) => q,
            Err(e) => return Err(e),
        };
        Ok(out)
    }

    /// Eq. (10) at a standardised input, °/h, integer-only.
    ///
    /// The input is scaled by √γ and clamped to ±32 (a validated table's inputs, clamped to
    /// the trained range, stay far inside). Terms whose kernel argument reaches 31
    /// (e^−31 = 3.4e-14) are skipped, so the cost depends a little on the input; the budget
    /// command reports the mean over a recording.
    // Not inlined: inside the caller's loop the compiler ran out of registers and reloaded
    // five constants per vector.
    #[inline(never)]
    pub fn predict(&self, z: &[Z; D]) -> Dph {
        let zs = scale_inputs(z, self.sqrt_gamma);
        // −Σ aᵢ·kᵢ in Q52 (Q24·Q28): |Σ| ≤ Σ|aᵢ|·2^28 < 2^63 by the conversion's check.
        let mut neg_acc: i64 = 0;
        // An index loop: zipping the two arrays costs six instructions per vector at
        // opt-level "s" (the bound of the shorter one is recomputed).
        for i in 0..N {
            if let Some(t) = neg_term(&zs, &self.support[i], self.alpha[i]) {
                neg_acc += t;
            }
        }
        finish(neg_acc, self.bias)
    }

    /// The model as borrowed parts ([`FixedModelRef`]), as a table laid out by C code gives it.
    pub fn as_model(&self) -> FixedModelRef<'_, D> {
        FixedModelRef {
            support: &self.support,
            alpha: &self.alpha,
            sqrt_gamma: self.sqrt_gamma,
            bias: self.bias,
        }
    }

    /// Compile-time check that D squares below 2^60 fit a u64.
    const D_FITS: () = assert!(D < 16, "FixedModel supports fewer than 16 inputs");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversion_rounds_to_nearest() {
        for v in [0.0f32, 1.0, -1.0, 0.5, 3.25e-3, -7.1, 127.9, 1e-12, -2.0e-8] {
            let q = Q::<24>::from_f32_bits(v.to_bits()).unwrap();
            let want = (f64::from(v) * (1u64 << 24) as f64).round();
            assert_eq!(f64::from(q.0), want, "{v}");
        }
        assert!(Q::<24>::from_f32_bits(200.0f32.to_bits()).is_none());
        assert!(Q::<24>::from_f32_bits(f32::NAN.to_bits()).is_none());
        assert!(Q::<24>::from_f32_bits(f32::INFINITY.to_bits()).is_none());
    }

    /// exp(−x) against f64 over [0, 31): absolute error ≤ 2 Q28 units (7.5e-9): the table's
    /// rounding (≤ 9.3e-10), the Taylor truncation (≤ 2.5e-10), four truncated Horner steps
    /// (≤ 1.9e-9) and the truncated final product (< 3.7e-9).
    #[test]
    fn exp_error_is_a_few_q28_units() {
        let mut worst = 0.0f64;
        for i in 0..(31u32 << 14) {
            let x = i << 13; // step 2^-14 in Q27
            let got = exp_neg_q27(x).to_f64();
            let want = (-(f64::from(x) / (1u64 << 27) as f64)).exp();
            worst = worst.max((got - want).abs());
        }
        println!("fixed-point exp: worst absolute error {worst:e}");
        assert!(worst <= 2.0 / (1u64 << 28) as f64, "worst {worst:e}");
        assert!(worst > 0.0);
        assert_eq!(exp_neg_q27(0).0, 1 << 28);
        assert_eq!(exp_neg_q27(X_MAX_Q27).0, 0);
        assert_eq!(EXP_STEPS[0], 1 << 29);
    }

    /// √γ rounds to nearest, and values outside the accepted range are refused.
    #[test]
    fn sqrt_gamma_rounds_to_nearest() {
        for g in [1.0f32, 1.113_895, 0.25, 2.0, 3.0e-3, 50.0, 255.0] {
            let got = f64::from(sqrt_q28(g.to_bits()).unwrap());
            let want = f64::from(g).sqrt() * (1u64 << 28) as f64;
            assert!((got - want).abs() <= 0.5, "{g}: {got} vs {want}");
        }
        for g in [0.0f32, -1.0, 256.0, f32::NAN, f32::INFINITY, 1e-12] {
            assert!(sqrt_q28(g.to_bits()).is_none(), "{g}");
        }
        assert_eq!(isqrt_round(0), 0);
        assert_eq!(isqrt_round(2), 1);
        assert_eq!(isqrt_round(3), 2);
        assert_eq!(isqrt_round(u64::MAX as u128), 1 << 32);
    }

    /// Scaled support vectors: nearest Q24 value of z·√γ, refused beyond ±32.
    #[test]
    fn scaling_rounds_to_nearest_and_bounds() {
        let sg = sqrt_q28(1.113_895f32.to_bits()).unwrap();
        let sgf = f64::from(sg) / (1u64 << 28) as f64;
        for z in [0.0f32, 1.0, -1.7, 3.25e-3, 29.0, -2.0e-8] {
            let got = f64::from(scaled_q24(z.to_bits(), sg).unwrap());
            let want = f64::from(z) * sgf * (1u64 << 24) as f64;
            assert!((got - want).abs() <= 0.5, "{z}: {got} vs {want}");
        }
        assert!(scaled_q24(31.0f32.to_bits(), sg).is_none());
        assert!(scaled_q24(f32::NAN.to_bits(), sg).is_none());
    }

    #[test]
    fn saturates_instead_of_wrapping() {
        let big = Q::<24>(i32::MAX - 1);
        assert_eq!(big.saturating_add(Q(5)).0, i32::MAX);
        assert_eq!(Q::<24>(i32::MIN + 1).saturating_sub(Q(5)).0, i32::MIN);
    }
}
