//! Each family's best point, and its judgement: in order of significance, a significant
//! point is fitted (its term refined, its held-out gain), asked for evidence that does not
//! rest on the noise model, and put against the two other explanations of a slow function
//! of time (a single step, the record's own slow noise). The first point that passes all of
//! it is the pass's finding.

use std::collections::BTreeMap;

use rlg_physics::Term;

use super::bump::{bump_instead, BumpScan};
use super::cache::ColumnCache;
use super::line::{line_ratio, LINE_RATIO};
use super::noise_model::FittedNoise;
use super::significance::Significance;
use super::slow::{slow_time_only, SlowDrift, SLOW_PERIOD_OF_RECORD};
use super::step::{step_instead, step_times, Against, Step, StepScan, STEP_TIMES};
use super::ALONE_NO_GAIN;
use crate::baseline::Baseline;
use crate::candidates::{node_lag, Family, WARMUP_TAU_MAX_S};
use crate::linalg::{added_fit, Basis};
use crate::noise::allan_check::allan_check;
use crate::noise::reml::reml_noise;
use crate::noise::whiten::Whitener;
use crate::prepare::Prepared;
use crate::ramp::{best_p_beside_rrw, best_p_under_rrw, p_under_rrw, step_p_under_rrw, Draws};
use crate::refine::refine;
use crate::scan::{Scan, Scanned};
use crate::score::{
    cycle_folds, cycle_rss, delta_bic, heldout_metrics, nonlinear_of, warmup_heldout_gain, HeldOut,
};
use crate::variance::VarianceTest;
use crate::{BumpEvidence, CandidateScore, DiagnoseError, Figures, Options, StepEvidence};
use rlg_simulate::noise::NoiseParams;

/// The best point of each family (its index among the scan's points), best fit first, the
/// reading's quantisation before the families that fit better by less than strong evidence.
/// A node's lag is attributed only where the residual's dependence on the rate follows the
/// term's temperature ([`rate_alone`]): elsewhere the family's best point on the reading's
/// own node stands for it, with a note where the lagged one would have been significant.
pub(super) fn best_points(
    scanned: &Scanned<'_>,
    families: &[Family],
    sig: &Significance,
    prep: &Prepared,
    notes: &mut Vec<String>,
) -> Vec<(Family, usize)> {
    let (s, points) = (scanned.scan, scanned.points);
    let best_of = |f: Family, keep: &dyn Fn(usize) -> bool| {
        (0..points.len())
            .filter(|&j| points[j].family == f && keep(j))
            .min_by(|&a, &b| s.dbic[a].total_cmp(&s.dbic[b]))
    };
    let mut best: Vec<(Family, usize)> = families
        .iter()
        .filter_map(|f| best_of(*f, &|_| true).map(|i| (*f, i)))
        .collect();
    let mut rate_fit = None;
    for (f, i) in &mut best {
        let lag = node_lag(*f, &points[*i].nl);
        if lag == 0.0 {
            continue;
        }
        let rate_dbic = *rate_fit.get_or_insert_with(|| rate_alone(scanned.whitener, s, prep));
        if rate_dbic > s.dbic[*i] {
            continue;
        }
        let Some(j) = best_of(*f, &|j| node_lag(*f, &points[j].nl) == 0.0) else {
            continue;
        };
        // Said only where the lagged term would have been significant.
        if s.dbic[*i] < sig.threshold(*f) {
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
    // In order of fit, not of significance: each family is significant on its own tail,
    // but which of two significant families describes the record is the one that fits it
    // better (ordered on their tails, a family of few points, a gradient's lag, would take
    // a sensor's lag and a coarse reading's steps from the families that fit them).
    best.sort_by(|a, b| s.dbic[a.1].total_cmp(&s.dbic[b.1]));
    // The reading's rounding is seen in the record (the family exists only where the
    // reading's quantum is read from it); a family that fits about as well is inferred. So
    // the quantisation goes before the families that fit better by less than strong evidence
    // ([`crate::CLOSE_DELTA_BIC`]): on a staircase reading, a gradient's lag takes the
    // rounding's spikes of dT/dt as well, and named first it leaves the rounding unnamed.
    if let Some(k) = best.iter().position(|p| p.0 == Family::TempQuantization) {
        let quantum = s.dbic[best[k].1];
        if let Some(to) = best[..k]
            .iter()
            .position(|p| quantum - s.dbic[p.1] < crate::CLOSE_DELTA_BIC)
        {
            let q = best.remove(k);
            best.insert(to, q);
        }
    }
    best
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
/// minutes and the body's rate then decays over hours through every value, which equal bins
/// of the rate cut too coarsely for two or three parameters to follow (bins gain about a
/// tenth of what the powers gain on a bias in the rate's square).
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

/// What a pass judges each family's best point against.
pub(super) struct Judge<'a> {
    /// The model's fit.
    pub(super) base: &'a Baseline<'a>,
    /// The grid's scan.
    pub(super) scanned: &'a Scanned<'a>,
    /// The noise-scale test, where it runs.
    pub(super) var: Option<&'a VarianceTest>,
    /// The fitted noise.
    pub(super) noise: &'a FittedNoise,
    /// The thresholds and p-value scale.
    pub(super) sig: &'a Significance,
    /// The diagnosis' options.
    pub(super) opts: &'a Options,
    /// Candidate columns kept across passes.
    pub(super) cache: &'a ColumnCache,
    /// The model's own held-out figures.
    pub(super) base_ho: HeldOut,
}

/// A significant point fitted: its term, the term's 1σ uncertainties and held-out figures.
pub(super) struct Fitted {
    /// The family.
    pub(super) family: Family,
    /// Its point among the scan's points.
    pub(super) point: usize,
    /// The refined term.
    pub(super) term: Term,
    /// 1σ uncertainties of its parameters, by the library's names.
    pub(super) unc: BTreeMap<String, f64>,
    /// Held-out figures with the term added.
    pub(super) heldout: HeldOut,
    /// Reduction of the held-out sum of squares, (°/h)² (for the noise scale, of the block
    /// log-variances).
    gain: f64,
    /// Reduction when each temperature cycle is predicted from the others (thermal families
    /// on records of two or more cycles).
    cycle_gain: Option<f64>,
    /// On a record of one temperature cycle whose noise model failed its check: whether white
    /// noise and bias instability, refitted beside the term, describe the residual (the term
    /// is then what the check saw).
    explains_departure: bool,
    /// Where modelling the term alone lowers no held-out error: another family significant
    /// on its own beside which it does, each lowering the other's (see
    /// `Judge::gain_beside`).
    beside: Option<Beside>,
}

/// Another family's term beside which a term lowers the held-out error.
#[derive(Clone, Copy)]
struct Beside {
    family: Family,
    /// Its p-value alone.
    p_alone: f64,
    /// The term's held-out gain with the other's term in the model, (°/h)².
    gain: f64,
}

/// What a pass concluded from its families' best points.
pub(super) struct Judged {
    /// Every family's score, most significant first.
    pub(super) scores: Vec<CandidateScore>,
    /// The first point that passed every check.
    pub(super) finding: Option<Fitted>,
    /// A single step preferred to a slow function of time (no finding is made after it).
    pub(super) step: Option<StepEvidence>,
    /// A bump at one temperature preferred to a family stationary in temperature (no
    /// finding is made after it).
    pub(super) bump: Option<BumpEvidence>,
    /// Significant families with a held-out gain that are not separable from the record's
    /// slow noise (the noise model failed its check, and they have no cycle-by-cycle
    /// evidence).
    untestable: Vec<Family>,
    /// Significant families not attributed for what their fit is the shape of instead (a
    /// noise level that follows time, a period at which the temperature oscillates); not
    /// close alternatives to a finding either.
    pub(super) unattributable: Vec<Family>,
    /// Slow functions of time significant under white + B but not under rate random walk.
    pub(super) slow_drift: Vec<SlowDrift>,
    /// Significant families that count but are not named, with why (see [`Unconfirmed`]).
    unconfirmed: Vec<Unconfirmed>,
    /// Whether a significant family counts towards `unexplained_structure`.
    pub(super) counted: bool,
    /// The smallest α at which a family would make the verdict other than `consistent`.
    pub(super) p_counted: f64,
    /// Notes of the steps and bumps preferred, in order.
    pub(super) notes: Vec<String>,
}

/// A family significant and separable from the record's noise that is not named: modelling
/// it lowers no held-out error, or, where the noise model is not trusted, fitted on the
/// other temperature cycles it predicts them no better. It still makes the verdict
/// `unexplained_structure`, and without a note the user would see that verdict with no
/// shape and no reason.
struct Unconfirmed {
    family: Family,
    /// Its p-value on the verdict's scale.
    p_value: f64,
    /// Its held-out gain, (°/h)².
    gain: f64,
    /// Its cycle-by-cycle gain, (°/h)², where that is what it failed.
    cycle_gain: Option<f64>,
}

impl Unconfirmed {
    /// The evidence's note on it.
    fn note(&self) -> String {
        let why = match self.cycle_gain {
            Some(g) => format!(
                "fitted on the other temperature cycles it predicts them no better (gain \
                 {g:.2e} (°/h)²)"
            ),
            None => format!(
                "modelling it lowers no held-out error (gain {:.2e} (°/h)²)",
                self.gain
            ),
        };
        format!(
            "{} fits the residual significantly (p = {:.3}) but is not named: {why}; the \
             structure it fits is counted as unexplained",
            self.family.name(),
            self.p_value
        )
    }
}

impl Beside {
    /// The evidence's note on the finding `f` named for it, `alone` its own gain.
    fn note(self, f: Family, alone: f64) -> String {
        format!(
            "{} {ALONE_NO_GAIN} (gain {alone:.2e} (°/h)²) but does beside {} \
             (significant on its own, p = {:.3}; gain {:.2e} (°/h)², and {} lowers it beside \
             {} too): the next pass, with it in the model, asks for the other",
            f.name(),
            self.family.name(),
            self.p_alone,
            self.gain,
            self.family.name(),
            f.name()
        )
    }
}

/// What a family's check computes once per pass, when first needed.
#[derive(Default)]
struct OncePerPass {
    /// The model's own leave-one-cycle-out sum of squares.
    base_cycle_rss: Option<f64>,
    /// The whitened step columns (`None` inside: the record has no room for a step).
    steps: Option<Option<StepScan>>,
    /// The whitened windows in temperature (`None` inside: the record has none).
    bumps: Option<Option<BumpScan>>,
    /// White + B + rate random walk by REML on the baseline (`None` inside: REML puts no
    /// rate random walk in).
    slow_noise: Option<Option<NoiseParams>>,
    /// The note on an aging whose drift beat the slow noise as a decay (see
    /// `p_under_slow_noise`).
    drift_note: Option<String>,
}

impl Judge<'_> {
    /// Judges the best points `best` (most significant first).
    pub(super) fn judge(&self, best: &[(Family, usize)]) -> Result<Judged, DiagnoseError> {
        let mut out = Judged {
            scores: Vec::new(),
            finding: None,
            step: None,
            bump: None,
            untestable: Vec::new(),
            unattributable: Vec::new(),
            slow_drift: Vec::new(),
            unconfirmed: Vec::new(),
            counted: false,
            p_counted: 1.0,
            notes: Vec::new(),
        };
        let mut once = OncePerPass::default();
        // When the noise model does not describe the residual, its p-values do not either,
        // and a finding needs evidence that does not rest on it: a thermal family must
        // predict each held-out temperature cycle (two or more cycles), and a slow function
        // of time alone is not separable from the record's own slow noise.
        let cycles = cycle_folds(self.base.prep);
        for &(f, i) in best {
            let dbic = self.scanned.scan.dbic[i];
            let mut score = CandidateScore {
                mechanism: f.mechanism(),
                delta_bic: dbic,
                threshold: self.sig.threshold(f),
                p_value: 1.0,
                p_value_alone: self.sig.alone_p(f, dbic),
                heldout_gain: 0.0,
                cycle_gain: None,
                p_value_rrw: None,
            };
            if dbic < self.sig.threshold(f) {
                let mut fit = match (f, self.var) {
                    (Family::Heteroscedastic, Some(v)) => self.fit_noise_scale(v, i),
                    _ => self.fit_mean(f, i, cycles.as_deref(), &mut once)?,
                };
                let open = out.finding.is_none() && out.step.is_none() && out.bump.is_none();
                if open && fit.gain <= 0.0 {
                    fit.beside = self.gain_beside(&fit, best)?;
                }
                score.heldout_gain = fit.gain;
                score.cycle_gain = fit.cycle_gain;
                score.p_value_rrw = self.weigh(fit, &mut out, &mut once)?;
            }
            score.p_value = self.sig.candidate_p(f, dbic, score.p_value_rrw);
            out.scores.push(score);
        }
        Ok(out)
    }

    /// The noise-scale term fitted on the block log-variances. The mean model is unchanged;
    /// the BIC adds the held-out change of the block log-variance model (two parameters: k
    /// and ref_c).
    fn fit_noise_scale(&self, v: &VarianceTest, i: usize) -> Fitted {
        let (term, u) = v.fit();
        let unc = u.into_iter().map(|(k, x)| (k.to_string(), x)).collect();
        let (r0, r1) = v.heldout(&term);
        let n = v.z.len() as f64;
        let figures = Figures {
            bic: self.base_ho.figures.bic
                + n * (r1.max(1e-300) / r0.max(1e-300)).ln()
                + 2.0 * n.ln(),
            ..self.base_ho.figures
        };
        Fitted {
            family: Family::Heteroscedastic,
            point: i,
            term,
            unc,
            heldout: HeldOut {
                figures,
                rss_b: self.base_ho.rss_b,
            },
            gain: r0 - r1,
            cycle_gain: None,
            explains_departure: false,
            beside: None,
        }
    }

    /// A family of the mean refined from its point `i`, with its held-out gain and, for a
    /// thermal family on a record of two or more temperature cycles (`cycles`: each block's
    /// cycle), its gain when each cycle is predicted from the others.
    fn fit_mean(
        &self,
        f: Family,
        i: usize,
        cycles: Option<&[usize]>,
        once: &mut OncePerPass,
    ) -> Result<Fitted, DiagnoseError> {
        let (prep, model) = (self.base.prep, self.base.model);
        let (term, unc) = refine(self.base, self.scanned, i)?;
        let heldout = heldout_metrics(prep, model, Some(&term))?;
        let gain = match (f, nonlinear_of(&term)) {
            (Family::Warmup, Some((_, nl))) => warmup_heldout_gain(prep, model, &term, nl[0])?,
            _ => self.base_ho.rss_b - heldout.rss_b,
        };
        // Evidence that does not rest on the noise model: an effect of the temperature
        // history recurs in every cycle, so fitted on the other cycles it must predict each
        // held-out one better than the model alone. Slow noise does not recur and fails here
        // whatever its spectrum.
        let cycle_gain = match (f.is_thermal(), cycles) {
            (true, Some(folds)) => {
                let base_c = match once.base_cycle_rss {
                    Some(v) => v,
                    None => *once
                        .base_cycle_rss
                        .insert(cycle_rss(prep, model, None, folds)?),
                };
                Some(base_c - cycle_rss(prep, model, Some(&term), folds)?)
            }
            _ => None,
        };
        let explains_departure = f.is_thermal()
            && cycles.is_none()
            && !self.noise.trusted()
            && self.explains_departure(&term)?;
        Ok(Fitted {
            family: f,
            point: i,
            term,
            unc,
            heldout,
            gain,
            cycle_gain,
            explains_departure,
            beside: None,
        })
    }

    /// Whether white noise and bias instability, fitted by REML beside `term`, pass the Allan
    /// check on the residual with `term` added. A record of one temperature cycle has no
    /// held-out cycle to show that a thermal effect recurs; what it can show is that the
    /// departure from white + B that made the noise model fail was the effect: with the term
    /// in, the residual is white + B again, which slow noise a thermal term absorbs only by
    /// chance (the bootstrap threshold the term already passed is under the noise refitted
    /// with rate random walk).
    fn explains_departure(&self, term: &Term) -> Result<bool, DiagnoseError> {
        let Some((f, nl)) = nonlinear_of(term) else {
            return Ok(false);
        };
        let base = self.base;
        let mut cols = base.cols_b.clone();
        cols.extend(base.candidate_blocks(f, &nl)?);
        let Some(g) = reml_noise(
            &cols,
            &base.prep.y_b,
            base.prep.block,
            base.prep.dt_s,
            false,
        ) else {
            return Ok(false);
        };
        let basis = Basis::new(&cols);
        let resid = basis.residual(&base.prep.y_b);
        let check = allan_check(
            &g,
            &resid,
            base.block_s(),
            |x| basis.residual(x),
            self.opts.seed,
        );
        Ok(check.is_some_and(|c| c.fits()))
    }

    /// Weighs a significant family's fit: whether it is separable from the record's slow
    /// noise, whether a single step explains the record better, whether it beats the
    /// record's noise refitted with rate random walk; records what it counts for in `out`
    /// (the fit becomes the finding where it passes everything and none was made before).
    /// Returns its p-value under rate random walk where that was asked.
    fn weigh(
        &self,
        fit: Fitted,
        out: &mut Judged,
        once: &mut OncePerPass,
    ) -> Result<Option<f64>, DiagnoseError> {
        let (f, i) = (fit.family, fit.point);
        let prep = self.base.prep;
        let dbic = self.scanned.scan.dbic[i];
        let trusted = self.noise.trusted();
        let record_s = prep.nb() as f64 * self.base.block_s();
        let separable = trusted
            || match f {
                _ if f.is_thermal() => fit.cycle_gain.is_some() || fit.explains_departure,
                Family::Periodic => nonlinear_of(&fit.term)
                    .is_some_and(|(_, nl)| nl[0] < record_s * SLOW_PERIOD_OF_RECORD),
                Family::Heteroscedastic => true,
                _ => false,
            };
        // A noise scale must go with temperature, not only with time; whatever its held-out
        // gain: a noise level that changes in time and that a temperature quadratic does not
        // predict is not structure of the bias either.
        let in_time = f == Family::Heteroscedastic && !self.noise_scale_with_temperature(out);
        // A period in time where the temperature oscillates at that period is the
        // temperature's as much: the thermal families weigh it, not `periodic`.
        let in_temperature = f == Family::Periodic && self.period_of_temperature(&fit.term, out);
        let unattributable = in_time || in_temperature;
        if unattributable {
            out.unattributable.push(f);
        }
        let separable = separable && !unattributable;
        // The cycle-by-cycle gain is required only where the noise model is not trusted:
        // with two cycles each is predicted from one, which loses real hysteresis near the
        // detection threshold that the bootstrap finds clearly.
        let recurs = trusted || fit.cycle_gain.is_none_or(|g| g > 0.0);
        // A decay from power-on slower than any warm-up of the library is no warm-up: it is a
        // monotone trend over the record, the aging family's, and a significant aging that
        // passes every check below takes the finding from it.
        let replaces = f == Family::Aging
            && out
                .finding
                .as_ref()
                .is_some_and(|w| Self::unresolved_decay(&w.term));
        let gain = fit.beside.map_or(fit.gain, |b| b.gain);
        let candidate = separable
            && gain > 0.0
            && recurs
            && (out.finding.is_none() || replaces)
            && out.step.is_none()
            && out.bump.is_none();
        // A drift or a slow period in time alone competes with the time-only shape outside
        // the library that real records show most: a step (a mode jump, a power or readout
        // event). Where one step fits better, the structure is not attributed, and the
        // families after this one fit worse than the step too.
        let against = Against {
            scanned: self.scanned,
            gyro: &self.noise.gyro,
            white_level: self.noise.white_level.as_deref(),
            prep,
            opts: self.opts,
        };
        let step_pref = if candidate {
            step_instead(&against, i, &mut once.steps)
        } else {
            None
        };
        // A ripple or a step in temperature competes in the same way with a bump at one
        // temperature, which each of them takes otherwise.
        let bump_pref = if candidate {
            bump_instead(&against, i, &mut once.bumps)
        } else {
            None
        };
        // A slow function of time alone (or the step preferred to it) must also beat the
        // record's own slow noise (see `slow_time_only`), even where white + B passes the
        // Allan check.
        // So must a thermal effect that does not recur cycle by cycle: fitted on the other
        // cycles it predicts none better, which is what slow noise a thermal shape absorbs
        // looks like (a loop as wide as the range over one or two cycles is a drift in
        // time); it is tested beside that noise, not against it, among the family's scanned
        // points.
        let not_recurring = f.is_thermal() && fit.cycle_gain.is_some_and(|g| g <= 0.0);
        // So must a thermal effect weighed after structure that fit the record better and did
        // not beat that noise: the structure may be the record's slow noise, and a loop or a
        // lag fitted over a cycle or two takes part of a drift (heating first, cooling later).
        // Judged under white + B alone, it would name a mechanism for the part of the slow
        // noise it fits.
        let after_slow_drift = f.is_thermal() && !out.slow_drift.is_empty();
        let slow_check = separable
            && trusted
            && self.noise.without_slow_noise()
            && (not_recurring
                || after_slow_drift
                || slow_time_only(f, &self.scanned.points[i].nl, record_s));
        let p_slow = if slow_check {
            self.p_under_slow_noise(f, i, step_pref.as_ref(), once)?
        } else {
            None
        };
        let beats_slow_noise = p_slow.is_none_or(|p| p <= self.opts.alpha);
        if separable && !beats_slow_noise {
            out.slow_drift.push(SlowDrift {
                shape: if step_pref.is_some() {
                    "a single step"
                } else {
                    f.name()
                },
                p_value: p_slow.unwrap_or(1.0),
                noise: once.slow_noise.clone().flatten(),
            });
        }
        let separable = separable && beats_slow_noise;
        if !separable && !unattributable && gain > 0.0 && beats_slow_noise {
            out.untestable.push(f);
        }
        out.counted |= separable;
        if separable {
            let p = self.sig.candidate_p(f, dbic, p_slow);
            out.p_counted = out.p_counted.min(p);
            if gain <= 0.0 || !recurs {
                out.unconfirmed.push(Unconfirmed {
                    family: f,
                    p_value: p,
                    gain: fit.gain,
                    cycle_gain: fit.cycle_gain.filter(|_| !recurs),
                });
            }
        }
        if let (true, true, Some(b)) = (separable, candidate, bump_pref) {
            let (note, evidence) = b.evidence(f, dbic);
            out.notes.push(note);
            out.bump = Some(evidence);
        } else if separable && candidate {
            match (step_pref, out.finding.take()) {
                (Some(_), Some(decay)) => out.finding = Some(decay),
                (Some(st), None) => {
                    let (note, evidence) = st.evidence(prep, f, dbic);
                    out.notes.push(note);
                    out.step = Some(evidence);
                }
                (None, decay) => {
                    if let Some(b) = fit.beside {
                        out.notes.push(b.note(f, fit.gain));
                    }
                    if f == Family::Aging {
                        out.notes.extend(once.drift_note.take());
                    }
                    if let Some(Term::Warmup { tau_s, .. }) = decay.map(|d| d.term) {
                        out.notes.push(format!(
                            "warmup's decay from power-on came out at the slowest τ a \
                             warm-up of the library has ({tau_s:.0} s): slower than any \
                             warm-up, it is a monotone trend over the record, and aging \
                             (ΔBIC {dbic:.1}, significant too) names it"
                        ));
                    }
                    out.finding = Some(fit);
                }
            }
        }
        Ok(p_slow)
    }

    /// For a fit `fit` whose term alone lowers no held-out error: the most significant family
    /// among `best` (in their order), significant on its own, beside whose term (refined from
    /// its best point) it does, the other's term lowering the held-out error beside it too.
    /// *Why a pair:* the held-out check adds one term at a time, and a second effect left
    /// out of the model (a drift beside a loop) can make the first's prediction of held-out
    /// chunks worse, not better; the pair is what the record supports, and the next pass,
    /// with this term in the model, asks for the other. *Why not the pair of largest gain:*
    /// a slow lag at the end of its grid takes a drift about as well as the drift's own
    /// family; the record's ranking is the better guide to which effect stands beside. The
    /// warm-up (whose held-out check has folds of its own) and the noise scale are not
    /// weighed this way.
    fn gain_beside(
        &self,
        fit: &Fitted,
        best: &[(Family, usize)],
    ) -> Result<Option<Beside>, DiagnoseError> {
        let no_pair = |f: Family| matches!(f, Family::Warmup | Family::Heteroscedastic);
        if no_pair(fit.family) {
            return Ok(None);
        }
        let (prep, model) = (self.base.prep, self.base.model);
        for &(g, j) in best {
            let p_alone = self.sig.alone_p(g, self.scanned.scan.dbic[j]);
            if g == fit.family || no_pair(g) || p_alone > self.opts.alpha {
                continue;
            }
            let (other, _) = refine(self.base, self.scanned, j)?;
            let mut with_other = model.clone();
            with_other.terms.push(other);
            let rss_other = heldout_metrics(prep, &with_other, None)?.rss_b;
            let rss_both = heldout_metrics(prep, &with_other, Some(&fit.term))?.rss_b;
            let (gain, gain_other) = (rss_other - rss_both, fit.heldout.rss_b - rss_both);
            if gain > 0.0 && gain_other > 0.0 {
                return Ok(Some(Beside {
                    family: g,
                    p_alone,
                    gain,
                }));
            }
        }
        Ok(None)
    }

    /// Whether `term` is a warm-up whose τ is at the library's slowest warm-up
    /// ([`WARMUP_TAU_MAX_S`]). At the record's own bound (half the record, on records under
    /// 60 000 s) a decay is only as slow as the record can tell, and stays a warm-up.
    fn unresolved_decay(term: &Term) -> bool {
        matches!(term, Term::Warmup { tau_s, .. } if *tau_s >= WARMUP_TAU_MAX_S * (1.0 - 1e-6))
    }

    /// Whether a periodic `term`'s period is one at which the record's temperature itself
    /// oscillates ([`line_ratio`]); a note in `out` says so.
    fn period_of_temperature(&self, term: &Term, out: &mut Judged) -> bool {
        let prep = self.base.prep;
        let Some((_, nl)) = nonlinear_of(term) else {
            return false;
        };
        let ratio = line_ratio(&prep.t_b, &prep.dtemp_b, nl[0]);
        if ratio <= LINE_RATIO {
            return false;
        }
        out.notes.push(format!(
            "the bias repeats every {:.0} s, a period at which the temperature oscillates too \
             (dT/dt's power there is {ratio:.0} times the median of the periods from half to \
             twice it): a response to temperature as much as a period in time, not attributed \
             to periodic",
            nl[0]
        ));
        true
    }

    /// Whether a significant noise scale goes with temperature: a noise level that a level
    /// in time (a drift, a step, an episode) explains, and to which temperature adds nothing,
    /// is not attributed to temperature (a note in `out` says so and where). On one
    /// temperature cycle the level in time must also explain more than temperature does,
    /// since there the two move together ([`VarianceTest::in_time_not_temperature`]).
    fn noise_scale_with_temperature(&self, out: &mut Judged) -> bool {
        let prep = self.base.prep;
        let Some(v) = self.var else {
            return true;
        };
        let several = cycle_folds(prep).is_some();
        match v.in_time_not_temperature(&prep.t_b, several) {
            Some((dbic, level)) => {
                let shape = level.describe(&prep.t_b);
                out.notes.push(format!(
                    "the 1 Hz noise level {shape}, with time, not with temperature (beside \
                     that level in time, the temperature's quadratic adds ΔBIC {dbic:+.1}): \
                     not attributed to heteroscedastic"
                ));
                false
            }
            None => true,
        }
    }

    /// The p-value of point `i` of `f` (or of the single step preferred to it) under the
    /// record's noise refitted with rate random walk, a non-linear parameter (or the step's
    /// time) chosen on every replicate as on the record; `None` where REML puts no rate
    /// random walk in.
    fn p_under_slow_noise(
        &self,
        f: Family,
        i: usize,
        step: Option<&Step>,
        once: &mut OncePerPass,
    ) -> Result<Option<f64>, DiagnoseError> {
        let g1 = once.slow_noise.get_or_insert_with(|| {
            self.base
                .reml_noise(true)
                .filter(|g| g.rrw_dph_per_rt_h > 0.0)
        });
        let Some(g1) = g1.clone() else {
            return Ok(None);
        };
        let g1 = &g1;
        let draws = Draws {
            reps: self.opts.bootstrap,
            seed: self.opts.seed,
        };
        let record = self.base.block_record();
        Ok(match step {
            Some(st) => step_p_under_rrw(
                &record,
                g1,
                st.block,
                &step_times(self.base.prep.nb(), STEP_TIMES),
                &draws,
            ),
            None => {
                let cols_of = |f: Family, nl: &[f64]| {
                    self.cache
                        .get_or_build(f, nl, || self.base.candidate_blocks(f, nl))
                };
                let nl = &self.scanned.points[i].nl;
                let record_s = self.base.prep.nb() as f64 * self.base.block_s();
                let slow_points = |of: &dyn Fn(Family) -> bool| {
                    self.scanned
                        .points
                        .iter()
                        .filter(|p| of(p.family) && slow_time_only(p.family, &p.nl, record_s))
                        .map(|p| cols_of(p.family, &p.nl).map(|c| c.to_vec()))
                        .collect::<Result<Vec<_>, _>>()
                };
                if f.is_thermal() {
                    // Every point of the family, its parameter chosen on each replicate; a
                    // thermal effect may stand beside slow noise, so the test is nested.
                    let shapes = self
                        .scanned
                        .points
                        .iter()
                        .filter(|p| p.family == f)
                        .map(|p| cols_of(f, &p.nl).map(|c| c.to_vec()))
                        .collect::<Result<Vec<_>, _>>()?;
                    best_p_beside_rrw(&record, g1, &shapes, &draws)
                } else if f == Family::Aging {
                    let p_line = p_under_rrw(&record, &cols_of(f, nl)?, g1, &draws);
                    match p_line {
                        Some(p) if p > self.opts.alpha => {
                            // The drift may beat the slow noise as a decay where the line does
                            // not (an aging that slows, like a logarithm or a square root):
                            // where the record ranks the line before every decay, the decay's
                            // own test, at its best point as when it is weighed, is the
                            // drift's evidence, and aging names it.
                            let dbic = &self.scanned.scan.dbic;
                            let decay = self
                                .scanned
                                .points
                                .iter()
                                .enumerate()
                                .filter(|(_, q)| q.family == Family::Warmup)
                                .min_by(|a, b| dbic[a.0].total_cmp(&dbic[b.0]));
                            let q = match decay {
                                Some((w, q)) if dbic[w] > dbic[i] => best_p_under_rrw(
                                    &record,
                                    g1,
                                    &cols_of(Family::Warmup, &q.nl)?,
                                    &slow_points(&|g| g == Family::Warmup)?,
                                    &draws,
                                ),
                                _ => None,
                            };
                            match q {
                                Some(q) if q <= self.opts.alpha => {
                                    once.drift_note = Some(format!(
                                        "aging's straight line alone does not beat the \
                                         record's noise refitted with rate random walk \
                                         (p = {p:.3}), but a decay from power-on does \
                                         (p = {q:.3}, its τ chosen on every replicate \
                                         alike): the drift is real, and aging, ranked before \
                                         warmup, names it"
                                    ));
                                    Some(q)
                                }
                                _ => Some(p),
                            }
                        }
                        p => p,
                    }
                } else if nl.is_empty() {
                    p_under_rrw(&record, &cols_of(f, nl)?, g1, &draws)
                } else {
                    // The parameter (a warm-up's τ, a slow period) was chosen on the record:
                    // it is chosen on every replicate too, among the family's slow points.
                    let shapes = slow_points(&|g| g == f)?;
                    best_p_under_rrw(&record, g1, &cols_of(f, nl)?, &shapes, &draws)
                }
            }
        })
    }
}

impl Judged {
    /// Where nothing was found: the notes on significant structure that could not be
    /// attributed (not separable from the record's slow noise, or not beating it).
    pub(super) fn unattributed_notes(&self) -> Vec<String> {
        let mut notes = Vec::new();
        if self.finding.is_some() {
            return notes;
        }
        if !self.untestable.is_empty() {
            let names: Vec<&str> = self.untestable.iter().map(|f| f.name()).collect();
            notes.push(format!(
                "significant under the fitted noise model but not separable from the record's own \
                 slow noise (the model fails its Allan check, and {} {} no cycle-by-cycle \
                 evidence): slow drift, not attributed to a mechanism in a record this long",
                names.join(", "),
                if names.len() == 1 { "has" } else { "have" }
            ));
        }
        notes.extend(self.slow_drift.iter().map(SlowDrift::note));
        notes.extend(self.unconfirmed.iter().map(Unconfirmed::note));
        notes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The note on a significant family left unnamed gives its p-value and the check it
    /// failed: the cycle-by-cycle gain where that is what failed, else the held-out gain.
    #[test]
    fn an_unnamed_significant_family_says_which_check_it_failed() {
        let held_out = Unconfirmed {
            family: Family::Hysteresis,
            p_value: 0.005,
            gain: -1.4e-3,
            cycle_gain: None,
        }
        .note();
        assert!(held_out.starts_with("hysteresis fits"), "{held_out}");
        assert!(held_out.contains("p = 0.005"), "{held_out}");
        assert!(
            held_out.contains("held-out error (gain -1.40e-3"),
            "{held_out}"
        );
        let cycles = Unconfirmed {
            family: Family::GradientLag,
            p_value: 0.002,
            gain: 3.0e-4,
            cycle_gain: Some(-2.0e-5),
        }
        .note();
        assert!(cycles.contains("other temperature cycles"), "{cycles}");
        assert!(cycles.contains("-2.00e-5"), "{cycles}");
        assert!(!cycles.contains("held-out"), "{cycles}");
    }
}
