//! Preconditioned conjugate gradients in f64 on H·X = B, one recurrence per column of B,
//! stopped on LAPACK `dsposv`'s backward-error test and checked on the true residual at the
//! end.
//!
//! The recurrence ([`Cg`]) asks for its products with H instead of making them, so that one
//! driver can serve several systems with one pass over a stored matrix: [`pcg`] runs a single
//! system with a product it is given; `mixed::solve_low_rank_shifts` runs the systems
//! K + I/c of several c in lock step, each pass over the packed K making every product of
//! the round (the pass is bound by reading K, not by the arithmetic). A column's arithmetic
//! does not depend on which other columns share the pass, so either driver gives the same
//! bits.

use faer::prelude::*;

use super::mixed::{GiveUp, MixedStats};

/// One system's recurrence between two products with H.
pub(crate) struct Cg {
    b: Mat<f64>,
    x: Mat<f64>,
    r: Mat<f64>,
    p: Mat<f64>,
    rz: Vec<f64>,
    /// ‖H‖∞.
    h_norm: f64,
    /// The backward-error threshold √n·ε·‖H‖∞ (times ‖x‖∞ per column).
    tol: f64,
    /// Columns converged at the start of the current step.
    done: Vec<bool>,
    steps: usize,
    max_steps: usize,
}

/// What the recurrence needs next.
pub(crate) enum Need<'a> {
    /// H·P for the search directions P, then [`Cg::advance`].
    Step(&'a Mat<f64>),
    /// H·X for the converged X, then [`Cg::finish`].
    Check(&'a Mat<f64>),
}

fn col_dot(a: &Mat<f64>, b: &Mat<f64>, j: usize) -> f64 {
    (0..a.nrows()).map(|i| a[(i, j)] * b[(i, j)]).sum()
}

fn col_max(a: &Mat<f64>, j: usize) -> f64 {
    (0..a.nrows()).map(|i| a[(i, j)].abs()).fold(0.0, f64::max)
}

impl Cg {
    /// The first product the recurrence needs: H·[X₀ | 1] with X₀ = P⁻¹B (one pass over H
    /// gives H·X₀ and H·1: H's entries are positive, Gaussian kernel plus a positive
    /// diagonal, so ‖H‖∞, the largest row sum of |H|, is max(H·1)). Returns X₀ and [X₀ | 1].
    pub fn first(
        b: MatRef<'_, f64>,
        precondition: impl Fn(&Mat<f64>) -> Mat<f64>,
    ) -> (Mat<f64>, Mat<f64>) {
        let (n, m) = (b.nrows(), b.ncols());
        let x = precondition(&b.to_owned());
        let x1 = Mat::<f64>::from_fn(n, m + 1, |i, j| if j < m { x[(i, j)] } else { 1.0 });
        (x, x1)
    }

    /// The recurrence from X₀ and `hx1` = H·[X₀ | 1] (see [`Cg::first`]).
    pub fn new(
        b: MatRef<'_, f64>,
        x: Mat<f64>,
        hx1: &Mat<f64>,
        precondition: impl Fn(&Mat<f64>) -> Mat<f64>,
        max_steps: usize,
    ) -> Cg {
        let (n, m) = (b.nrows(), b.ncols());
        let h_norm = (0..n).map(|i| hx1[(i, m)]).fold(0.0, f64::max);
        let tol = (n as f64).sqrt() * f64::EPSILON * h_norm;
        let r = Mat::<f64>::from_fn(n, m, |i, j| b[(i, j)] - hx1[(i, j)]);
        let zr = precondition(&r);
        let p = zr.clone();
        let rz: Vec<f64> = (0..m).map(|j| col_dot(&r, &zr, j)).collect();
        Cg {
            b: b.to_owned(),
            x,
            r,
            p,
            rz,
            h_norm,
            tol,
            done: vec![false; m],
            steps: 0,
            max_steps,
        }
    }

    /// The next product, or [`GiveUp::NoConvergence`] when the step budget is spent.
    pub fn next(&mut self) -> Result<Need<'_>, GiveUp> {
        let m = self.b.ncols();
        self.done = (0..m)
            .map(|j| col_max(&self.r, j) <= self.tol * col_max(&self.x, j))
            .collect();
        if self.done.iter().all(|d| *d) {
            return Ok(Need::Check(&self.x));
        }
        if self.steps == self.max_steps {
            return Err(GiveUp::NoConvergence);
        }
        Ok(Need::Step(&self.p))
    }

    /// One CG step with `q` = H·P.
    pub fn advance(
        &mut self,
        q: &Mat<f64>,
        precondition: impl Fn(&Mat<f64>) -> Mat<f64>,
    ) -> Result<(), GiveUp> {
        let (n, m) = (self.b.nrows(), self.b.ncols());
        self.steps += 1;
        for j in 0..m {
            if self.done[j] {
                continue;
            }
            let pq = col_dot(&self.p, q, j);
            if !(pq > 0.0 && self.rz[j].is_finite()) {
                return Err(GiveUp::NoConvergence);
            }
            let a = self.rz[j] / pq;
            for i in 0..n {
                self.x[(i, j)] += a * self.p[(i, j)];
                self.r[(i, j)] -= a * q[(i, j)];
            }
        }
        let zr = precondition(&self.r);
        for j in 0..m {
            if self.done[j] {
                continue;
            }
            let rz_new = col_dot(&self.r, &zr, j);
            let beta = rz_new / self.rz[j];
            self.rz[j] = rz_new;
            for i in 0..n {
                self.p[(i, j)] = zr[(i, j)] + beta * self.p[(i, j)];
            }
        }
        Ok(())
    }

    /// The solution, checked on the true residual B − `hx` (`hx` = H·X): the recurrence's
    /// residual drifts from it.
    pub fn finish(self, hx: &Mat<f64>) -> Result<(Mat<f64>, MixedStats), GiveUp> {
        let (n, m) = (self.b.nrows(), self.b.ncols());
        let r = &self.b - hx;
        let mut backward_error: f64 = 0.0;
        for j in 0..m {
            let xm = col_max(&self.x, j);
            let rm = col_max(&r, j);
            // `col_max` would skip a NaN (f64::max ignores it): check finiteness on its own.
            let finite = (0..n).all(|i| self.x[(i, j)].is_finite() && r[(i, j)].is_finite());
            if !finite || rm > 4.0 * self.tol * xm {
                return Err(GiveUp::NoConvergence);
            }
            backward_error = backward_error.max(rm / (self.h_norm * xm));
        }
        Ok((
            self.x,
            MixedStats {
                steps: self.steps,
                backward_error,
            },
        ))
    }
}

/// Solves H·X = B by preconditioned CG, `apply_h` making the products with H; gives up
/// after `max_steps` steps.
pub(crate) fn pcg(
    apply_h: impl Fn(&Mat<f64>) -> Mat<f64>,
    b: MatRef<'_, f64>,
    precondition: impl Fn(&Mat<f64>) -> Mat<f64>,
    max_steps: usize,
) -> Result<(Mat<f64>, MixedStats), GiveUp> {
    let (x, x1) = Cg::first(b, &precondition);
    let hx1 = apply_h(&x1);
    let mut cg = Cg::new(b, x, &hx1, &precondition, max_steps);
    loop {
        match cg.next()? {
            Need::Step(p) => {
                let q = apply_h(p);
                cg.advance(&q, &precondition)?;
            }
            Need::Check(x) => {
                let hx = apply_h(x);
                return cg.finish(&hx);
            }
        }
    }
}
