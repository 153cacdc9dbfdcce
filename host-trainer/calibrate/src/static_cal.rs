//! Static characterisation: a temperature-only model from points of (T, mean output), for
//! logs that carry no continuous 1 Hz stream (a MEMS thermal-vacuum log of bursts every few
//! minutes, reduced to burst means by `rlg resample --bursts`) or for soak plateaus.
//!
//! * Points: each row of a sparse recording (median step above 1.1 s) is one point; a
//!   continuous 1 Hz recording is reduced to means of `block` samples over its soak plateaus
//!   (blocks over which T moves less than [`PLATEAU_MAX_C`]), or over all of it when it has
//!   fewer than [`MIN_PLATEAU_POINTS`] such blocks.
//! * Models: a polynomial in T (degree by CV) and the LS-SVM on [T] with a linear trend in T
//!   beside the kernel ([`train_with_trend`]: a steep absolute trend is one coefficient rather
//!   than kernel coefficients that cancel in f32), σ and c by CV; exact up to `budget` points,
//!   else fixed-size with `budget` vectors. Both on the same folds. Points
//!   neighbouring in time share slow noise, so the folds leave out runs of consecutive points
//!   (5 folds, runs of n/25); below 25 points the points are taken as independent
//!   (closed-form leave-one-out for the LS-SVM, the same left-out point for the polynomial).
//! * The board table is the LS-SVM's. Its output is checked in f32 as for the dynamic table;
//!   a gyro whose output sits far from zero stores b − reference
//!   ([`rlg_train::export::folds_reference`]), so its correction keeps its precision.

use indicatif::ProgressBar;

use compensator_core::Feature;
use rlg_eval::metrics::stability::rms;
use rlg_io::recording::Recording;
use rlg_train::export::{self, Precision};
use rlg_train::lssvm::sparse::train_with_trend;
use rlg_train::lssvm::tune::{
    fold_indices, log_space, CvPoint, Grid, Tuned, Validation, PARSIMONY,
};
use rlg_train::model::{ModelFile, Provenance, Removal};

use crate::cv::{poly_cv_dph, poly_degree, poly_of};
use crate::error::{ensure, CalibrateError};
use crate::phases::classify;

/// A block of a continuous stream is a soak plateau when T moves less than this over it, °C.
pub const PLATEAU_MAX_C: f64 = 0.05;
/// Fewest plateau blocks for a model on plateaus alone.
pub const MIN_PLATEAU_POINTS: usize = 10;

/// Options of [`calibrate_static`].
#[derive(Clone, Debug, PartialEq)]
pub struct StaticOptions {
    /// Means of this many samples per point for a continuous 1 Hz recording.
    pub block: usize,
    /// Support vectors of the board table.
    pub budget: usize,
    /// σ × c grid.
    pub grid: Grid,
    /// The dT/dt estimator's time constant written into the table (the board runs it for its
    /// status flags even when the model does not use dT/dt), s.
    pub rate_tau_s: f64,
    /// What the board table removes ([`crate::Options::remove`]).
    pub remove: Removal,
}

impl Default for StaticOptions {
    fn default() -> Self {
        StaticOptions {
            block: rlg_train::protocol::TRAIN_BLOCK,
            budget: rlg_train::protocol::SUPPORT_VECTORS,
            grid: Grid::default(),
            rate_tau_s: rlg_train::protocol::RATE_TAU_S,
            remove: Removal::Variation,
        }
    }
}

/// The result of [`calibrate_static`].
#[derive(Clone, Debug)]
pub struct StaticCalibration {
    /// Points trained on: (T °C, output °/h).
    pub points: Vec<(f64, f64)>,
    /// Each point's phase: 0 heating, 1 cooling, 2 hold.
    pub point_phases: Vec<usize>,
    /// How the points were made, in words.
    pub points_from: String,
    /// The CV scheme, in words.
    pub validation: String,
    /// Chosen polynomial degree and the CV RMS of degrees 1 … [`crate::MAX_POLY_DEGREE`], °/h.
    pub poly_degree: usize,
    /// See [`StaticCalibration::poly_degree`].
    pub poly_cv_dph: Vec<f64>,
    /// TRAINING RMS of the polynomial, °/h.
    pub poly_train_rms_dph: f64,
    /// The LS-SVM's tuning.
    pub tuned: Tuned,
    /// σ, c and CV RMS of the table (the tuning's choice unless its f32 evaluation failed).
    pub table_point: CvPoint,
    /// Better-scoring points passed over for f32 precision: (σ, c, departure °/h).
    pub refused: Vec<(f64, f64, f64)>,
    /// The board model (features [temp_c]).
    pub model: ModelFile,
    /// |f32 − f64| of the board's correction over the trained range, °/h.
    pub f32_deviation_dph: f64,
    /// The limit it was held to ([`export::Precision::limit_dph`]), °/h.
    pub f32_limit_dph: f64,
    /// Whether the table stores b − reference.
    pub reference_folded: bool,
    /// HELD-OUT RMS on the test points (polynomial, LS-SVM), °/h, when a test was given.
    pub held_out_rms_dph: Option<(f64, f64)>,
    /// Test points, when given.
    pub test_points: Vec<(f64, f64)>,
    /// How the logs were reduced before the points were taken (bursts to their means, a fast
    /// stream to 1 s means); empty when read as they are.
    pub notes: Vec<String>,
}

/// The (T, output) points of a record, how they were made and each one's thermal phase.
#[derive(Clone, Debug, PartialEq)]
pub struct StaticPoints {
    /// (T °C, output °/h), in time order.
    pub points: Vec<(f64, f64)>,
    /// How they were made, in words.
    pub from: String,
    /// Each point's phase: 0 heating, 1 cooling, 2 hold ([`crate::phases::classify`] of the
    /// temperature's rate across it, or between its neighbours for one row per point).
    pub phases: Vec<usize>,
}

/// The temperature's mean rate from sample `a` to sample `b` of `rec`, °C/s (0 over no time).
fn rate_between(rec: &Recording, a: usize, b: usize) -> f64 {
    let span = rec.time_s[b] - rec.time_s[a];
    if span > 0.0 {
        (rec.temp_c[b] - rec.temp_c[a]) / span
    } else {
        0.0
    }
}

/// The (T, output) points of `rec` (see the module doc).
pub fn points_of(rec: &Recording, block: usize) -> Result<StaticPoints, CalibrateError> {
    ensure!(block >= 1, Option, "--block must be at least 1");
    let good: Vec<usize> = (0..rec.len())
        .filter(|&k| rec.temp_c[k].is_finite() && rec.rate_dph[k].is_finite())
        .collect();
    ensure!(
        good.len() >= 2,
        Input,
        "{} usable rows (finite temperature and rate); a static model needs points at several \
         temperatures",
        good.len()
    );
    let mut steps: Vec<f64> = rec.time_s.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let dt = steps.get(steps.len() / 2).copied().unwrap_or(1.0);
    if dt > 1.1 {
        let points = good
            .iter()
            .map(|&k| (rec.temp_c[k], rec.rate_dph[k]))
            .collect();
        // A row's rate of temperature: between its neighbours (one-sided at the ends).
        let rates: Vec<f64> = (0..good.len())
            .map(|i| {
                let (a, b) = (good[i.saturating_sub(1)], good[(i + 1).min(good.len() - 1)]);
                rate_between(rec, a, b)
            })
            .collect();
        return Ok(StaticPoints {
            points,
            from: format!("each row a point (a row every {dt:.0} s: burst or plateau means)"),
            phases: classify(&rates, &rates),
        });
    }
    // Soak plateaus: blocks over which the temperature moved less than PLATEAU_MAX_C, so the
    // rate terms a static model leaves out are near zero in them. Without enough such blocks
    // (a record of ramps only), every block is taken, and the description says so.
    let mean = |c: &[usize], v: &[f64]| c.iter().map(|&k| v[k]).sum::<f64>() / c.len() as f64;
    let blocks: Vec<&[usize]> = good.chunks_exact(block).collect();
    let held: Vec<(f64, f64)> = blocks
        .iter()
        .filter(|c| (rec.temp_c[c[c.len() - 1]] - rec.temp_c[c[0]]).abs() < PLATEAU_MAX_C)
        .map(|c| (mean(c, &rec.temp_c), mean(c, &rec.rate_dph)))
        .collect();
    if held.len() >= MIN_PLATEAU_POINTS {
        let n_held = held.len();
        return Ok(StaticPoints {
            phases: vec![2; n_held],
            points: held,
            from: format!(
                "means of {block} samples of a 1 Hz stream where T moved less than \
                 {PLATEAU_MAX_C} °C (soak plateaus; {n_held} of {} blocks)",
                blocks.len()
            ),
        });
    }
    let points: Vec<(f64, f64)> = blocks
        .iter()
        .map(|c| (mean(c, &rec.temp_c), mean(c, &rec.rate_dph)))
        .collect();
    let rates: Vec<f64> = blocks
        .iter()
        .map(|c| rate_between(rec, c[0], c[c.len() - 1]))
        .collect();
    Ok(StaticPoints {
        points,
        from: format!(
            "means of {block} samples of a 1 Hz stream, ramps included (only {} blocks held T \
             within {PLATEAU_MAX_C} °C)",
            held.len()
        ),
        phases: classify(&rates, &rates),
    })
}

fn validation_for(n: usize) -> Validation {
    if n < 25 {
        Validation::LeaveOneOut
    } else {
        Validation::Blocked {
            block: (n / 25).max(1),
            folds: 5,
        }
    }
}

/// Largest number of points the static grid search solves exactly.
pub const MAX_POINTS: usize = 4000;

/// The points, and as the models take them: T as the one feature.
struct Points {
    /// (T °C, output °/h).
    raw: Vec<(f64, f64)>,
    /// Each point's phase (see [`StaticPoints::phases`]).
    phases: Vec<usize>,
    /// How they were made, in words.
    from: String,
    names: Vec<String>,
    x: Vec<Vec<f64>>,
    y: Vec<f64>,
    t: Vec<f64>,
}

/// The points of `cal`, checked: enough of them, over a sweep of temperature, few enough to
/// solve exactly.
fn checked_points(cal: &Recording, block: usize) -> Result<Points, CalibrateError> {
    let StaticPoints {
        points,
        from: points_from,
        phases,
    } = points_of(cal, block)?;
    let n = points.len();
    let (lo, hi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
    ensure!(
        hi - lo >= 1.0,
        Input,
        "the points span {:.2} °C of temperature; a temperature model needs a sweep of at \
         least 1 °C",
        hi - lo
    );
    ensure!(
        n >= 5,
        Input,
        "{n} points; a static model needs at least 5 (tuning leaves some out)"
    );
    Ok(Points {
        names: vec![Feature::TempC.name().to_string()],
        x: points.iter().map(|p| vec![p.0]).collect(),
        y: points.iter().map(|p| p.1).collect(),
        t: points.iter().map(|p| p.0).collect(),
        raw: points,
        phases,
        from: points_from,
    })
}

/// A note when the heating and the cooling points sit apart about the temperature-only fit `f`:
/// their mean residuals differ by over four standard errors (on at least five points each), a
/// loop the model fits straight through. Points neighbouring in time share slow noise, so the
/// standard error is optimistic; the note warns, it does not claim a mechanism.
fn loop_note(p: &Points, f: &dyn Fn(f64) -> f64) -> Option<String> {
    let branch = |phase: usize| -> Option<(f64, f64, usize)> {
        let r: Vec<f64> = p
            .raw
            .iter()
            .zip(&p.phases)
            .filter(|(_, k)| **k == phase)
            .map(|((t, y), _)| y - f(*t))
            .collect();
        let n = r.len();
        (n >= 5).then(|| {
            let m = r.iter().sum::<f64>() / n as f64;
            let v = r.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1) as f64;
            (m, v / n as f64, n)
        })
    };
    let ((mh, vh, nh), (mc, vc, nc)) = (branch(0)?, branch(1)?);
    let (gap, se) = (mh - mc, (vh + vc).sqrt());
    (gap.abs() > 4.0 * se).then(|| {
        format!(
            "The heating points ({nh}) sit {gap:+.3e} °/h from the cooling points ({nc}) about \
             the temperature-only fit ({:.1} standard errors): a heating/cooling loop a model of \
             T alone fits straight through. A record sampled throughout calibrates with dT/dt \
             without --static, and `--diagnose` models a loop where cross-validation adopts it.",
            gap.abs() / se
        )
    })
}

/// σ and c of the LS-SVM with a linear trend in T ([`train_with_trend`]) by CV over the coarse
/// grid (in parallel); the choice is the most regularised point within [`PARSIMONY`] of the
/// best, as [`rlg_train::lssvm::tune::tune`] chooses.
fn tune_with_trend(
    p: &Points,
    (validation, folds): (&Validation, &[Vec<usize>]),
    grid: &Grid,
    budget: usize,
    progress: &ProgressBar,
) -> Tuned {
    use rayon::prelude::*;
    let (names, x, y) = (&p.names, &p.x, &p.y);
    let n = x.len();
    let pairs: Vec<(f64, f64)> = log_space(grid.sigma.0, grid.sigma.1, grid.sigma_points)
        .into_iter()
        .flat_map(|s| {
            log_space(grid.c.0, grid.c.1, grid.c_points)
                .into_iter()
                .map(move |c| (s, c))
        })
        .collect();
    progress.set_length(pairs.len() as u64);
    let curve: Vec<CvPoint> = pairs
        .par_iter()
        .map(|&(sigma, c)| {
            let mut ss = 0.0;
            let mut count = 0usize;
            let mut ok = true;
            for f in folds {
                let mut out = vec![false; n];
                for &i in f {
                    out[i] = true;
                }
                let tr: Vec<usize> = (0..n).filter(|&i| !out[i]).collect();
                let xs: Vec<Vec<f64>> = tr.iter().map(|&i| x[i].clone()).collect();
                let ys: Vec<f64> = tr.iter().map(|&i| y[i]).collect();
                match train_with_trend(names, &xs, &ys, sigma, c, budget, &[true]) {
                    Ok(m) => {
                        for &i in f {
                            ss += (y[i] - m.predict(&x[i])).powi(2);
                            count += 1;
                        }
                    }
                    Err(_) => ok = false,
                }
            }
            progress.inc(1);
            CvPoint {
                sigma,
                c,
                cv_rms_dph: if ok && count > 0 {
                    (ss / count as f64).sqrt()
                } else {
                    f64::NAN
                },
            }
        })
        .collect();
    let best = curve
        .iter()
        .map(|p| p.cv_rms_dph)
        .filter(|v| v.is_finite())
        .fold(f64::INFINITY, f64::min);
    let choice = curve
        .iter()
        .filter(|p| p.cv_rms_dph <= best * (1.0 + PARSIMONY))
        .min_by(|a, b| a.c.total_cmp(&b.c).then(b.sigma.total_cmp(&a.sigma)))
        .copied()
        .unwrap_or(CvPoint {
            sigma: f64::NAN,
            c: f64::NAN,
            cv_rms_dph: f64::NAN,
        });
    Tuned {
        sigma: choice.sigma,
        c: choice.c,
        cv_rms_dph: choice.cv_rms_dph,
        curve,
        refined: Vec::new(),
        validation: validation.describe(),
    }
}

/// The board table's choice.
struct Table {
    point: CvPoint,
    model: ModelFile,
    precision: Precision,
    /// Better-scoring points passed over: (σ, c, departure °/h).
    refused: Vec<(f64, f64, f64)>,
    /// The limit the table departs beyond ([`crate::board::pick_table`]); None: within it.
    raised_from: Option<f64>,
}

/// The table: the CV choice, or the best-scoring grid point whose f32 evaluation meets the
/// export limit (or departs by less than it gains: [`crate::board::pick_table`]); with the
/// better-scoring points passed over.
fn choose_table(
    p: &Points,
    tuned: &Tuned,
    opts: &StaticOptions,
    provenance: &Provenance,
) -> Result<Table, CalibrateError> {
    let mut order: Vec<CvPoint> = tuned
        .curve
        .iter()
        .filter(|p| p.cv_rms_dph.is_finite())
        .copied()
        .collect();
    ensure!(
        !order.is_empty(),
        Input,
        "no (σ, c) of the grid could be trained on every fold"
    );
    order.sort_by(|a, b| a.cv_rms_dph.total_cmp(&b.cv_rms_dph));
    order.insert(
        0,
        CvPoint {
            sigma: tuned.sigma,
            c: tuned.c,
            cv_rms_dph: tuned.cv_rms_dph,
        },
    );
    let picked = crate::board::pick_table(order, |point| {
        let lssvm = train_with_trend(
            &p.names,
            &p.x,
            &p.y,
            point.sigma,
            point.c,
            opts.budget,
            &[true],
        )?;
        // The board runs at 1 Hz whatever the spacing of the points.
        let mut model = ModelFile::from_trained(
            lssvm,
            &p.x,
            &p.y,
            opts.rate_tau_s,
            1.0,
            None,
            provenance.clone(),
        )?;
        model.removes = opts.remove;
        let prec = export::precision(&model)?;
        Ok((model, prec.deviation_dph, prec.limit_dph))
    })?;
    let Some(mut picked) = picked else {
        return Err(CalibrateError::NoBoardTable(format!(
            "no (σ, c) of the grid gives a board table within the f32 limit of {:.0e} °/h, nor \
             one whose departure is finite; lower --c-min",
            export::EXPORT_LIMIT_DPH,
        )));
    };
    let raised_from = picked.raise_limit();
    // Evaluated again under the limit the table now carries (the same departure).
    let precision = export::precision(&picked.table)?;
    Ok(Table {
        point: picked.point,
        model: picked.table,
        precision,
        refused: picked.refused,
        raised_from,
    })
}

/// Fits and checks the temperature-only model (see the module doc).
pub fn calibrate_static(
    cal: &Recording,
    test: Option<&Recording>,
    opts: &StaticOptions,
    provenance: &Provenance,
    progress: &ProgressBar,
) -> Result<StaticCalibration, CalibrateError> {
    ensure!(
        (1..=crate::MAX_BUDGET).contains(&opts.budget),
        Option,
        "--budget {}: the board table holds 1 to {} support vectors",
        opts.budget,
        crate::MAX_BUDGET
    );
    let mut notes = Vec::new();
    let cal = crate::input::for_static(cal, "the calibration recording", &mut notes)?;
    let p = checked_points(&cal, opts.block)?;
    let n = p.raw.len();
    let validation = validation_for(n);
    let folds = match &validation {
        Validation::LeaveOneOut => (0..n).map(|i| vec![i]).collect(),
        v => fold_indices(v, n)?,
    };
    ensure!(
        n <= MAX_POINTS,
        Input,
        "{n} points; the static model's grid search solves exactly on up to {MAX_POINTS}: \
         average more samples per point with a larger --block"
    );
    let tuned = tune_with_trend(&p, (&validation, &folds), &opts.grid, opts.budget, progress);
    progress.finish_and_clear();

    let poly_cv_dph = poly_cv_dph(&folds, &p.t, &p.y);
    let poly_degree = poly_degree(&poly_cv_dph)?;
    let all: Vec<usize> = (0..n).collect();
    let poly = poly_of(&p.t, &p.y, &all, poly_degree)
        .ok_or_else(|| CalibrateError::Input("the polynomial did not fit".to_string()))?;
    let poly_train: Vec<f64> = (0..n).map(|i| p.y[i] - poly.predict(p.t[i])).collect();
    let Table {
        point,
        model,
        precision: prec,
        refused,
        raised_from,
    } = choose_table(&p, &tuned, opts, provenance)?;
    if let Some(base) = raised_from {
        notes.push(format!(
            "The board table (σ = {:.3}, c = {:.3}) departs in f32 from its f64 model by {:.2e} \
             °/h, over the limit of {base:.1e}, and is taken all the same: its CV rms plus {m} \
             times that departure, {:.3e} + {m} × {:.2e} °/h, is below the CV rms of every point \
             of the grid left to try. Its model file carries the raised limit, {:.2e} °/h.",
            point.sigma,
            point.c,
            prec.deviation_dph,
            point.cv_rms_dph,
            prec.deviation_dph,
            prec.limit_dph,
            m = crate::board::DEPARTURE_MARGIN,
        ));
    }

    notes.extend(crate::warnings::tuning_notes(
        "The static LS-SVM",
        (point.sigma, point.c),
        &opts.grid,
        (model.training.rms_dph, point.cv_rms_dph),
    ));
    notes.extend(loop_note(&p, &|t| model.predict_dph(&[t])));
    let (test_points, held_out_rms_dph) = match test {
        Some(r) => {
            let r = crate::input::for_static(r, "the test recording", &mut notes)?;
            let tp = points_of(&r, opts.block)?.points;
            let e = |f: &dyn Fn(f64) -> f64| {
                rms(&tp.iter().map(|(t, y)| y - f(*t)).collect::<Vec<_>>()).unwrap_or(f64::NAN)
            };
            let held = (e(&|t| poly.predict(t)), e(&|t| model.predict_dph(&[t])));
            (tp, Some(held))
        }
        None => (Vec::new(), None),
    };
    Ok(StaticCalibration {
        points: p.raw,
        point_phases: p.phases,
        points_from: p.from,
        validation: match validation {
            Validation::LeaveOneOut => "leave-one-out (fewer than 25 points)".to_string(),
            v => v.describe(),
        },
        poly_degree,
        poly_train_rms_dph: rms(&poly_train).unwrap_or(f64::NAN),
        poly_cv_dph,
        reference_folded: export::folds_reference(model.kept_dph()),
        tuned,
        table_point: point,
        refused,
        model,
        f32_deviation_dph: prec.deviation_dph,
        f32_limit_dph: prec.limit_dph,
        held_out_rms_dph,
        test_points,
        notes,
    })
}
