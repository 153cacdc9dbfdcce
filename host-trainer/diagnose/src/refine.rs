//! Refinement of the best grid point of a family into a fitted term with 1σ uncertainties.

use std::collections::BTreeMap;

use rayon::prelude::*;

use super::candidates::{node_lag, Family};
use super::linalg::{added_fit, dot, Basis};
use super::minimise::{argmax, argmin, parabolic};
use super::noise::Whitener;
use super::prepare::{DriveSeries, PhysicsModel, Prepared};
use super::scan::{Point, Scan};
use super::DiagnoseError;
use rlg_physics::Term;

/// A candidate's whitened fit gain, coefficients and baseline-orthogonal columns.
type Fit = (f64, Vec<f64>, Vec<Vec<f64>>);

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
    // The family's points at the best point's node lag: the profiles of the other parameters
    // are taken there, and the lag is then refined on its own (`refine_node_lag`).
    let lag = node_lag(f, &points[i].nl);
    let idx: Vec<usize> = (0..points.len())
        .filter(|&j| points[j].family == f && node_lag(f, &points[j].nl) == lag)
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
    let yw = s.basis.residual(&ar.whiten(&prep.y_b));
    // The whitened fit gain, coefficients and baseline-orthogonal columns at `p`.
    let fit_at = |p: &[f64]| -> Result<Fit, DiagnoseError> {
        let cpr: Vec<Vec<f64>> = f
            .columns(p, prep, model, mdrive, beta_b)?
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
    let lagged = lag != 0.0;
    if lagged {
        // The scan steps a lagged node every |τ|/200 samples (`strided_blocks`): the point is
        // refitted at every sample, so that it is compared below with fits of its own kind
        // and its coefficients are not the stepped node's.
        let (d, a, c) = fit_at(fit.nl)?;
        fit.d = d;
        *fit.coef = a;
        *fit.cp = c;
    }
    if matches!(f, Family::ModeHop) {
        // 2-D grid: a fine local grid around the best coarse point (temperature ±1 coarse
        // step in sixths, switching hysteresis 0…4.5 °C in 0.25 °C), then the profile of
        // each axis over the coarse and fine points. On the coarse grid alone (hysteresis
        // 0, 0.5, 1, 2, 4 °C) the step is up to 42 % off at ten times the benchmark's
        // detectability (measured). A node's lag moves both switching temperatures by
        // τ·dT/dt, which a wider hysteresis and another temperature mimic where the rates
        // are alike: a lagged hop is first searched in all three together, then the fine
        // grid and the lag's own profile are taken in turn (at most three passes) until the
        // lag stays.
        let all_t: Vec<f64> = idx.iter().map(|&j| points[j].nl[0]).collect();
        let dt = grid_step(&all_t, fit.nl[0]);
        let mut last: Option<(Vec<Vec<f64>>, Vec<Fit>)> = None;
        for pass in 0..3 {
            if lagged && pass == 0 {
                // First a joint grid of lag (±¾ octave in eighths), temperature (±3 coarse
                // steps in halves) and hysteresis (0…4 °C): at 1 °C/min a lag of 1 200 s
                // puts the node 20 °C behind, and from the octave grid's 800 s the lag
                // alone, the temperature and hysteresis held, did not move (measured: the
                // step 27 % low, the hysteresis 3.75 °C for 1.5, the temperature 4.4 °C
                // (3.2 coarse steps) off).
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
                // The gain's peak is narrow at high SNR (a lag 8 % off lost six sevenths of
                // it, measured): a pattern search from the grid's three best points.
                let mut order: Vec<usize> = (0..gains.len()).collect();
                order.sort_by(|&a, &b| gains[b].total_cmp(&gains[a]));
                let steps = [dt / 3.0, 0.5, 1.0 / 8.0];
                let log = [false, false, true];
                let min = [f64::NEG_INFINITY, 0.0, f64::NEG_INFINITY];
                for &k in order.iter().take(3) {
                    let (p, d) = pattern_search(&fit_at, &joint[k], gains[k], &steps, &log, &min)?;
                    if d > fit.d {
                        let r = fit_at(&p)?;
                        fit.take(&p, &r);
                    }
                }
            } else if lagged {
                if !refine_node_lag(f, &fit_at, sigma2, &mut fit, &mut unc)? {
                    break;
                }
            } else if pass > 0 {
                break;
            }
            let (t0, node) = (fit.nl[0], fit.nl[2]);
            let fine: Vec<Vec<f64>> = (-6..=6)
                .flat_map(|a| {
                    (0..=18)
                        .map(move |b| vec![t0 + dt * f64::from(a) / 6.0, 0.25 * f64::from(b), node])
                })
                .collect();
            let res: Vec<Fit> = fine
                .par_iter()
                .map(|p| fit_at(p))
                .collect::<Result<_, DiagnoseError>>()?;
            if let Some(k) = (0..res.len()).max_by(|&a, &b| res[a].0.total_cmp(&res[b].0)) {
                fit.take(&fine[k], &res[k]);
            }
            last = Some((fine, res));
        }
        let node = fit.nl[2];
        let best_d = fit.d;
        let (fine, res) = last.unwrap_or_default();
        // The coarse points count where they share the refined lag.
        let inside: Vec<&[f64]> = idx
            .iter()
            .filter(|&&j| points[j].nl[2] == node && best_d - s.drss[j] <= sigma2)
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
    } else if !fit.nl.is_empty() {
        let vals: Vec<f64> = idx.iter().map(|&j| points[j].nl[0]).collect();
        let gains: Vec<f64> = idx.iter().map(|&j| s.drss[j]).collect();
        let k = idx.iter().position(|&j| j == i).unwrap_or(0);
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
            .filter(|&j| s.drss[i] - gains[j] <= sigma2)
            .map(|j| vals[j])
            .collect();
        unc.insert(nl_names(f)[0].to_string(), half_range(&inside, &vals, k));
        if f.has_node_lag() && lagged {
            // The lag and the main parameter together (a play's width and a ripple's
            // period trade against the lag as the mode hop's hysteresis does), then the
            // lag's own profile for its 1σ.
            let start = fit.nl.to_vec();
            let (p, d) = pattern_search(
                &fit_at,
                &start,
                fit.d,
                &[1.0 / 8.0, 1.0 / 8.0],
                &[true, true],
                &[f64::NEG_INFINITY; 2],
            )?;
            if d > fit.d {
                let r = fit_at(&p)?;
                fit.take(&p, &r);
            }
            refine_node_lag(f, &fit_at, sigma2, &mut fit, &mut unc)?;
        }
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

/// The point being refined: its non-linear parameters, whitened fit gain, coefficients and
/// baseline-orthogonal columns.
struct Current<'a> {
    nl: &'a mut [f64],
    d: f64,
    coef: &'a mut Vec<f64>,
    cp: &'a mut Vec<Vec<f64>>,
}

impl Current<'_> {
    /// Moves to `p` where its fit `r` gains more; returns whether it moved.
    fn take(&mut self, p: &[f64], r: &Fit) -> bool {
        if r.0 <= self.d {
            return false;
        }
        self.nl.copy_from_slice(p);
        self.d = r.0;
        self.coef.clone_from(&r.1);
        self.cp.clone_from(&r.2);
        true
    }
}

/// The profile of the fit gain along non-linear parameter `axis` over `vals`, the others
/// held; moves the point to its best value where that gains more. Returns whether it moved
/// and the profile.
fn refine_axis(
    fit_at: &(dyn Fn(&[f64]) -> Result<Fit, DiagnoseError> + Sync),
    cur: &mut Current<'_>,
    axis: usize,
    vals: &[f64],
) -> Result<(bool, Vec<f64>), DiagnoseError> {
    let points: Vec<Vec<f64>> = vals
        .iter()
        .map(|v| {
            let mut p = cur.nl.to_vec();
            p[axis] = *v;
            p
        })
        .collect();
    let res: Vec<Fit> = points
        .par_iter()
        .map(|p| fit_at(p))
        .collect::<Result<_, DiagnoseError>>()?;
    let gains: Vec<f64> = res.iter().map(|r| r.0).collect();
    let moved = match (0..res.len()).max_by(|&a, &b| gains[a].total_cmp(&gains[b])) {
        Some(k) => cur.take(&points[k], &res[k]),
        None => false,
    };
    Ok((moved, gains))
}

/// A compass search for the largest fit gain from `start` (gain `d0`), moving along every
/// combination of ±1 step on each axis (the diagonals follow a ridge where two parameters
/// trade against each other) and halving the steps where no move gains, six times. An axis
/// marked `log` steps by factors of 2^step; values below an axis' `min` are not tried.
/// Written here because a handful of parameters evaluated in parallel batches is all it
/// needs; none of the project's crates minimises without derivatives. Returns the best point
/// and its gain.
fn pattern_search(
    fit_at: &(dyn Fn(&[f64]) -> Result<Fit, DiagnoseError> + Sync),
    start: &[f64],
    d0: f64,
    steps: &[f64],
    log: &[bool],
    min: &[f64],
) -> Result<(Vec<f64>, f64), DiagnoseError> {
    let n = steps.len();
    let dirs: Vec<Vec<i32>> = (0..3i32.pow(n as u32))
        .map(|c| (0..n).map(|a| (c / 3i32.pow(a as u32)) % 3 - 1).collect())
        .filter(|d: &Vec<i32>| d.iter().any(|&x| x != 0))
        .collect();
    let (mut p, mut d) = (start.to_vec(), d0);
    let mut h = steps.to_vec();
    let mut halvings = 0;
    for _ in 0..60 {
        let cands: Vec<Vec<f64>> = dirs
            .iter()
            .map(|dir| {
                let mut q = p.clone();
                for a in 0..n {
                    let k = f64::from(dir[a]);
                    q[a] = if log[a] {
                        q[a] * 2f64.powf(k * h[a])
                    } else {
                        q[a] + k * h[a]
                    };
                }
                q
            })
            .filter(|q| (0..n).all(|a| q[a] >= min[a]))
            .collect();
        let gains: Vec<f64> = cands
            .par_iter()
            .map(|q| fit_at(q).map(|r| r.0))
            .collect::<Result<_, DiagnoseError>>()?;
        match argmax(&gains).filter(|&k| gains[k] > d) {
            Some(k) => {
                p.clone_from(&cands[k]);
                d = gains[k];
            }
            None if halvings == 6 => break,
            None => {
                h.iter_mut().for_each(|x| *x *= 0.5);
                halvings += 1;
            }
        }
    }
    Ok((p, d))
}

/// The node's lag of a point refined over half an octave either side of its current value
/// (on the scan's octave grid `NODE_LAGS_S`, the midpoints to its neighbours) in eighths of
/// an octave, the other parameters held: where the lag times the rate moves the driving
/// temperature by tens of degrees, an octave's error moves a mode hop's switching by
/// several (measured: misses at p 0.6–0.99 on the coarse grid). Records the lag's 1σ (the
/// Δχ² ≤ 1 range of the profile, at least half a step); returns whether the lag moved.
fn refine_node_lag(
    f: Family,
    fit_at: &(dyn Fn(&[f64]) -> Result<Fit, DiagnoseError> + Sync),
    sigma2: f64,
    cur: &mut Current<'_>,
    unc: &mut BTreeMap<String, f64>,
) -> Result<bool, DiagnoseError> {
    let last = cur.nl.len() - 1;
    let lag = node_lag(f, cur.nl);
    let lags: Vec<f64> = (-4..=4)
        .map(|k| lag * 2f64.powf(f64::from(k) / 8.0))
        .collect();
    let (moved, gains) = refine_axis(fit_at, cur, last, &lags)?;
    let k = lags.iter().position(|l| *l == cur.nl[last]).unwrap_or(4);
    let inside: Vec<f64> = (0..lags.len())
        .filter(|&j| cur.d - gains[j] <= sigma2)
        .map(|j| lags[j])
        .collect();
    unc.insert("node_lag_s".into(), half_range(&inside, &lags, k));
    Ok(moved)
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
