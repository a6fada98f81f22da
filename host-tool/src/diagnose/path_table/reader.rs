//! The path table's reader (its format: the parent module's doc).

use crate::csv_table::{content_lines, csv_header, RowError};
use crate::excerpt::{self, Number};
use crate::file_error::{read_bytes_and_parse, FileError};
use serde::Serialize;
use std::path::Path;

/// The header of a path table; the last column is optional.
pub const PATH_TABLE_COLUMNS: [&str; 7] = [
    "start_deg",
    "end_deg",
    "distance_m",
    "r_lo_over_r_prime",
    "r_hi_over_r_prime",
    "delta_e_pct",
    "p_value",
];

/// One row of a path table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PathRow {
    /// Line in the file (1-based).
    pub line: usize,
    /// θ_A [deg].
    pub start_deg: f64,
    /// θ_C [deg].
    pub end_deg: f64,
    /// d [m].
    pub distance_m: f64,
    /// Lower bound of R/R'.
    pub r_lo_over_r_prime: f64,
    /// Upper bound of R/R'.
    pub r_hi_over_r_prime: f64,
    /// Measured mean ΔE [%].
    pub delta_e_pct: f64,
    /// p of the two-tailed t-test, if given.
    pub p_value: Option<f64>,
}

/// What is wrong with a path table.
#[derive(Debug, thiserror::Error)]
pub enum PathTableError {
    /// Not UTF-8.
    #[error("not UTF-8 text")]
    NotUtf8,
    /// The header is not the path table's.
    #[error("line {line}: header `{found}` is not `{}[,p_value]`", PATH_TABLE_COLUMNS[..6].join(","))]
    Header {
        /// The header's line (0: no header).
        line: usize,
        /// As written (cut after 40 characters).
        found: String,
    },
    /// A row that does not parse.
    #[error(transparent)]
    Row(#[from] RowError),
    /// A slice whose lower bound is not below its upper bound.
    #[error("line {line}: slice {} – {} of R/R' is empty (r_lo_over_r_prime must be < r_hi_over_r_prime)", Number(*.lo), Number(*.hi))]
    EmptySlice {
        /// The line.
        line: usize,
        /// Lower bound.
        lo: f64,
        /// Upper bound.
        hi: f64,
    },
    /// A path the model cannot plan (headings outside Eq 50, a slice too wide for the poses).
    #[error("line {line}: {why}")]
    Path {
        /// The line.
        line: usize,
        /// Why.
        why: String,
    },
    /// A header and no row.
    #[error("no rows after the header")]
    NoRows,
    /// Fewer than three slices: nothing to hold out against.
    #[error("{0} slices: leave-one-slice-out needs at least 3")]
    TooFewRows(usize),
}

/// Whether `header`'s cells are the path table's six or seven columns, in order.
fn is_header(header: &str) -> bool {
    let cells: Vec<&str> = header.split(',').map(str::trim).collect();
    (cells.len() == 6 || cells.len() == 7)
        && cells.iter().zip(PATH_TABLE_COLUMNS).all(|(c, n)| *c == n)
}

/// Parses a path table's text (see the module doc).
pub fn parse_path_table(text: &str) -> Result<Vec<PathRow>, PathTableError> {
    let mut lines = content_lines(text);
    let (header_line, header) = lines.next().ok_or(PathTableError::Header {
        line: 0,
        found: String::new(),
    })?;
    if !is_header(header) {
        return Err(PathTableError::Header {
            line: header_line,
            found: excerpt::cut(header),
        });
    }
    let columns = header.split(',').count();
    let mut rows = Vec::new();
    for (line, text) in lines {
        let cells: Vec<&str> = text.split(',').map(str::trim).collect();
        if cells.len() != columns {
            return Err(RowError::CellCount {
                line,
                found: cells.len(),
                expected: columns,
            }
            .into());
        }
        let bad = |k: usize, problem: &'static str| {
            PathTableError::from(RowError::Cell {
                line,
                column: k + 1,
                name: PATH_TABLE_COLUMNS[k],
                value: excerpt::cut(cells[k]),
                problem,
            })
        };
        let number = |k: usize| match cells[k].parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(bad(k, "is not a finite number")),
        };
        let [start_deg, end_deg, distance_m, lo, hi, delta_e_pct] = [0, 1, 2, 3, 4, 5].map(number);
        let (lo, hi) = (lo?, hi?);
        if lo < 0.0 {
            return Err(bad(3, "must be ≥ 0"));
        }
        if lo >= hi {
            return Err(PathTableError::EmptySlice { line, lo, hi });
        }
        let distance_m = distance_m?;
        if distance_m <= 0.0 {
            return Err(bad(2, "must be > 0"));
        }
        let p_value = match cells.get(6) {
            None | Some(&"") => None,
            Some(_) => match number(6)? {
                p if p > 0.0 && p <= 1.0 => Some(p),
                _ => return Err(bad(6, "must be in (0, 1]")),
            },
        };
        rows.push(PathRow {
            line,
            start_deg: start_deg?,
            end_deg: end_deg?,
            distance_m,
            r_lo_over_r_prime: lo,
            r_hi_over_r_prime: hi,
            delta_e_pct: delta_e_pct?,
            p_value,
        });
    }
    if rows.is_empty() {
        return Err(PathTableError::NoRows);
    }
    Ok(rows)
}

/// Reads and parses the path table at `path`; an error names the file.
pub fn load_path_table(path: &Path) -> Result<Vec<PathRow>, FileError<PathTableError>> {
    read_bytes_and_parse(path, |bytes| {
        parse_path_table(std::str::from_utf8(bytes).map_err(|_| PathTableError::NotUtf8)?)
    })
}

/// Whether `path` is a path table: a `.csv` whose first content line is its header.
pub fn is_path_table_file(path: &Path) -> bool {
    csv_header(path).is_some_and(|h| h.starts_with("start_deg,") && h.contains("delta_e_pct"))
}
