//! Side-by-side comparison of our figures of merit with the paper's.

/// Improvement factor raw / compensated (the paper's "increase of N times", e.g.
/// 0.0102 / 0.0016 = 6.375). `None` unless both are finite and `compensated > 0`.
pub fn improvement_factor(raw: f64, compensated: f64) -> Option<f64> {
    (raw.is_finite() && compensated.is_finite() && compensated > 0.0).then(|| raw / compensated)
}

/// A figure of merit as we measured it, next to the paper's value when it gives one.
#[derive(Debug, Clone, PartialEq)]
pub struct FigureOfMerit {
    /// What is measured, e.g. "100 s bias stability, raw".
    pub name: String,
    /// Unit of `ours` and `paper`, e.g. "°/h" (empty for a ratio).
    pub unit: String,
    /// Our value.
    pub ours: f64,
    /// The paper's value, if it states one.
    pub paper: Option<f64>,
}

impl FigureOfMerit {
    /// A figure with its paper value.
    pub fn new(name: &str, unit: &str, ours: f64, paper: Option<f64>) -> Self {
        Self {
            name: name.into(),
            unit: unit.into(),
            ours,
            paper,
        }
    }

    /// ours / paper; `None` without a paper value or when it is zero.
    pub fn ratio_to_paper(&self) -> Option<f64> {
        self.paper
            .filter(|p| *p != 0.0 && p.is_finite())
            .map(|p| self.ours / p)
    }
}

/// Formats a value with 4 significant digits, in plain notation where that is readable.
fn fmt_sig(v: f64) -> String {
    if v == 0.0 || (1e-3..1e5).contains(&v.abs()) {
        let digits = if v == 0.0 {
            3
        } else {
            (3 - v.abs().log10().floor() as i32).max(0) as usize
        };
        format!("{v:.digits$}")
    } else {
        format!("{v:.3e}")
    }
}

/// Escapes the Markdown cell separator so names like "max |e|" keep the table intact.
fn escape(s: &str) -> String {
    s.replace('|', "\\|")
}

/// A Markdown table: figure | unit | ours | paper | ours/paper ("—" where absent).
pub fn markdown_table(rows: &[FigureOfMerit]) -> String {
    let mut s =
        String::from("| figure | unit | ours | paper | ours/paper |\n|---|---|---:|---:|---:|\n");
    for r in rows {
        let dash = || "—".to_string();
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} |\n",
            escape(&r.name),
            escape(&r.unit),
            fmt_sig(r.ours),
            r.paper.map_or_else(dash, fmt_sig),
            r.ratio_to_paper().map_or_else(dash, |x| format!("{x:.2}")),
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's own factors (Sec. 4): 0.0102/0.0016 = 6.375 and 0.0102/0.0011 = 9.273.
    #[test]
    fn improvement_factor_reproduces_paper() {
        use crate::paper::{LSSVM_B100_DPH, RAW_B100_DPH, STEPWISE_B100_DPH};
        assert!(
            (improvement_factor(RAW_B100_DPH, STEPWISE_B100_DPH).unwrap() - 6.375).abs() < 1e-12
        );
        assert!((improvement_factor(RAW_B100_DPH, LSSVM_B100_DPH).unwrap() - 9.273).abs() < 5e-4);
        assert_eq!(improvement_factor(1.0, 0.0), None);
        assert_eq!(improvement_factor(f64::NAN, 1.0), None);
    }

    #[test]
    fn markdown_table_lists_each_figure() {
        let rows = [
            FigureOfMerit::new("100 s stability, raw", "°/h", 0.0104, Some(0.0102)),
            FigureOfMerit::new("max LOO error", "°/h", 1.23e-4, None),
        ];
        let t = markdown_table(&rows);
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines.len(), 4);
        assert_eq!(
            lines[2],
            "| 100 s stability, raw | °/h | 0.01040 | 0.01020 | 1.02 |"
        );
        assert_eq!(lines[3], "| max LOO error | °/h | 1.230e-4 | — | — |");
        let t = markdown_table(&[FigureOfMerit::new("max |e|", "°/h", 1.0, None)]);
        assert!(t.contains("| max \\|e\\| | °/h |"), "{t}");
    }
}
