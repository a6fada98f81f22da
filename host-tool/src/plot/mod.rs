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

use crate::log::AtomicWriteError;
use std::io;
use std::path::{Path, PathBuf};

mod axes;
mod chart;
mod draw;
mod render;

pub use chart::*;
pub use render::*;

/// The font every figure's text is drawn with (see `assets/fonts/README.md` for its licence).
const FONT_TTF: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

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

#[cfg(test)]
mod tests;
