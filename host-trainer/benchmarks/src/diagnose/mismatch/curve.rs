//! The detection curve of a mismatched run: by detectability D, the share of hidden library
//! effects named first (top-1), the share found at all (any verdict but consistent) and the
//! share of effects outside the library called `unexplained`, each with its 95 % interval,
//! as a table and a figure. The summary's three bands say whether a target is met; the curve
//! says where between them the power is lost and whether a miss is a silence or a wrong name.

use std::fmt::Write as _;
use std::ops::Range;
use std::path::Path;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use rlg_io::plot::render_custom_png;

use super::report::wilson;
use super::{Kind, MismatchResult};
use crate::diagnose::report::pct;
use crate::diagnose::{BenchError, Label};

/// The curve's bins of D (lower bound included, upper excluded); the last is open.
const BINS: [(f64, f64); 8] = [
    (0.0, 2.0),
    (2.0, 3.0),
    (3.0, 4.0),
    (4.0, 5.0),
    (5.0, 6.0),
    (6.0, 8.0),
    (8.0, 12.0),
    (12.0, f64::INFINITY),
];

/// The targets the curve is read against: (lowest D, highest D, top-1 share).
const TARGETS: [(f64, f64, f64); 2] = [(3.0, 6.0, 0.5), (6.0, f64::INFINITY, 0.9)];

/// One bin of the curve.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Bin {
    pub(super) lo: f64,
    pub(super) hi: f64,
    /// The median D of the library cases in the bin (where the figure puts the bin).
    pub(super) at: f64,
    /// Library cases, those named first, those with any verdict but consistent.
    pub(super) library: usize,
    pub(super) top1: usize,
    pub(super) detected: usize,
    /// Outside-library cases and those called `unexplained`.
    pub(super) outside: usize,
    pub(super) unexplained: usize,
}

/// Whether a library effect was found at all: any verdict but consistent; with a second
/// effect or a coarse reading beside it (either alone makes a verdict), some finding names it.
fn found(r: &MismatchResult) -> bool {
    match (&r.two, &r.coarse) {
        (Some(t), _) => t.first.1,
        (None, Some(c)) => c.effect_found,
        (None, None) => r.result.predicted != Label::None,
    }
}

/// What the effect is beside in this run, for the curve's caption (`None`: nothing).
fn beside(results: &[MismatchResult]) -> Option<&'static str> {
    if results.iter().any(|r| r.two.is_some()) {
        Some("the first of two effects")
    } else if results.iter().any(|r| r.coarse.is_some()) {
        Some("beside a coarse temperature reading")
    } else {
        None
    }
}

/// The curve's bins that hold a case of a hidden effect.
pub(super) fn bins(results: &[MismatchResult]) -> Vec<Bin> {
    BINS.iter()
        .filter_map(|&(lo, hi)| {
            let inside =
                |r: &&MismatchResult| r.result.detectability >= lo && r.result.detectability < hi;
            let lib: Vec<&MismatchResult> = results
                .iter()
                .filter(|r| matches!(r.kind, Kind::Library(_)))
                .filter(inside)
                .collect();
            let out: Vec<&MismatchResult> = results
                .iter()
                .filter(|r| r.kind.outside())
                .filter(inside)
                .collect();
            if lib.is_empty() && out.is_empty() {
                return None;
            }
            let mut d: Vec<f64> = lib
                .iter()
                .chain(&out)
                .map(|r| r.result.detectability)
                .collect();
            d.sort_by(f64::total_cmp);
            Some(Bin {
                lo,
                hi,
                at: d[d.len() / 2],
                library: lib.len(),
                top1: lib
                    .iter()
                    .filter(|r| r.result.predicted == r.result.truth)
                    .count(),
                detected: lib.iter().filter(|r| found(r)).count(),
                outside: out.len(),
                unexplained: out
                    .iter()
                    .filter(|r| r.result.predicted == Label::Unexplained)
                    .count(),
            })
        })
        .collect()
}

/// A bin's range as the report writes it.
fn range(b: &Bin) -> String {
    if b.hi.is_finite() {
        format!("{}–{}", b.lo, b.hi)
    } else {
        format!("≥ {}", b.lo)
    }
}

/// A share with its 95 % interval, or "–" for an empty bin.
fn share(k: usize, n: usize) -> String {
    if n == 0 {
        return "–".into();
    }
    let (lo, hi) = wilson(k, n);
    format!("{} [{:.0}–{:.0} %]", pct(k, n), 100.0 * lo, 100.0 * hi)
}

/// The curve as a Markdown section (nothing when the run hid no effect).
pub(super) fn curve_table(o: &mut String, results: &[MismatchResult]) {
    let bins = bins(results);
    if bins.is_empty() {
        return;
    }
    let found = match beside(results) {
        Some(b) => format!("({b}) named first (top-1) and named by some finding"),
        None => "named first (top-1) and found at all (any verdict but consistent)".into(),
    };
    let outside = bins.iter().any(|b| b.outside > 0);
    let _ = write!(
        o,
        "\nDetection curve by D: library effects {found}{}; 95 % intervals. Targets: top-1 \
         ≥ 50 % at D 3–6 and ≥ 90 % at D ≥ 6.\n\n| D | library: top-1 | library: found |",
        if outside {
            ", effects outside the library called `unexplained`"
        } else {
            ""
        }
    );
    o.push_str(if outside {
        " outside: `unexplained` |\n|---|---|---|---|\n"
    } else {
        "\n|---|---|---|\n"
    });
    for b in &bins {
        let _ = write!(
            o,
            "| {} | {} | {} |",
            range(b),
            share(b.top1, b.library),
            share(b.detected, b.library)
        );
        if outside {
            let _ = write!(o, " {} |", share(b.unexplained, b.outside));
        }
        o.push('\n');
    }
}

/// Draws the detection curve of `results` to a PNG at `path` (`set`: the run's set and
/// variant, as the caption names them).
pub fn detection_png(results: &[MismatchResult], set: &str, path: &Path) -> Result<(), BenchError> {
    let err = |m: String| BenchError::Truth {
        path: path.display().to_string(),
        message: m,
    };
    let bins = bins(results);
    let xmax = bins
        .iter()
        .map(|b| if b.hi.is_finite() { b.hi } else { b.at + 2.0 })
        .fold(8.0, f64::max);
    // From just below the first bin that holds cases: the set draws few effects at low D.
    let xmin = bins.first().map_or(0.0, |b| (b.lo - 0.5).max(0.0));
    render_custom_png(path, (900, 650), |root| {
        let mut chart = frame(
            root,
            &format!(
                "Detection by detectability D, {set}, {} recordings",
                results.len()
            ),
            (xmin..xmax, 0.0..1.05),
            (
                "D (GLS signal-to-noise of the hidden effect; a bin's cases drawn at their median D)",
                "share of the bin's recordings",
            ),
        )?;
        let grey = RGBColor(90, 90, 90);
        // The targets are read against the top-1 line: a run of effects outside the library
        // alone has neither.
        let library = bins.iter().any(|b| b.library > 0);
        for (i, &(lo, hi, t)) in TARGETS.iter().enumerate().filter(|_| library) {
            let s = chart.draw_series(std::iter::once(PathElement::new(
                vec![(lo, t), (hi.min(xmax), t)],
                grey.stroke_width(2),
            )))?;
            if i == 0 {
                s.label("top-1 targets (50 % at D 3–6, 90 % at D ≥ 6)")
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], grey.stroke_width(2))
                    });
            }
        }
        let series = [
            ("library: named first (top-1)", RGBColor(31, 119, 180), 0.0),
            (
                if beside(results).is_some() {
                    "library: named by some finding"
                } else {
                    "library: found at all"
                },
                RGBColor(255, 127, 14),
                -0.08,
            ),
            (
                "outside the library: `unexplained`",
                RGBColor(44, 160, 44),
                0.08,
            ),
        ];
        for (k, &(label, color, dx)) in series.iter().enumerate() {
            let pts: Vec<(f64, usize, usize)> = bins
                .iter()
                .map(|b| match k {
                    0 => (b.at, b.top1, b.library),
                    1 => (b.at, b.detected, b.library),
                    _ => (b.at, b.unexplained, b.outside),
                })
                .filter(|p| p.2 > 0)
                .collect();
            // A run without such cases (no effect outside the library) has no such line.
            if pts.is_empty() {
                continue;
            }
            let line: Vec<(f64, f64)> = pts
                .iter()
                .map(|&(x, k, n)| (x + dx, k as f64 / n as f64))
                .collect();
            chart
                .draw_series(LineSeries::new(line.clone(), color.stroke_width(2)))?
                .label(label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
            chart.draw_series(line.iter().map(|&p| Circle::new(p, 4, color.filled())))?;
            chart.draw_series(pts.iter().map(|&(x, k, n)| {
                let (lo, hi) = wilson(k, n);
                PathElement::new(vec![(x + dx, lo), (x + dx, hi)], color.stroke_width(1))
            }))?;
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight)
    })
    .map_err(|e| err(e.to_string()))
}

/// A benchmark figure's chart on `root`: its caption, margins, label areas and mesh with the
/// axis descriptions `(x, y)`, the same in every figure of the benchmark.
pub(super) fn frame<'a>(
    root: &DrawingArea<BitMapBackend<'a>, Shift>,
    caption: &str,
    (x, y): (Range<f64>, Range<f64>),
    (x_desc, y_desc): (&str, &str),
) -> Result<
    ChartContext<'a, BitMapBackend<'a>, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    Box<dyn std::error::Error>,
> {
    let mut chart = ChartBuilder::on(root)
        .caption(caption, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .draw()?;
    Ok(chart)
}

/// The legend of a benchmark figure's series, boxed at `position` inside the plot.
pub(super) fn legend<'a>(
    chart: &mut ChartContext<'a, BitMapBackend<'a>, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    position: SeriesLabelPosition,
) -> Result<(), Box<dyn std::error::Error>> {
    chart
        .configure_series_labels()
        .position(position)
        .label_font(("sans-serif", 14))
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}
