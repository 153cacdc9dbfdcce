//! The PNG figures of a calibration.

use std::path::Path;

use rlg_io::plot::{render_png, Figure, Series, Style};

use crate::static_cal::StaticCalibration;
use crate::{CalibrateError, Calibration, Model};

/// `v` rounded to three significant digits, printed short: 0.1, 10, 1780, 100000 (the grid's
/// c come from a log spacing: 9.999999999999998).
fn three_digits(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let e = 2 - v.abs().log10().floor() as i32;
    let rounded = if e >= 0 {
        let s = 10f64.powi(e);
        (v * s).round() / s
    } else {
        let s = 10f64.powi(-e);
        (v / s).round() * s
    };
    format!("{rounded}")
}

fn centred(v: &[f64]) -> Vec<f64> {
    let m = v.iter().sum::<f64>() / v.len().max(1) as f64;
    v.iter().map(|x| x - m).collect()
}

/// Whether the board table's held-out window means lie within 1 % of the raw output's spread of
/// the LS-SVM's everywhere: drawn, its line would hide the LS-SVM's, so one line stands for both.
fn board_coincides(c: &Calibration) -> bool {
    let of = |m: Model| {
        c.rows
            .iter()
            .position(|r| r.model == m)
            .and_then(|k| c.series.outputs.get(k))
            .filter(|o| !o.is_empty())
    };
    let (Some(raw), Some(lssvm), Some(board)) =
        (of(Model::Raw), of(Model::Lssvm), of(Model::Board))
    else {
        return false;
    };
    let (lo, hi) = raw
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    let (l, b) = (centred(lssvm), centred(board));
    l.iter()
        .zip(&b)
        .all(|(x, y)| (x - y).abs() <= 0.01 * (hi - lo))
}

/// The figures of a dynamic calibration, written into `dir`; their file names.
pub(super) fn figures(c: &Calibration, dir: &Path) -> Result<Vec<String>, CalibrateError> {
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
        let board_on_lssvm = board_coincides(c);
        for (r, out) in c.rows.iter().zip(&s.outputs) {
            let drawn = [Model::Raw, Model::Stepwise, Model::Lssvm, Model::Board];
            if !drawn.contains(&r.model) || out.is_empty() {
                continue;
            }
            if r.model == Model::Board && board_on_lssvm {
                continue;
            }
            let m = centred(out);
            let label = if r.model == Model::Lssvm && board_on_lssvm {
                "LS-SVM and board table (one line)".to_string()
            } else {
                r.model.name().to_string()
            };
            fig.series
                .push(Series::new(&label, th.clone(), m.clone(), Style::Line));
            if r.model != Model::Board {
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
                            &format!("{}, {name}", r.model),
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
            if r.model == Model::Lssvm && board_on_lssvm {
                continue;
            }
            if let Some(h) = &r.held_out {
                let tau: Vec<f64> = h.allan.iter().map(|p| p.tau_s).collect();
                let label = if r.model == Model::Board && board_on_lssvm {
                    "board table and LS-SVM (one line)"
                } else {
                    r.model.name()
                };
                allan.series.push(Series::new(
                    label,
                    tau.clone(),
                    h.allan.iter().map(|p| p.adev).collect(),
                    Style::LinePoints,
                ));
                if r.model == Model::Raw || r.model == Model::Board {
                    for (what, f) in [("lo", 0), ("hi", 1)] {
                        allan.series.push(Series::new(
                            &format!("{}, 1σ {what}", r.model),
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
            &format!("c = {}", three_digits(cc)),
            xs,
            ys,
            Style::LinePoints,
        ));
    }
    // The choice (refined between grid points) marked on the curves it was chosen from.
    cv.series.push(Series::new(
        &format!(
            "chosen: σ = {}, c = {}",
            three_digits(c.tuned.sigma),
            three_digits(c.tuned.c)
        ),
        vec![c.tuned.sigma],
        vec![c.tuned.cv_rms_dph],
        Style::Points,
    ));
    render_png(&cv, &dir.join("cv_curve.png"))?;
    files.push("cv_curve.png".into());
    Ok(files)
}

/// The static fit over the training (and held-out) points, written into `dir`.
pub(super) fn static_figure(c: &StaticCalibration, dir: &Path) -> Result<String, CalibrateError> {
    let (lo, hi) = (c.model.input_lo[0], c.model.input_hi[0]);
    let grid: Vec<f64> = (0..=200)
        .map(|i| lo + (hi - lo) * f64::from(i) / 200.0)
        .collect();
    let mut fig = Figure::new("Static characterisation", "T (°C)", "output (°/h)");
    // The training points by phase: a heating/cooling loop shows as two branches that a
    // temperature-only model can only split the difference of.
    for (phase, label) in ["heating", "cooling", "hold"].iter().enumerate() {
        let (px, py): (Vec<f64>, Vec<f64>) = c
            .points
            .iter()
            .zip(&c.point_phases)
            .filter(|(_, k)| **k == phase)
            .map(|(p, _)| *p)
            .unzip();
        if !px.is_empty() {
            fig.series.push(Series::new(
                &format!("training points, {label}"),
                px,
                py,
                Style::Points,
            ));
        }
    }
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
    Ok("static_fit.png".into())
}

#[cfg(test)]
mod tests {
    use super::three_digits;

    #[test]
    fn legend_numbers_are_short() {
        let got: Vec<String> = [
            0.1,
            9.999_999_999_999_998,
            1778.279,
            100_000.0,
            0.889_3,
            -42.17,
        ]
        .iter()
        .map(|v| three_digits(*v))
        .collect();
        assert_eq!(got, ["0.1", "10", "1780", "100000", "0.889", "-42.2"]);
    }
}
