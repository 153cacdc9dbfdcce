//! A mode hop's two switching parameters refined on a fine local grid, and on a lagging or
//! leading node its lag with them.
//!
//! 2-D grid: a fine local grid around the best coarse point (temperature ±1 coarse step in
//! sixths, switching hysteresis 0…4.5 °C in 0.25 °C), then the profile of each axis over the
//! coarse and fine points. On the coarse grid alone (hysteresis 0, 0.5, 1, 2, 4 °C) the
//! step is far off at high signal-to-noise. A node's lag moves both switching temperatures
//! by τ·dT/dt, which a wider hysteresis and another temperature mimic where the rates are
//! alike: a lagged hop is first searched in all three together, then the fine grid and the
//! lag's own profile are taken in turn (at most three passes) until the lag stays.

use std::collections::BTreeMap;

use rayon::prelude::*;

use super::local::{grid_step, minmax, pattern_search, refine_node_lag, Axes, Current, Fit, FitAt};
use super::{nl_names, Profile};
use crate::DiagnoseError;

/// Refines the mode hop at `fit` (see the module doc) and records the 1σ of its switching
/// temperature and hysteresis (and of its lag, where `lagged`) in `unc`.
pub(super) fn refine(
    family: &Profile<'_>,
    fit_at: &FitAt<'_>,
    lagged: bool,
    fit: &mut Current<'_>,
    unc: &mut BTreeMap<String, f64>,
) -> Result<(), DiagnoseError> {
    let points = family.scanned.points;
    let all_t: Vec<f64> = family.idx.iter().map(|&j| points[j].nl[0]).collect();
    let dt = grid_step(&all_t, fit.nl[0]);
    let mut last: Option<(Vec<Vec<f64>>, Vec<Fit>)> = None;
    for pass in 0..3 {
        if lagged && pass == 0 {
            joint_search(fit_at, dt, fit)?;
        } else if lagged {
            if !refine_node_lag(family.f, fit_at, family.sigma2, fit, unc)? {
                break;
            }
        } else if pass > 0 {
            break;
        }
        last = Some(fine_grid(fit_at, dt, fit)?);
    }
    let (fine, res) = last.unwrap_or_default();
    switching_intervals(family, dt, fit, (&fine, &res), unc);
    Ok(())
}

/// A joint grid of lag (±¾ octave in eighths), temperature (±3 coarse steps of `dt` in
/// halves) and hysteresis (0…4 °C), then a pattern search from its three best points: at
/// 1 °C/min a lag of 1 200 s puts the node 20 °C behind, and from the octave grid's nearest
/// lag the lag alone, the temperature and hysteresis held, does not move (the step, the
/// hysteresis and the temperature then all come out far off). The gain's peak is narrow at
/// high signal-to-noise (a lag 8 % off loses most of it), hence the pattern search.
fn joint_search(fit_at: &FitAt<'_>, dt: f64, fit: &mut Current<'_>) -> Result<(), DiagnoseError> {
    let (t0, lag0) = (fit.nl[0], fit.nl[2]);
    let joint: Vec<Vec<f64>> = (-6..=6)
        .flat_map(|k| {
            let l = lag0 * 2f64.powf(f64::from(k) / 8.0);
            (-6..=6).flat_map(move |a| {
                [0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0]
                    .map(move |h| vec![t0 + dt * f64::from(a) / 2.0, h, l])
            })
        })
        .collect();
    // Gains only: every point's columns held at once would be the grid's size.
    let gains: Vec<f64> = joint
        .par_iter()
        .map(|p| fit_at(p).map(|r| r.0))
        .collect::<Result<_, DiagnoseError>>()?;
    let mut order: Vec<usize> = (0..gains.len()).collect();
    order.sort_by(|&a, &b| gains[b].total_cmp(&gains[a]));
    let axes = Axes {
        steps: &[dt / 3.0, 0.5, 1.0 / 8.0],
        log: &[false, false, true],
        min: &[f64::NEG_INFINITY, 0.0, f64::NEG_INFINITY],
    };
    for &k in order.iter().take(3) {
        let (p, d) = pattern_search(fit_at, &joint[k], gains[k], &axes)?;
        if d > fit.d {
            let r = fit_at(&p)?;
            fit.take(&p, &r);
        }
    }
    Ok(())
}

/// The fine grid around the current point (temperature ±1 coarse step `dt` in sixths,
/// hysteresis 0…4.5 °C in 0.25 °C, the lag held); moves the point to its best. Returns the
/// grid and its fits.
fn fine_grid(
    fit_at: &FitAt<'_>,
    dt: f64,
    fit: &mut Current<'_>,
) -> Result<(Vec<Vec<f64>>, Vec<Fit>), DiagnoseError> {
    let (t0, node) = (fit.nl[0], fit.nl[2]);
    let fine: Vec<Vec<f64>> = (-6..=6)
        .flat_map(|a| {
            (0..=18).map(move |b| vec![t0 + dt * f64::from(a) / 6.0, 0.25 * f64::from(b), node])
        })
        .collect();
    let res: Vec<Fit> = fine
        .par_iter()
        .map(|p| fit_at(p))
        .collect::<Result<_, DiagnoseError>>()?;
    if let Some(k) = (0..res.len()).max_by(|&a, &b| res[a].0.total_cmp(&res[b].0)) {
        fit.take(&fine[k], &res[k]);
    }
    Ok((fine, res))
}

/// The 1σ of the switching temperature and hysteresis: half the range of the coarse points
/// at the refined lag and the last fine grid's points within Δχ² ≤ 1 of the best fit, at
/// least half the fine grid's step.
fn switching_intervals(
    family: &Profile<'_>,
    dt: f64,
    fit: &Current<'_>,
    (fine, res): (&[Vec<f64>], &[Fit]),
    unc: &mut BTreeMap<String, f64>,
) {
    let (points, drss) = (family.scanned.points, &family.scanned.scan.drss);
    let node = fit.nl[2];
    let best_d = fit.d;
    // The coarse points count where they share the refined lag.
    let inside: Vec<&[f64]> = family
        .idx
        .iter()
        .filter(|&&j| points[j].nl[2] == node && best_d - drss[j] <= family.sigma2)
        .map(|&j| &points[j].nl[..])
        .chain(
            fine.iter()
                .zip(res)
                .filter(|(_, r)| best_d - r.0 <= family.sigma2)
                .map(|(p, _)| &p[..]),
        )
        .collect();
    for (a, name) in nl_names(family.f).iter().enumerate() {
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
}
