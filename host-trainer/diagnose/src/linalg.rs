//! Least squares on a handful of columns by modified Gram–Schmidt with one re-orthogonalisation
//! pass. Written here rather than taken from faer's QR because the diagnosis needs a
//! rank-revealing drop: a baseline column that the others already span (e.g. `earth_rate` and
//! `static_poly`'s constant, or the rate terms on a record without ramps) must be removed, not
//! kept as an arbitrary direction.

/// Relative norm below which a column counts as dependent on the previous ones.
const DROP_REL: f64 = 1e-9;

/// An orthonormal basis of the span of some columns, with the triangular factor to recover
/// coefficients of the original columns.
#[derive(Clone, Debug)]
pub struct Basis {
    /// Orthonormal columns (only the kept ones).
    pub q: Vec<Vec<f64>>,
    /// For each kept column: its index among the input columns.
    pub kept: Vec<usize>,
    /// Upper-triangular R over the kept columns: col_kept[j] = Σ_i r[i][j]·q[i].
    r: Vec<Vec<f64>>,
    /// Number of input columns.
    ncols: usize,
}

/// Dot product of two equal-length vectors.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `x` less its mean.
pub fn centred(x: &[f64]) -> Vec<f64> {
    let m = x.iter().sum::<f64>() / x.len().max(1) as f64;
    x.iter().map(|v| v - m).collect()
}

impl Basis {
    /// Orthonormalises `cols` (all of equal length) in order, dropping dependent ones.
    pub fn new(cols: &[Vec<f64>]) -> Self {
        let mut q: Vec<Vec<f64>> = Vec::new();
        let mut kept = Vec::new();
        let mut r: Vec<Vec<f64>> = Vec::new();
        for (j, c) in cols.iter().enumerate() {
            let norm0 = dot(c, c).sqrt();
            if !(norm0 > 0.0 && norm0.is_finite()) {
                continue;
            }
            let mut v = c.clone();
            let mut coef = vec![0.0; q.len()];
            for _pass in 0..2 {
                for (i, qi) in q.iter().enumerate() {
                    let a = dot(qi, &v);
                    coef[i] += a;
                    v.iter_mut().zip(qi).for_each(|(x, y)| *x -= a * y);
                }
            }
            let nv = dot(&v, &v).sqrt();
            if nv <= DROP_REL * norm0 {
                continue;
            }
            v.iter_mut().for_each(|x| *x /= nv);
            coef.push(nv);
            q.push(v);
            kept.push(j);
            r.push(coef);
        }
        Self {
            q,
            kept,
            r,
            ncols: cols.len(),
        }
    }

    /// y minus its projection on the span.
    pub fn residual(&self, y: &[f64]) -> Vec<f64> {
        let mut v = y.to_vec();
        self.residual_in_place(&mut v);
        v
    }

    /// [`Basis::residual`] over `v` itself (no second copy of a large grid's columns).
    pub fn residual_in_place(&self, v: &mut [f64]) {
        for _pass in 0..2 {
            for qi in &self.q {
                let a = dot(qi, v);
                v.iter_mut().zip(qi).for_each(|(x, y)| *x -= a * y);
            }
        }
    }

    /// ln det of the Gram matrix of the kept columns, Σ 2·ln r_ii (R of their QR).
    pub fn log_gram_det(&self) -> f64 {
        self.r
            .iter()
            .enumerate()
            .map(|(i, c)| 2.0 * c[i].ln())
            .sum()
    }

    /// Least-squares coefficients of the input columns for `y` (0 for dropped columns).
    pub fn coefficients(&self, y: &[f64]) -> Vec<f64> {
        let k = self.q.len();
        let b: Vec<f64> = self.q.iter().map(|qi| dot(qi, y)).collect();
        // Back substitution R·x = b; r[j] holds column j of R (rows 0..=j).
        let mut x = vec![0.0; k];
        for i in (0..k).rev() {
            let s: f64 = ((i + 1)..k).map(|j| self.r[j][i] * x[j]).sum();
            x[i] = (b[i] - s) / self.r[i][i];
        }
        let mut out = vec![0.0; self.ncols];
        for (i, &j) in self.kept.iter().enumerate() {
            out[j] = x[i];
        }
        out
    }
}

/// Σ cols[j]·beta[j].
pub fn combine(cols: &[Vec<f64>], beta: &[f64], n: usize) -> Vec<f64> {
    let mut out = vec![0.0; n];
    for (c, b) in cols.iter().zip(beta) {
        if *b != 0.0 {
            out.iter_mut().zip(c).for_each(|(o, v)| *o += b * v);
        }
    }
    out
}

/// Reduction of the residual sum of squares when the columns `c_perp` (already orthogonal to
/// the baseline) are added to fit `y_perp`; also returns their coefficients.
pub fn added_fit(c_perp: &[Vec<f64>], y_perp: &[f64]) -> (f64, Vec<f64>) {
    match c_perp.len() {
        1 => {
            let g = dot(&c_perp[0], &c_perp[0]);
            if g <= 0.0 {
                return (0.0, vec![0.0]);
            }
            let b = dot(&c_perp[0], y_perp);
            (b * b / g, vec![b / g])
        }
        2 => {
            let (g11, g12, g22) = (
                dot(&c_perp[0], &c_perp[0]),
                dot(&c_perp[0], &c_perp[1]),
                dot(&c_perp[1], &c_perp[1]),
            );
            let (b1, b2) = (dot(&c_perp[0], y_perp), dot(&c_perp[1], y_perp));
            let det = g11 * g22 - g12 * g12;
            if det.is_nan() || det <= 1e-12 * g11 * g22 {
                let (d, a) = added_fit(&c_perp[..1], y_perp);
                return (d, vec![a[0], 0.0]);
            }
            let a1 = (g22 * b1 - g12 * b2) / det;
            let a2 = (g11 * b2 - g12 * b1) / det;
            (a1 * b1 + a2 * b2, vec![a1, a2])
        }
        _ => {
            let basis = Basis::new(c_perp);
            let r = basis.residual(y_perp);
            (
                dot(y_perp, y_perp) - dot(&r, &r),
                basis.coefficients(y_perp),
            )
        }
    }
}

/// [`added_fit`]'s reduction of the RSS with the parts that do not depend on `y_perp` (the
/// Gram matrix, or the orthonormal basis of three or more columns) computed once: the
/// bootstrap fits the same candidate columns to hundreds of null replicates. Gives
/// `added_fit(c_perp, y).0` bit for bit.
#[derive(Clone, Debug)]
pub enum AddedFit {
    /// One column and its squared norm.
    One(f64),
    /// Two columns: G = [[g11, g12], [g12, g22]] and det G, or `None` when G is singular
    /// (the second column is then dropped, as `added_fit` does).
    Two(f64, f64, f64, Option<f64>),
    /// None, or three or more: their orthonormal basis.
    Many(Basis),
}

impl AddedFit {
    /// Prepares the fit of the columns `c_perp`.
    pub fn new(c_perp: &[Vec<f64>]) -> Self {
        match c_perp.len() {
            1 => AddedFit::One(dot(&c_perp[0], &c_perp[0])),
            2 => {
                let (g11, g12, g22) = (
                    dot(&c_perp[0], &c_perp[0]),
                    dot(&c_perp[0], &c_perp[1]),
                    dot(&c_perp[1], &c_perp[1]),
                );
                let det = g11 * g22 - g12 * g12;
                let ok = !(det.is_nan() || det <= 1e-12 * g11 * g22);
                AddedFit::Two(g11, g12, g22, ok.then_some(det))
            }
            _ => AddedFit::Many(Basis::new(c_perp)),
        }
    }

    /// The reduction of the RSS of `y_perp` by the columns `c_perp` this was prepared from.
    pub fn drss(&self, c_perp: &[Vec<f64>], y_perp: &[f64]) -> f64 {
        let one = |g: f64| {
            if g <= 0.0 {
                return 0.0;
            }
            let b = dot(&c_perp[0], y_perp);
            b * b / g
        };
        match self {
            AddedFit::One(g) => one(*g),
            AddedFit::Two(g11, _, _, None) => one(*g11),
            AddedFit::Two(g11, g12, g22, Some(det)) => {
                let (b1, b2) = (dot(&c_perp[0], y_perp), dot(&c_perp[1], y_perp));
                let a1 = (g22 * b1 - g12 * b2) / det;
                let a2 = (g11 * b2 - g12 * b1) / det;
                a1 * b1 + a2 * b2
            }
            AddedFit::Many(basis) => {
                let r = basis.residual(y_perp);
                dot(y_perp, y_perp) - dot(&r, &r)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The prepared fit gives `added_fit`'s reduction bit for bit: no column, one, two
    /// (independent and collinear), three.
    #[test]
    fn prepared_fit_equals_added_fit() {
        let col = |k: f64| -> Vec<f64> {
            (0..97)
                .map(|i| ((i as f64 * 0.37 + k).sin() * 1.7).fract())
                .collect()
        };
        let y: Vec<f64> = (0..97).map(|i| (i as f64 * 0.11).cos()).collect();
        let a = col(0.3);
        let twice: Vec<f64> = a.iter().map(|v| 2.0 * v).collect();
        let sets: Vec<Vec<Vec<f64>>> = vec![
            vec![],
            vec![a.clone()],
            vec![a.clone(), col(1.9)],
            vec![a.clone(), twice],
            vec![a.clone(), col(1.9), col(4.4)],
        ];
        for cols in &sets {
            let want = added_fit(cols, &y).0;
            let got = AddedFit::new(cols).drss(cols, &y);
            assert_eq!(got.to_bits(), want.to_bits(), "{} columns", cols.len());
        }
    }

    /// Coefficients against the closed form of a 2-column fit through exact data, and a
    /// dependent column is dropped (coefficient 0) without changing the fit.
    #[test]
    fn recovers_exact_coefficients_and_drops_dependent_columns() {
        let x: Vec<f64> = (0..50).map(|i| i as f64 * 0.1).collect();
        let one = vec![1.0; 50];
        let twice_one = vec![2.0; 50];
        let y: Vec<f64> = x.iter().map(|v| 3.0 - 0.5 * v).collect();
        let b = Basis::new(&[one, x.clone(), twice_one]);
        assert_eq!(b.kept, vec![0, 1]);
        let c = b.coefficients(&y);
        assert!((c[0] - 3.0).abs() < 1e-12 && (c[1] + 0.5).abs() < 1e-12 && c[2] == 0.0);
        let r = b.residual(&y);
        assert!(dot(&r, &r) < 1e-20);
    }

    /// The two-column added fit equals a dense solve of the 2×2 normal equations.
    #[test]
    fn added_fit_matches_normal_equations() {
        let c1: Vec<f64> = (0..20).map(|i| (i as f64 * 0.3).sin()).collect();
        let c2: Vec<f64> = (0..20).map(|i| (i as f64 * 0.3).cos()).collect();
        let y: Vec<f64> = (0..20).map(|i| 0.7 * c1[i] - 1.2 * c2[i]).collect();
        let (drss, a) = added_fit(&[c1, c2], &y);
        assert!((a[0] - 0.7).abs() < 1e-12 && (a[1] + 1.2).abs() < 1e-12);
        assert!((drss - dot(&y, &y)).abs() < 1e-12);
    }
}
