//! Input quoted in messages, bounded: a cell, key or name is cut after [`MAX_CHARS`] characters
//! (a 10 MB cell would otherwise make a 10 MB error, twice over with its source) and a number
//! read from input is printed in a form of bounded length (`1e308`, not 309 digits). Every
//! error or warning that quotes what a file or argument holds goes through here.

use std::fmt;

/// Characters of quoted input kept in a message.
pub const MAX_CHARS: usize = 40;

/// `text` cut after [`MAX_CHARS`] characters, with `…` where it was cut.
pub fn cut(text: &str) -> String {
    cut_to(text, MAX_CHARS)
}

/// `text` cut after `max_chars` characters, with `…` where it was cut (for a message that may
/// quote input, such as a parser's).
pub fn cut_to(text: &str, max_chars: usize) -> String {
    match text.char_indices().nth(max_chars) {
        Some((i, _)) => format!("{}…", &text[..i]),
        None => text.to_owned(),
    }
}

/// A number read from input (`f64` or `f32`), for a message: as `{}` prints it (shortest
/// round-trip digits) while that stays short, in exponent form (`1e308`, `2.5e-9`) beyond.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Number<T>(pub T);

impl<T: Copy + Into<f64> + fmt::Display + fmt::LowerExp> fmt::Display for Number<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x: f64 = self.0.into();
        if x == 0.0 || !x.is_finite() || (1e-5..1e15).contains(&x.abs()) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_text_is_cut_at_a_character() {
        assert_eq!(cut("short"), "short");
        let long = "é".repeat(10_000_000);
        let shown = cut(&long);
        assert_eq!(shown.chars().count(), MAX_CHARS + 1);
        assert!(shown.ends_with("é…"), "{shown}");
        assert_eq!(cut(&"x".repeat(MAX_CHARS)), "x".repeat(MAX_CHARS));
    }

    #[test]
    fn numbers_stay_short_at_any_magnitude() {
        let shown = |x: f64| Number(x).to_string();
        assert_eq!(shown(1e308), "1e308");
        assert_eq!(shown(-1.7976931348623157e308), "-1.7976931348623157e308");
        assert_eq!(shown(5e-324), "5e-324");
        assert_eq!(shown(2.5e-9), "2.5e-9");
        assert_eq!(shown(0.1), "0.1");
        assert_eq!(shown(-3.25), "-3.25");
        assert_eq!(shown(123_456.5), "123456.5");
        assert_eq!(shown(0.0), "0");
        assert_eq!(shown(f64::INFINITY), "inf");
        assert_eq!(shown(f64::NAN), "NaN");
        assert_eq!(Number(0.606_060_6_f32).to_string(), "0.6060606");
        assert_eq!(Number(f32::MAX).to_string(), "3.4028235e38");
        for x in [1e15, 1e16, 1e300, f64::MAX, f64::MIN_POSITIVE, 1e-6] {
            assert!(shown(x).len() <= 24, "{x:e}: {}", shown(x));
        }
    }
}
