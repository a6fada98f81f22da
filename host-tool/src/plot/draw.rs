//! Drawing one chart into a panel with plotters: mesh, markers, series, notes and legend.

use super::axes::{clip_segment, drawable, inside, polylines, ranges, tick_label, Span};
use super::chart::{Chart, Legend, Series, SeriesStyle, Shape};
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

/// A series' glyph at `at`: a short line, the series' mark, or both, centred there. It draws
/// each point of a points series (at a data coordinate) and each legend sample (at a pixel).
/// (plotters' composed elements cannot be boxed for the legend unless the backend is
/// `'static`, which buffer backends are not.)
#[derive(Debug, Clone, Copy)]
struct Glyph<C> {
    at: C,
    colour: RGBColor,
    style: SeriesStyle,
    shape: Shape,
}

impl<'b, C> PointCollection<'b, C> for &'b Glyph<C> {
    type Point = &'b C;
    type IntoIter = std::iter::Once<&'b C>;
    fn point_iter(self) -> Self::IntoIter {
        std::iter::once(&self.at)
    }
}

impl<C, DB: DrawingBackend> Drawable<DB> for Glyph<C> {
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
            let half = SAMPLE_HALF_PX;
            backend.draw_path([(x - half, y), (x + half, y)], &self.colour.stroke_width(2))?;
        }
        if matches!(self.style, SeriesStyle::Points | SeriesStyle::LineAndPoints) {
            draw_mark(backend, (x, y), self.shape, self.colour)?;
        }
        Ok(())
    }
}

/// Radius of a point's mark [px].
const MARK_PX: i32 = 4;
/// Half the length of a line series' legend sample [px].
const SAMPLE_HALF_PX: i32 = 10;

/// One point's mark at `at`, in backend pixels.
fn draw_mark<DB: DrawingBackend>(
    backend: &mut DB,
    (x, y): BackendCoord,
    shape: Shape,
    colour: RGBColor,
) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
    let r = MARK_PX;
    match shape {
        Shape::Dot => backend.draw_circle((x, y), r as u32, &colour.filled(), true),
        Shape::Ring => backend.draw_circle((x, y), r as u32, &colour.stroke_width(2), false),
        Shape::Square => backend.draw_rect((x - r, y - r), (x + r, y + r), &colour.filled(), true),
        Shape::Triangle => backend.fill_polygon(
            [(x, y - r - 1), (x - r - 1, y + r), (x + r + 1, y + r)],
            &colour.filled(),
        ),
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
    // The margin and title as plotters' ChartBuilder lays them out, drawn here once, so the
    // chart can be laid out twice: where the legend covers nothing, or above its strip.
    let mut area = area.margin(12, 12, 12, 12);
    if !chart.title.is_empty() {
        area = area.titled(&chart.title, (FAMILY, 20))?;
    }
    let entries = legend_entries(chart, &area)?;
    let mut ctx = build(&area, x, y)?;
    let mut place = legend_place(chart, &ctx, &entries, x, y);
    let mut strip = None;
    if place == Place::Below {
        let (w, h) = area.dim_in_pixel();
        let strip_h = strip_rows(&entries, w) * LEGEND_ROW_PX + 2 * LEGEND_PAD_PX;
        if strip_h + 200 < h {
            let (top, bottom) = area.split_vertically(h - strip_h);
            ctx = build(&top, x, y)?;
            strip = Some(bottom);
        } else {
            place = Place::Corner(corner_rect(&ctx, &entries, Legend::UpperRight));
        }
    }
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
    match (place, strip) {
        (Place::Corner(rect), _) => draw_legend_box(&area, &entries, rect),
        (Place::Below, Some(strip)) => draw_legend_strip(&strip, &entries),
        _ => Ok(()),
    }
}

/// The plotting context on `area`, with the label areas of every panel.
fn build<'a, DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    x: Span,
    y: Span,
) -> Result<Ctx<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    ChartBuilder::on(area)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(x.0..x.1, y.0..y.1)
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
                        marker_label_offset(marker_row),
                        (FAMILY, 13).into_font().color(&GREY),
                    ),
            ))?;
            marker_row += 1;
        }
    }
    Ok(())
}

/// Where the `row`th marker label goes from its line's top: beside the line, rows stacked down.
fn marker_label_offset(row: usize) -> (i32, i32) {
    (4, 4 + 16 * row as i32)
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
        let (shape, style) = (s.shape, SeriesStyle::Points);
        ctx.draw_series(dots.into_iter().map(|at| Glyph {
            at,
            colour: c,
            style,
            shape,
        }))?;
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

/// Height of a legend row and the padding around the rows [px].
const LEGEND_ROW_PX: u32 = 20;
const LEGEND_PAD_PX: u32 = 6;
/// Width of an entry's sample and the gap before its text [px].
const LEGEND_GLYPH_PX: u32 = 30;

/// One legend entry: its sample and its text's width.
struct Entry {
    name: String,
    glyph: Glyph<BackendCoord>,
    text_w: u32,
}

/// The legend's font.
fn legend_font() -> TextStyle<'static> {
    (FAMILY, 14).into_font().color(&BLACK)
}

/// The named series' entries (none when the legend is hidden or nothing is named).
fn legend_entries<DB: DrawingBackend>(
    chart: &Chart,
    area: &DrawingArea<DB, Shift>,
) -> Result<Vec<Entry>, DrawingAreaErrorKind<DB::ErrorType>> {
    if chart.legend == Legend::Hidden {
        return Ok(Vec::new());
    }
    let font = legend_font();
    chart
        .series
        .iter()
        .filter(|s| !s.name.is_empty())
        .map(|s| {
            Ok(Entry {
                name: s.name.clone(),
                glyph: Glyph {
                    at: (0, 0),
                    colour: colour(s.colour),
                    style: s.style,
                    shape: s.shape,
                },
                text_w: area.estimate_text_size(&s.name, &font)?.0,
            })
        })
        .collect()
}

/// Where the legend is drawn: a box at a pixel rectangle, a strip below the chart, or nowhere.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Place {
    Corner((i32, i32, i32, i32)),
    Below,
    Nowhere,
}

/// The legend box's rectangle (x0, y0, x1, y1) in `corner` of the plot, 8 px in.
fn corner_rect<DB: DrawingBackend>(
    ctx: &Ctx<'_, DB>,
    entries: &[Entry],
    corner: Legend,
) -> (i32, i32, i32, i32) {
    let (xs, ys) = ctx.plotting_area().get_pixel_range();
    let text_w = entries.iter().map(|e| e.text_w).max().unwrap_or(0);
    let w = (2 * LEGEND_PAD_PX + LEGEND_GLYPH_PX + text_w) as i32;
    let h = (2 * LEGEND_PAD_PX + LEGEND_ROW_PX * entries.len() as u32) as i32;
    let left = matches!(corner, Legend::UpperLeft | Legend::LowerLeft);
    let top = matches!(corner, Legend::UpperLeft | Legend::UpperRight);
    let x0 = if left { xs.start + 8 } else { xs.end - 8 - w };
    let y0 = if top { ys.start + 8 } else { ys.end - 8 - h };
    (x0, y0, x0 + w, y0 + h)
}

/// Where the legend goes: the chart's corner if it names one; for [`Legend::Auto`] the first
/// corner where the box covers nothing drawn, else the strip below.
fn legend_place<DB: DrawingBackend>(
    chart: &Chart,
    ctx: &Ctx<'_, DB>,
    entries: &[Entry],
    x: Span,
    y: Span,
) -> Place {
    if entries.is_empty() {
        return Place::Nowhere;
    }
    let corners = [
        Legend::UpperRight,
        Legend::UpperLeft,
        Legend::LowerRight,
        Legend::LowerLeft,
    ];
    match chart.legend {
        Legend::Hidden => Place::Nowhere,
        Legend::Below => Place::Below,
        Legend::Auto => {
            let drawn = drawn_pixels(chart, ctx, x, y);
            corners
                .into_iter()
                .map(|corner| corner_rect(ctx, entries, corner))
                .find(|&(x0, y0, x1, y1)| {
                    // 3 px of air around the box.
                    !drawn.iter().any(|&(px, py)| {
                        (x0 - 3..=x1 + 3).contains(&px) && (y0 - 3..=y1 + 3).contains(&py)
                    })
                })
                .map_or(Place::Below, Place::Corner)
        }
        corner => Place::Corner(corner_rect(ctx, entries, corner)),
    }
}

/// Every pixel the chart draws something at, near enough: each point's mark (its corners),
/// lines and interval bars every 3 px, and each marker label's box.
fn drawn_pixels<DB: DrawingBackend>(
    chart: &Chart,
    ctx: &Ctx<'_, DB>,
    x: Span,
    y: Span,
) -> Vec<(i32, i32)> {
    let px = |p: (f64, f64)| ctx.backend_coord(&p);
    let mut out = Vec::new();
    let segment = |a: (f64, f64), b: (f64, f64), out: &mut Vec<(i32, i32)>| {
        let (a, b) = (px(a), px(b));
        let steps = ((b.0 - a.0).abs().max((b.1 - a.1).abs()) / 3).max(1);
        for k in 0..=steps {
            out.push((a.0 + (b.0 - a.0) * k / steps, a.1 + (b.1 - a.1) * k / steps));
        }
    };
    for s in &chart.series {
        if matches!(s.style, SeriesStyle::Line | SeriesStyle::LineAndPoints) {
            let (runs, isolated) = polylines(&s.points, x, y);
            for run in runs {
                for pair in run.windows(2) {
                    segment(pair[0], pair[1], &mut out);
                }
            }
            out.extend(isolated.into_iter().map(px));
        }
        if matches!(s.style, SeriesStyle::Points | SeriesStyle::LineAndPoints) {
            for &p in s.points.iter().filter(|&&p| drawable(p) && inside(p, x, y)) {
                let (cx, cy) = px(p);
                let r = MARK_PX + 1;
                out.extend([
                    (cx - r, cy - r),
                    (cx + r, cy - r),
                    (cx - r, cy + r),
                    (cx + r, cy + r),
                    (cx, cy),
                ]);
            }
            for (&(bx, _), &(lo, hi)) in s.points.iter().zip(&s.intervals) {
                if drawable((bx, lo)) && drawable((bx, hi)) {
                    if let Some((a, b)) = clip_segment((bx, lo), (bx, hi), x, y) {
                        segment(a, b, &mut out);
                    }
                }
            }
        }
    }
    // Marker labels where `draw_markers` puts them, about 8 px a character.
    let top = ctx.plotting_area().get_pixel_range().1.start;
    let labelled = chart
        .markers
        .iter()
        .filter(|m| m.x.is_finite() && (x.0..=x.1).contains(&m.x) && !m.label.is_empty());
    for (row, m) in labelled.enumerate() {
        let (dx0, dy) = marker_label_offset(row);
        let (mx, y0) = (px((m.x, y.1)).0 + dx0, top + dy);
        let w = 8 * m.label.chars().count() as i32;
        // From the marker's line to the label's end.
        for dx in (-dx0..=w).step_by(3) {
            out.extend([(mx + dx, y0), (mx + dx, y0 + 14)]);
        }
    }
    out
}

/// The legend as a box at `rect`: white behind, a grey border, one entry a row.
fn draw_legend_box<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[Entry],
    (x0, y0, x1, y1): (i32, i32, i32, i32),
) -> DrawResult<DB> {
    let (bx, by) = area.get_base_pixel();
    let local = |(x, y): (i32, i32)| (x - bx, y - by);
    area.draw(&Rectangle::new(
        [local((x0, y0)), local((x1, y1))],
        WHITE.mix(0.85).filled(),
    ))?;
    area.draw(&Rectangle::new(
        [local((x0, y0)), local((x1, y1))],
        RGBColor(160, 160, 160).stroke_width(1),
    ))?;
    for (k, e) in entries.iter().enumerate() {
        let row_y = y0 + (LEGEND_PAD_PX + LEGEND_ROW_PX * k as u32 + LEGEND_ROW_PX / 2) as i32;
        draw_entry(area, e, local((x0 + LEGEND_PAD_PX as i32, row_y)))?;
    }
    Ok(())
}

/// How many rows the entries take side by side in a strip `width` px wide.
fn strip_rows(entries: &[Entry], width: u32) -> u32 {
    strip_layout(entries, width)
        .last()
        .map_or(0, |&(_, row)| row + 1)
}

/// Each entry's (x offset, row) in a strip `width` px wide, filled row by row.
fn strip_layout(entries: &[Entry], width: u32) -> Vec<(u32, u32)> {
    let (mut x, mut row) = (LEGEND_PAD_PX, 0);
    let mut out = Vec::with_capacity(entries.len());
    for e in entries {
        let w = LEGEND_GLYPH_PX + e.text_w + 18;
        if x > LEGEND_PAD_PX && x + w > width {
            (x, row) = (LEGEND_PAD_PX, row + 1);
        }
        out.push((x, row));
        x += w;
    }
    out
}

/// The legend as a strip below the chart (`strip`): entries side by side, wrapping.
fn draw_legend_strip<DB: DrawingBackend>(
    strip: &DrawingArea<DB, Shift>,
    entries: &[Entry],
) -> DrawResult<DB> {
    let (w, _) = strip.dim_in_pixel();
    // Indented like the plot (its y label area), so the strip reads as the chart's.
    let indent = 72;
    for (e, (x, row)) in entries
        .iter()
        .zip(strip_layout(entries, w.saturating_sub(indent)))
    {
        let at = (
            (indent + x) as i32,
            (LEGEND_PAD_PX + LEGEND_ROW_PX * row + LEGEND_ROW_PX / 2) as i32,
        );
        draw_entry(strip, e, at)?;
    }
    Ok(())
}

/// One entry, its sample's left end at `at` (the row's middle), in `area`'s pixels.
fn draw_entry<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    e: &Entry,
    at: (i32, i32),
) -> DrawResult<DB> {
    let centre = (at.0 + SAMPLE_HALF_PX, at.1);
    area.draw(&Glyph {
        at: centre,
        ..e.glyph
    })?;
    area.draw(&Text::new(
        e.name.clone(),
        (at.0 + LEGEND_GLYPH_PX as i32, at.1),
        legend_font().pos(Pos::new(HPos::Left, VPos::Center)),
    ))
}
