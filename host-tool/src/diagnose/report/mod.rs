//! The diagnosis' outputs: the terminal table ([`table`]), the JSON ([`write_json`]:
//! [`Diagnosis::to_json`](super::Diagnosis::to_json), which carries the calibration note) and the
//! `--out` directory ([`write_out_dir`]: `diagnosis.md` with the figures embedded, the figures as
//! PNG and SVG, and `model.toml` for `plan --model`). Every file is written atomically.
//!
//! - `words`: the diagnosis in lines: the conclusion, the findings, the baseline and its
//!   adequacy, what to drive next;
//! - `tables`: the tables both outputs print (gaps, candidates, signatures, per regime) and
//!   their two layouts;
//! - `terminal`: the terminal table; `markdown`: `diagnosis.md`;
//! - `files`: the JSON and the `--out` directory.

use super::baseline::BaselineError;
use super::model_file::ModelFileError;
use crate::log::AtomicWriteError;
use crate::plan::ModelError;
use crate::plot::PlotError;
use std::io;
use std::path::PathBuf;

mod files;
mod markdown;
mod tables;
mod terminal;
mod words;

pub use files::{write_json, write_out_dir};
pub use markdown::markdown;
pub use terminal::table;
pub use words::{adequacy_summary, calibration_line, conclusion, findings, next_runs_lines};

/// The Markdown report's file name in the output directory.
pub const REPORT_FILE: &str = "diagnosis.md";
/// The model file's name in the output directory.
pub const MODEL_FILE: &str = "model.toml";
/// Figure of held-out residuals vs R/R′ (without extension).
pub const RESIDUALS_FIGURE: &str = "residuals-vs-radius";
/// Figure of growth through the turn vs R/R′ (without extension).
pub const GROWTH_FIGURE: &str = "growth-vs-radius";

/// Why an output was not written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Recomputing the held-out residuals for the figures failed.
    #[error(transparent)]
    Baseline(#[from] BaselineError),
    /// The scheme of the diagnosis has fewer than 2 groups (cannot happen for a diagnosis).
    #[error("no held-out residuals to draw")]
    NothingToHoldOut,
    /// A figure could not be drawn or written.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// The plan model could not be made.
    #[error("model file: {0}")]
    ModelFile(#[from] ModelFileError),
    /// The plan model could not be written as TOML.
    #[error("model file: {0}")]
    Model(#[from] ModelError),
    /// The output directory could not be created.
    #[error("{}: {source}", path.display())]
    Dir {
        /// The directory.
        path: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// A file could not be written (a previous file of that name is untouched).
    #[error(transparent)]
    Write(#[from] AtomicWriteError<io::Error>),
}

#[cfg(test)]
mod tests;
