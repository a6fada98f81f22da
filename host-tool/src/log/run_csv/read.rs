//! Reading a run CSV: the table layer (known columns, cell counts, numbers, increasing time)
//! shared with the commands CSV, and the streaming sample reader with its salvage rules.

use super::*;

/// The table layer shared by the run CSV and the commands CSV (same cell rules, same column
/// names): locates the known columns in the header, checks cell counts, parses numbers
/// (within a [`RigRange`]) and keeps `t_s` strictly increasing.
#[derive(Debug)]
pub(crate) struct Table<R> {
    records: Records<R>,
    /// Cell position of each column (`None`: an optional column that is absent).
    positions: [Option<usize>; Column::ALL.len()],
    cells: usize,
    previous_t_s: Option<f64>,
    /// The readings accepted.
    range: RigRange,
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
            range: RigRange::default(),
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
        } else if !self.range.admits(column, value) {
            Err(err(CellProblem::OutOfRange(self.range)))
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
    pub(super) dropped: Vec<DroppedRow>,
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

    /// Reads the bus voltages and currents within `range` (default: any physical reading).
    pub fn within(mut self, range: RigRange) -> Self {
        self.table.range = range;
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
