//! The mismatched set's Markdown report and calibration figure.

use std::fmt::Write as _;
use std::path::Path;

use plotters::prelude::*;
use rlg_io::plot::render_custom_png;

use super::curve::{frame, legend};
use super::gen::{BESIDE_TAGS, CONDITION_TAGS};
use super::logger::LOGGER_TAGS;
use super::{Kind, MismatchResult};
use crate::diagnose::report::pct;
use crate::diagnose::{BenchError, CaseResult, Label};
use rlg_diagnose::candidates::Family;

/// The α at which the calibration is read.
const CAL_ALPHAS: [f64; 4] = [0.01, 0.02, 0.05, 0.10];

/// 95 % Wilson interval of a share k/n.
pub(super) fn wilson(k: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let (z, nf) = (1.96, n as f64);
    let p = k as f64 / nf;
    let c = (p + z * z / (2.0 * nf)) / (1.0 + z * z / nf);
    let h = z / (1.0 + z * z / nf) * (p * (1.0 - p) / nf + z * z / (4.0 * nf * nf)).sqrt();
    ((c - h).max(0.0), (c + h).min(1.0))
}

/// The α the run was made at (the largest of its cases').
fn run_alpha(results: &[MismatchResult]) -> f64 {
    results.iter().map(|r| r.result.alpha).fold(0.0, f64::max)
}

/// Clean recordings flagged at α (any verdict but consistent).
fn flagged(clean: &[&CaseResult], a: f64) -> usize {
    clean
        .iter()
        .filter(|r| r.predicted_at(a) != Label::None)
        .count()
}

/// Clean recordings whose best candidate has p ≤ α.
fn p_best(clean: &[&CaseResult], a: f64) -> usize {
    clean.iter().filter(|r| r.p_values.best <= a).count()
}

/// The report of a mismatched run: the summary, top-1 by form, the calibration, false
/// alarms by condition and the confusion matrix.
pub fn mismatch_report_markdown(results: &[MismatchResult]) -> String {
    let mut o = String::new();
    let ra = run_alpha(results);
    let clean: Vec<&CaseResult> = results
        .iter()
        .filter(|r| r.kind == Kind::Clean)
        .map(|r| &r.result)
        .collect();
    let _ = writeln!(
        o,
        "Mismatched set (independent generator): {} recordings, diagnosed at α = {:.1} %.\n",
        results.len(),
        100.0 * ra
    );
    let shift = results.iter().map(|r| r.result.shift).max().unwrap_or(0);
    if shift > 0 {
        let _ = writeln!(
            o,
            "Each recording diagnosed without its first {shift} samples (its 100 s blocks start \
             {shift} samples later).\n"
        );
    }
    summary(&mut o, results, &clean, ra);
    two_effects_table(&mut o, results);
    coarse_table(&mut o, results);
    noise_in_time_table(&mut o, results);
    forms_table(&mut o, results);
    super::curve::curve_table(&mut o, results);
    // A run of hidden effects only (`--only` without `none`) has no false alarms to count.
    if clean.is_empty() {
        o.push_str(
            "\nNo clean recordings in this run: the false alarms and the p-values' calibration \
             are measured on runs that include them.\n",
        );
    } else {
        o.push_str(&calibration_markdown(&clean));
        conditions_table(&mut o, results, ra);
    }
    confusion_matrix(&mut o, results);
    o
}

/// With two effects hidden (`--two-effects`): how often each is named by some finding,
/// by the D of each.
fn two_effects_table(o: &mut String, results: &[MismatchResult]) {
    let two: Vec<&super::TwoFound> = results.iter().filter_map(|r| r.two.as_ref()).collect();
    if two.is_empty() {
        return;
    }
    let _ = writeln!(
        o,
        "\nTwo effects hidden: each counts as found when some finding names its mechanism.\n\n\
         | cases | first found | second found | both found |\n|---|---|---|---|"
    );
    for (name, lo) in [("both D ≥ 6", 6.0), ("both D ≥ 3", 3.0)] {
        let set: Vec<&&super::TwoFound> = two
            .iter()
            .filter(|t| t.first.0 >= lo && t.second.0 >= lo)
            .collect();
        let n = |f: &dyn Fn(&super::TwoFound) -> bool| set.iter().filter(|t| f(t)).count();
        let _ = writeln!(
            o,
            "| {name} | {} | {} | {} |",
            pct(n(&|t| t.first.1), set.len()),
            pct(n(&|t| t.second.1), set.len()),
            pct(n(&|t| t.first.1 && t.second.1), set.len())
        );
    }
    o.push('\n');
}

/// With a coarse reading (`--coarse-reading`): the hidden effect found beside the reading's
/// artefact, by D.
fn coarse_table(o: &mut String, results: &[MismatchResult]) {
    let all: Vec<&super::CoarseFound> = results.iter().filter_map(|r| r.coarse.as_ref()).collect();
    if all.is_empty() {
        return;
    }
    let _ = writeln!(
        o,
        "\nThe temperature read at a sensor's coarse quantum (0.0625–0.5 °C) beside the hidden \
         effect: the effect counts as found when some finding names its mechanism; the \
         quantum is named when some finding is `temp_quantization`.\n\n\
         | cases | effect found | effect first | quantum named | another mechanism named |\n\
         |---|---|---|---|---|"
    );
    let bands: [(&str, f64, f64); 3] = [
        ("D ≥ 6", 6.0, f64::INFINITY),
        ("D 3–6", 3.0, 6.0),
        ("clean", 0.0, 0.0),
    ];
    for (name, lo, hi) in bands {
        let set: Vec<&&super::CoarseFound> = all
            .iter()
            .filter(|c| {
                if hi > 0.0 {
                    c.d >= lo && c.d < hi
                } else {
                    c.d == 0.0
                }
            })
            .collect();
        if set.is_empty() {
            continue;
        }
        let n = |f: &dyn Fn(&super::CoarseFound) -> bool| set.iter().filter(|c| f(c)).count();
        let effect = |f: &dyn Fn(&super::CoarseFound) -> bool| {
            if hi > 0.0 {
                pct(n(f), set.len())
            } else {
                "–".to_string()
            }
        };
        let _ = writeln!(
            o,
            "| {name} | {} | {} | {} | {} |",
            effect(&|c| c.effect_found),
            effect(&|c| c.effect_first),
            pct(n(&|c| c.artefact_named), set.len()),
            pct(n(&|c| c.other_named), set.len())
        );
    }
    o.push('\n');
}

/// With a noise level in time on the clean cases (`--noise-in-time`): how often it is taken
/// for a noise level in temperature, by the change's form.
fn noise_in_time_table(o: &mut String, results: &[MismatchResult]) {
    let all: Vec<&MismatchResult> = results
        .iter()
        .filter(|r| r.noise_in_time.is_some())
        .collect();
    if all.is_empty() {
        return;
    }
    let _ = writeln!(
        o,
        "\nClean recordings whose white noise level changes in time, not with temperature:\n\n\
         | form | recordings | `heteroscedastic` named | any verdict but consistent |\n\
         |---|---|---|---|"
    );
    for form in [
        super::TimeForm::Drift,
        super::TimeForm::Step,
        super::TimeForm::Episode,
    ] {
        let set: Vec<&&MismatchResult> = all
            .iter()
            .filter(|r| r.noise_in_time.as_ref().is_some_and(|n| n.0.form == form))
            .collect();
        let hetero = set
            .iter()
            .filter(|r| r.noise_in_time.as_ref().is_some_and(|n| n.1))
            .count();
        let flagged = set
            .iter()
            .filter(|r| r.result.predicted != Label::None)
            .count();
        let _ = writeln!(
            o,
            "| {form:?} | {} | {} | {} |",
            set.len(),
            pct(hetero, set.len()),
            pct(flagged, set.len())
        );
    }
    o.push('\n');
}

/// The summary table: false alarms, top-1 by detectability, parameters, effects outside the
/// library, concealment and time.
fn summary(o: &mut String, results: &[MismatchResult], clean: &[&CaseResult], ra: f64) {
    let library: Vec<&CaseResult> = results
        .iter()
        .filter(|r| matches!(r.kind, Kind::Library(_)))
        .map(|r| &r.result)
        .collect();
    let outside: Vec<&MismatchResult> = results.iter().filter(|r| r.kind.outside()).collect();
    let _ = writeln!(o, "| measure | result |\n|---|---|");
    // A row whose cases this run does not hold (`--only`, a variant) is left out.
    let mut row = |name: &str, k: usize, n: usize| {
        if n > 0 {
            let _ = writeln!(o, "| {name} | {} |", pct(k, n));
        }
    };
    let fa = flagged(clean, ra);
    let named = clean
        .iter()
        .filter(|r| matches!(r.predicted, Label::Mechanism(_)))
        .count();
    row(
        "false alarms on clean recordings (any verdict but consistent)",
        fa,
        clean.len(),
    );
    row(
        "false alarms naming a library mechanism",
        named,
        clean.len(),
    );
    // With two effects the verdict's first finding is scored against the first effect only;
    // the two-effect table counts each effect named by any finding.
    let top1 = if results.iter().any(|r| r.two.is_some()) {
        "top-1 is the first of two effects"
    } else {
        "top-1"
    };
    for (band, lo, hi) in [
        ("D 3–5", 3.0, 5.0),
        ("D 5–6", 5.0, 6.0),
        ("D ≥ 6", 6.0, f64::INFINITY),
    ] {
        let set: Vec<&&CaseResult> = library
            .iter()
            .filter(|r| r.detectability >= lo && r.detectability < hi)
            .collect();
        let ok = set.iter().filter(|r| r.predicted == r.truth).count();
        row(&format!("{top1}, library families, {band}"), ok, set.len());
    }
    // (A mechanism hidden in another form has no parameter to score: not counted.)
    let correct: Vec<&&CaseResult> = library
        .iter()
        .filter(|r| r.predicted == r.truth && r.param_ok.is_some())
        .collect();
    let pok = correct.iter().filter(|r| r.param_ok == Some(true)).count();
    row(
        "key parameter within tolerance (of correct identifications)",
        pok,
        correct.len(),
    );
    // All of them, then at D ≥ 6 (where the diagnosis' targets are set).
    for (range, at) in [("", 0.0), (" at D ≥ 6", 6.0)] {
        let set: Vec<_> = outside
            .iter()
            .filter(|r| r.result.detectability >= at)
            .collect();
        let named = set
            .iter()
            .filter(|r| matches!(r.result.predicted, Label::Mechanism(_)))
            .count();
        let unexp = set
            .iter()
            .filter(|r| r.result.predicted == Label::Unexplained)
            .count();
        row(
            &format!("outside-library effects{range} named as a library mechanism"),
            named,
            set.len(),
        );
        row(
            &format!("outside-library effects{range} called `unexplained`"),
            unexp,
            set.len(),
        );
    }
    let hidden: Vec<&CaseResult> = results
        .iter()
        .filter(|r| r.kind != Kind::Clean)
        .map(|r| &r.result)
        .collect();
    let conc = hidden.iter().filter(|r| r.peak_over_sigma1 < 0.5).count();
    row(
        "hidden effects concealed (peak < σ₁/2; not required here)",
        conc,
        hidden.len(),
    );
    let mut secs: Vec<f64> = results.iter().map(|r| r.result.seconds).collect();
    secs.sort_by(f64::total_cmp);
    let _ = writeln!(
        o,
        "| diagnosis time per recording (median / max) | {:.2} s / {:.2} s |",
        secs.get(secs.len() / 2).copied().unwrap_or(0.0),
        secs.last().copied().unwrap_or(0.0)
    );
}

/// False alarms by condition of the clean recordings, at the run's α `ra` and at the
/// diagnosis' default 2 % when the run's is larger.
fn conditions_table(o: &mut String, results: &[MismatchResult], ra: f64) {
    let low = CAL_ALPHAS[1].min(ra);
    let two = low < ra - 1e-12;
    let at_alpha = if two {
        format!("{:.1} % / {:.1} %", 100.0 * ra, 100.0 * low)
    } else {
        format!("{:.1} %", 100.0 * ra)
    };
    let _ = writeln!(
        o,
        "\nFalse alarms by condition (clean recordings flagged at α = {at_alpha} of those with \
         and without it; in brackets: flagged naming a mechanism at the run's α):\n"
    );
    let _ = writeln!(o, "| condition | with it | without it |\n|---|---|---|");
    let clean_mm: Vec<&MismatchResult> = results.iter().filter(|r| r.kind == Kind::Clean).collect();
    let cell = |set: &[&&MismatchResult]| {
        let at = |a: f64| {
            set.iter()
                .filter(|r| r.result.predicted_at(a) != Label::None)
                .count()
        };
        let nm = set
            .iter()
            .filter(|r| matches!(r.result.predicted, Label::Mechanism(_)))
            .count();
        if two {
            format!("{} / {} of {} ({nm})", at(ra), at(low), set.len())
        } else {
            format!("{} of {} ({nm})", at(ra), set.len())
        }
    };
    for tag in CONDITION_TAGS
        .iter()
        .chain(&LOGGER_TAGS)
        .chain(&BESIDE_TAGS)
    {
        let (with, without): (Vec<&&MismatchResult>, Vec<&&MismatchResult>) = clean_mm
            .iter()
            .partition(|r| r.conditions.iter().any(|c| c == tag));
        // The variants' rows only where they put their conditions.
        if with.is_empty() && !CONDITION_TAGS.contains(tag) {
            continue;
        }
        let _ = writeln!(o, "| {tag} | {} | {} |", cell(&with), cell(&without));
    }
}

/// The confusion matrix: rows the hidden effect, columns the diagnosis.
fn confusion_matrix(o: &mut String, results: &[MismatchResult]) {
    let mut cols: Vec<Label> = Family::ALL
        .iter()
        .map(|f| Label::Mechanism(f.mechanism()))
        .collect();
    cols.push(Label::None);
    cols.push(Label::Unexplained);
    let _ = writeln!(
        o,
        "\nConfusion matrix (rows: hidden effect, columns: diagnosis; `step`, `rate_squared`, \
         `bump_in_time`, `telegraph` and `bump_in_temperature` are outside the library, right \
         answer `unexplained`):\n"
    );
    let names: Vec<&str> = cols.iter().map(|c| c.name()).collect();
    let _ = writeln!(o, "| hidden \\ diagnosed | {} |", names.join(" | "));
    let _ = writeln!(o, "|---|{}", "---|".repeat(cols.len()));
    let mut rows: Vec<Kind> = Family::ALL.iter().map(|f| Kind::Library(*f)).collect();
    rows.extend([Kind::Step, Kind::RateSquared]);
    rows.extend(Kind::MORE_OUTSIDE);
    rows.push(Kind::Clean);
    for row in rows {
        let rs: Vec<&MismatchResult> = results.iter().filter(|r| r.kind == row).collect();
        if rs.is_empty() {
            continue;
        }
        let cells: Vec<String> = cols
            .iter()
            .map(|c| {
                rs.iter()
                    .filter(|r| r.result.predicted == *c)
                    .count()
                    .to_string()
            })
            .collect();
        let _ = writeln!(o, "| {} | {} |", row.name(), cells.join(" | "));
    }
}

/// Top-1 by form, D ≥ 6 and all, when library mechanisms were hidden in other forms
/// (`--other-shapes`); nothing otherwise.
fn forms_table(o: &mut String, results: &[MismatchResult]) {
    let mut forms: Vec<&str> = results.iter().filter_map(|r| r.form).collect();
    if forms.is_empty() {
        return;
    }
    forms.sort_unstable();
    forms.dedup();
    let _ = writeln!(
        o,
        "\nMechanisms hidden in a form other than the library's term (top-1 correct, and the \
         wrong verdicts, most frequent first):\n\n| form | D ≥ 6 | all | wrong verdicts |\n|---|---|---|---|"
    );
    for form in forms {
        let rs: Vec<&CaseResult> = results
            .iter()
            .filter(|r| r.form == Some(form))
            .map(|r| &r.result)
            .collect();
        let ok = |v: &[&CaseResult]| v.iter().filter(|r| r.predicted == r.truth).count();
        let hi: Vec<&CaseResult> = rs
            .iter()
            .copied()
            .filter(|r| r.detectability >= 6.0)
            .collect();
        let mut wrong: Vec<&str> = rs
            .iter()
            .filter(|r| r.predicted != r.truth)
            .map(|r| r.predicted.name())
            .collect();
        wrong.sort_unstable();
        let mut counts: Vec<(usize, &str)> = Vec::new();
        for w in wrong {
            match counts.last_mut() {
                Some((k, name)) if *name == w => *k += 1,
                _ => counts.push((1, w)),
            }
        }
        counts.sort_by_key(|c| std::cmp::Reverse(c.0));
        let wrong: Vec<String> = counts.iter().map(|(k, n)| format!("{n} {k}")).collect();
        let _ = writeln!(
            o,
            "| {form} | {} | {} | {} |",
            pct(ok(&hi), hi.len()),
            pct(ok(&rs), rs.len()),
            if wrong.is_empty() {
                "–".to_string()
            } else {
                wrong.join(", ")
            }
        );
    }
}

/// The calibration of the verdict's p-value on the clean recordings `clean` (one run or
/// several pooled): the share flagged at each α of 1, 2, 5 and 10 %, its 95 % interval, the
/// band [α/2, 2α] and the share whose best candidate has p ≤ α, in Markdown.
pub fn calibration_markdown(clean: &[&CaseResult]) -> String {
    let mut o = String::new();
    let ra = clean.iter().map(|r| r.alpha).fold(0.0, f64::max);
    let _ = writeln!(
        o,
        "\nCalibration on the {} clean recordings: share whose verdict at α is not `none` \
         (from the bootstrap p-values; exact for α ≤ the run's α = {:.1} %, the run's verdict \
         above it), its 95 % interval, the target band [α/2, 2α], and the share whose best \
         candidate has p ≤ α:\n",
        clean.len(),
        100.0 * ra
    );
    let _ = writeln!(
        o,
        "| α | flagged | 95 % interval | band | in band | p_best ≤ α |\n|---|---|---|---|---|---|"
    );
    for a in CAL_ALPHAS {
        let k = flagged(clean, a);
        let n = clean.len();
        let share = k as f64 / n.max(1) as f64;
        let (lo, hi) = wilson(k, n);
        let exact = if a <= ra + 1e-12 { "" } else { " (run's α)" };
        let inside = if n == 0 {
            "–"
        } else if (0.5 * a..=2.0 * a).contains(&share) {
            "yes"
        } else {
            "no"
        };
        let _ = writeln!(
            o,
            "| {:.0} %{exact} | {} | {:.1}–{:.1} % | {:.1}–{:.0} % | {inside} | {} |",
            100.0 * a,
            pct(k, n),
            100.0 * lo,
            100.0 * hi,
            50.0 * a,
            200.0 * a,
            pct(p_best(clean, a), n)
        );
    }

    o
}

/// The clean recordings of the benchmark results in `json` (a `results.json` of either
/// set: a mismatched run's entries hold their kind and result, a matched run's are results).
pub fn clean_results(json: &str) -> Result<Vec<CaseResult>, serde_json::Error> {
    let all: Vec<serde_json::Value> = serde_json::from_str(json)?;
    let mut clean = Vec::new();
    for v in all {
        let (r, is_clean) = match v.get("result") {
            Some(r) => (
                serde_json::from_value::<CaseResult>(r.clone())?,
                v.get("kind").and_then(serde_json::Value::as_str) == Some(Kind::Clean.name()),
            ),
            None => {
                let r: CaseResult = serde_json::from_value(v)?;
                let none = r.truth == Label::None;
                (r, none)
            }
        };
        if is_clean {
            clean.push(r);
        }
    }
    Ok(clean)
}

/// Draws the calibration on the clean recordings of a mismatched run (see
/// [`calibration_png_of`]).
pub fn calibration_png(results: &[MismatchResult], path: &Path) -> Result<(), BenchError> {
    let clean: Vec<&CaseResult> = results
        .iter()
        .filter(|r| r.kind == Kind::Clean)
        .map(|r| &r.result)
        .collect();
    calibration_png_of(&clean, "mismatched", path)
}

/// Draws the calibration on the clean recordings `clean` of a set (`set`: its name in the
/// caption) to a PNG: the share flagged and the share with p_best ≤ α against α, the band
/// [α/2, 2α] and the diagonal.
pub fn calibration_png_of(clean: &[&CaseResult], set: &str, path: &Path) -> Result<(), BenchError> {
    let err = |m: String| BenchError::Truth {
        path: path.display().to_string(),
        message: m,
    };
    let clean = clean.to_vec();
    let n = clean.len().max(1) as f64;
    let ra = clean.iter().map(|r| r.alpha).fold(0.0, f64::max);
    let xmax = 0.11f64.max(1.05 * ra).min(1.0);
    let grid: Vec<f64> = (1..=200).map(|i| xmax * f64::from(i) / 200.0).collect();
    let verdict: Vec<(f64, f64)> = grid
        .iter()
        .filter(|a| **a <= ra + 1e-12)
        .map(|&a| (a, flagged(&clean, a) as f64 / n))
        .collect();
    let best: Vec<(f64, f64)> = grid
        .iter()
        .map(|&a| (a, p_best(&clean, a) as f64 / n))
        .collect();
    let ymax = verdict
        .iter()
        .chain(&best)
        .map(|p| p.1)
        .fold(2.0 * xmax, f64::max)
        .min(1.0)
        * 1.05;
    // Where the best candidate's share climbs high (a noise level rightly significant and then
    // put down to time), the upper left is its line's: the legend goes where nothing is drawn.
    let high = best.iter().any(|p| p.1 > 0.5 * ymax);
    render_custom_png(path, (900, 650), |root| {
        let mut chart = frame(
            root,
            &format!(
                "p-value calibration on {} clean {set} recordings (run at α = {:.0} %)",
                clean.len(),
                100.0 * ra
            ),
            (0.0..xmax, 0.0..ymax),
            ("α", "share of clean recordings"),
        )?;
        let band_color = RGBColor(44, 160, 44);
        let mut band: Vec<(f64, f64)> = grid.iter().map(|&a| (a, 0.5 * a)).collect();
        band.extend(grid.iter().rev().map(|&a| (a, (2.0 * a).min(ymax))));
        band.insert(0, (0.0, 0.0));
        chart
            .draw_series(std::iter::once(Polygon::new(
                band,
                band_color.mix(0.2).filled(),
            )))?
            .label("target band [α/2, 2α]")
            .legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 20, y + 5)], band_color.mix(0.3).filled())
            });
        chart
            .draw_series(LineSeries::new(
                [(0.0, 0.0), (xmax.min(ymax), xmax.min(ymax))],
                BLACK.stroke_width(1),
            ))?
            .label("share = α")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
        let blue = RGBColor(31, 119, 180);
        chart
            .draw_series(LineSeries::new(verdict.clone(), blue.stroke_width(2)))?
            .label("verdict not `none` at α")
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], blue.stroke_width(2))
            });
        chart.draw_series(
            CAL_ALPHAS
                .iter()
                .filter(|a| **a <= ra + 1e-12)
                .map(|&a| Circle::new((a, flagged(&clean, a) as f64 / n), 5, blue.filled())),
        )?;
        let red = RGBColor(214, 39, 40);
        chart
            .draw_series(LineSeries::new(best, red.stroke_width(2)))?
            .label("best candidate's p ≤ α (before a finding's other checks)")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], red.stroke_width(2)));
        let at = if high {
            SeriesLabelPosition::MiddleRight
        } else {
            SeriesLabelPosition::UpperLeft
        };
        legend(&mut chart, at)
    })
    .map_err(|e| err(e.to_string()))
}
