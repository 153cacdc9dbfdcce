//! The benchmark's Markdown report.

use super::label::Label;
use super::result::CaseResult;
use rlg_diagnose::candidates::Family;

/// The results as a Markdown report: the summary table, the operating curve at smaller α
/// and the confusion matrix.
pub fn report_markdown(results: &[CaseResult]) -> String {
    use std::fmt::Write as _;
    let mut o = String::new();
    let hidden: Vec<&CaseResult> = results.iter().filter(|r| r.truth != Label::None).collect();
    let nulls: Vec<&CaseResult> = results.iter().filter(|r| r.truth == Label::None).collect();
    let shift = results.iter().map(|r| r.shift).max().unwrap_or(0);
    if shift > 0 {
        let _ = writeln!(
            o,
            "Each recording diagnosed without its first {shift} samples (its 100 s blocks start \
             {shift} samples later).\n"
        );
    }
    summary(&mut o, results, &hidden, &nulls);
    operating_curve(&mut o, results, &hidden, &nulls);
    confusion_matrix(&mut o, results);
    o
}

/// `a` of `b` as a percentage with the counts ("–" for none).
pub(super) fn pct(a: usize, b: usize) -> String {
    if b == 0 {
        "–".to_string()
    } else {
        format!("{:.0} % ({a}/{b})", 100.0 * a as f64 / b as f64)
    }
}

/// The cases hiding a term whose detectability is in `lo` … `hi`.
fn in_band<'a>(hidden: &[&'a CaseResult], lo: f64, hi: f64) -> Vec<&'a CaseResult> {
    hidden
        .iter()
        .filter(|r| r.detectability >= lo && r.detectability < hi)
        .copied()
        .collect()
}

/// The summary table: false alarms, top-1 by detectability, parameters, localisation, gain,
/// concealment and time.
fn summary(o: &mut String, results: &[CaseResult], hidden: &[&CaseResult], nulls: &[&CaseResult]) {
    use std::fmt::Write as _;
    let fa = nulls.iter().filter(|r| r.predicted != Label::None).count();
    let fa_mp = nulls
        .iter()
        .filter(|r| matches!(r.predicted, Label::Mechanism(_)))
        .count();
    let _ = writeln!(o, "| measure | result | target |\n|---|---|---|");
    let _ = writeln!(
        o,
        "| false alarms (any verdict but consistent) | {} | ≤ 5 % |",
        pct(fa, nulls.len())
    );
    let _ = writeln!(
        o,
        "| false alarms naming a mechanism | {} | |",
        pct(fa_mp, nulls.len())
    );
    for (name, lo, hi, target) in [
        ("top-1, D 3–5", 3.0, 5.0, "≥ 70 %"),
        ("top-1, D 5–6", 5.0, 6.0, ""),
        ("top-1, D ≥ 6", 6.0, f64::INFINITY, "≥ 90 %"),
    ] {
        let set = in_band(hidden, lo, hi);
        let ok = set.iter().filter(|r| r.predicted == r.truth).count();
        let _ = writeln!(o, "| {name} | {} | {target} |", pct(ok, set.len()));
    }
    let correct: Vec<&CaseResult> = hidden
        .iter()
        .filter(|r| r.predicted == r.truth)
        .copied()
        .collect();
    parameter_rows(o, &correct);
    let iok = correct
        .iter()
        .filter(|r| r.iou.is_some_and(|v| v >= 0.5))
        .count();
    let _ = writeln!(
        o,
        "| localisation IoU ≥ 0.5 (of correct) | {} | |",
        pct(iok, correct.len())
    );
    let mut g: Vec<f64> = correct.iter().filter_map(|r| r.gain_fraction).collect();
    g.sort_by(f64::total_cmp);
    let gok = g.iter().filter(|v| **v >= 0.8).count();
    let med = g.get(g.len() / 2).copied().unwrap_or(f64::NAN);
    let _ = writeln!(
        o,
        "| held-out gain ≥ 80 % of the true model's (of correct) | {} (median {med:.2}) | ≥ 80 % |",
        pct(gok, g.len())
    );
    let conc = hidden.iter().filter(|r| r.peak_over_sigma1 < 0.5).count();
    let _ = writeln!(
        o,
        "| concealed (peak < σ₁/2) | {} | all |",
        pct(conc, hidden.len())
    );
    let mut span: Vec<f64> = hidden.iter().map(|r| r.energy_in_span).collect();
    span.sort_by(f64::total_cmp);
    let _ = writeln!(
        o,
        "| median energy share inside the baseline span | {:.2} | > 0.5 |",
        span.get(span.len() / 2).copied().unwrap_or(f64::NAN)
    );
    let mut secs: Vec<f64> = results.iter().map(|r| r.seconds).collect();
    secs.sort_by(f64::total_cmp);
    let _ = writeln!(
        o,
        "| diagnosis time per recording (median / max) | {:.2} s / {:.2} s | |",
        secs.get(secs.len() / 2).copied().unwrap_or(0.0),
        secs.last().copied().unwrap_or(0.0)
    );
}

/// The key parameter of the correctly named cases: within tolerance, and what the
/// diagnosis' own 1σ says it should reach, Σ P(|N(0, σᵢ)| ≤ tolᵢ), with how often the truth
/// lies within 1σ and 2σ (68 % and 95 % if the σ are right).
fn parameter_rows(o: &mut String, correct: &[&CaseResult]) {
    use std::fmt::Write as _;
    let pok = correct.iter().filter(|r| r.param_ok == Some(true)).count();
    let _ = writeln!(
        o,
        "| key parameter within 20 %/25 % (of correct) | {} | ≥ 80 % |",
        pct(pok, correct.len())
    );
    let with_p: Vec<(f64, f64, f64, f64)> = correct
        .iter()
        .filter_map(|r| {
            let (t, f, u) = r.param?;
            let Label::Mechanism(m) = r.truth else {
                return None;
            };
            let tol = Family::of(m)?.key_parameter().1;
            Some((t, f, u, tol))
        })
        .filter(|(t, _, u, _)| *t != 0.0 && u.is_finite() && *u > 0.0)
        .collect();
    if with_p.is_empty() {
        return;
    }
    let m = with_p.len() as f64;
    let expected: f64 = with_p
        .iter()
        .map(|(t, _, u, tol)| statrs::function::erf::erf(tol * t.abs() / u / 2f64.sqrt()))
        .sum();
    let within = |k: f64| {
        with_p
            .iter()
            .filter(|(t, f, u, _)| (f - t).abs() <= k * u)
            .count() as f64
    };
    let _ = writeln!(
        o,
        "| key parameter: share within tolerance its reported 1σ predicts; truth within 1σ / 2σ | {:.0} %; {:.0} % / {:.0} % | (68 % / 95 %) |",
        100.0 * expected / m,
        100.0 * within(1.0) / m,
        100.0 * within(2.0) / m
    );
}

/// The operating curve: the verdicts at every smaller false-alarm probability of 0.25 … 5 %
/// than the run's, from the bootstrap p-values.
fn operating_curve(
    o: &mut String,
    results: &[CaseResult],
    hidden: &[&CaseResult],
    nulls: &[&CaseResult],
) {
    use std::fmt::Write as _;
    let run_alpha = results.iter().map(|r| r.alpha).fold(0.0, f64::max);
    let alphas: Vec<f64> = [0.0025, 0.005, 0.01, 0.02, 0.03, 0.05]
        .into_iter()
        .filter(|a| *a <= run_alpha + 1e-12)
        .collect();
    if alphas.len() <= 1 {
        return;
    }
    let _ = writeln!(
        o,
        "\nOperating curve (verdicts at a smaller α from the bootstrap p-values; the run's α = {:.1} %):\n",
        100.0 * run_alpha
    );
    let _ = writeln!(
        o,
        "| α | false alarms | top-1 D 3–5 | D 5–6 | D ≥ 6 | D 3–5 found if the family were known |\n|---|---|---|---|---|---|"
    );
    for a in alphas {
        let fa = nulls
            .iter()
            .filter(|r| r.predicted_at(a) != Label::None)
            .count();
        let band = |lo: f64, hi: f64| {
            let set = in_band(hidden, lo, hi);
            pct(
                set.iter().filter(|r| r.predicted_at(a) == r.truth).count(),
                set.len(),
            )
        };
        let low = in_band(hidden, 3.0, 5.0);
        let known = low
            .iter()
            .filter(|r| r.p_values.true_family_alone.is_some_and(|p| p <= a))
            .count();
        let _ = writeln!(
            o,
            "| {:.2} % | {} | {} | {} | {} | {} |",
            100.0 * a,
            pct(fa, nulls.len()),
            band(3.0, 5.0),
            band(5.0, 6.0),
            band(6.0, f64::INFINITY),
            pct(known, low.len())
        );
    }
}

/// The confusion matrix: rows the hidden term, columns the diagnosis.
fn confusion_matrix(o: &mut String, results: &[CaseResult]) {
    use std::fmt::Write as _;
    let mut cols: Vec<Label> = Family::ALL
        .iter()
        .map(|f| Label::Mechanism(f.mechanism()))
        .collect();
    cols.push(Label::None);
    cols.push(Label::Unexplained);
    let _ = writeln!(
        o,
        "\nConfusion matrix (rows: hidden term, columns: diagnosis):\n"
    );
    let names: Vec<&str> = cols.iter().map(|c| c.name()).collect();
    let _ = writeln!(o, "| truth \\ diagnosed | {} |", names.join(" | "));
    let _ = writeln!(o, "|---|{}", "---|".repeat(cols.len()));
    for row in cols.iter().take(cols.len() - 1) {
        let rs: Vec<&CaseResult> = results.iter().filter(|r| r.truth == *row).collect();
        if rs.is_empty() {
            continue;
        }
        let cells: Vec<String> = cols
            .iter()
            .map(|c| rs.iter().filter(|r| r.predicted == *c).count().to_string())
            .collect();
        let _ = writeln!(o, "| {row} | {} |", cells.join(" | "));
    }
}
