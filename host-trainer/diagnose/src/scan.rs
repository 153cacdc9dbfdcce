//! The scan: every candidate point's whitened fit gain over the baseline, and the generic
//! piecewise-constant basis that asks whether there is any structure at all.

use rayon::prelude::*;

use super::candidates::{node_lag, Family};
use super::linalg::{added_fit, dot, AddedFit, Basis};
use super::noise::Whitener;
use super::prepare::Prepared;
use super::score::delta_bic;
use super::search::step_times;
use super::Unexplained;

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
    /// The generic structure test's alternatives, whitened and prepared.
    pub(super) gen: GenericFits,
    /// The alternative that fits the record best.
    pub(super) gen_best: Option<usize>,
    /// Its coefficients (°/h per unit of each of its columns).
    pub(super) gen_coef: Vec<f64>,
    /// Its ΔBIC: the generic structure test's statistic.
    pub(super) gen_dbic: f64,
    /// The best step, the best boxcar window and the best smooth window in time.
    pub(super) gen_tops: Vec<usize>,
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
    generic: &Generic,
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
    let gen = generic.whitened(ar, &basis);
    let (gen_best, gen_dbic) = gen.best(&yw, n, rss0);
    let gen_tops = [
        |s: &Shape| matches!(s, Shape::Step(_)),
        |s: &Shape| matches!(s, Shape::Window(..)),
        |s: &Shape| matches!(s, Shape::SmoothWindow(..)),
    ]
    .iter()
    .filter_map(|f| gen.best_where(&yw, n, rss0, f).0)
    .collect();
    let gen_coef = gen_best.map_or_else(Vec::new, |i| gen.coefficients(i, &yw));
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
        gen,
        gen_best,
        gen_coef,
        gen_dbic,
        gen_tops,
    }
}

/// Piecewise-constant columns in time (12 chunks), in temperature (8 bands) and in dT/dt
/// (4 bands): a generic basis for "is there any structure at all", with no physics in it.
/// The dT/dt bands see what differs between heating, cooling and holds (a term even in
/// dT/dt, which the model's odd rate terms cannot take).
fn piecewise_columns(prep: &Prepared) -> Vec<Vec<f64>> {
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

/// At most this many step times in the generic test: a step half-way between two tried times
/// is δ = 1/300 of the record from one, and in white noise a step at a fraction s of the record
/// loses about δ/(s(1 − s)) of its fit gain there, under 2 % in the middle third (the fine
/// step scan of the search locates it where a step is put against a drift).
const GENERIC_STEP_TIMES: usize = 150;

/// The shape of one alternative of the generic structure test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Shape {
    /// Piecewise constant in time, temperature and dT/dt together ([`piecewise_columns`]).
    Piecewise,
    /// A single step in the bias at the start of this block, at a time no term of the
    /// library puts one (the mode hop steps at a temperature, the warm-up decays).
    Step(usize),
    /// The same shift on heating and cooling: |dT/dt| and (dT/dt)², per sample and averaged
    /// over the block (the baseline's rate terms are odd).
    EvenInRate,
    /// A shift of the bias over the blocks `start..end` only, and back: a transient in time
    /// (a disturbance of the bench, a burst of a readout), which neither a step nor the
    /// piecewise chunks fit without spreading it.
    Window(usize, usize),
    /// A smooth bump of the bias over the blocks `start..end` (a raised cosine, its peak in
    /// the middle): a transient that rises and relaxes (a disturbance warming one part of
    /// the gyro's body, a readout settling), which a boxcar fits with much of its SNR lost at
    /// its edges.
    SmoothWindow(usize, usize),
    /// A bump of the bias while the temperature is between two levels (°C), on heating and
    /// cooling alike, and none outside them: the baseline's polynomial spreads it over the
    /// range, the backscatter term repeats it over the range and a mode hop keeps it beyond
    /// its temperature.
    TempWindow(f64, f64),
}

impl Shape {
    /// The parameters the alternative is charged (a step's time is one, a window's two
    /// edges two).
    fn n_params(self, cols: usize) -> usize {
        match self {
            Shape::Step(_) => 2,
            Shape::Window(..) | Shape::SmoothWindow(..) => 3,
            Shape::TempWindow(..) => TEMP_WINDOW_PARAMS,
            _ => cols,
        }
    }
}

/// The narrowest window in time, in blocks: an isolated spike of a single sample (a readout
/// glitch, up to 100 times the 1 s σ) moves one 100 s mean by up to about 10 of its σ, which a
/// window of 8 blocks dilutes to 3.5σ, below the 3 ln n a window is charged on any record of
/// more than a few hours.
const WINDOW_MIN_BLOCKS: usize = 8;

/// The windows in time, as pairs (i, j) of the generic test's step times `steps` (block
/// indices, ascending): a window is the step at the first less the step at the second, so
/// its whitened column is the difference of theirs and costs no whitening of its own (a
/// record of 1 300 blocks has about 1 000 windows, whose own whitening would double a
/// diagnosis' time). Widths of 1, 2, 3, 4, 6, 9, … step spacings (each 1.5 times the last)
/// from [`WINDOW_MIN_BLOCKS`] to a quarter of the record (wider, the steps and the
/// piecewise chunks fit it), each width starting every third of itself: a boxcar transient
/// is matched by some window at 80 % or more of its own fit's SNR where the spacing is
/// under a third of its width (the test below). On a month, the 150 step times are 4.8 h
/// apart, and so is the narrowest window.
fn window_pairs(steps: &[usize], nb: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut widths: Vec<usize> = Vec::new();
    let mut w = 1.0_f64;
    while (w.round() as usize) < steps.len() {
        let d = w.round() as usize;
        if widths.last() != Some(&d) {
            widths.push(d);
        }
        w *= 1.5;
    }
    for d in widths {
        let stride = (d / 3).max(1);
        for i in (0..steps.len() - d).step_by(stride) {
            let width = steps[i + d] - steps[i];
            if (WINDOW_MIN_BLOCKS..=nb / 4).contains(&width) {
                out.push((i, i + d));
            }
        }
    }
    out
}

/// The narrowest smooth window in time, in blocks: a raised cosine's half-height width is
/// half its span, so this matches a bump of about 8 blocks at half height, as narrow as the
/// narrowest boxcar.
const SMOOTH_MIN_BLOCKS: usize = 2 * WINDOW_MIN_BLOCKS;

/// The smooth windows in time of a record of `nb` blocks whose generic step times are
/// `steps`, as block spans `start..end`: widths from [`SMOOTH_MIN_BLOCKS`] (or three step
/// spacings, on a record longer than 150 of them) to 3/5 of the record, each 1.5 times the
/// last, starting every quarter of the width (or every step spacing, whichever is longer)
/// and once more ending at the record's end. A Gaussian bump of 1σ from a 30th to a tenth of
/// the record anywhere inside it is matched by some window at ≥ 90 % of its own fit's SNR
/// (the test below). Unlike a boxcar, a smooth window is not a difference of two steps and
/// is whitened on its own: the grid keeps them to about 600 on a day of 100 s blocks and as
/// many on a month, where the step spacing sets the grid.
fn smooth_spans(steps: &[usize], nb: usize) -> Vec<(usize, usize)> {
    let spacing = match steps {
        [a, b, ..] => b - a,
        _ => return Vec::new(),
    };
    let mut out = Vec::new();
    let mut w = SMOOTH_MIN_BLOCKS.max(3 * spacing) as f64;
    while (w.round() as usize) <= nb * 3 / 5 {
        let d = w.round() as usize;
        let stride = (d / 4).max(spacing).max(1);
        let mut starts: Vec<usize> = (0..=nb - d).step_by(stride).collect();
        if starts.last() != Some(&(nb - d)) {
            starts.push(nb - d);
        }
        out.extend(starts.into_iter().map(|a| (a, a + d)));
        w *= 1.5;
    }
    out
}

/// A smooth window's column on `nb` blocks: the raised cosine over `start..end` at each
/// block's middle.
fn smooth_column((a, b): (usize, usize), nb: usize) -> Vec<f64> {
    (0..nb)
        .map(|k| raised_cosine(k as f64 + 0.5, (a as f64, b as f64)))
        .collect()
}

/// Levels of temperature the windows in temperature start and end at, evenly spaced inside
/// the range of the block means: a 40th of it apart (2.5 °C on a 100 °C cycle).
const TEMP_LEVELS: usize = 39;

/// The parameters a window in temperature is charged: its height and its two edges.
pub(crate) const TEMP_WINDOW_PARAMS: usize = 3;

/// Widths of the generic structure test's windows in temperature, in level spacings: about
/// 1.25 times the last, 5 % to a third of the range (wider, the baseline's polynomial and the
/// temperature bands fit it).
pub(crate) const GENERIC_TEMP_WIDTHS: &[usize] = &[2, 3, 4, 5, 6, 8, 10, 13];

/// Widths of the bump put against a backscatter ripple or a mode hop (`search::bump`): the
/// generic test's, two fifths and half the range. A ripple's lobe is half its period wide,
/// its period fitted continuously; a bump of 1σ near a tenth of the range is wider than the
/// generic test's widest window fits well (a correlation under 0.88), and a lobe then takes
/// it unless a window as wide is put against the lobe. The generic test keeps its widths:
/// there the wider windows are what the baseline's polynomial and the bands already fit.
pub(crate) const BUMP_TEMP_WIDTHS: &[usize] = &[2, 3, 4, 5, 6, 8, 10, 13, 16, 20];

/// The edges (°C) of the windows in temperature on a record whose block means span
/// `lo..hi`: pairs of [`TEMP_LEVELS`] levels evenly spaced inside the range, `widths` level
/// spacings apart, each width starting every third of itself and once more ending at the
/// top level.
fn temp_window_edges(lo: f64, hi: f64, widths: &[usize]) -> Vec<(f64, f64)> {
    let level = |k: usize| lo + (hi - lo) * (k + 1) as f64 / (TEMP_LEVELS + 1) as f64;
    let mut out = Vec::new();
    for &d in widths {
        let last = TEMP_LEVELS - 1 - d;
        let mut starts: Vec<usize> = (0..=last).step_by((d / 3).max(1)).collect();
        if starts.last() != Some(&last) {
            starts.push(last);
        }
        out.extend(starts.into_iter().map(|i| (level(i), level(i + d))));
    }
    out
}

/// A window in temperature at `t`: a raised cosine between the edges `a..b`, 1 in the
/// middle and 0 at and beyond them. A bump at a temperature is smooth (the body's
/// temperature is not one value, and a sensor lags it), and a boxcar fits a smooth bump with
/// much of its SNR lost at the edges.
fn raised_cosine(t: f64, (a, b): (f64, f64)) -> f64 {
    if (a..b).contains(&t) {
        0.5 - 0.5 * (std::f64::consts::TAU * (t - a) / (b - a)).cos()
    } else {
        0.0
    }
}

/// The windows in temperature of `prep`'s record, `widths` level spacings wide
/// ([`temp_window_edges`]): their edges (°C) and block columns, each the block mean of the
/// per-sample window (a block of a 3 °C/min ramp spans 5 °C, which its mean temperature
/// alone would put at one value). A window the record spends less than
/// [`WINDOW_MIN_BLOCKS`] blocks inside is left out, for the same reason as a narrow window
/// in time: a few blocks are fitted by a spike.
pub(crate) fn temp_windows(prep: &Prepared, widths: &[usize]) -> Vec<((f64, f64), Vec<f64>)> {
    let (lo, hi) = prep
        .temp_b
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
            (a.min(*t), b.max(*t))
        });
    if hi <= lo {
        return Vec::new();
    }
    temp_window_edges(lo, hi, widths)
        .into_iter()
        .filter(|(a, b)| {
            prep.temp_b.iter().filter(|t| (*a..*b).contains(*t)).count() >= WINDOW_MIN_BLOCKS
        })
        .map(|w| {
            let per_sample: Vec<f64> = prep
                .drive
                .temp_c
                .iter()
                .map(|t| raised_cosine(*t, w))
                .collect();
            (w, prep.blocks(&per_sample))
        })
        .collect()
}

/// The generic structure test's alternatives: shapes with no physics in them, each fitted
/// beside the model, the test's statistic the best of their ΔBIC. The piecewise basis alone
/// spreads a single step or a term even in dT/dt over 22 parameters and loses it; each such
/// shape a record shows often and no library term has gets its own alternative, and the
/// bootstrap calibrates the best of them as it does the library's scan.
pub(super) struct Generic {
    shapes: Vec<Shape>,
    cols: Vec<Vec<Vec<f64>>>,
    /// The windows ([`window_pairs`]), as indices of their two steps among `shapes`; their
    /// shapes follow the others' in the fits' numbering.
    windows: Vec<(usize, usize)>,
}

impl Generic {
    /// The alternatives of `prep`'s record.
    pub(super) fn new(prep: &Prepared) -> Self {
        let nb = prep.nb();
        let mut shapes = vec![Shape::Piecewise];
        let mut cols = vec![piecewise_columns(prep)];
        let steps = step_times(nb, GENERIC_STEP_TIMES);
        let first_step = shapes.len();
        for &k in &steps {
            shapes.push(Shape::Step(k));
            cols.push(vec![(0..nb).map(|b| f64::from(u8::from(b >= k))).collect()]);
        }
        let r = &prep.drive.dtemp_c_per_s;
        let scale = r.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        if scale > 0.0 && scale.is_finite() {
            shapes.push(Shape::EvenInRate);
            cols.push(vec![
                prep.blocks(&r.iter().map(|v| (v / scale).abs()).collect::<Vec<f64>>()),
                prep.blocks(&r.iter().map(|v| (v / scale).powi(2)).collect::<Vec<f64>>()),
            ]);
        }
        for ((a, b), col) in temp_windows(prep, GENERIC_TEMP_WIDTHS) {
            shapes.push(Shape::TempWindow(a, b));
            cols.push(vec![col]);
        }
        for span in smooth_spans(&steps, nb) {
            shapes.push(Shape::SmoothWindow(span.0, span.1));
            cols.push(vec![smooth_column(span, nb)]);
        }
        let windows = window_pairs(&steps, nb);
        shapes.extend(
            windows
                .iter()
                .map(|&(i, j)| Shape::Window(steps[i], steps[j])),
        );
        let windows = windows
            .into_iter()
            .map(|(i, j)| (first_step + i, first_step + j))
            .collect();
        Self {
            shapes,
            cols,
            windows,
        }
    }

    /// Whether alternative `i` is a window in time (a boxcar or a smooth one).
    pub(super) fn is_window(&self, i: usize) -> bool {
        matches!(self.shapes[i], Shape::Window(..) | Shape::SmoothWindow(..))
    }

    /// Whether alternative `i` is a step or a window in time.
    pub(super) fn is_step_or_window(&self, i: usize) -> bool {
        self.is_window(i) || matches!(self.shapes[i], Shape::Step(_))
    }

    /// The block columns of alternative `i` on a record of `nb` blocks.
    pub(super) fn columns(&self, i: usize, nb: usize) -> Vec<Vec<f64>> {
        match self.shapes[i] {
            Shape::Window(a, b) => {
                vec![(0..nb)
                    .map(|k| f64::from(u8::from((a..b).contains(&k))))
                    .collect()]
            }
            _ => self.cols[i].clone(),
        }
    }

    /// The alternatives whitened by `ar` and made orthogonal to the model's `basis`.
    fn whitened(&self, ar: &Whitener, basis: &Basis) -> GenericFits {
        let all: Vec<&[f64]> = self.cols.iter().flatten().map(Vec::as_slice).collect();
        let mut w = ar.whiten_many(&all).into_iter();
        let cperp: Vec<Vec<Vec<f64>>> = self
            .cols
            .iter()
            .map(|c| w.by_ref().take(c.len()).collect::<Vec<Vec<f64>>>())
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|mut c| {
                c.iter_mut().for_each(|v| basis.residual_in_place(v));
                c
            })
            .collect();
        let fits: Vec<AddedFit> = cperp.par_iter().map(|c| AddedFit::new(c)).collect();
        let k = self
            .shapes
            .iter()
            .zip(&fits)
            .zip(&cperp)
            .map(|((s, f), c)| match f {
                AddedFit::Many(b) => s.n_params(b.q.len()),
                _ => s.n_params(c.len()),
            })
            .collect();
        // A window's column is its first step's less its second's, whitened and orthogonal
        // to the model as theirs are; its fit needs only its squared norm.
        let windows = self
            .windows
            .iter()
            .map(|&(a, b)| {
                let (ca, cb) = (&cperp[a][0], &cperp[b][0]);
                (a, b, dot(ca, ca) - 2.0 * dot(ca, cb) + dot(cb, cb))
            })
            .collect();
        GenericFits {
            shapes: self.shapes.clone(),
            cperp,
            fits,
            k,
            windows,
        }
    }
}

/// The generic alternatives in a scan's whitened metric.
pub(super) struct GenericFits {
    /// Each alternative's shape.
    pub(super) shapes: Vec<Shape>,
    cperp: Vec<Vec<Vec<f64>>>,
    fits: Vec<AddedFit>,
    k: Vec<usize>,
    /// Each window's two step alternatives and its whitened column's squared norm; the
    /// windows are numbered after the other alternatives.
    windows: Vec<(usize, usize, f64)>,
}

impl GenericFits {
    /// The best alternative for the whitened residual `e` (orthogonal to the model) whose
    /// sum of squares is `rss0`, and its ΔBIC (+∞ with none).
    pub(super) fn best(&self, e: &[f64], n: usize, rss0: f64) -> (Option<usize>, f64) {
        self.best_where(e, n, rss0, &|_: &Shape| true)
    }

    /// [`Self::best`] among the alternatives whose shape passes `keep`.
    pub(super) fn best_where(
        &self,
        e: &[f64],
        n: usize,
        rss0: f64,
        keep: &dyn Fn(&Shape) -> bool,
    ) -> (Option<usize>, f64) {
        let mut best = (None, f64::INFINITY);
        for (i, ((c, f), k)) in self.cperp.iter().zip(&self.fits).zip(&self.k).enumerate() {
            if !keep(&self.shapes[i]) {
                continue;
            }
            let d = delta_bic(n, rss0, f.drss(c, e), *k);
            if d < best.1 {
                best = (Some(i), d);
            }
        }
        let dots = self.step_dots(e);
        let windows = Shape::Window(0, 0).n_params(1);
        for (w, &(a, b, g)) in self.windows.iter().enumerate() {
            if g <= 0.0 || !keep(&self.shapes[self.cperp.len() + w]) {
                continue;
            }
            let x = dots[a] - dots[b];
            let d = delta_bic(n, rss0, x * x / g, windows);
            if d < best.1 {
                best = (Some(self.cperp.len() + w), d);
            }
        }
        best
    }

    /// Each single-column alternative's column against `e` (0 for the others), for the
    /// windows made of two steps.
    fn step_dots(&self, e: &[f64]) -> Vec<f64> {
        if self.windows.is_empty() {
            return Vec::new();
        }
        self.cperp
            .iter()
            .map(|c| match c.as_slice() {
                [one] => dot(one, e),
                _ => 0.0,
            })
            .collect()
    }

    /// The coefficients of alternative `i` fitted to `e` (°/h per unit of each column).
    pub(super) fn coefficients(&self, i: usize, e: &[f64]) -> Vec<f64> {
        match i.checked_sub(self.cperp.len()) {
            None => crate::linalg::added_fit(&self.cperp[i], e).1,
            Some(w) => {
                let (a, b, g) = self.windows[w];
                let x = dot(&self.cperp[a][0], e) - dot(&self.cperp[b][0], e);
                vec![if g > 0.0 { x / g } else { 0.0 }]
            }
        }
    }
}

impl Scan {
    /// The fitted shape of the best generic alternative in °/h per block (its columns as
    /// recorded, weighted by the whitened fit's coefficients), less what the model's block
    /// columns `base_b` take of it (the part the residual can show).
    pub(super) fn generic_fit(&self, generic: &Generic, base_b: &[Vec<f64>]) -> Vec<f64> {
        let Some(i) = self.gen_best else {
            return Vec::new();
        };
        let nb = base_b.first().map_or(0, Vec::len);
        let cols = generic.columns(i, nb);
        let fit: Vec<f64> = (0..nb)
            .map(|b| cols.iter().zip(&self.gen_coef).map(|(c, a)| a * c[b]).sum())
            .collect();
        Basis::new(base_b).residual(&fit)
    }

    /// What the generic alternative that fits best looks like: where a step is and how high,
    /// how large a shift even in dT/dt is, or that the structure is spread over time,
    /// temperature and dT/dt at once.
    pub(super) fn unexplained(&self, prep: &Prepared) -> Option<Unexplained> {
        let shape = self.gen.shapes[self.gen_best?];
        let c = &self.gen_coef;
        Some(match shape {
            Shape::Step(k) => Unexplained::Step {
                t_s: prep.t_b[k] - prep.full_drive.t_s[0],
                temp_c: prep.temp_b[k],
                height_dph: c.first().copied().unwrap_or(0.0),
            },
            Shape::EvenInRate => Unexplained::EvenInRate {
                shift_dph: c.iter().sum(),
                at_c_per_s: prep
                    .drive
                    .dtemp_c_per_s
                    .iter()
                    .fold(0.0_f64, |m, v| m.max(v.abs())),
            },
            Shape::Window(a, b) | Shape::SmoothWindow(a, b) => Unexplained::Window {
                t_start_s: prep.t_b[a] - prep.full_drive.t_s[0],
                t_end_s: prep.t_b[b.min(prep.t_b.len() - 1)] - prep.full_drive.t_s[0],
                height_dph: c.first().copied().unwrap_or(0.0),
                smooth: matches!(shape, Shape::SmoothWindow(..)),
            },
            Shape::TempWindow(lo_c, hi_c) => Unexplained::TempWindow {
                lo_c,
                hi_c,
                height_dph: c.first().copied().unwrap_or(0.0),
            },
            Shape::Piecewise => Unexplained::Piecewise,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The best correlation of a Gaussian bump of 1σ `sigma` (a fraction of the range) with
    /// a window of `edges` on `lo..hi`, over temperatures visited evenly, at its worst over
    /// centres at least 2σ and a tenth of the range from either end.
    fn worst_bump_match(edges: &[(f64, f64)], (lo, hi): (f64, f64), sigma: f64) -> f64 {
        let range = hi - lo;
        let grid: Vec<f64> = (0..4000).map(|k| lo + range * k as f64 / 3999.0).collect();
        let corr = |x: &[f64], y: &[f64]| {
            let d = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(p, q)| p * q).sum::<f64>();
            d(x, y) / (d(x, x) * d(y, y)).sqrt()
        };
        let wins: Vec<Vec<f64>> = edges
            .iter()
            .map(|&w| grid.iter().map(|t| raised_cosine(*t, w)).collect())
            .collect();
        let margin = (2.0 * sigma).max(0.1);
        (0..=40)
            .map(|c| {
                let centre = lo + range * (margin + (1.0 - 2.0 * margin) * c as f64 / 40.0);
                let bump: Vec<f64> = grid
                    .iter()
                    .map(|t| (-0.5 * ((t - centre) / (sigma * range)).powi(2)).exp())
                    .collect();
                wins.iter().map(|w| corr(&bump, w)).fold(0.0, f64::max)
            })
            .fold(1.0, f64::min)
    }

    /// The windows of `widths` on `lo..hi`, each asserted inside the range and from a
    /// twentieth of it to `max_share` of it wide.
    fn windows_inside(widths: &[usize], (lo, hi): (f64, f64), max_share: f64) -> Vec<(f64, f64)> {
        let edges = temp_window_edges(lo, hi, widths);
        for &(a, b) in &edges {
            assert!(lo < a && b < hi, "{a}..{b}");
            let w = (b - a) / (hi - lo);
            assert!((0.049..max_share).contains(&w), "{a}..{b}: {w}");
        }
        edges
    }

    /// Every window in temperature of the generic test lies inside the range, from a
    /// twentieth to a third of it wide; a Gaussian bump of 1σ from 2 % to 6 % of the range,
    /// centred anywhere in it at least 2σ and a tenth of the range from either end, is
    /// matched by some window at ≥ 90 % of its own fit's SNR (the correlation of the two
    /// over temperatures visited evenly).
    #[test]
    fn temperature_windows_match_every_smooth_bump_inside_the_range() {
        let (lo, hi) = (-20.0, 60.0);
        let edges = windows_inside(GENERIC_TEMP_WIDTHS, (lo, hi), 0.34);
        for sigma in [0.02_f64, 0.03, 0.04, 0.05, 0.06] {
            let best = worst_bump_match(&edges, (lo, hi), sigma);
            assert!(best >= 0.9, "σ {sigma}: {best:.3}");
        }
    }

    /// The bump's windows reach half the range, and match a bump of 1σ up to a tenth of the
    /// range at ≥ 90 % of its SNR, where the generic test's windows, a third of the range at
    /// most, fall under 88 %.
    #[test]
    fn the_bumps_windows_match_bumps_as_wide_as_a_ripples_lobe() {
        let (lo, hi) = (-20.0, 60.0);
        let edges = windows_inside(BUMP_TEMP_WIDTHS, (lo, hi), 0.51);
        let generic = temp_window_edges(lo, hi, GENERIC_TEMP_WIDTHS);
        for sigma in [0.02_f64, 0.04, 0.06, 0.08, 0.1] {
            let best = worst_bump_match(&edges, (lo, hi), sigma);
            assert!(best >= 0.9, "σ {sigma}: {best:.3}");
        }
        let narrow = worst_bump_match(&generic, (lo, hi), 0.1);
        assert!(narrow < 0.88, "generic windows at σ 0.1: {narrow:.3}");
    }

    /// Every smooth window lies inside the record, from the narrowest to 3/5 of the record
    /// wide; a Gaussian bump of 1σ from a 30th to a tenth of the record, centred anywhere at
    /// least 2σ from either end, is matched by some smooth window at ≥ 90 % of its own fit's
    /// SNR (their correlation over the blocks), on a day and on a month of 100 s blocks.
    #[test]
    fn smooth_windows_match_every_gaussian_bump_inside_the_record() {
        for nb in [361, 864, 4000, 26_000] {
            let steps = step_times(nb, GENERIC_STEP_TIMES);
            let spans = smooth_spans(&steps, nb);
            assert!(spans.len() <= 700, "{nb}: {} smooth windows", spans.len());
            for &(a, b) in &spans {
                assert!(
                    b <= nb && b - a >= SMOOTH_MIN_BLOCKS && b - a <= nb * 3 / 5,
                    "{nb}: {a}..{b}"
                );
            }
            let cols: Vec<Vec<f64>> = spans.iter().map(|&s| smooth_column(s, nb)).collect();
            let d = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(p, q)| p * q).sum::<f64>();
            let norms: Vec<f64> = cols.iter().map(|c| d(c, c).sqrt()).collect();
            for sigma in [1.0 / 30.0, 0.05, 0.075, 0.1] {
                let s = sigma * nb as f64;
                for k in 0..=30 {
                    let centre = 2.0 * s + (nb as f64 - 4.0 * s) * k as f64 / 30.0;
                    let bump: Vec<f64> = (0..nb)
                        .map(|i| (-0.5 * ((i as f64 + 0.5 - centre) / s).powi(2)).exp())
                        .collect();
                    let nbump = d(&bump, &bump).sqrt();
                    let best = cols
                        .iter()
                        .zip(&norms)
                        .map(|(c, n)| d(c, &bump) / (n * nbump))
                        .fold(0.0, f64::max);
                    assert!(
                        best >= 0.9,
                        "{nb}: σ {s:.0} blocks at {centre:.0}: {best:.3}"
                    );
                }
            }
        }
    }

    /// Every window lies between two of the generic test's step times, none narrower than
    /// the spike guard or wider than a quarter of the record; a boxcar transient between the
    /// first and the last step time, from three step spacings (and 8 blocks) to the widest
    /// window, is matched by some window at ≥ 80 % of its own fit's SNR (overlap / √(w·w₀)).
    #[test]
    fn windows_match_every_transient_inside_the_record() {
        for nb in [100, 361, 1272, 4000] {
            let steps = step_times(nb, GENERIC_STEP_TIMES);
            let spans: Vec<(usize, usize)> = window_pairs(&steps, nb)
                .into_iter()
                .map(|(i, j)| (steps[i], steps[j]))
                .collect();
            let widest = spans.iter().map(|(a, b)| b - a).max().expect("windows");
            for &(a, b) in &spans {
                assert!(
                    (WINDOW_MIN_BLOCKS..=nb / 4).contains(&(b - a)),
                    "{nb}: {a}..{b}"
                );
            }
            let (first, last) = (steps[0], steps[steps.len() - 1]);
            let mut w0 = WINDOW_MIN_BLOCKS.max(3 * (steps[1] - steps[0]));
            while w0 <= widest {
                for s0 in (first..last - w0).step_by((w0 / 5).max(1)) {
                    let best = spans
                        .iter()
                        .map(|&(a, b)| {
                            let overlap = b.min(s0 + w0).saturating_sub(a.max(s0)) as f64;
                            overlap / (((b - a) * w0) as f64).sqrt()
                        })
                        .fold(0.0, f64::max);
                    assert!(best >= 0.8, "{nb}: transient {s0}+{w0}: {best:.3}");
                }
                w0 = w0 * 5 / 4 + 1;
            }
        }
    }
}
