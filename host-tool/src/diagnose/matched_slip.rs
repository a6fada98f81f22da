//! The turns' yaw-timed slip against the calibration runs' own turns driven alike: the same
//! commanded radius, yaw rate and turned angle, and the same side where both are known.
//!
//! The reference is measured, never a parameter of the fitted baseline (its terrain slip may be
//! clamped at 0, absent from the chosen member, or chosen for the power). What the calibration
//! ground does to a turn it does to the same turn in the runs: a slip track narrower than the
//! controller's makes every turn quicker than commanded, a slip that grows with the yaw rate
//! slows the quick turns more, a wheel-speed loop that lags loses the same time on each turn of
//! one angle, a gyro that reads 3 % high reads it in both. Compared like with like, each
//! cancels; only a change between the calibration ground and the runs' remains. Negative
//! differences (turns quicker than the calibration's) are slips too.

use super::features::TurnRow;
use super::stats::matched_upper;

/// Largest difference of R/R′ between turns driven alike: an absolute part (point turns, 0)
/// and a relative part.
const RADIUS_TOLERANCE: (f64, f64) = (0.05, 0.10);

/// Largest relative difference of the commanded yaw rate between turns driven alike.
const YAW_RATE_TOLERANCE: f64 = 0.15;

/// Largest relative difference of the turned angle between turns driven alike (a fixed time
/// lost per turn is a larger share of a short turn).
const ANGLE_TOLERANCE: f64 = 0.30;

/// The turns' slip beyond the calibration's at matched conditions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum SlipAgainstCalibration {
    /// The runs calibrate themselves: no calibration ground was driven to compare with.
    NoCalibrationRuns,
    /// No turn of the runs (or none of the calibration's) was timed by yaw.
    NoYawTimedTurns,
    /// Turns timed by yaw, but none driven as a calibration turn was (radius, yaw rate, angle).
    NotMatched {
        /// The runs' yaw-timed turns.
        turns: usize,
    },
    /// Matched turns, too few to estimate a spread (one per condition on both sides).
    TooFew {
        /// The runs' matched turns.
        turns: usize,
    },
    /// The comparison.
    Measured(MatchedSlip),
}

/// The matched comparison ([`matched_upper`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct MatchedSlip {
    /// The runs' slip minus the calibration's, weighted by the runs' turns per condition.
    pub difference: f64,
    /// Its t (NaN when degenerate: no spread to test against).
    pub t: f64,
    /// Degrees of freedom of the pooled spread.
    pub df: f64,
    /// The runs' matched turns.
    pub turns: usize,
    /// The calibration turns they were matched with.
    pub calibration_turns: usize,
    /// Conditions (groups of turns driven alike).
    pub conditions: usize,
}

/// Whether two turns were driven alike: radius, yaw rate and turned angle within their
/// tolerances, and the same side of the turn where both are known.
fn driven_alike(a: &TurnRow, b: &TurnRow) -> bool {
    let within = |x: f64, y: f64, rel: f64| (x - y).abs() <= rel * x.abs().max(y.abs());
    let (abs, rel) = RADIUS_TOLERANCE;
    let turned = |r: &TurnRow| r.expected_duration_s * r.yaw_rate_cmd_rad_s;
    (a.r_over_r_prime - b.r_over_r_prime).abs()
        <= abs + rel * a.r_over_r_prime.max(b.r_over_r_prime)
        && within(
            a.yaw_rate_cmd_rad_s,
            b.yaw_rate_cmd_rad_s,
            YAW_RATE_TOLERANCE,
        )
        && within(turned(a), turned(b), ANGLE_TOLERANCE)
        && (a.direction.is_none() || b.direction.is_none() || a.direction == b.direction)
}

/// The yaw-timed turns of `rows` with their measured angular slip (Eq 6.3).
pub(crate) fn yaw_timed<'r>(
    rows: impl IntoIterator<Item = &'r TurnRow>,
) -> impl Iterator<Item = (&'r TurnRow, f64)> {
    rows.into_iter()
        .filter(|r| r.turned_from_yaw && !r.is_straight())
        .filter_map(|r| r.angular_slip.map(|s| (r, s)))
        .filter(|(_, s)| s.is_finite())
}

/// The measured angular slip of the yaw-timed turns of `rows` matching `keep`.
pub(crate) fn yaw_slips<'r>(
    rows: impl IntoIterator<Item = &'r TurnRow>,
    keep: impl Fn(&TurnRow) -> bool,
) -> Vec<f64> {
    yaw_timed(rows)
        .filter(|(r, _)| keep(r))
        .map(|(_, s)| s)
        .collect()
}

/// The slip of the turns of `rows` matching `keep` against the turns of `calibration` (the
/// calibration runs' rows, empty when the runs calibrate themselves) driven alike.
pub(crate) fn slip_against_calibration(
    rows: &[TurnRow],
    calibration: &[TurnRow],
    keep: impl Fn(&TurnRow) -> bool,
) -> SlipAgainstCalibration {
    if calibration.is_empty() {
        return SlipAgainstCalibration::NoCalibrationRuns;
    }
    let turns: Vec<(&TurnRow, f64)> = yaw_timed(rows).filter(|(r, _)| keep(r)).collect();
    let reference: Vec<(&TurnRow, f64)> = yaw_timed(calibration).collect();
    if turns.is_empty() || reference.is_empty() {
        return SlipAgainstCalibration::NoYawTimedTurns;
    }
    // Group the runs' turns by the set of calibration turns they match: one condition each.
    let mut groups: Vec<(Vec<usize>, Vec<f64>)> = Vec::new();
    for (row, slip) in &turns {
        let matched: Vec<usize> = (0..reference.len())
            .filter(|&i| driven_alike(row, reference[i].0))
            .collect();
        if matched.is_empty() {
            continue;
        }
        match groups.iter_mut().find(|(m, _)| *m == matched) {
            Some((_, slips)) => slips.push(*slip),
            None => groups.push((matched, vec![*slip])),
        }
    }
    if groups.is_empty() {
        return SlipAgainstCalibration::NotMatched { turns: turns.len() };
    }
    let matched_turns = groups.iter().map(|(_, s)| s.len()).sum();
    let mut calibration_turns: Vec<usize> = groups.iter().flat_map(|(m, _)| m.clone()).collect();
    calibration_turns.sort_unstable();
    calibration_turns.dedup();
    let samples: Vec<(Vec<f64>, Vec<f64>)> = groups
        .iter()
        .map(|(m, slips)| (slips.clone(), m.iter().map(|&i| reference[i].1).collect()))
        .collect();
    match matched_upper(&samples) {
        None => SlipAgainstCalibration::TooFew {
            turns: matched_turns,
        },
        Some((difference, t, df, _)) => SlipAgainstCalibration::Measured(MatchedSlip {
            difference,
            t,
            df,
            turns: matched_turns,
            calibration_turns: calibration_turns.len(),
            conditions: groups.len(),
        }),
    }
}

/// The slip a side asymmetry can put between the point turns and the turns towards R′, read
/// off the straights of `rows`. Sides that run at different ground speeds for the same command
/// (a smaller tyre, a weaker driver) turn a straight at δ·v_c/B_s; under the constant
/// total-absolute-velocity constraint (Eq 2.6) they slow the point turn by δ/2 and a turn at
/// R′ (one side still) by 0 or δ, a rise of up to δ/2, which is the straights' yaw rate over
/// the point turn's commanded one (2v_c/B_s). 0 without yaw-timed straights or point turns.
pub(crate) fn asymmetry_slip(rows: &[TurnRow]) -> f64 {
    let per_speed = |keep: &dyn Fn(&TurnRow) -> bool, rate: &dyn Fn(&TurnRow) -> Option<f64>| {
        let v: Vec<f64> = rows
            .iter()
            .filter(|r| keep(r) && r.v_c_mps > 0.0)
            .filter_map(|r| rate(r).map(|w| w / r.v_c_mps))
            .filter(|v| v.is_finite())
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let straight = per_speed(&|r| r.is_straight(), &|r| r.yaw_rate_act_rad_s);
    let point = per_speed(
        &|r| r.regime == model_core::kinematics::Regime::Point,
        &|r| Some(r.yaw_rate_cmd_rad_s),
    );
    match (straight, point) {
        (Some(s), Some(p)) if p > 0.0 => s.abs() / p,
        _ => 0.0,
    }
}

/// Whether the runs were driven on a weaker supply than any the calibration ran on: their
/// straights (the lightest load, driven alike in both) on a mean bus voltage further below the
/// calibration's most loaded manoeuvre than that sits below the calibration's own straights (the
/// supply fell by more than the whole range the calibration spanned; within it, run-to-run
/// charge and load are what the calibration saw). Then every loaded manoeuvre of the runs had
/// less headroom than was ever calibrated: the drives may not reach their commanded wheel
/// speeds, so a slower turn or a side drawing otherwise is the supply's doing, not the
/// ground's. `Some((runs' straights, the limit))` [V] when so; `None` without calibration runs,
/// straights or bus voltages.
pub(crate) fn supply_below_calibration(
    rows: &[TurnRow],
    calibration: &[TurnRow],
) -> Option<(f64, f64)> {
    let straights = |rows: &[TurnRow]| -> Option<f64> {
        let v: Vec<f64> = rows
            .iter()
            .filter(|r| r.is_straight() && r.bus_v > 0.0)
            .map(|r| r.bus_v)
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let floor = calibration
        .iter()
        .map(|r| r.bus_v)
        .filter(|v| *v > 0.0)
        .min_by(f64::total_cmp)?;
    let span = straights(calibration).map_or(0.0, |s| (s - floor).max(0.0));
    let limit = floor - span;
    let runs = straights(rows)?;
    (runs < limit).then_some((runs, limit))
}

/// Why marks are not read on a weaker supply than the calibration's.
pub(crate) fn supply_words((runs_v, floor_v): (f64, f64)) -> String {
    format!(
        "the runs' straights ran on a {runs_v:.2} V bus, below {floor_v:.2} V, further under the \
         calibration's most loaded manoeuvre than the calibration's own range: the drives may \
         not reach their commanded speeds, so this mark would be the supply's, not the \
         ground's (charge the battery, or calibrate on the same supply)"
    )
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::diagnose::features::{Observed, SideObs, SideRole};
    use model_core::kinematics::Regime;

    /// A yaw-timed turn (or straight) of run `run` at R/R′ `rho` with slip `slip`.
    pub(crate) fn turn(run: usize, rho: f64, slip: f64, bus_v: f64, yaw_rate: f64) -> TurnRow {
        let side = |role| SideObs {
            role,
            cmd_mps: 0.3,
            avg_power_w: 10.0,
            max_power_w: 10.0,
            energy_j: 50.0,
            effective_power_w: 10.0,
            growth_w: None,
        };
        let straight = rho.is_infinite();
        TurnRow {
            run: format!("run-{run}"),
            run_index: run,
            manoeuvre: 0,
            regime: match rho {
                r if r.is_infinite() => Regime::Straight,
                0.0 => Regime::Point,
                _ => Regime::AboveRPrime,
            },
            radius_cmd_m: rho * 0.55,
            r_over_r_prime: rho,
            v_c_mps: 0.3,
            yaw_rate_cmd_rad_s: if straight { 0.0 } else { 0.6 / (1.0 + rho) },
            duration_s: 3.0,
            expected_duration_s: if straight {
                3.0
            } else {
                1.5 * (1.0 + rho) / 0.6
            },
            turned_from_yaw: true,
            angular_slip: (!straight).then_some(slip),
            yaw_rate_act_rad_s: Some(yaw_rate),
            t_start_s: 0.0,
            pitch_deg: None,
            standstill_current_a: None,
            standstill_w: [0.0; 2],
            bus_v,
            sides: [side(SideRole::Inner), side(SideRole::Outer)],
            calibration_kind: true,
            observed: Observed::Sides,
            copper_heat_a4: None,
            measured: None,
            direction: None,
        }
    }

    #[test]
    fn the_reference_is_the_calibrations_turns_driven_alike() {
        // Calibration and runs both 6 % quicker than commanded at the point turn and 3 % at
        // 2R′ (a narrow slip track and a slip that grows with the yaw rate): no difference.
        let cal = [0, 1].map(|k| {
            [
                turn(k, 0.0, -0.06, 25.0, 0.0),
                turn(k, 2.0, -0.03, 25.0, 0.0),
            ]
        });
        let cal: Vec<TurnRow> = cal.into_iter().flatten().collect();
        let runs: Vec<TurnRow> = (0..3)
            .flat_map(|k| {
                let jitter = 0.001 * k as f64;
                [
                    turn(k, 0.0, -0.06 + jitter, 25.0, 0.0),
                    turn(k, 2.0, -0.03 - jitter, 25.0, 0.0),
                    // No calibration turn at R′/3: not compared.
                    turn(k, 1.0 / 3.0, 0.2, 25.0, 0.0),
                ]
            })
            .collect();
        let SlipAgainstCalibration::Measured(m) = slip_against_calibration(&runs, &cal, |_| true)
        else {
            panic!("measured");
        };
        assert!(m.difference.abs() < 0.002, "{m:?}");
        assert_eq!((m.turns, m.calibration_turns, m.conditions), (6, 4, 2));
        // Without calibration runs there is no reference ground.
        assert_eq!(
            slip_against_calibration(&runs, &[], |_| true),
            SlipAgainstCalibration::NoCalibrationRuns
        );
        // Runs 5 % slower than the calibration at both radii: a difference of +5 %.
        let slower: Vec<TurnRow> = runs
            .iter()
            .map(|r| TurnRow {
                angular_slip: r.angular_slip.map(|s| s + 0.05),
                ..r.clone()
            })
            .collect();
        let SlipAgainstCalibration::Measured(m) = slip_against_calibration(&slower, &cal, |_| true)
        else {
            panic!("measured");
        };
        assert!((m.difference - 0.05).abs() < 0.002 && m.t > 10.0, "{m:?}");
    }

    #[test]
    fn straights_that_turn_bound_what_an_asymmetry_can_raise() {
        // Point turns at 2v_c/B_s = 0.6 rad/s; straights turning at 0.012 rad/s: sides 4 %
        // apart, which can raise the slip towards R′ by 2 %.
        let rows = [
            turn(0, 0.0, 0.05, 25.0, 0.6),
            turn(0, f64::INFINITY, 0.0, 25.0, 0.012),
            turn(1, f64::INFINITY, 0.0, 25.0, 0.012),
        ];
        assert!((asymmetry_slip(&rows) - 0.02).abs() < 1e-9);
        assert_eq!(asymmetry_slip(&rows[..1]), 0.0);
    }

    #[test]
    fn a_supply_weaker_than_any_the_calibration_ran_on_is_said() {
        let cal = [
            turn(0, 0.0, 0.0, 24.0, 0.0),
            turn(0, f64::INFINITY, 0.0, 25.5, 0.0),
        ];
        // The calibration spans 25.5 → 24.0 V. The runs' straights on 23.0 V: 1 V under its
        // most loaded manoeuvre, within the 1.5 V it spanned itself.
        let runs = [
            turn(0, 0.0, 0.0, 21.5, 0.0),
            turn(0, f64::INFINITY, 0.0, 23.0, 0.0),
        ];
        assert_eq!(supply_below_calibration(&runs, &cal), None);
        // A battery 40 % down: its straights on 15.5 V.
        let flat = [
            turn(0, 0.0, 0.0, 14.0, 0.0),
            turn(0, f64::INFINITY, 0.0, 15.5, 0.0),
        ];
        assert_eq!(supply_below_calibration(&flat, &cal), Some((15.5, 22.5)));
        assert!(supply_words((15.5, 22.5)).contains("charge the battery"));
    }
}
