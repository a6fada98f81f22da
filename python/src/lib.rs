//! `rover_power._native`: the host tool's own library calls behind the Python package
//! (`rover_power/__init__.py` turns what they return into DataFrames and dicts). The same
//! sequences as the CLI's (`host_tool::analysis`), so a report here is the CLI's `--json`.
//! Each call reads and computes without the GIL; what reading found is warned about
//! (`RoverPowerWarning`) once the call is back in Python; errors carry the CLI's message.
//! Every path is refused up front unless it is a regular file (or missing, which the reader
//! words): a FIFO would wait for a writer and a device may never end, and neither can be
//! interrupted from Python while the call waits in Rust.

use host_tool::analysis::{self, Reader};
use host_tool::log::csv_sink::events_path;
use host_tool::log::load::RunFormat;
use host_tool::log::run_csv::{Column, RigRange};
use host_tool::plan::{load_model, ModelSource, Preset};
use pyo3::exceptions::{PyException, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::ffi::CString;
use std::fs::Metadata;
use std::path::{Path, PathBuf};

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

/// Refuses each of `paths` that exists and is not a regular file (a directory, a FIFO, a
/// device, a socket), naming it and what it is; a ROS 2 bag directory (with its
/// `metadata.yaml`) is read as its MCAP file, as the CLI reads it. Asked of the file system without opening the
/// file: opening a FIFO waits for a writer. A path that cannot be looked at (missing, not
/// permitted) passes: the reader's own error names it, as the CLI's does.
fn regular_files<'a>(paths: impl IntoIterator<Item = &'a Path>) -> PyResult<()> {
    for path in paths {
        let Ok(metadata) = std::fs::metadata(path) else {
            continue;
        };
        if metadata.is_dir() && path.join("metadata.yaml").is_file() {
            continue;
        }
        if metadata.is_dir() {
            let shown = path.display();
            return Err(RoverPowerError::new_err(format!(
                "{shown}: is a directory, not a file"
            )));
        }
        if !metadata.is_file() {
            return Err(RoverPowerError::new_err(format!(
                "{}: {}, not a regular file (reading it could wait for a writer or never end: \
                 save its data to a file and pass that)",
                path.display(),
                what_it_is(&metadata)
            )));
        }
    }
    Ok(())
}

/// What a path that is neither a regular file nor a directory is, in words.
#[cfg_attr(not(unix), allow(unused_variables))]
fn what_it_is(metadata: &Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let kind = metadata.file_type();
        if kind.is_fifo() {
            return "is a named pipe (FIFO)";
        }
        if kind.is_char_device() {
            return "is a character device";
        }
        if kind.is_block_device() {
            return "is a block device";
        }
        if kind.is_socket() {
            return "is a socket";
        }
    }
    "is a special file"
}

/// Refuses an empty list of runs, which the analysis would word as a run set without
/// manoeuvres.
fn some_runs(runs: &[PathBuf], command: &str, takes: &str) -> PyResult<()> {
    if runs.is_empty() {
        return Err(PyValueError::new_err(format!(
            "no runs given: {command} needs at least one {takes}"
        )));
    }
    Ok(())
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

/// One column of a run handed to numpy without a copy: numpy reads and writes `values` through
/// `__array_interface__` and keeps this object alive as the array's base, as rust-numpy's
/// `PyArray::from_vec` does (that crate does not build for the stable ABI). The vector is this
/// object's own, and numpy writes through a pointer taken from a mutable borrow
/// (`Vec::as_mut_ptr`, which makes no reference to the values): Rust never reads the values
/// again, it only frees them with the last array, so a frame can be changed in place like any
/// other without writing into memory Rust lent to be read.
#[pyclass]
#[derive(Debug)]
struct ColumnBuffer {
    /// A value per sample.
    values: Vec<f64>,
}

#[pymethods]
impl ColumnBuffer {
    /// numpy's array interface (version 3): a writable one-dimensional array of f64.
    #[getter]
    fn __array_interface__<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let interface = PyDict::new(py);
        interface.set_item("version", 3)?;
        interface.set_item("shape", (self.values.len(),))?;
        let typestr = if cfg!(target_endian = "little") {
            "<f8"
        } else {
            ">f8"
        };
        interface.set_item("typestr", typestr)?;
        // (address, read-only = false): numpy owns the values through this object.
        interface.set_item("data", (self.values.as_mut_ptr() as usize, false))?;
        Ok(interface)
    }
}

/// The run log at `path` as its columns (in the order of `columns()`; NaN where an optional
/// cell is empty) and its events as JSON.
#[pyfunction]
fn read_run(
    py: Python<'_>,
    path: PathBuf,
    salvage: bool,
    rig_range: &str,
) -> PyResult<(Vec<ColumnBuffer>, String)> {
    let range = self::rig_range(rig_range)?;
    // A run CSV's events file beside it is read too.
    let events = matches!(RunFormat::of(&path), Ok(RunFormat::Csv)).then(|| events_path(&path));
    regular_files([path.as_path()].into_iter().chain(events.as_deref()))?;
    reading(py, salvage, range, |reader| {
        let columns = analysis::read_run_columns(&path, reader)?;
        let events = columns.events_json().to_string();
        let buffers = columns.values.map(|values| ColumnBuffer { values });
        Ok((buffers.into(), events))
    })
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
    some_runs(&runs, "validate", "run log (.csv or .mcap)")?;
    regular_files(rover.iter().chain(&runs).map(PathBuf::as_path))?;
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
    some_runs(
        &runs,
        "diagnose",
        "run log (.csv or .mcap), per-turn summary CSV or path table",
    )?;
    regular_files(
        rover
            .iter()
            .chain(&runs)
            .chain(&calibration)
            .map(PathBuf::as_path),
    )?;
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
    regular_files(model.as_deref())?;
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
