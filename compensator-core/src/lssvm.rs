//! f32 evaluation of the LS-SVM regression function, Yu et al. 2011 Eq. (10):
//!
//! f(x) = Σᵢ aᵢ · exp(−‖z(x) − zᵢ‖² / 2σ²) + b,  z(x) = (x − mean) ⊙ inv_scale,
//!
//! with the Gaussian kernel of Eq. (8) written as exp(−γ‖·‖²), γ = 1/(2σ²).
//!
//! Accuracy against the trainer's f64 evaluation of the same model is a budget enforced by the
//! host tests (`tests/`); the measured figure is quoted where the budget is defined.
//! The exp is software on every target ([`crate::fastexp`], or `libm::expf` for reference)
//! and no operation is fused, so the host and the board round identically.

use crate::table::ModelRef;

impl<const D: usize> ModelRef<'_, D> {
    /// Standardises a raw feature vector with the table's mean and inverse scale.
    #[inline]
    pub fn standardise(&self, x: &[f32; D]) -> [f32; D] {
        let s = self.spec;
        // `get`, not indexing: no bounds check survives even where this is not inlined (the C
        // library holds five input counts; its link proves it panic-free). Inlined, the `None`
        // arms vanish and the code is that of plain indexing.
        core::array::from_fn(
            |d| match (x.get(d), s.input_mean.get(d), s.input_inv_scale.get(d)) {
                (Some(x), Some(m), Some(k)) => (x - m) * k,
                _ => 0.0,
            },
        )
    }

    /// The model at a raw (unstandardised) feature vector, °/h: Eq. (10) plus the linear
    /// terms Σ_d linear_d·(x_d − mean_d) ([`crate::ModelSpec::linear_dph`]; zero for the
    /// paper's model).
    ///
    /// No clamping: the caller decides what to do outside the trained range
    /// (see [`crate::Compensator`]). Finite for finite input and a validated table, since the
    /// kernel lies in (0, 1].
    #[inline]
    pub fn predict_dph(&self, x: &[f32; D]) -> f32 {
        self.predict_standardised_dph(&self.standardise(x)) + self.linear_dph(x)
    }

    /// Σ_d linear_d·(x_d − mean_d), °/h, summed in feature order (0 for a table without
    /// linear terms).
    #[inline]
    pub fn linear_dph(&self, x: &[f32; D]) -> f32 {
        let s = self.spec;
        let mut sum = 0.0f32;
        for ((b, v), m) in s.linear_dph.iter().zip(x).zip(&s.input_mean) {
            sum += b * (v - m);
        }
        sum
    }

    /// Eq. (10) at an already standardised feature vector, °/h: the board's evaluation, with
    /// the kernel's exp from [`crate::fastexp::exp_neg`] (≤ 3 ulp).
    #[inline]
    pub fn predict_standardised_dph(&self, z: &[f32; D]) -> f32 {
        self.predict_standardised_dph_with(z, crate::fastexp::exp_neg)
    }

    /// [`ModelRef::predict_standardised_dph`] with `libm::expf` (≤ 1 ulp, about a quarter
    /// slower on the board): the reference choice the budgets compare against.
    #[inline]
    pub fn predict_standardised_dph_libm(&self, z: &[f32; D]) -> f32 {
        self.predict_standardised_dph_with(z, |v| libm::expf(-v))
    }

    /// Eq. (10) at a standardised feature vector with the kernel value from `exp_neg`, which
    /// is called with γ‖z − zᵢ‖² ≥ 0 and must return its exp(−·).
    ///
    /// The kernel sum is accumulated with TwoSum error compensation (Knuth): the coefficients
    /// of a tightly regularised model reach |aᵢ| ≫ |f| with cancelling signs, and plain f32
    /// summation would then lose the 1e-5 °/h agreement budget. TwoSum recovers each
    /// addition's rounding error exactly whatever the magnitudes, in six adds and no branch
    /// (the magnitude test of Neumaier's variant costs a compare and a flag transfer).
    #[inline]
    pub fn predict_standardised_dph_with(&self, z: &[f32; D], exp_neg: impl Fn(f32) -> f32) -> f32 {
        let gamma = self.spec.gamma;
        let mut sum = 0.0f32;
        let mut carry = 0.0f32;
        for (sv, a) in self.support.iter().zip(self.alpha_dph) {
            let term = a * exp_neg(gamma * squared_distance(z, sv));
            let t = sum + term;
            let b = t - sum;
            carry += (sum - (t - b)) + (term - b);
            sum = t;
        }
        sum + carry + self.spec.bias_dph
    }
}

/// ‖z − s‖², accumulated from the first feature on (the order the host reference uses).
/// Two features, the paper's [T, dT/dt], are written out: the size-optimised board build
/// would otherwise keep a two-trip loop per support vector.
#[inline(always)]
fn squared_distance<const D: usize>(z: &[f32; D], s: &[f32; D]) -> f32 {
    if D == 2 {
        let (a, b) = (z[0] - s[0], z[1] - s[1]);
        return a * a + b * b;
    }
    let mut d2 = 0.0f32;
    for d in 0..D {
        let diff = z[d] - s[d];
        d2 += diff * diff;
    }
    d2
}

#[cfg(test)]
mod tests {
    use crate::rate::RateFilter;
    use crate::table::{Feature, ModelSpec, ModelTable};

    fn spec() -> ModelSpec<1> {
        ModelSpec {
            features: [Feature::TempC],
            input_mean: [10.0],
            input_inv_scale: [0.5],
            linear_dph: [0.0],
            input_lo: [0.0],
            input_hi: [20.0],
            gamma: 0.5,
            bias_dph: -7.0,
            reference_dph: -7.0,
            rate_filter: RateFilter::from_tau_s(60.0, 1.0),
        }
    }

    /// Two support vectors, evaluated by hand in f64.
    #[test]
    fn matches_hand_computed_value() {
        let table = ModelTable {
            spec: spec(),
            support: [[-1.0], [1.0]],
            alpha_dph: [0.25, -0.5],
            crc32: 0,
        };
        let m = table.as_model();
        m.validate().unwrap();
        // x = 12 → z = 1; distances² 4 and 0.
        let want = 0.25 * (-0.5f64 * 4.0).exp() - 0.5 + -7.0;
        let got = m.predict_dph(&[12.0]);
        assert!((f64::from(got) - want).abs() < 1e-6, "{got} vs {want}");
    }

    #[test]
    fn compensated_sum_survives_cancellation() {
        // Large cancelling coefficients at identical support vectors: exact sum is 1e-3, which a
        // plain f32 sum in this order rounds to 0 or 9.8e-4 (ulp of 1e4 is 9.8e-4).
        let table = ModelTable {
            spec: spec(),
            support: [[0.0], [0.0], [0.0]],
            alpha_dph: [1.0e4, 1.0e-3, -1.0e4],
            crc32: 0,
        };
        let got = table.as_model().predict_standardised_dph(&[0.0]) + 7.0;
        assert!((got - 1.0e-3).abs() < 1e-6, "{got}");
    }
}
