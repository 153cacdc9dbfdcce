//! The search: baseline fit, candidate scans, bootstrap thresholds, held-out checks, findings.

use std::collections::BTreeMap;
use std::collections::HashMap;
use std::sync::Arc;

use rayon::prelude::*;

use super::bootstrap::{bootstrap, Test};
use super::candidates::{node_lag, Family};
use super::explain::explain;
use super::linalg::{added_fit, combine, dot, Basis};
use super::locate::{moving_average, peak_mask, phases, spans};
use super::minimise::argmin;
use super::noise::allan_check::{allan_check, AllanCheck};
use super::noise::allan_fit::{calibrate_bias_instability, fit_gyro_noise};
use super::noise::covariance::block_mean_cov;
use super::noise::reml::reml_noise;
use super::noise::replicates::{replicate_rng, simulate_block_means};
use super::noise::whiten::{ArModel, GlsWhitener, Whitener, GLS_MAX_BLOCKS};
use super::prepare::{model_drive, PhysicsModel, Prepared};
use super::ramp::{p_under_rrw, ramp_instead_of_rrw, step_p_under_rrw};
use super::refine::refine;
use super::scan::{generic_columns, scan, Point, Scan};
use super::score::{
    cycle_folds, cycle_rss, delta_bic, heldout_metrics, nonlinear_of, warmup_heldout_gain, HeldOut,
    ModelColumns,
};
use super::variance::{output_quantum, VarianceTest, MIN_COUNT_SIGMA};
use super::{
    CandidateScore, DiagnoseError, Diagnosis, Evidence, Figures, Finding, Options, Verdict,
};
use rlg_simulate::noise::NoiseParams;

/// Moving average (blocks) and threshold (σ of that average under the noise model) that
/// mark a located span of the baseline residual.
pub(super) const LOCATE_WINDOW: usize = 5;
pub(super) const LOCATE_Z: f64 = 3.5;

/// Candidate block columns that do not depend on the model (every family but the sensor's
/// lag and quantisation, which change the baseline's drive), kept across the passes of one
/// diagnosis: each pass after a finding scans the same grid against a larger model, and on
/// a month at 1 Hz rebuilding the columns cost 18 s per pass.
#[derive(Debug, Default)]
pub(crate) struct ColumnCache(std::sync::Mutex<HashMap<ColumnKey, Arc<Vec<Vec<f64>>>>>);

/// A candidate point: its family's index and the bits of its non-linear parameters.
type ColumnKey = (usize, Vec<u64>);

impl ColumnCache {
    fn get_or_build(
        &self,
        family: Family,
        nl: &[f64],
        build: impl FnOnce() -> Result<Vec<Vec<f64>>, DiagnoseError>,
    ) -> Result<Arc<Vec<Vec<f64>>>, DiagnoseError> {
        // The sensor's families depend on the model; periodic columns are closed-form sums,
        // cheaper to rebuild than the 160 MB the grid's columns hold on a month.
        if matches!(
            family,
            Family::SensorLag | Family::TempQuantization | Family::Periodic
        ) {
            return build().map(Arc::new);
        }
        let key = (family.index(), nl.iter().map(|v| v.to_bits()).collect());
        if let Some(c) = self.0.lock().ok().and_then(|m| m.get(&key).cloned()) {
            return Ok(c);
        }
        // Shared with the scan's points, not copied: on a month the grid's raw columns are
        // hundreds of MB.
        let c = Arc::new(build()?);
        if let Ok(mut m) = self.0.lock() {
            m.insert(key, Arc::clone(&c));
        }
        Ok(c)
    }
}

/// One pass of the search. `first`: the pass on the user's model; the later passes (after a
/// finding) ask whether the findings account for the structure, and there the generic test
/// keeps its one null unless a slow function of time fails the slow-drift check (see
/// `structure_under_rrw`).
pub(crate) fn run(
    prep: &Prepared,
    model: &PhysicsModel,
    opts: &Options,
    cache: &ColumnCache,
    first: bool,
) -> Result<Diagnosis, DiagnoseError> {
    let nb = prep.nb();
    let mdrive = model_drive(model, prep)?;
    let base_b = prep.baseline_blocks(model, &mdrive);
    let ols = Basis::new(&base_b);
    let beta_b = ols.coefficients(&prep.y_b);
    let resid_b = ols.residual(&prep.y_b);

    let families: Vec<Family> = Family::ALL
        .into_iter()
        .filter(|f| !model.has(f.mechanism()))
        .collect();
    let specs: Vec<(Family, Vec<f64>)> = families
        .iter()
        .flat_map(|f| f.grid(prep).into_iter().map(move |nl| (*f, nl)))
        .collect();
    let mut points: Vec<Point> = specs
        .into_par_iter()
        .map(|(family, nl)| {
            Ok(Point {
                family,
                cols_b: cache.get_or_build(family, &nl, || {
                    family.block_columns(&nl, prep, model, &mdrive, &beta_b)
                })?,
                nl,
            })
        })
        .collect::<Result<_, DiagnoseError>>()?;
    // The noise-scale family: one point with no mean column, its ΔBIC from the variance test.
    let mut notes = Vec::new();
    let block_s = prep.block as f64 * prep.dt_s;
    // (A record of burst means has one sample per block, however long the blocks.)
    if prep.block > 1 && block_s > super::prepare::BLOCK_S * 1.5 {
        notes.push(format!(
            "the record is {:.1} days long: it is analysed as {} means of {block_s:.0} s (at \
             most {} blocks) instead of 100 s means, and periodic terms are searched down to \
             periods of {:.0} s",
            prep.nb() as f64 * block_s / 86_400.0,
            prep.nb(),
            super::prepare::MAX_BLOCKS,
            4.0 * block_s
        ));
    }
    let var = families
        .contains(&Family::Heteroscedastic)
        .then(|| VarianceTest::new(prep))
        .flatten();
    if let Some(q) = output_quantum(&prep.rate_dph) {
        let counts = format!(
            "the rate is an undithered count ({q:.4} °/h per sample, {:.4}″ counts)",
            q * prep.dt_s
        );
        if let Some(v) = var.as_ref() {
            let summed = match v.summed() {
                1 => String::new(),
                k => format!(
                    " (on sums of {k} samples: the noise is a small fraction of a count, \
                     and a sum's noise grows with k while its count error does not)"
                ),
            };
            notes.push(format!(
                "{counts}: the noise-scale test takes out the count's own variance, which \
                 follows where each block's mean rate falls between counts{summed}"
            ));
        } else if families.contains(&Family::Heteroscedastic) {
            notes.push(format!(
                "{counts} whose noise is too small a part of a count even summed over a few \
                 samples (under {MIN_COUNT_SIGMA} counts, or a block whose sums are all \
                 equal): the noise-scale test is not run (what remains of the variance \
                 follows where the rate falls between counts)"
            ));
        }
    }
    if let Some(d) = var
        .as_ref()
        .map(VarianceTest::detrend_degree)
        .filter(|d| *d > 1)
    {
        notes.push(format!(
            "the rate curves within the 100 s blocks by more than its 1 s noise (a large \
             temperature coefficient where the ramps bend): the noise-scale test takes each \
             block's variance about a polynomial of degree {d}, not its straight line"
        ));
    }
    if var.as_ref().is_some_and(VarianceTest::heavy_tailed) {
        notes.push(
            "the white noise is heavy-tailed (samples beyond 4 RMS of their block more than \
             ten times as often as Gaussian noise): the noise-scale test compares the blocks' \
             ½-power means of their deviations, not their variances"
                .to_string(),
        );
    }
    let var_point = var.as_ref().map(|_| {
        points.push(Point {
            family: Family::Heteroscedastic,
            nl: Vec::new(),
            cols_b: Arc::default(),
        });
        points.len() - 1
    });
    let generic = generic_columns(prep);

    // Pass 1 whitens by an AR fit to the baseline residual; the AR fit kept for recordings too
    // long for the GLS factor is made on the residual with the best pass-1 candidate removed,
    // so a strong effect does not masquerade as noise colour.
    let ar1 = Whitener::Ar(ArModel::fit(&resid_b));
    let s1 = scan(&ar1, &base_b, &prep.y_b, &points, &generic);
    // (Fitted into an AR noise model, a real effect raises the thresholds: measured, only 23 %
    // of D ≥ 6 effects are found.)
    let best1 = argmin(&s1.dbic).filter(|&i| s1.dbic[i] < 0.0);
    // Pass 1 is needed for its best point only; its whitened columns are as large as the
    // grid's.
    drop(s1);
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
    // The noise is fitted where the tests use it, on the 100 s means, by REML (`reml.rs`):
    // white level and bias instability first; when that model fails the residual's own
    // Allan check (slow wander the bank does not describe), rate random walk is added. The
    // 1 Hz Allan fit and its recalibration remain for records too long for the dense REML.
    let check = |g: &NoiseParams| allan_check(g, &resid_b, block_s, |x| ols.residual(x), opts.seed);
    let fitted = reml_noise(&base_b, &prep.y_b, prep.block, prep.dt_s, false).map(|g| {
        let c = check(&g);
        (g, c)
    });
    // Set when a rate ramp is preferred to rate random walk: every finding then rests on
    // that choice too, and the verdict's p-value is at least its p-value.
    let mut ramp_found: Option<super::RampEvidence> = None;
    let (gyro, noise_check) = match fitted {
        Some((g, c)) if c.as_ref().is_none_or(AllanCheck::fits) => (g, c),
        Some((g, c)) => match reml_noise(&base_b, &prep.y_b, prep.block, prep.dt_s, true) {
            Some(g1) => {
                let p_wb = c.as_ref().map_or(f64::NAN, |c| c.p_value);
                let ramp = points
                    .iter()
                    .find(|p| p.family == Family::Aging)
                    .and_then(|p| p.cols_b.first())
                    .and_then(|r| {
                        ramp_instead_of_rrw(
                            &base_b,
                            r,
                            &prep.y_b,
                            &g1,
                            prep.block,
                            prep.dt_s,
                            opts.bootstrap,
                            opts.seed,
                            opts.alpha,
                        )
                    });
                if let Some(r) = ramp {
                    ramp_found = Some(super::RampEvidence {
                        rrw_dph_per_rt_h: g1.rrw_dph_per_rt_h,
                        statistic: r.statistic,
                        p_under_rrw: r.p_rrw,
                        p_under_ramp: r.p_ramp,
                    });
                    notes.push(format!(
                        "the residual's Allan deviation departs from white noise and bias \
                         instability (p = {p_wb:.3}); a rate ramp explains the departure \
                         better than rate random walk (K = {:.2e} °/h/√h; the record's \
                         likelihood ratio has probability {:.3} under rate random walk and \
                         {:.3} under the ramp): the noise model is white + B fitted beside a \
                         ramp, and aging is tested against it",
                        g1.rrw_dph_per_rt_h, r.p_rrw, r.p_ramp
                    ));
                    (r.gyro, r.check)
                } else {
                    notes.push(if g1.rrw_dph_per_rt_h > 0.0 {
                        format!(
                            "the residual's Allan deviation departs from white noise and bias \
                             instability (p = {p_wb:.3}): rate random walk added to the noise \
                             model (K = {:.2e} °/h/√h)",
                            g1.rrw_dph_per_rt_h
                        )
                    } else {
                        format!(
                            "the residual's Allan deviation departs from white noise and bias \
                             instability (p = {p_wb:.3}); refitted with rate random walk \
                             allowed, the likeliest K is 0"
                        )
                    });
                    let c1 = check(&g1);
                    (g1, c1)
                }
            }
            None => (g, c),
        },
        None => {
            let resid1 = prep.baseline_residual(model, &mdrive, &beta_b);
            let allan = fit_gyro_noise(&resid1, prep.dt_s);
            let g = calibrate_bias_instability(
                &allan,
                &resid_b,
                block_s,
                |x| ols.residual(x),
                opts.seed,
            );
            let c = check(&g);
            (g, c)
        }
    };
    if let Some(c) = noise_check.as_ref().filter(|c| !c.fits()) {
        notes.push(format!(
            "the fitted noise model does not describe the residual's Allan deviation \
             (p = {:.3}, largest departure {:.1} sd): significance rests on it",
            c.p_value, c.statistic
        ));
    }
    // Pass 2 whitens by the exact covariance of the fitted gyro noise's 100 s means (GLS):
    // the bank's correlation times reach 100 blocks and a rate random walk is not
    // stationary, neither of which an AR(3) filter can represent, and slow effects (aging,
    // warm-up, gradient lag, mode hop) compete exactly with that slow noise.
    let ar = (nb <= GLS_MAX_BLOCKS)
        .then(|| GlsWhitener::from_cov(block_mean_cov(&gyro, nb, prep.block, prep.dt_s)))
        .flatten()
        .map_or_else(|| Whitener::Ar(ar_fit.clone()), Whitener::Gls);
    let mut s = scan(&ar, &base_b, &prep.y_b, &points, &generic);
    // From here on the points are read for their family and parameters only; the scan holds
    // their whitened columns (on a month, the raw ones are another 180 MB).
    for p in &mut points {
        p.cols_b = Arc::default();
    }
    if let (Some(i), Some(v)) = (var_point, var.as_ref()) {
        s.dbic[i] = v.dbic;
    }

    let nulls = bootstrap(&ar, &gyro, &s, &points, var.as_ref(), prep, opts);
    // The record's p-value in each test alone: the other test's breaks ties between the two
    // (see `Nulls::either_p`).
    let struct_p1 = nulls.structure.p_value(s.gen_dbic);
    let best_p1 = nulls
        .best
        .p_value(s.dbic.iter().copied().fold(f64::INFINITY, f64::min));
    // Each test at the level that gives the two together false-alarm probability α.
    let (thr_all, thr_gen) = (
        nulls.threshold(opts.alpha, Test::Best, struct_p1),
        nulls.threshold(opts.alpha, Test::Structure, best_p1),
    );
    let thr = |_: Family| thr_all;
    // With a rate ramp preferred to rate random walk, every p-value rests on that choice.
    let ramp_p = ramp_found.as_ref().map(|r| r.p_under_rrw);
    let floor = |p: f64| ramp_p.map_or(p, |q| p.max(q));

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
    // A node's lag is attributed only where the residual's dependence on the rate follows the
    // term's temperature (see `rate_alone`).
    let mut rate_fit = None;
    for (f, i) in &mut best {
        let lag = node_lag(*f, &points[*i].nl);
        if lag == 0.0 {
            continue;
        }
        let rate_dbic = *rate_fit.get_or_insert_with(|| rate_alone(&ar, &s, prep));
        if rate_dbic > s.dbic[*i] {
            continue;
        }
        let Some(j) = (0..points.len())
            .filter(|&j| points[j].family == *f && node_lag(*f, &points[j].nl) == 0.0)
            .min_by(|&a, &b| s.dbic[a].total_cmp(&s.dbic[b]))
        else {
            continue;
        };
        // Said only where the lagged term would have been significant.
        if s.dbic[*i] < thr_all {
            notes.push(format!(
                "{} on a node {:.0} s {} the reading (ΔBIC {:.1}) is no better than a function \
                 of dT/dt alone (ΔBIC {rate_dbic:.1}): the lag is not attributed, and {} is \
                 judged on the reading's node (ΔBIC {:.1})",
                f.name(),
                lag.abs(),
                if lag > 0.0 { "behind" } else { "ahead of" },
                s.dbic[*i],
                f.name(),
                s.dbic[j]
            ));
        }
        *i = j;
    }
    best.sort_by(|a, b| s.dbic[a.1].total_cmp(&s.dbic[b.1]));

    let base_ho = heldout_metrics(prep, model, None)?;
    let mut scores = Vec::new();
    let mut finding = None;
    // When the noise model does not describe the residual, its p-values do not either, and a
    // finding needs evidence that does not rest on it: a thermal family must predict each
    // held-out temperature cycle (two or more cycles), and a slow function of time alone is
    // not separable from the record's own slow noise.
    let trusted = noise_check.as_ref().is_none_or(AllanCheck::fits);
    let cycles = cycle_folds(prep);
    let record_s = prep.nb() as f64 * block_s;
    let mut untestable = Vec::new();
    // The model's own leave-one-cycle-out RSS, the same for every family: computed once.
    let mut base_cycle_rss: Option<f64> = None;
    // Whether a significant family counts towards `unexplained_structure`.
    let mut sig_counted = false;
    // The smallest α at which the verdict would not be `consistent` (see `Evidence`).
    let mut p_counted: f64 = 1.0;
    // The step columns, made when aging or a periodic term first needs them.
    let mut step = None;
    let mut step_found = None;
    // White + B + rate random walk by REML on the baseline, fitted when a slow function of
    // time is first significant (`None` inside: REML puts no rate random walk in).
    let mut slow_noise: Option<Option<NoiseParams>> = None;
    let mut slow_drift: Vec<(&str, f64, Option<NoiseParams>)> = Vec::new();
    for &(f, i) in &best {
        let mut gain = 0.0;
        let mut cycle_gain = None;
        let mut p_slow: Option<f64> = None;
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
                    gain = match (f, nonlinear_of(&term)) {
                        (Family::Warmup, Some((_, nl))) => {
                            warmup_heldout_gain(prep, model, &term, nl[0])?
                        }
                        _ => base_ho.rss_b - ho.rss_b,
                    };
                    // Evidence that does not rest on the noise model: an effect of the
                    // temperature history recurs in every cycle, so fitted on the other
                    // cycles it must predict each held-out one better than the model alone.
                    // Slow noise does not recur and fails here whatever its spectrum.
                    if let (true, Some(folds)) = (f.is_thermal(), cycles.as_ref()) {
                        let base_c = match base_cycle_rss {
                            Some(v) => v,
                            None => *base_cycle_rss.insert(cycle_rss(prep, model, None, folds)?),
                        };
                        cycle_gain = Some(base_c - cycle_rss(prep, model, Some(&term), folds)?);
                    }
                    (term, unc, ho)
                }
            };
            let separable = trusted
                || match f {
                    _ if f.is_thermal() => cycle_gain.is_some(),
                    Family::Periodic => nonlinear_of(&term)
                        .is_some_and(|(_, nl)| nl[0] < record_s * SLOW_PERIOD_OF_RECORD),
                    Family::Heteroscedastic => true,
                    _ => false,
                };
            // The cycle-by-cycle gain is required only where the noise model is not trusted:
            // with two cycles each is predicted from one, and at D 5–6 on the matched
            // benchmark that alone lost a hysteresis whose bootstrap p-value was 0.005.
            let recurs = trusted || cycle_gain.is_none_or(|g| g > 0.0);
            // A drift or a slow period in time alone competes with the time-only shape
            // outside the library that real records show most: a step (a mode jump, a power
            // or readout event). Where one step fits better, the structure is not attributed,
            // and the families after this one fit worse than the step too.
            let candidate =
                separable && gain > 0.0 && recurs && finding.is_none() && step_found.is_none();
            let step_pref = if candidate {
                step_instead(f, i, &ar, &s, &points, &gyro, prep, opts, &mut step)
            } else {
                None
            };
            // A slow function of time alone (or the step preferred to it) must also beat the
            // record's own slow noise (see `slow_time_only`), even where white + B passes the
            // Allan check.
            let slow_check = separable
                && trusted
                && gyro.rrw_dph_per_rt_h == 0.0
                && ramp_found.is_none()
                && slow_time_only(f, &points[i].nl, record_s);
            if slow_check {
                let g1 = slow_noise.get_or_insert_with(|| {
                    reml_noise(&base_b, &prep.y_b, prep.block, prep.dt_s, true)
                        .filter(|g| g.rrw_dph_per_rt_h > 0.0)
                });
                if let Some(g1) = g1.as_ref() {
                    p_slow = match &step_pref {
                        Some(st) => step_p_under_rrw(
                            &base_b,
                            &prep.y_b,
                            g1,
                            prep.block,
                            prep.dt_s,
                            st.block,
                            &step_times(prep.nb()),
                            opts.bootstrap,
                            opts.seed,
                        ),
                        None => {
                            let nl = &points[i].nl;
                            let cols = cache.get_or_build(f, nl, || {
                                f.block_columns(nl, prep, model, &mdrive, &beta_b)
                            })?;
                            p_under_rrw(
                                &base_b,
                                &cols,
                                &prep.y_b,
                                g1,
                                prep.block,
                                prep.dt_s,
                                opts.bootstrap,
                                opts.seed,
                            )
                        }
                    };
                }
            }
            let beats_slow_noise = p_slow.is_none_or(|p| p <= opts.alpha);
            if separable && !beats_slow_noise {
                let shape = if step_pref.is_some() {
                    "a single step"
                } else {
                    f.name()
                };
                slow_drift.push((shape, p_slow.unwrap_or(1.0), slow_noise.clone().flatten()));
            }
            let separable = separable && beats_slow_noise;
            if !separable && gain > 0.0 && beats_slow_noise {
                untestable.push(f);
            }
            sig_counted |= separable;
            if separable {
                p_counted = p_counted.min(floor(
                    nulls
                        .either_p(nulls.best.p_value(s.dbic[i]), Test::Best, struct_p1)
                        .max(p_slow.unwrap_or(0.0)),
                ));
            }
            if separable && candidate {
                match step_pref {
                    Some(st) => {
                        let t_s = prep.t_b[st.block] - 0.5 * block_s;
                        let (name, into_h) =
                            (f.name(), (t_s - prep.t_b[0] + 0.5 * block_s) / 3600.0);
                        notes.push(format!(
                            "a single step of {:.2e} °/h at {t_s:.0} s ({into_h:.1} h into the \
                             record; ΔBIC {:.1}) explains it better than {name} (ΔBIC {:.1}): \
                             under {name} and the fitted noise a step fits this much better in \
                             a share {:.3} of bootstrap replicates, under the step {name} fits \
                             this well in {:.3}. A step at one time, not tied to temperature, \
                             is outside the term library, so the structure is not attributed",
                            st.height_dph, st.delta_bic, s.dbic[i], st.p_family, st.p_step
                        ));
                        step_found = Some(super::StepEvidence {
                            t_s,
                            height_dph: st.height_dph,
                            delta_bic: st.delta_bic,
                            instead_of: f.mechanism(),
                            instead_of_delta_bic: s.dbic[i],
                            p_under_family: st.p_family,
                            p_under_step: st.p_step,
                        });
                    }
                    None => finding = Some((f, i, term, unc, ho)),
                }
            }
        }
        scores.push(CandidateScore {
            mechanism: f.mechanism(),
            delta_bic: s.dbic[i],
            threshold: thr(f),
            p_value: floor(
                nulls
                    .either_p(nulls.best.p_value(s.dbic[i]), Test::Best, struct_p1)
                    .max(p_slow.unwrap_or(0.0)),
            ),
            p_value_alone: nulls.family[f.index()].p_value(s.dbic[i]),
            heldout_gain: gain,
            cycle_gain,
            p_value_rrw: p_slow,
        });
    }

    if finding.is_none() && !untestable.is_empty() {
        let names: Vec<&str> = untestable.iter().map(|f| f.name()).collect();
        notes.push(format!(
            "significant under the fitted noise model but not separable from the record's own \
             slow noise (the model fails its Allan check, and {} {} no cycle-by-cycle \
             evidence): slow drift, not attributed to a mechanism in a record this long",
            names.join(", "),
            if names.len() == 1 { "has" } else { "have" }
        ));
    }
    if finding.is_none() {
        for (shape, p, g) in &slow_drift {
            notes.push(format!(
                "{shape} is significant under white noise and bias instability but not under the \
                 record's noise refitted with rate random walk (K = {:.2e} °/h/√h; the \
                 record's likelihood ratio has probability {p:.3} there): slow drift, not \
                 separable from the record's own slow noise in a record this long",
                g.as_ref().map_or(f64::NAN, |g| g.rrw_dph_per_rt_h),
            ));
        }
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

    // On a later pass the generic test keeps its one null, unless a slow function of time
    // has just failed the slow-drift check: the drift it saw is then in the time chunks
    // too, and under white + B alone it passed as structure the findings leave behind.
    let struct_p_rrw = ((first || !slow_drift.is_empty())
        && gyro.rrw_dph_per_rt_h == 0.0
        && ramp_found.is_none()
        && struct_p1 <= STRUCTURE_RRW_BELOW)
        .then(|| structure_under_rrw(prep, &base_b, &generic, opts))
        .flatten();
    let structure_p = floor(nulls.either_p(
        struct_p_rrw.map_or(struct_p1, |q| struct_p1.max(q)),
        Test::Structure,
        best_p1,
    ));
    p_counted = p_counted.min(structure_p);
    let any_sig = sig_counted || (s.gen_dbic < thr_gen && structure_p <= opts.alpha);
    if let Some((p1, q)) = struct_p_rrw
        .map(|q| {
            (
                nulls.either_p(struct_p1, Test::Structure, best_p1),
                nulls.either_p(q, Test::Structure, best_p1),
            )
        })
        .filter(|(p1, q)| *p1 <= opts.alpha && *q > opts.alpha)
    {
        notes.push(format!(
            "the generic structure test (time chunks, temperature and dT/dt bands) is \
             significant under white noise and bias instability (p = {p1:.3}) but not \
             under the same record's noise refitted with rate random walk (p = {q:.3}): slow \
             drift, not separable from the record's own slow noise in a record this long"
        ));
    }
    let mut findings = Vec::new();
    if let Some((f, i, term, unc, ho)) = finding {
        // Where: blocks where the fitted effect (full fit − baseline fit; for the noise scale
        // its log-variance change) is ≥ half its peak.
        let effect: Vec<f64> = match (f, var.as_ref()) {
            (Family::Heteroscedastic, Some(v)) => v.effect(&term),
            _ => {
                let cols_b = ModelColumns::new(
                    prep,
                    model,
                    &mdrive,
                    nonlinear_of(&term).as_ref().map(|(f, nl)| (*f, &nl[..])),
                )?
                .blocks()?;
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
            mechanism: f.mechanism(),
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
            noise_check,
            notes,
            p_value: floor(p_counted),
            delta_bic_threshold: best.first().map_or(f64::NEG_INFINITY, |&(f, _)| thr(f)),
            structure_threshold: thr_gen,
            structure_delta_bic: s.gen_dbic,
            structure_p_value: structure_p,
            step: step_found,
            rate_ramp: ramp_found,
            candidates: scores,
        },
        series: super::BlockSeries::default(),
    })
}

/// A periodic term counts as slow (a function of time the record's own slow noise can
/// mimic) when its period is at least this share of the record; shorter periods recur
/// often enough within it to be told from a wander.
const SLOW_PERIOD_OF_RECORD: f64 = 1.0 / 8.0;

/// Whether the point `nl` of `f` is a slow function of time alone: aging, warm-up, or a
/// period of at least [`SLOW_PERIOD_OF_RECORD`] of the record. Such a finding under white
/// noise and bias instability must also be significant under the record's noise refitted
/// with rate random walk ([`p_under_rrw`]): over one record a rate random walk or a 1/f-like
/// wander of correlation times of days is a drift, and the Allan check, on the few
/// independent long-τ clusters a record holds, does not reject white + B for it. Measured on
/// the clean mismatched recordings of design seeds 1 and 3, flagged at α 1 / 2 / 5 / 10 %:
/// 3 / 4 / 11 / 13 → 3 / 4 / 9 / 13 and 4 / 6 / 11 / 15 → 3 / 4 / 7 / 13 of 60. Warm-up is
/// among them because, left out, it took two agings that failed the check on the matched
/// design seed.
fn slow_time_only(f: Family, nl: &[f64], record_s: f64) -> bool {
    match f {
        Family::Aging | Family::Warmup => true,
        Family::Periodic => nl
            .first()
            .is_some_and(|p| *p >= record_s * SLOW_PERIOD_OF_RECORD),
        _ => false,
    }
}

/// The generic test's second null is computed only when its first p-value is at most this
/// (a larger one decides nothing at the α the diagnosis is run at, ≤ 10 %).
const STRUCTURE_RRW_BELOW: f64 = 0.2;

/// The generic structure test's p-value under the record's noise refitted by REML under the
/// null with rate random walk allowed, its own GLS whitening and bootstrap (`None` when REML
/// puts no rate random walk in, or the record is too long for the GLS factor). Twelve time
/// chunks are among the generic columns, and over one record a drift of rate random walk or
/// of 1/f-like wander fills them as a step would: under white noise and bias instability
/// alone such a drift passed as structure. The structure test needs both p-values at α.
fn structure_under_rrw(
    prep: &Prepared,
    base_b: &[Vec<f64>],
    generic: &[Vec<f64>],
    opts: &Options,
) -> Option<f64> {
    if prep.nb() > GLS_MAX_BLOCKS {
        return None;
    }
    let g = reml_noise(base_b, &prep.y_b, prep.block, prep.dt_s, true)?;
    if g.rrw_dph_per_rt_h == 0.0 {
        return None;
    }
    let w = Whitener::Gls(GlsWhitener::from_cov(block_mean_cov(
        &g,
        prep.nb(),
        prep.block,
        prep.dt_s,
    ))?);
    let s = scan(&w, base_b, &prep.y_b, &[], generic);
    let nulls = bootstrap(&w, &g, &s, &[], None, prep, opts);
    Some(nulls.structure.p_value(s.gen_dbic))
}

/// The ΔBIC of a function of dT/dt alone that the baseline lacks: the rate's square and cube
/// (each sample's, averaged over the block; the baseline holds the linear term), fitted
/// jointly, two parameters.
///
/// A node τ behind the reading is at T − τ·dT/dt, so a term of that node differs from the same
/// term of the reading by a dependence on the rate whose size and sign follow the term's
/// temperature (a ripple's phase, a hop's switching point). A dependence on the rate that is
/// the same at every temperature is not a lag: a bias that follows the rate in a way the
/// model lacks (a gradient's square, a drive that tracks the heater's power) takes the lag's
/// extra freedom and fits a lagged ripple or play, which then names a mechanism the record
/// does not show. The lowest powers beyond the baseline's, not bins: a chamber's ramps are
/// minutes and the body's rate then decays over hours through every value, which equal bins of
/// the rate cut too coarsely for two or three parameters to follow (measured on the
/// mismatched set's rate cases: bins gained 2–4 in ΔBIC where the powers gain 30–40).
fn rate_alone(ar: &Whitener, s: &Scan, prep: &Prepared) -> f64 {
    let r = &prep.drive.dtemp_c_per_s;
    let scale = r.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if scale <= 0.0 || !scale.is_finite() {
        return f64::INFINITY;
    }
    let raw: Vec<Vec<f64>> = [2, 3]
        .into_iter()
        .map(|p| prep.blocks(&r.iter().map(|v| (v / scale).powi(p)).collect::<Vec<f64>>()))
        .collect();
    let refs: Vec<&[f64]> = raw.iter().map(Vec::as_slice).collect();
    let cols: Vec<Vec<f64>> = ar
        .whiten_many(&refs)
        .into_iter()
        .map(|c| s.basis.residual(&c))
        .collect();
    let yw = s.basis.residual(&ar.whiten(&prep.y_b));
    let (drss, _) = added_fit(&cols, &yw);
    delta_bic(s.n, s.rss0, drss, cols.len())
}

/// The best single step in the bias: the block it starts at, its height and its ΔBIC in the
/// scan's whitened metric (two parameters: height and time).
#[derive(Debug, Clone, Copy)]
struct Step {
    block: usize,
    height_dph: f64,
    delta_bic: f64,
    /// The shares of the two bootstraps (see [`step_instead`]; NaN until they are run).
    p_family: f64,
    p_step: f64,
}

/// At most this many step times are tried (evenly spaced blocks).
const STEP_TIMES: usize = 600;

/// The blocks a step is tried at: at most [`STEP_TIMES`], evenly spaced; none within 2 % of
/// either end, where a step is an offset of a few blocks, which the noise does by itself.
fn step_times(nb: usize) -> Vec<usize> {
    let edge = (nb / 50).max(2);
    if nb < 2 * edge + 2 {
        return Vec::new();
    }
    let stride = ((nb - 2 * edge) / STEP_TIMES).max(1);
    (edge..nb - edge).step_by(stride).collect()
}

/// Whitened step columns at every tried time, orthogonal to the baseline.
struct StepScan {
    blocks: Vec<usize>,
    cols: Vec<Vec<f64>>,
    norms: Vec<f64>,
}

impl StepScan {
    fn new(ar: &Whitener, s: &Scan, nb: usize) -> Option<Self> {
        let blocks = step_times(nb);
        if blocks.is_empty() {
            return None;
        }
        let raw: Vec<Vec<f64>> = blocks
            .iter()
            .map(|&k| (0..nb).map(|b| f64::from(u8::from(b >= k))).collect())
            .collect();
        let refs: Vec<&[f64]> = raw.iter().map(Vec::as_slice).collect();
        let cols: Vec<Vec<f64>> = ar
            .whiten_many(&refs)
            .into_par_iter()
            .map(|mut c| {
                s.basis.residual_in_place(&mut c);
                c
            })
            .collect();
        let norms = cols.iter().map(|c| dot(c, c)).collect();
        Some(Self {
            blocks,
            cols,
            norms,
        })
    }

    /// The best step for the whitened residual `e` (orthogonal to the baseline) whose sum of
    /// squares is `rss0`.
    fn best(&self, e: &[f64], n: usize, rss0: f64) -> Step {
        let mut best = Step {
            block: 0,
            height_dph: 0.0,
            delta_bic: f64::INFINITY,
            p_family: f64::NAN,
            p_step: f64::NAN,
        };
        for ((c, g), &k) in self.cols.iter().zip(&self.norms).zip(&self.blocks) {
            if *g <= 0.0 {
                continue;
            }
            let b = dot(c, e);
            let d = delta_bic(n, rss0, b * b / g, 2);
            if d < best.delta_bic {
                best = Step {
                    block: k,
                    height_dph: b / g,
                    delta_bic: d,
                    ..best
                };
            }
        }
        best
    }
}

/// `Some(step)` when `f` is aging or a periodic term and the record is better explained by a
/// single step than by `f`. The statistic is the step's best ΔBIC less `f`'s; each of the two
/// explanations gives it a null by a parametric bootstrap of its fitted effect plus the
/// fitted noise (on each replicate the best step and the best point of `f`'s grid are
/// refitted), and the step is preferred when the record's statistic is less probable under
/// `f` (share of `f`'s replicates at least as favourable to the step) than under the step
/// (share of the step's replicates at least as favourable to `f`). Unlike the lower ΔBIC
/// alone, this counts the search over the step's time; like it, it takes a simulated aging of
/// 0.01 °/h/day on 31 h whose best step was 0.8 lower (0.21 against 0.33: the two are close
/// there). A one-sided test of `f` at α kept both of design seed 1's steps as aging. Warm-up is not put to it: an early step is what its decay
/// from power-on looks like, and on the matched design seed the step took two of twenty real
/// warm-ups (and a mismatched one).
#[allow(clippy::too_many_arguments)]
fn step_instead(
    f: Family,
    i: usize,
    ar: &Whitener,
    s: &Scan,
    points: &[Point],
    gyro: &NoiseParams,
    prep: &Prepared,
    opts: &Options,
    cached: &mut Option<Option<StepScan>>,
) -> Option<Step> {
    if !matches!(f, Family::Aging | Family::Periodic) {
        return None;
    }
    let sc = cached
        .get_or_insert_with(|| StepScan::new(ar, s, prep.nb()))
        .as_ref()?;
    let yw = s.basis.residual(&ar.whiten(&prep.y_b));
    let step = sc.best(&yw, s.n, s.rss0);
    let t_obs = step.delta_bic - s.dbic[i];
    if t_obs >= 0.0 {
        return None;
    }
    let grid: Vec<usize> = (0..points.len())
        .filter(|&j| points[j].family == f)
        .collect();
    let reps = opts.bootstrap.max(1);
    let sims: Vec<Vec<f64>> = (0..reps)
        .into_par_iter()
        .map(|k| {
            simulate_block_means(
                gyro,
                prep.nb(),
                prep.block as f64 * prep.dt_s,
                &mut replicate_rng(opts.seed ^ STEP_SEED, k as u64),
                (opts.seed ^ STEP_SEED).wrapping_add(k as u64 + 1),
            )
        })
        .collect();
    let refs: Vec<&[f64]> = sims.iter().map(Vec::as_slice).collect();
    let noise: Vec<Vec<f64>> = ar
        .whiten_many(&refs)
        .into_par_iter()
        .map(|w| s.basis.residual(&w))
        .collect();
    // The statistic on every replicate of `effect` plus the noise.
    let stats = |effect: &[f64]| -> Vec<f64> {
        noise
            .par_iter()
            .map(|w| {
                let e: Vec<f64> = w.iter().zip(effect).map(|(a, b)| a + b).collect();
                let rss0 = dot(&e, &e);
                let df = grid
                    .iter()
                    .map(|&j| {
                        delta_bic(
                            s.n,
                            rss0,
                            s.fits[j].drss(&s.cperp[j], &e),
                            points[j].n_params(),
                        )
                    })
                    .fold(f64::INFINITY, f64::min);
                sc.best(&e, s.n, rss0).delta_bic - df
            })
            .collect()
    };
    let share = |v: Vec<f64>, extreme: &dyn Fn(f64) -> bool| {
        (1 + v.into_iter().filter(|t| extreme(*t)).count()) as f64 / (reps + 1) as f64
    };
    let p_family = share(stats(&combine(&s.cperp[i], &s.coef[i], s.n)), &|t| {
        t <= t_obs
    });
    let k = sc.blocks.iter().position(|&b| b == step.block)?;
    let step_effect: Vec<f64> = sc.cols[k].iter().map(|c| c * step.height_dph).collect();
    let p_step = share(stats(&step_effect), &|t| t >= t_obs);
    (p_family < p_step).then_some(Step {
        p_family,
        p_step,
        ..step
    })
}

/// Salt of the step test's replicates (another stream than the significance bootstrap's).
const STEP_SEED: u64 = 0x57e9;
