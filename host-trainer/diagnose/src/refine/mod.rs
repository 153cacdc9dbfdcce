//! Refinement of the best grid point of a family into a fitted term with 1σ uncertainties.
//!
//! The grid point is refined by parabolic interpolation of the fit gain along its main
//! non-linear parameter (a mode hop on a finer grid in its two, [`mode_hop`]; a node's lag
//! on its own profile, [`local::refine_node_lag`]); `sensor_lag` by an exact refit of the
//! baseline driven by the un-lagged temperature. The uncertainties: the amplitude's from
//! the whitened least squares, a non-linear parameter's from the profile of the sum of
//! squares (the range where it rises by less than σ², i.e. Δχ² ≤ 1).

mod local;
mod mode_hop;

use std::collections::BTreeMap;

use rayon::prelude::*;

use crate::baseline::Baseline;
use crate::candidates::{node_lag, Family};
use crate::linalg::{added_fit, dot, Basis};
use crate::minimise::{argmin, parabolic};
use crate::scan::Scanned;
use crate::DiagnoseError;
use local::{half_range, pattern_search, refine_node_lag, Axes, Current, Fit, FitAt};
use rlg_physics::Term;

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

/// Refines the scan's point `i` (the best point of its family) beside the fit `base` and
/// returns the fitted term with 1σ uncertainties (see the module doc).
pub(super) fn refine(
    base: &Baseline<'_>,
    scanned: &Scanned<'_>,
    i: usize,
) -> Result<(Term, BTreeMap<String, f64>), DiagnoseError> {
    let (s, points) = (scanned.scan, scanned.points);
    let f = points[i].family;
    // The family's points at the best point's node lag: the profiles of the other parameters
    // are taken there, and the lag is then refined on its own (`refine_node_lag`).
    let lag = node_lag(f, &points[i].nl);
    let family = Profile {
        f,
        scanned,
        idx: (0..points.len())
            .filter(|&j| points[j].family == f && node_lag(f, &points[j].nl) == lag)
            .collect(),
        sigma2: (s.rss0 - s.drss[i])
            / (s.n as f64 - s.basis.q.len() as f64 - f.n_params() as f64).max(1.0),
    };
    match f {
        Family::TempQuantization => {
            // Not scanned: the quantum read from the recorded values, to the CSV's 1e-4 °C.
            let unc = BTreeMap::from([("step_c".to_string(), 0.5e-4)]);
            Ok((
                Term::TempQuantization {
                    step_c: points[i].nl[0],
                },
                unc,
            ))
        }
        Family::SensorLag => family.sensor_lag(base),
        _ => family.term(base, i, lag != 0.0),
    }
}

/// A family's grid at the best point's node lag, and the scale of its profiles.
struct Profile<'a> {
    /// The family.
    f: Family,
    /// The scan of the grid.
    scanned: &'a Scanned<'a>,
    /// The family's points at the best point's node lag.
    idx: Vec<usize>,
    /// The residual variance of the best point's fit: a profile's Δχ² ≤ 1 region is where
    /// the sum of squares rises by less than this.
    sigma2: f64,
}

impl Profile<'_> {
    /// Exact profile of a sensor lag: the whitened RSS of the baseline refitted on each
    /// un-lagged drive.
    fn sensor_lag(
        &self,
        base: &Baseline<'_>,
    ) -> Result<(Term, BTreeMap<String, f64>), DiagnoseError> {
        let (prep, ar, points) = (base.prep, self.scanned.whitener, self.scanned.points);
        let mut unc = BTreeMap::new();
        let taus: Vec<f64> = self.idx.iter().map(|&j| points[j].nl[0]).collect();
        let rss: Vec<f64> = taus
            .par_iter()
            .map(|&tau| {
                let d = prep.drive_unlagged(tau)?;
                let cols: Vec<Vec<f64>> = prep
                    .baseline_blocks(base.model, &d)
                    .iter()
                    .map(|c| ar.whiten(c))
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
            .filter(|&j| rss[j] - rss[k] <= self.sigma2)
            .map(|j| taus[j])
            .collect();
        unc.insert("tau_s".into(), half_range(&inside, &taus, k));
        Ok((Term::SensorLag { tau_s: tau }, unc))
    }

    /// A term of the bias refined from the scan's point `i` (on a lagging or leading node
    /// where `lagged`): its non-linear parameters, then the amplitude's uncertainty.
    fn term(
        &self,
        base: &Baseline<'_>,
        i: usize,
        lagged: bool,
    ) -> Result<(Term, BTreeMap<String, f64>), DiagnoseError> {
        let (s, ar, f) = (self.scanned.scan, self.scanned.whitener, self.f);
        let prep = base.prep;
        let mut unc = BTreeMap::new();
        let mut nl = self.scanned.points[i].nl.clone();
        let mut coef = s.coef[i].clone();
        let mut cp = s.cperp[i].clone();
        let yw = s.basis.residual(&ar.whiten(&prep.y_b));
        // The whitened fit gain, coefficients and baseline-orthogonal columns at `p`.
        let fit_at = |p: &[f64]| -> Result<Fit, DiagnoseError> {
            let cpr: Vec<Vec<f64>> = base
                .candidate_columns(f, p)?
                .iter()
                .map(|c| s.basis.residual(&ar.whiten(&prep.blocks(c))))
                .collect();
            let (d, a) = added_fit(&cpr, &yw);
            Ok((d, a, cpr))
        };
        let mut fit = Current {
            nl: &mut nl,
            d: s.drss[i],
            coef: &mut coef,
            cp: &mut cp,
        };
        if lagged {
            // The scan steps a lagged node every |τ|/200 samples (`strided_blocks`): the
            // point is refitted at every sample, so that it is compared below with fits of
            // its own kind and its coefficients are not the stepped node's.
            fit.set(fit_at(fit.nl)?);
        }
        if matches!(f, Family::ModeHop) {
            mode_hop::refine(self, &fit_at, lagged, &mut fit, &mut unc)?;
        } else if !fit.nl.is_empty() {
            self.main_parameter(&fit_at, i, lagged, &mut fit, &mut unc)?;
        }
        if let Some(name) = amp_name(f) {
            unc.insert(name.to_string(), amplitude_sd(self.sigma2, &cp, &coef));
        }
        Ok((f.term(&nl, &coef, prep.full_drive.t_s[0]), unc))
    }

    /// The main non-linear parameter of a one-parameter family refined by parabolic
    /// interpolation of the grid's fit gains (a period uniformly in frequency, the others in
    /// its logarithm), with its Δχ² ≤ 1 range on the grid; on a lagging or leading node the
    /// lag and that parameter then searched together, and the lag's own profile taken.
    fn main_parameter(
        &self,
        fit_at: &FitAt<'_>,
        i: usize,
        lagged: bool,
        fit: &mut Current<'_>,
        unc: &mut BTreeMap<String, f64>,
    ) -> Result<(), DiagnoseError> {
        let (s, points, f) = (self.scanned.scan, self.scanned.points, self.f);
        let vals: Vec<f64> = self.idx.iter().map(|&j| points[j].nl[0]).collect();
        let gains: Vec<f64> = self.idx.iter().map(|&j| s.drss[j]).collect();
        let k = self.idx.iter().position(|&j| j == i).unwrap_or(0);
        let periodic = f == Family::Periodic;
        let u: Vec<f64> = vals
            .iter()
            .map(|v| if periodic { 1.0 / v } else { v.ln() })
            .collect();
        let ur = parabolic(&u, &gains, k);
        let mut cand = fit.nl.to_vec();
        cand[0] = if periodic { 1.0 / ur } else { ur.exp() };
        let r = fit_at(&cand)?;
        fit.take(&cand, &r);
        let inside: Vec<f64> = (0..vals.len())
            .filter(|&j| s.drss[i] - gains[j] <= self.sigma2)
            .map(|j| vals[j])
            .collect();
        unc.insert(nl_names(f)[0].to_string(), half_range(&inside, &vals, k));
        if f.has_node_lag() && lagged {
            // The lag and the main parameter together (a play's width and a ripple's
            // period trade against the lag as the mode hop's hysteresis does), then the
            // lag's own profile for its 1σ.
            let start = fit.nl.to_vec();
            let axes = Axes {
                steps: &[1.0 / 8.0, 1.0 / 8.0],
                log: &[true, true],
                min: &[f64::NEG_INFINITY; 2],
            };
            let (p, d) = pattern_search(fit_at, &start, fit.d, &axes)?;
            if d > fit.d {
                let r = fit_at(&p)?;
                fit.take(&p, &r);
            }
            refine_node_lag(f, fit_at, self.sigma2, fit, unc)?;
        }
        Ok(())
    }
}

/// The 1σ of a term's amplitude from the whitened joint fit (Frisch–Waugh: the candidate's
/// columns `cp` orthogonal to the baseline carry its covariance σ²·(CᵀC)⁻¹); for a pair of
/// columns (a sine and a cosine) the amplitude's along the fitted direction of `coef`.
fn amplitude_sd(sigma2: f64, cp: &[Vec<f64>], coef: &[f64]) -> f64 {
    let sigma = sigma2.sqrt();
    match cp.len() {
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
    }
}
