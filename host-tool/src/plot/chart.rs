//! What a figure shows: series, markers, legend placement, charts and grids of charts.

use super::axes::{drawable, interval_ends};
use super::{PlotError, MAX_SIDE_PX};

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

/// The mark of each point of a points series.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Shape {
    /// A filled circle (default).
    #[default]
    Dot,
    /// A hollow circle: reads apart from dots of any colour.
    Ring,
    /// A filled square.
    Square,
    /// A filled triangle, point up.
    Triangle,
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
    /// The mark of each point (points styles).
    pub shape: Shape,
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
            shape: Shape::Dot,
        }
    }

    /// The same series with `shape` for its points.
    pub fn with_shape(mut self, shape: Shape) -> Self {
        self.shape = shape;
        self
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

/// Where the legend goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Legend {
    /// The first corner of the plot (upper right, upper left, lower right, lower left) where
    /// it covers no point, line, interval or marker label; a strip below the chart when every
    /// corner would (default).
    #[default]
    Auto,
    /// Top right of the plot, whatever it covers.
    UpperRight,
    /// Top left.
    UpperLeft,
    /// Bottom right.
    LowerRight,
    /// Bottom left.
    LowerLeft,
    /// A strip below the chart, entries side by side.
    Below,
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
pub(super) const FIGURE_TITLE_PX: u32 = 40;

impl Chart {
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
    pub(super) fn grid(&self) -> (usize, usize) {
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
