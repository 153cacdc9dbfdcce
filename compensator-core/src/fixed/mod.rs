//! Integer-only evaluation of Eq. (10) for FPU-less boards (Cortex-M0+/M3).
//!
//! Q formats are in the types: [`Q<F>`] is an `i32` holding value·2^F. The model is held as
//!
//! * standardised support vectors and inputs: [`Z`] = `Q<24>` (±128, resolution 6.0e-8);
//! * coefficients, bias and output, °/h: [`Dph`] = `Q<24>` (±128 °/h, resolution 6.0e-8 °/h);
//! * γ: `Q<24>`; the kernel argument γ‖z − zᵢ‖²: `u32` Q27 (clamped at 31, where
//!   e^−31 = 3.4e-14 is below every coefficient's resolution); the kernel value: [`Kernel`] =
//!   `Q<30>`.
//!
//! Products are formed in `i64`/`u64` and rounded to nearest; every add that can overflow
//! saturates. exp(−x) ([`exp_neg_q27`]) reduces x·log2(e) = k + f with |f| ≤ ½ and evaluates
//! e^(−f·ln2) by a degree-7 Taylor polynomial in Q30 (truncation ≤ 0.347⁸/8! = 5.2e-9), then
//! shifts by k.
//!
//! The table is converted from the f32 table ([`FixedModel::from_table`]) with integer bit
//! manipulation only (round to nearest, ties away from zero), in a `const fn`, so a board
//! holds the converted table in flash and never touches a float. Accuracy against the f64
//! reference is measured by `tests/tests/fixed_point.rs`.

use crate::table::ModelTable;

pub mod trace;
pub use trace::FixedTrace;

/// A signed fixed-point number: the `i32` holds value·2^F.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Q<const F: u32>(pub i32);

/// Standardised feature value.
pub type Z = Q<24>;
/// A rate, °/h.
pub type Dph = Q<24>;
/// A kernel value in (0, 1].
pub type Kernel = Q<30>;

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
        let neg = bits >> 31 != 0;
        let exp = ((bits >> 23) & 0xff) as i32;
        if exp == 0xff {
            return None;
        }
        let (mant, e) = if exp == 0 {
            ((bits & 0x7f_ffff) as u64, 1)
        } else {
            (((bits & 0x7f_ffff) | 0x80_0000) as u64, exp)
        };
        // value = mant·2^(e − 150); in Q<F>: mant·2^(e − 150 + F).
        let shift = e - 150 + F as i32;
        let mag: u64 = if shift >= 0 {
            if shift > 40 {
                return None;
            }
            mant << shift
        } else if -shift > 40 {
            0
        } else {
            let s = (-shift) as u32;
            (mant + (1 << (s - 1))) >> s
        };
        if mag > i32::MAX as u64 {
            return None;
        }
        let v = mag as i32;
        Some(Q(if neg { -v } else { v }))
    }
}

/// The high word of a·b rounded to nearest: (a·b + 2^31) >> 32.
const fn mul_hi(a: i32, b: i32) -> i32 {
    (((a as i64) * (b as i64) + (1 << 31)) >> 32) as i32
}

/// log2(e) in Q30.
const LOG2_E_Q30: u64 = 1_549_082_005;
/// ln 2 in Q32.
const LN2_Q32: i64 = 2_977_044_472;
/// 1/n! in Q30, n = 0..=7: round(2^30/n!).
const INV_FACT_Q30: [i64; 8] = [
    1_073_741_824,
    1_073_741_824,
    536_870_912,
    178_956_971,
    44_739_243,
    8_947_849,
    1_491_308,
    213_044,
];
/// Kernel arguments at or above 31 (Q27) give 0 (e^−31 = 3.4e-14).
const X_MAX_Q27: u32 = 31 << 27;

/// exp(−x) for x ≥ 0 given in Q27 (unsigned), as a [`Kernel`] (Q30).
///
/// Every product is 32 × 32 → 64 bits (one `SMULL`/`UMULL` on a Cortex-M3/M4).
pub const fn exp_neg_q27(x: u32) -> Kernel {
    if x >= X_MAX_Q27 {
        return Q(0);
    }
    // y = x·log2(e), Q27; < 44.8·2^27 < 2^33, so it is kept in u64.
    let y = ((x as u64) * LOG2_E_Q30 + (1 << 29)) >> 30;
    let k = (y + (1 << 26)) >> 27; // round(y) ≤ 45
    let f = (y as i64 - ((k as i64) << 27)) as i32; // |f| ≤ 2^26 (½ in Q27)
                                                    // u = −f·ln2 in Q32, |u| ≤ 0.347·2^32 < 2^31.
    let u = -(((f as i64) * LN2_Q32 + (1 << 26)) >> 27) as i32;
    // e^u by Horner in Q30: p·u is Q62, its high word (>> 32, rounded) is Q30 again — one
    // multiply-high per step. Every partial value lies in (−2, 2) and fits an i32.
    // Written out: a loop over the coefficients is not unrolled at opt-level "s".
    let c = INV_FACT_Q30;
    let mut p = c[7] as i32;
    p = c[6] as i32 + mul_hi(p, u);
    p = c[5] as i32 + mul_hi(p, u);
    p = c[4] as i32 + mul_hi(p, u);
    p = c[3] as i32 + mul_hi(p, u);
    p = c[2] as i32 + mul_hi(p, u);
    p = c[1] as i32 + mul_hi(p, u);
    p = c[0] as i32 + mul_hi(p, u);
    // p ∈ (0.70, 1.42) in Q30; divide by 2^k with rounding.
    if k >= 31 {
        return Q(0);
    }
    let v = if k == 0 { p } else { (p + (1 << (k - 1))) >> k };
    Q(v)
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
}

/// A table in fixed point: N support vectors of dimension D.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FixedModel<const N: usize, const D: usize> {
    /// Standardised support vectors.
    pub support: [[Z; D]; N],
    /// Coefficients a_i, °/h.
    pub alpha: [Dph; N],
    /// γ of Eq. (8) in standardised units, Q24.
    pub gamma: Q<24>,
    /// Bias b, °/h.
    pub bias: Dph,
}

const fn conv<const F: u32>(v: f32, what: &'static str) -> Result<Q<F>, FixedError> {
    match Q::<F>::from_f32_bits(v.to_bits()) {
        Some(q) => Ok(q),
        None => Err(FixedError::Range(what)),
    }
}

impl<const N: usize, const D: usize> FixedModel<N, D> {
    /// The fixed-point form of `t` (integer arithmetic only; usable in a `const` item).
    pub const fn from_table(t: &ModelTable<N, D>) -> Result<Self, FixedError> {
        let mut d = 0;
        while d < D {
            if t.spec.linear_dph[d] != 0.0 {
                return Err(FixedError::LinearTerms);
            }
            d += 1;
        }
        let mut out = FixedModel {
            support: [[Q(0); D]; N],
            alpha: [Q(0); N],
            gamma: Q(0),
            bias: Q(0),
        };
        let mut i = 0;
        while i < N {
            let mut d = 0;
            while d < D {
                out.support[i][d] = match conv(t.support[i][d], "support") {
                    Ok(q) => q,
                    Err(e) => return Err(e),
                };
                d += 1;
            }
            out.alpha[i] = match conv(t.alpha_dph[i], "alpha_dph") {
                Ok(q) => q,
                Err(e) => return Err(e),
            };
            i += 1;
        }
        out.gamma = match conv(t.spec.gamma, "gamma") {
            Ok(q) => q,
            Err(e) => return Err(e),
        };
        out.bias = match conv(t.spec.bias_dph, "bias_dph") {
            Ok(q) => q,
            Err(e) => return Err(e),
        };
        Ok(out)
    }

    /// Eq. (10) at a standardised input, °/h, integer-only.
    ///
    /// Terms whose kernel argument reaches 31 (e^−31 = 3.4e-14) are skipped, so the cost
    /// depends a little on the input; the budget command reports the mean over a recording.
    pub fn predict(&self, z: &[Z; D]) -> Dph {
        let gamma = i64::from(self.gamma.0);
        // ‖z − zᵢ‖² (Q27) at which γ‖·‖² reaches 31: beyond it the term is 0. For γ > 0
        // (validated tables) the cut is ≤ 31·2^51/γ_q24, and below it γ·d2 < 2^56.
        let cut_q27 = if gamma > 0 {
            (i64::from(X_MAX_Q27) << 24) / gamma
        } else {
            0 // γ ≤ 0: not a validated table; every term is skipped, f = b
        };
        // Σ aᵢ·kᵢ in Q40 (each Q54 product rounded down 14 bits). |term| < 2^47, so the
        // sum of fewer than 2^16 terms cannot overflow an i64 (checked at compile time for
        // every instantiated N by `N_FITS`).
        let () = Self::N_FITS;
        let mut acc: i64 = 0;
        for (sv, a) in self.support.iter().zip(&self.alpha) {
            // ‖z − zᵢ‖² in Q48; each difference saturates in i32 (a saturated one is ≥ 128,
            // far outside every kernel), each square < 2^62, the sum saturates.
            let mut d2: i64 = 0;
            for d in 0..D {
                let diff = i64::from(z[d].0.saturating_sub(sv[d].0));
                d2 = d2.saturating_add(diff * diff);
            }
            let d2_q27 = (d2 >> 21) + ((d2 >> 20) & 1); // round Q48 → Q27
            if d2_q27 >= cut_q27 {
                continue;
            }
            // x = γ·d2 in Q27 (Q24·Q27 >> 24) < 31·2^27.
            let x = ((d2_q27 * gamma + (1 << 23)) >> 24) as u32;
            let k = exp_neg_q27(x);
            acc += (i64::from(a.0) * i64::from(k.0) + (1 << 13)) >> 14;
        }
        // Q40 → Q24 with rounding, then + b, saturating into i32.
        let sum = (acc + (1 << 15)) >> 16;
        let sum = sum.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
        Q(sum).saturating_add(self.bias)
    }

    /// Compile-time check that N terms of magnitude < 2^47 cannot overflow the i64 sum.
    const N_FITS: () = assert!(
        N < (1 << 16),
        "FixedModel supports fewer than 65536 vectors"
    );
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

    /// exp(−x) against f64 over [0, 31): absolute error ≤ 8 Q30 units (7.5e-9; measured
    /// 7.2e-9: the Taylor truncation 5.2e-9 plus the roundings of Horner's steps).
    #[test]
    fn exp_error_is_a_few_q30_units() {
        let mut worst = 0.0f64;
        for i in 0..(31u32 << 14) {
            let x = i << 13; // step 2^-14 in Q27
            let got = exp_neg_q27(x).to_f64();
            let want = (-(f64::from(x) / (1u64 << 27) as f64)).exp();
            worst = worst.max((got - want).abs());
        }
        assert!(worst <= 8.0 / (1u64 << 30) as f64, "worst {worst:e}");
        assert_eq!(exp_neg_q27(0).0, 1 << 30);
        assert_eq!(exp_neg_q27(X_MAX_Q27).0, 0);
    }

    #[test]
    fn saturates_instead_of_wrapping() {
        let big = Q::<24>(i32::MAX - 1);
        assert_eq!(big.saturating_add(Q(5)).0, i32::MAX);
        assert_eq!(Q::<24>(i32::MIN + 1).saturating_sub(Q(5)).0, i32::MIN);
    }
}
