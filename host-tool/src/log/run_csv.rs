//! The run CSV: the interchange format for runs recorded on other rigs (MATLAB, pandas, a ROS bag
//! export) and written by this tool.
//!
//! # Format
//!
//! - The first non-blank row is the header. Required columns, in any order:
//!   `t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,cmd_left_mps,cmd_right_mps`;
//!   optional: `yaw_rad,pitch_deg,x_m,y_m`. Other columns are ignored; a known column named twice
//!   is an error. Names are case-sensitive.
//! - Units and signs (the format's definition): time in s; bus voltage in V; current in A,
//!   positive when the motor driver draws from the battery; `cmd_*_mps` the commanded linear speed
//!   of each side in m/s, positive forward; yaw in rad, counter-clockwise (seen from above)
//!   positive; pitch in degrees, nose-up positive; `x_m,y_m` the tracked point (a prism, an RTK
//!   antenna, a motion-capture marker) in a fixed right-handed frame, metres, seen from above
//!   (the yaw's frame: counter-clockwise from +x). A tracker reports at its own rate: rows
//!   between its fixes leave both cells empty. `x_m` and `y_m` come together (header and row).
//!   A position cell may read `NaN` (a total station that lost the prism): it is a dropout,
//!   read as an empty cell.
//! - Every row has exactly as many cells as the header. Required cells hold a finite number
//!   (anything Rust's `f64` parser takes: `1`, `-0.5`, `1e-3`); optional cells may be empty
//!   (→ `None`). NaN and infinities are rejected.
//! - Bus voltages and currents lie within the range the file is read with ([`RigRange`]): by
//!   default any physical reading (bus 0 to 1000 V, current ±1000 A: the file may come from
//!   any rig), or the board's (`--rig-range board`), or a range the user states.
//! - `t_s` strictly increases from row to row: equal timestamps are an error (the per-sample
//!   energy integration and the segmentation need dt > 0; a repeated time is a rig's bug).
//! - Comma-separated, RFC 4180 quoting (`"1.5"` is fine), LF or CRLF line ends, an optional UTF-8
//!   byte-order mark, spaces and tabs around cells ignored, empty lines skipped (anywhere, so
//!   trailing blank lines are fine). A quoted cell may span lines. There are no comment lines: a
//!   `#` row is a row with a bad number.
//!
//! Errors name the 1-based line (where the row starts) and column (the cell's position in the
//! row, with the column's name) and the reason, e.g.
//! `line 7, column 3 (left_current_a): "abc" is not a number`.

use super::{write_atomically, AtomicWriteError, Existing};
use crate::excerpt::{cut, Number};
use model_core::Sides;
use std::fmt;
use std::io::{self, BufRead, Write};
use std::path::{Path, PathBuf};

/// One row of a run CSV.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSample {
    /// Time [s]; strictly increasing within a run.
    pub t_s: f64,
    /// Bus voltage at each motor driver [V].
    pub bus_v: Sides<f64>,
    /// Current into each motor driver [A], positive when drawn from the battery.
    pub current_a: Sides<f64>,
    /// Commanded linear speed of each side [m/s], positive forward.
    pub cmd_mps: Sides<f64>,
    /// Yaw [rad], counter-clockwise positive, if measured.
    pub yaw_rad: Option<f64>,
    /// Pitch [deg], nose-up positive, if measured.
    pub pitch_deg: Option<f64>,
    /// Tracked point's x in the fixed frame [m], if a fix landed on this sample.
    pub x_m: Option<f64>,
    /// Tracked point's y in the fixed frame [m], if a fix landed on this sample.
    pub y_m: Option<f64>,
}

impl RunSample {
    /// A sample of the required cells only: no yaw, pitch or tracked position.
    pub fn new(t_s: f64, bus_v: Sides<f64>, current_a: Sides<f64>, cmd_mps: Sides<f64>) -> Self {
        Self {
            t_s,
            bus_v,
            current_a,
            cmd_mps,
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        }
    }

    /// The required cells' values in column order: t, bus V and current per side, commanded
    /// speed per side.
    pub fn required_values(&self) -> [f64; 7] {
        [
            self.t_s,
            self.bus_v.left,
            self.bus_v.right,
            self.current_a.left,
            self.current_a.right,
            self.cmd_mps.left,
            self.cmd_mps.right,
        ]
    }

    /// The tracked point (x, y) [m] when both coordinates are present and finite.
    pub fn position_m(&self) -> Option<(f64, f64)> {
        match (self.x_m, self.y_m) {
            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => Some((x, y)),
            _ => None,
        }
    }
}

/// A column the run CSV defines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Column {
    /// `t_s`
    TimeS,
    /// `left_bus_v`
    LeftBusV,
    /// `left_current_a`
    LeftCurrentA,
    /// `right_bus_v`
    RightBusV,
    /// `right_current_a`
    RightCurrentA,
    /// `cmd_left_mps`
    CmdLeftMps,
    /// `cmd_right_mps`
    CmdRightMps,
    /// `yaw_rad` (optional)
    YawRad,
    /// `pitch_deg` (optional)
    PitchDeg,
    /// `x_m` (optional, with `y_m`)
    XM,
    /// `y_m` (optional, with `x_m`)
    YM,
}

impl Column {
    /// The columns every run CSV has, in the order this tool writes them.
    pub const REQUIRED: [Column; 7] = [
        Column::TimeS,
        Column::LeftBusV,
        Column::LeftCurrentA,
        Column::RightBusV,
        Column::RightCurrentA,
        Column::CmdLeftMps,
        Column::CmdRightMps,
    ];
    /// The optional columns, in the order this tool writes them (after the required ones).
    pub const OPTIONAL: [Column; 4] = [Column::YawRad, Column::PitchDeg, Column::XM, Column::YM];
    /// Optional columns whose `NaN` cells read as empty (a tracker's dropout).
    pub const NAN_IS_EMPTY: [Column; 2] = [Column::XM, Column::YM];
    /// All columns in the order this tool writes them: the required, then the optional.
    pub const ALL: [Column; 11] = {
        let mut all = [Column::TimeS; 11];
        let mut i = 0;
        while i < all.len() {
            all[i] = if i < Self::REQUIRED.len() {
                Self::REQUIRED[i]
            } else {
                Self::OPTIONAL[i - Self::REQUIRED.len()]
            };
            i += 1;
        }
        all
    };

    /// The column's header name.
    pub const fn name(self) -> &'static str {
        match self {
            Column::TimeS => "t_s",
            Column::LeftBusV => "left_bus_v",
            Column::LeftCurrentA => "left_current_a",
            Column::RightBusV => "right_bus_v",
            Column::RightCurrentA => "right_current_a",
            Column::CmdLeftMps => "cmd_left_mps",
            Column::CmdRightMps => "cmd_right_mps",
            Column::YawRad => "yaw_rad",
            Column::PitchDeg => "pitch_deg",
            Column::XM => "x_m",
            Column::YM => "y_m",
        }
    }

    /// The column with this header name.
    pub fn from_name(name: &str) -> Option<Column> {
        Column::ALL.into_iter().find(|c| c.name() == name)
    }

    const fn index(self) -> usize {
        self as usize
    }
}

impl RunSample {
    /// The first value outside `range` or not finite, with its column.
    pub fn out_of_range(&self, range: RigRange) -> Option<(Column, f64)> {
        let values = [
            (Column::TimeS, self.t_s),
            (Column::LeftBusV, self.bus_v.left),
            (Column::LeftCurrentA, self.current_a.left),
            (Column::RightBusV, self.bus_v.right),
            (Column::RightCurrentA, self.current_a.right),
            (Column::CmdLeftMps, self.cmd_mps.left),
            (Column::CmdRightMps, self.cmd_mps.right),
        ];
        let optional = [
            (Column::YawRad, self.yaw_rad),
            (Column::PitchDeg, self.pitch_deg),
            (Column::XM, self.x_m),
            (Column::YM, self.y_m),
        ];
        values
            .into_iter()
            .chain(optional.into_iter().filter_map(|(c, v)| Some((c, v?))))
            .find(|&(column, v)| !range.admits(column, v))
    }
}

impl fmt::Display for Column {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a cell is not a valid value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CellProblem {
    /// The cell is empty in a required column.
    Empty,
    /// The cell does not parse as a number.
    NotANumber,
    /// The number is NaN or infinite.
    NotFinite,
    /// `t_s` is not greater than the previous row's.
    TimeNotIncreasing,
    /// The number is outside the range the file is read with.
    OutOfRange(RigRange),
}

/// What is wrong with a run CSV or a commands CSV (reading), or with a row handed to a writer
/// (then the line is the one it would have been written at).
#[derive(Debug, thiserror::Error)]
pub enum RunCsvError {
    /// Reading or writing the underlying stream failed.
    #[error("{0}")]
    Io(#[from] io::Error),
    /// The input has no header row (it is empty or blank).
    #[error("line 1: no header row (the file is empty)")]
    NoHeader,
    /// A required column is absent from the header.
    #[error("line {line}: missing required column `{column}` in the header")]
    MissingColumn {
        /// The header's line.
        line: u64,
        /// The absent column.
        column: Column,
    },
    /// A known column appears twice in the header.
    #[error(
        "line {line}: column `{column}` appears twice in the header (columns {first} and {second})"
    )]
    DuplicateColumn {
        /// The header's line.
        line: u64,
        /// The repeated column.
        column: Column,
        /// 1-based position of its first occurrence.
        first: usize,
        /// 1-based position of its second occurrence.
        second: usize,
    },
    /// One of a pair of columns that only come together (`x_m`, `y_m`) is in the header alone.
    #[error("line {line}: column `{present}` needs column `{missing}` in the header too")]
    UnpairedColumn {
        /// The header's line.
        line: u64,
        /// The column present.
        present: Column,
        /// Its partner, absent.
        missing: Column,
    },
    /// A row has a different number of cells than the header.
    #[error("line {line}: row has {found} cells, the header has {expected}")]
    CellCount {
        /// The row's line.
        line: u64,
        /// Cells in the row.
        found: usize,
        /// Cells in the header.
        expected: usize,
    },
    /// A cell holds no valid value.
    #[error("line {line}, column {column} ({name}): {}", describe(*.problem, .value, *.previous_t_s))]
    Cell {
        /// The row's line.
        line: u64,
        /// 1-based position of the cell in its row.
        column: usize,
        /// The cell's column.
        name: Column,
        /// The cell's text (cut after 40 characters).
        value: String,
        /// What is wrong.
        problem: CellProblem,
        /// For [`CellProblem::TimeNotIncreasing`], the previous row's time.
        previous_t_s: Option<f64>,
    },
    /// The text is not well-formed CSV (quoting).
    #[error("line {line}, column {column}: {problem}")]
    Syntax {
        /// The line where the problem is.
        line: u64,
        /// 1-based cell position in the row.
        column: usize,
        /// What is wrong.
        problem: &'static str,
    },
}

fn describe(problem: CellProblem, value: &str, previous_t_s: Option<f64>) -> String {
    match problem {
        CellProblem::Empty => "empty cell in a required column".into(),
        CellProblem::NotANumber => format!("{value:?} is not a number"),
        CellProblem::NotFinite => format!("{value:?} is not a finite number"),
        CellProblem::OutOfRange(range) => format!("{value} is outside {range}"),
        CellProblem::TimeNotIncreasing => match previous_t_s {
            Some(prev) => format!(
                "time {value} is not after the previous row's {}",
                Number(prev)
            ),
            None => format!("time {value} is not increasing"),
        },
    }
}

/// A run CSV file that could not be read or written; names the file.
#[derive(Debug, thiserror::Error)]
#[error("{}: {source}", path.display())]
pub struct RunCsvFileError {
    /// The file.
    pub path: PathBuf,
    /// What went wrong.
    #[source]
    pub source: RunCsvError,
}

impl RunCsvFileError {
    fn new(path: &Path, source: impl Into<RunCsvError>) -> Self {
        Self {
            path: path.to_owned(),
            source: source.into(),
        }
    }
}

/// Reads a whole run CSV file, any physical reading (a cut last row is left out; see
/// [`read_run_csv_salvaging`] to learn about it, or to read it within another range).
pub fn read_run_csv(path: &Path) -> Result<Vec<RunSample>, RunCsvFileError> {
    read_run_csv_salvaging(path, false, RigRange::default()).map(|(samples, _)| samples)
}

/// Reads a whole run CSV file, its readings within `range`, and the rows left out: a cut last
/// row always, any damaged row with `salvage` (see [`RunCsvReader::salvaging`]).
pub fn read_run_csv_salvaging(
    path: &Path,
    salvage: bool,
    range: RigRange,
) -> Result<(Vec<RunSample>, Vec<DroppedRow>), RunCsvFileError> {
    // This tool's own files, valid throughout: read and parsed in parallel, block by block.
    if let Some(samples) = read_own_run_csv(path, range)? {
        return Ok((samples, Vec::new()));
    }
    let bytes = std::fs::read(path).map_err(|e| RunCsvFileError::new(path, e))?;
    let mut reader = RunCsvReader::new(&bytes[..])
        .map_err(|e| RunCsvFileError::new(path, e))?
        .salvaging(salvage)
        .within(range);
    let samples = reader
        .by_ref()
        .collect::<Result<_, _>>()
        .map_err(|e| RunCsvFileError::new(path, e))?;
    Ok((samples, reader.dropped))
}

/// The samples of the run CSV at `path` if it is one of this tool's own (its header and layout,
/// valid throughout, readings within `range`), read once and parsed on every core
/// ([`visit_own_run_csv`]); `Ok(None)` for any other file, which [`RunCsvReader`] reads and
/// judges (it words the errors, drops a cut last row).
pub fn read_own_run_csv(
    path: &Path,
    range: RigRange,
) -> Result<Option<Vec<RunSample>>, RunCsvFileError> {
    let mut samples = Vec::new();
    let own = visit_own_run_csv(path, range, &mut |rows| samples.extend_from_slice(rows))?;
    Ok(own.then_some(samples))
}

/// Hands `visit` the samples of the run CSV at `path`, in file order, a stretch at a time as
/// they are read (on the core that parsed them, while they are in its cache), and returns
/// true if the file is one of this tool's own (its header and layout, valid throughout,
/// readings within `range`): read once, parsed on every core, in memory of a few stretches
/// whatever its length. False for any other file, which [`RunCsvReader`] reads and judges;
/// `visit` may have had some of its samples by then (not all).
pub fn visit_own_run_csv(
    path: &Path,
    range: RigRange,
    visit: &mut (dyn FnMut(&[RunSample]) + Send),
) -> Result<bool, RunCsvFileError> {
    fast::read_file(path, fast::BLOCK_BYTES, range, visit)
        .map_err(|e| RunCsvFileError::new(path, e))
}

/// Writes `samples` to a run CSV at `path`, all or nothing (see [`write_atomically`]): if any
/// sample is refused or any write fails, `path` is not created (or keeps its previous content).
/// Returns the number of rows written.
pub fn write_run_csv_atomically<'a>(
    path: &Path,
    existing: Existing,
    samples: impl IntoIterator<Item = &'a RunSample>,
) -> Result<u64, RunCsvFileError> {
    try_write_run_csv_atomically(path, existing, samples.into_iter().map(|s| Ok(*s)))
}

/// Like [`write_run_csv_atomically`] for samples that may fail on the way (e.g. a reader): the
/// first `Err` aborts the write, nothing is left at `path`, and the error is returned as is
/// (so it names the input file, not the output).
pub fn try_write_run_csv_atomically(
    path: &Path,
    existing: Existing,
    samples: impl IntoIterator<Item = Result<RunSample, RunCsvFileError>>,
) -> Result<u64, RunCsvFileError> {
    let written = write_atomically(path, existing, |out| {
        let mut writer = RunCsvWriter::new(out).map_err(|e| RunCsvFileError::new(path, e))?;
        for sample in samples {
            writer
                .write(&sample?)
                .map_err(|e| RunCsvFileError::new(path, e))?;
        }
        let rows = writer.rows();
        writer
            .into_inner()
            .map_err(|e| RunCsvFileError::new(path, e))?;
        Ok(rows)
    });
    written.map_err(|e| match e {
        AtomicWriteError::Io { path, source } => RunCsvFileError::new(&path, source),
        AtomicWriteError::Content { source, .. } => source,
    })
}

/// Rewrites the run CSV `input` as a canonical run CSV at `output` (this tool's column order,
/// extra columns dropped, shortest round-trip numbers). Nothing is created at `output` unless all
/// of `input` is valid. Returns the number of rows.
pub fn normalize_run_csv(
    input: &Path,
    output: &Path,
    existing: Existing,
) -> Result<u64, RunCsvFileError> {
    let file = std::fs::File::open(input).map_err(|e| RunCsvFileError::new(input, e))?;
    let reader =
        RunCsvReader::new(io::BufReader::new(file)).map_err(|e| RunCsvFileError::new(input, e))?;
    try_write_run_csv_atomically(
        output,
        existing,
        reader.map(|r| r.map_err(|e| RunCsvFileError::new(input, e))),
    )
}

mod fast;
mod range;
mod read;
mod records;
mod write;

pub use range::{RigRange, BUS_V_MAX, CURRENT_A_MAX, PHYSICAL_BUS_V_MAX, PHYSICAL_CURRENT_A_MAX};

pub(crate) use read::Table;
pub use read::{DroppedRow, RunCsvReader};
use records::Records;
pub use write::RunCsvWriter;
pub(crate) use write::{write_header, write_row};
#[cfg(test)]
mod tests;
