//! The scenario figure: chamber and sensor temperatures and the gyro rate against time
//! (the layout of the paper's Fig. 3), for `rlg simulate --plot`.

use rlg_eval::metrics::block_means;
use rlg_io::plot::{Figure, Series, Style};
use rlg_io::recording::Recording;

/// Samples per plotted rate point: 100 s means at 1 Hz, as the paper plots them.
pub const RATE_BLOCK: usize = 100;

/// Temperatures (left axis, °C) and 100 s means of the rate (right axis, °/h) vs time (h).
pub fn scenario_figure(title: &str, rec: &Recording) -> Figure {
    let hours: Vec<f64> = rec.time_s.iter().map(|t| t / 3600.0).collect();
    let mut fig = Figure::new(title, "time (h)", "temperature (°C)");
    fig.y2_label = Some("gyro output, 100 s means (°/h)".to_string());
    if let Some(chamber) = &rec.chamber_c {
        fig.series.push(Series::new(
            "chamber air",
            hours.clone(),
            chamber.clone(),
            Style::Line,
        ));
    }
    fig.series.push(Series::new(
        "gyro sensor",
        hours.clone(),
        rec.temp_c.clone(),
        Style::Line,
    ));
    let t_mid = block_means(&hours, RATE_BLOCK);
    let rate = block_means(&rec.rate_dph, RATE_BLOCK);
    fig.series
        .push(Series::new("gyro output", t_mid, rate, Style::Line).on_right());
    fig
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figure_has_temperatures_and_block_means_and_renders() {
        let n = 1000;
        let rec = Recording {
            time_s: (0..n).map(f64::from).collect(),
            rate_dph: (0..n).map(|k| -7.1 + 1e-4 * f64::from(k % 7)).collect(),
            temp_c: (0..n).map(|k| 20.0 + 0.01 * f64::from(k)).collect(),
            chamber_c: Some((0..n).map(|k| 18.0 + 0.01 * f64::from(k)).collect()),
            ..Recording::default()
        };
        let fig = scenario_figure("t", &rec);
        assert_eq!(fig.series.len(), 3);
        assert_eq!(fig.series[2].x.len(), 10);
        assert!((fig.series[2].x[0] - 49.5 / 3600.0).abs() < 1e-12);
        let path = std::env::temp_dir().join(format!("rlg-scenario-{}.png", std::process::id()));
        rlg_io::plot::render_png(&fig, &path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    }
}
