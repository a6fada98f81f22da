//! [`Glyphs`]: a bitmap backend wrapper that rasterises text with each glyph at its own place.
//!
//! plotters 0.3.7's ab_glyph text drawing puts every glyph's outline at the pen position
//! without its left side bearing (the outline's pixel bounds are dropped), so letters with a
//! wide bearing sit a pixel left of where they belong: "inn er", "ou ter", "undefined:" with
//! the colon on the d. Its layout (width, kerning) is right, so the anchor arithmetic below is
//! plotters' own; only the per-glyph placement differs. SVG output is text, not pixels, and
//! does not need this.

use ab_glyph::{point, Font, FontRef, ScaleFont};
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
};
use std::sync::OnceLock;

/// The embedded font, parsed once (`None`: rejected, reported as a font error when drawing).
fn font() -> Option<&'static FontRef<'static>> {
    static FONT: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(super::FONT_TTF).ok())
        .as_ref()
}

/// Error when the embedded font does not parse (a build defect).
#[derive(Debug, thiserror::Error)]
#[error("the embedded font could not be loaded")]
struct FontRejected;

/// A drawing backend whose text is rasterised glyph by glyph at its true position; everything
/// else goes to the wrapped backend unchanged.
pub(super) struct Glyphs<B>(pub(super) B);

impl<B: DrawingBackend> DrawingBackend for Glyphs<B> {
    type ErrorType = B::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.draw_path(path, style)
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.fill_polygon(vert, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.blit_bitmap(pos, size, src)
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let font = font().ok_or_else(|| DrawingErrorKind::FontError(Box::new(FontRejected)))?;
        // Anchoring as plotters' default `draw_text`, on its own layout box.
        let ((min_x, min_y), (max_x, max_y)) = style
            .layout_box(text)
            .map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
        let (width, height) = (max_x - min_x, max_y - min_y);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        } - min_x;
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        } - min_y;
        let trans = style.transform();
        let (w, h) = self.get_size();
        let size = style.size() as f32;
        let scaled = font.as_scaled(size);
        let baseline = (size / 2.0).round() as i32;
        let mut caret = 0f32;
        let mut prev = None;
        let mut failed = None;
        for c in text.chars() {
            let id = scaled.glyph_id(c);
            if let Some(p) = prev {
                caret += scaled.kern(p, id);
            }
            prev = Some(id);
            let glyph = id.with_scale_and_position(size, point(caret, 0.0));
            caret += scaled.h_advance(id);
            let Some(outline) = scaled.outline_glyph(glyph) else {
                continue; // a space
            };
            let bounds = outline.px_bounds();
            // The glyph's own left edge (bearing included), and its top on one baseline for the
            // whole line, where plotters puts it (half the size down); plotters truncates each
            // glyph's top towards zero, which lifts a full stop above the digits ("0·2").
            let (gx, gy) = (bounds.min.x as i32, baseline + bounds.min.y as i32);
            outline.draw(|x, y, coverage| {
                if failed.is_some() {
                    return;
                }
                let (x, y) = trans.transform(gx + x as i32 + dx, gy + y as i32 + dy);
                let (x, y) = (pos.0 + x, pos.1 + y);
                if x >= 0 && x < w as i32 && y >= 0 && y < h as i32 {
                    if let Err(e) = self.0.draw_pixel((x, y), color.mix(f64::from(coverage))) {
                        failed = Some(e);
                    }
                }
            });
            if let Some(e) = failed {
                return Err(e);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::Glyphs;
    use plotters::backend::RGBPixel;
    use plotters::prelude::*;

    /// Columns of `text` drawn at 14 px that hold ink, as runs [start, end).
    fn ink_runs(text: &str, fixed: bool) -> Vec<(usize, usize)> {
        super::super::register_font().expect("font");
        let (w, h) = (120u32, 30u32);
        let mut rgb = vec![255u8; (w * h * 3) as usize];
        {
            let bitmap = BitMapBackend::<RGBPixel>::with_buffer_and_format(&mut rgb, (w, h))
                .expect("buffer");
            let style = (super::super::FAMILY, 14).into_font().color(&BLACK);
            if fixed {
                let root = Glyphs(bitmap).into_drawing_area();
                root.draw_text(text, &style, (4, 4)).expect("drawn");
                root.present().expect("present");
            } else {
                let root = bitmap.into_drawing_area();
                root.draw_text(text, &style, (4, 4)).expect("drawn");
                root.present().expect("present");
            }
        }
        let inked: Vec<bool> = (0..w as usize)
            .map(|x| (0..h as usize).any(|y| rgb[(y * w as usize + x) * 3] < 140))
            .collect();
        let mut runs = Vec::new();
        let mut start = None;
        for (x, &ink) in inked.iter().chain([&false]).enumerate() {
            match (ink, start) {
                (true, None) => start = Some(x),
                (false, Some(s)) => {
                    runs.push((s, x));
                    start = None;
                }
                _ => {}
            }
        }
        runs
    }

    #[test]
    fn letters_keep_their_bearings_no_inn_er() {
        // plotters' own drawing gives [(4, 5), (7, 13), (14, 20), (23, 33)]: "n" and "e" three
        // columns apart, "e" and "r" merged ("inn er").
        let runs = ink_runs("inner", true);
        assert_eq!(runs.len(), 5, "one ink run per letter: {runs:?}");
        let gaps: Vec<usize> = runs.windows(2).map(|w| w[1].0 - w[0].1).collect();
        let (lo, hi) = (gaps.iter().min(), gaps.iter().max());
        assert!(
            lo.zip(hi).is_some_and(|(lo, hi)| *lo >= 1 && hi - lo <= 1),
            "even spacing: {runs:?}"
        );
        // Anchoring is plotters' own: the text starts where plotters starts it, ± the bearing.
        let plain = ink_runs("inner", false);
        assert!(runs[0].0.abs_diff(plain[0].0) <= 1, "{runs:?} {plain:?}");
    }
}
