//! Calibrating a gyro of one's own: a chamber recording (and optionally a later test
//! recording) to a tuned board table, the baselines compared on the same split, and a report.
//!
//! The protocol, in the order [`calibrate`] runs it:
//! * **Input**: a continuous 1 Hz stream (time_s, rate_dph, temp_c). A bursty log (burst
//!   means minutes apart) carries no dT/dt, so it is refused here with that reason and goes
//!   to [`static_cal`], which fits a temperature-only model.
//! * **Split**: with a `--test` recording, all of the calibration recording trains and the
//!   test recording is held out. Otherwise the recording is cut into temperature cycles
//!   ([`rlg_io::cycles::cycle_spans`]); the first ⌈k/2⌉ of k cycles train (at most k − 1),
//!   the rest are held out. One cycle and no test recording: nothing is held out, and the
//!   report says so and shows cross-validated figures, labelled CV.
//! * **Inputs** of every model are the board's: recorded T and the board's causal dT/dt
//!   estimator, computed over the whole stream so its state at the split is the board's.
//! * **Tuning** of σ and c (and the polynomial's degree) on 100 s means of the training span,
//!   by leave-one-cycle-out when two or more cycles train (whole cycles, so neighbouring
//!   samples never score each other); within a single training cycle, blocked CV over
//!   runs of 10 means ([`rlg_train::protocol::CV`], the reproduction's choice).
//! * **Board table**: a fixed-size LS-SVM of at most `budget` support vectors with the tuned
//!   σ, c, exported to f32. When its f32 evaluation departs from the f64 model beyond the
//!   export limit, the next most regularised point of the CV curve that passes is taken
//!   and the report says which and why.
//! * **Comparison** on the held-out samples: raw, polynomial in T, stepwise over the paper's
//!   nine terms, the LS-SVM on [T, dT/dt] and the board table through the f32
//!   `Compensator`: bias stability over a selectable window, improvement factors, residual
//!   by heating / cooling / hold, Allan deviation.

pub mod fleet;
pub mod phases;
pub mod report;
pub mod static_cal;

use indicatif::ProgressBar;

use compensator_core::{Compensator, Feature, SensorLimits};
use rlg_eval::baselines::{paper_candidates, stepwise, PolyFit, StepwiseFit, StepwiseOptions};
use rlg_eval::metrics::allan::{octave_clusters, overlapping_adev_ci, AdevCi, CONFIDENCE_1SIGMA};
use rlg_eval::metrics::compare::improvement_factor;
use rlg_eval::metrics::stability::{bias_stability_gapless_dph, gapless_block_means, rms};
use rlg_io::cycles::cycle_spans;
use rlg_io::faults::{sensor_faults, FaultLimits, SensorFaults};
use rlg_io::recording::Recording;
use rlg_train::dataset::{self, Dataset, RecordingSelection};
use rlg_train::export;
use rlg_train::features::{self, FeatureSeries};
use rlg_train::lssvm::fixed_size::FixedSizeOptions;
use rlg_train::lssvm::sparse::{train_reduced, FixedSizePath, Reduction};
use rlg_train::lssvm::tune::{
    by_sigma, fold_indices, tune, CvPoint, Grid, Tuned, Validation, PARSIMONY,
};
use rlg_train::lssvm::Lssvm;
use rlg_train::model::{ModelFile, Provenance};
use rlg_train::protocol::{CV, RATE_TAU_S, SUPPORT_VECTORS, TRAIN_BLOCK};

use phases::PhaseRms;

/// Largest board table this tool writes, support vectors: at D = 2 a vector costs 12 bytes of
/// flash (two f32 coordinates and a coefficient), so 512 vectors are 6 KiB of the 32 KiB
/// flash budget and about 30 ms of a 1 Hz update on the Cortex-M4F.
pub const MAX_BUDGET: usize = 512;

/// Largest training set the exact LS-SVM row of the comparison is solved for; beyond it a
/// fixed-size model of [`LARGE_BUDGET`] vectors stands in (as in the reproduction).
pub const EXACT_MAX: usize = 4000;
/// See [`EXACT_MAX`].
pub const LARGE_BUDGET: usize = 512;

/// Most CV folds: beyond this many training cycles, runs of consecutive cycles are grouped.
pub const MAX_FOLDS: usize = 10;

/// Most means σ and c are tuned on (see [`calibrate`]): 1 500 means of 100 s are 42 h.
pub const MAX_TUNE_MEANS: usize = 1500;

/// Highest polynomial degree in T the polynomial baseline is chosen from.
pub const MAX_POLY_DEGREE: usize = 5;

/// Options of [`calibrate`].
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Cycles of the calibration recording that train (without a test recording); `None`:
    /// ⌈k/2⌉ of k, at most k − 1.
    pub train_cycles: Option<usize>,
    /// Stability window, samples (s at 1 Hz).
    pub window: usize,
    /// Training samples are means of this many 1 Hz samples (1: raw).
    pub block: usize,
    /// Support vectors of the board table.
    pub budget: usize,
    /// dT/dt estimator time constant, s.
    pub rate_tau_s: f64,
    /// σ × c search grid.
    pub grid: Grid,
    /// Entry / removal levels of the stepwise regression.
    pub stepwise: StepwiseOptions,
    /// Use only samples from this time on, s.
    pub from_s: Option<f64>,
    /// Use only samples up to this time, s.
    pub to_s: Option<f64>,
    /// Pool the training means into cells of temperature and dT/dt ([`pool_even`]) so that
    /// slow stretches of an uneven ramp do not dominate the fit.
    pub even_temperature: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            train_cycles: None,
            window: 100,
            block: TRAIN_BLOCK,
            budget: SUPPORT_VECTORS,
            rate_tau_s: RATE_TAU_S,
            grid: Grid::default(),
            stepwise: StepwiseOptions::default(),
            from_s: None,
            to_s: None,
            even_temperature: false,
        }
    }
}

impl Options {
    fn validate(&self) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.window >= 2,
            "the stability window must be at least 2 samples (got {})",
            self.window
        );
        anyhow::ensure!(self.block >= 1, "--block must be at least 1");
        anyhow::ensure!(
            (1..=MAX_BUDGET).contains(&self.budget),
            "--budget {}: the board table holds 1 to {MAX_BUDGET} support vectors",
            self.budget
        );
        anyhow::ensure!(
            self.rate_tau_s.is_finite() && self.rate_tau_s >= 1.0,
            "--rate-tau-s {}: the dT/dt estimator needs a time constant of at least 1 s",
            self.rate_tau_s
        );
        anyhow::ensure!(
            self.train_cycles != Some(0),
            "--train-cycles 0: at least one cycle must train"
        );
        if let (Some(a), Some(b)) = (self.from_s, self.to_s) {
            anyhow::ensure!(a < b, "--from-s {a} is not before --to-s {b}");
        }
        Ok(())
    }
}

/// What is held out.
#[derive(Clone, Debug, PartialEq)]
pub enum HeldOut {
    /// The later cycles of the calibration recording.
    Cycles {
        /// Cycles that train.
        train: usize,
        /// Cycles held out.
        test: usize,
    },
    /// A separate test recording.
    TestRecording,
    /// Nothing: one cycle and no test recording; only cross-validated figures exist.
    Nothing,
}

/// How the recording was split and the hyper-parameters scored.
#[derive(Clone, Debug, PartialEq)]
pub struct Split {
    /// What is held out.
    pub held_out: HeldOut,
    /// Temperature cycles found in the calibration recording.
    pub cycles: Vec<(f64, f64)>,
    /// Training span of the calibration recording, s.
    pub train_span_s: (f64, f64),
    /// Held-out span (of the calibration or the test recording), s.
    pub test_span_s: Option<(f64, f64)>,
    /// Training cycles that label the CV folds (1: blocked CV within the cycle).
    pub cv_groups: usize,
    /// The CV scheme, in words.
    pub validation: String,
}

/// The board table's hyper-parameters and why.
#[derive(Clone, Debug, PartialEq)]
pub struct BoardChoice {
    /// σ of the table.
    pub sigma: f64,
    /// c of the table.
    pub c: f64,
    /// CV RMS of the table at this σ, c, °/h.
    pub cv_rms_dph: f64,
    /// CV RMS of the table at the LS-SVM's σ, c, °/h.
    pub exact_choice_cv_rms_dph: f64,
    /// Support vectors.
    pub support_vectors: usize,
    /// |f32 − f64| of the table's correction over the trained range, °/h.
    pub f32_deviation_dph: f64,
    /// The export limit it was held to, °/h.
    pub f32_limit_dph: f64,
    /// Whether the table stores b − reference ([`export::folds_reference`]).
    pub reference_folded: bool,
    /// Points of the CV curve refused for f32 precision before this one, (σ, c, deviation).
    pub refused: Vec<(f64, f64, f64)>,
}

/// Held-out scores of one model.
#[derive(Clone, Debug, PartialEq)]
pub struct HeldOutScore {
    /// Bias stability of the compensated held-out output over the window, °/h.
    pub stability_dph: f64,
    /// Raw stability / this one.
    pub improvement: Option<f64>,
    /// RMS of the window means of the compensated output about their mean, by phase.
    pub phases: PhaseRms,
    /// Allan deviation of the compensated held-out output, with 1σ χ² intervals.
    pub allan: Vec<AdevCi>,
}

/// One row of the comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelRow {
    /// Name as printed.
    pub name: String,
    /// What it is, in a few words (terms, degree, σ and c).
    pub detail: String,
    /// TRAINING RMS on the training means, °/h (`None`: nothing fitted).
    pub train_rms_dph: Option<f64>,
    /// Cross-validated RMS on the tuning means, °/h (same folds for every fitted model).
    pub cv_rms_dph: Option<f64>,
    /// Held-out scores (`None` when nothing is held out).
    pub held_out: Option<HeldOutScore>,
}

/// Row names.
pub const RAW: &str = "raw";
/// See [`RAW`].
pub const POLY: &str = "polynomial in T";
/// See [`RAW`].
pub const STEPWISE: &str = "stepwise (paper's 9 terms)";
/// See [`RAW`].
pub const LSSVM: &str = "LS-SVM on [T, dT/dt]";
/// See [`RAW`].
pub const BOARD: &str = "board table (f32)";

/// The held-out stream as the figures need it: means over the stability's gap-free windows
/// (the 1 Hz series of a long record would hold most of the memory).
#[derive(Clone, Debug, PartialEq)]
pub struct HeldOutSeries {
    /// First held-out time, s.
    pub start_s: f64,
    /// Mean time of each window, s.
    pub time_s: Vec<f64>,
    /// Mean sensor temperature of each window, °C.
    pub temp_c: Vec<f64>,
    /// Phase of each window: 0 heating, 1 cooling, 2 hold ([`phases::window_phases`]).
    pub phase: Vec<usize>,
    /// Window means of the output of each row of [`Calibration::rows`] (raw first), °/h.
    pub outputs: Vec<Vec<f64>>,
}

/// The result of [`calibrate`].
#[derive(Clone, Debug)]
pub struct Calibration {
    /// Options used.
    pub options: Options,
    /// The split.
    pub split: Split,
    /// 1 Hz samples of the calibration recording.
    pub samples: usize,
    /// Training means (of `block` samples).
    pub train_samples: usize,
    /// The LS-SVM's tuning.
    pub tuned: Tuned,
    /// The board table's choice.
    pub board: BoardChoice,
    /// The board table (what `model.json` and the exported tables hold).
    pub board_model: ModelFile,
    /// Degree of the polynomial baseline and the CV RMS of each degree tried.
    pub poly_degree: usize,
    /// CV RMS of degrees 1 … [`MAX_POLY_DEGREE`], °/h.
    pub poly_cv_dph: Vec<f64>,
    /// The stepwise selection.
    pub stepwise: StepwiseFit,
    /// The comparison: raw, polynomial, stepwise, LS-SVM, board.
    pub rows: Vec<ModelRow>,
    /// The held-out stream (empty when nothing is held out).
    pub series: HeldOutSeries,
    /// Support vectors of the LS-SVM row.
    pub lssvm_support: usize,
    /// Lines the report must show (a changed choice, a caveat).
    pub notes: Vec<String>,
    /// The table on the diagnosed features, when the close loop adopts them (`rlg calibrate
    /// --diagnose`; [`calibrate`] leaves it `None`).
    pub diagnosed_board: Option<DiagnosedBoard>,
}

/// A board table on the inputs the diagnosis of the training span added (a lagged gradient,
/// a play operator, …: `compensator_core::Feature`, which the board computes from T itself),
/// written beside the [T, dT/dt] table when the close loop adopts those inputs by
/// cross-validation.
#[derive(Clone, Debug)]
pub struct DiagnosedBoard {
    /// The model its tables hold.
    pub model: ModelFile,
    /// Largest |f32 − f64| of its correction over the trained range, °/h.
    pub f32_deviation_dph: f64,
    /// The export limit it was held to, °/h.
    pub f32_limit_dph: f64,
    /// Held-out bias stability of the output compensated through the board's f32
    /// `Compensator` (None when nothing is held out), °/h.
    pub board_stability_dph: Option<f64>,
}

impl Calibration {
    /// The row named `name`.
    pub fn row(&self, name: &str) -> Option<&ModelRow> {
        self.rows.iter().find(|r| r.name == name)
    }
}

/// The median sample step of `rec`, checked to be a continuous 1 Hz stream; `what` names the
/// recording in errors.
pub fn check_stream(rec: &Recording, what: &str) -> anyhow::Result<f64> {
    anyhow::ensure!(
        rec.len() >= 2,
        "{what} has {} sample(s); a calibration needs a 1 Hz stream",
        rec.len()
    );
    let mut steps: Vec<f64> = rec.time_s.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let dt = steps[steps.len() / 2];
    anyhow::ensure!(
        dt <= 1.1,
        "{what}: samples every {dt:.3} s (median step): not a continuous 1 Hz stream (burst \
         means?), so no dT/dt model can be trained from it; give --static for a \
         temperature-only model"
    );
    anyhow::ensure!(
        dt >= 0.9,
        "{what}: samples every {dt:.3} s (median step); the board runs at 1 Hz: bring it to \
         1 Hz first with `rlg resample --period-s 1`"
    );
    Ok(dt)
}

/// The recording without the temperature samples the board's sensor rules reject
/// ([`rlg_io::faults::sensor_faults`]); they become gaps, which the features bridge as the
/// board does. A glitch left in would reach the dT/dt model (and the cycle split: a +30 °C
/// sample made a one-cycle record of a two-cycle one).
fn without_sensor_faults(
    rec: std::borrow::Cow<'_, Recording>,
    dt: f64,
) -> (std::borrow::Cow<'_, Recording>, SensorFaults) {
    let (bad, f) = sensor_faults(&rec.time_s, &rec.temp_c, dt, &FaultLimits::BOARD);
    if f.total() == 0 {
        (rec, f)
    } else {
        (std::borrow::Cow::Owned(rec.without(&bad)), f)
    }
}

fn features_of(rec: &Recording, tau: f64, dt: f64) -> anyhow::Result<FeatureSeries> {
    Ok(features::compute(
        &[Feature::TempC, Feature::TempRateCPerS],
        &rec.temp_c,
        &rec.time_s,
        tau,
        dt,
    )?)
}

/// Restricts `rec` to `[from_s, to_s]`.
fn window_of(
    rec: &Recording,
    from_s: Option<f64>,
    to_s: Option<f64>,
) -> anyhow::Result<std::borrow::Cow<'_, Recording>> {
    if from_s.is_none() && to_s.is_none() {
        return Ok(std::borrow::Cow::Borrowed(rec));
    }
    let lo = from_s.unwrap_or(f64::NEG_INFINITY);
    let hi = to_s.unwrap_or(f64::INFINITY);
    let a = rec.time_s.partition_point(|t| *t < lo);
    let b = rec.time_s.partition_point(|t| *t <= hi);
    anyhow::ensure!(
        b > a + 1,
        "no samples between --from-s {lo} and --to-s {hi} (the recording spans {} … {} s)",
        rec.time_s.first().unwrap_or(&f64::NAN),
        rec.time_s.last().unwrap_or(&f64::NAN)
    );
    let pick = |v: &Vec<f64>| v[a..b].to_vec();
    Ok(std::borrow::Cow::Owned(Recording {
        time_s: pick(&rec.time_s),
        rate_dph: pick(&rec.rate_dph),
        temp_c: pick(&rec.temp_c),
        chamber_c: rec.chamber_c.as_ref().map(pick),
        extra: Vec::new(),
        comments: rec.comments.clone(),
    }))
}

/// The training span's 100 s means and the cycle each starts in, by the rule
/// [`dataset::from_recording`] uses (warm-up dropped, consecutive kept samples averaged).
fn cycle_labels(
    rec: &Recording,
    series: &FeatureSeries,
    to_s: f64,
    block: usize,
    cycles: &[(f64, f64)],
) -> Vec<usize> {
    let keep: Vec<usize> = (0..rec.len())
        .filter(|&k| !series.warming_up[k] && rec.time_s[k] <= to_s)
        .collect();
    keep.chunks_exact(block)
        .map(|c| {
            let t = rec.time_s[c[0]];
            cycles
                .iter()
                .position(|s| t < s.1)
                .unwrap_or(cycles.len() - 1)
        })
        .collect()
}

fn col(x: &[Vec<f64>], d: usize) -> Vec<f64> {
    x.iter().map(|r| r[d]).collect()
}

/// CV RMS of a model fitted by `fit` (training indices → predictions at held-out indices).
fn cv_rms(
    folds: &[Vec<usize>],
    n: usize,
    y: &[f64],
    fit: impl Fn(&[usize], &[usize]) -> Option<Vec<f64>>,
) -> Option<f64> {
    cv_rms_many(folds, n, y, 1, |tr, te| vec![fit(tr, te)])[0]
}

/// [`cv_rms`] of `k` models fitted together per fold (`fit` gives each model's held-out
/// predictions, `None` where it failed): the same sums, model by model.
fn cv_rms_many(
    folds: &[Vec<usize>],
    n: usize,
    y: &[f64],
    k: usize,
    fit: impl Fn(&[usize], &[usize]) -> Vec<Option<Vec<f64>>>,
) -> Vec<Option<f64>> {
    let mut ss = vec![Some(0.0); k];
    let mut count = 0usize;
    for f in folds {
        let mut out = vec![false; n];
        for &i in f {
            out[i] = true;
        }
        let train: Vec<usize> = (0..n).filter(|&i| !out[i]).collect();
        let preds = fit(&train, f);
        for (s, pred) in ss.iter_mut().zip(&preds) {
            *s = match (*s, pred) {
                (Some(mut acc), Some(pred)) => {
                    for (p, &i) in pred.iter().zip(f) {
                        acc += (y[i] - p).powi(2);
                    }
                    Some(acc)
                }
                _ => None,
            };
        }
        count += f.len();
    }
    ss.into_iter()
        .map(|s| s.filter(|_| count > 0).map(|s| (s / count as f64).sqrt()))
        .collect()
}

fn poly_of(x: &[f64], y: &[f64], idx: &[usize], degree: usize) -> Option<PolyFit> {
    let xs: Vec<f64> = idx.iter().map(|&i| x[i]).collect();
    let ys: Vec<f64> = idx.iter().map(|&i| y[i]).collect();
    PolyFit::fit(&xs, &ys, degree).ok()
}

/// The board table, tuned as the table it is: a fixed-size model of `budget` vectors scored
/// by CV on the same folds at every point of the coarse σ × c grid and at the LS-SVM's
/// choice (a small table cannot follow a σ the exact model can, so the exact model's σ, c are
/// not assumed to suit it). The LS-SVM's choice is kept when its table scores within
/// [`PARSIMONY`] of the best, so the two rows then differ only by the reduction; otherwise
/// the best-scoring point. Points whose table departs in f32 beyond the export limit are
/// passed over, best first.
#[allow(clippy::too_many_arguments)]
fn choose_board(
    data: &Dataset,
    tune_data: &Dataset,
    folds: &[Vec<usize>],
    tuned: &Tuned,
    budget: usize,
    provenance: &Provenance,
    rate_tau_s: f64,
    progress: &ProgressBar,
) -> anyhow::Result<(BoardChoice, ModelFile)> {
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
    let mut refused = Vec::new();
    for p in order {
        let lssvm = train_reduced(
            &data.features,
            &data.x,
            &data.y_dph,
            p.sigma,
            p.c,
            budget,
            Reduction::FIXED_SIZE,
        )?;
        let m = ModelFile::from_trained(
            lssvm,
            &data.x,
            &data.y_dph,
            rate_tau_s,
            data.dt_s,
            None,
            provenance.clone(),
        )?;
        let prec = export::precision(&m)?;
        let dev = prec.deviation_dph;
        if dev <= prec.limit_dph {
            let choice = BoardChoice {
                sigma: p.sigma,
                c: p.c,
                cv_rms_dph: p.cv_rms_dph,
                exact_choice_cv_rms_dph: exact_point.cv_rms_dph,
                support_vectors: m.lssvm.support.len(),
                f32_deviation_dph: dev,
                f32_limit_dph: prec.limit_dph,
                reference_folded: export::folds_reference(m.reference_dph),
                refused,
            };
            return Ok((choice, m));
        }
        refused.push((p.sigma, p.c, dev));
    }
    anyhow::bail!(
        "no (σ, c) of the grid gives a board table within the f32 limit of {:.0e} °/h \
         (tried {}; smallest departure {:.2e} °/h); widen the grid to smaller c with --c-min",
        export::EXPORT_LIMIT_DPH,
        refused.len(),
        refused.iter().map(|r| r.2).fold(f64::INFINITY, f64::min)
    )
}

/// The board table run sample by sample through the f32 `Compensator` over the whole
/// `stream` (so the estimator's state is the board's); outputs at `keep`.
pub fn board_output(
    stream: &Recording,
    model: &ModelFile,
    keep: &[usize],
) -> anyhow::Result<Vec<f64>> {
    let t = export::to_f32::<2>(model)?;
    let mut comp = Compensator::new(t.as_model(), SensorLimits::DEFAULT);
    anyhow::ensure!(
        comp.table_ok(),
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

/// Allan deviation of a held-out output with 1σ intervals from the equivalent degrees of
/// freedom, noise type identified per τ as Stable32 does (the held-out span is one continuous
/// stretch of the stream; gaps are not bridged).
fn allan_of(v: &[f64]) -> Vec<AdevCi> {
    overlapping_adev_ci(v, 1.0, &octave_clusters(v.len()), CONFIDENCE_1SIGMA)
}

/// The CV scheme of the tuning means from the cycle each starts in (`labels`): leave one cycle
/// out when they span two or more, else blocked CV ([`rlg_train::protocol::CV`]); with the
/// number of groups (1 for blocked).
fn validation_of(labels: &[usize]) -> anyhow::Result<(Validation, usize)> {
    let n_tune = labels.len();
    let mut distinct = labels.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    let out = if distinct.len() > MAX_FOLDS {
        // Many cycles: runs of consecutive whole cycles form MAX_FOLDS groups, so the cost
        // stays that of MAX_FOLDS fits per grid point and no cycle is split.
        let g = distinct.len();
        let grouped: Vec<usize> = labels
            .iter()
            .map(|l| distinct.partition_point(|d| d < l) * MAX_FOLDS / g)
            .collect();
        (Validation::Groups(grouped), MAX_FOLDS)
    } else if distinct.len() >= 2 {
        (Validation::Groups(labels.to_vec()), distinct.len())
    } else {
        (CV, 1)
    };
    anyhow::ensure!(
        fold_indices(&out.0, n_tune).is_ok(),
        "the training span holds {n_tune} training means; tuning needs at least 50 (about \
         1.4 h of 100 s means at 1 Hz after the dT/dt warm-up)"
    );
    Ok(out)
}

/// Pools training means into cells of one cycle, 1 °C of T and a tenth of the largest
/// |dT/dt|, each cell one mean (`--even-temperature`): a slow stretch of an uneven ramp then
/// weighs as much as a fast one at the same temperature and rate, instead of as many times
/// more as it has means. Returns the pooled set and each cell's cycle, in (cycle, T, dT/dt)
/// order.
pub fn pool_even(d: &Dataset, labels: &[usize]) -> (Dataset, Vec<usize>) {
    use std::collections::BTreeMap;
    let rate_step = 0.1
        * d.x
            .iter()
            .map(|r| r[1].abs())
            .fold(0.0, f64::max)
            .max(1e-12);
    // (cycle, T bin, dT/dt bin) → (sum of x, sum of y, count).
    type Cell = (Vec<f64>, f64, usize);
    let mut cells: BTreeMap<(usize, i64, i64), Cell> = BTreeMap::new();
    for ((x, y), &g) in d.x.iter().zip(&d.y_dph).zip(labels) {
        let key = (g, x[0].floor() as i64, (x[1] / rate_step).round() as i64);
        let e = cells
            .entry(key)
            .or_insert_with(|| (vec![0.0; x.len()], 0.0, 0));
        for (s, v) in e.0.iter_mut().zip(x) {
            *s += v;
        }
        e.1 += y;
        e.2 += 1;
    }
    let mut out = Dataset {
        features: d.features.clone(),
        x: Vec::with_capacity(cells.len()),
        y_dph: Vec::with_capacity(cells.len()),
        dt_s: d.dt_s,
    };
    let mut groups = Vec::with_capacity(cells.len());
    for ((g, _, _), (sx, sy, n)) in cells {
        let k = n as f64;
        out.x.push(sx.iter().map(|v| v / k).collect());
        out.y_dph.push(sy / k);
        groups.push(g);
    }
    (out, groups)
}

/// σ and c of an exact LS-SVM on [T, dT/dt] for the span `[from_s, to_s]` of `rec`, by the
/// calibration's CV (whole cycles when the span holds two or more, see [`calibrate`]) on its
/// 100 s means (longer ones beyond [`MAX_TUNE_MEANS`], runs of cycles beyond [`MAX_FOLDS`]):
/// what `rlg train` uses when σ and c are not given.
pub fn tune_recording(
    rec: &Recording,
    from_s: Option<f64>,
    to_s: Option<f64>,
    rate_tau_s: f64,
    grid: &Grid,
    progress: &ProgressBar,
) -> anyhow::Result<Tuned> {
    let rec = window_of(rec, from_s, to_s)?;
    let dt = check_stream(&rec, "the recording")?;
    let series = features_of(&rec, rate_tau_s, dt)?;
    let cycles = cycle_spans(&rec.time_s, &rec.temp_c);
    let sel = |block| RecordingSelection {
        from_s: None,
        to_s: None,
        block,
        rate_tau_s,
    };
    // At most MAX_TUNE_MEANS means, as `calibrate` tunes.
    let mut block = TRAIN_BLOCK;
    let mut data = dataset::from_recording(&rec, &sel(block))?;
    if data.x.len() > MAX_TUNE_MEANS {
        block *= data.x.len().div_ceil(MAX_TUNE_MEANS);
        data = dataset::from_recording(&rec, &sel(block))?;
    }
    let t_end = *rec.time_s.last().unwrap_or(&0.0);
    let labels = cycle_labels(&rec, &series, t_end, block, &cycles);
    anyhow::ensure!(
        labels.len() == data.x.len(),
        "internal: {} cycle labels for {} tuning means",
        labels.len(),
        data.x.len()
    );
    let (validation, _) = validation_of(&labels)?;
    let tuned = tune(
        &data.features,
        &data.x,
        &data.y_dph,
        &validation,
        grid,
        progress,
    )?;
    progress.finish_and_clear();
    Ok(tuned)
}

/// Runs the calibration (see the module doc). `cal` trains; `test`, when given, is held out.
/// `progress` follows the σ, c search. `provenance` labels the board table.
pub fn calibrate(
    cal: &Recording,
    test: Option<&Recording>,
    opts: &Options,
    provenance: &Provenance,
    progress: &ProgressBar,
) -> anyhow::Result<Calibration> {
    opts.validate()?;
    let cal = window_of(cal, opts.from_s, opts.to_s)?;
    let dt = check_stream(&cal, "the calibration recording")?;
    let (cal, cal_faults) = without_sensor_faults(cal, dt);
    let series = features_of(&cal, opts.rate_tau_s, dt)?;
    let cycles = cycle_spans(&cal.time_s, &cal.temp_c);
    let k = cycles.len();
    let t0 = cal.time_s[0];
    let t_end = *cal.time_s.last().unwrap_or(&t0);
    let mut notes = Vec::new();
    if cal_faults.total() > 0 {
        notes.push(format!("Calibration recording: {}.", cal_faults.describe()));
    }

    // The split.
    let (held_out, train_end) = match test {
        Some(_) => (HeldOut::TestRecording, f64::INFINITY),
        None if k >= 2 => {
            let n_train = match opts.train_cycles {
                Some(n) => {
                    anyhow::ensure!(
                        n < k,
                        "--train-cycles {n}: the recording has {k} temperature cycles; train on \
                         fewer to leave one held out, or give --test"
                    );
                    n
                }
                None => k.div_ceil(2).min(k - 1),
            };
            (
                HeldOut::Cycles {
                    train: n_train,
                    test: k - n_train,
                },
                cycles[n_train - 1].1,
            )
        }
        None => {
            notes.push(format!(
                "No held-out data: the recording is one temperature cycle and no --test was \
                 given. Every figure below is TRAINING or cross-validated (CV, {} of the \
                 cycle); record another cycle or a later run to measure held-out stability.",
                "blocked folds"
            ));
            (HeldOut::Nothing, f64::INFINITY)
        }
    };
    let train_cycles = match held_out {
        HeldOut::Cycles { train, .. } => train,
        _ => k,
    };
    let to_s = train_end.is_finite().then_some(train_end);
    let sel = |block| RecordingSelection {
        from_s: None,
        to_s,
        block,
        rate_tau_s: opts.rate_tau_s,
    };
    let mut data = dataset::from_recording(&cal, &sel(opts.block))?;
    // Tuning solves the exact LS-SVM per fold and grid point, cubic in its size: a long
    // training span is tuned on longer means so that at most MAX_TUNE_MEANS remain.
    let mut tune_block = TRAIN_BLOCK;
    let mut tune_data = dataset::from_recording(&cal, &sel(tune_block))?;
    if tune_data.x.len() > MAX_TUNE_MEANS {
        tune_block *= tune_data.x.len().div_ceil(MAX_TUNE_MEANS);
        tune_data = dataset::from_recording(&cal, &sel(tune_block))?;
        notes.push(format!(
            "The training span is long: σ, c and the polynomial's degree are tuned on {} means \
             of {tune_block} s (at most {MAX_TUNE_MEANS}) rather than 100 s means.",
            tune_data.x.len()
        ));
    }
    let train_cyc = &cycles[..train_cycles.min(k)];
    let labels_of = |block: usize, n: usize| -> anyhow::Result<Vec<usize>> {
        let l = cycle_labels(&cal, &series, train_end.min(t_end), block, train_cyc);
        anyhow::ensure!(
            l.len() == n,
            "internal: {} cycle labels for {n} training means",
            l.len()
        );
        Ok(l)
    };
    let mut tune_labels = labels_of(tune_block, tune_data.x.len())?;
    if opts.even_temperature {
        let data_labels = labels_of(opts.block, data.x.len())?;
        let before = data.x.len();
        data = pool_even(&data, &data_labels).0;
        (tune_data, tune_labels) = pool_even(&tune_data, &tune_labels);
        notes.push(format!(
            "Training weighted evenly over temperature (--even-temperature): {before} training \
             means pooled into {} cells of one cycle, 1 °C and a tenth of the largest |dT/dt|, \
             one mean each.",
            data.x.len()
        ));
    }
    let n_tune = tune_data.x.len();
    let (validation, cv_groups) = validation_of(&tune_labels)?;
    let folds = fold_indices(&validation, n_tune)?;

    // The LS-SVM: σ and c by CV, then the model.
    let tuned = tune(
        &tune_data.features,
        &tune_data.x,
        &tune_data.y_dph,
        &validation,
        &opts.grid,
        progress,
    )?;
    progress.finish_and_clear();
    let (names, x, y) = (&data.features, &data.x, &data.y_dph);
    let lssvm = if x.len() <= EXACT_MAX {
        Lssvm::train(names, x, y, tuned.sigma, tuned.c)?
    } else {
        train_reduced(
            names,
            x,
            y,
            tuned.sigma,
            tuned.c,
            LARGE_BUDGET,
            Reduction::FIXED_SIZE,
        )?
    };
    let (board, board_model) = choose_board(
        &data,
        &tune_data,
        &folds,
        &tuned,
        opts.budget,
        provenance,
        opts.rate_tau_s,
        progress,
    )?;
    let exact_refused = board
        .refused
        .iter()
        .find(|r| (r.0, r.1) == (tuned.sigma, tuned.c));
    let passed_over = |n: usize| {
        format!(
            "{n} better-scoring point(s) of the grid passed over: their tables depart in f32 by \
             up to {:.2e} °/h",
            board.refused.iter().map(|r| r.2).fold(0.0, f64::max)
        )
    };
    if let Some(r) = exact_refused {
        notes.push(format!(
            "At the LS-SVM's σ = {:.3}, c = {:.3} the {}-vector table's f32 evaluation departs \
             from its f64 model by {:.2e} °/h (limit {:.1e}); the table uses σ = {:.3}, c = {:.3}, \
             the best point of the table's own CV that meets the limit (CV rms {:.3e} °/h; {}).",
            tuned.sigma,
            tuned.c,
            board.support_vectors,
            r.2,
            board.f32_limit_dph,
            board.sigma,
            board.c,
            board.cv_rms_dph,
            passed_over(board.refused.len())
        ));
    } else if (board.sigma, board.c) != (tuned.sigma, tuned.c) {
        notes.push(format!(
            "The board table uses σ = {:.3}, c = {:.3}, chosen by the CV of the {}-vector table \
             itself (CV rms {:.3e} °/h; at the LS-SVM's σ = {:.3}, c = {:.3} the table scores \
             {:.3e} °/h){}.",
            board.sigma,
            board.c,
            board.support_vectors,
            board.cv_rms_dph,
            tuned.sigma,
            tuned.c,
            board.exact_choice_cv_rms_dph,
            if board.refused.is_empty() {
                String::new()
            } else {
                format!("; {}", passed_over(board.refused.len()))
            }
        ));
    }

    // Polynomial in T: degree by CV on the same folds.
    let tt = col(&tune_data.x, 0);
    let poly_cv_dph: Vec<f64> = (1..=MAX_POLY_DEGREE)
        .map(|d| {
            cv_rms(&folds, n_tune, &tune_data.y_dph, |tr, te| {
                let p = poly_of(&tt, &tune_data.y_dph, tr, d)?;
                Some(te.iter().map(|&i| p.predict(tt[i])).collect())
            })
            .unwrap_or(f64::NAN)
        })
        .collect();
    let best = poly_cv_dph
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(f64::INFINITY, f64::min);
    anyhow::ensure!(best.is_finite(), "no polynomial in T could be fitted");
    let poly_degree = 1 + poly_cv_dph
        .iter()
        .position(|v| *v <= best * (1.0 + PARSIMONY))
        .unwrap_or(0);
    let all: Vec<usize> = (0..y.len()).collect();
    let poly = poly_of(&col(x, 0), y, &all, poly_degree)
        .ok_or_else(|| anyhow::anyhow!("the polynomial in T could not be fitted"))?;

    // Stepwise over the paper's nine terms; its CV re-runs the selection in every fold.
    let cand = paper_candidates(&col(x, 0), &col(x, 1))?;
    let sw = stepwise(&cand, y, &opts.stepwise)?;
    let tune_cand = paper_candidates(&tt, &col(&tune_data.x, 1))?;
    let sw_cv = cv_rms(&folds, n_tune, &tune_data.y_dph, |tr, te| {
        let pick = |idx: &[usize]| -> Vec<_> {
            tune_cand
                .iter()
                .map(|c| {
                    let mut c = c.clone();
                    c.values = idx.iter().map(|&i| c.values[i]).collect();
                    c
                })
                .collect()
        };
        let ytr: Vec<f64> = tr.iter().map(|&i| tune_data.y_dph[i]).collect();
        let f = stepwise(&pick(tr), &ytr, &opts.stepwise).ok()?;
        f.fit.predict(&pick(te)).ok()
    });
    let poly_cv = poly_cv_dph[poly_degree - 1];

    // The held-out stream.
    let test_series;
    let test_clean;
    let (stream, stream_series, start): (&Recording, &FeatureSeries, usize) = match test {
        Some(t) => {
            let dt_t = check_stream(t, "the test recording")?;
            let (t, f) = without_sensor_faults(std::borrow::Cow::Borrowed(t), dt_t);
            if f.total() > 0 {
                notes.push(format!("Test recording: {}.", f.describe()));
            }
            test_clean = t;
            test_series = features_of(&test_clean, opts.rate_tau_s, dt_t)?;
            (&*test_clean, &test_series, 0)
        }
        None => {
            // The reproduction's rule: samples from the cycle boundary on are held out.
            let s = cal.time_s.partition_point(|t| *t < train_end);
            (&cal, &series, s)
        }
    };
    let keep: Vec<usize> = (start..stream.len())
        .filter(|&k| !stream_series.warming_up[k])
        .collect();
    let has_test = !matches!(held_out, HeldOut::Nothing);
    anyhow::ensure!(
        !has_test || keep.len() >= 2 * opts.window,
        "the held-out part has {} samples after the dT/dt warm-up, fewer than two stability \
         windows of {}",
        keep.len(),
        opts.window
    );
    // Each model's held-out output is made, scored and reduced to window means in turn, so
    // that only one 1 Hz output is held at a time.
    let w = opts.window;
    let time: Vec<f64> = keep.iter().map(|&k| stream.time_s[k]).collect();
    let rate: Vec<f64> = keep.iter().map(|&k| stream_series.rows[k][1]).collect();
    // In parallel: a 512-vector LS-SVM over a million held-out samples is 5·10⁸ kernel
    // values; the outputs are the serial ones (each sample on its own).
    let compensate = |pred: &(dyn Fn(&[f64]) -> f64 + Sync)| -> Vec<f64> {
        use rayon::prelude::*;
        keep.par_iter()
            .map(|&k| stream.rate_dph[k] - pred(&stream_series.rows[k]))
            .collect()
    };
    let raw: Vec<f64> = keep.iter().map(|&k| stream.rate_dph[k]).collect();
    let raw_b = has_test
        .then(|| bias_stability_gapless_dph(&time, &raw, w))
        .flatten();
    let score = |out: &[f64]| -> Option<HeldOutScore> {
        if !has_test || out.is_empty() {
            return None;
        }
        let b = bias_stability_gapless_dph(&time, out, w).unwrap_or(f64::NAN);
        Some(HeldOutScore {
            stability_dph: b,
            improvement: raw_b.and_then(|r| improvement_factor(r, b)),
            phases: phases::phase_rms(&time, &rate, out, w),
            allan: allan_of(out),
        })
    };
    let mut means = Vec::new();
    let mut judge = |out: Vec<f64>| {
        let s = score(&out);
        means.push(if s.is_some() {
            gapless_block_means(&time, &out, w)
        } else {
            Vec::new()
        });
        s
    };
    let held_raw = judge(raw);
    let held_poly = judge(compensate(&|r| poly.predict(r[0])));
    // Stepwise's nine candidate columns, formed a chunk of samples at a time.
    let mut sw_out = Vec::with_capacity(keep.len());
    for chunk in keep.chunks(1 << 16) {
        let col =
            |d: usize| -> Vec<f64> { chunk.iter().map(|&k| stream_series.rows[k][d]).collect() };
        match paper_candidates(&col(0), &col(1)) {
            Ok(c) => {
                let p = sw.fit.predict(&c)?;
                sw_out.extend(chunk.iter().zip(&p).map(|(&k, p)| stream.rate_dph[k] - p));
            }
            // A held-out span with constant T cannot form the candidates.
            Err(e) if has_test => return Err(e.into()),
            Err(_) => {
                sw_out.clear();
                break;
            }
        }
    }
    let held_sw = judge(sw_out);
    let lssvm_at = lssvm.predictor();
    let held_ls = judge(compensate(&|r| lssvm_at.predict(r)));
    let held_board = judge(if has_test {
        board_output(stream, &board_model, &keep)?
    } else {
        Vec::new()
    });
    let outputs = means;
    let resid = |pred: &dyn Fn(&[f64]) -> f64, xx: &[Vec<f64>]| -> Option<f64> {
        let r: Vec<f64> = xx.iter().zip(y).map(|(r, y)| y - pred(r)).collect();
        rms(&r)
    };
    let rows = vec![
        ModelRow {
            name: RAW.into(),
            detail: "uncompensated output".into(),
            train_rms_dph: None,
            cv_rms_dph: None,
            held_out: held_raw,
        },
        ModelRow {
            name: POLY.into(),
            detail: format!("degree {poly_degree} (by CV of degrees 1–{MAX_POLY_DEGREE})"),
            train_rms_dph: resid(&|r| poly.predict(r[0]), x),
            cv_rms_dph: Some(poly_cv),
            held_out: held_poly,
        },
        ModelRow {
            name: STEPWISE.into(),
            detail: if sw.fit.terms.is_empty() {
                "intercept only".into()
            } else {
                sw.fit.terms.join(", ")
            },
            train_rms_dph: rms(&sw.fit.residuals),
            cv_rms_dph: sw_cv,
            held_out: held_sw,
        },
        ModelRow {
            name: LSSVM.into(),
            detail: format!(
                "σ = {:.3}, c = {:.3}, {} support vectors",
                tuned.sigma,
                tuned.c,
                lssvm.support.len()
            ),
            train_rms_dph: resid(&|r| lssvm.predict(r), x),
            cv_rms_dph: Some(tuned.cv_rms_dph),
            held_out: held_ls,
        },
        ModelRow {
            name: BOARD.into(),
            detail: format!(
                "fixed-size, {} vectors, σ = {:.3}, c = {:.3}",
                board.support_vectors, board.sigma, board.c
            ),
            train_rms_dph: Some(board_model.training.rms_dph),
            cv_rms_dph: Some(board.cv_rms_dph),
            held_out: held_board,
        },
    ];
    let (test_span_s, series_out) = if has_test {
        let temp: Vec<f64> = keep.iter().map(|&k| stream.temp_c[k]).collect();
        (
            Some((time[0], *time.last().unwrap_or(&time[0]))),
            HeldOutSeries {
                start_s: time[0],
                time_s: gapless_block_means(&time, &time, w),
                temp_c: gapless_block_means(&time, &temp, w),
                phase: phases::window_phases(&time, &rate, w),
                outputs,
            },
        )
    } else {
        (
            None,
            HeldOutSeries {
                start_s: f64::NAN,
                time_s: Vec::new(),
                temp_c: Vec::new(),
                phase: Vec::new(),
                outputs: Vec::new(),
            },
        )
    };
    Ok(Calibration {
        options: opts.clone(),
        split: Split {
            held_out,
            cycles,
            train_span_s: (t0, train_end.min(t_end)),
            test_span_s,
            cv_groups,
            validation: validation.describe(),
        },
        samples: cal.len(),
        train_samples: x.len(),
        tuned,
        board,
        board_model,
        poly_degree,
        poly_cv_dph,
        stepwise: sw,
        rows,
        series: series_out,
        lssvm_support: lssvm.support.len(),
        diagnosed_board: None,
        notes,
    })
}

#[cfg(test)]
mod tests;
