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

use super::{write_atomically, AtomicWriteError};
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
    /// The tracked point (x, y) [m] when both coordinates are present and finite.
    pub fn position_m(&self) -> Option<(f64, f64)> {
        match (self.x_m, self.y_m) {
            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => Some((x, y)),
            _ => None,
        }
    }
}

/// Highest bus voltage the INA226 reads: its bus input's full scale, 32 768 × 1.25 mV [V].
pub const BUS_V_MAX: f64 = 40.96;
/// Largest current the board measures: the INA226's full scale at its calibration (5 mΩ shunt,
/// 0.5 mA current LSB), 32 768 × 0.5 mA [A]. A reading beyond it is a unit or scale error.
pub const CURRENT_A_MAX: f64 = 16.384;

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
    /// All columns in the order this tool writes them.
    pub const ALL: [Column; 11] = [
        Column::TimeS,
        Column::LeftBusV,
        Column::LeftCurrentA,
        Column::RightBusV,
        Column::RightCurrentA,
        Column::CmdLeftMps,
        Column::CmdRightMps,
        Column::YawRad,
        Column::PitchDeg,
        Column::XM,
        Column::YM,
    ];

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

    /// The values the board can measure in this column (`None`: any finite number): bus
    /// voltages within the INA226's bus input range, currents within its full scale.
    pub fn range(self) -> Option<(f64, f64)> {
        match self {
            Column::LeftBusV | Column::RightBusV => Some((0.0, BUS_V_MAX)),
            Column::LeftCurrentA | Column::RightCurrentA => Some((-CURRENT_A_MAX, CURRENT_A_MAX)),
            Column::TimeS
            | Column::CmdLeftMps
            | Column::CmdRightMps
            | Column::YawRad
            | Column::PitchDeg
            | Column::XM
            | Column::YM => None,
        }
    }
}

impl RunSample {
    /// The first value outside what the board can measure ([`Column::range`]) or not finite,
    /// with its column.
    pub fn out_of_range(&self) -> Option<(Column, f64)> {
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
            .find(|&(column, v)| {
                !v.is_finite() || column.range().is_some_and(|(lo, hi)| v < lo || v > hi)
            })
    }
}

impl fmt::Display for Column {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a cell is not a valid value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellProblem {
    /// The cell is empty in a required column.
    Empty,
    /// The cell does not parse as a number.
    NotANumber,
    /// The number is NaN or infinite.
    NotFinite,
    /// `t_s` is not greater than the previous row's.
    TimeNotIncreasing,
    /// The number is outside what the board can measure ([`Column::range`]).
    OutOfRange,
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
        CellProblem::OutOfRange => format!(
            "{value} is outside the board's measuring range (INA226 at the board's calibration: \
             bus 0 to {BUS_V_MAX} V, current ±{CURRENT_A_MAX} A)"
        ),
        CellProblem::TimeNotIncreasing => match previous_t_s {
            Some(prev) => format!("time {value} is not after the previous row's {prev}"),
            None => format!("time {value} is not increasing"),
        },
    }
}

fn cut(text: &str) -> String {
    const MAX: usize = 40;
    match text.char_indices().nth(MAX) {
        Some((i, _)) => format!("{}…", &text[..i]),
        None => text.to_owned(),
    }
}

/// The table layer shared by the run CSV and the commands CSV (same cell rules, same column
/// names): locates the known columns in the header, checks cell counts, parses numbers and
/// keeps `t_s` strictly increasing.
#[derive(Debug)]
pub(crate) struct Table<R> {
    records: Records<R>,
    /// Cell position of each column (`None`: an optional column that is absent).
    positions: [Option<usize>; Column::ALL.len()],
    cells: usize,
    previous_t_s: Option<f64>,
}

impl<R: BufRead> Table<R> {
    /// Reads the header row; every column of `required` must be present.
    pub(crate) fn new(input: R, required: &[Column]) -> Result<Self, RunCsvError> {
        let mut records = Records::new(input);
        let Some(line) = records.next_record()? else {
            return Err(RunCsvError::NoHeader);
        };
        let mut positions = [None; Column::ALL.len()];
        for i in 0..records.len() {
            let Some(column) = records.cell_str(i).and_then(Column::from_name) else {
                continue;
            };
            if let Some(first) = positions[column.index()] {
                return Err(RunCsvError::DuplicateColumn {
                    line,
                    column,
                    first: first + 1,
                    second: i + 1,
                });
            }
            positions[column.index()] = Some(i);
        }
        if let Some(&column) = required.iter().find(|c| positions[c.index()].is_none()) {
            return Err(RunCsvError::MissingColumn { line, column });
        }
        for (present, missing) in [(Column::XM, Column::YM), (Column::YM, Column::XM)] {
            if positions[present.index()].is_some() && positions[missing.index()].is_none() {
                return Err(RunCsvError::UnpairedColumn {
                    line,
                    present,
                    missing,
                });
            }
        }
        Ok(Self {
            cells: records.len(),
            records,
            positions,
            previous_t_s: None,
        })
    }

    /// Whether the input ended inside the last line read (see [`Records::unterminated`]).
    pub(crate) fn at_cut_end(&self) -> bool {
        self.records.unterminated
    }

    /// Whether the header has `column`.
    pub(crate) fn has(&self, column: Column) -> bool {
        self.positions[column.index()].is_some()
    }

    /// Reads the next row and checks its cell count; returns its line (`None` at the end).
    pub(crate) fn next_row(&mut self) -> Result<Option<u64>, RunCsvError> {
        let Some(line) = self.records.next_record()? else {
            return Ok(None);
        };
        if self.records.len() != self.cells {
            return Err(RunCsvError::CellCount {
                line,
                found: self.records.len(),
                expected: self.cells,
            });
        }
        Ok(Some(line))
    }

    /// The current row's value of `column`: `None` if the column is absent or (for an optional
    /// column) the cell is empty.
    pub(crate) fn value(&self, line: u64, column: Column) -> Result<Option<f64>, RunCsvError> {
        let Some(i) = self.positions[column.index()] else {
            return Ok(None);
        };
        let bytes = self.records.cell(i);
        let err = |problem| RunCsvError::Cell {
            line,
            column: i + 1,
            name: column,
            value: cut(&String::from_utf8_lossy(bytes)),
            problem,
            previous_t_s: None,
        };
        if bytes.is_empty() {
            return if Column::OPTIONAL.contains(&column) {
                Ok(None)
            } else {
                Err(err(CellProblem::Empty))
            };
        }
        let value: f64 = self
            .records
            .cell_str(i)
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| err(CellProblem::NotANumber))?;
        if value.is_nan() && Column::NAN_IS_EMPTY.contains(&column) {
            Ok(None)
        } else if !value.is_finite() {
            Err(err(CellProblem::NotFinite))
        } else if column
            .range()
            .is_some_and(|(lo, hi)| value < lo || value > hi)
        {
            Err(err(CellProblem::OutOfRange))
        } else {
            Ok(Some(value))
        }
    }

    /// The current row's value of a required column.
    pub(crate) fn required(&self, line: u64, column: Column) -> Result<f64, RunCsvError> {
        self.value(line, column).map(|v| v.unwrap_or_default())
    }

    /// Checks that `t_s` (the current row's time) is after the previous row's, and remembers it.
    pub(crate) fn accept_time(&mut self, line: u64, t_s: f64) -> Result<(), RunCsvError> {
        if let Some(prev) = self.previous_t_s {
            if t_s <= prev {
                let i = self.positions[Column::TimeS.index()].unwrap_or_default();
                return Err(RunCsvError::Cell {
                    line,
                    column: i + 1,
                    name: Column::TimeS,
                    value: cut(&String::from_utf8_lossy(self.records.cell(i))),
                    problem: CellProblem::TimeNotIncreasing,
                    previous_t_s: Some(prev),
                });
            }
        }
        self.previous_t_s = Some(t_s);
        Ok(())
    }
}

/// Streaming reader of a run CSV: an iterator of samples. Stops after the first error.
#[derive(Debug)]
pub struct RunCsvReader<R> {
    table: Table<R>,
    done: bool,
    salvage: bool,
    dropped: Vec<DroppedRow>,
}

/// A row the reader left out (see [`RunCsvReader::salvaging`]).
#[derive(Debug, Clone, PartialEq)]
pub struct DroppedRow {
    /// Its line.
    pub line: u64,
    /// Why, as the error would have said it.
    pub reason: String,
    /// Whether it was the file's last line, cut before its end (a kill or a full disk while
    /// writing): dropped even without salvage.
    pub cut: bool,
}

impl RunCsvError {
    /// The line of a problem in one row (`None` for I/O and header problems).
    fn row_line(&self) -> Option<u64> {
        match self {
            RunCsvError::CellCount { line, .. }
            | RunCsvError::Cell { line, .. }
            | RunCsvError::Syntax { line, .. } => Some(*line),
            RunCsvError::Io(_)
            | RunCsvError::NoHeader
            | RunCsvError::MissingColumn { .. }
            | RunCsvError::DuplicateColumn { .. }
            | RunCsvError::UnpairedColumn { .. } => None,
        }
    }
}

impl<R: BufRead> RunCsvReader<R> {
    /// Reads the header row from `input` (any buffered reader: a `BufReader<File>`, `&[u8]`, ...).
    pub fn new(input: R) -> Result<Self, RunCsvError> {
        Ok(Self {
            table: Table::new(input, &Column::REQUIRED)?,
            done: false,
            salvage: false,
            dropped: Vec::new(),
        })
    }

    /// With `salvage`, a damaged row anywhere is left out (and listed in [`Self::dropped`])
    /// instead of ending the read with an error. Without it, only a cut last row is.
    pub fn salvaging(mut self, salvage: bool) -> Self {
        self.salvage = salvage;
        self
    }

    /// The rows left out so far.
    pub fn dropped(&self) -> &[DroppedRow] {
        &self.dropped
    }

    /// Whether the file has a `yaw_rad` column.
    pub fn has_yaw(&self) -> bool {
        self.table.has(Column::YawRad)
    }

    /// Whether the file has a `pitch_deg` column.
    pub fn has_pitch(&self) -> bool {
        self.table.has(Column::PitchDeg)
    }

    /// Whether the file has the `x_m,y_m` columns of a tracked point.
    pub fn has_position(&self) -> bool {
        self.table.has(Column::XM)
    }

    fn next_sample(&mut self) -> Result<Option<RunSample>, RunCsvError> {
        loop {
            let error = match self.next_row_sample() {
                Ok(sample) => return Ok(sample),
                Err(e) => e,
            };
            let Some(line) = error.row_line() else {
                return Err(error);
            };
            // The input ends inside this row: a row cut by a kill or a full disk.
            let cut = self.table.at_cut_end();
            if !cut && !self.salvage {
                return Err(error);
            }
            self.dropped.push(DroppedRow {
                line,
                reason: error.to_string(),
                cut,
            });
            if cut {
                return Ok(None);
            }
        }
    }

    fn next_row_sample(&mut self) -> Result<Option<RunSample>, RunCsvError> {
        let Some(line) = self.table.next_row()? else {
            return Ok(None);
        };
        let t = &self.table;
        let required = |column| t.required(line, column);
        let t_s = required(Column::TimeS)?;
        let sample = RunSample {
            t_s,
            bus_v: Sides::new(required(Column::LeftBusV)?, required(Column::RightBusV)?),
            current_a: Sides::new(
                required(Column::LeftCurrentA)?,
                required(Column::RightCurrentA)?,
            ),
            cmd_mps: Sides::new(
                required(Column::CmdLeftMps)?,
                required(Column::CmdRightMps)?,
            ),
            yaw_rad: t.value(line, Column::YawRad)?,
            pitch_deg: t.value(line, Column::PitchDeg)?,
            x_m: t.value(line, Column::XM)?,
            y_m: t.value(line, Column::YM)?,
        };
        self.table.accept_time(line, t_s)?;
        Ok(Some(sample))
    }
}

impl<R: BufRead> Iterator for RunCsvReader<R> {
    type Item = Result<RunSample, RunCsvError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        match self.next_sample() {
            Ok(Some(sample)) => Some(Ok(sample)),
            Ok(None) => {
                self.done = true;
                None
            }
            Err(e) => {
                self.done = true;
                Some(Err(e))
            }
        }
    }
}

/// The CSV layer: splits the input into records of cells, tracking physical line numbers.
///
/// A line without a quote (every row this tool writes) is split where it lies: its cells are
/// spans of the line, checked for UTF-8 once per line. Lines with quotes take the general path
/// (unquoting into `data`, possibly over several lines). Both give the same cells.
#[derive(Debug)]
struct Records<R> {
    input: R,
    /// Physical lines read so far (= the 1-based number of the line in `line`).
    line_no: u64,
    /// The current physical line without its LF / CRLF.
    line: Vec<u8>,
    /// The unquoted cells of a record with quotes, concatenated.
    data: Vec<u8>,
    /// The current record's text when it is UTF-8 (the line, or `data`, moved here).
    text: String,
    /// Which buffer the current record's cells are spans of.
    cells_in: CellsIn,
    /// Where each cell of the current record starts and ends.
    spans: Vec<(usize, usize)>,
    /// Whether the last physical line read had no line end: the input ends inside it (a row
    /// cut by a kill or a full disk, or a file without a final newline).
    unterminated: bool,
}

/// Where the current record's cells are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CellsIn {
    /// `text` (UTF-8, checked once for the whole record).
    Text,
    /// `line` (no quotes, not UTF-8).
    Line,
    /// `data` (quoted, not UTF-8).
    Data,
}

const UTF8_BOM: &[u8] = b"\xEF\xBB\xBF";

fn is_blank(b: u8) -> bool {
    b == b' ' || b == b'\t'
}

/// `start..end` of `bytes` without leading and trailing blanks.
fn trim_blanks(bytes: &[u8], mut start: usize, mut end: usize) -> (usize, usize) {
    while start < end && is_blank(bytes[start]) {
        start += 1;
    }
    while end > start && is_blank(bytes[end - 1]) {
        end -= 1;
    }
    (start, end)
}

impl<R: BufRead> Records<R> {
    fn new(input: R) -> Self {
        Self {
            input,
            line_no: 0,
            line: Vec::new(),
            data: Vec::new(),
            text: String::new(),
            cells_in: CellsIn::Text,
            spans: Vec::new(),
            unterminated: false,
        }
    }

    /// Cells in the current record.
    fn len(&self) -> usize {
        self.spans.len()
    }

    fn text(&self) -> &[u8] {
        match self.cells_in {
            CellsIn::Text => self.text.as_bytes(),
            CellsIn::Line => &self.line,
            CellsIn::Data => &self.data,
        }
    }

    /// Cell `i` of the current record (empty if there is no such cell).
    fn cell(&self, i: usize) -> &[u8] {
        self.spans
            .get(i)
            .and_then(|&(start, end)| self.text().get(start..end))
            .unwrap_or_default()
    }

    /// Cell `i` as text; `None` if it is not UTF-8.
    fn cell_str(&self, i: usize) -> Option<&str> {
        match self.cells_in {
            // Cells start and end at ASCII delimiters or blanks: always char boundaries.
            CellsIn::Text => {
                let &(start, end) = self.spans.get(i)?;
                self.text.get(start..end)
            }
            CellsIn::Line | CellsIn::Data => std::str::from_utf8(self.cell(i)).ok(),
        }
    }

    /// Moves the current record's bytes (`line` or `data`) into `text` if they are UTF-8.
    fn settle(&mut self, quoted: bool) {
        let buffer = if quoted {
            &mut self.data
        } else {
            &mut self.line
        };
        let bytes = std::mem::take(buffer);
        match String::from_utf8(bytes) {
            Ok(text) => {
                // The old text's allocation becomes the emptied buffer.
                *buffer = std::mem::replace(&mut self.text, text).into_bytes();
                self.cells_in = CellsIn::Text;
            }
            Err(e) => {
                *buffer = e.into_bytes();
                self.cells_in = if quoted { CellsIn::Data } else { CellsIn::Line };
            }
        }
    }

    /// Reads the next physical line into `line`; false at the end of the input.
    fn read_line(&mut self) -> io::Result<bool> {
        self.line.clear();
        if self.input.read_until(b'\n', &mut self.line)? == 0 {
            return Ok(false);
        }
        self.line_no += 1;
        self.unterminated = self.line.last() != Some(&b'\n');
        if self.line.last() == Some(&b'\n') {
            self.line.pop();
            if self.line.last() == Some(&b'\r') {
                self.line.pop();
            }
        }
        if self.line_no == 1 && self.line.starts_with(UTF8_BOM) {
            self.line.drain(..UTF8_BOM.len());
        }
        Ok(true)
    }

    /// Reads the next record (skipping blank lines); returns the line it starts on.
    fn next_record(&mut self) -> Result<Option<u64>, RunCsvError> {
        loop {
            if !self.read_line()? {
                return Ok(None);
            }
            if !self.line.is_empty() {
                break;
            }
        }
        let start_line = self.line_no;
        self.spans.clear();
        if memchr::memchr(b'"', &self.line).is_none() {
            let mut start = 0;
            for i in memchr::memchr_iter(b',', &self.line) {
                self.spans.push(trim_blanks(&self.line, start, i));
                start = i + 1;
            }
            self.spans
                .push(trim_blanks(&self.line, start, self.line.len()));
            self.settle(false);
            return Ok(Some(start_line));
        }
        self.data.clear();
        let mut pos = 0;
        loop {
            while self.line.get(pos).copied().is_some_and(is_blank) {
                pos += 1;
            }
            let column = self.spans.len() + 1;
            let cell_start = self.data.len();
            if self.line.get(pos) == Some(&b'"') {
                // Quoted cell: `""` is a quote; it may span lines.
                let open_line = self.line_no;
                pos += 1;
                loop {
                    let rest = self.line.get(pos..).unwrap_or_default();
                    match rest.iter().position(|&b| b == b'"') {
                        Some(q) => {
                            self.data.extend_from_slice(&rest[..q]);
                            if rest.get(q + 1) == Some(&b'"') {
                                self.data.push(b'"');
                                pos += q + 2;
                            } else {
                                pos += q + 1;
                                break;
                            }
                        }
                        None => {
                            self.data.extend_from_slice(rest);
                            self.data.push(b'\n');
                            if !self.read_line()? {
                                return Err(RunCsvError::Syntax {
                                    line: open_line,
                                    column,
                                    problem: "quoted cell is never closed",
                                });
                            }
                            pos = 0;
                        }
                    }
                }
                while self.line.get(pos).copied().is_some_and(is_blank) {
                    pos += 1;
                }
                self.spans.push((cell_start, self.data.len()));
                match self.line.get(pos) {
                    None => break,
                    Some(b',') => pos += 1,
                    Some(_) => {
                        return Err(RunCsvError::Syntax {
                            line: self.line_no,
                            column,
                            problem: "text after the closing quote of a cell",
                        })
                    }
                }
            } else {
                let rest = self.line.get(pos..).unwrap_or_default();
                let end = rest.iter().position(|&b| b == b',');
                let (_, cell_end) = trim_blanks(rest, 0, end.unwrap_or(rest.len()));
                self.data.extend_from_slice(&rest[..cell_end]);
                self.spans.push((cell_start, self.data.len()));
                match end {
                    None => break,
                    Some(e) => pos += e + 1,
                }
            }
        }
        self.settle(true);
        Ok(Some(start_line))
    }
}

/// Writes a run CSV: the header with all eleven columns, then one row per sample; `None` is an
/// empty cell. Numbers are written with `f64`'s shortest round-trip representation, so reading
/// the file back gives the same values bit for bit.
#[derive(Debug)]
pub struct RunCsvWriter<W: Write> {
    out: W,
    rows: u64,
    previous_t_s: Option<f64>,
}

impl<W: Write> RunCsvWriter<W> {
    /// Writes the header row.
    pub fn new(mut out: W) -> Result<Self, RunCsvError> {
        write_header(&mut out, &Column::ALL)?;
        Ok(Self {
            out,
            rows: 0,
            previous_t_s: None,
        })
    }

    /// Writes one row. A sample the reader would reject (a non-finite value, a time not after the
    /// previous row's) is refused with the error the reader would give, and nothing is written.
    pub fn write(&mut self, sample: &RunSample) -> Result<(), RunCsvError> {
        let values = [
            Some(sample.t_s),
            Some(sample.bus_v.left),
            Some(sample.current_a.left),
            Some(sample.bus_v.right),
            Some(sample.current_a.right),
            Some(sample.cmd_mps.left),
            Some(sample.cmd_mps.right),
            sample.yaw_rad,
            sample.pitch_deg,
            sample.x_m,
            sample.y_m,
        ];
        write_row(
            &mut self.out,
            self.rows + 2,
            &mut self.previous_t_s,
            &Column::ALL,
            &values,
        )?;
        self.rows += 1;
        Ok(())
    }

    /// The underlying writer (e.g. to take a `Vec<u8>`'s rows out between flushes).
    pub fn get_mut(&mut self) -> &mut W {
        &mut self.out
    }

    /// Rows written so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Flushes and returns the underlying writer.
    pub fn into_inner(mut self) -> Result<W, RunCsvError> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Writes one row of `columns` (`t_s` among them) at `line`, refusing what the reader would
/// reject: a non-finite value, a time not after `previous_t_s` (updated on success). `None` is
/// an empty cell. Shared by the run CSV and the commands CSV writers.
pub(crate) fn write_row<W: Write>(
    out: &mut W,
    line: u64,
    previous_t_s: &mut Option<f64>,
    columns: &[Column],
    values: &[Option<f64>],
) -> Result<(), RunCsvError> {
    let mut t_s = None;
    for (i, (column, value)) in columns.iter().zip(values).enumerate() {
        if let Some(v) = *value {
            let previous = previous_t_s.filter(|_| *column == Column::TimeS);
            let problem = if !v.is_finite() {
                Some(CellProblem::NotFinite)
            } else if previous.is_some_and(|prev| v <= prev) {
                Some(CellProblem::TimeNotIncreasing)
            } else {
                None
            };
            if let Some(problem) = problem {
                return Err(RunCsvError::Cell {
                    line,
                    column: i + 1,
                    name: *column,
                    value: v.to_string(),
                    problem,
                    previous_t_s: previous,
                });
            }
            if *column == Column::TimeS {
                t_s = Some(v);
            }
        }
    }
    for (i, value) in values.iter().enumerate() {
        if i > 0 {
            out.write_all(b",")?;
        }
        if let Some(v) = value {
            write!(out, "{v}")?;
        }
    }
    out.write_all(b"\n")?;
    if t_s.is_some() {
        *previous_t_s = t_s;
    }
    Ok(())
}

/// Writes the header row naming `columns`.
pub(crate) fn write_header<W: Write>(out: &mut W, columns: &[Column]) -> io::Result<()> {
    let names: Vec<&str> = columns.iter().map(|c| c.name()).collect();
    writeln!(out, "{}", names.join(","))
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

/// Reads a whole run CSV file (a cut last row is left out; see [`read_run_csv_salvaging`] to
/// learn about it).
pub fn read_run_csv(path: &Path) -> Result<Vec<RunSample>, RunCsvFileError> {
    read_run_csv_salvaging(path, false).map(|(samples, _)| samples)
}

/// Reads a whole run CSV file and the rows left out: a cut last row always, any damaged row
/// with `salvage` (see [`RunCsvReader::salvaging`]).
pub fn read_run_csv_salvaging(
    path: &Path,
    salvage: bool,
) -> Result<(Vec<RunSample>, Vec<DroppedRow>), RunCsvFileError> {
    // This tool's own files, valid throughout: read and parsed in parallel, block by block.
    if let Some(samples) =
        fast::read_file(path, fast::BLOCK_BYTES).map_err(|e| RunCsvFileError::new(path, e))?
    {
        return Ok((samples, Vec::new()));
    }
    let bytes = std::fs::read(path).map_err(|e| RunCsvFileError::new(path, e))?;
    let mut reader = RunCsvReader::new(&bytes[..])
        .map_err(|e| RunCsvFileError::new(path, e))?
        .salvaging(salvage);
    let samples = reader
        .by_ref()
        .collect::<Result<_, _>>()
        .map_err(|e| RunCsvFileError::new(path, e))?;
    Ok((samples, reader.dropped))
}

/// Writes `samples` to a run CSV at `path`, all or nothing (see [`write_atomically`]): if any
/// sample is refused or any write fails, `path` is not created (or keeps its previous content).
/// Returns the number of rows written.
pub fn write_run_csv_atomically<'a>(
    path: &Path,
    samples: impl IntoIterator<Item = &'a RunSample>,
) -> Result<u64, RunCsvFileError> {
    try_write_run_csv_atomically(path, samples.into_iter().map(|s| Ok(*s)))
}

/// Like [`write_run_csv_atomically`] for samples that may fail on the way (e.g. a reader): the
/// first `Err` aborts the write, nothing is left at `path`, and the error is returned as is
/// (so it names the input file, not the output).
pub fn try_write_run_csv_atomically(
    path: &Path,
    samples: impl IntoIterator<Item = Result<RunSample, RunCsvFileError>>,
) -> Result<u64, RunCsvFileError> {
    let written = write_atomically(path, |out| {
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
        AtomicWriteError::Content(e) => e,
    })
}

/// Rewrites the run CSV `input` as a canonical run CSV at `output` (this tool's column order,
/// extra columns dropped, shortest round-trip numbers). Nothing is created at `output` unless all
/// of `input` is valid. Returns the number of rows.
pub fn normalize_run_csv(input: &Path, output: &Path) -> Result<u64, RunCsvFileError> {
    let file = std::fs::File::open(input).map_err(|e| RunCsvFileError::new(input, e))?;
    let reader =
        RunCsvReader::new(io::BufReader::new(file)).map_err(|e| RunCsvFileError::new(input, e))?;
    try_write_run_csv_atomically(
        output,
        reader.map(|r| r.map_err(|e| RunCsvFileError::new(input, e))),
    )
}

mod fast;
#[cfg(test)]
mod tests;
