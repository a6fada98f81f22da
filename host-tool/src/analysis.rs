//! The analysis commands' sequences from files to report (`validate`, `plot`, `diagnose`), one
//! place for the command line and the Python package, so that both give the same report for
//! the same files. What reading the run logs found (a file cut short, damaged stretches or
//! rows) goes to the caller's [`Reader`] as it is found: the CLI prints it, Python warns.

use crate::diagnose::calibration::Calibration;
use crate::diagnose::features::{RunSampleScan, TurnRow};
use crate::diagnose::path_table::{self, PathDiagnosis};
use crate::diagnose::{self, Diagnosis};
use crate::log::commands::CommandRow;
use crate::log::csv_sink::{events_path, read_events};
use crate::log::load::{stream_salvaging, RunFormat};
use crate::log::mcap::Truncation;
use crate::log::run_csv::{visit_own_run_csv, Column, RigRange, RunSample};
use crate::log::run_log::{LogEvent, RunLogSink};
use crate::rover::RoverFile;
use crate::runs::{damage_warnings, truncation_warning, Runs, StreamedRuns, StreamedRunsError};
use crate::validate::{self, ValidateOptions, ValidationReport};
use anyhow::{anyhow, bail, Context, Result};
use model_core::wire::{BoardFrame, Sample};
use model_core::Rover;
use std::fmt;
use std::fs::File;
use std::io::{self, Read};
use std::path::{Path, PathBuf};

/// How run logs are read (`--salvage`, `--rig-range`), and where what reading them found goes.
pub struct Reader<'a> {
    /// Accept damaged run CSV rows (left out and listed) and lost data.
    pub salvage: bool,
    /// The readings a run CSV may hold.
    pub range: RigRange,
    warn: Box<dyn FnMut(&str) + 'a>,
    lost_data: bool,
}

impl fmt::Debug for Reader<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Reader")
            .field("salvage", &self.salvage)
            .field("range", &self.range)
            .field("lost_data", &self.lost_data)
            .finish_non_exhaustive()
    }
}

impl<'a> Reader<'a> {
    /// A reader that hands each warning to `warn` as it is found.
    pub fn new(salvage: bool, range: RigRange, warn: impl FnMut(&str) + 'a) -> Self {
        Self {
            salvage,
            range,
            warn: Box::new(warn),
            lost_data: false,
        }
    }

    /// Whether data inside a file read was lost to damage (not just a cut end): the CLI's exit
    /// code 4 and the Python package's error, unless `salvage`.
    pub fn lost_data(&self) -> bool {
        self.lost_data
    }

    /// Passes on what reading the files found.
    pub fn found(&mut self, truncated: &[(PathBuf, Truncation)], damage: &[String], lost: bool) {
        for (path, t) in truncated {
            (self.warn)(&truncation_warning(path, t));
        }
        for warning in damage {
            (self.warn)(warning);
        }
        self.lost_data |= lost;
    }
}

/// A run log's samples as columns, the run CSV's ([`Column::ALL`], in that order), for array
/// consumers (the Python package's `read_run`): no object per sample on the way, and each
/// column one vector that a consumer can take as it is.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunColumns {
    /// One vector per column of [`Column::ALL`], each a value per sample; an empty optional
    /// cell (not measured) is NaN.
    pub values: [Vec<f64>; Column::ALL.len()],
    /// The run's events at their run time [s]: an MCAP log's, or a run CSV's events file
    /// (`RUN.events.jsonl`) when there is one beside it.
    pub events: Vec<(f64, LogEvent)>,
}

impl RunColumns {
    /// The number of samples.
    pub fn rows(&self) -> usize {
        self.values[0].len()
    }

    /// Room for `rows` samples in every column.
    fn reserve(&mut self, rows: usize) {
        for column in &mut self.values {
            column.reserve(rows);
        }
    }

    /// Room for an estimated `rows` samples, where there is memory for them (else the columns
    /// grow as they fill).
    fn presize(&mut self, rows: usize) {
        for column in &mut self.values {
            if column.try_reserve(rows).is_err() {
                return;
            }
        }
    }

    fn extend(&mut self, samples: &[RunSample]) {
        for s in samples {
            let nan = f64::NAN;
            // In Column::ALL's order (not `required_values`', which groups by quantity).
            let row = [
                s.t_s,
                s.bus_v.left,
                s.current_a.left,
                s.bus_v.right,
                s.current_a.right,
                s.cmd_mps.left,
                s.cmd_mps.right,
                s.yaw_rad.unwrap_or(nan),
                s.pitch_deg.unwrap_or(nan),
                s.x_m.unwrap_or(nan),
                s.y_m.unwrap_or(nan),
            ];
            for (column, value) in self.values.iter_mut().zip(row) {
                column.push(value);
            }
        }
    }

    /// Room for `rows` more, and for a few more minutes of samples when the columns grow:
    /// growing an hour's columns a doubling at a time would copy them over and over.
    fn make_room(&mut self, rows: usize) {
        if self.values[0].len() + rows > self.values[0].capacity() {
            self.reserve(self.rows().max(1 << 16).max(rows));
        }
    }

    /// The events as JSON: `[{"t_s": …, "kind": "started", "port": …}, …]`, the fields of a run
    /// CSV's events file.
    pub fn events_json(&self) -> serde_json::Value {
        self.events
            .iter()
            .map(|(t_s, event)| {
                let mut line = serde_json::json!({ "t_s": t_s });
                if let (Some(line), Ok(serde_json::Value::Object(fields))) =
                    (line.as_object_mut(), serde_json::to_value(event))
                {
                    line.extend(fields);
                }
                line
            })
            .collect()
    }
}

/// Reads the run log at `path` (`.csv` or `.mcap`) into columns. This tool's own run CSVs are
/// read once and parsed on every core, as `validate` reads them; any other file as `validate`
/// loads it (the same errors, the same salvage).
pub fn read_run_columns(path: &Path, reader: &mut Reader<'_>) -> Result<RunColumns> {
    let mut columns = RunColumns::default();
    let format = RunFormat::of(path)?;
    columns.presize(match format {
        RunFormat::Csv => estimated_csv_rows(path),
        RunFormat::Mcap => estimated_mcap_samples(path),
    });
    let own = format == RunFormat::Csv
        && visit_own_run_csv(path, reader.range, &mut |rows| columns.extend(rows))?;
    if !own {
        // A file the fast path declined may have given it some rows: start over. Streamed
        // into the columns: the run's frames and commands are not kept.
        columns = RunColumns::default();
        let found = stream_salvaging(path, reader.salvage, reader.range, &mut columns)?;
        let truncated: Vec<(PathBuf, Truncation)> = found
            .truncated
            .iter()
            .map(|t| (path.to_owned(), *t))
            .collect();
        let damage = damage_warnings(path, &found.losses, &found.dropped_rows);
        reader.found(&truncated, &damage, found.lost_data());
    }
    let events = events_path(path);
    if format == RunFormat::Csv && events.exists() {
        columns.events = read_events(&events)?;
    }
    for column in &mut columns.values {
        column.shrink_to_fit(); // a large vector's unused end is given back without a copy
    }
    Ok(columns)
}

/// A run streamed into columns: its samples and events (frames and commands have no column).
impl RunLogSink for RunColumns {
    fn frame(&mut self, _t_s: f64, _frame: &BoardFrame) -> io::Result<()> {
        Ok(())
    }

    fn sample(&mut self, sample: &RunSample) -> io::Result<()> {
        self.samples(std::slice::from_ref(sample), &[])
    }

    fn samples(&mut self, samples: &[RunSample], _frames: &[Sample]) -> io::Result<()> {
        self.make_room(samples.len());
        self.extend(samples);
        Ok(())
    }

    fn command(&mut self, _row: &CommandRow) -> io::Result<()> {
        Ok(())
    }

    fn event(&mut self, t_s: f64, event: &LogEvent) -> io::Result<()> {
        self.events.push((t_s, event.clone()));
        Ok(())
    }
}

/// About how many rows the run CSV at `path` holds, a little more rather than less: its length
/// over the mean length of the lines in its first 64 KiB (0 when it cannot be read: the
/// reader says why). Growing a column to an hour-long run a doubling at a time would copy it
/// over and over (a third of the read's time).
fn estimated_csv_rows(path: &Path) -> usize {
    let mut head = Vec::new();
    let Ok(len) = File::open(path).and_then(|mut file| {
        (&mut file).take(64 << 10).read_to_end(&mut head)?;
        Ok(file.metadata()?.len())
    }) else {
        return 0;
    };
    let lines = memchr::memchr_iter(b'\n', &head).count().max(1);
    let rows = len as f64 / (head.len().max(1) as f64 / lines as f64);
    (rows * 1.05) as usize + 1024
}

/// About how many samples the MCAP log at `path` holds: its length over [`MCAP_BYTES_A_SAMPLE`]
/// (0 when it cannot be read: the reader says why). Growing the columns a doubling at a time
/// copied an hour's samples over and over, and touched twice the pages.
fn estimated_mcap_samples(path: &Path) -> usize {
    let len = std::fs::metadata(path).map_or(0, |m| m.len());
    usize::try_from(len / MCAP_BYTES_A_SAMPLE).unwrap_or(usize::MAX)
}

/// A little less than a sample takes in an MCAP log as the recorder writes it, with its share of
/// the frames and commands: 26 B in the simulated board's run (the test below), 46.6 B in the
/// throughput bench's hour, which has tracker poses (41.7 with the zstd chunks of older logs,
/// 85 with a message a sample, 135 as JSON). Reserving more than a log fills costs address
/// space only (untouched pages, given back at the end); a log that takes fewer (readings that
/// barely change compress further) grows its columns as they fill.
const MCAP_BYTES_A_SAMPLE: u64 = 24;

/// Loads `paths` whole and validates them with `options`: the sequence `plot` needs (it draws
/// the samples).
pub fn load_and_validate(
    rover: &Rover,
    paths: &[PathBuf],
    reader: &mut Reader<'_>,
    options: &ValidateOptions,
) -> Result<(Runs, ValidationReport)> {
    let runs = Runs::load(paths, reader.salvage, reader.range)?;
    reader.found(&runs.truncated, &runs.damage, runs.lost_data);
    let report = runs
        .validate(rover, options)
        .map_err(|e| about_the_runs(e, paths))?;
    Ok((runs, report))
}

/// [`load_and_validate`] with the runs streamed (each file read once, twice where the one
/// pass's guesses fail): memory stays bounded whatever the logs' length; the same report.
/// `validate` and `diagnose` read this way.
pub fn stream_and_validate(
    rover: &Rover,
    paths: &[PathBuf],
    reader: &mut Reader<'_>,
    options: &ValidateOptions,
) -> Result<(StreamedRuns, ValidationReport)> {
    let runs = StreamedRuns::scan(paths, reader.salvage, reader.range, rover, options)?;
    reader.found(&runs.truncated, &runs.damage, runs.lost_data);
    let report = runs.validate().map_err(|e| match e {
        StreamedRunsError::Validate(e) => about_the_runs(e, paths),
        other => other.into(),
    })?;
    Ok((runs, report))
}

/// A validation error about the runs as a whole (no manoeuvre in them) names them; the others
/// name their run already.
fn about_the_runs(e: validate::ValidateError, paths: &[PathBuf]) -> anyhow::Error {
    match e {
        validate::ValidateError::NoManoeuvres { .. } => anyhow!("{}: {e}", runs_named(paths)),
        other => other.into(),
    }
}

/// The runs a whole-run-set error is about, for its message: `a.csv`, `a.csv, b.csv`, or the
/// first three and how many more.
pub fn runs_named(paths: &[PathBuf]) -> String {
    let shown: Vec<String> = paths
        .iter()
        .take(3)
        .map(|p| p.display().to_string())
        .collect();
    match paths.len() {
        0..=3 => shown.join(", "),
        n => format!("{} and {} more", shown.join(", "), n - 3),
    }
}

/// What `diagnose` found: on runs (and per-turn summaries), or on path tables (thesis Table
/// 6.1's form), which have a judgement of their own.
#[derive(Debug)]
pub enum Diagnosed {
    /// Runs diagnosed against the hard-ground baseline.
    Runs {
        /// The diagnosis.
        diagnosis: Box<Diagnosis>,
        /// The diagnosed runs' rows (the figures and model file are drawn from them).
        rows: Vec<TurnRow>,
        /// The calibration runs' rows, when calibration runs were given.
        calibration_rows: Option<Vec<TurnRow>>,
    },
    /// Path tables judged against paper Table 2's hard-ground model.
    PathTable(PathDiagnosis),
}

impl Diagnosed {
    /// The `--json` report.
    pub fn to_json(&self) -> serde_json::Value {
        match self {
            Diagnosed::Runs { diagnosis, .. } => diagnosis.to_json(),
            Diagnosed::PathTable(diagnosis) => diagnosis.to_json(),
        }
    }

    /// Whether the model departs significantly (`--fail-on-departure`).
    pub fn significant(&self) -> bool {
        match self {
            Diagnosed::Runs { diagnosis, .. } => diagnosis.significant,
            Diagnosed::PathTable(diagnosis) => diagnosis.significant,
        }
    }
}

/// Diagnoses `runs` (run logs, per-turn summaries, or path tables) against the hard-ground
/// baseline fitted on `calibration` (default: the calibration manoeuvres of `runs`).
pub fn diagnose(
    rover_file: &RoverFile,
    runs: &[PathBuf],
    calibration: &[PathBuf],
    reader: &mut Reader<'_>,
) -> Result<Diagnosed> {
    let (rover, offset) = (&rover_file.rover, rover_file.tracker_offset_m);
    if runs.iter().any(|p| path_table::is_path_table_file(p)) {
        if !calibration.is_empty() {
            bail!(
                "a path table is judged against paper Table 2's hard-ground model carried over to \
                 the rover: calibration runs do not apply"
            );
        }
        return diagnose_path_tables(rover, runs).map(Diagnosed::PathTable);
    }
    let (rows, notes) = diagnosis_rows(rover, offset, runs, reader, "diagnosed")?;
    let calibration_rows = if calibration.is_empty() {
        None
    } else {
        Some(diagnosis_rows(rover, offset, calibration, reader, "calibration")?.0)
    };
    let baseline = match &calibration_rows {
        Some(rows) => Calibration::rows(rows),
        None => Calibration::FROM_RUNS,
    };
    let mut diagnosis = diagnose::diagnose_with(rover, &rows, baseline)
        .with_context(|| format!("diagnosing {}", runs_named(runs)))?;
    // The inputs' caveats first, then the diagnosis' own.
    diagnosis.notes.splice(0..0, notes);
    Ok(Diagnosed::Runs {
        diagnosis: Box::new(diagnosis),
        rows,
        calibration_rows,
    })
}

/// The diagnosis rows of `paths`: run logs through `validate`, and per-turn summary CSVs
/// (header with `radius_m` and `avg_power_w`, see `diagnose::summary`) as total-only rows,
/// each file its own run; plus the summaries' caveats.
fn diagnosis_rows(
    rover: &Rover,
    tracker_offset_m: f64,
    paths: &[PathBuf],
    reader: &mut Reader<'_>,
    what: &str,
) -> Result<(Vec<TurnRow>, Vec<String>)> {
    let (summaries, runs): (Vec<&PathBuf>, Vec<&PathBuf>) = paths
        .iter()
        .partition(|p| diagnose::summary::is_summary_file(p));
    let mut rows = if runs.is_empty() {
        Vec::new()
    } else {
        let runs: Vec<PathBuf> = runs.into_iter().cloned().collect();
        let options = ValidateOptions {
            tracker_offset_m,
            ..ValidateOptions::for_rover(rover)
        };
        // Streamed: validate reads each file once (twice where its guesses fail), the
        // standstill draw and the manoeuvres' bus voltage once more; memory stays bounded
        // whatever the logs' length.
        let (streamed, report) = stream_and_validate(rover, &runs, reader, &options)
            .with_context(|| format!("{what} runs"))?;
        let mut facts = Vec::with_capacity(runs.len());
        for index in 0..runs.len() {
            let mut scan = RunSampleScan::new(&report, index);
            if let Some(read) = streamed.read_again(index, &mut scan) {
                read.with_context(|| format!("{what} runs"))?;
            }
            facts.push(scan.finish());
        }
        diagnose::features::rows_from_facts(&report, &facts)
    };
    let mut notes = Vec::new();
    for path in summaries {
        let summary = diagnose::summary::load_summary(path)?;
        let run_index = rows.iter().map(|r| r.run_index + 1).max().unwrap_or(0);
        let mut of = diagnose::summary::summary_rows(rover, &summary, &path.display().to_string());
        for row in &mut of {
            row.run_index = run_index;
        }
        rows.extend(of);
        notes.extend(
            diagnose::summary::summary_notes(&summary)
                .into_iter()
                .map(|n| format!("{}: {n}", path.display())),
        );
    }
    Ok((rows, notes))
}

/// Path tables (every file must be one) judged against paper Table 2's hard-ground model
/// carried over to `rover`.
fn diagnose_path_tables(rover: &Rover, paths: &[PathBuf]) -> Result<PathDiagnosis> {
    if let Some(p) = paths.iter().find(|p| !path_table::is_path_table_file(p)) {
        bail!(
            "{}: a path table (header start_deg,end_deg,…) cannot be diagnosed with runs or \
             per-turn summaries; pass them separately",
            p.display()
        );
    }
    let model = path_table::hard_ground_for(rover);
    let mut rows = Vec::new();
    for path in paths {
        let of = path_table::load_path_table(path)?;
        // Each file's rows on their own: the error's line is then in a file it can name.
        path_table::check_rows(&model, &of).map_err(|e| naming(path, e))?;
        rows.extend(of);
    }
    Ok(path_table::diagnose_path_table(&model, &rows)?)
}

/// `error` with `path` in front unless a message in its chain already names the file: every
/// error names its file, once.
pub fn naming(path: &Path, error: impl Into<anyhow::Error>) -> anyhow::Error {
    let error = error.into();
    let shown = path.display().to_string();
    if error
        .chain()
        .any(|cause| cause.to_string().contains(&shown))
    {
        error
    } else {
        error.context(shown)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::run_csv::write_run_csv_atomically;
    use model_core::Sides;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!(
            "rover-power-analysis-{}-{name}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).expect("scratch dir");
        dir
    }

    /// Each column holds the file's cells under that header, read from the text itself (not
    /// through the run CSV reader), empty cells as NaN; the events file beside it is read.
    #[test]
    fn columns_follow_the_files_header() {
        let dir = scratch("columns");
        let path = dir.join("run.csv");
        let samples: Vec<RunSample> = (0..50)
            .map(|i| {
                let t = 0.005 * f64::from(i + 1);
                let mut s = RunSample::new(
                    t,
                    Sides::new(24.0 + t, 23.5 - t),
                    Sides::new(1.0 + t, -2.0 + t),
                    Sides::new(0.3, -0.3 + t),
                );
                s.yaw_rad = Some(0.1 * t);
                s.pitch_deg = (i % 2 == 0).then_some(2.0 + t);
                if i % 10 == 0 {
                    (s.x_m, s.y_m) = (Some(t), Some(-t));
                }
                s
            })
            .collect();
        write_run_csv_atomically(&path, crate::log::Existing::Replace, &samples).expect("written");
        std::fs::write(
            events_path(&path),
            "{\"t_s\":0.1,\"kind\":\"samples-lost\",\"after_seq\":3,\"missing\":2}\n",
        )
        .expect("events written");
        let text = std::fs::read_to_string(&path).expect("read back");
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().expect("header").split(',').collect();
        let cells: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
        let mut reader = Reader::new(false, RigRange::default(), |_: &str| {});
        let columns = read_run_columns(&path, &mut reader).expect("read");
        assert_eq!(columns.rows(), samples.len());
        for (index, column) in Column::ALL.iter().enumerate() {
            let at = header
                .iter()
                .position(|h| *h == column.name())
                .expect("column in header");
            for (row, value) in cells.iter().zip(&columns.values[index]) {
                let cell = row[at];
                if cell.is_empty() {
                    assert!(value.is_nan(), "{}: {value}", column.name());
                } else {
                    assert_eq!(
                        cell.parse::<f64>().expect("number"),
                        *value,
                        "{}",
                        column.name()
                    );
                }
            }
        }
        assert_eq!(
            columns.events_json(),
            serde_json::json!([{"t_s": 0.1, "kind": "samples-lost", "after_seq": 3, "missing": 2}])
        );
        std::fs::remove_dir_all(dir).expect("cleaned up");
    }

    /// The estimate of a run CSV's rows is a little above its count, and 0 for a file that
    /// cannot be read (whose error the reader words).
    #[test]
    fn a_run_csvs_rows_are_estimated_from_its_head() {
        let dir = scratch("estimate");
        let path = dir.join("run.csv");
        let samples: Vec<RunSample> = (0..20_000)
            .map(|i| {
                let t = 0.005 * f64::from(i);
                RunSample::new(
                    t,
                    Sides::new(24.0, 23.5),
                    Sides::new(1.5, -2.25),
                    Sides::new(0.3, -0.3),
                )
            })
            .collect();
        write_run_csv_atomically(&path, crate::log::Existing::Replace, &samples).expect("written");
        let estimate = estimated_csv_rows(&path);
        assert!((20_000..=24_000 + 1024).contains(&estimate), "{estimate}");
        assert_eq!(estimated_csv_rows(&dir.join("missing.csv")), 0);
        std::fs::remove_dir_all(dir).expect("cleaned up");
    }

    /// The estimate of an MCAP log's samples is near their count for a run as the recorder
    /// logs it (the simulated board's frames, model and status frames, commands, events), and
    /// 0 for a file that cannot be read.
    #[test]
    fn an_mcap_logs_samples_are_estimated_from_its_length() {
        let dir = scratch("estimate-mcap");
        let path = dir.join("run.mcap");
        let (run, _) = crate::log::mcap::tests::sim_run(20_000);
        let file = std::fs::File::create(&path).expect("created");
        crate::log::mcap::write_mcap_run(file, &run).expect("written");
        let (n, estimate) = (run.samples.len(), estimated_mcap_samples(&path));
        assert!((n / 2..=2 * n).contains(&estimate), "{estimate} for {n}");
        assert_eq!(estimated_mcap_samples(&dir.join("missing.mcap")), 0);
        std::fs::remove_dir_all(dir).expect("cleaned up");
    }
}
