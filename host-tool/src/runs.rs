//! Run logs read for analysis, the sequence `validate`, `plot` and `diagnose` share: load each
//! file (.mcap or .csv, with a progress bar), then validate them together.

use crate::figures::RunSamples;
use crate::log::load::{load_salvaging, refuse_duplicate_runs, LoadError};
use crate::log::mcap::{Loss, Truncation};
use crate::log::run_csv::{DroppedRow, RunSample};
use crate::log::run_log::RunLog;
use crate::progress;
use crate::validate::{self, RunInput, ValidateError, ValidateOptions, ValidationReport};
use model_core::Rover;
use std::path::{Path, PathBuf};

/// Loaded runs, named by their paths as given.
#[derive(Debug, Clone, Default)]
pub struct Runs {
    /// Each run's name (its path as given).
    pub names: Vec<String>,
    /// Each run's log.
    pub logs: Vec<RunLog>,
    /// MCAP files that ended before their footer (a killed recorder) and how much was used.
    pub truncated: Vec<(PathBuf, Truncation)>,
    /// What damage cost each file, one warning per stretch or row ([`damage_warnings`]).
    pub damage: Vec<String>,
    /// Whether data inside a file was lost to damage (not just a cut end).
    pub lost_data: bool,
}

impl Runs {
    /// Reads `paths` in order; with `salvage` damaged run CSV rows are left out instead of
    /// refused (damaged MCAP stretches are always skipped and listed). The same run given twice
    /// is refused: it would count as two independent repeats.
    pub fn load(paths: &[PathBuf], salvage: bool) -> Result<Runs, LoadError> {
        let bar = progress::bar(paths.len() as u64, "reading runs");
        let mut runs = Runs::default();
        for path in paths {
            let loaded = load_salvaging(path, salvage)?;
            if let Some(t) = loaded.truncated {
                runs.truncated.push((path.clone(), t));
            }
            runs.damage
                .extend(damage_warnings(path, &loaded.losses, &loaded.dropped_rows));
            runs.lost_data |= loaded.lost_data();
            runs.names.push(path.display().to_string());
            runs.logs.push(loaded.run);
            bar.inc(1);
        }
        bar.finish_and_clear();
        refuse_duplicate_runs(&runs.names, &runs.logs)?;
        Ok(runs)
    }

    /// The runs as `validate`'s input.
    pub fn inputs(&self) -> Vec<RunInput<'_>> {
        self.names
            .iter()
            .zip(&self.logs)
            .map(|(name, log)| RunInput::from_log(name, log))
            .collect()
    }

    /// Validates the runs together ([`validate::validate`]).
    pub fn validate(
        &self,
        rover: &Rover,
        options: &ValidateOptions,
    ) -> Result<ValidationReport, ValidateError> {
        validate::validate(rover, &self.inputs(), options)
    }

    /// Each run's samples, named, for the figures.
    pub fn samples(&self) -> Vec<RunSamples<'_>> {
        self.names
            .iter()
            .zip(&self.logs)
            .map(|(name, log)| RunSamples {
                name,
                samples: &log.samples,
            })
            .collect()
    }

    /// Each run's samples.
    pub fn sample_slices(&self) -> Vec<&[RunSample]> {
        self.logs.iter().map(|l| l.samples.as_slice()).collect()
    }
}

/// The warning for a truncated MCAP file.
pub fn truncation_warning(path: &Path, t: &Truncation) -> String {
    format!(
        "warning: {} ends before its footer (recorder killed?): using its first {} of {} bytes",
        path.display(),
        t.complete_bytes,
        t.file_bytes
    )
}

/// One warning per damaged stretch of an MCAP file and per dropped run CSV row.
pub fn damage_warnings(path: &Path, losses: &[Loss], dropped_rows: &[DroppedRow]) -> Vec<String> {
    let losses = losses
        .iter()
        .map(|loss| format!("warning: {}: damaged, skipped {loss}", path.display()));
    let rows = dropped_rows.iter().map(|row| {
        let why = if row.cut {
            "the file ends inside it (cut by a kill or a full disk)"
        } else {
            "damaged"
        };
        format!(
            "warning: {}: line {} dropped, {why}: {}",
            path.display(),
            row.line,
            row.reason
        )
    });
    losses.chain(rows).collect()
}
