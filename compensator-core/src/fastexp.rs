//! A faster exp for the Gaussian kernel, offered as an alternative to `libm::expf`.
//!
//! exp(−x) for x ≥ 0 (the kernel argument γ‖z − zᵢ‖² is never negative) by Cody–Waite range
//! reduction x·log2(e) = k + f, |r| = |f·ln 2| ≤ ln2/2, a degree-6 Taylor polynomial for e^r
//! (truncation error r⁷/7! ≤ 1.2e-7 relative) and the scale 2^k put into the exponent bits.
//! No special cases beyond x ≥ 87 → 0 (e^−87 = 1.6e-38 is below every coefficient's
//! resolution) and NaN → NaN, which `libm::expf` spends its extra instructions on.
//!
//! Measured error against f64 `exp`: see `fastexp::tests` (≤ 3 ulp relative over [0, 87]); the
//! cost of that error on a whole model against the 1e-5 °/h budget is measured by the budget
//! command, not assumed here.

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

/// exp(−x), x ≥ 0 (a negative x is treated as 0, giving 1; NaN gives NaN).
#[inline]
pub fn exp_neg(x: f32) -> f32 {
    if x.is_nan() {
        return x;
    }
    if x >= 87.0 {
        return 0.0;
    }
    let x = if x > 0.0 { x } else { 0.0 };
    // k = round(−x·log2 e) ∈ [−126, 0].
    let kf = (-x * LOG2_E + ROUND_MAGIC) - ROUND_MAGIC;
    let r = (-x - kf * LN2_HI) - kf * LN2_LO;
    // e^r, Horner form of the Taylor series to r⁶.
    let p = 1.0
        + r * (1.0
            + r * (0.5
                + r * (1.0 / 6.0 + r * (1.0 / 24.0 + r * (1.0 / 120.0 + r * (1.0 / 720.0))))));
    // kf is an integer in [−126, 0], so the cast is exact and the biased exponent is ≥ 1.
    let k = kf as i32;
    let scale = f32::from_bits(((k + 127) as u32) << 23);
    p * scale
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
        // and libm::expf for comparison is within 1 ulp (the reference evaluator's exp)
        let mut libm_worst = 0.0f64;
        for i in 0..n {
            let x = 87.0 * (i as f32) / (n as f32);
            let want = (-f64::from(x)).exp();
            libm_worst = libm_worst.max((f64::from(libm::expf(-x)) - want).abs() / want);
        }
        assert!(libm_worst < f64::from(f32::EPSILON), "{libm_worst:e}");
    }

    #[test]
    fn edges() {
        assert_eq!(exp_neg(0.0), 1.0);
        assert_eq!(exp_neg(-3.0), 1.0);
        assert_eq!(exp_neg(87.0), 0.0);
        assert_eq!(exp_neg(f32::INFINITY), 0.0);
        assert!(exp_neg(f32::NAN).is_nan());
        assert!(exp_neg(86.9) > 0.0 && exp_neg(86.9).is_normal());
    }
}
