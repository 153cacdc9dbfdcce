//! Refinement of the best grid point of a family into a fitted term with 1σ uncertainties.

use std::collections::BTreeMap;

use rayon::prelude::*;

use super::candidates::Family;
use super::linalg::{added_fit, dot, Basis};
use super::noise::Whitener;
use super::prepare::{DriveSeries, PhysicsModel, Prepared};
use super::scan::{Point, Scan};
use super::DiagnoseError;
use rlg_physics::Term;

/// Parabolic refinement of a maximum at grid index `i` of `f(u)`; returns u.
pub(super) fn parabolic(u: &[f64], f: &[f64], i: usize) -> f64 {
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
pub(super) fn nl_names(f: Family) -> &'static [&'static str] {
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
pub(super) fn amp_name(f: Family) -> Option<&'static str> {
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

pub(super) fn argmin(x: &[f64]) -> Option<usize> {
    (0..x.len()).min_by(|&a, &b| x[a].total_cmp(&x[b]))
}

/// Refines the best grid point of family `f` (parabolic interpolation of the fit gain along
/// its main non-linear parameter; for `sensor_lag` an exact refit of the baseline driven by
/// the un-lagged temperature) and returns the fitted term with 1σ uncertainties: the
/// amplitude's from the whitened least squares, the non-linear parameter's from the profile
/// of the sum of squares (the range where it rises by less than σ², i.e. Δχ² ≤ 1).
#[allow(clippy::too_many_arguments)]
pub(super) fn refine(
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
                let cols: Vec<Vec<f64>> = prep
                    .baseline_blocks(model, &d)
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
        // 0, 0.5, 1, 2, 4 °C) the step is up to 42 % off at ten times the benchmark's
        // detectability (measured).
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

pub(super) fn minmax(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        })
}

pub(super) fn grid_step(all: &[f64], at: f64) -> f64 {
    all.iter()
        .map(|v| (v - at).abs())
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min)
        .min(at.abs().max(1e-12))
}

/// Half the range of the grid values inside the Δχ² ≤ 1 region, at least half a grid step.
pub(super) fn half_range(inside: &[f64], all: &[f64], k: usize) -> f64 {
    let (lo, hi) = minmax(inside);
    let step = grid_step(all, all[k]);
    if inside.is_empty() {
        return 0.5 * step;
    }
    (0.5 * (hi - lo)).max(0.5 * step)
}
