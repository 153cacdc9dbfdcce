//! The gyro noise a pass whitens and bootstraps by, fitted under the null hypothesis to the
//! baseline residual, as a parametric bootstrap should.
//!
//! The noise is fitted where the tests use it, on the 100 s means, by REML (`reml.rs`):
//! white level and bias instability first; when that model fails the residual's own Allan
//! check (slow wander the bank does not describe), rate random walk is added, unless a rate
//! ramp, or else a warm-up's decay from power-on, beside the model explains the departure
//! better (`ramp.rs`). The 1 Hz Allan fit and
//! its recalibration remain for records too long for the dense REML. Under an effect the
//! null fit is slightly conservative (a D = 6 effect spread over 500 blocks adds about 7 % to
//! their variance).

use crate::baseline::Baseline;
use crate::candidates::Family;
use crate::minimise::argmin;
use crate::noise::allan_check::{allan_check, AllanCheck};
use crate::noise::allan_fit::{calibrate_bias_instability, fit_gyro_noise};
use crate::noise::covariance::block_mean_cov;
use crate::noise::whiten::{ArModel, GlsWhitener, Whitener, GLS_MAX_BLOCKS};
use crate::prepare::Prepared;
use crate::ramp::{slow_term_instead_of_rrw, Draws};
use crate::scan::{scan, Generic, Point};
use crate::{Options, RampEvidence};
use rlg_simulate::noise::NoiseParams;

/// Pass 1: the AR fit that whitens the first scan, refitted on the baseline residual with
/// that scan's best candidate removed, so that a strong effect does not masquerade as noise
/// colour. It is the whitening of records too long for the GLS factor, and the AR model the
/// evidence reports. (Fitted into an AR noise model, a real effect raises the thresholds
/// enough to lose most moderate effects.)
pub(super) fn first_pass_ar(base: &Baseline<'_>, points: &[Point], generic: &Generic) -> ArModel {
    let y_b = &base.prep.y_b;
    let ar1 = Whitener::Ar(ArModel::fit(&base.resid_b));
    let s1 = scan(&ar1, &base.cols_b, y_b, points, generic);
    let best1 = argmin(&s1.dbic).filter(|&i| s1.dbic[i] < 0.0);
    // Pass 1 is needed for its best point only; its whitened columns are as large as the
    // grid's.
    drop(s1);
    let resid_nb = {
        let mut cols_b = base.cols_b.clone();
        if let Some(i) = best1 {
            cols_b.extend(points[i].cols_b.iter().cloned());
        }
        crate::linalg::Basis::new(&cols_b).residual(y_b)
    };
    ArModel::fit(&resid_nb)
}

/// The fitted gyro noise and how far it can be trusted.
pub(super) struct FittedNoise {
    /// The noise model the tests whiten and bootstrap by.
    pub(super) gyro: NoiseParams,
    /// It against the residual's own Allan deviation (None: too few blocks).
    pub(super) check: Option<AllanCheck>,
    /// Set when a rate ramp (or a warm-up's decay) was preferred to rate random walk: every
    /// finding then rests on that choice too, and the verdict's p-value is at least its
    /// p-value.
    pub(super) ramp: Option<RampEvidence>,
    /// Each block's white variance relative to the record's (mean 1) where the 1 Hz noise
    /// level follows time ([`crate::variance::VarianceTest::white_level_in_time`]): the
    /// bootstraps' replicates draw the white noise at that level. The whitening and the
    /// Allan check stay the stationary model's: whitened by the level, the quiet hours
    /// weighed more and the noise's slow part, which the fit under the null does not always
    /// take whole, showed there as structure (METHOD.md).
    pub(super) white_level: Option<Vec<f64>>,
}

impl FittedNoise {
    /// Fits the noise to `base`'s residual (see the module doc); what was fitted instead of
    /// white noise and bias instability, and why, goes to `notes`. `points` give the aging
    /// ramp's column and the warm-up's decays for the tests against rate random walk;
    /// `white_level` is kept for the replicates ([`FittedNoise::white_level`]).
    pub(super) fn fit(
        base: &Baseline<'_>,
        points: &[Point],
        white_level: Option<Vec<f64>>,
        opts: &Options,
        notes: &mut Vec<String>,
    ) -> Self {
        let check = |g: &NoiseParams| {
            allan_check(
                g,
                &base.resid_b,
                base.block_s(),
                |x| base.ols.residual(x),
                opts.seed,
            )
        };
        let fitted = base.reml_noise(false).map(|g| {
            let c = check(&g);
            (g, c)
        });
        let noise = match fitted {
            Some((g, c)) if c.as_ref().is_none_or(AllanCheck::fits) => Self {
                gyro: g,
                check: c,
                ramp: None,
                white_level: None,
            },
            Some((g, c)) => match base.reml_noise(true) {
                Some(g1) => {
                    let p_wb = c.as_ref().map_or(f64::NAN, |c| c.p_value);
                    let aging = points
                        .iter()
                        .find(|p| p.family == Family::Aging)
                        .and_then(|p| p.cols_b.first());
                    let (taus, decays) = points
                        .iter()
                        .filter(|p| p.family == Family::Warmup)
                        .filter_map(|p| Some((p.nl[0], p.cols_b.first()?.clone())))
                        .unzip();
                    let slow = SlowShapes {
                        aging,
                        taus,
                        decays,
                    };
                    let (noise, note) = slow_term(base, &slow, g1, p_wb, opts, check);
                    notes.push(note);
                    noise
                }
                None => Self {
                    gyro: g,
                    check: c,
                    ramp: None,
                    white_level: None,
                },
            },
            None => {
                let g = allan_fit(base, opts);
                Self {
                    check: check(&g),
                    gyro: g,
                    ramp: None,
                    white_level: None,
                }
            }
        };
        let noise = Self {
            white_level,
            ..noise
        };
        if let Some(c) = noise.check.as_ref().filter(|c| !c.fits()) {
            notes.push(format!(
                "the fitted noise model does not describe the residual's Allan deviation \
                 (p = {:.3}, largest departure {:.1} sd): significance rests on it",
                c.p_value, c.statistic
            ));
        }
        noise
    }

    /// Whether the noise model passed its Allan check (or there were too few blocks for
    /// one): its p-values then stand on their own.
    pub(super) fn trusted(&self) -> bool {
        self.check.as_ref().is_none_or(AllanCheck::fits)
    }

    /// Whether the slow tests against rate random walk can be asked: the model has none,
    /// and no rate ramp stands in its place.
    pub(super) fn without_slow_noise(&self) -> bool {
        self.gyro.rrw_dph_per_rt_h == 0.0 && self.ramp.is_none()
    }

    /// The whitening of the second scan: the exact covariance of the fitted gyro noise's
    /// block means (GLS), or `ar_fit` on a record too long for the dense factor. The bank's
    /// correlation times reach 100 blocks and a rate random walk is not stationary, neither
    /// of which an AR(3) filter can represent, and slow effects (aging, warm-up, gradient
    /// lag, mode hop) compete exactly with that slow noise.
    pub(super) fn whitener(&self, prep: &Prepared, ar_fit: &ArModel) -> Whitener {
        let nb = prep.nb();
        (nb <= GLS_MAX_BLOCKS)
            .then(|| GlsWhitener::from_cov(block_mean_cov(&self.gyro, nb, prep.block, prep.dt_s)))
            .flatten()
            .map_or_else(|| Whitener::Ar(ar_fit.clone()), Whitener::Gls)
    }

    /// The fitted noise as the evidence reports it: angle random walk, bias instability and
    /// rate random walk.
    pub(super) fn components(&self) -> [f64; 3] {
        [
            self.gyro.arw_dph_rt_h,
            self.gyro.bias_instability_dph,
            self.gyro.rrw_dph_per_rt_h,
        ]
    }
}

/// The slow functions of time that may explain a departure from white noise and bias
/// instability in rate random walk's place.
struct SlowShapes<'a> {
    /// The aging ramp's block column.
    aging: Option<&'a Vec<f64>>,
    /// The warm-up's grid of τ (s), and its decays from power-on there (block columns).
    taus: Vec<f64>,
    decays: Vec<Vec<f64>>,
}

/// Where white noise and bias instability failed the Allan check (at p-value `p_wb`): the
/// rate ramp beside the model, or else a warm-up's decay, when it explains the departure
/// better than the rate random walk `rrw`, else `rrw`; and the note that says which.
fn slow_term(
    base: &Baseline<'_>,
    slow: &SlowShapes<'_>,
    rrw: NoiseParams,
    p_wb: f64,
    opts: &Options,
    check: impl Fn(&NoiseParams) -> Option<AllanCheck>,
) -> (FittedNoise, String) {
    let draws = Draws {
        reps: opts.bootstrap,
        seed: opts.seed,
    };
    let record = base.block_record();
    let ramp = slow_term_instead_of_rrw(
        &record,
        slow.aging.map(Vec::as_slice),
        &slow.decays,
        &rrw,
        &draws,
        opts.alpha,
    )
    .map(|(r, k)| (r, k.map(|k| slow.taus[k])));
    if let Some((r, decay_tau_s)) = ramp {
        let shape = match decay_tau_s {
            Some(tau) => format!("a warm-up's decay from power-on (τ = {tau:.0} s)"),
            None => "a ramp".to_string(),
        };
        let beside = if r.gyro.rrw_dph_per_rt_h > 0.0 {
            format!(
                "white + B + K (K = {:.2e} °/h/√h) fitted beside {shape}",
                r.gyro.rrw_dph_per_rt_h
            )
        } else {
            format!("white + B fitted beside {shape}")
        };
        let alone = if rrw.rrw_dph_per_rt_h > 0.0 {
            format!("rate random walk (K = {:.2e} °/h/√h)", rrw.rrw_dph_per_rt_h)
        } else {
            "the noise refitted with rate random walk allowed (its likeliest K is 0)".to_string()
        };
        let note = match decay_tau_s {
            None => format!(
                "the residual's Allan deviation departs from white noise and bias \
                 instability (p = {p_wb:.3}); a rate ramp explains the departure \
                 better than {alone} (the record's likelihood ratio has probability \
                 {:.3} under that noise and {:.3} under the ramp): the noise model is \
                 {beside}, and aging is tested against it",
                r.p_rrw, r.p_ramp
            ),
            Some(_) => format!(
                "the residual's Allan deviation departs from white noise and bias \
                 instability (p = {p_wb:.3}); a decay from power-on explains the \
                 departure better than {alone} (the record's likelihood ratio, its τ \
                 chosen on the record and on every replicate alike, has probability \
                 {:.3} under that noise and {:.3} under the decay): the noise model is \
                 {beside}, and the candidates are tested against it",
                r.p_rrw, r.p_ramp
            ),
        };
        let noise = FittedNoise {
            ramp: Some(RampEvidence {
                rrw_dph_per_rt_h: rrw.rrw_dph_per_rt_h,
                statistic: r.statistic,
                p_under_rrw: r.p_rrw,
                p_under_ramp: r.p_ramp,
                decay_tau_s,
            }),
            gyro: r.gyro,
            check: r.check,
            white_level: None,
        };
        return (noise, note);
    }
    let note = if rrw.rrw_dph_per_rt_h > 0.0 {
        format!(
            "the residual's Allan deviation departs from white noise and bias \
             instability (p = {p_wb:.3}): rate random walk added to the noise \
             model (K = {:.2e} °/h/√h)",
            rrw.rrw_dph_per_rt_h
        )
    } else {
        format!(
            "the residual's Allan deviation departs from white noise and bias \
             instability (p = {p_wb:.3}); refitted with rate random walk \
             allowed, the likeliest K is 0"
        )
    };
    let noise = FittedNoise {
        check: check(&rrw),
        gyro: rrw,
        ramp: None,
        white_level: None,
    };
    (noise, note)
}

/// The noise of a record too long for REML: angle random walk and bias instability from the
/// Allan variance of the 1 Hz residual, bias instability recalibrated on the block means.
fn allan_fit(base: &Baseline<'_>, opts: &Options) -> NoiseParams {
    let resid1 = base
        .prep
        .baseline_residual(base.model, &base.drive, &base.beta_b);
    let allan = fit_gyro_noise(&resid1, base.prep.dt_s);
    calibrate_bias_instability(
        &allan,
        &base.resid_b,
        base.block_s(),
        |x| base.ols.residual(x),
        opts.seed,
    )
}
