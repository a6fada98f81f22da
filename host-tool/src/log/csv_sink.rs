//! A recording written as a run CSV as it happens, with its events in a JSON-lines file beside it
//! (`run.csv` → `run.events.jsonl`): the run CSV holds physical samples only, so the marks a
//! recording needs (device vanished, reconnected, board reset, samples lost, stop) go there.
//!
//! Crash safety: both files are append-only. The header is on disk before the first sample; rows
//! are kept in memory and appended whole at each [`RunLogSink::flush`] (the recorder flushes every
//! 200 ms) with one write, so a killed process leaves a valid run CSV up to the last flush. A kill
//! that lands inside that write can leave the last row cut; the run CSV reader then reports it
//! (a row with too few cells, or a cell that is not a number), unless the cut falls inside the
//! last cell of the row — the `y_m` cell, empty unless a tracker's position is recorded.
//! [`RunLogSink::finish`] flushes and fsyncs both files.

use super::commands::CommandRow;
use super::run_csv::{RunCsvError, RunCsvWriter, RunSample};
use super::run_log::{LogEvent, RunLog, RunLogSink};
use model_core::wire::BoardFrame;
use std::fs::{File, OpenOptions};
use std::io::{self, BufRead, Write};
use std::path::{Path, PathBuf};

/// Rows kept in memory at most between flushes before they are appended anyway [bytes].
const MAX_BUFFERED: usize = 1 << 20;

/// The events file that goes with a run CSV: `run.csv` → `run.events.jsonl`.
pub fn events_path(csv_path: &Path) -> PathBuf {
    csv_path.with_extension("events.jsonl")
}

/// A run CSV (and its events file) being written live.
#[derive(Debug)]
pub struct CsvRunSink {
    rows: RunCsvWriter<Vec<u8>>,
    csv: File,
    events: File,
    events_buf: Vec<u8>,
    paths: [PathBuf; 2],
}

/// One line of the events file.
#[derive(serde::Serialize, serde::Deserialize)]
struct EventLine {
    t_s: f64,
    #[serde(flatten)]
    event: LogEvent,
}

fn csv_error(e: RunCsvError) -> io::Error {
    match e {
        RunCsvError::Io(e) => e,
        other => io::Error::new(io::ErrorKind::InvalidData, other),
    }
}

impl CsvRunSink {
    /// Creates `path` (and its [`events_path`]) with the header on disk. An existing file is an
    /// error unless `overwrite`, so a recording is never clobbered by accident.
    pub fn create(path: &Path, overwrite: bool) -> io::Result<Self> {
        let open = |p: &Path| {
            let mut o = OpenOptions::new();
            o.write(true);
            if overwrite {
                o.create(true).truncate(true);
            } else {
                o.create_new(true);
            }
            o.open(p).map_err(|e| {
                let hint = if e.kind() == io::ErrorKind::AlreadyExists {
                    " (it exists; choose another name or overwrite it explicitly)"
                } else {
                    ""
                };
                io::Error::new(e.kind(), format!("{}: {e}{hint}", p.display()))
            })
        };
        let events_path = events_path(path);
        let mut csv = open(path)?;
        let events = open(&events_path)?;
        let mut rows = RunCsvWriter::new(Vec::new()).map_err(csv_error)?;
        csv.write_all(&std::mem::take(rows.get_mut()))?;
        csv.flush()?;
        Ok(Self {
            rows,
            csv,
            events,
            events_buf: Vec::new(),
            paths: [path.to_owned(), events_path],
        })
    }

    /// Rows written (or waiting for the next flush).
    pub fn rows(&self) -> u64 {
        self.rows.rows()
    }

    /// The run CSV's path and the events file's path.
    pub fn paths(&self) -> &[PathBuf; 2] {
        &self.paths
    }

    fn append(&mut self) -> io::Result<()> {
        let rows = std::mem::take(self.rows.get_mut());
        if !rows.is_empty() {
            self.csv.write_all(&rows)?;
        }
        if !self.events_buf.is_empty() {
            self.events.write_all(&self.events_buf)?;
            self.events_buf.clear();
        }
        Ok(())
    }
}

impl RunLogSink for CsvRunSink {
    /// Wire frames are not part of a run CSV.
    fn frame(&mut self, _t_s: f64, _frame: &BoardFrame) -> io::Result<()> {
        Ok(())
    }

    fn sample(&mut self, sample: &RunSample) -> io::Result<()> {
        self.rows.write(sample).map_err(csv_error)?;
        if self.rows.get_mut().len() >= MAX_BUFFERED {
            self.append()?;
        }
        Ok(())
    }

    /// Commands are in the rows' `cmd_*_mps` columns.
    fn command(&mut self, _row: &CommandRow) -> io::Result<()> {
        Ok(())
    }

    fn event(&mut self, t_s: f64, event: &LogEvent) -> io::Result<()> {
        let line = EventLine {
            t_s,
            event: event.clone(),
        };
        serde_json::to_writer(&mut self.events_buf, &line).map_err(io::Error::other)?;
        self.events_buf.push(b'\n');
        Ok(())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.append()
    }

    fn finish(&mut self) -> io::Result<()> {
        self.append()?;
        self.csv.sync_all()?;
        self.events.sync_all()
    }
}

/// What is wrong with an events file.
#[derive(Debug, thiserror::Error)]
pub enum EventsFileError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// A line is not an event (a cut last line after a kill, or not our format).
    #[error("{}: line {line}: {source}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// Why.
        #[source]
        source: serde_json::Error,
    },
}

/// Reads an events file written by [`CsvRunSink`]: events at their run time [s].
pub fn read_events(path: &Path) -> Result<Vec<(f64, LogEvent)>, EventsFileError> {
    let io_err = |source| EventsFileError::Io {
        path: path.to_owned(),
        source,
    };
    let file = File::open(path).map_err(io_err)?;
    let mut events = Vec::new();
    for (i, line) in io::BufReader::new(file).lines().enumerate() {
        let line = line.map_err(io_err)?;
        if line.trim().is_empty() {
            continue;
        }
        let parsed: EventLine =
            serde_json::from_str(&line).map_err(|source| EventsFileError::Line {
                path: path.to_owned(),
                line: i as u64 + 1,
                source,
            })?;
        events.push((parsed.t_s, parsed.event));
    }
    Ok(events)
}

/// Why a recorded run CSV could not be read back.
#[derive(Debug, thiserror::Error)]
pub enum CsvRunLogError {
    /// The run CSV.
    #[error(transparent)]
    Csv(#[from] super::run_csv::RunCsvFileError),
    /// Its events file.
    #[error(transparent)]
    Events(#[from] EventsFileError),
}

/// Reads a run CSV and, when it exists, its events file into a [`RunLog`] (no frames or
/// commands: a run CSV does not hold them).
pub fn read_csv_run_log(path: &Path) -> Result<RunLog, CsvRunLogError> {
    let samples = super::run_csv::read_run_csv(path)?;
    let events_path = events_path(path);
    let events = if events_path.exists() {
        read_events(&events_path)?
    } else {
        Vec::new()
    };
    Ok(RunLog {
        samples,
        events,
        ..RunLog::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::run_csv::read_run_csv;
    use crate::log::tests_support::TempDir;
    use model_core::Sides;

    fn sample(t_s: f64) -> RunSample {
        RunSample {
            t_s,
            bus_v: Sides::new(24.5, 24.4),
            current_a: Sides::new(1.5, -0.5),
            cmd_mps: Sides::new(0.2, 0.4),
            yaw_rad: None,
            pitch_deg: Some(1.5),
            x_m: None,
            y_m: None,
        }
    }

    #[test]
    fn rows_reach_the_file_at_each_flush_and_events_go_beside_it() {
        let dir = TempDir::new("csv-sink");
        let path = dir.path().join("run.csv");
        let mut sink = CsvRunSink::create(&path, false).expect("create");
        // The header is on disk before any sample: an immediate kill leaves a valid, empty run.
        assert!(read_run_csv(&path).expect("header only").is_empty());
        sink.event(
            0.0,
            &LogEvent::Started {
                port: "/dev/ttyACM0".into(),
            },
        )
        .expect("event");
        sink.sample(&sample(0.0)).expect("row");
        sink.sample(&sample(0.005)).expect("row");
        assert!(
            read_run_csv(&path).expect("valid").is_empty(),
            "not flushed yet"
        );
        sink.flush().expect("flush");
        assert_eq!(
            read_run_csv(&path).expect("valid"),
            vec![sample(0.0), sample(0.005)]
        );
        sink.event(0.005, &LogEvent::DeviceVanished { port: "p".into() })
            .expect("event");
        sink.sample(&sample(0.01)).expect("row");
        // A row the reader would refuse is refused here, with the reader's message.
        let e = sink.sample(&sample(0.01)).expect_err("time repeats");
        assert!(e.to_string().contains("not after"), "{e}");
        sink.finish().expect("finish");
        let log = read_csv_run_log(&path).expect("log");
        assert_eq!(log.samples.len(), 3);
        assert_eq!(
            log.events,
            vec![
                (
                    0.0,
                    LogEvent::Started {
                        port: "/dev/ttyACM0".into()
                    }
                ),
                (0.005, LogEvent::DeviceVanished { port: "p".into() })
            ]
        );
        assert!(std::fs::read_to_string(events_path(&path))
            .expect("events")
            .starts_with(r#"{"t_s":0.0,"kind":"started","port":"/dev/ttyACM0"}"#));
    }

    #[test]
    fn an_existing_recording_is_not_clobbered_unless_asked() {
        let dir = TempDir::new("csv-sink-exists");
        let path = dir.path().join("run.csv");
        std::fs::write(&path, "precious").expect("write");
        let e = CsvRunSink::create(&path, false).expect_err("exists");
        assert_eq!(e.kind(), io::ErrorKind::AlreadyExists);
        assert!(e.to_string().contains("run.csv"), "{e}");
        assert_eq!(std::fs::read_to_string(&path).expect("read"), "precious");
        CsvRunSink::create(&path, true).expect("overwrite");
        assert!(read_run_csv(&path).expect("header").is_empty());
    }

    #[test]
    fn a_row_cut_by_a_kill_is_dropped_and_reported_by_the_reader() {
        let dir = TempDir::new("csv-sink-cut");
        let path = dir.path().join("run.csv");
        let mut sink = CsvRunSink::create(&path, false).expect("create");
        sink.sample(&sample(0.0)).expect("row");
        sink.sample(&sample(1.0)).expect("row");
        sink.finish().expect("finish");
        let text = std::fs::read_to_string(&path).expect("read");
        // Cut anywhere before the last row's final comma: the reader drops the row, names its
        // line and keeps the rows before it.
        let last_row_start = text[..text.len() - 1].rfind('\n').expect("rows") + 1;
        let last_comma = text.rfind(',').expect("comma");
        for cut in last_row_start + 1..=last_comma {
            std::fs::write(&path, &text[..cut]).expect("write");
            let range = crate::log::run_csv::RigRange::default();
            let (rows, dropped) =
                crate::log::run_csv::read_run_csv_salvaging(&path, false, range).expect("cut row");
            assert_eq!(rows, vec![sample(0.0)], "{cut}");
            assert_eq!(dropped.len(), 1, "{cut}");
            assert!(
                dropped[0].cut && dropped[0].line == 3,
                "{cut}: {:?}",
                dropped[0]
            );
        }
        let e = {
            std::fs::write(events_path(&path), "{\"t_s\":0.0,\"kind\":\"sta").expect("write");
            read_events(&events_path(&path)).expect_err("cut event")
        };
        assert!(e.to_string().contains("line 1"), "{e}");
    }
}
