//! A block's variance about its own trend: its least-squares line, or a polynomial of the
//! degree the record's curvature within blocks asks for ([`detrend_degree`]).

use crate::linalg::dot;

/// The residuals of `y` about its least-squares line (empty for fewer than 3 samples).
pub(super) fn line_residuals(y: &[f64]) -> Vec<f64> {
    let m = y.len();
    if m < 3 {
        return Vec::new();
    }
    let mf = m as f64;
    let ybar = y.iter().sum::<f64>() / mf;
    let xbar = 0.5 * (mf - 1.0);
    let sxy: f64 = y
        .iter()
        .enumerate()
        .map(|(j, v)| (j as f64 - xbar) * (v - ybar))
        .sum();
    let slope = sxy / (mf * (mf * mf - 1.0) / 12.0);
    y.iter()
        .enumerate()
        .map(|(j, v)| v - ybar - slope * (j as f64 - xbar))
        .collect()
}

/// Sample variance of `y` about its least-squares line (None for fewer than 3 samples).
pub fn line_variance(y: &[f64]) -> Option<f64> {
    let m = y.len();
    if m < 3 {
        return None;
    }
    let mf = m as f64;
    let ybar = y.iter().sum::<f64>() / mf;
    let xbar = 0.5 * (mf - 1.0);
    let (mut sxy, mut syy) = (0.0, 0.0);
    for (j, v) in y.iter().enumerate() {
        let (dx, dy) = (j as f64 - xbar, v - ybar);
        sxy += dx * dy;
        syy += dy * dy;
    }
    let sxx = mf * (mf * mf - 1.0) / 12.0;
    Some(((syy - sxy * sxy / sxx) / (mf - 2.0)).max(0.0))
}

/// Least-squares polynomial detrending of blocks of `m` samples: an orthonormal basis of the
/// polynomials of degree ≤ d over the block's sample times (Gram–Schmidt of 1, x, x², … on
/// x ∈ [−1, 1], twice for round-off). Degree 1 stays with the closed-form [`line_residuals`]
/// and [`line_variance`], so that a record without curvature gives the same bits as before
/// the degree was chosen (every benchmark record does).
pub(super) struct Detrend {
    basis: Vec<Vec<f64>>,
}

impl Detrend {
    pub(super) fn new(m: usize, degree: usize) -> Self {
        let x: Vec<f64> = (0..m)
            .map(|j| 2.0 * j as f64 / (m.max(2) - 1) as f64 - 1.0)
            .collect();
        let mut basis: Vec<Vec<f64>> = Vec::new();
        for d in 0..=degree.min(m.saturating_sub(1)) {
            let mut v: Vec<f64> = x.iter().map(|t| t.powi(d as i32)).collect();
            for _ in 0..2 {
                for q in &basis {
                    let c = dot(&v, q);
                    v.iter_mut().zip(q).for_each(|(a, w)| *a -= c * w);
                }
            }
            let n = dot(&v, &v).sqrt();
            v.iter_mut().for_each(|a| *a /= n);
            basis.push(v);
        }
        Self { basis }
    }

    /// The block's coefficients on the basis.
    pub(super) fn coefficients(&self, y: &[f64]) -> Vec<f64> {
        self.basis.iter().map(|q| dot(y, q)).collect()
    }

    pub(super) fn residuals(&self, y: &[f64]) -> Vec<f64> {
        let mut e = y.to_vec();
        for (q, c) in self.basis.iter().zip(self.coefficients(y)) {
            e.iter_mut().zip(q).for_each(|(a, w)| *a -= c * w);
        }
        e
    }

    pub(super) fn variance(&self, y: &[f64]) -> Option<f64> {
        let dof = y.len().checked_sub(self.basis.len()).filter(|d| *d > 0)?;
        let e = self.residuals(y);
        Some(dot(&e, &e) / dof as f64)
    }
}

/// Degrees of the within-block detrending tried, lowest first.
const DETREND_DEGREES: [usize; 4] = [1, 3, 5, 7];

/// The degree of the polynomial each block's variance is taken about: the lowest of
/// [`DETREND_DEGREES`] beyond which the blocks show no more curvature than white noise does.
/// A gyro whose bias moves by tens of °/h per °C (a MEMS part, a poorly compensated readout)
/// curves within 100 s where the temperature's ramp bends, by far more than its 1 s noise,
/// and only there: about a straight line that curvature is a noise scale in temperature (a
/// clean record of 100 °/h per °C with 1 °C/min ramps and 300 s corners shows a strong one
/// about lines and none about cubics). Each step from d to d + 2 is an F test per block of the two
/// further coefficients (numerator of 2 degrees of freedom, whose 1 % point is closed-form);
/// the degree rises while more blocks pass it at 1 % than a binomial share of 1 % plus three
/// standard deviations. On white or slowly wandering noise it stays 1.
pub(super) fn detrend_degree(rate: &[f64], m: usize) -> usize {
    let top = DETREND_DEGREES[DETREND_DEGREES.len() - 1];
    if m < top + 10 {
        return 1;
    }
    let det = Detrend::new(m, top);
    // Per block: the sum of squares about its mean and the squared coefficients (centred
    // first: a bias of thousands of °/h beside a 1 s noise of hundredths would otherwise
    // leave the residual sum to round-off).
    let blocks: Vec<(f64, Vec<f64>)> = rate
        .chunks_exact(m)
        .map(|c| {
            let mean = c.iter().sum::<f64>() / m as f64;
            let d: Vec<f64> = c.iter().map(|v| v - mean).collect();
            (
                dot(&d, &d),
                det.coefficients(&d).iter().map(|v| v * v).collect(),
            )
        })
        .collect();
    let nb = blocks.len() as f64;
    let allowed = nb * 0.01 + 3.0 * (nb * 0.01 * 0.99).sqrt() + 1.0;
    for d in DETREND_DEGREES.into_iter().filter(|d| *d < top) {
        let dof = (m - d - 3) as f64;
        // F(2, ν) exceeds f with probability (1 + 2f/ν)^(−ν/2).
        let crit = (0.01f64.powf(-2.0 / dof) - 1.0) * dof / 2.0;
        let passing = blocks
            .iter()
            .filter(|(ss, c2)| {
                let rss = ss - c2[..=d + 2].iter().sum::<f64>();
                let extra = c2[d + 1] + c2[d + 2];
                rss > 0.0 && (extra / 2.0) / (rss / dof) > crit
            })
            .count();
        if (passing as f64) <= allowed {
            return d;
        }
    }
    top
}
