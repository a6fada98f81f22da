//! What can be wrong with one row of a comma-separated table whose header names the columns:
//! the diagnosis' per-turn summaries ([`crate::diagnose::summary`]) and path tables
//! ([`crate::diagnose::path_table`]) share it, each inside its own error.

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
        /// The cell as written.
        value: String,
        /// What is wrong.
        problem: &'static str,
    },
}
