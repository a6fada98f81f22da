//! Reading a run log whatever its format, chosen by the file's extension: `.mcap` (see
//! [`super::mcap`]) or `.csv` (the run CSV, [`super::run_csv`]).

use super::mcap::{read_mcap_run, Loss, McapError, Truncation};
use super::run_csv::{read_run_csv_salvaging, DroppedRow, RunCsvFileError};
use super::run_log::RunLog;
use std::fmt;
use std::path::{Path, PathBuf};

/// A run log file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunFormat {
    /// The run CSV (`.csv`): physical samples only.
    Csv,
    /// MCAP (`.mcap`): frames, samples, commands and events.
    Mcap,
}

impl RunFormat {
    /// The format of `path` by its extension (case-insensitive).
    pub fn of(path: &Path) -> Result<RunFormat, LoadError> {
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match extension.as_deref() {
            Some("csv") => Ok(RunFormat::Csv),
            Some("mcap") => Ok(RunFormat::Mcap),
            _ => Err(LoadError::UnknownFormat {
                path: path.to_owned(),
            }),
        }
    }
}

impl fmt::Display for RunFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            RunFormat::Csv => "run CSV",
            RunFormat::Mcap => "MCAP",
        })
    }
}

/// Why a run log could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The extension names no format this tool reads.
    #[error("{}: unknown run log format (supported: .mcap, .csv)", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The run CSV is unreadable or invalid.
    #[error(transparent)]
    Csv(#[from] RunCsvFileError),
    /// The MCAP file is unreadable, damaged or not a rover-power run.
    #[error(transparent)]
    Mcap(#[from] McapError),
}

/// A run log as loaded, with what the caller should tell the user about it.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedRun {
    /// The run.
    pub run: RunLog,
    /// The file's format.
    pub format: RunFormat,
    /// For an MCAP file cut short (recorder killed): where; the run holds what came before.
    pub truncated: Option<Truncation>,
    /// For a damaged MCAP file: the stretches skipped (the run holds everything else).
    pub losses: Vec<Loss>,
    /// For a run CSV: the rows left out (a cut last row; damaged rows with salvage).
    pub dropped_rows: Vec<DroppedRow>,
}

impl LoadedRun {
    /// Whether data inside the file was lost to damage (not counting a cut end: a truncated
    /// MCAP file or a cut last CSV row, which a killed recorder leaves).
    pub fn lost_data(&self) -> bool {
        !self.losses.is_empty() || self.dropped_rows.iter().any(|r| !r.cut)
    }
}

/// Loads the run log at `path` (`.mcap` or `.csv`), reporting a truncated or damaged MCAP file
/// and a cut last CSV row; a damaged CSV row is an error.
pub fn load(path: &Path) -> Result<LoadedRun, LoadError> {
    load_salvaging(path, false)
}

/// [`load`], and with `salvage` damaged CSV rows are left out (and listed) instead of refused.
/// (A damaged MCAP file is always salvaged: its losses are listed.)
pub fn load_salvaging(path: &Path, salvage: bool) -> Result<LoadedRun, LoadError> {
    match RunFormat::of(path)? {
        RunFormat::Csv => {
            let (samples, dropped_rows) = read_run_csv_salvaging(path, salvage)?;
            Ok(LoadedRun {
                run: RunLog {
                    samples,
                    ..RunLog::default()
                },
                format: RunFormat::Csv,
                truncated: None,
                losses: Vec::new(),
                dropped_rows,
            })
        }
        RunFormat::Mcap => {
            let mcap = read_mcap_run(path)?;
            Ok(LoadedRun {
                run: mcap.run,
                format: RunFormat::Mcap,
                truncated: mcap.truncated,
                losses: mcap.losses,
                dropped_rows: Vec::new(),
            })
        }
    }
}

/// Loads the run log at `path` (`.mcap` or `.csv`). A truncated MCAP file loads up to its last
/// complete record; use [`load`] to learn whether it was.
pub fn load_run(path: &Path) -> Result<RunLog, LoadError> {
    load(path).map(|loaded| loaded.run)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::tests_support::TempDir;

    #[test]
    fn format_by_extension() {
        assert_eq!(
            RunFormat::of(Path::new("a/run.csv")).ok(),
            Some(RunFormat::Csv)
        );
        assert_eq!(
            RunFormat::of(Path::new("run.MCAP")).ok(),
            Some(RunFormat::Mcap)
        );
        for bad in ["run.txt", "run", "run.csv.gz", ".mcap"] {
            let e = RunFormat::of(Path::new(bad)).expect_err(bad);
            assert_eq!(
                e.to_string(),
                format!("{bad}: unknown run log format (supported: .mcap, .csv)")
            );
        }
    }

    #[test]
    fn csv_loads_samples_only_and_errors_name_the_file() {
        let dir = TempDir::new("load-csv");
        let path = dir.path().join("run.csv");
        std::fs::write(
            &path,
            "t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,cmd_left_mps,cmd_right_mps\n\
             0,24,1,24,2,0.1,0.2\n0.005,24,1.5,24,2.5,0.1,0.2\n",
        )
        .expect("write");
        let loaded = load(&path).expect("valid");
        assert_eq!(loaded.format, RunFormat::Csv);
        assert_eq!(loaded.run.samples.len(), 2);
        assert!(loaded.run.frames.is_empty() && loaded.truncated.is_none());

        std::fs::write(&path, "t_s\n").expect("write");
        let e = load_run(&path).expect_err("missing columns");
        assert!(
            e.to_string().starts_with(&path.display().to_string()),
            "{e}"
        );

        let mcap = dir.path().join("run.mcap");
        std::fs::write(&mcap, "t_s,left_bus_v\n").expect("write");
        let e = load_run(&mcap).expect_err("a CSV named .mcap");
        assert!(
            matches!(e, LoadError::Mcap(McapError::NotMcap { .. })),
            "{e}"
        );
        assert!(e.to_string().contains("not an MCAP file"), "{e}");
    }
}
