//! Where the hard-ground baseline is fitted from: the calibration manoeuvres of the diagnosed
//! runs themselves (straights, point turns, R ≥ 2R′; [`cv`]'s folds refit it on each training
//! fold), or separate calibration runs (`--calibration`), whose calibration manoeuvres fit one
//! baseline used in every fold and which are never scored.
//!
//! With calibration runs, each cross-validation fold fits the effect on the training rows of the
//! diagnosed runs plus the calibration manoeuvres (weight 1 each: as with in-run calibration, an
//! effect must not claim power on the manoeuvres the model is trusted on), and scores it on the
//! held-out diagnosed rows only.

use super::baseline::family::{self, Members};
use super::baseline::{Baseline, BaselineError};
use super::features::TurnRow;
use model_core::Rover;
use serde::Serialize;

/// Where the baseline's calibration manoeuvres came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CalibrationSource {
    /// The diagnosed runs' own straights, point turns and wide turns (no calibration runs given).
    Runs,
    /// Separate calibration runs.
    CalibrationFiles,
}

impl CalibrationSource {
    /// Stable id (`runs`, `calibration-files`).
    pub const fn id(self) -> &'static str {
        match self {
            CalibrationSource::Runs => "runs",
            CalibrationSource::CalibrationFiles => "calibration-files",
        }
    }
}

/// What the baseline was fitted on (the JSON's `calibration`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct CalibrationNote {
    /// Runs or calibration files.
    pub source: CalibrationSource,
    /// Calibration manoeuvres the baseline was fitted on (all folds together).
    pub manoeuvres: usize,
}

/// Where the calibration manoeuvres are: in the diagnosed runs, or in separate runs.
#[derive(Debug, Clone, Copy)]
pub enum Source<'a> {
    /// The calibration-kind rows of the diagnosed rows (refitted per fold).
    FromRuns,
    /// Rows of calibration runs (only their calibration-kind rows are used).
    Rows(&'a [TurnRow]),
}

/// The calibration of a diagnosis: where its manoeuvres are and which baseline family members
/// are fitted to them.
#[derive(Debug, Clone, Copy)]
pub struct Calibration<'a> {
    /// Where the calibration manoeuvres are.
    pub source: Source<'a>,
    /// The family members the baseline is chosen from.
    pub members: Members,
}

impl<'a> Calibration<'a> {
    /// The diagnosed runs' own calibration manoeuvres, the default family.
    pub const FROM_RUNS: Calibration<'static> = Calibration {
        source: Source::FromRuns,
        members: Members::Escalating,
    };

    /// The calibration manoeuvres of calibration runs' `rows`, the default family.
    pub const fn rows(rows: &'a [TurnRow]) -> Self {
        Calibration {
            source: Source::Rows(rows),
            members: Members::Escalating,
        }
    }

    /// The same calibration with the baseline chosen from `members`.
    pub const fn with_members(self, members: Members) -> Self {
        Calibration { members, ..self }
    }

    /// The calibration manoeuvres of this calibration for diagnosed `rows`.
    pub fn manoeuvres<'r>(&self, rows: &'r [TurnRow]) -> Vec<&'r TurnRow>
    where
        'a: 'r,
    {
        let of: &'r [TurnRow] = match self.source {
            Source::FromRuns => rows,
            Source::Rows(cal) => cal,
        };
        of.iter().filter(|r| r.calibration_kind).collect()
    }

    /// The note for reports.
    pub fn note(&self, rows: &[TurnRow]) -> CalibrationNote {
        CalibrationNote {
            source: match self.source {
                Source::FromRuns => CalibrationSource::Runs,
                Source::Rows(_) => CalibrationSource::CalibrationFiles,
            },
            manoeuvres: self.manoeuvres(rows).len(),
        }
    }

    /// The baseline on all calibration manoeuvres.
    pub fn baseline(&self, rover: &Rover, rows: &[TurnRow]) -> Result<Baseline, BaselineError> {
        self.baseline_on(rover, &self.manoeuvres(rows))
    }

    /// The baseline fitted on `manoeuvres` (e.g. a cross-validation fold's) from this
    /// calibration's family members.
    pub fn baseline_on(
        &self,
        rover: &Rover,
        manoeuvres: &[&TurnRow],
    ) -> Result<Baseline, BaselineError> {
        family::choose(rover, manoeuvres, self.members)
    }

    /// The rows an effect is fitted on when it is fitted on everything (the model file): the
    /// diagnosed rows, plus the calibration manoeuvres of calibration runs.
    pub fn training_rows<'r>(&self, rows: &'r [TurnRow]) -> Vec<&'r TurnRow>
    where
        'a: 'r,
    {
        let mut train: Vec<&TurnRow> = rows.iter().collect();
        if let Source::Rows(_) = self.source {
            train.extend(self.manoeuvres(rows));
        }
        train
    }
}

#[cfg(test)]
mod tests;
