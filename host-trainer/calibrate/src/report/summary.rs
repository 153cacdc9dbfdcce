//! `summary.json`: the calibration's figures for programs (schema in `SUMMARY.md` of this
//! crate, versioned by [`SCHEMA_VERSION`]).

use serde::Serialize;

use rlg_eval::metrics::allan::{
    angle_random_walk_dph_rt_h_ci, bias_instability_dph_ci, rate_random_walk_dph_per_rt_h_ci,
    AdevCi, ReadOff,
};
use rlg_train::export;
use rlg_train::model::ModelFile;

use super::{FileInfo, Inputs};
use crate::phases::PhaseRms;
use crate::static_cal::StaticCalibration;
use crate::{Calibration, HeldOut, Model};

/// Name of the summary's schema.
pub const SCHEMA: &str = "rlg-calibrate-summary";
/// Version of the summary's schema; raised when a field changes meaning or goes away.
pub const SCHEMA_VERSION: u32 = 1;

/// Allan read-off ranges, s (as in the reproduction's report).
const ARW_TAU_S: (f64, f64) = (1.0, 20.0);
const BI_TAU_S: (f64, f64) = (20.0, 5000.0);
const RRW_TAU_S: (f64, f64) = (5000.0, 1e9);

/// One read-off with its 1σ interval.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Interval {
    /// The value.
    pub value: f64,
    /// Lower bound (1σ, from the χ² interval of the point(s) it is read from).
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
}

impl From<ReadOff> for Interval {
    fn from(r: ReadOff) -> Self {
        Interval {
            value: r.value,
            lo: r.lo,
            hi: r.hi,
        }
    }
}

/// Allan read-offs of one output.
#[derive(Clone, Debug, Serialize)]
pub struct AllanReadOffs {
    /// Angle random walk, °/√h.
    pub arw_dph_rt_h: Option<Interval>,
    /// Bias instability, °/h.
    pub bias_instability_dph: Option<Interval>,
    /// Rate random walk, °/h/√h.
    pub rrw_dph_per_rt_h: Option<Interval>,
}

pub(super) fn read_offs(p: &[AdevCi]) -> AllanReadOffs {
    AllanReadOffs {
        arw_dph_rt_h: angle_random_walk_dph_rt_h_ci(p, ARW_TAU_S).map(Interval::from),
        bias_instability_dph: bias_instability_dph_ci(p, BI_TAU_S).map(Interval::from),
        rrw_dph_per_rt_h: rate_random_walk_dph_per_rt_h_ci(p, RRW_TAU_S).map(Interval::from),
    }
}

/// Held-out figures of one model in the summary.
#[derive(Clone, Debug, Serialize)]
pub struct HeldOutSummary {
    /// Bias stability over the window, °/h.
    pub stability_dph: f64,
    /// Raw / compensated stability.
    pub improvement: Option<f64>,
    /// By phase.
    pub phases: PhaseRms,
    /// Allan read-offs.
    pub allan: AllanReadOffs,
}

/// One model in the summary.
#[derive(Clone, Debug, Serialize)]
pub struct ModelSummary {
    /// Name.
    pub name: String,
    /// Detail.
    pub detail: String,
    /// TRAINING RMS, °/h.
    pub train_rms_dph: Option<f64>,
    /// CV RMS, °/h.
    pub cv_rms_dph: Option<f64>,
    /// Held-out figures.
    pub held_out: Option<HeldOutSummary>,
}

/// The split in the summary.
#[derive(Clone, Debug, Serialize)]
pub struct SplitSummary {
    /// `cycles`, `test_recording` or `nothing`.
    pub held_out: &'static str,
    /// Temperature cycles in the calibration recording.
    pub cycles: usize,
    /// Cycles that train (all of them with a test recording).
    pub train_cycles: usize,
    /// Training span, s.
    pub train_span_s: (f64, f64),
    /// Held-out span, s.
    pub test_span_s: Option<(f64, f64)>,
    /// The CV scheme.
    pub validation: String,
}

/// The tuning in the summary.
#[derive(Clone, Debug, Serialize)]
pub struct TuningSummary {
    /// Chosen σ.
    pub sigma: f64,
    /// Chosen c.
    pub c: f64,
    /// Its CV RMS, °/h.
    pub cv_rms_dph: f64,
    /// Grid points evaluated.
    pub points: usize,
}

/// The board table in the summary.
#[derive(Clone, Debug, Serialize)]
pub struct BoardSummary {
    /// Features of the table.
    pub features: Vec<String>,
    /// σ.
    pub sigma: f64,
    /// c.
    pub c: f64,
    /// Support vectors.
    pub support_vectors: usize,
    /// |f32 − f64| of the correction, °/h.
    pub f32_deviation_dph: f64,
    /// Limit, °/h.
    pub f32_limit_dph: f64,
    /// Whether b − reference is stored.
    pub reference_folded: bool,
    /// The model's output at the reference condition, °/h.
    pub reference_dph: f64,
    /// The reference temperature, °C.
    pub reference_temp_c: f64,
    /// What the board removes: `variation` (its output centred on `reference_dph`) or
    /// `whole` (centred on zero).
    pub removes: rlg_train::model::Removal,
    /// CV points refused for f32 precision: (σ, c, departure °/h).
    pub refused: Vec<(f64, f64, f64)>,
    /// Held-out bias stability of the output compensated through the board's f32 evaluation,
    /// °/h (None: nothing held out).
    pub held_out_stability_dph: Option<f64>,
}

/// `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// [`SCHEMA`].
    pub schema: &'static str,
    /// [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// `dynamic` or `static`.
    pub mode: &'static str,
    /// The command line.
    pub command: String,
    /// The calibration recording.
    pub recording: FileInfo,
    /// The test recording, when given.
    pub test_recording: Option<FileInfo>,
    /// Stability window, s.
    pub window_s: usize,
    /// The split (dynamic mode).
    pub split: Option<SplitSummary>,
    /// The LS-SVM's tuning.
    pub tuning: TuningSummary,
    /// The board table.
    pub board: BoardSummary,
    /// The board table on the diagnosed features (`--diagnose`, when the close loop adopts
    /// them).
    pub diagnosed_board: Option<BoardSummary>,
    /// The comparison.
    pub models: Vec<ModelSummary>,
    /// Caveats and changed choices.
    pub notes: Vec<String>,
    /// Files written into the folder.
    pub files: Vec<String>,
}

pub(super) fn board_summary(
    m: &ModelFile,
    refused: &[(f64, f64, f64)],
    dev: f64,
    limit: f64,
    held_out_stability_dph: Option<f64>,
) -> BoardSummary {
    BoardSummary {
        held_out_stability_dph,
        features: m.lssvm.features.clone(),
        sigma: m.lssvm.sigma,
        c: m.lssvm.c,
        support_vectors: m.lssvm.support.len(),
        f32_deviation_dph: dev,
        f32_limit_dph: limit,
        reference_folded: export::folds_reference(m.kept_dph()),
        reference_dph: m.reference_dph,
        reference_temp_c: export::reference(m).temp_c,
        removes: m.removes,
        refused: refused.to_vec(),
    }
}

/// The summary of a dynamic calibration.
pub fn summary(c: &Calibration, inputs: &Inputs, files: &[String]) -> Summary {
    let (held, train_cycles) = match c.split.held_out {
        HeldOut::Cycles { train, .. } => ("cycles", train),
        HeldOut::TestRecording => ("test_recording", c.split.cycles.len()),
        HeldOut::Nothing => ("nothing", c.split.cycles.len()),
    };
    Summary {
        schema: SCHEMA,
        schema_version: SCHEMA_VERSION,
        mode: "dynamic",
        command: inputs.command.clone(),
        recording: inputs.recording.clone(),
        test_recording: inputs.test_recording.clone(),
        window_s: c.options.window,
        split: Some(SplitSummary {
            held_out: held,
            cycles: c.split.cycles.len(),
            train_cycles,
            train_span_s: c.split.train_span_s,
            test_span_s: c.split.test_span_s,
            validation: c.split.validation.clone(),
        }),
        tuning: TuningSummary {
            sigma: c.tuned.sigma,
            c: c.tuned.c,
            cv_rms_dph: c.tuned.cv_rms_dph,
            points: c.tuned.curve.len() + c.tuned.refined.len(),
        },
        board: board_summary(
            &c.board_model,
            &c.board.refused,
            c.board.f32_deviation_dph,
            c.board.f32_limit_dph,
            c.row(Model::Board)
                .and_then(|r| r.held_out.as_ref())
                .map(|h| h.stability_dph),
        ),
        diagnosed_board: c.diagnosed_board.as_ref().map(|d| {
            board_summary(
                &d.model,
                &[],
                d.f32_deviation_dph,
                d.f32_limit_dph,
                d.board_stability_dph,
            )
        }),
        models: c
            .rows
            .iter()
            .map(|r| ModelSummary {
                name: r.model.name().to_string(),
                detail: r.detail.clone(),
                train_rms_dph: r.train_rms_dph,
                cv_rms_dph: r.cv_rms_dph,
                held_out: r.held_out.as_ref().map(|h| HeldOutSummary {
                    stability_dph: h.stability_dph,
                    improvement: h.improvement,
                    phases: h.phases,
                    allan: read_offs(&h.allan),
                }),
            })
            .collect(),
        notes: c.notes.clone(),
        files: files.to_vec(),
    }
}

/// The summary of a static calibration.
pub fn static_summary(c: &StaticCalibration, inputs: &Inputs, files: &[String]) -> Summary {
    let held = c.held_out_rms_dph;
    let row = |name: &str, detail: String, train, cv, held: Option<f64>| ModelSummary {
        name: name.to_string(),
        detail,
        train_rms_dph: train,
        cv_rms_dph: cv,
        held_out: held.map(|h| HeldOutSummary {
            stability_dph: h,
            improvement: None,
            phases: PhaseRms::default(),
            allan: AllanReadOffs {
                arw_dph_rt_h: None,
                bias_instability_dph: None,
                rrw_dph_per_rt_h: None,
            },
        }),
    };
    Summary {
        schema: SCHEMA,
        schema_version: SCHEMA_VERSION,
        mode: "static",
        command: inputs.command.clone(),
        recording: inputs.recording.clone(),
        test_recording: inputs.test_recording.clone(),
        window_s: 0,
        split: None,
        tuning: TuningSummary {
            sigma: c.tuned.sigma,
            c: c.tuned.c,
            cv_rms_dph: c.tuned.cv_rms_dph,
            points: c.tuned.curve.len() + c.tuned.refined.len(),
        },
        board: board_summary(
            &c.model,
            &c.refused,
            c.f32_deviation_dph,
            c.f32_limit_dph,
            // Static mode scores the f64 models' RMS over test points, not a board stream.
            None,
        ),
        diagnosed_board: None,
        models: vec![
            row(
                "polynomial in T",
                format!("degree {}", c.poly_degree),
                Some(c.poly_train_rms_dph),
                c.poly_cv_dph.get(c.poly_degree - 1).copied(),
                held.map(|h| h.0),
            ),
            row(
                "LS-SVM on [T]",
                format!(
                    "σ = {:.3}, c = {:.3}, {} support vectors",
                    c.table_point.sigma,
                    c.table_point.c,
                    c.model.lssvm.support.len()
                ),
                Some(c.model.training.rms_dph),
                Some(c.table_point.cv_rms_dph),
                held.map(|h| h.1),
            ),
        ],
        notes: std::iter::once(format!(
            "Static characterisation: points are {}; no dT/dt model (held-out figures, when a \
             test was given, are the RMS over its points, in `held_out.stability_dph`).",
            c.points_from
        ))
        .chain(c.notes.iter().cloned())
        .collect(),
        files: files.to_vec(),
    }
}
