//! The local searches a refinement is made of: the point being refined, a profile along one
//! parameter, a derivative-free compass search, and the Δχ² ≤ 1 interval of a profile.

use std::collections::BTreeMap;

use rayon::prelude::*;

use crate::candidates::{node_lag, Family};
use crate::minimise::argmax;
use crate::DiagnoseError;

/// A candidate's whitened fit gain, coefficients and baseline-orthogonal columns.
pub(super) type Fit = (f64, Vec<f64>, Vec<Vec<f64>>);

/// The fit of a family at given non-linear parameters.
pub(super) type FitAt<'a> = dyn Fn(&[f64]) -> Result<Fit, DiagnoseError> + Sync + 'a;

/// The point being refined: its non-linear parameters, whitened fit gain, coefficients and
/// baseline-orthogonal columns.
pub(super) struct Current<'a> {
    pub(super) nl: &'a mut [f64],
    pub(super) d: f64,
    pub(super) coef: &'a mut Vec<f64>,
    pub(super) cp: &'a mut Vec<Vec<f64>>,
}

impl Current<'_> {
    /// Moves to `p` where its fit `r` gains more; returns whether it moved.
    pub(super) fn take(&mut self, p: &[f64], r: &Fit) -> bool {
        if r.0 <= self.d {
            return false;
        }
        self.nl.copy_from_slice(p);
        self.d = r.0;
        self.coef.clone_from(&r.1);
        self.cp.clone_from(&r.2);
        true
    }

    /// Sets the point's fit at its own parameters, whether it gains or not.
    pub(super) fn set(&mut self, r: Fit) {
        let (d, a, c) = r;
        self.d = d;
        *self.coef = a;
        *self.cp = c;
    }
}

/// The profile of the fit gain along non-linear parameter `axis` over `vals`, the others
/// held; moves the point to its best value where that gains more. Returns whether it moved
/// and the profile.
fn refine_axis(
    fit_at: &FitAt<'_>,
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

/// The axes of a compass search: each one's first step, whether it steps by factors of
/// 2^step instead of adding the step, and the smallest value tried.
pub(super) struct Axes<'a> {
    pub(super) steps: &'a [f64],
    pub(super) log: &'a [bool],
    pub(super) min: &'a [f64],
}

/// A compass search for the largest fit gain from `start` (gain `d0`), moving along every
/// combination of ±1 step on each axis (the diagonals follow a ridge where two parameters
/// trade against each other) and halving the steps where no move gains, six times.
/// Written here because a handful of parameters evaluated in parallel batches is all it
/// needs; none of the project's crates minimises without derivatives. Returns the best point
/// and its gain.
pub(super) fn pattern_search(
    fit_at: &FitAt<'_>,
    start: &[f64],
    d0: f64,
    axes: &Axes<'_>,
) -> Result<(Vec<f64>, f64), DiagnoseError> {
    let n = axes.steps.len();
    let dirs: Vec<Vec<i32>> = (0..3i32.pow(n as u32))
        .map(|c| (0..n).map(|a| (c / 3i32.pow(a as u32)) % 3 - 1).collect())
        .filter(|d: &Vec<i32>| d.iter().any(|&x| x != 0))
        .collect();
    let (mut p, mut d) = (start.to_vec(), d0);
    let mut h = axes.steps.to_vec();
    let mut halvings = 0;
    for _ in 0..60 {
        let cands: Vec<Vec<f64>> = dirs
            .iter()
            .map(|dir| {
                let mut q = p.clone();
                for a in 0..n {
                    let k = f64::from(dir[a]);
                    q[a] = if axes.log[a] {
                        q[a] * 2f64.powf(k * h[a])
                    } else {
                        q[a] + k * h[a]
                    };
                }
                q
            })
            .filter(|q| (0..n).all(|a| q[a] >= axes.min[a]))
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
/// several, and the coarse grid alone misses such hops. Records the lag's 1σ (the Δχ² ≤ 1
/// range of the profile, at least half a step); returns whether the lag moved.
pub(super) fn refine_node_lag(
    f: Family,
    fit_at: &FitAt<'_>,
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

/// The smallest and largest of `v` (infinities for none).
pub(super) fn minmax(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        })
}

/// The grid's spacing at `at`: the distance to its nearest other value, at most |`at`|.
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
