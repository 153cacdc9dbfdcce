//! The paper's static model (Table 1, Fig. 2(a)): least-squares quadratic of the averaged
//! gyro output on gyro BODY temperature, errors quoted as prediction − measurement.
//!
//! Both conventions were checked against the published error row: the body-temperature
//! regressor with prediction − measurement reproduces all 11 published errors within
//! [`PAPER_QUAD_ERR_TOL_DPH`] (see the test); the chamber set temperature does not.

use super::poly::{PolyError, PolyFit};
use rlg_io::plot::{Figure, Series, Style};
use rlg_io::table1::Table1Row;

/// Published quadratic errors are printed to 3 significant digits of 1e-4 °/h and the
/// outputs to 1e-4 °/h, so an honest refit agrees to a fraction of 1e-4 °/h. Budget
/// 0.5e-4 °/h per point; measured max |ours − paper| = 3.6e-5 °/h (point 7, T = 24.75 °C).
pub const PAPER_QUAD_ERR_TOL_DPH: f64 = 0.5e-4;

/// One point of the static reproduction. All errors are prediction − measurement, °/h.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaticPoint {
    /// Chamber set temperature, °C.
    pub chamber_c: f64,
    /// Gyro body temperature (the regressor), °C.
    pub temp_c: f64,
    /// Measured averaged output, °/h.
    pub measured_dph: f64,
    /// The paper's quadratic-model error, °/h.
    pub paper_quad_err_dph: f64,
    /// Our quadratic's TRAINING error (fit to all 11 points), °/h.
    pub quad_err_dph: f64,
    /// Our quadratic's LEAVE-ONE-OUT error (refit without this point), °/h.
    pub loo_err_dph: f64,
}

/// The quadratic fit and its per-point errors.
#[derive(Debug, Clone, PartialEq)]
pub struct StaticRepro {
    /// The quadratic rate_dph(temp_c); coefficients in °/h, °/h/°C, °/h/°C².
    pub fit: PolyFit,
    /// One entry per Table 1 row, in table order.
    pub points: Vec<StaticPoint>,
}

impl StaticRepro {
    /// Largest |training error|, °/h.
    pub fn max_abs_train_err_dph(&self) -> f64 {
        self.points
            .iter()
            .map(|p| p.quad_err_dph.abs())
            .fold(0.0, f64::max)
    }
    /// Largest |LOO error|, °/h.
    pub fn max_abs_loo_err_dph(&self) -> f64 {
        self.points
            .iter()
            .map(|p| p.loo_err_dph.abs())
            .fold(0.0, f64::max)
    }
    /// Largest |ours − paper| over the training errors, °/h.
    pub fn max_abs_diff_from_paper_dph(&self) -> f64 {
        self.points
            .iter()
            .map(|p| (p.quad_err_dph - p.paper_quad_err_dph).abs())
            .fold(0.0, f64::max)
    }
}

impl StaticRepro {
    /// Markdown table: point, T, measured, paper's quadratic error, our training error, our
    /// leave-one-out error (errors in 1e-4 °/h, prediction − measurement).
    pub fn to_markdown(&self) -> String {
        let mut s = String::from(
            "| point | chamber (°C) | T body (°C) | measured (°/h) | paper quad err (1e-4 °/h) \
             | our quad err, training (1e-4 °/h) | our quad err, LOO (1e-4 °/h) |\n\
             |---:|---:|---:|---:|---:|---:|---:|\n",
        );
        for (i, p) in self.points.iter().enumerate() {
            s.push_str(&format!(
                "| {} | {:.0} | {:.2} | {:.4} | {:.2} | {:.2} | {:.2} |\n",
                i + 1,
                p.chamber_c,
                p.temp_c,
                p.measured_dph,
                p.paper_quad_err_dph * 1e4,
                p.quad_err_dph * 1e4,
                p.loo_err_dph * 1e4
            ));
        }
        s
    }

    /// A Fig. 2(a)-style figure: measured points and the quadratic on the left axis
    /// (°/h), training errors (ours and the paper's) on the right axis (1e-4 °/h).
    pub fn figure(&self) -> Figure {
        let t: Vec<f64> = self.points.iter().map(|p| p.temp_c).collect();
        let (lo, hi) = (t[0].min(t[t.len() - 1]), t[0].max(t[t.len() - 1]));
        let lo = t.iter().cloned().fold(lo, f64::min);
        let hi = t.iter().cloned().fold(hi, f64::max);
        let grid: Vec<f64> = (0..=200)
            .map(|i| lo + (hi - lo) * i as f64 / 200.0)
            .collect();
        let mut f = Figure::new(
            "Static test (Table 1): least-squares quadratic of gyro output on body temperature",
            "body temperature T (°C)",
            "gyro output (°/h)",
        );
        f.y2_label = Some("model error, prediction − measurement (1e-4 °/h)".into());
        f.series = vec![
            Series::new(
                "measured",
                t.clone(),
                self.points.iter().map(|p| p.measured_dph).collect(),
                Style::Points,
            ),
            Series::new(
                "quadratic fit",
                grid.clone(),
                grid.iter().map(|&x| self.fit.predict(x)).collect(),
                Style::Line,
            ),
            Series::new(
                "our training error (right axis)",
                t.clone(),
                self.points.iter().map(|p| p.quad_err_dph * 1e4).collect(),
                Style::LinePoints,
            )
            .on_right(),
            Series::new(
                "paper's error (right axis)",
                t,
                self.points
                    .iter()
                    .map(|p| p.paper_quad_err_dph * 1e4)
                    .collect(),
                Style::Points,
            )
            .on_right(),
        ];
        f
    }
}

/// Fits the least-squares quadratic of `rate_dph` on body temperature `temp_c` to the rows
/// and reports training and leave-one-out errors (prediction − measurement).
pub fn static_quadratic(rows: &[Table1Row]) -> Result<StaticRepro, PolyError> {
    static_polynomial(rows, 2)
}

/// As [`static_quadratic`] with a polynomial of `degree` (the paper's errors stay beside it
/// for comparison; they belong to its quadratic).
pub fn static_polynomial(rows: &[Table1Row], degree: usize) -> Result<StaticRepro, PolyError> {
    let t: Vec<f64> = rows.iter().map(|r| r.temp_c).collect();
    let y: Vec<f64> = rows.iter().map(|r| r.rate_dph).collect();
    let fit = PolyFit::fit(&t, &y, degree)?;
    let loo = fit.loo_residuals()?;
    let points = rows
        .iter()
        .zip(fit.residuals())
        .zip(loo)
        .map(|((r, e), l)| StaticPoint {
            chamber_c: r.chamber_c,
            temp_c: r.temp_c,
            measured_dph: r.rate_dph,
            paper_quad_err_dph: r.quad_err_1e4_dph * 1e-4,
            // residual = y − ŷ; the paper quotes ŷ − y.
            quad_err_dph: -e,
            loo_err_dph: -l,
        })
        .collect();
    Ok(StaticRepro { fit, points })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rlg_io::table1::bundled;

    /// Pins the reproduction of the published quadratic-error row of Table 1.
    #[test]
    fn reproduces_paper_quadratic_errors() {
        let r = static_quadratic(&bundled().unwrap()).unwrap();
        for p in &r.points {
            assert!(
                (p.quad_err_dph - p.paper_quad_err_dph).abs() <= PAPER_QUAD_ERR_TOL_DPH,
                "T = {} °C: ours {:.3e}, paper {:.3e}",
                p.temp_c,
                p.quad_err_dph,
                p.paper_quad_err_dph
            );
        }
        eprintln!(
            "max |ours − paper| = {:.3e} °/h",
            r.max_abs_diff_from_paper_dph()
        );
        // The paper: "maximum error of least-squares quadratic model is less than 0.0014 °/h".
        assert!(r.max_abs_train_err_dph() < 0.0014);
    }

    /// The chamber temperature as regressor does NOT reproduce the paper (so the choice of
    /// body temperature is a finding, not an assumption).
    #[test]
    fn chamber_regressor_does_not_reproduce_paper() {
        let rows = bundled().unwrap();
        let x: Vec<f64> = rows.iter().map(|r| r.chamber_c).collect();
        let y: Vec<f64> = rows.iter().map(|r| r.rate_dph).collect();
        let f = PolyFit::fit(&x, &y, 2).unwrap();
        let worst = rows
            .iter()
            .zip(f.residuals())
            .map(|(r, e)| (-e - r.quad_err_1e4_dph * 1e-4).abs())
            .fold(0.0, f64::max);
        assert!(worst > PAPER_QUAD_ERR_TOL_DPH, "{worst}");
    }

    /// A cubic has a smaller training error than the quadratic on the same points (nested
    /// models); on Table 1 its leave-one-out PRESS is smaller too (measured 1.64e-5 against
    /// 2.20e-5 (°/h)²), so the paper's quadratic is not the best polynomial for these points.
    #[test]
    fn a_cubic_fits_and_predicts_table_1_better() {
        let rows = bundled().unwrap();
        let (q, c) = (
            static_quadratic(&rows).unwrap(),
            static_polynomial(&rows, 3).unwrap(),
        );
        assert_eq!(c.fit.degree(), 3);
        let rss = |r: &StaticRepro| r.points.iter().map(|p| p.quad_err_dph.powi(2)).sum::<f64>();
        let press = |r: &StaticRepro| r.points.iter().map(|p| p.loo_err_dph.powi(2)).sum::<f64>();
        assert!(rss(&c) < rss(&q));
        assert!(press(&c) < press(&q));
        eprintln!("PRESS quadratic {:.3e}, cubic {:.3e}", press(&q), press(&c));
    }

    /// LOO errors are never smaller in magnitude than training errors (|e/(1−h)| ≥ |e|).
    #[test]
    fn loo_errors_exceed_training_errors() {
        let r = static_quadratic(&bundled().unwrap()).unwrap();
        for p in &r.points {
            assert!(p.loo_err_dph.abs() >= p.quad_err_dph.abs());
        }
    }
}
