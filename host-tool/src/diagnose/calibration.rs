//! Where the hard-ground baseline is fitted from: the calibration manoeuvres of the diagnosed
//! runs themselves (straights, point turns, R ≥ 2R′; [`cv`]'s folds refit it on each training
//! fold), or separate calibration runs (`--calibration`), whose calibration manoeuvres fit one
//! baseline used in every fold and which are never scored.
//!
//! With calibration runs, each cross-validation fold fits the effect on the training rows of the
//! diagnosed runs plus the calibration manoeuvres (weight 1 each: as with in-run calibration, an
//! effect must not claim power on the manoeuvres the model is trusted on), and scores it on the
//! held-out diagnosed rows only.

use super::baseline::{Baseline, BaselineError};
use super::cv::{self, CandidateScore, HeldOut, Scheme};
use super::effects::{fitted_params, Context, FittedEffect};
use super::features::TurnRow;
use crate::sim::world::EffectId;
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

/// The calibration of a diagnosis: in the runs, or the calibration manoeuvres of separate runs.
#[derive(Debug, Clone, Copy)]
pub enum Calibration<'a> {
    /// The calibration-kind rows of the diagnosed rows (refitted per fold).
    FromRuns,
    /// Rows of calibration runs (only their calibration-kind rows are used).
    Rows(&'a [TurnRow]),
}

impl<'a> Calibration<'a> {
    /// The calibration manoeuvres of this calibration for diagnosed `rows`.
    pub fn manoeuvres<'r>(&self, rows: &'r [TurnRow]) -> Vec<&'r TurnRow>
    where
        'a: 'r,
    {
        let of: &'r [TurnRow] = match self {
            Calibration::FromRuns => rows,
            Calibration::Rows(cal) => cal,
        };
        of.iter().filter(|r| r.calibration_kind).collect()
    }

    /// The note for reports.
    pub fn note(&self, rows: &[TurnRow]) -> CalibrationNote {
        CalibrationNote {
            source: match self {
                Calibration::FromRuns => CalibrationSource::Runs,
                Calibration::Rows(_) => CalibrationSource::CalibrationFiles,
            },
            manoeuvres: self.manoeuvres(rows).len(),
        }
    }

    /// The baseline on all calibration manoeuvres.
    pub fn baseline(&self, rover: &Rover, rows: &[TurnRow]) -> Result<Baseline, BaselineError> {
        Baseline::fit(rover, &self.manoeuvres(rows))
    }

    /// The rows an effect is fitted on when it is fitted on everything (the model file): the
    /// diagnosed rows, plus the calibration manoeuvres of calibration runs.
    pub fn training_rows<'r>(&self, rows: &'r [TurnRow]) -> Vec<&'r TurnRow>
    where
        'a: 'r,
    {
        let mut train: Vec<&TurnRow> = rows.iter().collect();
        if let Calibration::Rows(_) = self {
            train.extend(self.manoeuvres(rows));
        }
        train
    }

    /// [`cv::heldout_residuals`] under this calibration: held-out residuals of every diagnosed
    /// row, before (`effect` `None`) or after adding `effect`; `Ok(None)` when `scheme` has
    /// fewer than 2 groups.
    pub fn heldout_residuals(
        &self,
        rover: &Rover,
        rows: &[TurnRow],
        scheme: Scheme,
        effect: Option<EffectId>,
    ) -> Result<Option<HeldOut>, BaselineError> {
        let Calibration::Rows(cal) = self else {
            return cv::heldout_residuals(rover, rows, scheme, effect);
        };
        let mut groups: Vec<i64> = rows.iter().map(|r| group(scheme, r)).collect();
        groups.sort_unstable();
        groups.dedup();
        if groups.len() < 2 {
            return Ok(None);
        }
        let cal: Vec<&TurnRow> = cal.iter().filter(|r| r.calibration_kind).collect();
        let baseline = Baseline::fit(rover, &cal)?;
        let ctx = Context {
            rover,
            baseline: &baseline,
        };
        let mut out = Vec::with_capacity(rows.len());
        for g in groups {
            let mut train: Vec<&TurnRow> = rows.iter().filter(|r| group(scheme, r) != g).collect();
            train.extend(cal.iter().copied());
            let fitted = effect.and_then(|e| FittedEffect::fit(e, &train, &ctx).ok());
            for (i, row) in rows
                .iter()
                .enumerate()
                .filter(|(_, r)| group(scheme, r) == g)
            {
                let mut res = baseline.residual_w(row);
                if let Some(f) = &fitted {
                    for (side, r) in res.iter_mut().enumerate() {
                        *r -= f.extra_w(row, side, &ctx);
                    }
                }
                out.push((i, res));
            }
        }
        out.sort_by_key(|(i, _)| *i);
        Ok(Some(out))
    }

    /// [`cv::score_all`] under this calibration.
    pub fn score_all(
        &self,
        rover: &Rover,
        rows: &[TurnRow],
        scheme: Scheme,
    ) -> Result<Option<Vec<CandidateScore>>, BaselineError> {
        if let Calibration::FromRuns = self {
            return cv::score_all(rover, rows, scheme);
        }
        let Some(before) = self.heldout_residuals(rover, rows, scheme, None)? else {
            return Ok(None);
        };
        let rms_before = cv::mean_square(&before, |_| true).unwrap_or(0.0).sqrt();
        let n = before.len() * 2;
        let mut out = Vec::new();
        for effect in EffectId::ALL {
            let Some(after) = self.heldout_residuals(rover, rows, scheme, Some(effect))? else {
                return Ok(None);
            };
            let mse = cv::mean_square(&after, |_| true).unwrap_or(0.0);
            let rms_after = mse.sqrt();
            out.push(CandidateScore {
                effect,
                heldout_error_before: rms_before,
                heldout_error_after: rms_after,
                shrink_pct: if rms_before > 0.0 {
                    100.0 * (1.0 - rms_after / rms_before)
                } else {
                    0.0
                },
                penalised_mse: cv::penalised(mse, n, fitted_params(effect)),
            });
        }
        Ok(Some(out))
    }
}

/// The fold of `row` under `scheme` (as in [`cv`]: run index, or R/R′ to 0.01 with straights
/// one group).
fn group(scheme: Scheme, row: &TurnRow) -> i64 {
    match scheme {
        Scheme::LeaveOneRunOut => row.run_index as i64,
        Scheme::LeaveOneRadiusOut if row.r_over_r_prime.is_finite() => {
            (row.r_over_r_prime * 100.0).round() as i64
        }
        Scheme::LeaveOneRadiusOut => i64::MAX,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::tests::{rows_of, simulate_run};
    use crate::diagnose::{diagnose, diagnose_with};
    use crate::sim::world::{Scenario, WorldConfig};
    use model_core::kinematics::Regime;

    const HUSKY: Rover = Rover::HUSKY_A200;

    fn rows(world: &WorldConfig, seeds: std::ops::Range<u64>) -> Vec<TurnRow> {
        let runs: Vec<_> = seeds
            .map(|k| simulate_run(world, &Scenario::seed_turns(0.3, 1), k))
            .collect();
        rows_of(&runs)
    }

    fn straight_gap(d: &crate::diagnose::Diagnosis) -> f64 {
        d.gaps
            .iter()
            .filter(|g| g.regime == Regime::Straight)
            .map(|g| g.mean_w)
            .sum::<f64>()
    }

    /// A sensor offset in the runs, clean calibration runs: with calibration runs the baseline
    /// is theirs, the offset shows in full on the runs' straights (in-run calibration absorbs
    /// part of it into G), and only the diagnosed rows are scored.
    #[test]
    fn calibration_runs_fix_the_baseline_and_are_not_scored() {
        let cal = rows(&WorldConfig::hard_ground(), 50..52);
        let offset = WorldConfig::hard_ground().with_effect(EffectId::CurrentOffset, true);
        let runs = rows(&offset, 60..63);
        let from_runs = diagnose(&HUSKY, &runs).expect("diagnoses");
        let with_cal = diagnose_with(&HUSKY, &runs, Calibration::Rows(&cal)).expect("diagnoses");

        let cal_kind: Vec<&TurnRow> = cal.iter().filter(|r| r.calibration_kind).collect();
        assert_eq!(
            with_cal.calibration,
            CalibrationNote {
                source: CalibrationSource::CalibrationFiles,
                manoeuvres: cal_kind.len(),
            }
        );
        assert_eq!(from_runs.calibration.source, CalibrationSource::Runs);
        assert_eq!(
            with_cal.baseline,
            Baseline::fit(&HUSKY, &cal_kind).expect("fits")
        );
        assert!(
            straight_gap(&with_cal) > straight_gap(&from_runs) + 1.0,
            "{} vs {}",
            straight_gap(&with_cal),
            straight_gap(&from_runs)
        );

        let held = Calibration::Rows(&cal)
            .heldout_residuals(&HUSKY, &runs, Scheme::LeaveOneRunOut, None)
            .expect("fits")
            .expect("3 runs");
        let indices: Vec<usize> = held.iter().map(|(i, _)| *i).collect();
        assert_eq!(indices, (0..runs.len()).collect::<Vec<_>>());
        // The baseline is the same in every fold: held-out residuals are the plain residuals.
        for (i, res) in &held {
            assert_eq!(*res, with_cal.baseline.residual_w(&runs[*i]));
        }
    }

    #[test]
    fn calibration_runs_without_calibration_manoeuvres_are_an_error() {
        let runs = rows(&WorldConfig::hard_ground(), 1..3);
        let turns_only: Vec<TurnRow> = runs
            .iter()
            .filter(|r| !r.calibration_kind)
            .cloned()
            .collect();
        let err = diagnose_with(&HUSKY, &runs, Calibration::Rows(&turns_only))
            .expect_err("nothing to fit");
        assert!(
            err.to_string().contains("0 calibration manoeuvres"),
            "{err}"
        );
    }
}
