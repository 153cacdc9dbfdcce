//! The fixed-point model as borrowed parts: what a table laid out by C code holds next to its
//! f32 numbers, checked against them once ([`FixedModelRef::verified`]) so that the bounds
//! [`FixedModelRef::predict`] relies on hold as they do for [`super::FixedModel`].
//!
//! The conversion of each part ([`sqrt_gamma_q28`], [`scaled_vector`], [`Dph`] by
//! [`Q::from_f32_bits`]) is the one [`super::FixedModel::from_table`] applies, exposed for
//! exporters that write the parts out.

use super::{
    finish, neg_term, scale_inputs, scaled_q24, sqrt_q28, Dph, FixedError, ABS_ALPHA_SUM_LIMIT, Q,
    Z,
};
use crate::table::ModelRef;

/// √γ of Eq. (8) in Q28, rounded to nearest; fails unless 2^−32 ≤ γ < 256.
pub fn sqrt_gamma_q28(gamma: f32) -> Result<u32, FixedError> {
    sqrt_q28(gamma.to_bits()).ok_or(FixedError::Range("gamma"))
}

/// A standardised support vector times √γ (Q28), in Q24 rounded to nearest; fails for an entry
/// outside ±32.
pub fn scaled_vector<const D: usize>(sv: &[f32; D], sqrt_gamma: u32) -> Result<[Z; D], FixedError> {
    let mut out = [Q(0); D];
    for (o, v) in out.iter_mut().zip(sv) {
        *o = Q(scaled_q24(v.to_bits(), sqrt_gamma).ok_or(FixedError::Range("support"))?);
    }
    Ok(out)
}

fn dph(v: f32, what: &'static str) -> Result<Dph, FixedError> {
    Q::from_f32_bits(v.to_bits()).ok_or(FixedError::Range(what))
}

/// A fixed-point model whose support vectors and coefficients are borrowed: the same
/// evaluation as [`super::FixedModel::predict`] for a size known at run time. Built by
/// [`FixedModelRef::verified`] or [`super::FixedModel::as_model`] only, which establish the
/// bounds the evaluation relies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FixedModelRef<'a, const D: usize> {
    pub(super) support: &'a [[Z; D]],
    pub(super) alpha: &'a [Dph],
    pub(super) sqrt_gamma: u32,
    pub(super) bias: Dph,
}

impl<'a, const D: usize> FixedModelRef<'a, D> {
    /// The parts, after checking that each is exactly the conversion of `model`'s f32 number
    /// ([`super::FixedModel::from_table`]'s rules): √γ (Q28), the scaled support vectors and the
    /// coefficients and bias (Q24). A table whose f32 content passed its CRC thus vouches for
    /// its fixed-point form too.
    pub fn verified(
        model: &ModelRef<'_, D>,
        support: &'a [[Z; D]],
        alpha: &'a [Dph],
        sqrt_gamma: u32,
        bias: Dph,
    ) -> Result<Self, FixedError> {
        let () = Self::D_FITS;
        let s = model.spec;
        if s.linear_dph.iter().any(|b| *b != 0.0) {
            return Err(FixedError::LinearTerms);
        }
        if sqrt_gamma_q28(s.gamma)? != sqrt_gamma {
            return Err(FixedError::Mismatch("sqrt_gamma"));
        }
        if support.len() != model.support.len() || alpha.len() != model.alpha_dph.len() {
            return Err(FixedError::Mismatch("length"));
        }
        for (q, sv) in support.iter().zip(model.support) {
            if scaled_vector(sv, sqrt_gamma)? != *q {
                return Err(FixedError::Mismatch("support"));
            }
        }
        let mut abs_sum: i64 = 0;
        for (q, a) in alpha.iter().zip(model.alpha_dph) {
            if dph(*a, "alpha_dph")? != *q {
                return Err(FixedError::Mismatch("alpha_dph"));
            }
            abs_sum += i64::from(q.0).abs();
        }
        if abs_sum >= ABS_ALPHA_SUM_LIMIT {
            return Err(FixedError::Range("alpha_dph"));
        }
        if dph(s.bias_dph, "bias_dph")? != bias {
            return Err(FixedError::Mismatch("bias_dph"));
        }
        Ok(FixedModelRef {
            support,
            alpha,
            sqrt_gamma,
            bias,
        })
    }

    /// Eq. (10) at a standardised input, °/h, integer-only: [`super::FixedModel::predict`]'s
    /// arithmetic over the borrowed parts, so both give the same bits.
    pub fn predict(&self, z: &[Z; D]) -> Dph {
        let zs = scale_inputs(z, self.sqrt_gamma);
        let mut neg_acc: i64 = 0;
        for (sv, a) in self.support.iter().zip(self.alpha) {
            if let Some(t) = neg_term(&zs, sv, *a) {
                neg_acc += t;
            }
        }
        finish(neg_acc, self.bias)
    }

    /// Compile-time check that D squares below 2^60 fit a u64.
    const D_FITS: () = assert!(D < 16, "FixedModelRef supports fewer than 16 inputs");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixed::FixedModel;
    use crate::rate::RateFilter;
    use crate::table::{Feature, ModelSpec, ModelTable};

    fn table() -> ModelTable<3, 2> {
        ModelTable {
            spec: ModelSpec {
                features: [Feature::TempC, Feature::TempRateCPerS],
                input_mean: [40.0, 0.0],
                input_inv_scale: [0.05, 50.0],
                linear_dph: [0.0, 0.0],
                input_lo: [10.0, -0.02],
                input_hi: [65.0, 0.02],
                gamma: 1.113_895,
                bias_dph: -7.1,
                reference_dph: -7.1,
                rate_filter: RateFilter::from_tau_s(60.0, 1.0),
            },
            support: [[-1.0, 0.0], [0.25, -1.5], [1.0, 0.5]],
            alpha_dph: [-0.01, 0.002, 0.01],
            crc32: 0,
        }
        .sealed()
    }

    /// The parts of a converted table verify and evaluate to the same bits as the table
    /// itself; any part that is not the conversion of its f32 number is refused.
    #[test]
    fn verified_parts_match_the_converted_table() {
        let t = table();
        let fixed = FixedModel::from_table(&t).unwrap();
        let r = fixed.as_model();
        let m = t.as_model();
        let v = FixedModelRef::verified(&m, r.support, r.alpha, r.sqrt_gamma, r.bias).unwrap();
        assert_eq!(v, r);
        for k in 0..200 {
            let z = [Q(k * 300_000 - 30_000_000), Q(17_000_000 - k * 170_000)];
            assert_eq!(v.predict(&z), fixed.predict(&z), "{z:?}");
        }
        let mut support = r.support.to_vec();
        support[1][0].0 += 1;
        assert_eq!(
            FixedModelRef::verified(&m, &support, r.alpha, r.sqrt_gamma, r.bias),
            Err(FixedError::Mismatch("support"))
        );
        let mut alpha = r.alpha.to_vec();
        alpha[2].0 -= 1;
        assert_eq!(
            FixedModelRef::verified(&m, r.support, &alpha, r.sqrt_gamma, r.bias),
            Err(FixedError::Mismatch("alpha_dph"))
        );
        assert_eq!(
            FixedModelRef::verified(&m, &r.support[..2], r.alpha, r.sqrt_gamma, r.bias),
            Err(FixedError::Mismatch("length"))
        );
        assert_eq!(
            FixedModelRef::verified(&m, r.support, r.alpha, r.sqrt_gamma + 1, r.bias),
            Err(FixedError::Mismatch("sqrt_gamma"))
        );
        assert_eq!(
            FixedModelRef::verified(&m, r.support, r.alpha, r.sqrt_gamma, Q(r.bias.0 + 1)),
            Err(FixedError::Mismatch("bias_dph"))
        );
        let mut lin = t;
        lin.spec.linear_dph[0] = 1e-3;
        assert_eq!(
            FixedModelRef::verified(&lin.as_model(), r.support, r.alpha, r.sqrt_gamma, r.bias),
            Err(FixedError::LinearTerms)
        );
    }
}
