//! LS-SVM regression with a Gaussian kernel, Yu et al. 2011 Eqs. (8)–(10), in f64.
//!
//! * [`scaling`]: per-feature standardisation fitted on the training inputs.
//! * [`solve`]: the kernel matrix and the solution of Eq. (9) by Cholesky, a dense reference
//!   solve, and closed-form leave-one-out residuals.
//! * [`mixed`]: the iterative solves [`solve`] takes for large n: f64 conjugate gradients
//!   preconditioned by a low-rank factor of K ([`pivoted`], on H in [`packed`] storage) or by
//!   an f32 Cholesky factor.
//! * [`tune`]: σ and c by closed-form leave-one-out or blocked / group cross-validation.
//!
//! [`Lssvm`] ties them together: train on raw features, predict on raw features.

mod cg;
pub mod fixed_size;
pub mod kernel;
pub mod mixed;
pub mod packed;
pub mod pivoted;
pub mod prune;
pub mod scaling;
pub mod solve;
pub mod sparse;
pub mod tune;

use serde::{Deserialize, Serialize};

use crate::features::RowSet;

pub use kernel::{kernel_matrix, KernelMatrix};
pub use scaling::Scaling;
pub use solve::{loo_residuals, solve, solve_dense_reference, Solution};

/// Why an LS-SVM could not be trained.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LssvmError {
    /// No training samples.
    #[error("no training samples")]
    Empty,
    /// Inputs and targets differ in count.
    #[error("{inputs} input rows but {targets} targets")]
    Length {
        /// Number of input rows.
        inputs: usize,
        /// Number of targets.
        targets: usize,
    },
    /// An input row has the wrong number of features.
    #[error("input row {row} has {got} features, expected {want}")]
    Dimension {
        /// 0-based row.
        row: usize,
        /// Features found.
        got: usize,
        /// Features expected.
        want: usize,
    },
    /// A NaN or infinite value in the data.
    #[error("non-finite {what} at sample {index}{}", feature.as_ref().map(|f| format!(" (feature {f})")).unwrap_or_default())]
    NonFinite {
        /// "input" or "target".
        what: &'static str,
        /// 0-based sample.
        index: usize,
        /// The feature, for inputs.
        feature: Option<String>,
    },
    /// A feature takes a single value over the training set, so it cannot be standardised.
    #[error(
        "feature {feature} is constant ({value}) over the training set; it cannot be standardised"
    )]
    ConstantFeature {
        /// The feature's name.
        feature: String,
        /// Its (only) value, in the feature's unit.
        value: f64,
    },
    /// σ or c is not a positive finite number.
    #[error("hyper-parameter {name} = {value} must be a positive finite number")]
    HyperParameter {
        /// "sigma" or "c".
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// K + I/c is not numerically positive definite (c too large for σ, or duplicated
    /// inputs with a huge c).
    #[error("Cholesky factorisation of K + I/c failed at pivot {pivot}: the matrix is not numerically positive definite (try a smaller c or a different sigma)")]
    NotPositiveDefinite {
        /// 0-based pivot where the factorisation stopped.
        pivot: usize,
    },
    /// The solve produced NaN or infinity (an ill-conditioned system).
    #[error("the solution of Eq. (9) is not finite (ill-conditioned system)")]
    Singular,
    /// Too many samples for a method that forms the n×n kernel matrix.
    #[error(
        "{samples} samples is more than the {max} an exact solve holds (its n×n kernel matrix \
         would take {:.1} GB): average blocks of samples (`rlg train --block {}` or more) or \
         train a reduced model of at most M support vectors (`rlg train --budget 64`: memory \
         grows as samples × M)",
        12.0 * (*samples as f64).powi(2) / 1e9,
        samples.div_ceil(*max)
    )]
    TooLarge {
        /// Samples given.
        samples: usize,
        /// Largest accepted.
        max: usize,
    },
}

/// A trained LS-SVM: Eq. (10) on standardised inputs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Lssvm {
    /// Feature names in input order (`compensator_core::Feature::name` strings).
    pub features: Vec<String>,
    /// Standardisation fitted on the training inputs.
    pub scaling: Scaling,
    /// Standardised support vectors x_i (every training sample: LS-SVM is not sparse).
    pub support: Vec<Vec<f64>>,
    /// Coefficients a_i of Eq. (10), °/h.
    pub alpha_dph: Vec<f64>,
    /// Bias b of Eq. (10), °/h.
    pub bias_dph: f64,
    /// Kernel width σ of Eq. (8), in standardised units.
    pub sigma: f64,
    /// Regularisation c of Eq. (9).
    pub c: f64,
    /// Per feature, whether it is a kernel input (empty: every feature is). A feature outside
    /// the kernel has 0 in every support vector and enters only through `linear_dph`.
    #[serde(default)]
    pub in_kernel: Vec<bool>,
    /// Per feature, the coefficient of its linear term on (x − mean), °/h per unit (empty:
    /// none; the partially linear model of [`solve::solve_partially_linear`]).
    #[serde(default)]
    pub linear_dph: Vec<f64>,
}

/// The scaling fitted on `x` (columns named by `features`) and `x` standardised by it, after
/// checking that there is one target per row.
pub(crate) fn standardised<X: RowSet + ?Sized>(
    features: &[String],
    x: &X,
    y_dph: &[f64],
) -> Result<(Scaling, Vec<Vec<f64>>), LssvmError> {
    if x.n_rows() != y_dph.len() {
        return Err(LssvmError::Length {
            inputs: x.n_rows(),
            targets: y_dph.len(),
        });
    }
    let scaling = Scaling::fit(features, x)?;
    let z = (0..x.n_rows()).map(|i| scaling.apply(x.row(i))).collect();
    Ok((scaling, z))
}

/// [`standardised`] into one row-major block: a row of its own costs 56 bytes for two
/// features against 16 in the block (10⁷ samples: 560 MB against 160 MB).
pub(crate) fn standardised_rows<X: RowSet + ?Sized>(
    features: &[String],
    x: &X,
    y_dph: &[f64],
) -> Result<(Scaling, fixed_size::Rows), LssvmError> {
    if x.n_rows() != y_dph.len() {
        return Err(LssvmError::Length {
            inputs: x.n_rows(),
            targets: y_dph.len(),
        });
    }
    let scaling = Scaling::fit(features, x)?;
    let dim = scaling.dim();
    let mut data = Vec::with_capacity(x.n_rows() * dim);
    for i in 0..x.n_rows() {
        data.extend(scaling.apply(x.row(i)));
    }
    Ok((scaling, fixed_size::Rows { data, dim }))
}

/// Inputs per support vector up to which [`Lssvm::predict_standardised`] batches its kernel
/// values (the models here have 2 to 4).
const PREDICT_MAX_DIM: usize = 8;

impl Lssvm {
    /// Trains on raw inputs `x` (one row per sample, columns named by `features`) and
    /// targets `y_dph` (°/h).
    pub fn train(
        features: &[String],
        x: &[Vec<f64>],
        y_dph: &[f64],
        sigma: f64,
        c: f64,
    ) -> Result<Lssvm, LssvmError> {
        let (scaling, z) = standardised(features, x, y_dph)?;
        let sol = solve(&z, y_dph, sigma, c)?;
        Ok(Lssvm {
            features: features.to_vec(),
            scaling,
            support: z,
            alpha_dph: sol.alpha,
            bias_dph: sol.bias,
            sigma,
            c,
            in_kernel: Vec::new(),
            linear_dph: Vec::new(),
        })
    }

    /// Trains the partially linear model: the features with `linear[d]` set enter as linear
    /// terms on (x − mean) beside the bias, the others as kernel inputs
    /// ([`solve::solve_partially_linear`]). With no linear feature this is [`Lssvm::train`].
    pub fn train_partially_linear(
        features: &[String],
        x: &[Vec<f64>],
        y_dph: &[f64],
        sigma: f64,
        c: f64,
        linear: &[bool],
    ) -> Result<Lssvm, LssvmError> {
        let (scaling, z, lin) = partially_linear_design(features, x, y_dph, linear)?;
        let sol = solve::solve_partially_linear(&z, &lin, y_dph, sigma, c)?;
        Ok(Lssvm {
            features: features.to_vec(),
            in_kernel: linear.iter().map(|l| !l).collect(),
            linear_dph: expand_linear(linear, &sol.beta),
            scaling,
            support: z,
            alpha_dph: sol.solution.alpha,
            bias_dph: sol.solution.bias,
            sigma,
            c,
        })
    }

    /// Whether feature `d` is a kernel input.
    pub fn is_kernel_input(&self, d: usize) -> bool {
        self.in_kernel.get(d).copied().unwrap_or(true)
    }

    /// The standardised kernel input of a raw feature vector (0 for features outside the
    /// kernel, as the board's zero inverse scale gives).
    pub fn standardise(&self, x: &[f64]) -> Vec<f64> {
        let mut z = self.scaling.apply(x);
        for (d, v) in z.iter_mut().enumerate() {
            if !self.is_kernel_input(d) {
                *v = 0.0;
            }
        }
        z
    }

    /// Σ_d linear_d·(x_d − mean_d), °/h (0 without linear terms).
    pub fn linear_part(&self, x: &[f64]) -> f64 {
        self.linear_dph
            .iter()
            .zip(x.iter().zip(&self.scaling.mean))
            .map(|(b, (v, m))| b * (v - m))
            .sum()
    }

    /// The model at a raw feature vector, °/h: Eq. (10) plus the linear terms.
    pub fn predict(&self, x: &[f64]) -> f64 {
        self.predict_standardised(&self.standardise(x)) + self.linear_part(x)
    }

    /// Eq. (10) at a standardised feature vector, °/h.
    pub fn predict_standardised(&self, z: &[f64]) -> f64 {
        let inv = 1.0 / (2.0 * self.sigma * self.sigma);
        // Kernel values four at a time (`kernel::gauss_rows`' lanes), summed in the order of
        // the support vectors.
        let mut sum = 0.0;
        let mut rows = [0.0; 4 * PREDICT_MAX_DIM];
        let mut k = [0.0; 4];
        let dim = z.len();
        for (svs, alphas) in self.support.chunks(4).zip(self.alpha_dph.chunks(4)) {
            if dim > PREDICT_MAX_DIM || svs.iter().any(|s| s.len() != dim) {
                sum += svs
                    .iter()
                    .zip(alphas)
                    .map(|(sv, a)| a * kernel::gauss(sv, z, inv))
                    .sum::<f64>();
                continue;
            }
            for (l, sv) in svs.iter().enumerate() {
                rows[l * dim..(l + 1) * dim].copy_from_slice(sv);
            }
            kernel::gauss_rows(&rows, dim, z, inv, &mut k[..svs.len()]);
            for (a, kv) in alphas.iter().zip(&k) {
                sum += a * kv;
            }
        }
        sum + self.bias_dph
    }

    /// A predictor for many inputs: [`Lssvm::predict`]'s values, bit for bit, with the
    /// support vectors laid out once in one contiguous block.
    pub fn predictor(&self) -> Predictor<'_> {
        let dim = self.support.first().map_or(0, Vec::len);
        let uniform = self.support.iter().all(|s| s.len() == dim) && dim <= PREDICT_MAX_DIM;
        Predictor {
            model: self,
            flat: if uniform {
                self.support.iter().flatten().copied().collect()
            } else {
                Vec::new()
            },
            dim,
        }
    }

    /// Number of input features.
    pub fn dim(&self) -> usize {
        self.features.len()
    }
}

/// [`Lssvm::predictor`]'s result.
#[derive(Clone, Debug)]
pub struct Predictor<'a> {
    model: &'a Lssvm,
    /// The support vectors, row-major; empty when they cannot be batched (the model's own
    /// `predict` is then used).
    flat: Vec<f64>,
    dim: usize,
}

impl Predictor<'_> {
    /// The model at a raw feature vector, °/h: [`Lssvm::predict`].
    pub fn predict(&self, x: &[f64]) -> f64 {
        let m = self.model;
        if self.flat.is_empty() && !m.support.is_empty() {
            return m.predict(x);
        }
        let z = m.standardise(x);
        if z.len() != self.dim {
            return m.predict(x);
        }
        let inv = 1.0 / (2.0 * m.sigma * m.sigma);
        const CHUNK: usize = 64;
        let mut k = [0.0; CHUNK];
        let mut sum = 0.0;
        for (rows, alphas) in self
            .flat
            .chunks(CHUNK * self.dim)
            .zip(m.alpha_dph.chunks(CHUNK))
        {
            let k = &mut k[..alphas.len()];
            kernel::gauss_rows(rows, self.dim, &z, inv, k);
            for (a, kv) in alphas.iter().zip(k.iter()) {
                sum += a * kv;
            }
        }
        sum + m.bias_dph + m.linear_part(x)
    }
}

/// The design of a partially linear model: the scaling (fitted on all features), the kernel
/// inputs (standardised, 0 for linear features) and the linear columns (x − mean of each
/// linear feature, in feature order).
#[allow(clippy::type_complexity)]
pub fn partially_linear_design(
    features: &[String],
    x: &[Vec<f64>],
    y_dph: &[f64],
    linear: &[bool],
) -> Result<(Scaling, Vec<Vec<f64>>, Vec<Vec<f64>>), LssvmError> {
    if x.len() != y_dph.len() {
        return Err(LssvmError::Length {
            inputs: x.len(),
            targets: y_dph.len(),
        });
    }
    if linear.len() != features.len() {
        return Err(LssvmError::Dimension {
            row: 0,
            got: linear.len(),
            want: features.len(),
        });
    }
    let scaling = Scaling::fit(features, x)?;
    let z: Vec<Vec<f64>> = x
        .iter()
        .map(|r| {
            let mut z = scaling.apply(r);
            for (d, v) in z.iter_mut().enumerate() {
                if linear[d] {
                    *v = 0.0;
                }
            }
            z
        })
        .collect();
    let lin: Vec<Vec<f64>> = (0..features.len())
        .filter(|&d| linear[d])
        .map(|d| x.iter().map(|r| r[d] - scaling.mean[d]).collect())
        .collect();
    Ok((scaling, z, lin))
}

/// The per-feature linear coefficients from those of the linear columns (0 elsewhere).
pub fn expand_linear(linear: &[bool], beta: &[f64]) -> Vec<f64> {
    let mut k = 0;
    linear
        .iter()
        .map(|&l| {
            if l {
                k += 1;
                beta[k - 1]
            } else {
                0.0
            }
        })
        .collect()
}

#[cfg(test)]
pub(crate) mod test_data {
    /// Deterministic scattered 2-D inputs in [−1.7, 1.7]² (a quasi-random sequence).
    pub fn points(n: usize) -> Vec<Vec<f64>> {
        (0..n)
            .map(|i| {
                let t = i as f64;
                vec![
                    (t * 0.618_033_988_7).fract() * 3.4 - 1.7,
                    (t * 0.414_213_562_4).fract() * 3.4 - 1.7,
                ]
            })
            .collect()
    }

    /// [`points`] and a smooth target with a little "noise", shared by the solver tests.
    pub fn scattered(n: usize) -> (Vec<Vec<f64>>, Vec<f64>) {
        let z = points(n);
        let y = z
            .iter()
            .enumerate()
            .map(|(i, r)| {
                (1.3 * r[0]).sin()
                    + 0.4 * r[1] * r[0]
                    + 0.01 * ((i * 7919 % 101) as f64 / 101.0 - 0.5)
            })
            .collect();
        (z, y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The batched predictor gives `predict`'s bits: 131 support vectors (two full chunks of
    /// 64 and a tail), a partially linear model, and NaN for a NaN input.
    #[test]
    fn predictor_equals_predict_bit_for_bit() {
        let (z, y) = test_data::scattered(131);
        let f: Vec<String> = vec!["a".into(), "b".into()];
        let exact = Lssvm::train(&f, &z, &y, 0.8, 30.0).unwrap();
        let mixed = Lssvm::train_partially_linear(&f, &z, &y, 0.8, 30.0, &[false, true]).unwrap();
        for m in [&exact, &mixed] {
            let p = m.predictor();
            for q in test_data::points(57) {
                let q = [q[0] * 1.3, q[1] - 0.2];
                assert_eq!(p.predict(&q).to_bits(), m.predict(&q).to_bits());
            }
            assert!(p.predict(&[f64::NAN, 0.1]).is_nan());
        }
    }
}
