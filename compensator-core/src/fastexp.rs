//! The exp of the Gaussian kernel on the board: faster than `libm::expf`, which stays
//! available as the reference choice (`ModelRef::predict_standardised_dph_libm`).
//!
//! exp(−x) for x ≥ 0 (the kernel argument γ‖z − zᵢ‖² is never negative) by Cody–Waite range
//! reduction x·log2(e) = k + f, |r| = |f·ln 2| ≤ ln2/2, a degree-5 polynomial for e^r,
//! 1 + r + r²·q(r) with q the cubic minimising the largest relative error of e^r on
//! [−ln2/2, ln2/2] (0.88 ulp; fitted offline by Lawson's iteratively reweighted least squares),
//! and the scale 2^k put into the exponent bits.
//! One special case, x > 87 → 0 (e^−87 = 1.6e-38 is below every coefficient's resolution);
//! NaN gives NaN and a negative x is treated as 0. `libm::expf` spends its extra instructions
//! on the general argument range and on correct rounding.
//!
//! Measured error against f64 `exp`: 1.49 ulp relative at worst over [0, 87]
//! (`fastexp::tests`, budget 3 ulp; `libm::expf`: < 1 ulp). Its cost on whole models against
//! the 1e-5 °/h budget is measured by `tests/tests/f32_vs_f64.rs` and the budget command.

/// 1.5·2²³: adding and subtracting it rounds an f32 of magnitude < 2²² to an integer
/// (round to nearest even), in two adds and without a float→int conversion of a fraction.
const ROUND_MAGIC: f32 = 12_582_912.0;
/// log2(e).
const LOG2_E: f32 = core::f32::consts::LOG2_E;
/// ln 2 split for Cody–Waite: `LN2_HI` has 16 significant bits, so k·LN2_HI is exact for
/// |k| ≤ 128.
const LN2_HI: f32 = 0.693_145_75;
/// ln 2 − `LN2_HI`.
const LN2_LO: f32 = 1.428_606_8e-6;

/// Coefficients of q(r) = c₂ + c₃r + c₄r² + c₅r³, e^r ≈ 1 + r + r²·q(r) on |r| ≤ ln2/2.
const C2: f32 = 0.499_992_3;
/// See [`C2`].
const C3: f32 = 0.166_671_14;
/// See [`C2`].
const C4: f32 = 0.041_890_074;
/// See [`C2`].
const C5: f32 = 0.008_312_472;

/// Bit pattern of 87.0f32: for a non-negative f32 the bit patterns order like the values,
/// and every negative number or NaN compares above it as an unsigned integer.
const LIMIT_BITS: u32 = 0x42ae_0000;

/// exp(−x) for x ≥ 0; x > 87 gives 0, a negative x is treated as 0 (giving 1), NaN gives NaN.
///
/// The common case 0 ≤ x ≤ 87 is recognised by one unsigned compare of the bit pattern
/// (negative numbers, −0.0 and NaN all have bits above 87.0's), so the kernel loop pays one
/// compare and branch for all three special cases.
#[inline]
pub fn exp_neg(x: f32) -> f32 {
    if x.to_bits() > LIMIT_BITS {
        return special(x);
    }
    // k = round(−x·log2 e) ∈ [−126, 0]: after adding ROUND_MAGIC the sum's low mantissa
    // bits hold k in two's complement.
    let t = -x * LOG2_E + ROUND_MAGIC;
    let kf = t - ROUND_MAGIC;
    let r = (-x - kf * LN2_HI) - kf * LN2_LO;
    // e^r by Estrin's scheme, (1 + r) + r²·((c₂ + c₃r) + r²(c₄ + c₅r)): two fewer register
    // moves than Horner on a multiply-accumulate FPU.
    let r2 = r * r;
    let p = 1.0 + (r + r2 * ((C2 + C3 * r) + r2 * (C4 + C5 * r)));
    // 2^k: k's low bits shifted into the exponent field (k ≥ −126, so the biased exponent
    // k + 127 is ≥ 1), without a float-to-integer conversion.
    let scale = f32::from_bits((t.to_bits() << 23).wrapping_add(127 << 23));
    p * scale
}

/// The cases [`exp_neg`] keeps off its fast path.
#[cold]
fn special(x: f32) -> f32 {
    if x.is_nan() {
        x
    } else if x > 0.0 {
        0.0
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relative error against f64 exp over a dense grid of [0, 87): at most 3 f32 ulps
    /// (ulp = 2⁻²³ relative at worst 1.19e-7).
    #[test]
    fn relative_error_is_within_three_ulp() {
        let mut worst = 0.0f64;
        let n = 2_000_000;
        for i in 0..n {
            let x = 87.0 * (i as f32) / (n as f32);
            let got = f64::from(exp_neg(x));
            let want = (-f64::from(x)).exp();
            worst = worst.max((got - want).abs() / want);
        }
        assert!(
            worst < 3.0 * f64::from(f32::EPSILON),
            "worst relative error {worst:e}"
        );
        eprintln!("exp_neg: worst {:.2} ulp", worst / f64::from(f32::EPSILON));
        // and libm::expf for comparison is within 1 ulp (the reference evaluator's exp)
        let mut libm_worst = 0.0f64;
        for i in 0..n {
            let x = 87.0 * (i as f32) / (n as f32);
            let want = (-f64::from(x)).exp();
            libm_worst = libm_worst.max((f64::from(libm::expf(-x)) - want).abs() / want);
        }
        assert!(libm_worst < f64::from(f32::EPSILON), "{libm_worst:e}");
    }

    /// The polynomial itself, evaluated in f64 with its f32 coefficients: the approximation
    /// error the module doc quotes (0.88 ulp of f32), so the rest of the 1.49 ulp is rounding.
    #[test]
    fn polynomial_approximation_error() {
        let a = core::f64::consts::LN_2 / 2.0;
        let c = [C2, C3, C4, C5].map(f64::from);
        let worst = (0..=100_000)
            .map(|i| {
                let r = -a + 2.0 * a * f64::from(i) / 100_000.0;
                let p = 1.0 + r + r * r * (c[0] + r * (c[1] + r * (c[2] + r * c[3])));
                (p - r.exp()).abs() / r.exp()
            })
            .fold(0.0, f64::max);
        let ulp = worst / f64::from(f32::EPSILON);
        assert!(ulp < 0.9, "{ulp} ulp");
    }

    #[test]
    fn edges() {
        assert_eq!(exp_neg(0.0), 1.0);
        assert_eq!(exp_neg(-0.0), 1.0);
        assert_eq!(exp_neg(-3.0), 1.0);
        assert_eq!(exp_neg(f32::NEG_INFINITY), 1.0);
        assert_eq!(exp_neg(f32::from_bits(LIMIT_BITS)), exp_neg(87.0));
        assert!(exp_neg(87.0) > 0.0);
        assert_eq!(exp_neg(87.000_01), 0.0);
        assert_eq!(exp_neg(f32::INFINITY), 0.0);
        assert!(exp_neg(f32::NAN).is_nan());
        assert!(exp_neg(86.9) > 0.0 && exp_neg(86.9).is_normal());
    }
}
