//! The calibration folder: `report.md`, `summary.json` (schema in `SUMMARY.md` of this
//! crate, versioned by [`SCHEMA_VERSION`]), PNG figures, `model.json`, the board table in Rust
//! (`table.rs`) and C (`table.h`). Every file is written atomically; the folder is created
//! first, so a path that cannot hold it fails before any work.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::Serialize;

use rlg_eval::metrics::allan::{
    angle_random_walk_dph_rt_h_ci, bias_instability_dph_ci, rate_random_walk_dph_per_rt_h_ci,
    AdevCi, ReadOff,
};
use rlg_io::plot::{render_png, Figure, Series, Style};
use rlg_train::export::{self, Format};
use rlg_train::model::ModelFile;

use crate::phases::PhaseRms;
use crate::static_cal::StaticCalibration;
use crate::{Calibration, HeldOut, BOARD, LSSVM, RAW, STEPWISE};

/// Name of the summary's schema.
pub const SCHEMA: &str = "rlg-calibrate-summary";
/// Version of the summary's schema; raised when a field changes meaning or goes away.
pub const SCHEMA_VERSION: u32 = 1;

/// Allan read-off ranges, s (as in the reproduction's report).
const ARW_TAU_S: (f64, f64) = (1.0, 20.0);
const BI_TAU_S: (f64, f64) = (20.0, 5000.0);
const RRW_TAU_S: (f64, f64) = (5000.0, 1e9);

/// A data file named in the summary.
#[derive(Clone, Debug, Serialize)]
pub struct FileInfo {
    /// File name (no folder).
    pub file: String,
    /// SHA-256 of its bytes.
    pub sha256: String,
    /// Rows (samples) read.
    pub samples: usize,
}

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

fn read_offs(p: &[AdevCi]) -> AllanReadOffs {
    AllanReadOffs {
        arw_dph_rt_h: angle_random_walk_dph_rt_h_ci(p, ARW_TAU_S).map(Interval::from),
        bias_instability_dph: bias_instability_dph_ci(p, BI_TAU_S).map(Interval::from),
        rrw_dph_per_rt_h: rate_random_walk_dph_per_rt_h_ci(p, RRW_TAU_S).map(Interval::from),
    }
}

fn interval(v: Option<Interval>) -> String {
    v.filter(|v| v.value.is_finite()).map_or_else(
        || "—".to_string(),
        |v| format!("{:.3e} [{:.2e}, {:.2e}]", v.value, v.lo, v.hi),
    )
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

/// What a report is written from, besides the result.
#[derive(Clone, Debug)]
pub struct Inputs {
    /// The command line.
    pub command: String,
    /// The calibration recording.
    pub recording: FileInfo,
    /// The test recording.
    pub test_recording: Option<FileInfo>,
}

fn fmt(v: Option<f64>, prec: usize) -> String {
    v.filter(|v| v.is_finite())
        .map_or_else(|| "—".to_string(), |v| format!("{v:.prec$}"))
}

fn sci(v: Option<f64>) -> String {
    v.filter(|v| v.is_finite())
        .map_or_else(|| "—".to_string(), |v| format!("{v:.3e}"))
}

fn board_summary(
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
        reference_folded: export::folds_reference(m.reference_dph),
        reference_dph: m.reference_dph,
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
            c.row(crate::BOARD)
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
                name: r.name.clone(),
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

/// The Markdown report of a dynamic calibration.
pub fn markdown(c: &Calibration, inputs: &Inputs) -> String {
    let mut s = String::new();
    let w = c.options.window;
    let _ = writeln!(s, "# Calibration of {}\n", inputs.recording.file);
    let _ = writeln!(s, "Command: `{}`\n", inputs.command);
    let split = match &c.split.held_out {
        HeldOut::Cycles { train, test } => format!(
            "{} temperature cycles found; the first {train} train, the last {test} are HELD OUT \
             (span {:.0}–{:.0} s).",
            c.split.cycles.len(),
            c.split.test_span_s.map_or(f64::NAN, |t| t.0),
            c.split.test_span_s.map_or(f64::NAN, |t| t.1)
        ),
        HeldOut::TestRecording => format!(
            "All of `{}` trains; `{}` is HELD OUT.",
            inputs.recording.file,
            inputs
                .test_recording
                .as_ref()
                .map_or("the test recording", |f| f.file.as_str())
        ),
        HeldOut::Nothing => "Nothing is held out (one temperature cycle, no --test).".to_string(),
    };
    let _ = writeln!(s, "## Split and tuning\n\n{split}");
    let _ = writeln!(
        s,
        "Training: {} means of {} s from {} samples at 1 Hz. Inputs: recorded T and the board's \
         dT/dt estimator (τ = {} s).\n",
        c.train_samples, c.options.block, c.samples, c.options.rate_tau_s
    );
    let _ = writeln!(
        s,
        "σ and c of the LS-SVM, and the polynomial's degree, by {} on 100 s means of the \
         training span: σ = {:.4}, c = {:.4}, CV RMS {:.3e} °/h ({} grid points).\n",
        c.split.validation,
        c.tuned.sigma,
        c.tuned.c,
        c.tuned.cv_rms_dph,
        c.tuned.curve.len() + c.tuned.refined.len()
    );
    for n in &c.notes {
        let _ = writeln!(s, "**Note.** {n}\n");
    }
    let _ = writeln!(s, "## Comparison\n");
    let _ = writeln!(
        s,
        "| model | detail | TRAINING rms (°/h) | CV rms (°/h) | HELD-OUT {w} s stability (°/h) | \
         improvement | HELD-OUT heating / cooling / hold rms of {w} s means (°/h) |\n\
         |---|---|---:|---:|---:|---:|---|"
    );
    for r in &c.rows {
        let h = r.held_out.as_ref();
        let ph = h.map_or_else(
            || "—".to_string(),
            |h| {
                format!(
                    "{} / {} / {}",
                    sci(h.phases.heating_dph),
                    sci(h.phases.cooling_dph),
                    sci(h.phases.hold_dph)
                )
            },
        );
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} |",
            r.name,
            r.detail,
            sci(r.train_rms_dph),
            sci(r.cv_rms_dph),
            sci(h.map(|h| h.stability_dph)),
            if r.name == RAW {
                "—".to_string()
            } else {
                fmt(h.and_then(|h| h.improvement), 2)
            },
            ph
        );
    }
    let _ = writeln!(
        s,
        "\nTRAINING: on the training means. CV: out-of-fold on the tuning means ({}). \
         HELD-OUT: on samples no model saw.\n",
        c.split.validation
    );
    if c.rows.iter().any(|r| r.held_out.is_some()) {
        let _ = writeln!(
            s,
            "## Allan deviation of the HELD-OUT output\n\n\
             Overlapping Allan deviation; intervals are 1σ χ² bounds from the equivalent degrees \
             of freedom (Greenhall's algorithm, noise type identified at each τ, as Stable32 \
             gives them) of the point(s) each coefficient is read from.\n\n\
             | output | ARW (°/√h) | bias instability (°/h) | RRW (°/h/√h) |\n|---|---:|---:|---:|"
        );
        for r in &c.rows {
            if let Some(h) = &r.held_out {
                let a = read_offs(&h.allan);
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} |",
                    r.name,
                    interval(a.arw_dph_rt_h),
                    interval(a.bias_instability_dph),
                    interval(a.rrw_dph_per_rt_h)
                );
            }
        }
        let _ = writeln!(s);
    }
    let b = &c.board;
    let _ = writeln!(
        s,
        "## Board table\n\nFixed-size LS-SVM, {} support vectors, σ = {:.4}, c = {:.4}; f32 \
         evaluation of the correction within {:.2e} °/h of the f64 model (limit {:.1e}){}. \
         Files: `model.json`, `table.rs` (compensator-core), `table.h` (C).\n",
        b.support_vectors,
        b.sigma,
        b.c,
        b.f32_deviation_dph,
        b.f32_limit_dph,
        if b.reference_folded {
            "; the table stores b − reference, so the board sums only the correction"
        } else {
            ""
        }
    );
    if let Some(d) = &c.diagnosed_board {
        let l = &d.model.lssvm;
        let _ = writeln!(
            s,
            "## Board table on the diagnosed features\n\nThe close loop adopted the inputs \
             [{}] (see the notes): fixed-size LS-SVM, {} support vectors, σ = {:.4}, c = {:.4}; \
             f32 evaluation of the correction within {:.2e} °/h of the f64 model (limit \
             {:.1e}); held out through the board's f32 compensator: {} °/h ({w} s stability). \
             The board computes these inputs from T itself (`compensator_core::Feature`); a C \
             firmware must compute the inputs `rlg_features` names. Files: \
             `model_diagnosed.json`, `table_diagnosed.rs`, `table_diagnosed.h`.\n",
            l.features.join(", "),
            l.support.len(),
            l.sigma,
            l.c,
            d.f32_deviation_dph,
            d.f32_limit_dph,
            sci(d.board_stability_dph),
        );
    }
    let _ = writeln!(
        s,
        "Figures: `held_out.png` ({w} s means over time), `residual_vs_temperature.png`, \
         `allan.png`, `cv_curve.png`."
    );
    s
}

fn write_text(path: &Path, text: &str) -> anyhow::Result<()> {
    rlg_io::atomic::write(path, text.as_bytes())
        .with_context(|| format!("writing {}", path.display()))
}

/// Writes `model{stem}.json`, `table{stem}.rs` and `table{stem}.h`.
fn write_tables(
    dir: &Path,
    m: &ModelFile,
    command: &str,
    stem: &str,
) -> anyhow::Result<Vec<String>> {
    let names = [
        format!("model{stem}.json"),
        format!("table{stem}.rs"),
        format!("table{stem}.h"),
    ];
    m.write(&dir.join(&names[0]))?;
    export::write_board_table(m, command, &dir.join(&names[1]), Format::Rust)?;
    export::write_board_table(m, command, &dir.join(&names[2]), Format::C)?;
    Ok(names.to_vec())
}

fn centred(v: &[f64]) -> Vec<f64> {
    let m = v.iter().sum::<f64>() / v.len().max(1) as f64;
    v.iter().map(|x| x - m).collect()
}

fn figures(c: &Calibration, dir: &Path) -> anyhow::Result<Vec<String>> {
    let mut files = Vec::new();
    let w = c.options.window;
    let s = &c.series;
    if !s.time_s.is_empty() {
        let th: Vec<f64> = s.time_s.iter().map(|t| t / 3600.0).collect();
        let tc = s.temp_c.clone();
        let mut fig = Figure::new(
            &format!("HELD-OUT output, {w} s means (each centred)"),
            "time (h)",
            "rate − mean (°/h)",
        );
        fig.y2_label = Some("T (°C)".into());
        let mut resid = Figure::new(
            &format!("HELD-OUT {w} s means against temperature (each centred)"),
            "T (°C)",
            "rate − mean (°/h)",
        );
        let phases = &s.phase;
        for (r, out) in c.rows.iter().zip(&s.outputs) {
            if ![RAW, STEPWISE, LSSVM, BOARD].contains(&r.name.as_str()) || out.is_empty() {
                continue;
            }
            let m = centred(out);
            fig.series
                .push(Series::new(&r.name, th.clone(), m.clone(), Style::Line));
            if r.name != BOARD {
                for (p, name) in ["heating", "cooling", "hold"].iter().enumerate() {
                    let (xs, ys): (Vec<f64>, Vec<f64>) = tc
                        .iter()
                        .zip(&m)
                        .zip(phases)
                        .filter(|(_, ph)| **ph == p)
                        .map(|((t, v), _)| (*t, *v))
                        .unzip();
                    if !xs.is_empty() {
                        resid.series.push(Series::new(
                            &format!("{}, {name}", r.name),
                            xs,
                            ys,
                            Style::Points,
                        ));
                    }
                }
            }
        }
        fig.series
            .push(Series::new("T", th, tc, Style::Line).on_right());
        render_png(&fig, &dir.join("held_out.png"))?;
        render_png(&resid, &dir.join("residual_vs_temperature.png"))?;
        files.push("held_out.png".into());
        files.push("residual_vs_temperature.png".into());

        let mut allan = Figure::new(
            "Allan deviation of the HELD-OUT output",
            "τ (s)",
            "σ(τ) (°/h)",
        );
        allan.log_x = true;
        allan.log_y = true;
        for r in &c.rows {
            if let Some(h) = &r.held_out {
                let tau: Vec<f64> = h.allan.iter().map(|p| p.tau_s).collect();
                allan.series.push(Series::new(
                    &r.name,
                    tau.clone(),
                    h.allan.iter().map(|p| p.adev).collect(),
                    Style::LinePoints,
                ));
                if r.name == RAW || r.name == BOARD {
                    for (what, f) in [("lo", 0), ("hi", 1)] {
                        allan.series.push(Series::new(
                            &format!("{}, 1σ {what}", r.name),
                            tau.clone(),
                            h.allan
                                .iter()
                                .map(|p| if f == 0 { p.lo } else { p.hi })
                                .collect(),
                            Style::Points,
                        ));
                    }
                }
            }
        }
        render_png(&allan, &dir.join("allan.png"))?;
        files.push("allan.png".into());
    }
    let mut cv = Figure::new(
        &format!("CV RMS of the LS-SVM ({})", c.split.validation),
        "σ (standardised)",
        "CV rms (°/h)",
    );
    cv.log_x = true;
    cv.log_y = true;
    let mut cs: Vec<f64> = c.tuned.curve.iter().map(|p| p.c).collect();
    cs.sort_by(f64::total_cmp);
    cs.dedup();
    for cc in cs {
        let (xs, ys): (Vec<f64>, Vec<f64>) = c
            .tuned
            .curve
            .iter()
            .filter(|p| p.c == cc && p.cv_rms_dph.is_finite())
            .map(|p| (p.sigma, p.cv_rms_dph))
            .unzip();
        cv.series.push(Series::new(
            &format!("c = {cc:.3}"),
            xs,
            ys,
            Style::LinePoints,
        ));
    }
    render_png(&cv, &dir.join("cv_curve.png"))?;
    files.push("cv_curve.png".into());
    Ok(files)
}

/// Creates `dir` (a clear error when it cannot be a folder); done before the work.
pub fn prepare_dir(dir: &Path) -> anyhow::Result<()> {
    anyhow::ensure!(
        !dir.is_file(),
        "--out {}: is a file; give a folder",
        dir.display()
    );
    std::fs::create_dir_all(dir)
        .with_context(|| format!("--out {}: cannot create the folder", dir.display()))
}

/// Writes the folder of a dynamic calibration; returns the files written.
pub fn write(c: &Calibration, inputs: &Inputs, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    prepare_dir(dir)?;
    let mut files = write_tables(dir, &c.board_model, &inputs.command, "")?;
    if let Some(d) = &c.diagnosed_board {
        files.extend(write_tables(dir, &d.model, &inputs.command, "_diagnosed")?);
    }
    files.extend(figures(c, dir)?);
    write_text(&dir.join("report.md"), &markdown(c, inputs))?;
    files.push("report.md".into());
    files.push("summary.json".into());
    let sum = summary(c, inputs, &files);
    write_text(
        &dir.join("summary.json"),
        &(serde_json::to_string_pretty(&sum)? + "\n"),
    )?;
    Ok(files.iter().map(|f| dir.join(f)).collect())
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
        notes: vec![format!(
            "Static characterisation: points are {}; no dT/dt model (held-out figures, when a \
             test was given, are the RMS over its points, in `held_out.stability_dph`).",
            c.points_from
        )],
        files: files.to_vec(),
    }
}

/// Writes the folder of a static calibration.
pub fn write_static(
    c: &StaticCalibration,
    inputs: &Inputs,
    dir: &Path,
) -> anyhow::Result<Vec<PathBuf>> {
    prepare_dir(dir)?;
    let mut files = write_tables(dir, &c.model, &inputs.command, "")?;
    let (lo, hi) = (c.model.input_lo[0], c.model.input_hi[0]);
    let grid: Vec<f64> = (0..=200)
        .map(|i| lo + (hi - lo) * f64::from(i) / 200.0)
        .collect();
    let mut fig = Figure::new("Static characterisation", "T (°C)", "output (°/h)");
    let (px, py): (Vec<f64>, Vec<f64>) = c.points.iter().copied().unzip();
    fig.series
        .push(Series::new("training points", px, py, Style::Points));
    if !c.test_points.is_empty() {
        let (tx, ty): (Vec<f64>, Vec<f64>) = c.test_points.iter().copied().unzip();
        fig.series
            .push(Series::new("HELD-OUT points", tx, ty, Style::Points));
    }
    fig.series.push(Series::new(
        "LS-SVM on [T]",
        grid.clone(),
        grid.iter().map(|t| c.model.predict_dph(&[*t])).collect(),
        Style::Line,
    ));
    render_png(&fig, &dir.join("static_fit.png"))?;
    files.push("static_fit.png".into());
    let sum0 = static_summary(c, inputs, &files);
    let mut md = format!(
        "# Static calibration of {}\n\nCommand: `{}`\n\n{}\n\nPoints: {} ({}). CV: {}.\n\n\
         | model | detail | TRAINING rms (°/h) | CV rms (°/h) | HELD-OUT rms (°/h) |\n\
         |---|---|---:|---:|---:|\n",
        inputs.recording.file,
        inputs.command,
        sum0.notes.join(" "),
        c.points.len(),
        c.points_from,
        c.validation
    );
    for m in &sum0.models {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} |",
            m.name,
            m.detail,
            sci(m.train_rms_dph),
            sci(m.cv_rms_dph),
            sci(m.held_out.as_ref().map(|h| h.stability_dph))
        );
    }
    let _ = writeln!(
        md,
        "\nBoard table: {} support vectors on [T]; f32 correction within {:.2e} °/h (limit \
         {:.1e}){}; reference output {:.4} °/h.\n",
        c.model.lssvm.support.len(),
        c.f32_deviation_dph,
        c.f32_limit_dph,
        if c.reference_folded {
            "; the table stores b − reference, so the board sums only the correction"
        } else {
            ""
        },
        c.model.reference_dph
    );
    write_text(&dir.join("report.md"), &md)?;
    files.push("report.md".into());
    files.push("summary.json".into());
    let sum = static_summary(c, inputs, &files);
    write_text(
        &dir.join("summary.json"),
        &(serde_json::to_string_pretty(&sum)? + "\n"),
    )?;
    Ok(files.iter().map(|f| dir.join(f)).collect())
}
