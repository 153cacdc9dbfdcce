//! Small shared PNG plotting on `plotters`: line/point series against a shared x axis, an
//! optional second y axis, title, axis labels with units, legend.
//!
//! Text comes from DejaVu Sans embedded in the binary (crate `dejavu`) through plotters'
//! `ab_glyph` feature, so plots render on a machine without fontconfig/freetype.

use plotters::coord::Shift;
use plotters::prelude::*;
use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

/// The font family name the embedded font is registered under.
const FONT: &str = "sans-serif";

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Connected line.
    Line,
    /// Markers only.
    Points,
    /// Line with markers.
    LinePoints,
}

/// Which y axis a series is scaled against.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// Left (primary) axis.
    Left,
    /// Right (secondary) axis; needs [`Figure::y2_label`].
    Right,
}

/// One data series.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// x values, in the unit of [`Figure::x_label`].
    pub x: Vec<f64>,
    /// y values, in the unit of the axis label the series is drawn against.
    pub y: Vec<f64>,
    /// Drawing style.
    pub style: Style,
    /// Axis the series uses.
    pub axis: Axis,
}

impl Series {
    /// A series on the left axis.
    pub fn new(label: &str, x: Vec<f64>, y: Vec<f64>, style: Style) -> Self {
        Self {
            label: label.into(),
            x,
            y,
            style,
            axis: Axis::Left,
        }
    }
    /// The same series on the right axis.
    pub fn on_right(mut self) -> Self {
        self.axis = Axis::Right;
        self
    }
}

/// A figure: labels (with units, e.g. "T (°C)") and series.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// Title above the plot.
    pub title: String,
    /// x-axis label with unit.
    pub x_label: String,
    /// Left y-axis label with unit.
    pub y_label: String,
    /// Right y-axis label with unit; `Some` enables the second axis.
    pub y2_label: Option<String>,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Series in drawing order.
    pub series: Vec<Series>,
    /// Logarithmic x axis (non-positive x values are not drawn).
    pub log_x: bool,
    /// Logarithmic left y axis (non-positive y values are not drawn).
    pub log_y: bool,
}

impl Figure {
    /// An empty 1000 × 600 px figure.
    pub fn new(title: &str, x_label: &str, y_label: &str) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            y2_label: None,
            width: 1000,
            height: 600,
            series: Vec::new(),
            log_x: false,
            log_y: false,
        }
    }
}

/// Why a figure could not be drawn.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// A series' x and y differ in length.
    #[error("series `{0}`: x and y differ in length")]
    LengthMismatch(String),
    /// A series is on the right axis but the figure has no `y2_label`.
    #[error("series `{0}` uses the right axis but the figure has no second axis")]
    NoSecondAxis(String),
    /// No finite point to scale an axis on.
    #[error("no finite data for the {0} axis")]
    NoData(&'static str),
    /// Image size out of range.
    #[error("image size {0} × {1} px is out of range (100 … 10000)")]
    BadSize(u32, u32),
    /// The embedded font could not be loaded.
    #[error("the embedded font could not be loaded")]
    Font,
    /// The backend failed (e.g. the file could not be written).
    #[error("drawing failed: {0}")]
    Draw(String),
}

impl From<std::io::Error> for PlotError {
    /// Writing or renaming the PNG failed.
    fn from(e: std::io::Error) -> Self {
        PlotError::Draw(e.to_string())
    }
}

fn draw_err<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Draw(e.to_string())
}

fn register_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok()
    });
    ok.then_some(()).ok_or(PlotError::Font)
}

/// Padded [min, max] of the finite values; a flat range is widened to ±1 (or ±1 %).
fn range_of<'a>(
    v: impl Iterator<Item = &'a f64>,
    axis: &'static str,
) -> Result<Range<f64>, PlotError> {
    let (lo, hi) = v
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return Err(PlotError::NoData(axis));
    }
    let span = hi - lo;
    let pad = if span > 0.0 {
        0.05 * span
    } else {
        (0.01 * lo.abs()).max(1.0)
    };
    Ok(lo - pad..hi + pad)
}

/// Ten distinguishable colours (matplotlib's "tab10" order, black in place of grey).
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(0, 0, 0),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

fn finite_points(s: &Series) -> Vec<(f64, f64)> {
    s.x.iter()
        .zip(&s.y)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| (*x, *y))
        .collect()
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, fig: &Figure) -> Result<(), PlotError> {
    for s in &fig.series {
        if s.x.len() != s.y.len() {
            return Err(PlotError::LengthMismatch(s.label.clone()));
        }
        if s.axis == Axis::Right && fig.y2_label.is_none() {
            return Err(PlotError::NoSecondAxis(s.label.clone()));
        }
    }
    // Log axes: the data are drawn as log10 values and the tick labels show 10^v, which keeps
    // one cartesian chart type for every figure.
    let logged: Vec<Series>;
    let series: &[Series] = if fig.log_x || fig.log_y {
        let lg = |v: f64, on: bool| match (on, v > 0.0) {
            (false, _) => v,
            (true, true) => v.log10(),
            (true, false) => f64::NAN,
        };
        logged = fig
            .series
            .iter()
            .map(|s| Series {
                x: s.x.iter().map(|&v| lg(v, fig.log_x)).collect(),
                y: s.y
                    .iter()
                    .map(|&v| lg(v, fig.log_y && s.axis == Axis::Left))
                    .collect(),
                ..s.clone()
            })
            .collect();
        &logged
    } else {
        &fig.series
    };
    let on = |a: Axis| series.iter().filter(move |s| s.axis == a);
    let xr = range_of(series.iter().flat_map(|s| &s.x), "x")?;
    let yr = range_of(on(Axis::Left).flat_map(|s| &s.y), "left y")?;
    let y2r = match fig.y2_label {
        Some(_) => range_of(on(Axis::Right).flat_map(|s| &s.y), "right y")?,
        None => 0.0..1.0,
    };

    // Room for the legend: its widest label, the key before it and a gap.
    let label_font: TextStyle = (FONT, 13).into_font().into();
    let mut legend_w = 12;
    for s in series {
        let (w, _) = root
            .estimate_text_size(&s.label, &label_font)
            .map_err(draw_err)?;
        legend_w = legend_w.max(w + 56);
    }
    root.fill(&WHITE).map_err(draw_err)?;
    // The title over the whole width (the chart's own caption is centred on the plot beside
    // the legend, and a long title ran off the image's left edge).
    // The ticks' labels and the legend are drawn on `root` at the chart's backend (absolute)
    // coordinates, so only the chart is built on the area below the title.
    let below_title = root.titled(&fig.title, (FONT, 22)).map_err(draw_err)?;
    let mut chart = ChartBuilder::on(&below_title)
        .margin(12)
        // Room right of the plot for the legend, so that it covers no data.
        .margin_right(legend_w)
        .x_label_area_size(50)
        .y_label_area_size(90)
        .right_y_label_area_size(if fig.y2_label.is_some() { 90 } else { 0 })
        .build_cartesian_2d(xr.clone(), yr)
        .map_err(draw_err)?
        .set_secondary_coord(xr, y2r);
    // A log axis gets ticks of its own at 1, 2, 5 × 10ⁿ (plotters' would sit at round
    // logarithms, 10^0.2 = 1.585), drawn after the mesh.
    let mut mesh = chart.configure_mesh();
    if fig.log_x {
        mesh.x_labels(0);
    }
    if fig.log_y {
        mesh.y_labels(0);
    }
    mesh.x_desc(&fig.x_label)
        .y_desc(&fig.y_label)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()
        .map_err(draw_err)?;
    let (xr, yr) = (chart.x_range(), chart.y_range());
    let font: TextStyle = (FONT, 14).into_font().into();
    if fig.log_x {
        for (v, label) in log_ticks(&xr) {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(v, yr.start), (v, yr.end)],
                    BLACK.mix(0.15),
                )))
                .map_err(draw_err)?;
            if let Some(text) = label {
                let (px, py) = chart.backend_coord(&(v, yr.start));
                let (w, _) = root.estimate_text_size(&text, &font).map_err(draw_err)?;
                root.draw(&Text::new(text, (px - w as i32 / 2, py + 6), font.clone()))
                    .map_err(draw_err)?;
            }
        }
    }
    if fig.log_y {
        for (v, label) in log_ticks(&yr) {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(xr.start, v), (xr.end, v)],
                    BLACK.mix(0.15),
                )))
                .map_err(draw_err)?;
            if let Some(text) = label {
                let (px, py) = chart.backend_coord(&(xr.start, v));
                let (w, h) = root.estimate_text_size(&text, &font).map_err(draw_err)?;
                root.draw(&Text::new(
                    text,
                    (px - w as i32 - 8, py - h as i32 / 2),
                    font.clone(),
                ))
                .map_err(draw_err)?;
            }
        }
    }
    if let Some(l) = &fig.y2_label {
        chart
            .configure_secondary_axes()
            .y_desc(l)
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 16))
            .draw()
            .map_err(draw_err)?;
    }
    for (i, s) in series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let pts = finite_points(s);
        let line = matches!(s.style, Style::Line | Style::LinePoints);
        let marks = matches!(s.style, Style::Points | Style::LinePoints);
        let right = s.axis == Axis::Right;
        if line {
            let series = LineSeries::new(pts.clone(), color.stroke_width(2));
            let anno = if right {
                chart.draw_secondary_series(series)
            } else {
                chart.draw_series(series)
            };
            anno.map_err(draw_err)?;
        }
        if marks {
            let series = pts.iter().map(|p| Circle::new(*p, 4, color.filled()));
            let anno = if right {
                chart.draw_secondary_series(series)
            } else {
                chart.draw_series(series)
            };
            anno.map_err(draw_err)?;
        }
    }
    // The legend right of the plot, drawn on the whole image (the chart's own legend is
    // clipped to the plotting area, where it would cover data).
    let right_axis = if fig.y2_label.is_some() { 90 } else { 0 };
    let (x_right, y_top) = chart.backend_coord(&(xr.end, yr.end));
    let (lx, ly) = (x_right + right_axis + 16, y_top);
    draw_legend(&root, series, (lx, ly))?;
    root.present().map_err(draw_err)
}

/// The legend of `series` from `(lx, ly)` down: a line and/or a marker in each series'
/// colour, and its label.
fn draw_legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    series: &[Series],
    (lx, mut ly): (i32, i32),
) -> Result<(), PlotError> {
    let label_font: TextStyle = (FONT, 13).into_font().into();
    for (i, s) in series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        if matches!(s.style, Style::Line | Style::LinePoints) {
            root.draw(&PathElement::new(
                vec![(lx, ly + 8), (lx + 20, ly + 8)],
                color.stroke_width(2),
            ))
            .map_err(draw_err)?;
        }
        if matches!(s.style, Style::Points | Style::LinePoints) {
            root.draw(&Circle::new((lx + 10, ly + 8), 4, color.filled()))
                .map_err(draw_err)?;
        }
        root.draw(&Text::new(
            s.label.clone(),
            (lx + 28, ly),
            label_font.clone(),
        ))
        .map_err(draw_err)?;
        ly += 20;
    }
    Ok(())
}

/// Ticks of a log axis spanning `range` (log10 values): (log10 of the tick, its label). Every
/// 1, 2 and 5 × 10ⁿ is a tick; over three decades or fewer each is labelled, over more only
/// the powers of ten.
fn log_ticks(range: &Range<f64>) -> Vec<(f64, Option<String>)> {
    let (lo, hi) = (range.start.min(range.end), range.start.max(range.end));
    if !(lo.is_finite() && hi.is_finite()) {
        return Vec::new();
    }
    let all = hi - lo <= 3.0;
    let mut out = Vec::new();
    for n in (lo.floor() as i32)..=(hi.ceil() as i32) {
        for m in [1.0, 2.0, 5.0] {
            let v = m * 10f64.powi(n);
            let l = v.log10();
            if l < lo - 1e-9 || l > hi + 1e-9 {
                continue;
            }
            let label = (all || m == 1.0).then(|| {
                if (1e-3..1e5).contains(&v) {
                    // Rounded to the tick's own digits: 0.05, 2, 500.
                    format!("{}", (v * 1e3).round() / 1e3)
                } else {
                    format!("{v:.0e}")
                }
            });
            out.push((l, label));
        }
    }
    out
}

fn check_size((width, height): (u32, u32)) -> Result<(), PlotError> {
    let ok = |v: u32| (100..=10_000).contains(&v);
    if ok(width) && ok(height) {
        Ok(())
    } else {
        Err(PlotError::BadSize(width, height))
    }
}

/// Draws `fig` into a PNG file at `path` (`fig.width` × `fig.height` px), atomically
/// ([`crate::atomic::write_with`]).
pub fn render_png(fig: &Figure, path: &Path) -> Result<(), PlotError> {
    check_size((fig.width, fig.height))?;
    register_font()?;
    crate::atomic::write_with(path, |tmp| {
        draw(
            BitMapBackend::new(tmp, (fig.width, fig.height)).into_drawing_area(),
            fig,
        )
    })
}

/// Draws a figure [`Figure`] cannot describe (error bars, bands, reference lines) into a PNG
/// file at `path` (`width` × `height` px): with the same embedded font (registered under
/// "sans-serif"), white background and atomic write as [`render_png`]. `draw` gets the whole
/// image's drawing area; presenting it and mapping the backend's errors are done here.
pub fn render_custom_png<F>(
    path: &Path,
    (width, height): (u32, u32),
    draw: F,
) -> Result<(), PlotError>
where
    F: for<'a> FnOnce(
        &DrawingArea<BitMapBackend<'a>, Shift>,
    ) -> Result<(), Box<dyn std::error::Error>>,
{
    check_size((width, height))?;
    register_font()?;
    crate::atomic::write_with(path, |tmp| {
        let root = BitMapBackend::new(tmp, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        draw(&root).map_err(draw_err)?;
        root.present().map_err(draw_err)
    })
}

/// Draws `fig` into an RGB8 buffer (row-major, 3 bytes per pixel); for tests and callers
/// that post-process the image.
pub fn render_rgb(fig: &Figure) -> Result<Vec<u8>, PlotError> {
    check_size((fig.width, fig.height))?;
    register_font()?;
    let mut buf = vec![0u8; fig.width as usize * fig.height as usize * 3];
    draw(
        BitMapBackend::with_buffer(&mut buf, (fig.width, fig.height)).into_drawing_area(),
        fig,
    )?;
    Ok(buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn demo() -> Figure {
        let x: Vec<f64> = (0..50).map(|i| i as f64).collect();
        let mut f = Figure::new("Demo", "t (s)", "rate (°/h)");
        f.y2_label = Some("T (°C)".into());
        f.width = 640;
        f.height = 400;
        f.series.push(Series::new(
            "rate",
            x.clone(),
            x.iter().map(|v| v.sin()).collect(),
            Style::Line,
        ));
        f.series.push(
            Series::new(
                "T",
                x.clone(),
                x.iter().map(|v| 20.0 + v).collect(),
                Style::Points,
            )
            .on_right(),
        );
        f
    }

    /// The file is a PNG (signature + IHDR per the PNG spec) of the requested size.
    #[test]
    fn writes_png_of_requested_size() {
        let dir = std::env::temp_dir().join(format!("plot-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("demo.png");
        render_png(&demo(), &path).unwrap();
        let b = std::fs::read(&path).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(&b[12..16], b"IHDR");
        let be = |s: &[u8]| u32::from_be_bytes([s[0], s[1], s[2], s[3]]);
        assert_eq!((be(&b[16..20]), be(&b[20..24])), (640, 400));
    }

    /// Text is drawn: the title band (top 30 px) holds dark pixels, which needs the
    /// embedded font to load and rasterise.
    #[test]
    fn title_text_is_rendered() {
        let f = demo();
        let buf = render_rgb(&f).unwrap();
        let w = f.width as usize;
        let dark = (0..30)
            .flat_map(|y| (0..w).map(move |x| (y * w + x) * 3))
            .filter(|&i| buf[i] < 100 && buf[i + 1] < 100 && buf[i + 2] < 100)
            .count();
        assert!(dark > 20, "{dark} dark pixels in the title band");
    }

    #[test]
    fn log_ticks_are_round() {
        let t = log_ticks(&((0.05f64).log10()..(5.0f64).log10()));
        let labels: Vec<String> = t.iter().filter_map(|(_, l)| l.clone()).collect();
        assert_eq!(labels, ["0.05", "0.1", "0.2", "0.5", "1", "2", "5"]);
        let wide = log_ticks(&(-1.0..5.0));
        let labels: Vec<String> = wide.iter().filter_map(|(_, l)| l.clone()).collect();
        assert_eq!(labels, ["0.1", "1", "10", "100", "1000", "10000", "1e5"]);
        assert_eq!(wide.len(), 3 * 6 + 1);
    }

    #[test]
    fn bad_figures_are_errors() {
        let mut f = demo();
        f.y2_label = None;
        assert!(matches!(render_rgb(&f), Err(PlotError::NoSecondAxis(_))));
        let mut f = demo();
        f.series[0].y.pop();
        assert!(matches!(render_rgb(&f), Err(PlotError::LengthMismatch(_))));
        let mut f = demo();
        f.width = 10;
        assert!(matches!(render_rgb(&f), Err(PlotError::BadSize(..))));
        let f = Figure::new("empty", "x", "y");
        assert!(matches!(render_rgb(&f), Err(PlotError::NoData(_))));
    }
}
