//! Figures of the reproduction, laid out as the paper's: static fits (Fig. 2), bias with
//! temperature and with dT/dt against time (Figs. 3–4), compensated outputs (Figs. 5–6), and
//! beyond the paper the Allan deviations and the LS-SVM's cross-validation curve.

use rlg_eval::metrics::block_means;
use rlg_io::plot::{Figure, Series, Style};

use super::dynamic::{DynamicResult, ModelScore, Row};

/// Samples per plotted point of a rate: 100 s means at 1 Hz, as the paper plots.
const BLOCK: usize = 100;

fn hours(r: &DynamicResult) -> Vec<f64> {
    r.run.recording.time_s.iter().map(|t| t / 3600.0).collect()
}

/// Fig. 3: gyro output (100 s means) and body temperature against time.
pub fn fig3_bias_and_temperature(r: &DynamicResult) -> Figure {
    rlg_simulate::figure::scenario_figure(
        "Fig. 3: gyro output (100 s means) and temperature, dynamic test",
        &r.run.recording,
    )
}

/// Fig. 4: gyro output (100 s means) and the board's dT/dt against time.
pub fn fig4_bias_and_rate(r: &DynamicResult) -> Figure {
    let h = hours(r);
    let mut f = Figure::new(
        "Fig. 4: gyro output (100 s means) and temperature rate dT/dt (board estimator)",
        "time (h)",
        "dT/dt (°C/min)",
    );
    f.y2_label = Some("gyro output, 100 s means (°/h)".into());
    let rate_c_per_min: Vec<f64> = r.features.rows.iter().map(|v| 60.0 * v[1]).collect();
    f.series = vec![
        Series::new(
            "dT/dt",
            block_means(&h, 10),
            block_means(&rate_c_per_min, 10),
            Style::Line,
        ),
        Series::new(
            "gyro output",
            block_means(&h, BLOCK),
            block_means(&r.run.recording.rate_dph, BLOCK),
            Style::Line,
        )
        .on_right(),
    ];
    f
}

/// Figs. 5–6: the held-out output before and after compensation by `model` (100 s means,
/// each with its held-out mean removed so both share one axis).
pub fn compensated(r: &DynamicResult, model: &ModelScore, title: &str) -> Figure {
    let h = &hours(r)[r.split..];
    let centred = |v: &[f64]| {
        let m = block_means(v, BLOCK);
        let mean = m.iter().sum::<f64>() / m.len().max(1) as f64;
        m.iter().map(|x| x - mean).collect::<Vec<f64>>()
    };
    let raw = r.model(Row::Raw).map(|m| &m.compensated_dph[r.split..]);
    let mut f = Figure::new(
        title,
        "time (h)",
        "output − held-out mean, 100 s means (°/h)",
    );
    if let Some(raw) = raw {
        f.series.push(Series::new(
            &format!(
                "raw: 100 s stability {:.4} °/h",
                r.model(Row::Raw).map_or(f64::NAN, |m| m.test_b100_dph)
            ),
            block_means(h, BLOCK),
            centred(raw),
            Style::Line,
        ));
    }
    f.series.push(Series::new(
        &format!(
            "{}: 100 s stability {:.4} °/h",
            model.row.name(),
            model.test_b100_dph
        ),
        block_means(h, BLOCK),
        centred(&model.compensated_dph[r.split..]),
        Style::Line,
    ));
    f
}

/// Fig. 5 (stepwise regression) and Fig. 6 (LS-SVM), plus Eq. (11) as published.
pub fn compensated_figures(r: &DynamicResult) -> Vec<(&'static str, Figure)> {
    let mut out = Vec::new();
    for (file, name, title) in [
        (
            "fig5_stepwise.png",
            Row::Stepwise,
            "Fig. 5: held-out cycles compensated by the stepwise regression (refitted)",
        ),
        (
            "fig5b_eq11.png",
            Row::Eq11,
            "Fig. 5 (b): held-out cycles compensated by Eq. (11) as published",
        ),
        (
            "fig6_lssvm.png",
            Row::Lssvm,
            "Fig. 6: held-out cycles compensated by the LS-SVM",
        ),
    ] {
        if let Some(m) = r.model(name) {
            out.push((file, compensated(r, m, title)));
        }
    }
    out
}

/// Overlapping Allan deviation of the held-out output, raw and compensated (log–log).
pub fn allan(r: &DynamicResult) -> Figure {
    let mut f = Figure::new(
        "Allan deviation of the held-out output, raw and compensated",
        "cluster time τ (s)",
        "Allan deviation (°/h)",
    );
    f.log_x = true;
    f.log_y = true;
    for m in &r.models {
        f.series.push(Series::new(
            m.row.name(),
            m.allan.points.iter().map(|p| p.tau_s).collect(),
            m.allan.points.iter().map(|p| p.adev).collect(),
            Style::LinePoints,
        ));
    }
    f
}

/// The LS-SVM's cross-validation RMS against σ, one line per c of the coarse grid.
pub fn cv_curve(r: &DynamicResult) -> Figure {
    let t = &r.tuned;
    let mut f = Figure::new(
        &format!(
            "LS-SVM tuning ({}): chosen σ = {:.3}, c = {:.3e}",
            t.validation, t.sigma, t.c
        ),
        "kernel width σ (standardised units)",
        "cross-validated RMS (°/h)",
    );
    f.log_x = true;
    f.log_y = true;
    let mut cs: Vec<f64> = t.curve.iter().map(|p| p.c).collect();
    cs.sort_by(f64::total_cmp);
    cs.dedup();
    for c in cs {
        let pts: Vec<_> = t.curve.iter().filter(|p| p.c == c).collect();
        f.series.push(Series::new(
            &format!("c = {c:.0e}"),
            pts.iter().map(|p| p.sigma).collect(),
            pts.iter().map(|p| p.cv_rms_dph).collect(),
            Style::LinePoints,
        ));
    }
    f.series.push(Series::new(
        "chosen (after refinement)",
        vec![t.sigma],
        vec![t.cv_rms_dph],
        Style::Points,
    ));
    f
}
