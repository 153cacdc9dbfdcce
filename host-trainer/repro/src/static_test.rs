//! The static test (Table 1, Fig. 2): the least-squares quadratic and an LS-SVM fitted to the
//! 11 averaged temperature points, each with training and leave-one-out errors.
//!
//! The paper does not state its LS-SVM's σ and c. Here they are chosen by the closed-form
//! leave-one-out error ([`rlg_train::lssvm::tune`], the points are independent 1 h means), so the
//! training errors are those of an honestly tuned model, not of one tuned to match the
//! paper's error row. With 11 points an LS-SVM can interpolate; its training error alone says
//! nothing about prediction, which is why the leave-one-out errors stand beside it.

use indicatif::ProgressBar;

use rlg_eval::baselines::{static_quadratic, StaticRepro};
use rlg_io::plot::{Figure, Series, Style};
use rlg_io::table1::Table1Row;
use rlg_train::lssvm::tune::{tune, Grid, Tuned, Validation};
use rlg_train::lssvm::Lssvm;

use crate::ReproError;

/// One Table 1 point with every model's errors (prediction − measurement, °/h).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StaticRow {
    /// Body temperature, °C.
    pub temp_c: f64,
    /// Measured output, °/h.
    pub measured_dph: f64,
    /// The paper's quadratic error.
    pub paper_quad_err_dph: f64,
    /// The paper's LS-SVM error.
    pub paper_lssvm_err_dph: f64,
    /// Our quadratic, TRAINING error.
    pub quad_train_err_dph: f64,
    /// Our quadratic, LEAVE-ONE-OUT error.
    pub quad_loo_err_dph: f64,
    /// Our LS-SVM, TRAINING error.
    pub lssvm_train_err_dph: f64,
    /// Our LS-SVM, LEAVE-ONE-OUT error (closed form).
    pub lssvm_loo_err_dph: f64,
}

/// The static reproduction.
#[derive(Clone, Debug)]
pub struct StaticResult {
    /// The quadratic and its per-point errors.
    pub quadratic: StaticRepro,
    /// The LS-SVM trained on all 11 points with the tuned σ, c.
    pub lssvm: Lssvm,
    /// How σ and c were chosen.
    pub tuned: Tuned,
    /// Per-point errors of every model.
    pub rows: Vec<StaticRow>,
}

fn max_abs(v: impl Iterator<Item = f64>) -> f64 {
    v.map(f64::abs).fold(0.0, f64::max)
}

impl StaticResult {
    /// Largest |error| of one column of [`StaticRow`].
    pub fn max_abs(&self, f: impl Fn(&StaticRow) -> f64) -> f64 {
        max_abs(self.rows.iter().map(f))
    }

    /// Markdown table of the per-point errors in 1e-4 °/h.
    pub fn to_markdown(&self) -> String {
        let mut s = String::from(
            "| T body (°C) | measured (°/h) | quad, paper | quad, TRAINING | quad, LOO \
             | LS-SVM, paper | LS-SVM, TRAINING | LS-SVM, LOO |\n\
             |---:|---:|---:|---:|---:|---:|---:|---:|\n",
        );
        for r in &self.rows {
            s.push_str(&format!(
                "| {:.2} | {:.4} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |\n",
                r.temp_c,
                r.measured_dph,
                r.paper_quad_err_dph * 1e4,
                r.quad_train_err_dph * 1e4,
                r.quad_loo_err_dph * 1e4,
                r.paper_lssvm_err_dph * 1e4,
                r.lssvm_train_err_dph * 1e4,
                r.lssvm_loo_err_dph * 1e4,
            ));
        }
        s.push_str(&format!(
            "| **max \\|e\\|** | | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |\n",
            self.max_abs(|r| r.paper_quad_err_dph) * 1e4,
            self.max_abs(|r| r.quad_train_err_dph) * 1e4,
            self.max_abs(|r| r.quad_loo_err_dph) * 1e4,
            self.max_abs(|r| r.paper_lssvm_err_dph) * 1e4,
            self.max_abs(|r| r.lssvm_train_err_dph) * 1e4,
            self.max_abs(|r| r.lssvm_loo_err_dph) * 1e4,
        ));
        s
    }

    /// Fig. 2(b)-style figure: measured points, the LS-SVM and the quadratic (left axis) and
    /// the LS-SVM's training and leave-one-out errors (right axis, 1e-4 °/h).
    pub fn lssvm_figure(&self) -> Figure {
        let t: Vec<f64> = self.rows.iter().map(|r| r.temp_c).collect();
        let (lo, hi) = t
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let grid: Vec<f64> = (0..=300)
            .map(|i| lo + (hi - lo) * i as f64 / 300.0)
            .collect();
        let mut f = Figure::new(
            &format!(
                "Static test (Table 1): LS-SVM, σ = {:.3}, c = {:.3e} (leave-one-out)",
                self.tuned.sigma, self.tuned.c
            ),
            "body temperature T (°C)",
            "gyro output (°/h)",
        );
        f.y2_label = Some("error, prediction − measurement (1e-4 °/h)".into());
        f.series = vec![
            Series::new(
                "measured",
                t.clone(),
                self.rows.iter().map(|r| r.measured_dph).collect(),
                Style::Points,
            ),
            Series::new(
                "LS-SVM",
                grid.clone(),
                grid.iter().map(|&x| self.lssvm.predict(&[x])).collect(),
                Style::Line,
            ),
            Series::new(
                "quadratic",
                grid.clone(),
                grid.iter()
                    .map(|&x| self.quadratic.fit.predict(x))
                    .collect(),
                Style::Line,
            ),
            Series::new(
                "LS-SVM training error (right)",
                t.clone(),
                self.rows
                    .iter()
                    .map(|r| r.lssvm_train_err_dph * 1e4)
                    .collect(),
                Style::LinePoints,
            )
            .on_right(),
            Series::new(
                "LS-SVM leave-one-out error (right)",
                t.clone(),
                self.rows
                    .iter()
                    .map(|r| r.lssvm_loo_err_dph * 1e4)
                    .collect(),
                Style::LinePoints,
            )
            .on_right(),
            Series::new(
                "paper's LS-SVM error (right)",
                t,
                self.rows
                    .iter()
                    .map(|r| r.paper_lssvm_err_dph * 1e4)
                    .collect(),
                Style::Points,
            )
            .on_right(),
        ];
        f
    }
}

/// Fits both models to the Table 1 rows (σ, c of the LS-SVM by leave-one-out over `grid`).
pub fn reproduce(
    rows: &[Table1Row],
    grid: &Grid,
    progress: &ProgressBar,
) -> Result<StaticResult, ReproError> {
    let quadratic = static_quadratic(rows)?;
    let names = vec!["temp_c".to_string()];
    let x: Vec<Vec<f64>> = rows.iter().map(|r| vec![r.temp_c]).collect();
    let y: Vec<f64> = rows.iter().map(|r| r.rate_dph).collect();
    let tuned = tune(&names, &x, &y, &Validation::LeaveOneOut, grid, progress)?;
    let lssvm = Lssvm::train(&names, &x, &y, tuned.sigma, tuned.c)?;
    let z: Vec<Vec<f64>> = x.iter().map(|r| lssvm.scaling.apply(r)).collect();
    let loo = rlg_train::lssvm::loo_residuals(&z, &y, tuned.sigma, tuned.c)?;
    let out = rows
        .iter()
        .zip(&quadratic.points)
        .zip(&loo)
        .map(|((r, q), l)| StaticRow {
            temp_c: r.temp_c,
            measured_dph: r.rate_dph,
            paper_quad_err_dph: r.quad_err_1e4_dph * 1e-4,
            paper_lssvm_err_dph: r.lssvm_err_1e4_dph * 1e-4,
            quad_train_err_dph: q.quad_err_dph,
            quad_loo_err_dph: q.loo_err_dph,
            lssvm_train_err_dph: lssvm.predict(&[r.temp_c]) - r.rate_dph,
            // The LOO residual is y − f₋ᵢ(x); the paper's sign is prediction − measurement.
            lssvm_loo_err_dph: -l,
        })
        .collect();
    Ok(StaticResult {
        quadratic,
        lssvm,
        tuned,
        rows: out,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pins the static reproduction on the shipped Table 1: the quadratic's training errors
    /// are the paper's row (within its 0.5e-4 °/h print budget), the LS-SVM's leave-one-out
    /// errors equal explicit 10-point refits, and its training error is below its LOO error
    /// (a model judged on its own training points flatters itself).
    #[test]
    fn static_reproduction_on_table_1() {
        let rows = rlg_io::table1::bundled().unwrap();
        let r = reproduce(&rows, &Grid::default(), &ProgressBar::hidden()).unwrap();
        for row in &r.rows {
            assert!(
                (row.quad_train_err_dph - row.paper_quad_err_dph).abs()
                    < rlg_eval::baselines::static_quad::PAPER_QUAD_ERR_TOL_DPH,
                "{row:?}"
            );
        }
        let paper_max = r.max_abs(|p| p.paper_quad_err_dph);
        assert!((paper_max - super::super::paper::STATIC_QUAD_MAX_ERR_DPH).abs() < 1e-12);
        for (i, row) in r.rows.iter().enumerate() {
            let keep: Vec<&Table1Row> = rows
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, p)| p)
                .collect();
            let x: Vec<Vec<f64>> = keep.iter().map(|p| vec![p.temp_c]).collect();
            let y: Vec<f64> = keep.iter().map(|p| p.rate_dph).collect();
            // Same standardisation as the full model (the closed form keeps it fixed).
            let z: Vec<Vec<f64>> = x.iter().map(|v| r.lssvm.scaling.apply(v)).collect();
            let sol = rlg_train::lssvm::solve(&z, &y, r.tuned.sigma, r.tuned.c).unwrap();
            let zi = r.lssvm.scaling.apply(&[row.temp_c]);
            let inv = 1.0 / (2.0 * r.tuned.sigma * r.tuned.sigma);
            let f: f64 = z
                .iter()
                .zip(&sol.alpha)
                .map(|(s, a)| a * (-(s[0] - zi[0]).powi(2) * inv).exp())
                .sum::<f64>()
                + sol.bias;
            let want = f - row.measured_dph;
            assert!(
                (row.lssvm_loo_err_dph - want).abs() < 1e-9,
                "point {i}: {} vs {want}",
                row.lssvm_loo_err_dph
            );
        }
        let train = r.max_abs(|p| p.lssvm_train_err_dph);
        let loo = r.max_abs(|p| p.lssvm_loo_err_dph);
        assert!(train < loo, "training {train} vs LOO {loo}");
        // Both models explain the 0.041 °/h span of Table 1 to a few 1e-4 °/h in training.
        assert!(train < 2e-3 && r.max_abs(|p| p.quad_train_err_dph) < 1.4e-3);
    }
}
