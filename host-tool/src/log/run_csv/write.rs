//! Writing a run CSV: the header and one row per sample, numbers in their shortest
//! round-trip form.

use super::*;

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
                    value: Number(v).to_string(),
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
