//! Small comma-separated tables whose header names the columns: the diagnosis' per-turn
//! summaries ([`crate::diagnose::summary`]) and path tables ([`crate::diagnose::path_table`]).
//! Both skip blank lines and `#` comments, tell their kind from the header, and report a bad row
//! with the same error, each inside its own.

use std::io::BufRead;
use std::path::Path;

/// Splits `text` into (line number, trimmed line) without blanks and `#` comments; a leading
/// byte-order mark is dropped.
pub fn content_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim().trim_start_matches('\u{feff}')))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

/// The header of the `.csv` file at `path`: its first line, trimmed, that is neither blank nor
/// a `#` comment, among the first 64. `None` for another extension or an unreadable file (what
/// is not a table here is left for the run-log readers to judge).
pub fn csv_header(path: &Path) -> Option<String> {
    if !path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"))
    {
        return None;
    }
    let file = std::fs::File::open(path).ok()?;
    std::io::BufReader::new(file)
        .lines()
        .take(64)
        .map_while(Result::ok)
        .map(|l| l.trim().trim_start_matches('\u{feff}').to_owned())
        .find(|l| !l.is_empty() && !l.starts_with('#'))
}

/// A row of a header-named table that does not parse.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RowError {
    /// A row with a different number of cells than the header.
    #[error("line {line}: row has {found} cells, the header has {expected}")]
    CellCount {
        /// The line.
        line: usize,
        /// Cells found.
        found: usize,
        /// Cells in the header.
        expected: usize,
    },
    /// A cell that is not a valid value for its column.
    #[error("line {line}, column {column} ({name}): `{value}` {problem}")]
    Cell {
        /// The line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// The column's name.
        name: &'static str,
        /// The cell as written (cut after 40 characters: [`crate::excerpt::cut`]).
        value: String,
        /// What is wrong.
        problem: &'static str,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn content_lines_skip_blanks_comments_and_the_byte_order_mark() {
        let text = "\u{feff}# note\n\n  a,b  \n# c\n1,2\n\t\n";
        assert_eq!(
            content_lines(text).collect::<Vec<_>>(),
            [(3, "a,b"), (5, "1,2")]
        );
    }

    #[test]
    fn the_header_is_the_first_content_line_of_a_csv() {
        let dir = std::env::temp_dir().join(format!("csv-table-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let csv = dir.join("t.CSV");
        std::fs::write(&csv, "\u{feff}\n# comment\n radius_m,avg_power_w \n1,2\n").expect("write");
        assert_eq!(csv_header(&csv).as_deref(), Some("radius_m,avg_power_w"));
        let txt = dir.join("t.txt");
        std::fs::write(&txt, "radius_m,avg_power_w\n").expect("write");
        assert_eq!(csv_header(&txt), None);
        assert_eq!(csv_header(&dir.join("missing.csv")), None);
        std::fs::remove_dir_all(&dir).expect("clean up");
    }
}
