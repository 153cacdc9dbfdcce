//! The hidden effect of a case and its detectability D (see the benchmark's module doc).

use rlg_diagnose::linalg::{dot, Basis};
use rlg_diagnose::noise::{block_mean_autocov, GlsWhitener};
use rlg_diagnose::prepare::{baseline_columns, estimate_rate, PhysicsModel, Prepared};
use rlg_diagnose::variance::heteroscedastic_detectability;
use rlg_physics::{contribution, Term};
use rlg_simulate::{NoiseParams, Truth};

/// σ of a 1 s sample and of a 100 s mean of the simulated noise, °/h.
pub(super) fn noise_sigmas(p: &NoiseParams) -> (f64, f64) {
    let w = p.arw_dph_rt_h * 60.0;
    let (taus, s) = p.gauss_markov_bank();
    let window = 100.0;
    let gm100: f64 = taus
        .iter()
        .map(|t| {
            let x = window / t;
            s * s * 2.0 / x * (1.0 - (1.0 - (-x).exp()) / x)
        })
        .sum();
    let gm1: f64 = taus.len() as f64 * s * s;
    ((w * w + gm1).sqrt(), (w * w / window + gm100).sqrt())
}

/// The hidden effect (°/h per sample of the recording) of `hidden` under `truth`.
pub(super) fn effect(hidden: &Term, truth: &Truth) -> Vec<f64> {
    let t: Vec<f64> = (0..truth.body_c.len())
        .map(|i| i as f64 * truth.scenario.sample_period_s + truth.scenario.power_on_s)
        .collect();
    match hidden {
        Term::SensorLag { tau_s } => {
            let lagged = contribution(hidden, &t, &truth.body_c, &truth.dbody_c_per_s);
            let dl: Vec<f64> = truth
                .body_c
                .iter()
                .zip(&lagged)
                .map(|(c, s)| (c - s) / tau_s)
                .collect();
            let base: Vec<&Term> = truth
                .scenario
                .terms
                .iter()
                .filter(|x| matches!(x, Term::StaticPoly { .. } | Term::RateTerms { .. }))
                .collect();
            let mut e = vec![0.0; t.len()];
            for b in base {
                let a = contribution(b, &t, &truth.body_c, &truth.dbody_c_per_s);
                let l = contribution(b, &t, &lagged, &dl);
                e.iter_mut()
                    .zip(a.iter().zip(&l))
                    .for_each(|(o, (x, y))| *o += x - y);
            }
            e
        }
        Term::TempQuantization { .. } => {
            let read = contribution(hidden, &t, &truth.body_c, &truth.dbody_c_per_s);
            let rate = estimate_rate(&read, &t, truth.scenario.sample_period_s)
                .unwrap_or_else(|_| vec![0.0; t.len()]);
            let mut e = vec![0.0; t.len()];
            for b in truth
                .scenario
                .terms
                .iter()
                .filter(|x| matches!(x, Term::StaticPoly { .. } | Term::RateTerms { .. }))
            {
                let a = contribution(b, &t, &truth.body_c, &truth.dbody_c_per_s);
                let l = contribution(b, &t, &read, &rate);
                e.iter_mut()
                    .zip(a.iter().zip(&l))
                    .for_each(|(o, (x, y))| *o += x - y);
            }
            e
        }
        // A noise scale adds nothing to the mean.
        Term::Heteroscedastic { .. } => vec![0.0; t.len()],
        _ => contribution(hidden, &t, &truth.body_c, &truth.dbody_c_per_s),
    }
}

/// Detectability of `hidden` on the recording `prep` of `truth` (see the module doc): the
/// mean effect's in the metric of the noise's block-mean covariance, or the noise scale's
/// on the 1 Hz samples.
pub(super) fn case_detectability(
    hidden: &Term,
    truth: &Truth,
    prep: &Prepared,
    model: &PhysicsModel,
) -> Option<f64> {
    match hidden {
        Term::Heteroscedastic { k, ref_c } => Some(heteroscedastic_detectability(
            &truth.body_c[prep.range.clone()],
            *k,
            *ref_c,
        )),
        _ => detectability(prep, model, &effect(hidden, truth), &truth.scenario.noise),
    }
}

/// The largest change of the 1 s noise σ a `heteroscedastic` term makes, °/h.
pub(super) fn noise_scale_peak(hidden: &Term, body_c: &[f64], noise: &NoiseParams) -> f64 {
    match hidden {
        Term::Heteroscedastic { k, ref_c } => {
            let xmax = body_c
                .iter()
                .map(|t| ((t - ref_c) / 30.0).powi(2))
                .fold(0.0f64, f64::max);
            noise.arw_dph_rt_h * 60.0 * (k * xmax).abs()
        }
        _ => 0.0,
    }
}

/// (‖P⊥ē‖, ‖ē‖², P⊥ē) on the diagnosis' blocks of `prep`.
pub(super) fn orthogonal_part(
    prep: &Prepared,
    model: &PhysicsModel,
    e: &[f64],
) -> (f64, f64, Vec<f64>) {
    let eb = prep.blocks(&e[prep.range.clone()]);
    let cols: Vec<Vec<f64>> = baseline_columns(model, &prep.drive)
        .iter()
        .map(|c| prep.blocks(&c.values))
        .collect();
    let r = Basis::new(&cols).residual(&eb);
    (dot(&r, &r).sqrt(), dot(&eb, &eb), r)
}

/// Detectability of the effect `e` on the blocks of `prep` under the noise `noise`: the
/// norm of its part orthogonal to the baseline's span in the metric of the noise covariance
/// of the 100 s means, D² = ēᵀ(Σ⁻¹ − Σ⁻¹X(XᵀΣ⁻¹X)⁻¹XᵀΣ⁻¹)ē — the signal-to-noise ratio of
/// the best test for that exact effect (known shape, known noise). None when the recording
/// is too long for the exact factor.
pub(super) fn detectability(
    prep: &Prepared,
    model: &PhysicsModel,
    e: &[f64],
    noise: &NoiseParams,
) -> Option<f64> {
    let g = GlsWhitener::new(&block_mean_autocov(noise, prep.nb(), prep.block, prep.dt_s))?;
    let eb = g.whiten(&prep.blocks(&e[prep.range.clone()]));
    let cols: Vec<Vec<f64>> = baseline_columns(model, &prep.drive)
        .iter()
        .map(|c| g.whiten(&prep.blocks(&c.values)))
        .collect();
    let r = Basis::new(&cols).residual(&eb);
    Some(dot(&r, &r).sqrt())
}

/// The amplitude in 1e-5 … 10 at which the detectability `d_of` reaches `target`, by
/// bisection on a log scale (60 halvings): D grows with a noise scale's k but is not linear
/// in it (it is in ln(1 + k·x)). `None` where even 10 falls short.
pub(super) fn amplitude_at(target: f64, d_of: impl Fn(f64) -> f64) -> Option<f64> {
    let (mut a, mut b) = (1e-5, 10.0);
    if d_of(b) < target {
        return None;
    }
    for _ in 0..60 {
        let m = (a * b).sqrt();
        if d_of(m) < target {
            a = m;
        } else {
            b = m;
        }
    }
    Some((a * b).sqrt())
}
