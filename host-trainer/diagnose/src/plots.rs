//! The diagnosis' figures (`rlg diagnose --plots DIR`): the model's residual of the block
//! means against time with the located spans, against temperature split into heating,
//! cooling and holds, and before/after the findings.

use std::path::{Path, PathBuf};

use super::{Diagnosis, Unexplained};
use rlg_io::plot::{render_png, Figure, PlotError, Series, Style};

/// |dT/dt| below which a block counts as a hold, °C/s (0.05 °C/min).
const HOLD_RATE_C_PER_S: f64 = 0.05 / 60.0;

/// The three figures with their file names.
pub fn figures(d: &Diagnosis) -> Vec<(&'static str, Figure)> {
    let hours: Vec<f64> = d.series.t_s.iter().map(|t| t / 3600.0).collect();
    vec![
        ("residual_time.png", residual_time(d, &hours)),
        ("residual_temperature.png", residual_temperature(d)),
        ("before_after.png", before_after(d, &hours)),
    ]
}

/// `v` where `keep` holds, NaN (not drawn) elsewhere.
fn masked(keep: &dyn Fn(usize) -> bool, v: &[f64]) -> Vec<f64> {
    v.iter()
        .enumerate()
        .map(|(i, y)| if keep(i) { *y } else { f64::NAN })
        .collect()
}

/// The residual against time (`hours`), the located spans and the first finding's
/// strongest part marked, and the findings' fitted effect.
fn residual_time(d: &Diagnosis, hours: &[f64]) -> Figure {
    let s = &d.series;
    let in_span = |t: f64| d.located.iter().any(|w| t >= w.t_start_s && t <= w.t_end_s);
    let spans = match d.findings.first() {
        Some(f) => format!(
            "{} located span(s), {} where {} is strongest",
            d.located.len(),
            f.where_.len(),
            f.mechanism
        ),
        None => format!("{} located span(s)", d.located.len()),
    };
    let mut time = Figure::new(
        &format!("Residual of the model, {:.0} s means ({spans})", s.block_s),
        "time (h)",
        "residual (°/h)",
    );
    time.series.push(Series::new(
        "residual",
        hours.to_vec(),
        s.baseline_resid_dph.clone(),
        Style::Line,
    ));
    if !d.located.is_empty() {
        time.series.push(Series::new(
            "in a located span (significant residual)",
            hours.to_vec(),
            masked(&|i| in_span(s.t_s[i]), &s.baseline_resid_dph),
            Style::Points,
        ));
    }
    if let Some(f) = d.findings.first() {
        let in_where = |t: f64| f.where_.iter().any(|w| t >= w.t_start_s && t <= w.t_end_s);
        time.series.push(Series::new(
            &format!("where the {} effect is ≥ half its peak", f.mechanism),
            hours.to_vec(),
            masked(&|i| in_where(s.t_s[i]), &s.baseline_resid_dph),
            Style::Points,
        ));
    }
    let explained: Vec<f64> = s
        .baseline_resid_dph
        .iter()
        .zip(&s.final_resid_dph)
        .map(|(a, b)| a - b)
        .collect();
    if !d.findings.is_empty() {
        time.series.push(Series::new(
            "fitted effect of the findings",
            hours.to_vec(),
            explained.clone(),
            Style::Line,
        ));
    }
    if !s.unexplained_dph.is_empty() {
        // Drawn over the residual: on the findings' fitted effect where there are any.
        let over: Vec<f64> = s
            .unexplained_dph
            .iter()
            .zip(&explained)
            .map(|(u, e)| u + e)
            .collect();
        time.series.push(Series::new(
            "what no library term explains",
            hours.to_vec(),
            over,
            Style::Line,
        ));
    }
    time
}

/// The residual against temperature, split into heating, cooling and holds.
fn residual_temperature(d: &Diagnosis) -> Figure {
    let s = &d.series;
    let mut temp = Figure::new(
        &format!(
            "Residual of the model against temperature, {:.0} s means",
            s.block_s
        ),
        "T (°C)",
        "residual (°/h)",
    );
    let r = &s.dtemp_c_per_s;
    for (label, keep) in [
        (
            "heating",
            Box::new(|i: usize| r[i] > HOLD_RATE_C_PER_S) as Box<dyn Fn(usize) -> bool>,
        ),
        ("cooling", Box::new(|i: usize| r[i] < -HOLD_RATE_C_PER_S)),
        ("hold", Box::new(|i: usize| r[i].abs() <= HOLD_RATE_C_PER_S)),
    ] {
        let y = masked(&keep, &s.baseline_resid_dph);
        if y.iter().any(|v| v.is_finite()) {
            temp.series
                .push(Series::new(label, s.temp_c.clone(), y, Style::Points));
        }
    }
    // A bump at one temperature is a shape of temperature: drawn here, where it is one
    // curve, and not only against time, where it recurs at every pass through it.
    if matches!(d.evidence.unexplained, Some(Unexplained::TempWindow { .. }))
        && s.unexplained_dph.len() == s.temp_c.len()
    {
        let mut by_temp: Vec<(f64, f64)> = s
            .temp_c
            .iter()
            .copied()
            .zip(s.unexplained_dph.iter().copied())
            .collect();
        by_temp.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (t, u): (Vec<f64>, Vec<f64>) = by_temp.into_iter().unzip();
        temp.series.push(Series::new(
            "what no library term explains",
            t,
            u,
            Style::Line,
        ));
    }
    temp
}

/// The residual of the model as given and with the findings, against time (`hours`).
fn before_after(d: &Diagnosis, hours: &[f64]) -> Figure {
    let s = &d.series;
    let b = &d.baseline;
    let a = d.findings.last().map_or(b, |f| &f.improved);
    let mut ba = Figure::new(
        &format!(
            "Before / after: held-out 100 s stability {:.2e} → {:.2e} °/h",
            b.b100_dph, a.b100_dph
        ),
        "time (h)",
        "residual (°/h)",
    );
    ba.series.push(Series::new(
        "model as given",
        hours.to_vec(),
        s.baseline_resid_dph.clone(),
        Style::Line,
    ));
    ba.series.push(Series::new(
        &format!(
            "with {}",
            if d.findings.is_empty() {
                "no finding".to_string()
            } else {
                d.findings
                    .iter()
                    .map(|f| f.mechanism.name())
                    .collect::<Vec<_>>()
                    .join(" + ")
            }
        ),
        hours.to_vec(),
        s.final_resid_dph.clone(),
        Style::Line,
    ));
    ba
}

/// Writes the figures into `dir` (created if missing); returns their paths.
pub fn write(d: &Diagnosis, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    std::fs::create_dir_all(dir)?;
    figures(d)
        .into_iter()
        .map(|(name, fig)| {
            let p = dir.join(name);
            render_png(&fig, &p).map(|()| p)
        })
        .collect()
}
