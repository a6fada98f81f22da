//! `rover_power._native`: the host tool's own library calls behind the Python package
//! (`rover_power/__init__.py` turns what they return into DataFrames and dicts). The same
//! sequences as the CLI's (`host_tool::analysis`), so a report here is the CLI's `--json`.
//! Each call reads and computes without the GIL; what reading found is warned about
//! (`RoverPowerWarning`) once the call is back in Python; errors carry the CLI's message.

use host_tool::analysis::{self, Reader};
use host_tool::log::run_csv::{Column, RigRange};
use host_tool::plan::{load_model, ModelSource, Preset};
use pyo3::exceptions::{PyException, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyByteArray;
use std::ffi::CString;
use std::path::PathBuf;

pyo3::create_exception!(
    rover_power,
    RoverPowerError,
    PyException,
    "A file could not be read or analysed; the message is the command line's (file, line, column)."
);
pyo3::create_exception!(
    rover_power,
    RoverPowerWarning,
    PyUserWarning,
    "What reading a run log found: a file cut short, damaged stretches or rows left out."
);

/// The error as a Python exception, worded as the CLI prints it.
fn error(e: anyhow::Error) -> PyErr {
    RoverPowerError::new_err(host_tool::stderr::error_text(&e))
}

fn rig_range(text: &str) -> PyResult<RigRange> {
    RigRange::parse(text).map_err(|e| PyValueError::new_err(format!("rig_range={text:?}: {e}")))
}

/// Runs `work` without the GIL with a [`Reader`] that collects warnings, then warns about
/// each in Python. Data lost to damage is an error unless `salvage` (the CLI's exit code 4).
fn reading<T: Send>(
    py: Python<'_>,
    salvage: bool,
    range: RigRange,
    work: impl FnOnce(&mut Reader<'_>) -> anyhow::Result<T> + Send,
) -> PyResult<T> {
    let (result, warnings, lost_data) = py.detach(|| {
        let mut warnings = Vec::new();
        let mut reader = Reader::new(salvage, range, |w: &str| warnings.push(w.to_owned()));
        let result = work(&mut reader);
        let lost_data = reader.lost_data();
        drop(reader);
        (result, warnings, lost_data)
    });
    let category = py.get_type::<RoverPowerWarning>();
    for warning in warnings {
        let text = warning.strip_prefix("warning: ").unwrap_or(&warning);
        let text = CString::new(text.replace('\0', "")).unwrap_or_default();
        PyErr::warn(py, &category, &text, 2)?;
    }
    let value = result.map_err(error)?;
    if lost_data && !salvage {
        return Err(RoverPowerError::new_err(
            "data was lost to damage (see the warnings): salvage=True accepts what could be read",
        ));
    }
    Ok(value)
}

/// The columns' names, in the order `read_run` returns them.
#[pyfunction]
fn columns() -> Vec<&'static str> {
    Column::ALL.iter().map(|c| c.name()).collect()
}

/// The run log at `path` as one bytearray of little-endian f64, column after column (in the
/// order of `columns()`; NaN where an optional cell is empty), and its events as JSON.
#[pyfunction]
fn read_run<'py>(
    py: Python<'py>,
    path: PathBuf,
    salvage: bool,
    rig_range: &str,
) -> PyResult<(Bound<'py, PyByteArray>, String)> {
    let range = self::rig_range(rig_range)?;
    let columns = reading(py, salvage, range, |reader| {
        analysis::read_run_columns(&path, reader)
    })?;
    let events = columns.events_json().to_string();
    let rows = columns.rows();
    let bytes = PyByteArray::new_with(py, columns.values.len() * rows * 8, |buffer| {
        if rows == 0 {
            return Ok(()); // chunks of 0 bytes would panic
        }
        for (column, out) in columns.values.iter().zip(buffer.chunks_exact_mut(rows * 8)) {
            for (value, cell) in column.iter().zip(out.chunks_exact_mut(8)) {
                cell.copy_from_slice(&value.to_le_bytes());
            }
        }
        Ok(())
    })?;
    Ok((bytes, events))
}

/// `host-tool validate --json`'s report of `runs`, as JSON text.
#[pyfunction]
fn validate(
    py: Python<'_>,
    rover: Option<PathBuf>,
    runs: Vec<PathBuf>,
    salvage: bool,
    rig_range: &str,
) -> PyResult<String> {
    let range = self::rig_range(rig_range)?;
    reading(py, salvage, range, |reader| {
        let rover_file = host_tool::rover::load_rover_file_or_husky(rover.as_deref())?;
        let options = host_tool::validate::ValidateOptions {
            tracker_offset_m: rover_file.tracker_offset_m,
            ..host_tool::validate::ValidateOptions::for_rover(&rover_file.rover)
        };
        let (_, report) =
            analysis::stream_and_validate(&rover_file.rover, &runs, reader, &options)?;
        Ok(serde_json::to_string(&report)?)
    })
}

/// `host-tool diagnose --json`'s report of `runs` (calibrated on `calibration`, or on the
/// runs' own calibration manoeuvres when empty), as JSON text.
#[pyfunction]
fn diagnose(
    py: Python<'_>,
    rover: Option<PathBuf>,
    runs: Vec<PathBuf>,
    calibration: Vec<PathBuf>,
    salvage: bool,
    rig_range: &str,
) -> PyResult<String> {
    let range = self::rig_range(rig_range)?;
    reading(py, salvage, range, |reader| {
        let rover_file = host_tool::rover::load_rover_file_or_husky(rover.as_deref())?;
        let diagnosed = analysis::diagnose(&rover_file, &runs, &calibration, reader)?;
        Ok(serde_json::to_string(&diagnosed.to_json())?)
    })
}

/// `host-tool plan --json`'s comparison, with the model file `model` or paper Table 2's
/// Husky on hard ground, as JSON text.
#[pyfunction]
fn plan(
    py: Python<'_>,
    start_deg: f64,
    end_deg: f64,
    distance_m: f64,
    model: Option<PathBuf>,
) -> PyResult<String> {
    py.detach(|| -> anyhow::Result<String> {
        let (model, source) = match model {
            Some(path) => (load_model(&path)?, ModelSource::File(path)),
            None => {
                let preset = Preset::HuskyHardGround;
                (preset.model(), ModelSource::Preset(preset))
            }
        };
        let report = host_tool::plan::plan(&model, &source, start_deg, end_deg, distance_m)?;
        Ok(serde_json::to_string(&report)?)
    })
    .map_err(error)
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // No progress bars: a notebook's stderr is no terminal, and a REPL's would be garbled.
    host_tool::progress::set_quiet(true);
    m.add("RoverPowerError", m.py().get_type::<RoverPowerError>())?;
    m.add("RoverPowerWarning", m.py().get_type::<RoverPowerWarning>())?;
    m.add_function(wrap_pyfunction!(columns, m)?)?;
    m.add_function(wrap_pyfunction!(read_run, m)?)?;
    m.add_function(wrap_pyfunction!(validate, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(plan, m)?)?;
    Ok(())
}
