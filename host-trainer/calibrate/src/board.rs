//! The board table: a fixed-size LS-SVM tuned as the table it is, within the board's f32
//! limit, and its output through the board's own `Compensator`.

use indicatif::ProgressBar;

use compensator_core::{Compensator, SensorLimits};
use rlg_io::recording::Recording;
use rlg_train::export;
use rlg_train::lssvm::fixed_size::FixedSizeOptions;
use rlg_train::lssvm::sparse::{train_reduced, FixedSizePath, Reduction};
use rlg_train::lssvm::tune::{by_sigma, CvPoint, Tuned, PARSIMONY};
use rlg_train::model::{ModelFile, Provenance};

use crate::cv::cv_rms_many;
use crate::error::{ensure, CalibrateError};
use crate::options::Options;
use crate::result::BoardChoice;
use crate::sets::TrainingSets;

/// A table may depart in f32 by this fraction of the record's 1 s noise whatever the export
/// limit: a MEMS gyro of a few hundred °/h of noise and thousands of °/h of bias gains nothing
/// from a table exact to 5e-5 °/h, and a departure a thousandth of the noise adds a millionth
/// of its variance. (A hundredth would still be harmless, but would loosen an RLG's limit,
/// whose 1 s noise is about a hundredth of a °/h.)
pub const NOISE_FRACTION: f64 = 1e-3;

/// A table may also depart in f32 by this fraction of the exact LS-SVM's CV rms: a departure
/// d adds at most d² to the mean square the CV measures, 0.04 % of it at 2 %. Where the
/// record's bias is large against its noise (a MEMS gyro's thousands of °/h over a chamber
/// cycle), the kernel sums of a well-fitting σ cancel in f32 by more than a thousandth of the
/// noise, and the table would otherwise fall back to a σ whose CV is twice the LS-SVM's. An
/// RLG's CV rms of about 1e-3 °/h gives 2e-5 °/h, under the export's own limit.
pub const CV_FRACTION: f64 = 0.02;

/// The board table, tuned as the table it is: a fixed-size model of `budget` vectors scored
/// by CV on the same folds at every point of the coarse σ × c grid and at the LS-SVM's
/// choice (a small table cannot follow a σ the exact model can, so the exact model's σ, c are
/// not assumed to suit it). The LS-SVM's choice is kept when its table scores within
/// [`PARSIMONY`] of the best, so the two rows then differ only by the reduction; otherwise
/// the best-scoring point. Points whose table departs in f32 beyond the export limit are
/// passed over, best first, unless the departure costs less than passing them over
/// ([`pick_table`]).
pub(crate) fn choose_board(
    sets: &TrainingSets,
    folds: &[Vec<usize>],
    tuned: &Tuned,
    opts: &Options,
    provenance: &Provenance,
    progress: &ProgressBar,
) -> Result<(BoardChoice, ModelFile), CalibrateError> {
    let (data, tune_data) = (&sets.data, &sets.tune);
    let (budget, rate_tau_s) = (opts.budget, opts.rate_tau_s);
    let n = tune_data.x.len();
    let exact = (tuned.sigma, tuned.c);
    let mut points: Vec<(f64, f64)> = tuned.curve.iter().map(|p| (p.sigma, p.c)).collect();
    points.push(exact);
    progress.reset();
    progress.set_message(format!("tuning the {budget}-vector table"));
    progress.set_length(points.len() as u64);
    // One task per σ: the active set and normal equations of a fold serve every c.
    let scored: Vec<CvPoint> = by_sigma(&points, |sigma, cs| {
        let cv = cv_rms_many(folds, n, &tune_data.y_dph, cs.len(), |tr, te| {
            let xs: Vec<Vec<f64>> = tr.iter().map(|&i| tune_data.x[i].clone()).collect();
            let ys: Vec<f64> = tr.iter().map(|&i| tune_data.y_dph[i]).collect();
            let opts = FixedSizeOptions::with_budget(budget.min(xs.len()));
            let Ok(path) = FixedSizePath::new(&tune_data.features, &xs, &ys, sigma, &opts) else {
                return vec![None; cs.len()];
            };
            cs.iter()
                .map(|&c| {
                    let m = path.model(c).ok()?;
                    Some(te.iter().map(|&i| m.predict(&tune_data.x[i])).collect())
                })
                .collect()
        });
        progress.inc(cs.len() as u64);
        cv
    })
    .into_iter()
    .zip(&points)
    .map(|(cv, &(sigma, c))| CvPoint {
        sigma,
        c,
        cv_rms_dph: cv.unwrap_or(f64::NAN),
    })
    .collect();
    progress.finish_and_clear();
    let exact_point = *scored.last().unwrap_or(&CvPoint {
        sigma: exact.0,
        c: exact.1,
        cv_rms_dph: f64::NAN,
    });
    let mut order: Vec<CvPoint> = scored
        .iter()
        .filter(|p| p.cv_rms_dph.is_finite())
        .copied()
        .collect();
    order.sort_by(|a, b| a.cv_rms_dph.total_cmp(&b.cv_rms_dph));
    let best = order.first().map_or(f64::NAN, |p| p.cv_rms_dph);
    if exact_point.cv_rms_dph <= best * (1.0 + PARSIMONY) {
        order.insert(0, exact_point);
    }
    let budget = budget.min(data.x.len());
    let noise_floor = (NOISE_FRACTION * sets.noise_1s_dph).max(CV_FRACTION * tuned.cv_rms_dph);
    let mut limit_dph = f64::NAN;
    let picked = pick_table(order, |p| {
        let lssvm = train_reduced(
            &data.features,
            &data.x,
            &data.y_dph,
            p.sigma,
            p.c,
            budget,
            Reduction::FIXED_SIZE,
        )?;
        let mut m = ModelFile::from_trained(
            lssvm,
            &data.x,
            &data.y_dph,
            rate_tau_s,
            data.dt_s,
            None,
            provenance.clone(),
        )?;
        m.removes = opts.remove;
        let mut prec = export::precision(&m)?;
        if noise_floor > prec.limit_dph {
            m.f32_limit_dph = Some(noise_floor);
            prec.limit_dph = noise_floor;
        }
        limit_dph = prec.limit_dph;
        Ok((m, prec.deviation_dph, prec.limit_dph))
    })?;
    let Some(mut picked) = picked else {
        return Err(CalibrateError::NoBoardTable(format!(
            "no (σ, c) of the grid gives a board table within the f32 limit of {limit_dph:.1e} \
             °/h, nor one whose departure is finite; widen the grid to smaller c with --c-min"
        )));
    };
    let raised = picked.raise_limit();
    let m = &picked.table;
    let choice = BoardChoice {
        sigma: picked.point.sigma,
        c: picked.point.c,
        cv_rms_dph: picked.point.cv_rms_dph,
        exact_choice_cv_rms_dph: exact_point.cv_rms_dph,
        support_vectors: m.lssvm.support.len(),
        f32_deviation_dph: picked.deviation_dph,
        f32_limit_dph: picked.limit_dph,
        limit_raised_from_dph: raised,
        reference_folded: export::folds_reference(m.kept_dph()),
        refused: picked.refused,
    };
    Ok((choice, picked.table))
}

/// The departure of a table's f32 evaluation is measured at its support vectors and a few
/// hundred quasi-random points of the trained box (`rlg_train::export::precision`); between
/// them it can be larger (a dense temperature sweep of a static MEMS table through the board's
/// `Compensator` finds it so). A table taken over its limit is judged, and held, at this
/// multiple of the measured figure.
pub const DEPARTURE_MARGIN: f64 = 2.0;

/// The table [`pick_table`] chose, its f32 departure and limit, and the points passed over.
pub struct Picked<T> {
    /// The chosen point of the grid and its CV rms.
    pub point: CvPoint,
    /// Its table, as `build` made it.
    pub table: T,
    /// Its f32 departure, °/h.
    pub deviation_dph: f64,
    /// The limit the table was tried against (below its departure when `over_limit`, until
    /// [`Picked::raise_limit`]).
    pub limit_dph: f64,
    /// Whether the departure is over the limit (see [`pick_table`]).
    pub over_limit: bool,
    /// Points tried and passed over: (σ, c, departure °/h).
    pub refused: Vec<(f64, f64, f64)>,
}

impl Picked<ModelFile> {
    /// A table taken over its limit carries [`DEPARTURE_MARGIN`] times its departure as the
    /// limit, so that the export accepts the table the report describes and the board is
    /// held to what the choice assumed; the limit it was over (None: it was within it).
    pub(crate) fn raise_limit(&mut self) -> Option<f64> {
        if !self.over_limit {
            return None;
        }
        let was = self.limit_dph;
        let carried = DEPARTURE_MARGIN * self.deviation_dph;
        self.table.f32_limit_dph = Some(carried);
        self.limit_dph = carried;
        Some(was)
    }
}

/// The first point of `order` (the CV's order of preference) whose table, built by `build`
/// as (table, f32 departure, limit), departs within its limit; or else a table over the
/// limit whose CV rms plus [`DEPARTURE_MARGIN`] times its departure is the least of those
/// tried, once that sum is below the CV rms of every point still to try. A departure d of the
/// f32 evaluation adds at most d to the rms of what the table leaves, so CV rms + d bounds
/// what the f32 table scores: a MEMS gyro's thousands of °/h of bias make the kernel sums of
/// every well-fitting σ, c cancel in f32 by a few °/h, and the first table within a limit of
/// a fraction of a °/h can fit ten times worse than the host model (a c of 1 on a bias moving
/// 100 °/h per °C). Within the limit, the departure is negligible by the limit's definition
/// and the CV order decides. `None`: nothing tried had a finite departure.
pub fn pick_table<T>(
    order: Vec<CvPoint>,
    mut build: impl FnMut(CvPoint) -> Result<(T, f64, f64), CalibrateError>,
) -> Result<Option<Picked<T>>, CalibrateError> {
    let mut refused = Vec::new();
    // The best table over its limit: (its bound, point, table, departure, limit, its entry
    // in `refused`).
    let mut over: Option<(f64, CvPoint, T, f64, f64, usize)> = None;
    for p in order {
        if over.as_ref().is_some_and(|o| p.cv_rms_dph >= o.0) {
            break;
        }
        let (table, dev, limit) = build(p)?;
        if dev <= limit {
            return Ok(Some(Picked {
                point: p,
                table,
                deviation_dph: dev,
                limit_dph: limit,
                over_limit: false,
                refused,
            }));
        }
        refused.push((p.sigma, p.c, dev));
        let bound = p.cv_rms_dph + DEPARTURE_MARGIN * dev;
        if bound.is_finite() && over.as_ref().is_none_or(|o| bound < o.0) {
            over = Some((bound, p, table, dev, limit, refused.len() - 1));
        }
    }
    Ok(over.map(|(_, point, table, dev, limit, entry)| {
        refused.remove(entry);
        Picked {
            point,
            table,
            deviation_dph: dev,
            limit_dph: limit,
            over_limit: true,
            refused,
        }
    }))
}

/// The board table run sample by sample through the f32 `Compensator` over the whole
/// `stream` (so the estimator's state is the board's); outputs at `keep`.
pub fn board_output(
    stream: &Recording,
    model: &ModelFile,
    keep: &[usize],
) -> Result<Vec<f64>, CalibrateError> {
    let t = export::to_f32::<2>(model)?;
    let mut comp = Compensator::new(t.as_model(), SensorLimits::DEFAULT);
    ensure!(
        comp.table_ok(),
        Internal,
        "the exported table fails the board's validation"
    );
    let mut out = Vec::with_capacity(keep.len());
    let mut next = keep.iter().peekable();
    for k in 0..stream.len() {
        let o = comp.update(stream.temp_c[k] as f32, stream.rate_dph[k] as f32);
        if next.peek() == Some(&&k) {
            out.push(f64::from(o.rate_dph));
            next.next();
        }
    }
    Ok(out)
}
