//! Long report lines folded to a terminal's width at spaces, so a detail reads without a
//! horizontal scroll; the JSON and Markdown keep each line whole.

/// The width a folded line stays within [characters], indent included.
pub const WIDTH: usize = 100;

/// `text` after `first` (the first line's indent), folded at spaces to [`WIDTH`], every further
/// line after `rest`. A number keeps its unit (`0.04 W`, `25 %`); a word longer than the width
/// stays whole on its own line.
pub fn wrapped(text: &str, first: &str, rest: &str) -> String {
    let mut out = String::from(first);
    let mut line_len = first.chars().count();
    let mut line_empty = true;
    for word in words(text) {
        let word = word.as_str();
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

/// A report line folded to [`WIDTH`]: its leading spaces are its indent, and its continuation
/// lines are indented two more.
pub fn folded(line: &str) -> String {
    let text = line.trim_start_matches(' ');
    let indent = &line[..line.len() - text.len()];
    wrapped(text, indent, &format!("{indent}  "))
}

/// The words of `text`, a unit joined to the number before it, and spaces beyond the first
/// kept with the word before them (a padded column stays padded).
fn words(text: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for word in text.split(' ') {
        if word.is_empty() {
            if let Some(previous) = out.last_mut() {
                previous.push(' ');
            }
            continue;
        }
        let core = word.trim_end_matches([',', ';', ':', ')', '.']);
        let is_unit = !core.is_empty()
            && core.chars().count() <= 3
            && !core.starts_with(|c: char| c.is_ascii_digit() || c == '(' || c == '-');
        match out.last_mut() {
            Some(previous) if is_unit && previous.ends_with(|c: char| c.is_ascii_digit()) => {
                previous.push(' ');
                previous.push_str(word);
            }
            _ => out.push(word.to_owned()),
        }
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
    fn a_padded_column_stays_padded() {
        assert_eq!(
            wrapped("inner-drag     present: t = 2", "  ", "    "),
            "  inner-drag     present: t = 2"
        );
    }

    #[test]
    fn a_number_keeps_its_unit() {
        let text = format!("{} repeat σ 0.04 W, n 3", "x".repeat(WIDTH - 20));
        let folded = wrapped(&text, "", "  ");
        assert!(folded.contains("0.04 W,"), "{folded}");
        assert!(
            folded.lines().all(|l| l.chars().count() <= WIDTH),
            "{folded}"
        );
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
