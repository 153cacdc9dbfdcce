//! The search: baseline fit, candidate scans, bootstrap thresholds, held-out checks, findings.

use std::collections::BTreeMap;

use rayon::prelude::*;

use super::candidates::Family;
use super::linalg::{added_fit, combine, dot, Basis};
use super::locate::{moving_average, peak_mask, phases, spans};
use super::noise::{
    block_mean_autocov, calibrate_bias_instability, fit_gyro_noise, reml_bias_instability,
    replicate_rng, simulate_block_means, ArModel, GlsWhitener, Whitener,
};
use super::prepare::{baseline_columns, model_drive, DriveSeries, PhysicsModel, Prepared};
use super::variance::VarianceTest;
use super::{
    CandidateScore, DiagnoseError, Diagnosis, Evidence, Figures, Finding, Options, Verdict,
};
use rlg_eval::metrics::{bias_stability_dph, rms};
use rlg_eval::noise::NoiseParams;
use rlg_physics::Term;

/// Held-out folds: 1 h chunks of 100 s means, interleaved over this many folds, so every
/// fold samples every part of the run (warm-up, ramps, holds) and none is extrapolated.
pub(super) const FOLDS: usize = 4;
/// Blocks per chunk (1 h of 100 s blocks).
pub(super) const CHUNK_BLOCKS: usize = 36;
/// Moving average (blocks) and threshold (σ of that average under the noise model) that
/// mark a located span of the baseline residual.
const LOCATE_WINDOW: usize = 5;
const LOCATE_Z: f64 = 3.5;

/// Held-out result of one model.
#[derive(Clone, Debug, PartialEq)]
pub struct HeldOut {
    /// Figures of merit.
    pub figures: Figures,
    /// Held-out sum of squares of the 100 s means, (°/h)².
    pub rss_b: f64,
}

fn cross_validate(prep: &Prepared, cols1: &[Vec<f64>], k: usize) -> HeldOut {
    let cols_b: Vec<Vec<f64>> = cols1.iter().map(|c| prep.blocks(c)).collect();
    let nb = prep.nb();
    let fold = |b: usize| (b / CHUNK_BLOCKS) % FOLDS;
    let mut resid1 = vec![0.0; prep.rate_dph.len()];
    let mut rss = 0.0;
    for f in 0..FOLDS {
        let train: Vec<usize> = (0..nb).filter(|&b| fold(b) != f).collect();
        if train.len() == nb {
            continue;
        }
        let tc: Vec<Vec<f64>> = cols_b
            .iter()
            .map(|c| train.iter().map(|&b| c[b]).collect())
            .collect();
        let ty: Vec<f64> = train.iter().map(|&b| prep.y_b[b]).collect();
        let beta = Basis::new(&tc).coefficients(&ty);
        for b in (0..nb).filter(|&b| fold(b) == f) {
            let pred: f64 = cols_b.iter().zip(&beta).map(|(c, w)| c[b] * w).sum();
            rss += (prep.y_b[b] - pred).powi(2);
            for i in b * prep.block..(b + 1) * prep.block {
                let p: f64 = cols1.iter().zip(&beta).map(|(c, w)| c[i] * w).sum();
                resid1[i] = prep.rate_dph[i] - p;
            }
        }
    }
    let n = nb as f64;
    HeldOut {
        figures: Figures {
            rms_dph: rms(&resid1).unwrap_or(0.0),
            b100_dph: bias_stability_dph(&resid1, prep.block).unwrap_or(0.0),
            bic: n * (rss / n).max(1e-300).ln() + k as f64 * n.ln(),
        },
        rss_b: rss,
    }
}

/// The non-linear parameters of a library term as the candidate family scans them.
fn nonlinear_of(term: &Term) -> Option<(Family, Vec<f64>)> {
    Some(match term {
        Term::SensorLag { tau_s } => (Family::SensorLag, vec![*tau_s]),
        Term::GradientLag { tau_s, .. } => (Family::GradientLag, vec![*tau_s]),
        Term::Hysteresis { width_c, .. } => (Family::Hysteresis, vec![*width_c]),
        Term::Warmup { tau_s, .. } => (Family::Warmup, vec![*tau_s]),
        Term::ModeHop {
            temp_c,
            hysteresis_c,
            ..
        } => (Family::ModeHop, vec![*temp_c, *hysteresis_c]),
        Term::Backscatter { period_c, .. } => (Family::Backscatter, vec![*period_c]),
        Term::Periodic { period_s, .. } => (Family::Periodic, vec![*period_s]),
        Term::Aging { .. } => (Family::Aging, vec![]),
        Term::TempQuantization { step_c } => (Family::TempQuantization, vec![*step_c]),
        _ => return None,
    })
}

/// Columns (per sample) of the baseline plus a candidate at non-linear parameters `nl`;
/// a sensor lag replaces the baseline's drive instead of adding a column.
fn model_columns(
    prep: &Prepared,
    model: &PhysicsModel,
    mdrive: &DriveSeries,
    extra: Option<(Family, &[f64])>,
) -> Result<Vec<Vec<f64>>, DiagnoseError> {
    let vals = |d: &DriveSeries| -> Vec<Vec<f64>> {
        baseline_columns(model, d)
            .into_iter()
            .map(|c| c.values)
            .collect()
    };
    Ok(match extra {
        None => vals(mdrive),
        Some((Family::SensorLag, nl)) => vals(&prep.drive_unlagged(nl[0])?),
        Some((Family::TempQuantization, nl)) => vals(&prep.drive_dequantised(nl[0])?),
        Some((f, nl)) => {
            let mut c = vals(mdrive);
            c.extend(f.columns(nl, prep, model, mdrive, &[])?);
            c
        }
    })
}

/// Held-out figures of `model` alone or with `extra` added (its non-linear parameters fixed,
/// its amplitude fitted), by 4-fold interleaved cross-validation on the recording. The
/// benchmark calls this with the true hidden term to obtain the true model's gain. A
/// `heteroscedastic` term does not change the mean: its check is `variance::heldout_variance`.
pub fn heldout_metrics(
    prep: &Prepared,
    model: &PhysicsModel,
    extra: Option<&Term>,
) -> Result<HeldOut, DiagnoseError> {
    let mdrive = model_drive(model, prep)?;
    let ex = extra.and_then(nonlinear_of);
    let cols = model_columns(
        prep,
        model,
        &mdrive,
        ex.as_ref().map(|(f, nl)| (*f, &nl[..])),
    )?;
    let k = cols.len() + ex.map_or(0, |(f, _)| f.n_params().saturating_sub(1));
    Ok(cross_validate(prep, &cols, k))
}

struct Point {
    family: Family,
    nl: Vec<f64>,
    cols_b: Vec<Vec<f64>>,
}

/// Whitened statistics of every candidate point.
struct Scan {
    n: usize,
    rss0: f64,
    drss: Vec<f64>,
    coef: Vec<Vec<f64>>,
    cperp: Vec<Vec<Vec<f64>>>,
    dbic: Vec<f64>,
    basis: Basis,
    gen_perp: Basis,
    gen_k: usize,
    gen_dbic: f64,
}

pub(super) fn delta_bic(n: usize, rss0: f64, drss: f64, k: usize) -> f64 {
    let n = n as f64;
    n * ((rss0 - drss).max(1e-300 * rss0) / rss0).ln() + k as f64 * n.ln()
}

fn scan(
    ar: &Whitener,
    base_b: &[Vec<f64>],
    y_b: &[f64],
    points: &[Point],
    generic: &[Vec<f64>],
) -> Scan {
    let base_w: Vec<Vec<f64>> = base_b.iter().map(|c| ar.whiten(c)).collect();
    let basis = Basis::new(&base_w);
    let yw = basis.residual(&ar.whiten(y_b));
    let n = yw.len();
    let rss0 = dot(&yw, &yw);
    let res: Vec<(Vec<Vec<f64>>, f64, Vec<f64>)> = points
        .par_iter()
        .map(|p| {
            let cp: Vec<Vec<f64>> = p
                .cols_b
                .iter()
                .map(|c| basis.residual(&ar.whiten(c)))
                .collect();
            let (d, a) = added_fit(&cp, &yw);
            (cp, d, a)
        })
        .collect();
    let mut cperp = Vec::with_capacity(res.len());
    let (mut drss, mut coef, mut dbic) = (Vec::new(), Vec::new(), Vec::new());
    for ((cp, d, a), p) in res.into_iter().zip(points) {
        dbic.push(delta_bic(n, rss0, d, p.family.n_params()));
        cperp.push(cp);
        drss.push(d);
        coef.push(a);
    }
    let gen_w: Vec<Vec<f64>> = generic
        .iter()
        .map(|c| basis.residual(&ar.whiten(c)))
        .collect();
    let gen_perp = Basis::new(&gen_w);
    let gen_k = gen_perp.q.len();
    let r = gen_perp.residual(&yw);
    let gen_dbic = delta_bic(n, rss0, rss0 - dot(&r, &r), gen_k);
    Scan {
        n,
        rss0,
        drss,
        coef,
        cperp,
        dbic,
        basis,
        gen_perp,
        gen_k,
        gen_dbic,
    }
}

/// Significance thresholds from a parametric bootstrap of the fitted gyro noise model
/// (replicates whitened exactly as the data are and run through the same scan): the `alpha`
/// quantile of the best ΔBIC over all families and grid points (the look-elsewhere effect
/// included), and that of the generic-structure ΔBIC.
///
/// Tried and not kept: a threshold per family (each family's null put on a common scale by
/// its exponential tail, the same overall α), so that a one-parameter aging drift would not
/// need the evidence of the periodic scan over hundreds of frequencies. On the benchmark's
/// seed 2 it found 45 % instead of 43 % at detectability 3–5 but raised false alarms from 8 %
/// to 12 % with the Allan-fitted noise, and with the REML noise fit 27 % vs 30 % and 6 % vs
/// 4 %: the family-wise share put the false alarms where noise misfit matters most.
#[allow(clippy::too_many_arguments)]
fn bootstrap(
    ar: &Whitener,
    gyro: &NoiseParams,
    s: &Scan,
    points: &[Point],
    var: Option<&VarianceTest>,
    prep: &Prepared,
    opts: &Options,
) -> Nulls {
    let reps: Vec<(Vec<f64>, f64)> = (0..opts.bootstrap.max(1))
        .into_par_iter()
        .map(|k| {
            let mut rng = replicate_rng(opts.seed, k as u64);
            let x = simulate_block_means(
                gyro,
                prep.nb(),
                prep.block as f64 * prep.dt_s,
                &mut rng,
                opts.seed.wrapping_add(k as u64 + 1),
            );
            let e = s.basis.residual(&ar.whiten(&x));
            let rss0 = dot(&e, &e);
            // The best ΔBIC of each family (indexed as `Family::ALL`).
            let mut best = vec![f64::INFINITY; Family::ALL.len()];
            // The variance test's replicate: independent of the block means (it sees the
            // samples about each block's line, they see each block's mean).
            let var_d = var.map(|v| v.replicate(&mut rng));
            for (cp, p) in s.cperp.iter().zip(points) {
                let d = match (p.family, var_d) {
                    (Family::Heteroscedastic, Some(d)) => d,
                    _ => delta_bic(s.n, rss0, added_fit(cp, &e).0, p.family.n_params()),
                };
                let b = &mut best[p.family.index()];
                *b = b.min(d);
            }
            let r = s.gen_perp.residual(&e);
            let g = delta_bic(s.n, rss0, rss0 - dot(&r, &r), s.gen_k);
            (best, g)
        })
        .collect();
    let overall = |r: &Vec<f64>| r.iter().copied().fold(f64::INFINITY, f64::min);
    Nulls {
        best: NullDist::new(reps.iter().map(|r| overall(&r.0)).collect()),
        family: (0..Family::ALL.len())
            .map(|f| NullDist::new(reps.iter().map(|r| r.0[f]).collect()))
            .collect(),
        structure: NullDist::new(reps.iter().map(|r| r.1).collect()),
    }
}

/// The bootstrap's null distributions.
struct Nulls {
    /// Best ΔBIC over every family and grid point: the test's.
    best: NullDist,
    /// Best ΔBIC within each family (as `Family::ALL`): what the test would be if that family
    /// alone were tested, its own scan the only look-elsewhere. Reported, never decides.
    family: Vec<NullDist>,
    /// Generic structure ΔBIC.
    structure: NullDist,
}

/// A bootstrap null distribution of a ΔBIC (more negative = stronger evidence).
struct NullDist(Vec<f64>);

impl NullDist {
    fn new(mut v: Vec<f64>) -> Self {
        v.sort_by(f64::total_cmp);
        Self(v)
    }

    /// The threshold of a test at false-alarm probability `alpha`: the `alpha` quantile.
    fn quantile(&self, alpha: f64) -> f64 {
        let n = self.0.len();
        self.0[((alpha * n as f64).floor() as usize).min(n - 1)]
    }

    /// Bootstrap p-value of an observed ΔBIC: (1 + #replicates at least as extreme)/(B + 1).
    fn p_value(&self, x: f64) -> f64 {
        let k = self.0.partition_point(|v| *v <= x);
        (1 + k) as f64 / (self.0.len() + 1) as f64
    }
}

/// Piecewise-constant columns in time (12 chunks) and in temperature (8 bands): a generic
/// basis for "is there any structure at all", with no physics in it.
fn generic_columns(prep: &Prepared) -> Vec<Vec<f64>> {
    let nb = prep.nb();
    let mut cols = Vec::new();
    for c in 1..12 {
        cols.push(
            (0..nb)
                .map(|b| f64::from(u8::from(b * 12 / nb == c)))
                .collect(),
        );
    }
    let mut sorted = prep.temp_b.clone();
    sorted.sort_by(f64::total_cmp);
    let edges: Vec<f64> = (1..8).map(|k| sorted[k * nb / 8]).collect();
    for w in edges
        .windows(2)
        .chain(std::iter::once(&[edges[6], f64::INFINITY][..]))
    {
        cols.push(
            prep.temp_b
                .iter()
                .map(|t| f64::from(u8::from(*t >= w[0] && *t < w[1])))
                .collect(),
        );
    }
    cols
}

/// Parabolic refinement of a maximum at grid index `i` of `f(u)`; returns u.
fn parabolic(u: &[f64], f: &[f64], i: usize) -> f64 {
    if i == 0 || i + 1 >= u.len() {
        return u[i];
    }
    let (u0, u1, u2) = (u[i - 1], u[i], u[i + 1]);
    let (f0, f1, f2) = (f[i - 1], f[i], f[i + 1]);
    let den = (u1 - u0) * (f1 - f2) - (u1 - u2) * (f1 - f0);
    if den.abs() < 1e-300 {
        return u1;
    }
    let num = (u1 - u0).powi(2) * (f1 - f2) - (u1 - u2).powi(2) * (f1 - f0);
    (u1 - 0.5 * num / den).clamp(u0, u2)
}

/// The non-linear parameter names of a family, in `nl` order.
fn nl_names(f: Family) -> &'static [&'static str] {
    match f {
        Family::SensorLag | Family::GradientLag | Family::Warmup => &["tau_s"],
        Family::Hysteresis => &["width_c"],
        Family::ModeHop => &["temp_c", "hysteresis_c"],
        Family::Backscatter => &["period_c"],
        Family::Periodic => &["period_s"],
        Family::Aging => &[],
        Family::Heteroscedastic => &["ref_c"],
        Family::TempQuantization => &["step_c"],
    }
}

/// The amplitude parameter name (None for sensor_lag).
fn amp_name(f: Family) -> Option<&'static str> {
    match f {
        Family::SensorLag | Family::TempQuantization => None,
        Family::Heteroscedastic => Some("k"),
        Family::GradientLag => Some("gain"),
        Family::Hysteresis => Some("height_dph"),
        Family::ModeHop => Some("step_dph"),
        Family::Aging => Some("rate_dph_per_day"),
        _ => Some("amplitude_dph"),
    }
}

pub(crate) fn run(
    prep: &Prepared,
    model: &PhysicsModel,
    opts: &Options,
) -> Result<Diagnosis, DiagnoseError> {
    let nb = prep.nb();
    let mdrive = model_drive(model, prep)?;
    let base1: Vec<Vec<f64>> = baseline_columns(model, &mdrive)
        .into_iter()
        .map(|c| c.values)
        .collect();
    let base_b: Vec<Vec<f64>> = base1.iter().map(|c| prep.blocks(c)).collect();
    let ols = Basis::new(&base_b);
    let beta_b = ols.coefficients(&prep.y_b);
    let resid_b = ols.residual(&prep.y_b);

    let families: Vec<Family> = Family::ALL
        .into_iter()
        .filter(|f| !model.has(f.name()))
        .collect();
    let specs: Vec<(Family, Vec<f64>)> = families
        .iter()
        .flat_map(|f| f.grid(prep).into_iter().map(move |nl| (*f, nl)))
        .collect();
    let mut points: Vec<Point> = specs
        .into_par_iter()
        .map(|(family, nl)| {
            let c = family.columns(&nl, prep, model, &mdrive, &beta_b)?;
            Ok(Point {
                family,
                cols_b: c.iter().map(|v| prep.blocks(v)).collect(),
                nl,
            })
        })
        .collect::<Result<_, DiagnoseError>>()?;
    // The noise-scale family: one point with no mean column, its ΔBIC from the variance test.
    let var = families
        .contains(&Family::Heteroscedastic)
        .then(|| VarianceTest::new(prep))
        .flatten();
    let var_point = var.as_ref().map(|_| {
        points.push(Point {
            family: Family::Heteroscedastic,
            nl: Vec::new(),
            cols_b: Vec::new(),
        });
        points.len() - 1
    });
    let generic = generic_columns(prep);

    // Pass 1 whitens by an AR fit to the baseline residual; the AR fit kept for recordings too
    // long for the GLS factor is made on the residual with the best pass-1 candidate removed,
    // so a strong effect does not masquerade as noise colour.
    let ar1 = Whitener::Ar(ArModel::fit(&resid_b));
    let s1 = scan(&ar1, &base_b, &prep.y_b, &points, &generic);
    // (Fitted into an AR noise model, a real effect raised the thresholds until only 23 % of
    // D ≥ 6 effects were found.)
    let best1 = argmin(&s1.dbic).filter(|&i| s1.dbic[i] < 0.0);
    let resid_nb = {
        let mut cols_b = base_b.clone();
        if let Some(i) = best1 {
            cols_b.extend(points[i].cols_b.iter().cloned());
        }
        Basis::new(&cols_b).residual(&prep.y_b)
    };
    let ar_fit = ArModel::fit(&resid_nb);
    // The gyro noise (whitening and bootstrap) is fitted under the null hypothesis, to the
    // baseline residual, as a parametric bootstrap should: angle random walk from the Allan
    // variance of the 1 Hz residual, bias instability by REML on the 100 s means. Under an
    // effect the null fit is slightly conservative (a D = 6 effect spread over 500 blocks adds
    // about 7 % to their variance).
    let resid1 = {
        let fit0 = combine(&base1, &beta_b, prep.rate_dph.len());
        prep.rate_dph
            .iter()
            .zip(&fit0)
            .map(|(a, f)| a - f)
            .collect::<Vec<f64>>()
    };
    let allan = fit_gyro_noise(&resid1, prep.dt_s);
    let gyro = reml_bias_instability(&allan, &base_b, &prep.y_b, prep.block, prep.dt_s)
        .unwrap_or_else(|| {
            calibrate_bias_instability(
                &allan,
                &resid_b,
                prep.block as f64 * prep.dt_s,
                |x| ols.residual(x),
                opts.seed,
            )
        });
    // Pass 2 whitens by the exact covariance of the fitted gyro noise's 100 s means (GLS):
    // the bank's correlation times reach 100 blocks, which an AR(3) filter cannot represent,
    // and slow effects (aging, warm-up, gradient lag, mode hop) compete exactly with that
    // slow noise.
    let ar = GlsWhitener::new(&block_mean_autocov(&gyro, nb, prep.block, prep.dt_s))
        .map_or_else(|| Whitener::Ar(ar_fit.clone()), Whitener::Gls);
    let mut s = scan(&ar, &base_b, &prep.y_b, &points, &generic);
    if let (Some(i), Some(v)) = (var_point, var.as_ref()) {
        s.dbic[i] = v.dbic;
    }

    let nulls = bootstrap(&ar, &gyro, &s, &points, var.as_ref(), prep, opts);
    let (thr_all, thr_gen) = (
        nulls.best.quantile(opts.alpha),
        nulls.structure.quantile(opts.alpha),
    );
    let thr = |_: Family| thr_all;

    // Best point of each family, most significant first.
    let mut best: Vec<(Family, usize)> = families
        .iter()
        .filter_map(|f| {
            (0..points.len())
                .filter(|&i| points[i].family == *f)
                .min_by(|&a, &b| s.dbic[a].total_cmp(&s.dbic[b]))
                .map(|i| (*f, i))
        })
        .collect();
    best.sort_by(|a, b| s.dbic[a.1].total_cmp(&s.dbic[b.1]));

    let base_ho = heldout_metrics(prep, model, None)?;
    let mut scores = Vec::new();
    let mut finding = None;
    for &(f, i) in &best {
        let mut gain = 0.0;
        if s.dbic[i] < thr(f) {
            let (term, unc, ho) = match (f, var.as_ref()) {
                (Family::Heteroscedastic, Some(v)) => {
                    let (term, u) = v.fit();
                    let unc = u.into_iter().map(|(k, x)| (k.to_string(), x)).collect();
                    let (r0, r1) = v.heldout(&term);
                    gain = r0 - r1;
                    let n = v.z.len() as f64;
                    // The mean model is unchanged; the BIC adds the held-out change of the
                    // block log-variance model (two parameters: k and ref_c).
                    let figures = Figures {
                        bic: base_ho.figures.bic
                            + n * (r1.max(1e-300) / r0.max(1e-300)).ln()
                            + 2.0 * n.ln(),
                        ..base_ho.figures
                    };
                    let ho = HeldOut {
                        figures,
                        rss_b: base_ho.rss_b,
                    };
                    (term, unc, ho)
                }
                _ => {
                    let (term, unc) =
                        refine(prep, model, &mdrive, &beta_b, &ar, &s, &points, f, i)?;
                    let ho = heldout_metrics(prep, model, Some(&term))?;
                    gain = base_ho.rss_b - ho.rss_b;
                    (term, unc, ho)
                }
            };
            if gain > 0.0 && finding.is_none() {
                finding = Some((f, i, term, unc, ho));
            }
        }
        scores.push(CandidateScore {
            mechanism: f.name().to_string(),
            delta_bic: s.dbic[i],
            threshold: thr(f),
            p_value: nulls.best.p_value(s.dbic[i]),
            p_value_alone: nulls.family[f.index()].p_value(s.dbic[i]),
            heldout_gain: gain,
        });
    }

    // Located spans of the baseline residual.
    let sigma_ma = {
        let sim = simulate_block_means(
            &gyro,
            20_000,
            prep.block as f64 * prep.dt_s,
            &mut replicate_rng(opts.seed ^ 0xa11ce, 0),
            opts.seed ^ 0xa11ce,
        );
        let ma = moving_average(&sim, LOCATE_WINDOW);
        (ma.iter().map(|v| v * v).sum::<f64>() / ma.len() as f64).sqrt()
    };
    let ma = moving_average(&resid_b, LOCATE_WINDOW);
    let mask: Vec<bool> = ma.iter().map(|v| v.abs() > LOCATE_Z * sigma_ma).collect();
    let located = spans(prep, &mask, 2, &resid_b);

    let any_sig = best.iter().any(|&(f, i)| s.dbic[i] < thr(f)) || s.gen_dbic < thr_gen;
    let mut findings = Vec::new();
    if let Some((f, i, term, unc, ho)) = finding {
        // Where: blocks where the fitted effect (full fit − baseline fit; for the noise scale
        // its log-variance change) is ≥ half its peak.
        let effect: Vec<f64> = match (f, var.as_ref()) {
            (Family::Heteroscedastic, Some(v)) => v.effect(&term),
            _ => {
                let cols1 = model_columns(
                    prep,
                    model,
                    &mdrive,
                    nonlinear_of(&term).as_ref().map(|(f, nl)| (*f, &nl[..])),
                )?;
                let cols_b: Vec<Vec<f64>> = cols1.iter().map(|c| prep.blocks(c)).collect();
                let full = Basis::new(&cols_b);
                let fit1 = combine(&cols_b, &full.coefficients(&prep.y_b), nb);
                let fit0 = combine(&base_b, &beta_b, nb);
                fit1.iter().zip(&fit0).map(|(a, b)| a - b).collect()
            }
        };
        let where_ = spans(prep, &peak_mask(&effect, 0.5), 2, &effect);
        let mut parameters = BTreeMap::new();
        for (k, v) in term.parameters() {
            parameters.insert(k, v);
        }
        let explanation = explain(
            f,
            &parameters,
            &unc,
            s.dbic[i],
            thr(f),
            &base_ho.figures,
            &ho.figures,
            &where_,
        );
        findings.push(Finding {
            mechanism: f.name().to_string(),
            parameters,
            uncertainty: unc,
            where_,
            delta_bic: s.dbic[i],
            improved: ho.figures,
            explanation,
        });
    }
    let verdict = if !findings.is_empty() {
        Verdict::MissingPhysics
    } else if any_sig {
        Verdict::UnexplainedStructure
    } else {
        Verdict::Consistent
    };
    Ok(Diagnosis {
        verdict,
        baseline: base_ho.figures,
        findings,
        located,
        phases: phases(prep),
        evidence: Evidence {
            noise_ar: ar_fit.phi.clone(),
            noise_sigma_dph: ar_fit.sigma,
            whitening: ar.name().to_string(),
            noise_fit: [
                gyro.arw_dph_rt_h,
                gyro.bias_instability_dph,
                gyro.rrw_dph_per_rt_h,
            ],
            delta_bic_threshold: best.first().map_or(f64::NEG_INFINITY, |&(f, _)| thr(f)),
            structure_threshold: thr_gen,
            structure_delta_bic: s.gen_dbic,
            structure_p_value: nulls.structure.p_value(s.gen_dbic),
            candidates: scores,
        },
        series: super::BlockSeries::default(),
    })
}

fn argmin(x: &[f64]) -> Option<usize> {
    (0..x.len()).min_by(|&a, &b| x[a].total_cmp(&x[b]))
}

/// Refines the best grid point of family `f` (parabolic interpolation of the fit gain along
/// its main non-linear parameter; for `sensor_lag` an exact refit of the baseline driven by
/// the un-lagged temperature) and returns the fitted term with 1σ uncertainties: the
/// amplitude's from the whitened least squares, the non-linear parameter's from the profile
/// of the sum of squares (the range where it rises by less than σ², i.e. Δχ² ≤ 1).
#[allow(clippy::too_many_arguments)]
fn refine(
    prep: &Prepared,
    model: &PhysicsModel,
    mdrive: &DriveSeries,
    beta_b: &[f64],
    ar: &Whitener,
    s: &Scan,
    points: &[Point],
    f: Family,
    i: usize,
) -> Result<(Term, BTreeMap<String, f64>), DiagnoseError> {
    let t_on = prep.full_drive.t_s[0];
    let idx: Vec<usize> = (0..points.len())
        .filter(|&j| points[j].family == f)
        .collect();
    let mut unc = BTreeMap::new();
    let sigma2 =
        (s.rss0 - s.drss[i]) / (s.n as f64 - s.basis.q.len() as f64 - f.n_params() as f64).max(1.0);
    if f == Family::TempQuantization {
        // Not scanned: the quantum read from the recorded values, to the CSV's 1e-4 °C.
        unc.insert("step_c".into(), 0.5e-4);
        return Ok((
            Term::TempQuantization {
                step_c: points[i].nl[0],
            },
            unc,
        ));
    }
    if f == Family::SensorLag {
        // Exact profile: whitened RSS of the baseline refitted on each un-lagged drive.
        let taus: Vec<f64> = idx.iter().map(|&j| points[j].nl[0]).collect();
        let rss: Vec<f64> = taus
            .par_iter()
            .map(|&tau| {
                let d = prep.drive_unlagged(tau)?;
                let cols: Vec<Vec<f64>> = baseline_columns(model, &d)
                    .iter()
                    .map(|c| ar.whiten(&prep.blocks(&c.values)))
                    .collect();
                let r = Basis::new(&cols).residual(&ar.whiten(&prep.y_b));
                Ok(dot(&r, &r))
            })
            .collect::<Result<_, DiagnoseError>>()?;
        let k = argmin(&rss).unwrap_or(0);
        let u: Vec<f64> = taus.iter().map(|t| t.ln()).collect();
        let neg: Vec<f64> = rss.iter().map(|v| -v).collect();
        let tau = parabolic(&u, &neg, k).exp();
        let inside: Vec<f64> = (0..taus.len())
            .filter(|&j| rss[j] - rss[k] <= sigma2)
            .map(|j| taus[j])
            .collect();
        unc.insert("tau_s".into(), half_range(&inside, &taus, k));
        return Ok((Term::SensorLag { tau_s: tau }, unc));
    }
    let mut nl = points[i].nl.clone();
    let mut coef = s.coef[i].clone();
    let mut cp = s.cperp[i].clone();
    if matches!(f, Family::ModeHop) {
        // 2-D grid: a fine local grid around the best coarse point (temperature ±1 coarse
        // step in sixths, switching hysteresis 0…4.5 °C in 0.25 °C), then the profile of
        // each axis over the coarse and fine points. On the coarse grid alone (hysteresis
        // 0, 0.5, 1, 2, 4 °C) the step came out up to 42 % off at ten times the benchmark's
        // detectability.
        let all_t: Vec<f64> = idx.iter().map(|&j| points[j].nl[0]).collect();
        let (t0, dt) = (nl[0], grid_step(&all_t, nl[0]));
        let fine: Vec<Vec<f64>> = (-6..=6)
            .flat_map(|a| {
                (0..=18).map(move |b| vec![t0 + dt * f64::from(a) / 6.0, 0.25 * f64::from(b)])
            })
            .collect();
        let yw = s.basis.residual(&ar.whiten(&prep.y_b));
        let res: Vec<(f64, Vec<f64>, Vec<Vec<f64>>)> = fine
            .par_iter()
            .map(|p| {
                let cpr: Vec<Vec<f64>> = f
                    .columns(p, prep, model, mdrive, beta_b)?
                    .iter()
                    .map(|c| s.basis.residual(&ar.whiten(&prep.blocks(c))))
                    .collect();
                let (d, a) = added_fit(&cpr, &yw);
                Ok((d, a, cpr))
            })
            .collect::<Result<_, DiagnoseError>>()?;
        let mut best_d = s.drss[i];
        if let Some(k) = (0..res.len()).max_by(|&a, &b| res[a].0.total_cmp(&res[b].0)) {
            if res[k].0 > best_d {
                best_d = res[k].0;
                nl.clone_from(&fine[k]);
                coef.clone_from(&res[k].1);
                cp.clone_from(&res[k].2);
            }
        }
        let inside: Vec<&[f64]> = idx
            .iter()
            .filter(|&&j| best_d - s.drss[j] <= sigma2)
            .map(|&j| &points[j].nl[..])
            .chain(
                fine.iter()
                    .zip(&res)
                    .filter(|(_, r)| best_d - r.0 <= sigma2)
                    .map(|(p, _)| &p[..]),
            )
            .collect();
        for (a, name) in nl_names(f).iter().enumerate() {
            let vals: Vec<f64> = inside.iter().map(|p| p[a]).collect();
            let (lo, hi) = minmax(&vals);
            let step = [dt / 6.0, 0.25][a];
            let half = if vals.is_empty() {
                0.0
            } else {
                0.5 * (hi - lo)
            };
            unc.insert((*name).to_string(), half.max(0.5 * step));
        }
    } else if !nl.is_empty() {
        let vals: Vec<f64> = idx.iter().map(|&j| points[j].nl[0]).collect();
        let gains: Vec<f64> = idx.iter().map(|&j| s.drss[j]).collect();
        let k = idx.iter().position(|&j| j == i).unwrap_or(0);
        let periodic = f == Family::Periodic;
        let u: Vec<f64> = vals
            .iter()
            .map(|v| if periodic { 1.0 / v } else { v.ln() })
            .collect();
        let ur = parabolic(&u, &gains, k);
        let cand = if periodic { 1.0 / ur } else { ur.exp() };
        let cols = f.columns(&[cand], prep, model, mdrive, beta_b)?;
        let cpr: Vec<Vec<f64>> = cols
            .iter()
            .map(|c| s.basis.residual(&ar.whiten(&prep.blocks(c))))
            .collect();
        let yw = s.basis.residual(&ar.whiten(&prep.y_b));
        let (d, a) = added_fit(&cpr, &yw);
        if d >= s.drss[i] {
            nl = vec![cand];
            coef = a;
            cp = cpr;
        }
        let inside: Vec<f64> = (0..vals.len())
            .filter(|&j| s.drss[i] - gains[j] <= sigma2)
            .map(|j| vals[j])
            .collect();
        unc.insert(nl_names(f)[0].to_string(), half_range(&inside, &vals, k));
    }
    // Amplitude uncertainty from the whitened joint fit (Frisch–Waugh: the candidate's
    // columns orthogonal to the baseline carry its covariance σ²·(CᵀC)⁻¹).
    let sigma = sigma2.sqrt();
    if let Some(name) = amp_name(f) {
        let se = match cp.len() {
            1 => sigma / dot(&cp[0], &cp[0]).sqrt(),
            _ => {
                let (g11, g12, g22) = (
                    dot(&cp[0], &cp[0]),
                    dot(&cp[0], &cp[1]),
                    dot(&cp[1], &cp[1]),
                );
                let det = g11 * g22 - g12 * g12;
                let (c11, c12, c22) = (g22 / det, -g12 / det, g11 / det);
                let a = coef[0].hypot(coef[1]).max(1e-300);
                let (u1, u2) = (coef[0] / a, coef[1] / a);
                sigma * (u1 * u1 * c11 + 2.0 * u1 * u2 * c12 + u2 * u2 * c22).sqrt()
            }
        };
        unc.insert(name.to_string(), se);
    }
    Ok((f.term(&nl, &coef, t_on), unc))
}

fn minmax(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        })
}

fn grid_step(all: &[f64], at: f64) -> f64 {
    all.iter()
        .map(|v| (v - at).abs())
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min)
        .min(at.abs().max(1e-12))
}

/// Half the range of the grid values inside the Δχ² ≤ 1 region, at least half a grid step.
fn half_range(inside: &[f64], all: &[f64], k: usize) -> f64 {
    let (lo, hi) = minmax(inside);
    let step = grid_step(all, all[k]);
    if inside.is_empty() {
        return 0.5 * step;
    }
    (0.5 * (hi - lo)).max(0.5 * step)
}

/// Plain-words explanation of a finding.
#[allow(clippy::too_many_arguments)]
fn explain(
    f: Family,
    p: &BTreeMap<String, f64>,
    u: &BTreeMap<String, f64>,
    dbic: f64,
    thr: f64,
    before: &Figures,
    after: &Figures,
    where_: &[super::Span],
) -> String {
    let pu = |k: &str| {
        format!(
            "{k} = {:.4} ± {:.2}",
            p.get(k).copied().unwrap_or(f64::NAN),
            u.get(k).copied().unwrap_or(f64::NAN)
        )
    };
    let mech = match f {
        Family::SensorLag => format!("the temperature sensor lags the gyro body ({}); the model, driven by the late reading, misplaces every temperature-dependent bias during ramps", pu("tau_s")),
        Family::GradientLag => format!("a bias follows the rate of temperature change through a thermal lag ({}, {} °/h per °C/s): it persists after each ramp ends", pu("tau_s"), pu("gain")),
        Family::Hysteresis => format!("the bias differs between heating and cooling at the same temperature ({}, {} °/h)", pu("width_c"), pu("height_dph")),
        Family::Warmup => format!("a transient decays after power-on ({} °/h, {})", pu("amplitude_dph"), pu("tau_s")),
        Family::ModeHop => format!("the bias steps by {} °/h when the temperature crosses {} °C ({} °C switching hysteresis)", pu("step_dph"), pu("temp_c"), pu("hysteresis_c")),
        Family::Backscatter => format!("a ripple periodic in temperature ({}, {} °/h), as backscatter/lock-in varies with cavity length", pu("period_c"), pu("amplitude_dph")),
        Family::Periodic => format!("a ripple periodic in time ({}, {} °/h), an external disturbance", pu("period_s"), pu("amplitude_dph")),
        Family::Aging => format!("the bias drifts linearly in time ({} °/h per day)", pu("rate_dph_per_day")),
        Family::Heteroscedastic => format!("the 1 Hz white noise grows away from {} °C as 1 + k·((T − ref)/30)² ({}); the mean model is unchanged, so the RMS and 100 s stability below are too, and the BIC adds the held-out gain of the block log-variance model", pu("ref_c"), pu("k")),
        Family::TempQuantization => format!("the temperature reading is rounded to {} °C, read from the recorded values; driven by the staircase, the model sees false temperature steps and dT/dt spikes, which the reconstructed (de-quantised) temperature removes", pu("step_c")),
    };
    let wh = match where_.first() {
        Some(w) => format!(
            " The effect is largest in {} span(s), the first {:.0}–{:.0} s ({}, {:.1}–{:.1} °C).",
            where_.len(),
            w.t_start_s,
            w.t_end_s,
            w.phase,
            w.temp_lo_c,
            w.temp_hi_c
        ),
        None => String::new(),
    };
    format!(
        "{}: {mech}. Adding it changes the BIC of the whitened 100 s means by {dbic:.1} (significance threshold {thr:.1} from the noise-model bootstrap); on held-out data the 100 s stability goes from {:.2e} to {:.2e} °/h and the BIC from {:.1} to {:.1}.{wh}",
        f.name(),
        before.b100_dph,
        after.b100_dph,
        before.bic,
        after.bic
    )
}

#[cfg(test)]
mod tests {
    use super::{Family, NullDist};

    /// The per-family nulls are indexed by `Family::index`, which must follow `Family::ALL`.
    #[test]
    fn family_index_follows_all() {
        for (i, f) in Family::ALL.into_iter().enumerate() {
            assert_eq!(f.index(), i, "{}", f.name());
        }
    }

    /// The threshold at α is the α quantile of the replicates, and a ΔBIC below it has a
    /// p-value of at most α (to the resolution 1/(B + 1)).
    #[test]
    fn null_quantile_and_p_value_agree() {
        // Replicates −1, −2, …, −400 (ΔBIC; lower = more extreme).
        let d = NullDist::new((1..=400).map(|k| -f64::from(k)).collect());
        assert_eq!(d.quantile(0.01), -396.0);
        assert_eq!(d.quantile(0.05), -380.0);
        assert!((d.p_value(-396.5) - 5.0 / 401.0).abs() < 1e-12);
        assert!(d.p_value(-396.5) <= 0.01 + 1.0 / 401.0);
        assert!((d.p_value(-1000.0) - 1.0 / 401.0).abs() < 1e-12);
        assert!((d.p_value(0.0) - 1.0).abs() < 1e-12);
        for x in [-399.0, -390.0, -350.0, -10.0] {
            let p = d.p_value(x);
            for a in [0.01, 0.02, 0.05, 0.5] {
                if x < d.quantile(a) {
                    assert!(p <= a + 1.0 / 401.0, "x {x} p {p} a {a}");
                }
            }
        }
    }
}
