//! Slow functions of time against the record's own slow noise: over one record a rate
//! random walk or a 1/f-like wander of correlation times of days is a drift, and the Allan
//! check, on the few independent long-τ clusters a record holds, does not reject white + B
//! for it. A slow time-only finding, a thermal one that does not recur cycle by cycle, and
//! the generic structure test must therefore also be significant under the record's noise
//! refitted with rate random walk.

use crate::bootstrap::bootstrap;
use crate::candidates::Family;
use crate::noise::covariance::block_mean_cov;
use crate::noise::reml::reml_noise;
use crate::noise::whiten::{GlsWhitener, Whitener, GLS_MAX_BLOCKS};
use crate::prepare::Prepared;
use crate::scan::{scan, Generic, Scan, Scanned};
use crate::Options;
use rlg_simulate::noise::NoiseParams;

/// A periodic term counts as slow (a function of time the record's own slow noise can
/// mimic) when its period is at least this share of the record; shorter periods recur
/// often enough within it to be told from a wander.
pub(super) const SLOW_PERIOD_OF_RECORD: f64 = 1.0 / 8.0;

/// Whether the point `nl` of `f` is a slow function of time alone: aging, warm-up, or a
/// period of at least [`SLOW_PERIOD_OF_RECORD`] of the record. Such a finding under white
/// noise and bias instability must also be significant under the record's noise refitted
/// with rate random walk ([`crate::ramp::p_under_rrw`]; see the module doc). Without it,
/// slow wander on clean records is flagged as aging or a long period at every α. Warm-up
/// is among them because, left out, it takes the place of an aging that fails the check
/// (the start of a drift fits a decay from power-on).
pub(super) fn slow_time_only(f: Family, nl: &[f64], record_s: f64) -> bool {
    match f {
        Family::Aging | Family::Warmup => true,
        Family::Periodic => nl
            .first()
            .is_some_and(|p| *p >= record_s * SLOW_PERIOD_OF_RECORD),
        _ => false,
    }
}

/// A slow function of time significant under white noise and bias instability but not
/// under the record's noise refitted with rate random walk.
pub(super) struct SlowDrift {
    /// What it is: the family's name, or "a single step".
    pub(super) shape: &'static str,
    /// Its p-value under rate random walk.
    pub(super) p_value: f64,
    /// The noise refitted with rate random walk.
    pub(super) noise: Option<NoiseParams>,
}

impl SlowDrift {
    /// The evidence's note on it.
    pub(super) fn note(&self) -> String {
        let (shape, p) = (self.shape, self.p_value);
        format!(
            "{shape} is significant under white noise and bias instability but not under the \
             record's noise refitted with rate random walk (K = {:.2e} °/h/√h; the \
             record's likelihood ratio has probability {p:.3} there): slow drift, not \
             separable from the record's own slow noise in a record this long",
            self.noise.as_ref().map_or(f64::NAN, |g| g.rrw_dph_per_rt_h),
        )
    }
}

/// The generic test's second null is computed only when its first p-value is at most this
/// (a larger one decides nothing at the α the diagnosis is run at, ≤ 10 %).
pub(super) const STRUCTURE_RRW_BELOW: f64 = 0.2;

/// The generic structure test's p-value under the record's noise refitted by REML with rate
/// random walk allowed, its own GLS whitening and bootstrap (`None` when REML puts no rate
/// random walk in, or the record is too long for the GLS factor). Twelve time chunks are
/// among the generic columns, and over one record a drift of rate random walk or of
/// 1/f-like wander fills them as a step would: under white noise and bias instability
/// alone such a drift passed as structure. The structure test needs both p-values at α.
///
/// The noise is refitted beside `best`, the columns of the generic alternative that fits
/// the record best: fitted on the baseline residual alone, K took the structure under test
/// as wander (a transient of 30 min at 4σ of a 100 s mean raised K until the test under it
/// had p 0.24), and no structure could then be told from slow noise. The bootstrap still
/// takes the best of every alternative under that noise, so choosing `best` on the record is
/// charged; what is not is the little of the noise's own wander `best` takes from K's fit.
pub(super) fn structure_under_rrw(
    prep: &Prepared,
    base_b: &[Vec<f64>],
    best: Vec<Vec<f64>>,
    generic: &Generic,
    white_level: Option<&[f64]>,
    opts: &Options,
) -> Option<f64> {
    structure_beside(prep, base_b, best, generic, white_level, opts, true).map(|r| r.p_value)
}

/// The generic structure test asked again under a refitted noise.
pub(super) struct Refit {
    /// Its p-value under its own bootstrap.
    pub(super) p_value: f64,
    /// The scan in the refit's whitening: its best alternative is the one that p-value
    /// tests, so it is the shape reported.
    pub(super) scan: Scan,
}

/// The generic structure test's p-value under the record's noise refitted by REML beside
/// `best`, the columns of one alternative, with rate random walk allowed where `with_rrw`
/// (`None` where the record is too long for the GLS factor, or `with_rrw` and REML puts no
/// rate random walk in), on its own GLS whitening and bootstrap (its replicates' white noise
/// at `white_level` where the record's level changes in time).
///
/// The pass's noise is fitted under the null, to the baseline residual: a step or a transient
/// of an hour or two in the bias is then partly taken as noise (bias instability raised, or
/// rate random walk added where the Allan check fails), and the replicates drawn from that
/// noise wander as the record does. On the independent generator's records, steps,
/// transients in time and telegraph switching well above the detection limit were
/// `consistent` that way; the noise refitted beside the best step or window in time is the
/// noise without them. The bootstrap still takes the best of every alternative; what is not
/// charged is the share of the noise's own wander the one alternative takes from the refit
/// (measured on the clean recordings, `rlg benchmark-diagnose --set mismatched`). Piecewise
/// chunks are never put beside the refit: 22 columns would take most of the noise's slow
/// part.
pub(super) fn structure_beside(
    prep: &Prepared,
    base_b: &[Vec<f64>],
    best: Vec<Vec<f64>>,
    generic: &Generic,
    white_level: Option<&[f64]>,
    opts: &Options,
    with_rrw: bool,
) -> Option<Refit> {
    let g = noise_beside(prep, base_b, best, with_rrw)?;
    structure_under(prep, base_b, &g, generic, white_level, opts)
}

/// The record's noise refitted by REML beside `best`, the columns of one alternative, with
/// rate random walk allowed where `with_rrw` (`None` where the record is too long for the GLS
/// factor, or `with_rrw` and REML puts no rate random walk in).
pub(super) fn noise_beside(
    prep: &Prepared,
    base_b: &[Vec<f64>],
    best: Vec<Vec<f64>>,
    with_rrw: bool,
) -> Option<NoiseParams> {
    if prep.nb() > GLS_MAX_BLOCKS {
        return None;
    }
    let beside: Vec<Vec<f64>> = base_b.iter().cloned().chain(best).collect();
    let g = reml_noise(&beside, &prep.y_b, prep.block, prep.dt_s, with_rrw)?;
    (!with_rrw || g.rrw_dph_per_rt_h > 0.0).then_some(g)
}

/// The generic structure test's p-value under the noise `g`, on its own GLS whitening and
/// bootstrap (its replicates' white noise at `white_level` where the record's level changes
/// in time).
pub(super) fn structure_under(
    prep: &Prepared,
    base_b: &[Vec<f64>],
    g: &NoiseParams,
    generic: &Generic,
    white_level: Option<&[f64]>,
    opts: &Options,
) -> Option<Refit> {
    let w = Whitener::Gls(GlsWhitener::from_cov(block_mean_cov(
        g,
        prep.nb(),
        prep.block,
        prep.dt_s,
    ))?);
    let s = scan(&w, base_b, &prep.y_b, &[], generic);
    let scanned = Scanned {
        whitener: &w,
        scan: &s,
        points: &[],
    };
    let nulls = bootstrap(&scanned, g, white_level, None, prep, opts);
    Some(Refit {
        p_value: nulls.structure.p_value(s.gen_dbic),
        scan: s,
    })
}
