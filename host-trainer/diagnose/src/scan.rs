//! The scan: every candidate point's whitened fit gain over the baseline, and the generic
//! piecewise-constant basis that asks whether there is any structure at all.

use rayon::prelude::*;

use super::candidates::{node_lag, Family};
use super::linalg::{added_fit, dot, AddedFit, Basis};
use super::noise::Whitener;
use super::prepare::Prepared;
use super::score::delta_bic;

/// A point of a family's grid.
pub(super) struct Point {
    /// The family.
    pub(super) family: Family,
    /// Its non-linear parameters.
    pub(super) nl: Vec<f64>,
    /// Its block columns (shared with the column cache; emptied once the scan holds their
    /// whitened form).
    pub(super) cols_b: std::sync::Arc<Vec<Vec<f64>>>,
}

impl Point {
    /// The parameters the point's ΔBIC is charged: its family's, and one more where the
    /// term is driven by a lagging or leading node. Without the charge a lagged point wins
    /// on noise where the sensor's own node drives the term, trading the lag against the
    /// hysteresis' width (a wide play then comes out much narrower on a lagged node).
    pub(super) fn n_params(&self) -> usize {
        self.family.n_params() + usize::from(node_lag(self.family, &self.nl) != 0.0)
    }
}

/// Whitened statistics of every candidate point.
pub(super) struct Scan {
    pub(super) n: usize,
    pub(super) rss0: f64,
    pub(super) drss: Vec<f64>,
    pub(super) coef: Vec<Vec<f64>>,
    pub(super) cperp: Vec<Vec<Vec<f64>>>,
    /// Each point's fit prepared for the bootstrap's replicates.
    pub(super) fits: Vec<AddedFit>,
    pub(super) dbic: Vec<f64>,
    pub(super) basis: Basis,
    pub(super) gen_perp: Basis,
    pub(super) gen_k: usize,
    pub(super) gen_dbic: f64,
}

/// A grid scanned: the whitening, the scan's statistics and the points they belong to.
pub(super) struct Scanned<'a> {
    /// The whitening the scan was made in.
    pub(super) whitener: &'a Whitener,
    /// The scan.
    pub(super) scan: &'a Scan,
    /// The points, in the scan's order.
    pub(super) points: &'a [Point],
}

/// The columns as slices, for [`Whitener::whiten_many`].
fn refs(cols: &[Vec<f64>]) -> Vec<&[f64]> {
    cols.iter().map(Vec::as_slice).collect()
}

/// Every point's whitened fit gain over the baseline `base_b` for the block means `y_b`, and
/// the generic structure test's, in the whitening `ar`.
pub(super) fn scan(
    ar: &Whitener,
    base_b: &[Vec<f64>],
    y_b: &[f64],
    points: &[Point],
    generic: &[Vec<f64>],
) -> Scan {
    let base_w = ar.whiten_many(&refs(base_b));
    let basis = Basis::new(&base_w);
    let yw = basis.residual(&ar.whiten(y_b));
    let n = yw.len();
    let rss0 = dot(&yw, &yw);
    // Every point's columns whitened together (batched triangular solves), then each point's
    // fit in parallel.
    let all: Vec<&[f64]> = points
        .iter()
        .flat_map(|p| p.cols_b.iter().map(Vec::as_slice))
        .collect();
    let mut whitened = ar.whiten_many(&all).into_iter();
    let per_point: Vec<Vec<Vec<f64>>> = points
        .iter()
        .map(|p| whitened.by_ref().take(p.cols_b.len()).collect())
        .collect();
    let res: Vec<(Vec<Vec<f64>>, f64, Vec<f64>)> = per_point
        .into_par_iter()
        .map(|mut cp| {
            // Residualised in place: the grid's whitened columns are not held twice.
            cp.iter_mut().for_each(|c| basis.residual_in_place(c));
            let (d, a) = added_fit(&cp, &yw);
            (cp, d, a)
        })
        .collect();
    let mut cperp = Vec::with_capacity(res.len());
    let (mut drss, mut coef, mut dbic) = (Vec::new(), Vec::new(), Vec::new());
    for ((cp, d, a), p) in res.into_iter().zip(points) {
        dbic.push(delta_bic(n, rss0, d, p.n_params()));
        cperp.push(cp);
        drss.push(d);
        coef.push(a);
    }
    let gen_w: Vec<Vec<f64>> = ar
        .whiten_many(&refs(generic))
        .iter()
        .map(|c| basis.residual(c))
        .collect();
    let gen_perp = Basis::new(&gen_w);
    let gen_k = gen_perp.q.len();
    let r = gen_perp.residual(&yw);
    let gen_dbic = delta_bic(n, rss0, rss0 - dot(&r, &r), gen_k);
    let fits = cperp.par_iter().map(|cp| AddedFit::new(cp)).collect();
    Scan {
        n,
        rss0,
        drss,
        coef,
        cperp,
        fits,
        dbic,
        basis,
        gen_perp,
        gen_k,
        gen_dbic,
    }
}

/// Piecewise-constant columns in time (12 chunks), in temperature (8 bands) and in dT/dt
/// (4 bands): a generic basis for "is there any structure at all", with no physics in it.
/// The dT/dt bands see what differs between heating, cooling and holds (a term even in
/// dT/dt, which the model's odd rate terms cannot take).
pub(super) fn generic_columns(prep: &Prepared) -> Vec<Vec<f64>> {
    let nb = prep.nb();
    let mut cols = Vec::new();
    for c in 1..12 {
        cols.push(
            (0..nb)
                .map(|b| f64::from(u8::from(b * 12 / nb == c)))
                .collect(),
        );
    }
    let mut sorted = prep.temp_b.clone();
    sorted.sort_by(f64::total_cmp);
    let edges: Vec<f64> = (1..8).map(|k| sorted[k * nb / 8]).collect();
    for w in edges
        .windows(2)
        .chain(std::iter::once(&[edges[6], f64::INFINITY][..]))
    {
        cols.push(
            prep.temp_b
                .iter()
                .map(|t| f64::from(u8::from(*t >= w[0] && *t < w[1])))
                .collect(),
        );
    }
    let mut rates = prep.dtemp_b.clone();
    rates.sort_by(f64::total_cmp);
    let edges: Vec<f64> = (1..4).map(|k| rates[k * nb / 4]).collect();
    for w in edges
        .windows(2)
        .chain(std::iter::once(&[edges[2], f64::INFINITY][..]))
    {
        cols.push(
            prep.dtemp_b
                .iter()
                .map(|r| f64::from(u8::from(*r >= w[0] && *r < w[1])))
                .collect(),
        );
    }
    cols
}
