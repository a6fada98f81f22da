//! The drivable manoeuvres: the design space the suggestions are drawn from (the thesis' turn
//! set and straights, at the runs' v_c, in their turn direction, alone or repeated in a row),
//! each with its synthetic row.

use super::super::catalogue;
use super::super::effect::{When, MIN_LATE_REPEATS};
use super::super::features::TurnRow;
use super::super::model_file::{synthetic_row, Conditions};
use super::super::stats::upper_median;
use super::rival::Setting;
use super::suggestion::NextRun;
use crate::effect_id::EffectId;
use crate::scenario::Side;
use model_core::kinematics::TurnDirection;

/// Most extra manoeuvres one round suggests (repeats counted).
pub const MAX_MANOEUVRES: u32 = 10;
/// Most repeats of one suggested manoeuvre.
pub const MAX_REPEATS: u32 = 5;
/// The radii suggestions are drawn from, R/R′ (the thesis' turn set, 0.8 R′ and 3 R′).
pub const RADII: [f64; 8] = [0.0, 1.0 / 3.0, 2.0 / 3.0, 0.8, 1.0, 4.0 / 3.0, 2.0, 3.0];
/// The turn angles suggestions are drawn from [deg] (a longer turn shows growth through it).
pub const TURN_DEG: [f64; 2] = [90.0, 180.0];
/// Standstill between the scenario's manoeuvres and before and after them [s] (the
/// scenario file's defaults).
pub(super) const PAUSE_S: f64 = 2.0;
/// Straight length when the runs have no straight [m].
pub(super) const DEFAULT_STRAIGHT_M: f64 = 2.0;

/// A manoeuvre the rover could drive next, and its synthetic row.
pub(super) struct Drivable {
    pub(super) run: NextRun,
    pub(super) row: TurnRow,
    /// One drive and the pause after it [s].
    pub(super) cycle_s: f64,
    pub(super) least_repeats: u32,
    pub(super) most_repeats: u32,
}

impl Drivable {
    /// `n` drives of it in a row: at the start of a fresh run, or (late) one after the other,
    /// each starting where the one before ended.
    pub(super) fn drives(&self, n: u32) -> Vec<TurnRow> {
        (0..n)
            .map(|k| {
                let mut row = self.row.clone();
                if self.run.when == When::Late {
                    row.t_start_s = PAUSE_S + f64::from(k) * self.cycle_s;
                }
                row
            })
            .collect()
    }
}

/// What the runs could be extended by: the radii, v_c, angles and times of the module's design
/// space, in the runs' turn direction.
pub(super) fn drivable(s: &Setting<'_>, rows: &[TurnRow], late: bool) -> Vec<Drivable> {
    let moving: Vec<f64> = rows
        .iter()
        .map(|r| r.v_c_mps)
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    let lo = moving.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = moving.iter().copied().fold(0.0, f64::max);
    let mut speeds = vec![];
    if lo.is_finite() {
        speeds.push((lo * 100.0).round() / 100.0);
        if hi - lo >= 0.05 {
            speeds.push((hi * 100.0).round() / 100.0);
        }
    }
    let count = |d| rows.iter().filter(|r| r.direction == Some(d)).count();
    let direction = if count(TurnDirection::Right) > count(TurnDirection::Left) {
        Side::Right
    } else {
        Side::Left
    };
    let straight_m = upper_median(
        rows.iter()
            .filter(|r| r.is_straight())
            .map(|r| r.v_c_mps * r.duration_s)
            .filter(|d| d.is_finite() && *d > 0.0)
            .collect(),
    )
    .map_or(DEFAULT_STRAIGHT_M, |d| (d * 10.0).round() / 10.0);
    let bus_v =
        upper_median(rows.iter().map(|r| r.bus_v).filter(|v| *v > 0.0).collect()).unwrap_or(0.0);
    let r_prime = f64::from(s.rover.r_prime_m());
    let whens: &[When] = if late {
        &[When::Any, When::Late]
    } else {
        &[When::Any]
    };
    let mut out = Vec::new();
    for &when in whens {
        let (least_repeats, most_repeats) = match when {
            When::Any => (1, MAX_REPEATS),
            When::Late => (MIN_LATE_REPEATS, MAX_MANOEUVRES),
        };
        for &v_c in &speeds {
            let at = |turn_deg: f64| Conditions {
                v_c_mps: v_c,
                turn_rad: turn_deg.to_radians(),
                bus_v,
                t_start_s: PAUSE_S,
            };
            let run = |x: Option<f64>, turn_deg: f64| NextRun {
                r_over_r_prime: x.map(thousandths),
                radius_m: x.map(|x| thousandths(x * r_prime)),
                distance_m: x.is_none().then_some(straight_m),
                v_c_mps: v_c,
                turn_deg,
                direction,
                repeats: 1,
                when,
                separates: Vec::new(),
                expected_sigma: 0.0,
                observes: None,
            };
            let mut straight = synthetic_row(s.rover, s.baseline, f64::INFINITY, &at(90.0));
            straight.duration_s = straight_m / v_c;
            straight.expected_duration_s = straight.duration_s;
            let turns = RADII.into_iter().flat_map(|x| {
                TURN_DEG.map(|deg| {
                    (
                        run(Some(x), deg),
                        synthetic_row(s.rover, s.baseline, x, &at(deg)),
                    )
                })
            });
            for (run, row) in std::iter::once((run(None, 0.0), straight)).chain(turns) {
                out.push(Drivable {
                    cycle_s: row.duration_s + PAUSE_S,
                    run,
                    row,
                    least_repeats,
                    most_repeats,
                });
            }
        }
    }
    out
}

/// Whether `e`'s mark is shown by a manoeuvre repeated in a row, late in a run.
pub(super) fn shown_late(e: EffectId) -> bool {
    catalogue::of(e)
        .drives_to_show_mark()
        .iter()
        .any(|d| d.when == When::Late)
}

/// `x` to 3 decimals: how the design writes R/R′ and R (and finds them again).
pub(super) fn thousandths(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}
