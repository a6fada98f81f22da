//! Rendering a figure to PNG or SVG bytes and writing it atomically.

use super::axes::ranges;
use super::chart::{Chart, Figure};
use super::draw::draw_chart;
use super::glyphs::Glyphs;
use super::{Format, PlotError, FAMILY, FONT_TTF};
use crate::log::{write_atomically, Existing};
use plotters::backend::RGBPixel;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::io::Write;
use std::path::Path;
use std::sync::OnceLock;

/// Writes `chart` to `path` as PNG or SVG (by extension), atomically.
pub fn render(chart: &Chart, path: &Path) -> Result<(), PlotError> {
    render_figure(&Figure::single(chart.clone()), path)
}

/// Writes `figure` to `path` as PNG or SVG (by extension), atomically: on any error the previous
/// file, if any, is left as it was.
pub fn render_figure(figure: &Figure, path: &Path) -> Result<(), PlotError> {
    let format = Format::from_path(path)?;
    let bytes = render_bytes(figure, format)?;
    write_atomically(path, Existing::Replace, |w| w.write_all(&bytes))?;
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
                let root = Glyphs(backend).into_drawing_area();
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
pub(super) fn register_font() -> Result<(), PlotError> {
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

pub(super) type DrawResult<DB> =
    Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

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
