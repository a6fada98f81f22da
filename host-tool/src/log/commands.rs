//! The commands CSV: what the rover's controller commanded, over time, and optionally the pose a
//! tracker measured. `record --commands FILE` forwards the speeds to the board (so its τ ∝ P/ω
//! estimates are live) and copies speeds and pose into the run log; the simulated world writes
//! one for each scenario it runs.

use super::run_csv::{write_header, write_row, Column, RunCsvError, RunCsvFileError, Table};
use model_core::Sides;
use std::io::{self, BufRead, Write};
use std::path::Path;

/// One row of a commands CSV: from `t_s` on (until the next row) the controller commands these
/// side speeds; `yaw_rad`/`pitch_deg` are the pose a tracker measured at `t_s`, if any.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CommandRow {
    /// Time since the start of the run [s], strictly increasing.
    pub t_s: f64,
    /// Commanded linear speed of each side [m/s], positive forward.
    pub cmd_mps: Sides<f64>,
    /// Yaw [rad], counter-clockwise positive, if tracked.
    pub yaw_rad: Option<f64>,
    /// Pitch [deg], nose-up positive, if tracked.
    pub pitch_deg: Option<f64>,
    /// The tracked point's x in the fixed frame [m], if the tracker had a fix at `t_s`.
    pub x_m: Option<f64>,
    /// The tracked point's y [m], with `x_m`.
    pub y_m: Option<f64>,
}

impl CommandRow {
    /// Side speeds from `t_s` on, without a tracked pose.
    pub fn new(t_s: f64, cmd_mps: Sides<f64>) -> Self {
        Self {
            t_s,
            cmd_mps,
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        }
    }
}

/// The columns of a commands CSV, in the order this tool writes them; the first three are
/// required. They are the run CSV's columns of the same names (same units and signs).
pub const COMMAND_COLUMNS: [Column; 7] = [
    Column::TimeS,
    Column::CmdLeftMps,
    Column::CmdRightMps,
    Column::YawRad,
    Column::PitchDeg,
    Column::XM,
    Column::YM,
];

/// Streaming reader of a commands CSV: an iterator of rows. Stops after the first error.
///
/// # Format
///
/// Header row with `t_s,cmd_left_mps,cmd_right_mps` (required, any order) and optionally
/// `yaw_rad,pitch_deg,x_m,y_m` (the tracker's pose; cells may be empty, position cells `NaN`);
/// other columns are ignored. The
/// cell, quoting, line-end and error rules are the run CSV's ([`super::run_csv`]): finite
/// numbers, `t_s` strictly increasing, errors naming line and column.
#[derive(Debug)]
pub struct CommandsCsvReader<R> {
    table: Table<R>,
    done: bool,
}

impl<R: BufRead> CommandsCsvReader<R> {
    /// Reads the header row from `input`.
    pub fn new(input: R) -> Result<Self, RunCsvError> {
        Ok(Self {
            table: Table::new(input, &COMMAND_COLUMNS[..3])?,
            done: false,
        })
    }

    fn next_row(&mut self) -> Result<Option<CommandRow>, RunCsvError> {
        let Some(line) = self.table.next_row()? else {
            return Ok(None);
        };
        let t = &self.table;
        let t_s = t.required(line, Column::TimeS)?;
        let row = CommandRow {
            t_s,
            cmd_mps: Sides::new(
                t.required(line, Column::CmdLeftMps)?,
                t.required(line, Column::CmdRightMps)?,
            ),
            yaw_rad: t.value(line, Column::YawRad)?,
            pitch_deg: t.value(line, Column::PitchDeg)?,
            x_m: t.value(line, Column::XM)?,
            y_m: t.value(line, Column::YM)?,
        };
        self.table.accept_time(line, t_s)?;
        Ok(Some(row))
    }
}

impl<R: BufRead> Iterator for CommandsCsvReader<R> {
    type Item = Result<CommandRow, RunCsvError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let next = self.next_row().transpose();
        if !matches!(next, Some(Ok(_))) {
            self.done = true;
        }
        next
    }
}

/// Writes a commands CSV: the header with all seven [`COMMAND_COLUMNS`], then one row per
/// command; `None` is an empty cell; numbers round-trip bit for bit.
#[derive(Debug)]
pub struct CommandsCsvWriter<W: Write> {
    out: W,
    rows: u64,
    previous_t_s: Option<f64>,
}

impl<W: Write> CommandsCsvWriter<W> {
    /// Writes the header row.
    pub fn new(mut out: W) -> Result<Self, RunCsvError> {
        write_header(&mut out, &COMMAND_COLUMNS)?;
        Ok(Self {
            out,
            rows: 0,
            previous_t_s: None,
        })
    }

    /// Writes one row; a row the reader would reject is refused with the reader's error.
    pub fn write(&mut self, row: &CommandRow) -> Result<(), RunCsvError> {
        let values = [
            Some(row.t_s),
            Some(row.cmd_mps.left),
            Some(row.cmd_mps.right),
            row.yaw_rad,
            row.pitch_deg,
            row.x_m,
            row.y_m,
        ];
        write_row(
            &mut self.out,
            self.rows + 2,
            &mut self.previous_t_s,
            &COMMAND_COLUMNS,
            &values,
        )?;
        self.rows += 1;
        Ok(())
    }

    /// Flushes and returns the underlying writer.
    pub fn into_inner(mut self) -> Result<W, RunCsvError> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Reads a whole commands CSV file.
pub fn read_commands_csv(path: &Path) -> Result<Vec<CommandRow>, RunCsvFileError> {
    let err = |e: RunCsvError| RunCsvFileError {
        path: path.to_owned(),
        source: e,
    };
    let file = std::fs::File::open(path).map_err(|e| err(e.into()))?;
    CommandsCsvReader::new(io::BufReader::new(file))
        .map_err(err)?
        .collect::<Result<_, _>>()
        .map_err(err)
}

/// Writes `rows` to a commands CSV at `path`, all or nothing (see [`super::write_atomically`]).
pub fn write_commands_csv_atomically<'a>(
    path: &Path,
    existing: super::Existing,
    rows: impl IntoIterator<Item = &'a CommandRow>,
) -> Result<(), RunCsvFileError> {
    let err = |e: RunCsvError| RunCsvFileError {
        path: path.to_owned(),
        source: e,
    };
    super::write_atomically(path, existing, |out| {
        let mut writer = CommandsCsvWriter::new(out).map_err(err)?;
        for row in rows {
            writer.write(row).map_err(err)?;
        }
        writer.into_inner().map(|_| ()).map_err(err)
    })
    .map_err(|e| match e {
        super::AtomicWriteError::Io { path, source } => RunCsvFileError {
            path,
            source: source.into(),
        },
        super::AtomicWriteError::Content { source, .. } => source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::tests_support::TempDir;

    fn read(text: &str) -> Result<Vec<CommandRow>, RunCsvError> {
        CommandsCsvReader::new(text.as_bytes())?.collect()
    }

    fn row(t_s: f64, left: f64, right: f64) -> CommandRow {
        CommandRow::new(t_s, Sides::new(left, right))
    }

    #[test]
    fn required_columns_in_any_order_extras_ignored_optional_pose() {
        let rows = read(
            "note,cmd_right_mps,t_s,cmd_left_mps,yaw_rad\n\
             a,0.5,0,0.1,\n\
             b,0.5,1.5,0.1,-0.25\n",
        )
        .expect("valid");
        assert_eq!(
            rows,
            vec![
                row(0.0, 0.1, 0.5),
                CommandRow {
                    yaw_rad: Some(-0.25),
                    ..row(1.5, 0.1, 0.5)
                }
            ]
        );
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = read("t_s,cmd_left_mps\n0,1\n").expect_err("missing column");
        assert_eq!(
            e.to_string(),
            "line 1: missing required column `cmd_right_mps` in the header"
        );
        let e = read("t_s,cmd_left_mps,cmd_right_mps\n0,1,1\n\n1,x,1\n").expect_err("bad cell");
        assert_eq!(
            e.to_string(),
            "line 4, column 2 (cmd_left_mps): \"x\" is not a number"
        );
        let e = read("t_s,cmd_left_mps,cmd_right_mps\n1,1,1\n1,1,1\n").expect_err("equal time");
        assert!(
            e.to_string().starts_with("line 3, column 1 (t_s): time 1"),
            "{e}"
        );
        let e = read("t_s,cmd_left_mps,cmd_right_mps\n0,NaN,1\n").expect_err("nan");
        assert!(e.to_string().contains("not a finite number"), "{e}");
        let e = read("t_s,cmd_left_mps,cmd_right_mps\n0,,1\n").expect_err("empty");
        assert!(e.to_string().contains("empty cell"), "{e}");
        let e = read("t_s,cmd_left_mps,cmd_right_mps\n0,1\n").expect_err("short row");
        assert_eq!(e.to_string(), "line 2: row has 2 cells, the header has 3");
    }

    #[test]
    fn write_then_read_back_bit_for_bit_and_atomically() {
        let dir = TempDir::new("commands-csv");
        let path = dir.path().join("cmds.csv");
        let rows = vec![
            row(0.0, 0.0, 0.0),
            CommandRow {
                yaw_rad: Some(0.1 + 0.2),
                pitch_deg: Some(-3.5),
                ..row(0.1, 0.3, -0.3)
            },
            row(2.0, 1.0 / 3.0, 0.55),
        ];
        write_commands_csv_atomically(&path, crate::log::Existing::Replace, &rows)
            .expect("written");
        assert_eq!(read_commands_csv(&path).expect("read"), rows);
        let bad = [row(1.0, 0.0, 0.0), row(0.5, 0.0, 0.0)];
        let other = dir.path().join("bad.csv");
        let e = write_commands_csv_atomically(&other, crate::log::Existing::Replace, &bad)
            .expect_err("time goes back");
        assert!(e.to_string().contains("line 3"), "{e}");
        assert!(!other.exists());
    }

    /// Issue 34: 1e308 in a message was 309 digits, a 10 MB cell 10 MB.
    #[test]
    fn quoted_numbers_and_cells_stay_short() {
        let e = read("t_s,cmd_left_mps,cmd_right_mps\n1e308,0,0\n1,0,0\n").expect_err("back");
        assert_eq!(
            e.to_string(),
            "line 3, column 1 (t_s): time 1 is not after the previous row's 1e308"
        );
        let cell = "9".repeat(10_000_000);
        let e = read(&format!("t_s,cmd_left_mps,cmd_right_mps\n0,{cell}x,0\n")).expect_err("cell");
        assert!(e.to_string().len() < 200, "{} bytes", e.to_string().len());
        let mut out = CommandsCsvWriter::new(Vec::new()).expect("header");
        out.write(&row(1e308, 0.0, 0.0)).expect("first row");
        let e = out.write(&row(1e308, 0.0, 0.0)).expect_err("same time");
        assert_eq!(
            e.to_string(),
            "line 3, column 1 (t_s): time 1e308 is not after the previous row's 1e308"
        );
    }
}
