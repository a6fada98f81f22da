//! Long report lines folded to a terminal's width at spaces, so a detail reads without a
//! horizontal scroll; the JSON and Markdown keep each line whole.

/// The width a folded line stays within [characters], indent included.
pub const WIDTH: usize = 100;

/// `text` after `first` (the first line's indent), folded at spaces to [`WIDTH`], every further
/// line after `rest`. A word longer than the width stays whole on its own line.
pub fn wrapped(text: &str, first: &str, rest: &str) -> String {
    let mut out = String::from(first);
    let mut line_len = first.chars().count();
    let mut line_empty = true;
    for word in text.split(' ').filter(|w| !w.is_empty()) {
        let len = word.chars().count();
        if !line_empty && line_len + 1 + len > WIDTH {
            out.push('\n');
            out.push_str(rest);
            line_len = rest.chars().count();
            line_empty = true;
        }
        if !line_empty {
            out.push(' ');
            line_len += 1;
        }
        out.push_str(word);
        line_len += len;
        line_empty = false;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_stay_within_the_width_and_keep_every_word_in_order() {
        let text = "the quick brown fox jumps over the lazy dog ".repeat(12);
        let folded = wrapped(&text, "  ", "    ");
        assert!(folded.lines().count() > 1);
        assert!(
            folded.lines().all(|l| l.chars().count() <= WIDTH),
            "{folded}"
        );
        assert!(
            folded.starts_with("  the ") && folded.lines().skip(1).all(|l| l.starts_with("    "))
        );
        let words: Vec<&str> = folded.split_whitespace().collect();
        assert_eq!(words, text.split_whitespace().collect::<Vec<_>>());
    }

    #[test]
    fn a_short_line_is_unchanged_and_a_long_word_stays_whole() {
        assert_eq!(wrapped("R′ = 0.55 m", "  ", "    "), "  R′ = 0.55 m");
        let long = "x".repeat(2 * WIDTH);
        assert_eq!(
            wrapped(&format!("a {long} b"), "", "  "),
            format!("a\n  {long}\n  b")
        );
    }
}
