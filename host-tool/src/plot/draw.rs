//! Drawing one chart into a panel with plotters: mesh, markers, series, notes and legend.

use super::axes::{clip_segment, drawable, inside, polylines, ranges, tick_label, Span};
use super::chart::{Chart, Legend, Series, SeriesStyle};
use super::render::DrawResult;
use super::{palette_rgb, FAMILY};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::element::{Drawable, PointCollection};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{BackendCoord, DrawingErrorKind};

pub(super) fn colour(index: usize) -> RGBColor {
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

/// The plotting context of one panel (f64 data coordinates on both axes).
type Ctx<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Grey of markers and notes.
const GREY: RGBColor = RGBColor(90, 90, 90);

/// Draws `chart` into `area`: the mesh, markers, series, notes and legend, in that order.
pub(super) fn draw_chart<DB: DrawingBackend>(
    chart: &Chart,
    area: &DrawingArea<DB, Shift>,
) -> DrawResult<DB> {
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

    draw_markers(&mut ctx, chart, x, y)?;
    let mut has_data = false;
    for s in &chart.series {
        has_data |= draw_series(&mut ctx, s, x, y)?;
    }
    draw_notes(&ctx, chart, has_data, x, y)?;
    draw_legend(&mut ctx, chart)
}

/// The chart's vertical markers inside the x range, labels stacked down from the top.
fn draw_markers<DB: DrawingBackend>(
    ctx: &mut Ctx<'_, DB>,
    chart: &Chart,
    x: Span,
    y: Span,
) -> DrawResult<DB> {
    let mut marker_row = 0;
    for m in &chart.markers {
        if !(m.x.is_finite() && (x.0..=x.1).contains(&m.x)) {
            continue;
        }
        ctx.draw_series(DashedLineSeries::new(
            [(m.x, y.0), (m.x, y.1)],
            6,
            4,
            GREY.stroke_width(1),
        ))?;
        if !m.label.is_empty() {
            ctx.draw_series(std::iter::once(
                EmptyElement::at((m.x, y.1))
                    + Text::new(
                        m.label.clone(),
                        (4, 4 + 16 * marker_row),
                        (FAMILY, 13).into_font().color(&GREY),
                    ),
            ))?;
            marker_row += 1;
        }
    }
    Ok(())
}

/// One series (lines, points and interval bars); whether anything of it landed in the panel.
fn draw_series<DB: DrawingBackend>(
    ctx: &mut Ctx<'_, DB>,
    s: &Series,
    x: Span,
    y: Span,
) -> Result<bool, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut has_data = false;
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
        draw_intervals(ctx, s, c, x, y)?;
    }
    Ok(has_data)
}

/// Interval bars, clipped to the panel, with caps 1 % of the x span wide.
fn draw_intervals<DB: DrawingBackend>(
    ctx: &mut Ctx<'_, DB>,
    s: &Series,
    c: RGBColor,
    x: Span,
    y: Span,
) -> DrawResult<DB> {
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
    Ok(())
}

/// "no data" in an empty panel, and the count of points that could not be drawn.
fn draw_notes<DB: DrawingBackend>(
    ctx: &Ctx<'_, DB>,
    chart: &Chart,
    has_data: bool,
    x: Span,
    y: Span,
) -> DrawResult<DB> {
    let plot = ctx.plotting_area();
    let note = (FAMILY, 14).into_font().color(&GREY);
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
                .color(&GREY)
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
    Ok(())
}

/// The legend of the named series, in the chart's corner (none when hidden or nothing is named).
fn draw_legend<'a, DB: DrawingBackend + 'a>(
    ctx: &mut Ctx<'a, DB>,
    chart: &Chart,
) -> DrawResult<DB> {
    if chart.legend == Legend::Hidden || chart.series.iter().all(|s| s.name.is_empty()) {
        return Ok(());
    }
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
        .draw()
}
