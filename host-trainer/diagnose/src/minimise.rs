//! The one-dimensional searches the fits share: the best point of a grid, refined either by
//! the vertex of the parabola through it and its neighbours, or by golden section between
//! them. A bracket of one parameter needs no optimisation crate; each is a few lines.

/// Index of the largest value (the last of equals; `None` for no values).
pub(crate) fn argmax(x: &[f64]) -> Option<usize> {
    (0..x.len()).max_by(|&a, &b| x[a].total_cmp(&x[b]))
}

/// Index of the smallest value (the first of equals; `None` for no values).
pub(crate) fn argmin(x: &[f64]) -> Option<usize> {
    (0..x.len()).min_by(|&a, &b| x[a].total_cmp(&x[b]))
}

/// Parabolic refinement of a maximum at grid index `i` of `f(u)` on any grid: the vertex of
/// the parabola through `i` and its two neighbours, kept between them; `u[i]` at either end
/// of the grid or where the three points are collinear.
pub(crate) fn parabolic(u: &[f64], f: &[f64], i: usize) -> f64 {
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

/// Vertex of the parabola through `f` at `x` − `step`, `x`, `x` + `step` of an evenly
/// spaced grid, for a minimum (`x` itself where `f` is not convex there). Unlike
/// [`parabolic`] it is not kept within the neighbours: the REML grid's ends are the
/// caller's to respect.
pub(crate) fn vertex(x: f64, step: f64, f: [f64; 3]) -> f64 {
    let den = f[0] - 2.0 * f[1] + f[2];
    if den > 0.0 {
        x + 0.5 * step * (f[0] - f[2]) / den
    } else {
        x
    }
}

/// The minimum of `f` over `grid`, refined by `iters` steps of golden-section search between
/// the best grid point's neighbours: (x, f(x)), the grid point if the refinement is no better.
pub(crate) fn grid_then_golden(grid: &[f64], iters: usize, f: impl Fn(f64) -> f64) -> (f64, f64) {
    let vals: Vec<f64> = grid.iter().map(|x| f(*x)).collect();
    let i = (0..grid.len())
        .min_by(|&p, &q| vals[p].total_cmp(&vals[q]))
        .unwrap_or(0);
    let (mut x0, mut x1) = (grid[i.saturating_sub(1)], grid[(i + 1).min(grid.len() - 1)]);
    let phi = 0.5 * (5.0f64.sqrt() - 1.0);
    for _ in 0..iters {
        let (c, d) = (x1 - phi * (x1 - x0), x0 + phi * (x1 - x0));
        if f(c) < f(d) {
            x1 = d;
        } else {
            x0 = c;
        }
    }
    let x = 0.5 * (x0 + x1);
    let fx = f(x);
    if fx <= vals[i] {
        (x, fx)
    } else {
        (grid[i], vals[i])
    }
}
