//! Multiple linear regression with intercept, and stepwise term selection by partial F
//! tests: the paper's "least-squares stepwise regression" that produced Eq. (11).
//!
//! Procedure (Efroymson's, as in common statistics packages): starting from the intercept
//! alone, (1) while some candidate outside the model has an entry p-value < `alpha_enter`,
//! add the one with the smallest p-value; (2) if some term in the model has a p-value above
//! `alpha_remove`, remove the one with the largest and go back to (1); otherwise stop.
//! p-values are upper tails of F(1, n − k − 1) for the partial F statistic
//! F = (RSS_small − RSS_big) / (RSS_big / (n − k − 1)), k = terms in the bigger model.
//! Requiring `alpha_enter ≤ alpha_remove` keeps a term from entering and leaving forever.
//!
//! Candidate columns span many decades (T³ ≈ 1e5 vs (dT/dt)³ ≈ 1e-6 in °C and °C/s), so
//! every fit is solved on standardised columns (zero mean, unit standard deviation) and the
//! coefficients are converted back to raw units with their covariance.

use super::ols::{ols, Ols, OlsError};
use statrs::distribution::{ContinuousCDF, FisherSnedecor};

/// Stable names of the paper's nine candidate terms x₁ … x₉ (Sec. 4, before Eq. (11)), in
/// order: T, T², T³, dT/dt, (dT/dt)², (dT/dt)³, T·dT/dt, T²·dT/dt, T·(dT/dt)².
pub const PAPER_TERMS: [&str; 9] = [
    "T",
    "T^2",
    "T^3",
    "dT/dt",
    "(dT/dt)^2",
    "(dT/dt)^3",
    "T*dT/dt",
    "T^2*dT/dt",
    "T*(dT/dt)^2",
];

/// A named candidate regressor column.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// Term name (unique among the candidates).
    pub name: String,
    /// One value per observation, in the term's raw unit.
    pub values: Vec<f64>,
}

/// Why a regression or stepwise selection could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StepwiseError {
    /// A column's length differs from the response's.
    #[error("column `{name}` has {got} values, the response has {expected}")]
    LengthMismatch {
        /// Column name (`"dT/dt"` etc. or the candidate's name).
        name: String,
        /// Its length.
        got: usize,
        /// The response's length.
        expected: usize,
    },
    /// A candidate is constant (or non-finite): it cannot be standardised.
    #[error("column `{0}` is constant or not finite")]
    DegenerateColumn(String),
    /// Two candidates share a name.
    #[error("duplicate candidate name `{0}`")]
    DuplicateName(String),
    /// A requested term is not among the candidates.
    #[error("no candidate named `{0}`")]
    UnknownTerm(String),
    /// Options out of range.
    #[error("need 0 < alpha_enter ≤ alpha_remove < 1, got {alpha_enter} / {alpha_remove}")]
    InvalidOptions {
        /// Given entry level.
        alpha_enter: f64,
        /// Given removal level.
        alpha_remove: f64,
    },
    /// The selection did not settle within `max_steps`.
    #[error("stepwise selection did not settle within {0} steps")]
    NoConvergence(usize),
    /// The least-squares solve failed.
    #[error(transparent)]
    Ols(#[from] OlsError),
}

/// A fitted linear model y ≈ intercept + Σ coefficientsⱼ · termⱼ, in raw units.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearFit {
    /// Names of the terms, in model order.
    pub terms: Vec<String>,
    /// Intercept, in the unit of y.
    pub intercept: f64,
    /// Standard error of the intercept.
    pub intercept_std_err: f64,
    /// One coefficient per term, in [y]/[term].
    pub coefficients: Vec<f64>,
    /// Standard errors of the coefficients.
    pub std_errors: Vec<f64>,
    /// Residuals y − ŷ, in the unit of y.
    pub residuals: Vec<f64>,
    /// Residual sum of squares.
    pub rss: f64,
    /// Residual degrees of freedom n − terms − 1.
    pub dof: usize,
}

impl LinearFit {
    /// Predictions for the observations of `candidates` (looked up by term name).
    pub fn predict(&self, candidates: &[Candidate]) -> Result<Vec<f64>, StepwiseError> {
        let cols = self
            .terms
            .iter()
            .map(|t| {
                candidates
                    .iter()
                    .find(|c| &c.name == t)
                    .map(|c| &c.values)
                    .ok_or_else(|| StepwiseError::UnknownTerm(t.clone()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let n = cols.first().map_or(0, |c| c.len());
        if let Some((c, t)) = cols.iter().zip(&self.terms).find(|(c, _)| c.len() != n) {
            return Err(StepwiseError::LengthMismatch {
                name: t.clone(),
                got: c.len(),
                expected: n,
            });
        }
        Ok((0..n)
            .map(|i| {
                self.intercept
                    + cols
                        .iter()
                        .zip(&self.coefficients)
                        .map(|(c, b)| b * c[i])
                        .sum::<f64>()
            })
            .collect())
    }
}

/// One accepted step of the selection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepAction {
    /// The term entered the model.
    Enter,
    /// The term left the model.
    Remove,
}

/// A step of the history: what changed and the test that justified it.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// Entry or removal.
    pub action: StepAction,
    /// The term concerned.
    pub term: String,
    /// Partial F statistic of the term (bigger vs smaller model).
    pub f_stat: f64,
    /// Upper-tail p-value of `f_stat` under F(1, dof of the bigger model).
    pub p_value: f64,
    /// Residual sum of squares of the model after the step.
    pub rss_after: f64,
}

/// Significance levels of the partial F tests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepwiseOptions {
    /// A term enters when its p-value is below this (default 0.05).
    pub alpha_enter: f64,
    /// A term leaves when its p-value is above this (default 0.10).
    pub alpha_remove: f64,
    /// Bound on the number of steps (default 100).
    pub max_steps: usize,
}

impl Default for StepwiseOptions {
    fn default() -> Self {
        Self {
            alpha_enter: 0.05,
            alpha_remove: 0.10,
            max_steps: 100,
        }
    }
}

/// The selected model and how it was reached.
#[derive(Debug, Clone, PartialEq)]
pub struct StepwiseFit {
    /// Final model, raw units.
    pub fit: LinearFit,
    /// Accepted steps in order.
    pub history: Vec<Step>,
}

/// The paper's nine candidate terms (names [`PAPER_TERMS`]) from body temperature `temp_c`
/// (°C) and its rate `dtdt` (in the unit the model is to use: Eq. (11) uses °C/s, see
/// [`super::eq11`]).
pub fn paper_candidates(temp_c: &[f64], dtdt: &[f64]) -> Result<Vec<Candidate>, StepwiseError> {
    if temp_c.len() != dtdt.len() {
        return Err(StepwiseError::LengthMismatch {
            name: "dT/dt".into(),
            got: dtdt.len(),
            expected: temp_c.len(),
        });
    }
    let f: [fn(f64, f64) -> f64; 9] = [
        |t, _| t,
        |t, _| t * t,
        |t, _| t * t * t,
        |_, r| r,
        |_, r| r * r,
        |_, r| r * r * r,
        |t, r| t * r,
        |t, r| t * t * r,
        |t, r| t * r * r,
    ];
    Ok(PAPER_TERMS
        .iter()
        .zip(f)
        .map(|(name, f)| Candidate {
            name: (*name).to_string(),
            values: temp_c.iter().zip(dtdt).map(|(&t, &r)| f(t, r)).collect(),
        })
        .collect())
}

/// Candidates standardised to zero mean and unit (population) standard deviation.
struct Standardised {
    names: Vec<String>,
    mean: Vec<f64>,
    sd: Vec<f64>,
    z: Vec<Vec<f64>>,
}

impl Standardised {
    fn new(candidates: &[Candidate], n: usize) -> Result<Self, StepwiseError> {
        let mut s = Self {
            names: vec![],
            mean: vec![],
            sd: vec![],
            z: vec![],
        };
        for c in candidates {
            if c.values.len() != n {
                return Err(StepwiseError::LengthMismatch {
                    name: c.name.clone(),
                    got: c.values.len(),
                    expected: n,
                });
            }
            if s.names.contains(&c.name) {
                return Err(StepwiseError::DuplicateName(c.name.clone()));
            }
            let m = c.values.iter().sum::<f64>() / n as f64;
            let sd = (c.values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n as f64).sqrt();
            if !(sd.is_finite() && sd > 0.0) {
                return Err(StepwiseError::DegenerateColumn(c.name.clone()));
            }
            s.z.push(c.values.iter().map(|v| (v - m) / sd).collect());
            s.names.push(c.name.clone());
            s.mean.push(m);
            s.sd.push(sd);
        }
        Ok(s)
    }

    /// Intercept + the chosen standardised columns.
    fn fit(&self, chosen: &[usize], y: &[f64]) -> Result<Ols, OlsError> {
        let mut cols = vec![vec![1.0; y.len()]];
        cols.extend(chosen.iter().map(|&j| self.z[j].clone()));
        ols(&cols, y)
    }

    /// Converts a standardised fit to raw units: bⱼ/sⱼ, intercept b₀ − Σ bⱼ mⱼ/sⱼ.
    fn to_raw(&self, chosen: &[usize], f: &Ols) -> LinearFit {
        let k = chosen.len();
        // a = ∂(raw intercept)/∂(b₀, b₁ …) = [1, −m₁/s₁, …]
        let a: Vec<f64> = std::iter::once(1.0)
            .chain(chosen.iter().map(|&j| -self.mean[j] / self.sd[j]))
            .collect();
        let intercept = a.iter().zip(&f.coef).map(|(a, b)| a * b).sum();
        let var0: f64 = (0..=k)
            .flat_map(|i| (0..=k).map(move |l| (i, l)))
            .map(|(i, l)| a[i] * f.cov(i, l) * a[l])
            .sum();
        let se = f.std_errors();
        LinearFit {
            terms: chosen.iter().map(|&j| self.names[j].clone()).collect(),
            intercept,
            intercept_std_err: var0.sqrt(),
            coefficients: chosen
                .iter()
                .enumerate()
                .map(|(i, &j)| f.coef[i + 1] / self.sd[j])
                .collect(),
            std_errors: chosen
                .iter()
                .enumerate()
                .map(|(i, &j)| se[i + 1] / self.sd[j])
                .collect(),
            residuals: f.residuals.clone(),
            rss: f.rss,
            dof: f.dof,
        }
    }
}

/// Upper-tail p-value of the partial F statistic of one term; `big` is the model with it.
fn partial_f(rss_small: f64, big: &Ols) -> (f64, f64) {
    let dof = big.dof as f64;
    if big.rss <= 0.0 {
        return (f64::INFINITY, 0.0);
    }
    let f = ((rss_small - big.rss).max(0.0)) / (big.rss / dof);
    let p = FisherSnedecor::new(1.0, dof).map_or(1.0, |d| d.sf(f));
    (f, p)
}

/// Least squares of `y` on an intercept and the named `terms` of `candidates`.
pub fn fit_terms(
    candidates: &[Candidate],
    terms: &[&str],
    y: &[f64],
) -> Result<LinearFit, StepwiseError> {
    let s = Standardised::new(candidates, y.len())?;
    let chosen = terms
        .iter()
        .map(|t| {
            s.names
                .iter()
                .position(|n| n == t)
                .ok_or_else(|| StepwiseError::UnknownTerm((*t).into()))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let f = s.fit(&chosen, y)?;
    Ok(s.to_raw(&chosen, &f))
}

/// Stepwise selection of terms among `candidates` for response `y` (see the module doc).
pub fn stepwise(
    candidates: &[Candidate],
    y: &[f64],
    opts: &StepwiseOptions,
) -> Result<StepwiseFit, StepwiseError> {
    let StepwiseOptions {
        alpha_enter,
        alpha_remove,
        max_steps,
    } = *opts;
    if !(alpha_enter > 0.0 && alpha_enter <= alpha_remove && alpha_remove < 1.0) {
        return Err(StepwiseError::InvalidOptions {
            alpha_enter,
            alpha_remove,
        });
    }
    let s = Standardised::new(candidates, y.len())?;
    let mut chosen: Vec<usize> = Vec::new();
    let mut current = s.fit(&chosen, y)?;
    let mut history = Vec::new();
    loop {
        if history.len() >= max_steps {
            return Err(StepwiseError::NoConvergence(max_steps));
        }
        // (1) forward: the best outside candidate by p-value. A candidate that would make
        // the design rank-deficient or leave no residual dof cannot enter.
        let mut best: Option<(usize, f64, f64, Ols)> = None;
        for j in (0..s.names.len()).filter(|j| !chosen.contains(j)) {
            let mut trial = chosen.clone();
            trial.push(j);
            let Ok(big) = s.fit(&trial, y) else { continue };
            let (f, p) = partial_f(current.rss, &big);
            if best.as_ref().is_none_or(|b| p < b.2) {
                best = Some((j, f, p, big));
            }
        }
        if let Some((j, f_stat, p_value, big)) = best {
            if p_value < alpha_enter {
                chosen.push(j);
                history.push(Step {
                    action: StepAction::Enter,
                    term: s.names[j].clone(),
                    f_stat,
                    p_value,
                    rss_after: big.rss,
                });
                current = big;
                continue;
            }
        }
        // (2) backward: the worst inside term by p-value.
        let mut worst: Option<(usize, f64, f64, Ols)> = None;
        for pos in 0..chosen.len() {
            let mut trial = chosen.clone();
            trial.remove(pos);
            let small = s.fit(&trial, y)?;
            let (f, p) = partial_f(small.rss, &current);
            if worst.as_ref().is_none_or(|w| p > w.2) {
                worst = Some((pos, f, p, small));
            }
        }
        match worst {
            Some((pos, f_stat, p_value, small)) if p_value > alpha_remove => {
                let j = chosen.remove(pos);
                history.push(Step {
                    action: StepAction::Remove,
                    term: s.names[j].clone(),
                    f_stat,
                    p_value,
                    rss_after: small.rss,
                });
                current = small;
            }
            _ => break,
        }
    }
    Ok(StepwiseFit {
        fit: s.to_raw(&chosen, &current),
        history,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Approximately standard normal noise (Irwin–Hall sum of 12 LCG uniforms − 6).
    fn gauss(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed;
        let mut u = move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| (0..12).map(|_| u()).sum::<f64>() - 6.0)
            .collect()
    }

    /// A thermal-cycle-like design: T swings 10 … 65 °C, dT/dt up to ±1 °C/min in °C/s,
    /// with the period of dT/dt not tied to T so the terms are distinguishable.
    fn design(n: usize) -> (Vec<f64>, Vec<f64>) {
        let w = 2.0 * std::f64::consts::PI / 400.0;
        let t = (0..n).map(|i| 37.5 + 27.5 * (w * i as f64).sin()).collect();
        let r = (0..n)
            .map(|i| (1.0 / 60.0) * (1.7 * w * i as f64).cos())
            .collect();
        (t, r)
    }

    /// Truth: y = 0.01 + 4e-4·T + 2·dT/dt + 2e-2·T·dT/dt + noise (σ = 2e-3 °/h). The true
    /// terms must enter, a pure-noise candidate must not, and the raw-unit coefficients
    /// must lie within 4 standard errors of the truth.
    #[test]
    fn recovers_known_terms_and_rejects_noise_column() {
        let n = 2000;
        let (t, r) = design(n);
        let e = gauss(n, 11);
        let y: Vec<f64> = (0..n)
            .map(|i| 0.01 + 4e-4 * t[i] + 2.0 * r[i] + 2e-2 * t[i] * r[i] + 2e-3 * e[i])
            .collect();
        let mut cands = paper_candidates(&t, &r).unwrap();
        cands.push(Candidate {
            name: "noise".into(),
            values: gauss(n, 99),
        });
        let sw = stepwise(&cands, &y, &StepwiseOptions::default()).unwrap();
        let terms = &sw.fit.terms;
        // With this seed exactly the true terms are chosen (a 5 % entry level can admit a
        // spurious term on other seeds; the noise column must never be among them).
        let mut sorted = terms.clone();
        sorted.sort();
        assert_eq!(sorted, ["T", "T*dT/dt", "dT/dt"], "{terms:?}");
        for (name, truth) in [("T", 4e-4), ("dT/dt", 2.0), ("T*dT/dt", 2e-2)] {
            let k = terms.iter().position(|t| t == name).unwrap();
            let (b, se) = (sw.fit.coefficients[k], sw.fit.std_errors[k]);
            assert!(
                (b - truth).abs() < 4.0 * se,
                "{name}: {b} ± {se} vs {truth}"
            );
        }
        assert!(!terms.iter().any(|t| t == "noise"), "{terms:?}");
        // Predictions from raw coefficients reproduce the fitted values (y − residual).
        let pred = sw.fit.predict(&cands).unwrap();
        for i in 0..n {
            assert!((pred[i] - (y[i] - sw.fit.residuals[i])).abs() < 1e-12);
        }
    }

    /// First step checked by hand: x = 0..3, y = [1, 3, 2, 5] → SSR = Sxy²/Sxx = 30.25/5 =
    /// 6.05, RSS = 2.7, F = 6.05/(2.7/2) = 4.4815; for F(1, 2) the upper tail equals the
    /// two-sided t(2) tail, which has the closed form 1 − t/√(2 + t²), t = √F.
    #[test]
    fn first_step_f_and_p_match_hand_computation() {
        let cands = vec![Candidate {
            name: "x".into(),
            values: vec![0.0, 1.0, 2.0, 3.0],
        }];
        let opts = StepwiseOptions {
            alpha_enter: 0.5,
            alpha_remove: 0.6,
            max_steps: 10,
        };
        let sw = stepwise(&cands, &[1.0, 3.0, 2.0, 5.0], &opts).unwrap();
        let s = &sw.history[0];
        let f = 6.05 / (2.7 / 2.0);
        let t = f64::sqrt(f);
        assert_eq!(s.action, StepAction::Enter);
        assert!((s.f_stat - f).abs() < 1e-12, "{}", s.f_stat);
        assert!(
            (s.p_value - (1.0 - t / (2.0 + t * t).sqrt())).abs() < 1e-9,
            "{}",
            s.p_value
        );
        assert!(
            (sw.fit.coefficients[0] - 1.1).abs() < 1e-12 && (sw.fit.intercept - 1.1).abs() < 1e-12
        );
        assert!((sw.fit.intercept_std_err - (1.35f64 * 0.7).sqrt()).abs() < 1e-12);
        // At the default 0.05 entry level, p ≈ 0.17 does not enter.
        let sw = stepwise(&cands, &[1.0, 3.0, 2.0, 5.0], &StepwiseOptions::default()).unwrap();
        assert!(sw.fit.terms.is_empty() && sw.history.is_empty());
    }

    /// Raw-unit coefficients and standard errors from the standardised solve equal an
    /// unstandardised solve where that is well conditioned.
    #[test]
    fn raw_coefficients_match_direct_solve() {
        let n = 50;
        let x1: Vec<f64> = (0..n).map(|i| i as f64 / 10.0).collect();
        let x2: Vec<f64> = (0..n).map(|i| ((i * 7) % 11) as f64).collect();
        let e = gauss(n, 5);
        let y: Vec<f64> = (0..n)
            .map(|i| 1.0 + 2.0 * x1[i] - 0.5 * x2[i] + 0.3 * e[i])
            .collect();
        let cands = vec![
            Candidate {
                name: "a".into(),
                values: x1.clone(),
            },
            Candidate {
                name: "b".into(),
                values: x2.clone(),
            },
        ];
        let f = fit_terms(&cands, &["a", "b"], &y).unwrap();
        let d = ols(&[vec![1.0; n], x1, x2], &y).unwrap();
        let se = d.std_errors();
        assert!((f.intercept - d.coef[0]).abs() < 1e-12);
        assert!((f.intercept_std_err - se[0]).abs() < 1e-12);
        for k in 0..2 {
            assert!((f.coefficients[k] - d.coef[k + 1]).abs() < 1e-12);
            assert!((f.std_errors[k] - se[k + 1]).abs() < 1e-12);
        }
    }

    #[test]
    fn bad_inputs_are_errors() {
        assert!(matches!(
            paper_candidates(&[1.0], &[]),
            Err(StepwiseError::LengthMismatch { .. })
        ));
        let c = vec![Candidate {
            name: "k".into(),
            values: vec![1.0; 4],
        }];
        assert!(matches!(
            stepwise(&c, &[1.0; 4], &StepwiseOptions::default()),
            Err(StepwiseError::DegenerateColumn(_))
        ));
        let c = vec![Candidate {
            name: "x".into(),
            values: vec![1.0, 2.0, 3.0, 4.0],
        }];
        let bad = StepwiseOptions {
            alpha_enter: 0.2,
            alpha_remove: 0.1,
            max_steps: 10,
        };
        assert!(matches!(
            stepwise(&c, &[1.0; 4], &bad),
            Err(StepwiseError::InvalidOptions { .. })
        ));
        assert!(matches!(
            fit_terms(&c, &["y"], &[1.0; 4]),
            Err(StepwiseError::UnknownTerm(_))
        ));
    }
}
