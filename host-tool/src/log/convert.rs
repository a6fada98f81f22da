//! `convert`: a run log from one format to another (or the same one, normalised), by the files'
//! extensions. Outputs are written whole or not at all ([`super::write_atomically`]).
//!
//! - MCAP → run CSV: the physical samples (with commanded speeds and pose); frames, commands
//!   and events have no place in a run CSV and are dropped.
//! - run CSV → MCAP: the samples exactly on `/rover_power/sample`, plus the wire frames the
//!   board would have sent for them ([`crate::replay::synthesise_frames`]: a hello, sample
//!   frames with the registers quantised at `Scale::BOARD` — 1.25 mV, 0.5 mA — and model
//!   frames), so the file replays like a recording.
//! - MCAP → MCAP: a clean, finished copy (also the way to repair a file cut short by a killed
//!   recorder: everything before the cut is kept, with a summary and footer).
//! - run CSV → run CSV: this tool's canonical column order and number format.

use super::load::{load, LoadError, RunFormat};
use super::mcap::{write_mcap_run, McapError, Truncation};
use super::run_csv::{write_run_csv_atomically, RunCsvFileError};
use super::run_log::RunLog;
use super::{write_atomically, AtomicWriteError};
use std::path::{Path, PathBuf};

/// Why a conversion produced no output.
#[derive(Debug, thiserror::Error)]
pub enum ConvertError {
    /// The output is the input file.
    #[error("{}: the output is the input file; choose another output", path.display())]
    SameFile {
        /// The file.
        path: PathBuf,
    },
    /// The input could not be loaded, or a file's extension names no known format.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// Writing the run CSV failed.
    #[error(transparent)]
    Csv(#[from] RunCsvFileError),
    /// Writing the MCAP file failed.
    #[error("{}: {source}", path.display())]
    Mcap {
        /// The output file.
        path: PathBuf,
        /// Why.
        #[source]
        source: McapError,
    },
}

/// What a conversion did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Converted {
    /// The input's format.
    pub from: RunFormat,
    /// The output's format.
    pub to: RunFormat,
    /// Samples written.
    pub samples: usize,
    /// Wire frames written (0 for a run CSV).
    pub frames: usize,
    /// Whether the frames were synthesised from the samples (CSV input).
    pub synthesised_frames: bool,
    /// The input MCAP file was cut short here; the output holds what came before.
    pub truncated: Option<Truncation>,
}

/// Writes `run` to `path` in the format its extension names, all or nothing. A run CSV keeps
/// the samples only.
pub fn save_run(path: &Path, run: &RunLog) -> Result<RunFormat, ConvertError> {
    let format = RunFormat::of(path)?;
    match format {
        RunFormat::Csv => {
            write_run_csv_atomically(path, &run.samples)?;
        }
        RunFormat::Mcap => {
            write_atomically(path, |out| write_mcap_run(out, run).map(|_| ())).map_err(|e| {
                let source = match e {
                    AtomicWriteError::Io { source, path } => McapError::Io { path, source },
                    AtomicWriteError::Content(e) => e,
                };
                ConvertError::Mcap {
                    path: path.to_owned(),
                    source,
                }
            })?;
        }
    }
    Ok(format)
}

/// Converts the run log `input` into `output` (formats by extension, see the module docs).
/// Refuses to write over the input; leaves `output` untouched on any error.
pub fn convert(input: &Path, output: &Path) -> Result<Converted, ConvertError> {
    let to = RunFormat::of(output)?;
    if same_file(input, output) {
        return Err(ConvertError::SameFile {
            path: output.to_owned(),
        });
    }
    let loaded = load(input)?;
    let mut run = loaded.run;
    let synthesised_frames =
        to == RunFormat::Mcap && loaded.format == RunFormat::Csv && run.frames.is_empty();
    if synthesised_frames {
        run.frames = crate::replay::synthesise_frames(&run.samples);
    }
    save_run(output, &run)?;
    Ok(Converted {
        from: loaded.format,
        to,
        samples: run.samples.len(),
        frames: if to == RunFormat::Mcap {
            run.frames.len()
        } else {
            0
        },
        synthesised_frames,
        truncated: loaded.truncated,
    })
}

/// Whether `a` and `b` name the same existing file (same path, symlink or hard link).
pub fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        matches!(
            (a.canonicalize(), b.canonicalize()),
            (Ok(x), Ok(y)) if x == y
        )
    }
}
