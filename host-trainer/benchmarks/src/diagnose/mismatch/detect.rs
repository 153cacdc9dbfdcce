//! Detectability D of an effect on a mismatched recording, in the metric of the exact
//! block-mean covariance of the generator's noise (dense: the rate random walk makes it
//! non-stationary), with the diagnosis' own baseline design.

use rlg_diagnose::linalg::{dot, Basis};
use rlg_diagnose::noise::GlsWhitener;
use rlg_diagnose::prepare::{estimate_rate, model_drive, PhysicsModel, Prepared};
use rlg_diagnose::DiagnoseError;
use rlg_physics::{contribution, Term};

use super::noise::NoiseDraw;

/// The metric of one recording and noise: the whitened baseline design, and the plain one
/// for the marginal figures.
pub(super) struct Metric {
    white: GlsWhitener,
    basis: Basis,
    plain: Basis,
    /// Mean variance of a 100 s mean, (°/h)².
    pub(super) var100: f64,
}

impl Metric {
    /// The metric on the blocks of `prep` under `noise`; None when Σ is not positive
    /// definite.
    pub(super) fn new(
        prep: &Prepared,
        model: &PhysicsModel,
        noise: &NoiseDraw,
    ) -> Result<Option<Self>, DiagnoseError> {
        let nb = prep.nb();
        let cov = noise.block_cov(nb, prep.block, prep.dt_s, prep.range.start);
        let var100 = (0..nb).map(|i| cov[i * nb + i]).sum::<f64>() / nb.max(1) as f64;
        let Some(white) = GlsWhitener::from_cov(faer::Mat::from_fn(nb, nb, |i, j| cov[i * nb + j]))
        else {
            return Ok(None);
        };
        let drive = model_drive(model, prep)?;
        let cols = prep.baseline_blocks(model, &drive);
        let wcols: Vec<Vec<f64>> = cols.iter().map(|c| white.whiten(c)).collect();
        Ok(Some(Self {
            white,
            basis: Basis::new(&wcols),
            plain: Basis::new(&cols),
            var100,
        }))
    }

    /// D of the effect `e` (°/h per sample of the whole recording):
    /// D² = ēᵀ(Σ⁻¹ − Σ⁻¹X(XᵀΣ⁻¹X)⁻¹XᵀΣ⁻¹)ē, the norm of the whitened block means' part
    /// orthogonal to the whitened baseline.
    pub(super) fn d(&self, prep: &Prepared, e: &[f64]) -> f64 {
        let eb = self.white.whiten(&prep.blocks(&e[prep.range.clone()]));
        let r = self.basis.residual(&eb);
        dot(&r, &r).sqrt()
    }

    /// (‖P⊥ē‖/σ₁₀₀, share of ‖ē‖² inside the baseline's span), without the noise metric.
    pub(super) fn marginal(&self, prep: &Prepared, e: &[f64]) -> (f64, f64) {
        let eb = prep.blocks(&e[prep.range.clone()]);
        let r = self.plain.residual(&eb);
        let (r2, e2) = (dot(&r, &r), dot(&eb, &eb));
        (
            (r2 / self.var100).sqrt(),
            if e2 > 0.0 { 1.0 - r2 / e2 } else { 0.0 },
        )
    }
}

/// The bias the base terms give when driven by the true (`temp`, `rate`) minus what they
/// give when driven by (`temp2`, `rate2`): the mean effect of a sensor that reports the
/// second drive.
pub(super) fn drive_mismatch(
    base: &[Term],
    t_s: &[f64],
    temp: &[f64],
    rate: &[f64],
    temp2: &[f64],
    rate2: &[f64],
) -> Vec<f64> {
    let mut e = vec![0.0; t_s.len()];
    for b in base
        .iter()
        .filter(|x| matches!(x, Term::StaticPoly { .. } | Term::RateTerms { .. }))
    {
        let a = contribution(b, t_s, temp, rate);
        let l = contribution(b, t_s, temp2, rate2);
        e.iter_mut()
            .zip(a.iter().zip(&l))
            .for_each(|(o, (x, y))| *o += x - y);
    }
    e
}

/// The mean effect of a lagged reading: the base driven by the body minus the base driven
/// by the lagged temperature T_s and its exact rate (T − T_s)/τ.
pub(super) fn lag_effect(
    base: &[Term],
    t_s: &[f64],
    temp: &[f64],
    rate: &[f64],
    tau_s: f64,
) -> Vec<f64> {
    let lagged = contribution(&Term::SensorLag { tau_s }, t_s, temp, rate);
    let dl: Vec<f64> = temp
        .iter()
        .zip(&lagged)
        .map(|(c, s)| (c - s) / tau_s)
        .collect();
    drive_mismatch(base, t_s, temp, rate, &lagged, &dl)
}

/// The mean effect of a coarse reading `read`: the base driven by the body minus the base
/// driven by the reading and its rate by the diagnosis' estimator.
pub(super) fn reading_effect(
    base: &[Term],
    t_s: &[f64],
    temp: &[f64],
    rate: &[f64],
    read: &[f64],
) -> Result<Vec<f64>, DiagnoseError> {
    let dt = if t_s.len() > 1 { t_s[1] - t_s[0] } else { 1.0 };
    let r2 = estimate_rate(read, t_s, dt)?;
    Ok(drive_mismatch(base, t_s, temp, rate, read, &r2))
}
