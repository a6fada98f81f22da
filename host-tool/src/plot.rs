//! Figures: x–y charts (lines, points, vertical markers) rendered to PNG or SVG with plotters.
//!
//! Format-agnostic: the callers (validate, diagnose, demo) turn their data into [`Chart`]s —
//! power vs time per turn, average and maximum power vs R/R′ with the model curve, the
//! τ-proportional curves per side, residuals — and [`render`] or [`render_figure`] writes them.
//! Text is drawn with DejaVu Sans compiled into the binary, so figures render on machines without
//! system fonts. Odd data never fails or panics: non-finite points are skipped (and counted on
//! the chart), a chart with nothing to draw says "no data", equal values get a sensible range.
//!
//! ```no_run
//! use host_tool::plot::{render, Chart, Marker, Series, SeriesStyle};
//! use std::path::Path;
//!
//! let mut chart = Chart::new("Average power vs turn radius", "R/R′", "P [W]");
//! chart.series.push(Series::new(
//!     "measured",
//!     vec![(0.5, 410.0), (1.0, 260.0), (2.0, 180.0)],
//!     SeriesStyle::Points,
//!     0,
//! ));
//! chart.series.push(Series::new(
//!     "model",
//!     vec![(0.5, 400.0), (1.0, 270.0), (2.0, 175.0)],
//!     SeriesStyle::Line,
//!     1,
//! ));
//! chart.markers.push(Marker::new(1.0, "R = R′"));
//! render(&chart, Path::new("power_vs_radius.svg"))?; // or .png
//! # Ok::<(), host_tool::plot::PlotError>(())
//! ```

mod glyphs;

use crate::log::{write_atomically, AtomicWriteError};
use plotters::backend::RGBPixel;
use plotters::coord::Shift;
use plotters::element::{Drawable, PointCollection};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{BackendCoord, DrawingErrorKind};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The font every figure's text is drawn with (see `assets/fonts/README.md` for its licence).
const FONT_TTF: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");

/// The family name the embedded font is registered under (plotters' default family).
const FAMILY: &str = "sans-serif";

/// Coordinates beyond ±this are not drawn (they are counted like non-finite points): axis ticks
/// and pixel mapping need spans that stay finite.
pub const MAX_ABS_COORDINATE: f64 = 1e150;

/// Largest figure side [px].
pub const MAX_SIDE_PX: u32 = 16_384;

/// Colour-blind-safe series colours (Okabe & Ito, 2008; yellow replaced by grey), as RGB.
pub const PALETTE: [(u8, u8, u8); 8] = [
    (0x00, 0x72, 0xB2), // blue
    (0xD5, 0x5E, 0x00), // vermillion
    (0x00, 0x9E, 0x73), // bluish green
    (0xCC, 0x79, 0xA7), // reddish purple
    (0xE6, 0x9F, 0x00), // orange
    (0x56, 0xB4, 0xE9), // sky blue
    (0x00, 0x00, 0x00), // black
    (0x77, 0x77, 0x77), // grey
];

/// The RGB colour of palette entry `index` (wrapping around [`PALETTE`]).
pub fn palette_rgb(index: usize) -> (u8, u8, u8) {
    PALETTE[index % PALETTE.len()]
}

/// Why a figure was not written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The output path's extension names no format this module writes.
    #[error("{}: unsupported figure format (use a .png or .svg file name)", path.display())]
    UnsupportedFormat {
        /// The requested output path.
        path: PathBuf,
    },
    /// An explicit axis range is unusable.
    #[error("{axis} range {lo}..{hi}: {reason}")]
    BadRange {
        /// `"x"` or `"y"`.
        axis: &'static str,
        /// Requested lower end.
        lo: f64,
        /// Requested upper end.
        hi: f64,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// The figure size is zero or larger than [`MAX_SIDE_PX`].
    #[error("figure size {width_px}×{height_px} px is outside 1..={MAX_SIDE_PX} px per side")]
    BadSize {
        /// Requested width [px].
        width_px: u64,
        /// Requested height [px].
        height_px: u64,
    },
    /// The embedded font was rejected by the rasteriser (a build defect).
    #[error("the embedded font could not be loaded")]
    Font,
    /// plotters failed while drawing.
    #[error("drawing the figure: {0}")]
    Draw(String),
    /// Encoding the PNG failed.
    #[error("encoding PNG: {0}")]
    Png(#[from] png::EncodingError),
    /// Writing the file failed (the previous file, if any, is untouched).
    #[error(transparent)]
    Write(#[from] AtomicWriteError<io::Error>),
}

/// An output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// RGB PNG, rasterised with the embedded font.
    Png,
    /// SVG text (text elements name the `sans-serif` family; the viewer picks the face).
    Svg,
}

impl Format {
    /// The format named by `path`'s extension (`.png`/`.svg`, any case).
    pub fn from_path(path: &Path) -> Result<Self, PlotError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png") => Ok(Format::Png),
            Some("svg") => Ok(Format::Svg),
            _ => Err(PlotError::UnsupportedFormat {
                path: path.to_owned(),
            }),
        }
    }
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeriesStyle {
    /// A polyline through the points in order; a non-finite point breaks it, and a point with no
    /// finite neighbour is drawn as a small dot.
    Line,
    /// A filled circle per point.
    Points,
    /// Both.
    LineAndPoints,
}

/// One data series.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend entry (no entry when empty).
    pub name: String,
    /// (x, y) points, in drawing order for lines.
    pub points: Vec<(f64, f64)>,
    /// Line, points or both.
    pub style: SeriesStyle,
    /// Index into [`PALETTE`] (wraps).
    pub colour: usize,
    /// Vertical interval (low, high) of each point, drawn as a bar with caps (empty: none;
    /// otherwise one per point, a non-finite end draws no bar).
    pub intervals: Vec<(f64, f64)>,
}

impl Series {
    /// A series named `name`.
    pub fn new(
        name: impl Into<String>,
        points: Vec<(f64, f64)>,
        style: SeriesStyle,
        colour: usize,
    ) -> Self {
        Self {
            name: name.into(),
            points,
            style,
            colour,
            intervals: Vec::new(),
        }
    }

    /// The same series with a vertical interval per point (e.g. a 95 % CI).
    pub fn with_intervals(mut self, intervals: Vec<(f64, f64)>) -> Self {
        self.intervals = intervals;
        self
    }
}

/// A labelled vertical line, e.g. at R/R′ = 1 or at R = B/2.
#[derive(Debug, Clone, PartialEq)]
pub struct Marker {
    /// Where [x units].
    pub x: f64,
    /// Text beside the line's top.
    pub label: String,
}

impl Marker {
    /// A marker at `x`.
    pub fn new(x: f64, label: impl Into<String>) -> Self {
        Self {
            x,
            label: label.into(),
        }
    }
}

/// Where the legend goes inside the plotting area.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Legend {
    /// Top right (default).
    #[default]
    UpperRight,
    /// Top left.
    UpperLeft,
    /// Bottom right.
    LowerRight,
    /// Bottom left.
    LowerLeft,
    /// No legend.
    Hidden,
}

/// One x–y chart (a panel).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Chart {
    /// Caption above the panel.
    pub title: String,
    /// X axis description, with units.
    pub x_label: String,
    /// Y axis description, with units.
    pub y_label: String,
    /// The data.
    pub series: Vec<Series>,
    /// Vertical marker lines (included in the automatic x range).
    pub markers: Vec<Marker>,
    /// Fixed x range (lo < hi); automatic with 5 % padding when `None`. Lines are clipped to it.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range (lo < hi); automatic with 5 % padding when `None`. Lines are clipped to it.
    pub y_range: Option<(f64, f64)>,
    /// Legend placement.
    pub legend: Legend,
}

impl Chart {
    /// An empty chart with its texts.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            ..Self::default()
        }
    }

    /// Points that cannot be drawn (a non-finite coordinate, or beyond
    /// ±[`MAX_ABS_COORDINATE`]); the chart notes their number.
    pub fn undrawable_points(&self) -> usize {
        self.series
            .iter()
            .flat_map(|s| &s.points)
            .filter(|&&p| !drawable(p))
            .count()
    }
}

/// Several charts in a grid, filled row by row.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// Caption above the grid (none when empty).
    pub title: String,
    /// The panels.
    pub charts: Vec<Chart>,
    /// Panels per row (at least 1).
    pub columns: usize,
    /// Size of one panel [px] (PNG pixels, SVG user units).
    pub panel_px: (u32, u32),
}

/// Default panel size [px].
pub const PANEL_PX: (u32, u32) = (800, 560);

/// Height of a figure title's band [px].
const FIGURE_TITLE_PX: u32 = 40;

impl Chart {
    /// The legend corner whose quarter of the plot holds the fewest data points.
    pub fn least_crowded_corner(&self) -> Legend {
        let points: Vec<(f64, f64)> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .filter(|(x, _)| self.x_range.is_none_or(|(lo, hi)| (lo..=hi).contains(x)))
            .collect();
        let bounds = |f: fn(&(f64, f64)) -> f64| {
            points
                .iter()
                .map(f)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                })
        };
        let (x0, x1) = self.x_range.unwrap_or_else(|| bounds(|p| p.0));
        let (y0, y1) = bounds(|p| p.1);
        let (xm, ym) = (x0 + 0.6 * (x1 - x0), y0 + 0.6 * (y1 - y0));
        let (xl, yl) = (x0 + 0.4 * (x1 - x0), y0 + 0.4 * (y1 - y0));
        let count = |f: &dyn Fn(f64, f64) -> bool| points.iter().filter(|(x, y)| f(*x, *y)).count();
        let corners = [
            (Legend::UpperRight, count(&|x, y| x >= xm && y >= ym)),
            (Legend::UpperLeft, count(&|x, y| x <= xl && y >= ym)),
            (Legend::LowerRight, count(&|x, y| x >= xm && y <= yl)),
            (Legend::LowerLeft, count(&|x, y| x <= xl && y <= yl)),
        ];
        corners
            .into_iter()
            .min_by_key(|(_, n)| *n)
            .map_or(Legend::UpperRight, |(corner, _)| corner)
    }

    /// Puts the legend in [`Chart::least_crowded_corner`].
    pub fn place_legend(&mut self) {
        self.legend = self.least_crowded_corner();
    }

    /// The y extent of the finite points (inside the x range, if fixed).
    fn y_extent(&self) -> Option<(f64, f64)> {
        let ys = self
            .series
            .iter()
            .flat_map(|s| s.points.iter())
            .filter(|(x, y)| {
                x.is_finite()
                    && y.is_finite()
                    && self.x_range.is_none_or(|(lo, hi)| (lo..=hi).contains(x))
            })
            .map(|(_, y)| *y)
            .chain(interval_ends(self));
        let (lo, hi) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), y| {
            (lo.min(y), hi.max(y))
        });
        (lo <= hi).then_some((lo, hi))
    }
}

impl Figure {
    /// Gives every panel the same y range (the union of their data, 5 % padding), so panels
    /// side by side (inner and outer) compare at a glance.
    pub fn share_y(mut self) -> Self {
        let extent = self
            .charts
            .iter()
            .filter_map(Chart::y_extent)
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)));
        if let Some((lo, hi)) = extent {
            let pad = if hi > lo { 0.05 * (hi - lo) } else { 1.0 };
            for chart in &mut self.charts {
                chart.y_range = Some((lo - pad, hi + pad));
            }
        }
        self
    }
}

impl Figure {
    /// A grid of `charts`, `columns` per row, with the default panel size.
    pub fn new(title: impl Into<String>, charts: Vec<Chart>, columns: usize) -> Self {
        Self {
            title: title.into(),
            charts,
            columns,
            panel_px: PANEL_PX,
        }
    }

    /// A figure of one chart.
    pub fn single(chart: Chart) -> Self {
        Self::new("", vec![chart], 1)
    }

    /// (columns, rows) of the grid; an empty figure is drawn as one "no data" panel.
    fn grid(&self) -> (usize, usize) {
        let n = self.charts.len().max(1);
        let columns = self.columns.clamp(1, n);
        (columns, n.div_ceil(columns))
    }

    /// The whole figure's size [px].
    pub fn size_px(&self) -> Result<(u32, u32), PlotError> {
        let (columns, rows) = self.grid();
        let title = if self.title.is_empty() {
            0
        } else {
            u64::from(FIGURE_TITLE_PX)
        };
        let w = u64::from(self.panel_px.0).saturating_mul(columns as u64);
        let h = u64::from(self.panel_px.1)
            .saturating_mul(rows as u64)
            .saturating_add(title);
        let side = 1..=u64::from(MAX_SIDE_PX);
        if self.panel_px.0 == 0 || self.panel_px.1 == 0 || !side.contains(&w) || !side.contains(&h)
        {
            return Err(PlotError::BadSize {
                width_px: w,
                height_px: h,
            });
        }
        // Both fit in MAX_SIDE_PX, hence in u32.
        Ok((w as u32, h as u32))
    }
}

/// Writes `chart` to `path` as PNG or SVG (by extension), atomically.
pub fn render(chart: &Chart, path: &Path) -> Result<(), PlotError> {
    render_figure(&Figure::single(chart.clone()), path)
}

/// Writes `figure` to `path` as PNG or SVG (by extension), atomically: on any error the previous
/// file, if any, is left as it was.
pub fn render_figure(figure: &Figure, path: &Path) -> Result<(), PlotError> {
    let format = Format::from_path(path)?;
    let bytes = render_bytes(figure, format)?;
    write_atomically(path, |w| w.write_all(&bytes))?;
    Ok(())
}

/// The encoded file content of `figure` in `format`.
pub fn render_bytes(figure: &Figure, format: Format) -> Result<Vec<u8>, PlotError> {
    register_font()?;
    let (w, h) = figure.size_px()?;
    for chart in &figure.charts {
        ranges(chart)?;
    }
    match format {
        Format::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
                draw_figure(figure, &root).map_err(draw_error)?;
                root.present().map_err(draw_error)?;
            }
            Ok(svg.into_bytes())
        }
        Format::Png => {
            // Sides are at most MAX_SIDE_PX, so this fits in usize.
            let mut rgb = vec![0u8; w as usize * h as usize * 3];
            {
                let backend = BitMapBackend::<RGBPixel>::with_buffer_and_format(&mut rgb, (w, h))
                    .map_err(|e| PlotError::Draw(e.to_string()))?;
                let root = glyphs::Glyphs(backend).into_drawing_area();
                draw_figure(figure, &root).map_err(draw_error)?;
                root.present().map_err(draw_error)?;
            }
            let mut out = Vec::new();
            let mut encoder = png::Encoder::new(&mut out, w, h);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            let mut writer = encoder.write_header()?;
            writer.write_image_data(&rgb)?;
            writer.finish()?;
            Ok(out)
        }
    }
}

/// Registers the embedded font with plotters once per process.
fn register_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FAMILY, FontStyle::Normal, FONT_TTF).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}

fn draw_error<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
    PlotError::Draw(e.to_string())
}

type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

fn draw_figure<DB: DrawingBackend>(
    figure: &Figure,
    root: &DrawingArea<DB, Shift>,
) -> DrawResult<DB> {
    root.fill(&WHITE)?;
    let area = if figure.title.is_empty() {
        root.clone()
    } else {
        root.titled(&figure.title, (FAMILY, 26))?
    };
    let (columns, rows) = figure.grid();
    let panels = area.split_evenly((rows, columns));
    if figure.charts.is_empty() {
        if let Some(panel) = panels.first() {
            draw_chart(&Chart::default(), panel)?;
        }
    }
    for (chart, panel) in figure.charts.iter().zip(&panels) {
        draw_chart(chart, panel)?;
    }
    Ok(())
}

/// An axis interval (lo, hi).
type Span = (f64, f64);

/// A data point (x, y).
type Point = (f64, f64);

/// Whether `p` can be placed on an axis.
fn drawable(p: (f64, f64)) -> bool {
    let ok = |v: f64| v.is_finite() && v.abs() <= MAX_ABS_COORDINATE;
    ok(p.0) && ok(p.1)
}

/// An explicit range, checked.
fn checked_range(axis: &'static str, (lo, hi): (f64, f64)) -> Result<(f64, f64), PlotError> {
    let bad = |reason| PlotError::BadRange {
        axis,
        lo,
        hi,
        reason,
    };
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(bad("the ends must be finite"));
    }
    if lo.abs().max(hi.abs()) > MAX_ABS_COORDINATE {
        return Err(bad("the ends must lie within ±1e150"));
    }
    if lo >= hi {
        return Err(bad("the lower end must be below the upper end"));
    }
    if hi - lo < lo.abs().max(hi.abs()) * 1e-12 {
        return Err(bad(
            "too narrow for its magnitude (relative width under 1e-12)",
        ));
    }
    Ok((lo, hi))
}

/// An automatic axis range around `values` (finite, within ±[`MAX_ABS_COORDINATE`]): 5 %
/// padding each side; equal values get ±5 % of their magnitude (±1 around 0).
fn auto_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values.fold(None, |acc: Option<(f64, f64)>, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })?;
    let magnitude = lo.abs().max(hi.abs());
    let span = hi - lo;
    if span <= magnitude * 1e-9 {
        let half = if magnitude > 0.0 {
            magnitude * 0.05
        } else {
            1.0
        };
        let mid = lo / 2.0 + hi / 2.0;
        return Some((mid - half, mid + half));
    }
    let pad = span * 0.05;
    Some((lo - pad, hi + pad))
}

/// The x and y ranges of `chart` (0..1 for an axis with no data and no range).
fn ranges(chart: &Chart) -> Result<(Span, Span), PlotError> {
    let points = || {
        chart
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|&p| drawable(p))
    };
    let markers = chart
        .markers
        .iter()
        .map(|m| m.x)
        .filter(|x| x.is_finite() && x.abs() <= MAX_ABS_COORDINATE);
    let x = match chart.x_range {
        Some(r) => Some(checked_range("x", r)?),
        None => auto_range(points().map(|p| p.0).chain(markers)),
    };
    let y = match chart.y_range {
        Some(r) => Some(checked_range("y", r)?),
        None => auto_range(points().map(|p| p.1).chain(interval_ends(chart))),
    };
    Ok((x.unwrap_or((0.0, 1.0)), y.unwrap_or((0.0, 1.0))))
}

/// The finite ends of the intervals of drawable points (they widen the y range).
fn interval_ends(chart: &Chart) -> impl Iterator<Item = f64> + '_ {
    chart
        .series
        .iter()
        .flat_map(|s| s.points.iter().zip(&s.intervals))
        .filter(|(&p, _)| drawable(p))
        .flat_map(|(_, &(lo, hi))| [lo, hi])
        .filter(|v| v.is_finite() && v.abs() <= MAX_ABS_COORDINATE)
}

/// Clips the segment a–b to the box (Liang–Barsky); `None` if it lies outside.
fn clip_segment(
    a: (f64, f64),
    b: (f64, f64),
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - x0),
        (dx, x1 - a.0),
        (-dy, a.1 - y0),
        (dy, y1 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
            if t0 > t1 {
                return None;
            }
        }
    }
    // Clamped: rounding in t and in `a + t·d` may land outside a box that is tiny next to the
    // segment, and plotters' pixel mapping overflows far outside its range.
    let at = |t: f64| {
        let p = if t == 0.0 {
            a
        } else if t == 1.0 {
            b
        } else {
            (a.0 + t * dx, a.1 + t * dy)
        };
        (p.0.clamp(x0, x1), p.1.clamp(y0, y1))
    };
    Some((at(t0), at(t1)))
}

/// Whether `p` lies in the box (edges included).
fn inside(p: (f64, f64), (x0, x1): Span, (y0, y1): Span) -> bool {
    (x0..=x1).contains(&p.0) && (y0..=y1).contains(&p.1)
}

/// The polylines of `points` inside the box: broken at undrawable points and where the line
/// leaves the box. Also returns the isolated points (drawable, in the box, no drawable
/// neighbour), which a line alone would not show.
fn polylines(points: &[Point], x: Span, y: Span) -> (Vec<Vec<Point>>, Vec<Point>) {
    let mut runs = Vec::new();
    let mut isolated = Vec::new();
    let mut current: Vec<(f64, f64)> = Vec::new();
    for run in points.split(|&p| !drawable(p)) {
        if let [p] = run {
            if inside(*p, x, y) {
                isolated.push(*p);
            }
            continue;
        }
        for pair in run.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            match clip_segment(a, b, x, y) {
                None => {
                    if current.len() > 1 {
                        runs.push(std::mem::take(&mut current));
                    }
                    current.clear();
                }
                Some((ca, cb)) => {
                    if current.last() != Some(&ca) {
                        if current.len() > 1 {
                            runs.push(std::mem::take(&mut current));
                        }
                        current.clear();
                        current.push(ca);
                    }
                    current.push(cb);
                    if cb != b {
                        runs.push(std::mem::take(&mut current));
                    }
                }
            }
        }
        if current.len() > 1 {
            runs.push(std::mem::take(&mut current));
        }
        current.clear();
    }
    (runs, isolated)
}

/// A tick label: plain decimals for 1e-3 ≤ |v| < 1e5, otherwise scientific.
fn tick_label(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        return "0".into();
    }
    if !(1e-3..1e5).contains(&a) {
        return format!("{v:.2e}");
    }
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

fn colour(index: usize) -> RGBColor {
    let (r, g, b) = palette_rgb(index);
    RGBColor(r, g, b)
}

/// A series' legend sample: a short line, a dot, or both. (plotters' composed elements cannot
/// be boxed for the legend unless the backend is `'static`, which buffer backends are not.)
#[derive(Debug, Clone, Copy)]
struct LegendGlyph {
    at: BackendCoord,
    colour: RGBColor,
    style: SeriesStyle,
}

impl<'b> PointCollection<'b, BackendCoord> for &'b LegendGlyph {
    type Point = &'b BackendCoord;
    type IntoIter = std::iter::Once<&'b BackendCoord>;
    fn point_iter(self) -> Self::IntoIter {
        std::iter::once(&self.at)
    }
}

impl<DB: DrawingBackend> Drawable<DB> for LegendGlyph {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        mut pos: I,
        backend: &mut DB,
        _parent_dim: (u32, u32),
    ) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
        let Some((x, y)) = pos.next() else {
            return Ok(());
        };
        if matches!(self.style, SeriesStyle::Line | SeriesStyle::LineAndPoints) {
            backend.draw_path([(x, y), (x + 20, y)], &self.colour.stroke_width(2))?;
        }
        if matches!(self.style, SeriesStyle::Points | SeriesStyle::LineAndPoints) {
            backend.draw_circle((x + 10, y), 3, &self.colour.filled(), true)?;
        }
        Ok(())
    }
}

fn draw_chart<DB: DrawingBackend>(chart: &Chart, area: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
    // A bad explicit range is a caller error, reported on the panel rather than failing the
    // figure's other panels; `render` checks it up front.
    let (x, y) = match ranges(chart) {
        Ok(r) => r,
        Err(e) => {
            let style = (FAMILY, 16)
                .into_font()
                .color(&RED)
                .pos(Pos::new(HPos::Center, VPos::Center));
            let (w, h) = area.dim_in_pixel();
            area.draw_text(&e.to_string(), &style, (w as i32 / 2, h as i32 / 2))?;
            return Ok(());
        }
    };
    let mut builder = ChartBuilder::on(area);
    builder
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(72);
    if !chart.title.is_empty() {
        builder.caption(&chart.title, (FAMILY, 20));
    }
    let mut ctx = builder.build_cartesian_2d(x.0..x.1, y.0..y.1)?;
    ctx.configure_mesh()
        .x_desc(&chart.x_label)
        .y_desc(&chart.y_label)
        .x_label_formatter(&|v| tick_label(*v))
        .y_label_formatter(&|v| tick_label(*v))
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 15))
        .max_light_lines(4)
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()?;

    let grey = RGBColor(90, 90, 90);
    let mut marker_row = 0;
    for m in &chart.markers {
        if !(m.x.is_finite() && (x.0..=x.1).contains(&m.x)) {
            continue;
        }
        ctx.draw_series(DashedLineSeries::new(
            [(m.x, y.0), (m.x, y.1)],
            6,
            4,
            grey.stroke_width(1),
        ))?;
        if !m.label.is_empty() {
            ctx.draw_series(std::iter::once(
                EmptyElement::at((m.x, y.1))
                    + Text::new(
                        m.label.clone(),
                        (4, 4 + 16 * marker_row),
                        (FAMILY, 13).into_font().color(&grey),
                    ),
            ))?;
            marker_row += 1;
        }
    }

    let mut has_data = false;
    for s in &chart.series {
        let c = colour(s.colour);
        let line = c.stroke_width(2);
        let dot = c.filled();
        if matches!(s.style, SeriesStyle::Line | SeriesStyle::LineAndPoints) {
            let (runs, isolated) = polylines(&s.points, x, y);
            has_data |= !runs.is_empty() || !isolated.is_empty();
            for run in runs {
                ctx.draw_series(LineSeries::new(run, line))?;
            }
            if s.style == SeriesStyle::Line {
                ctx.draw_series(isolated.into_iter().map(|p| Circle::new(p, 2, dot)))?;
            }
        }
        if matches!(s.style, SeriesStyle::Points | SeriesStyle::LineAndPoints) {
            let dots: Vec<(f64, f64)> = s
                .points
                .iter()
                .copied()
                .filter(|&p| drawable(p) && inside(p, x, y))
                .collect();
            has_data |= !dots.is_empty();
            ctx.draw_series(dots.into_iter().map(|p| Circle::new(p, 3, dot)))?;
            // Interval bars, clipped to the panel, with caps 1 % of the x span wide.
            let cap = 0.01 * (x.1 - x.0);
            for (&(px, _), &(lo, hi)) in s.points.iter().zip(&s.intervals) {
                let bar = [
                    ((px, lo), (px, hi)),
                    ((px - cap, lo), (px + cap, lo)),
                    ((px - cap, hi), (px + cap, hi)),
                ];
                if !(drawable((px, lo)) && drawable((px, hi))) {
                    continue;
                }
                for (a, b) in bar {
                    if let Some((a, b)) = clip_segment(a, b, x, y) {
                        ctx.draw_series(LineSeries::new([a, b], c.stroke_width(1)))?;
                    }
                }
            }
        }
    }

    let plot = ctx.plotting_area();
    let note = (FAMILY, 14).into_font().color(&grey);
    if !has_data {
        let any_points = chart
            .series
            .iter()
            .flat_map(|s| &s.points)
            .any(|&p| drawable(p));
        let text = if any_points {
            "no data in range"
        } else {
            "no data"
        };
        plot.draw(&Text::new(
            text,
            (x.0 / 2.0 + x.1 / 2.0, y.0 / 2.0 + y.1 / 2.0),
            (FAMILY, 22)
                .into_font()
                .color(&grey)
                .pos(Pos::new(HPos::Center, VPos::Center)),
        ))?;
    }
    let undrawable = chart.undrawable_points();
    if undrawable > 0 {
        let plural = if undrawable == 1 { "" } else { "s" };
        plot.draw(
            &(EmptyElement::at((x.0, y.0))
                + Text::new(
                    format!("{undrawable} point{plural} not shown (non-finite or out of scale)"),
                    (6, -20),
                    note,
                )),
        )?;
    }

    if chart.legend != Legend::Hidden && chart.series.iter().any(|s| !s.name.is_empty()) {
        for s in chart.series.iter().filter(|s| !s.name.is_empty()) {
            let c = colour(s.colour);
            let style = s.style;
            ctx.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
                .label(s.name.clone())
                .legend(move |at| LegendGlyph {
                    at,
                    colour: c,
                    style,
                });
        }
        let position = match chart.legend {
            Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
            Legend::LowerRight => SeriesLabelPosition::LowerRight,
            Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
            Legend::UpperRight | Legend::Hidden => SeriesLabelPosition::UpperRight,
        };
        ctx.configure_series_labels()
            .position(position)
            .label_font((FAMILY, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(160, 160, 160))
            .draw()?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn panels_side_by_side_share_one_y_range() {
        let chart = |ys: &[f64]| {
            let mut c = Chart::new("p", "x", "y");
            let points = ys.iter().enumerate().map(|(i, y)| (i as f64, *y)).collect();
            c.series
                .push(Series::new("s", points, SeriesStyle::Points, 0));
            c
        };
        let figure = Figure::new("f", vec![chart(&[0.0, 10.0]), chart(&[-20.0, 5.0])], 2).share_y();
        let ranges: Vec<_> = figure.charts.iter().map(|c| c.y_range).collect();
        assert_eq!(ranges[0], ranges[1]);
        let (lo, hi) = ranges[0].expect("range");
        assert!(lo < -20.0 && hi > 10.0);
    }

    #[test]
    fn interval_bars_widen_the_y_range_and_are_drawn() {
        let mut chart = Chart::new("p", "x", "y");
        chart.series.push(
            Series::new("ci", vec![(0.0, 1.0), (1.0, 2.0)], SeriesStyle::Points, 0)
                .with_intervals(vec![(-40.0, 3.0), (f64::NEG_INFINITY, 90.0)]),
        );
        // A non-finite end draws no bar but its finite end still counts.
        let (_, (lo, hi)) = ranges(&chart).expect("ranges");
        assert!(lo <= -40.0 && hi >= 90.0, "{lo} {hi}");
        let shared = Figure::new("f", vec![chart.clone()], 1).share_y();
        let (lo, hi) = shared.charts[0].y_range.expect("range");
        assert!(lo < -40.0 && hi > 90.0);
        // The bar is ink: a figure with it has more elements than one without (same axes).
        chart.y_range = Some((-50.0, 100.0));
        let mut bare = chart.clone();
        bare.series[0].intervals.clear();
        let with = render_bytes(&Figure::single(chart), Format::Svg).expect("svg");
        let without = render_bytes(&Figure::single(bare), Format::Svg).expect("svg");
        let lines = |b: &[u8]| String::from_utf8_lossy(b).matches('<').count();
        assert!(lines(&with) >= lines(&without) + 3, "bar and two caps");
    }

    use super::*;
    use proptest::prelude::*;

    fn model_curve() -> Vec<(f64, f64)> {
        (1..=40)
            .map(|i| {
                let r = f64::from(i) * 0.1;
                (r, 140.0 + 130.0 / r)
            })
            .collect()
    }

    fn demo_chart() -> Chart {
        let mut chart = Chart::new("Average power vs R/R′", "R/R′ [-]", "P [W]");
        chart.series.push(Series::new(
            "measured",
            vec![(0.5, 410.0), (1.0, 260.0), (2.0, 180.0), (4.0, 150.0)],
            SeriesStyle::Points,
            0,
        ));
        chart
            .series
            .push(Series::new("model", model_curve(), SeriesStyle::Line, 1));
        chart.markers.push(Marker::new(1.0, "R = R′"));
        chart
    }

    fn svg_of(figure: &Figure) -> String {
        String::from_utf8(render_bytes(figure, Format::Svg).expect("renders")).expect("utf-8")
    }

    /// The contents of the SVG's `<text>` elements, trimmed.
    fn svg_texts(svg: &str) -> Vec<String> {
        svg.split("<text")
            .skip(1)
            .filter_map(|t| {
                let start = t.find('>')? + 1;
                let end = t.find("</text>")?;
                Some(t[start..end].trim().to_owned())
            })
            .collect()
    }

    /// The `<polyline>` elements stroked in `rgb`.
    fn polylines_in(svg: &str, rgb: (u8, u8, u8)) -> usize {
        let stroke = format!("stroke=\"#{:02X}{:02X}{:02X}\"", rgb.0, rgb.1, rgb.2);
        svg.split("<polyline")
            .skip(1)
            .filter(|p| {
                p.split('>')
                    .next()
                    .is_some_and(|attrs| attrs.contains(&stroke))
            })
            .count()
    }

    /// The `<circle>` elements filled with `rgb`.
    fn circles_in(svg: &str, rgb: (u8, u8, u8)) -> usize {
        let fill = format!("fill=\"#{:02X}{:02X}{:02X}\"", rgb.0, rgb.1, rgb.2);
        svg.split("<circle")
            .skip(1)
            .filter(|p| {
                p.split('>')
                    .next()
                    .is_some_and(|attrs| attrs.contains(&fill))
            })
            .count()
    }

    struct Decoded {
        width: u32,
        height: u32,
        rgb: Vec<u8>,
    }

    impl Decoded {
        fn pixels(&self) -> impl Iterator<Item = (u32, u32, (u8, u8, u8))> + '_ {
            self.rgb.chunks_exact(3).enumerate().map(|(i, p)| {
                let i = i as u32;
                (i % self.width, i / self.width, (p[0], p[1], p[2]))
            })
        }

        fn count(&self, pred: impl Fn(u32, u32, (u8, u8, u8)) -> bool) -> usize {
            self.pixels().filter(|&(x, y, c)| pred(x, y, c)).count()
        }
    }

    fn decode_png(bytes: &[u8]) -> Decoded {
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
            .read_info()
            .expect("PNG header");
        let mut rgb = vec![0; reader.output_buffer_size().expect("size")];
        let info = reader.next_frame(&mut rgb).expect("PNG data");
        assert_eq!(info.color_type, png::ColorType::Rgb);
        rgb.truncate(info.buffer_size());
        Decoded {
            width: info.width,
            height: info.height,
            rgb,
        }
    }

    #[test]
    fn format_follows_the_extension() {
        assert_eq!(
            Format::from_path(Path::new("a/b.png")).ok(),
            Some(Format::Png)
        );
        assert_eq!(
            Format::from_path(Path::new("B.SVG")).ok(),
            Some(Format::Svg)
        );
        for bad in ["fig.pdf", "fig", "fig.png.txt", ".png"] {
            assert!(
                matches!(
                    Format::from_path(Path::new(bad)),
                    Err(PlotError::UnsupportedFormat { .. })
                ),
                "{bad}"
            );
        }
    }

    #[test]
    fn bad_extension_is_an_error_and_writes_nothing() {
        let dir = std::env::temp_dir().join(format!("plot-ext-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("figure.jpg");
        let err = render(&demo_chart(), &path).expect_err("jpg is not supported");
        assert!(err.to_string().contains(".png or .svg"), "{err}");
        assert!(!path.exists());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn svg_holds_the_texts_and_one_path_per_line_series() {
        let mut chart = demo_chart();
        chart.legend = Legend::Hidden;
        let svg = svg_of(&Figure::single(chart));
        let texts = svg_texts(&svg);
        for t in ["Average power vs R/R′", "R/R′ [-]", "P [W]", "R = R′"] {
            assert!(texts.iter().any(|x| x == t), "{t} missing in {texts:?}");
        }
        assert_eq!(
            polylines_in(&svg, palette_rgb(1)),
            1,
            "one path for the model"
        );
        assert_eq!(circles_in(&svg, palette_rgb(0)), 4, "a dot per measurement");
        assert_eq!(polylines_in(&svg, palette_rgb(0)), 0);

        // With the legend, each series gains exactly one legend sample and its name.
        let svg = svg_of(&Figure::single(demo_chart()));
        assert_eq!(polylines_in(&svg, palette_rgb(1)), 2);
        assert_eq!(circles_in(&svg, palette_rgb(0)), 5);
        let texts = svg_texts(&svg);
        assert!(texts.iter().any(|x| x == "measured") && texts.iter().any(|x| x == "model"));
    }

    #[test]
    fn svg_text_is_escaped() {
        let chart = Chart::new("a < b & c", "x", "y");
        let svg = svg_of(&Figure::single(chart));
        assert!(svg.contains("a &lt; b &amp; c"), "{svg}");
    }

    #[test]
    fn nan_points_are_skipped_breaking_the_line_and_are_counted() {
        let mut chart = demo_chart();
        chart.legend = Legend::Hidden;
        chart.series[1].points[10].1 = f64::NAN;
        chart.series[1].points[20].0 = f64::INFINITY;
        chart.series[0].points.push((f64::NAN, 1.0));
        assert_eq!(chart.undrawable_points(), 3);
        let svg = svg_of(&Figure::single(chart));
        assert_eq!(
            polylines_in(&svg, palette_rgb(1)),
            3,
            "two gaps: three pieces"
        );
        assert_eq!(circles_in(&svg, palette_rgb(0)), 4);
        assert!(svg_texts(&svg)
            .iter()
            .any(|t| t == "3 points not shown (non-finite or out of scale)"));
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
    }

    #[test]
    fn empty_series_give_a_no_data_chart() {
        for chart in [
            Chart::new("nothing", "t [s]", "P [W]"),
            Chart {
                series: vec![Series::new(
                    "s",
                    vec![(f64::NAN, 1.0)],
                    SeriesStyle::Line,
                    0,
                )],
                ..Chart::new("only NaN", "t [s]", "P [W]")
            },
        ] {
            let svg = svg_of(&Figure::single(chart));
            assert!(svg_texts(&svg).iter().any(|t| t == "no data"));
        }
        let svg = svg_of(&Figure::new("", vec![], 3));
        assert!(svg_texts(&svg).iter().any(|t| t == "no data"));
        let png = decode_png(&render_bytes(&Figure::new("", vec![], 3), Format::Png).expect("png"));
        assert_eq!((png.width, png.height), PANEL_PX);
    }

    #[test]
    fn data_outside_a_fixed_range_says_so_and_lines_are_clipped() {
        let mut chart = demo_chart();
        chart.x_range = Some((10.0, 20.0));
        let svg = svg_of(&Figure::single(chart));
        assert!(svg_texts(&svg).iter().any(|t| t == "no data in range"));

        let mut chart = demo_chart();
        chart.legend = Legend::Hidden;
        chart.y_range = Some((0.0, 300.0));
        let svg = svg_of(&Figure::single(chart));
        // The model curve enters the range at R/R' ≈ 0.8 and stays.
        assert_eq!(polylines_in(&svg, palette_rgb(1)), 1);
        assert_eq!(
            circles_in(&svg, palette_rgb(0)),
            3,
            "the 410 W point is out"
        );
    }

    #[test]
    fn bad_ranges_and_sizes_are_errors() {
        for (range, what) in [
            ((1.0, 1.0), "below"),
            ((2.0, 1.0), "below"),
            ((f64::NAN, 1.0), "finite"),
            ((0.0, f64::INFINITY), "finite"),
            ((0.0, 1e200), "1e150"),
            ((1e9, 1e9 + 1e-6), "narrow"),
        ] {
            let mut chart = demo_chart();
            chart.y_range = Some(range);
            let err = render_bytes(&Figure::single(chart), Format::Svg).expect_err("bad range");
            assert!(
                matches!(err, PlotError::BadRange { axis: "y", .. })
                    && err.to_string().contains(what),
                "{range:?}: {err}"
            );
        }
        let mut figure = Figure::single(demo_chart());
        figure.panel_px = (0, 100);
        assert!(matches!(figure.size_px(), Err(PlotError::BadSize { .. })));
        figure.panel_px = (MAX_SIDE_PX, 100);
        figure.charts.push(demo_chart());
        figure.columns = 2;
        assert!(matches!(
            render_bytes(&figure, Format::Png),
            Err(PlotError::BadSize { .. })
        ));
    }

    #[test]
    fn png_decodes_with_text_and_series_colours() {
        let png =
            decode_png(&render_bytes(&Figure::single(demo_chart()), Format::Png).expect("png"));
        assert_eq!((png.width, png.height), PANEL_PX);
        let (b, v) = (palette_rgb(0), palette_rgb(1));
        assert!(
            png.count(|_, _, c| c == b) > 4 * 20,
            "measurement dots drawn"
        );
        assert!(png.count(|_, _, c| c == v) > 500, "model line drawn");
        // The caption band holds dark (text) pixels only when there is a title: the embedded
        // font renders.
        let dark = |c: (u8, u8, u8)| u16::from(c.0) + u16::from(c.1) + u16::from(c.2) < 200;
        assert!(png.count(|_, y, c| y < 30 && dark(c)) > 100);
        let mut untitled = demo_chart();
        untitled.title.clear();
        let png = decode_png(&render_bytes(&Figure::single(untitled), Format::Png).expect("png"));
        assert_eq!(png.count(|_, y, c| y < 10 && dark(c)), 0);
        // A chart without that series has none of its colour.
        let mut only_model = demo_chart();
        only_model.series.remove(0);
        let png = decode_png(&render_bytes(&Figure::single(only_model), Format::Png).expect("png"));
        assert_eq!(png.count(|_, _, c| c == b), 0);
    }

    #[test]
    fn png_dot_lands_where_its_coordinates_map() {
        // One point in the middle of fixed ranges: its colour appears around the plotting area's
        // centre, and nowhere else.
        let mut chart = Chart::new("", "", "");
        chart.legend = Legend::Hidden;
        chart.x_range = Some((0.0, 10.0));
        chart.y_range = Some((0.0, 10.0));
        chart
            .series
            .push(Series::new("", vec![(5.0, 5.0)], SeriesStyle::Points, 2));
        let png = decode_png(&render_bytes(&Figure::single(chart), Format::Png).expect("png"));
        let c = palette_rgb(2);
        let hits: Vec<(u32, u32)> = png
            .pixels()
            .filter(|p| p.2 == c)
            .map(|p| (p.0, p.1))
            .collect();
        assert!(!hits.is_empty());
        let (xs, ys): (Vec<u32>, Vec<u32>) = hits.iter().copied().unzip();
        let (x0, x1) = (
            xs.iter().min().copied().unwrap_or(0),
            xs.iter().max().copied().unwrap_or(0),
        );
        let (y0, y1) = (
            ys.iter().min().copied().unwrap_or(0),
            ys.iter().max().copied().unwrap_or(0),
        );
        assert!(x1 - x0 <= 7 && y1 - y0 <= 7, "one radius-3 dot: {hits:?}");
        let (x0, y0) = ((x0 + x1) / 2, (y0 + y1) / 2);
        // Plot area: left label area 72 + margin 12, right margin 12; bottom label area 48 +
        // margin 12, top margin 12 (no caption).
        let cx = (12 + 72 + (PANEL_PX.0 - 12)) / 2;
        let cy = (12 + (PANEL_PX.1 - 12 - 48)) / 2;
        assert!(
            x0.abs_diff(cx) <= 2 && y0.abs_diff(cy) <= 2,
            "dot at {x0},{y0}, centre {cx},{cy}"
        );
    }

    #[test]
    fn figure_grid_has_panel_sized_cells_and_all_titles() {
        let mut right = demo_chart();
        right.title = "right".into();
        let mut left = demo_chart();
        left.title = "left".into();
        let figure = Figure::new("Turn at R = 2 m", vec![left, right, demo_chart()], 2);
        assert_eq!(
            figure.size_px().ok(),
            Some((2 * PANEL_PX.0, 2 * PANEL_PX.1 + FIGURE_TITLE_PX))
        );
        let texts = svg_texts(&svg_of(&figure));
        for t in ["Turn at R = 2 m", "left", "right", "Average power vs R/R′"] {
            assert!(texts.iter().any(|x| x == t), "{t}");
        }
    }

    #[test]
    fn render_writes_both_formats_atomically() {
        let dir = std::env::temp_dir().join(format!("plot-render-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let svg = dir.join("f.svg");
        let png = dir.join("f.PNG");
        render(&demo_chart(), &svg).expect("svg");
        render(&demo_chart(), &png).expect("png");
        assert!(std::fs::read_to_string(&svg)
            .expect("read")
            .starts_with("<svg"));
        let bytes = std::fs::read(&png).expect("read");
        assert_eq!(decode_png(&bytes).width, PANEL_PX.0);
        // A failing render leaves the previous file alone.
        let mut bad = demo_chart();
        bad.x_range = Some((1.0, 0.0));
        assert!(render(&bad, &svg).is_err());
        assert!(std::fs::read_to_string(&svg)
            .expect("read")
            .contains("R = R′"));
        let leftovers = std::fs::read_dir(&dir).expect("dir").count();
        assert_eq!(leftovers, 2, "no temporary files left");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn clipping_segments() {
        let bx = (0.0, 1.0);
        assert_eq!(
            clip_segment((-1.0, 0.5), (2.0, 0.5), bx, bx),
            Some(((0.0, 0.5), (1.0, 0.5)))
        );
        assert_eq!(clip_segment((2.0, 2.0), (3.0, 3.0), bx, bx), None);
        // A box tiny next to the segment: the cut points stay inside it despite rounding.
        let tiny = (0.0, 6e-66);
        let (p, q) = clip_segment((0.0, -614.27), (0.0, 1e150), (-1.0, 1.0), tiny).expect("hit");
        assert!(
            inside(p, (-1.0, 1.0), tiny) && inside(q, (-1.0, 1.0), tiny),
            "{p:?} {q:?}"
        );
        assert_eq!(clip_segment((-1.0, 2.0), (2.0, 2.0), bx, bx), None);
        let inside = ((0.2, 0.2), (0.8, 0.9));
        assert_eq!(clip_segment(inside.0, inside.1, bx, bx), Some(inside));
        // Out, in, out again: two pieces; NaN splits too; a lone point is kept as a dot.
        let pts = [
            (-1.0, 0.5),
            (0.5, 0.5),
            (2.0, 0.5),
            (0.5, 0.6),
            (0.6, 0.6),
            (f64::NAN, 0.0),
            (0.3, 0.3),
        ];
        let (runs, isolated) = polylines(&pts, bx, bx);
        assert_eq!(
            runs,
            vec![
                vec![(0.0, 0.5), (0.5, 0.5), (1.0, 0.5)],
                vec![(1.0, 0.5 + 0.1 * (1.0 / 1.5)), (0.5, 0.6), (0.6, 0.6)],
            ]
        );
        assert_eq!(isolated, vec![(0.3, 0.3)]);
    }

    #[test]
    fn automatic_ranges() {
        assert_eq!(auto_range([0.0, 10.0].into_iter()), Some((-0.5, 10.5)));
        assert_eq!(auto_range([3.0].into_iter()), Some((2.85, 3.15)));
        assert_eq!(auto_range([0.0, 0.0].into_iter()), Some((-1.0, 1.0)));
        assert_eq!(auto_range(std::iter::empty()), None);
        let (lo, hi) = auto_range([-1e150, 1e150].into_iter()).expect("range");
        assert!(lo.is_finite() && hi.is_finite() && lo < -1e150 && hi > 1e150);
    }

    #[test]
    fn tick_labels() {
        assert_eq!(tick_label(0.0), "0");
        assert_eq!(tick_label(2.5), "2.5");
        assert_eq!(tick_label(-1200.0), "-1200");
        assert_eq!(tick_label(0.0004), "4.00e-4");
        assert_eq!(tick_label(250_000.0), "2.50e5");
        assert_eq!(tick_label(-0.00001), "-1.00e-5");
    }

    fn coordinate() -> impl Strategy<Value = f64> {
        prop_oneof![
            4 => -1e3..1e3f64,
            1 => any::<f64>(),
            1 => Just(f64::NAN),
            1 => Just(f64::INFINITY),
            1 => Just(f64::NEG_INFINITY),
            1 => Just(0.0),
            1 => Just(1e150),
            1 => Just(-1e150),
            1 => Just(1e-300),
            1 => Just(42.0),
        ]
    }

    fn series() -> impl Strategy<Value = Series> {
        (
            proptest::collection::vec((coordinate(), coordinate()), 0..12),
            prop_oneof![
                Just(SeriesStyle::Line),
                Just(SeriesStyle::Points),
                Just(SeriesStyle::LineAndPoints)
            ],
            0usize..20,
            "[a-zτ′ ]{0,6}",
        )
            .prop_map(|(points, style, colour, name)| Series::new(name, points, style, colour))
    }

    fn range() -> impl Strategy<Value = Option<(f64, f64)>> {
        prop_oneof![
            3 => Just(None),
            1 => (coordinate(), coordinate()).prop_map(Some),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Any data, finite or not, renders in both formats or gives a range error; nothing
        /// panics or hangs.
        #[test]
        fn arbitrary_points_never_panic(
            series in proptest::collection::vec(series(), 0..4),
            markers in proptest::collection::vec(coordinate(), 0..3),
            x_range in range(),
            y_range in range(),
        ) {
            let chart = Chart {
                series,
                markers: markers.into_iter().map(|x| Marker::new(x, "m")).collect(),
                x_range,
                y_range,
                ..Chart::new("t", "x", "y")
            };
            let mut figure = Figure::single(chart);
            figure.panel_px = (240, 180);
            for format in [Format::Svg, Format::Png] {
                match render_bytes(&figure, format) {
                    Ok(bytes) => prop_assert!(!bytes.is_empty()),
                    Err(PlotError::BadRange { .. }) => {
                        prop_assert!(x_range.is_some() || y_range.is_some());
                    }
                    Err(e) => prop_assert!(false, "{e}"),
                }
            }
        }
    }
}
