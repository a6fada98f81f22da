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
//! - `files`: the JSON and the `--out` directory; `names`: the names of its files.

mod files;
mod markdown;
mod names;
mod tables;
mod terminal;
mod words;

pub use files::{write_json, write_out_dir, ReportError};
pub use markdown::markdown;
pub use names::{GROWTH_FIGURE, MODEL_FILE, REPORT_FILE, RESIDUALS_FIGURE};
pub use terminal::table;
pub use words::{adequacy_summary, calibration_line, conclusion, findings, next_runs_lines};

#[cfg(test)]
mod tests;
