//! `report.md`: the calibration for people.

use std::fmt::Write as _;

use super::summary::{read_offs, Interval, Summary};
use super::Inputs;
use crate::static_cal::StaticCalibration;
use crate::{Calibration, HeldOut, Model};
use rlg_train::model::Removal;

fn fmt(v: Option<f64>, prec: usize) -> String {
    v.filter(|v| v.is_finite())
        .map_or_else(|| "—".to_string(), |v| format!("{v:.prec$}"))
}

fn sci(v: Option<f64>) -> String {
    v.filter(|v| v.is_finite())
        .map_or_else(|| "—".to_string(), |v| format!("{v:.3e}"))
}

fn interval(v: Option<Interval>) -> String {
    v.filter(|v| v.value.is_finite()).map_or_else(
        || "—".to_string(),
        |v| format!("{:.3e} [{:.2e}, {:.2e}]", v.value, v.lo, v.hi),
    )
}

/// The Markdown report of a dynamic calibration.
pub fn markdown(c: &Calibration, inputs: &Inputs) -> String {
    let mut s = split_and_tuning(c, inputs);
    s.push_str(&comparison(c));
    s.push_str(&allan(c));
    s.push_str(&board(c));
    s
}

/// The head of the report: the command, the split, the tuning and the notes.
fn split_and_tuning(c: &Calibration, inputs: &Inputs) -> String {
    let mut s = String::new();
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
        c.train_samples, c.train_block_s, c.samples, c.options.rate_tau_s
    );
    let _ = writeln!(
        s,
        "σ and c of the LS-SVM, and the polynomial's degree, by {} on {} s means of the \
         training span: σ = {:.4}, c = {:.4}, CV RMS {:.3e} °/h ({} grid points).\n",
        c.split.validation,
        c.tune_block_s,
        c.tuned.sigma,
        c.tuned.c,
        c.tuned.cv_rms_dph,
        c.tuned.curve.len() + c.tuned.refined.len()
    );
    for n in &c.notes {
        let _ = writeln!(s, "**Note.** {n}\n");
    }
    s
}

/// The comparison table of every model, TRAINING, CV and HELD-OUT (also what `rlg calibrate`
/// prints).
pub fn comparison(c: &Calibration) -> String {
    let mut s = String::new();
    let w = c.options.window;
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
            r.model,
            r.detail,
            sci(r.train_rms_dph),
            sci(r.cv_rms_dph),
            sci(h.map(|h| h.stability_dph)),
            if r.model == Model::Raw {
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
    s
}

/// The Allan read-offs of each held-out output (empty when nothing is held out).
fn allan(c: &Calibration) -> String {
    let mut s = String::new();
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
                    r.model,
                    interval(a.arw_dph_rt_h),
                    interval(a.bias_instability_dph),
                    interval(a.rrw_dph_per_rt_h)
                );
            }
        }
        let _ = writeln!(s);
    }
    s
}

/// What the board removes, the constant its output keeps, and where the held-out output was
/// centred.
fn removal(c: &Calibration) -> String {
    let mut s = removal_of(&c.board_model);
    let board = c.rows.iter().position(|row| row.model == Model::Board);
    if let Some(out) = board.and_then(|k| c.series.outputs.get(k)) {
        if !out.is_empty() {
            let mean = out.iter().sum::<f64>() / out.len() as f64;
            let _ = write!(s, " Held out, its output's mean is {mean:.4e} °/h.");
        }
    }
    s
}

/// What the board table of `m` removes and the constant its output keeps.
fn removal_of(m: &rlg_train::model::ModelFile) -> String {
    let r = rlg_train::export::reference(m);
    match m.removes {
        Removal::Whole => format!(
            "The board removes the whole bias (`--remove whole`): its output is raw − f(x), \
             centred on zero (the bias at {:.1} °C, f = {:.6e} °/h, is removed with the rest).",
            r.temp_c, r.bias_dph
        ),
        Removal::Variation => format!(
            "The board removes only the bias' variation (`--remove variation`): its output is \
             raw − (f(x) − B), centred on B = {:.6e} °/h, the bias at {:.1} °C and dT/dt = 0 \
             (`REFERENCE_BIAS_DPH` in the tables).",
            r.bias_dph, r.temp_c
        ),
    }
}

/// The board table(s) and the figures.
fn board(c: &Calibration) -> String {
    let mut s = String::new();
    let w = c.options.window;
    let b = &c.board;
    let _ = writeln!(
        s,
        "## Board table\n\nFixed-size LS-SVM, {} support vectors, σ = {:.4}, c = {:.4}; f32 \
         evaluation of the correction within {:.2e} °/h of the f64 model ({}){}. \
         Files: `model.json`, `table.rs` (compensator-core), `table.h` (C).\n",
        b.support_vectors,
        b.sigma,
        b.c,
        b.f32_deviation_dph,
        match b.limit_raised_from_dph {
            Some(base) => format!(
                "over the limit of {base:.1e}, which every table within it would cost more than: \
                 see the notes"
            ),
            None => format!("limit {:.1e}", b.f32_limit_dph),
        },
        if b.reference_folded {
            "; the table stores b − reference, so the board sums only the correction"
        } else {
            ""
        }
    );
    let _ = writeln!(s, "{}\n", removal(c));
    if let Some(d) = &c.diagnosed_board {
        let l = &d.model.lssvm;
        let _ = writeln!(
            s,
            "## Board table on the diagnosed features\n\nThe close loop adopted the inputs \
             [{}] (see the notes): fixed-size LS-SVM, {} support vectors, σ = {:.4}, c = {:.4}; \
             f32 evaluation of the correction within {:.2e} °/h of the f64 model (limit \
             {:.1e}); {}. The board computes these inputs from T itself (`compensator_core::Feature`); a C \
             firmware must compute the inputs `rlg_features` names. Files: \
             `model_diagnosed.json`, `table_diagnosed.rs`, `table_diagnosed.h`.\n",
            l.features.join(", "),
            l.support.len(),
            l.sigma,
            l.c,
            d.f32_deviation_dph,
            d.f32_limit_dph,
            match d.board_stability_dph {
                Some(b) => format!(
                    "held out through the board's f32 compensator: {} °/h ({w} s stability)",
                    sci(Some(b))
                ),
                None => "nothing held out (CV figures only)".to_string(),
            },
        );
    }
    if c.series.time_s.is_empty() {
        let _ = writeln!(
            s,
            "Figures: `cv_curve.png` (nothing is held out, so there are no held-out figures)."
        );
    } else {
        let _ = writeln!(
            s,
            "Figures: `held_out.png` ({w} s means over time), `residual_vs_temperature.png`, \
             `allan.png`, `cv_curve.png`."
        );
    }
    s
}

/// The Markdown report of a static calibration; `summary` its [`Summary`], whose rows and
/// notes it shows.
pub fn static_markdown(c: &StaticCalibration, inputs: &Inputs, summary: &Summary) -> String {
    let mut md = format!(
        "# Static calibration of {}\n\nCommand: `{}`\n\n{}\n\nPoints: {} ({}). CV: {}.\n\n\
         | model | detail | TRAINING rms (°/h) | CV rms (°/h) | HELD-OUT rms (°/h) |\n\
         |---|---|---:|---:|---:|\n",
        inputs.recording.file,
        inputs.command,
        summary.notes.join(" "),
        c.points.len(),
        c.points_from,
        c.validation
    );
    for m in &summary.models {
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
         {:.1e}){}. {}\n",
        c.model.lssvm.support.len(),
        c.f32_deviation_dph,
        c.f32_limit_dph,
        if c.reference_folded {
            "; the table stores b − reference, so the board sums only the correction"
        } else {
            ""
        },
        removal_of(&c.model)
    );
    md
}

/// What `rlg calibrate --static` prints: one line per model.
pub fn static_console(summary: &Summary) -> String {
    let mut s = String::new();
    for m in &summary.models {
        let _ = writeln!(
            s,
            "{:<18} TRAINING rms {:.3e}  CV rms {}  HELD-OUT rms {}",
            m.name,
            m.train_rms_dph.unwrap_or(f64::NAN),
            m.cv_rms_dph.map_or("—".into(), |v| format!("{v:.3e}")),
            m.held_out
                .as_ref()
                .map_or("— (no --test)".into(), |h| format!(
                    "{:.3e}",
                    h.stability_dph
                ))
        );
    }
    s
}

/// What `rlg calibrate` prints after the comparison: the notes and the board table(s).
pub fn console_tail(c: &Calibration) -> String {
    let mut s = String::new();
    for n in &c.notes {
        let _ = writeln!(s, "note: {n}");
    }
    let _ = writeln!(
        s,
        "board table: σ = {:.4}, c = {:.4}, {} vectors, f32 within {:.1e} °/h",
        c.board.sigma, c.board.c, c.board.support_vectors, c.board.f32_deviation_dph
    );
    if let Some(d) = &c.diagnosed_board {
        let l = &d.model.lssvm;
        let _ = writeln!(
            s,
            "board table on the diagnosed features [{}]: σ = {:.4}, c = {:.4}, {} vectors, f32 \
             within {:.1e} °/h",
            l.features.join(", "),
            l.sigma,
            l.c,
            l.support.len(),
            d.f32_deviation_dph
        );
    }
    s
}
