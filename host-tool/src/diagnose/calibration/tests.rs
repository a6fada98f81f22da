use super::*;
use crate::diagnose::cv::{self, Scheme};
use crate::diagnose::tests::{rows_of, simulate_run};
use crate::diagnose::{diagnose, diagnose_with};
use crate::effect_id::EffectId;
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
    let with_cal = diagnose_with(&HUSKY, &runs, Calibration::rows(&cal)).expect("diagnoses");

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

    let held = cv::heldout_residuals(
        &HUSKY,
        &runs,
        Scheme::LeaveOneRunOut,
        &[],
        Calibration::rows(&cal),
    )
    .expect("fits")
    .expect("3 runs");
    let indices: Vec<usize> = held.iter().map(|r| r.row).collect();
    assert_eq!(indices, (0..runs.len()).collect::<Vec<_>>());
    // The baseline is the same in every fold: held-out residuals are the plain residuals.
    for r in &held {
        assert_eq!(*r.effective_w, with_cal.baseline.residual_w(&runs[r.row]));
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
    let err =
        diagnose_with(&HUSKY, &runs, Calibration::rows(&turns_only)).expect_err("nothing to fit");
    assert!(
        err.to_string().contains("0 calibration manoeuvres"),
        "{err}"
    );
}
