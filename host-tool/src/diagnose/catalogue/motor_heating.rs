//! `motor-heating` (thesis Section 1.1.3, Dogru's temperature-dependent motor constants):
//! winding resistance rises as the motors heat.
//!
//! - Term: the mean of I²·x_τ over the manoeuvre, x_τ the measured I² low-passed with τ from a
//!   grid (copper loss × a first-order winding temperature rise,
//!   [`winding_heat`](crate::diagnose::winding_heat)); without samples
//!   (P_side/V_bus)⁴·(1 − e^(−t/τ)) at mid-manoeuvre, a constant current since the run's start.
//! - Mark: the same manoeuvre drawing more later in a run: some run repeats a manoeuvre, the
//!   "where" analysis' run-time trend is significant and rising (permutation test), and the
//!   repeats themselves draw more (one-sample t).
//! - Scored only where run time is identifiable apart from the turn order.

use crate::diagnose::effect::{
    AlsoRises, Context, Effect, MarkDrive, MarkSource, Marks, Measurement, ScoredWhen, When,
    MAX_PARAMS, MIN_LATE_REPEATS,
};
use crate::diagnose::features::radius_group;
use crate::diagnose::features::TurnRow;
use crate::diagnose::gaps::MIN_TREND_SPREAD_S;
use crate::diagnose::signature::{format_p, Evidence, Signature, SignatureTest, ALPHA};
use crate::diagnose::stats::{moments, one_sample_upper};
use crate::diagnose::winding_heat::{heating_rise, HEATING_TAU_GRID_S};
use crate::effect_id::EffectId;

/// `motor-heating`.
#[derive(Debug)]
pub struct MotorHeating;

impl Effect for MotorHeating {
    fn id(&self) -> EffectId {
        EffectId::MotorHeating
    }
    fn confined_to_regimes(&self) -> bool {
        false
    }
    fn fits_tau(&self) -> bool {
        true
    }
    fn regressors(
        &self,
        row: &TurnRow,
        side: usize,
        ctx: &Context<'_>,
    ) -> Option<[f64; MAX_PARAMS]> {
        let tau = HEATING_TAU_GRID_S
            .iter()
            .position(|&t| t == ctx.heating_tau_s);
        Some(if let (Some(h), Some(k)) = (row.copper_heat_a4, tau) {
            [h[k][side], 0.0]
        } else if row.bus_v > 0.0 {
            // No samples (a per-turn table, the model file's rows): as if the model's
            // current had flowed since the run's start, x_τ = I²(1 − e^(−t/τ)).
            let i = ctx.baseline.side_power_w(row, side) / row.bus_v;
            let t_mid_s = row.t_start_s + 0.5 * row.duration_s;
            [i.powi(4) * heating_rise(t_mid_s, ctx.heating_tau_s), 0.0]
        } else {
            [0.0, 0.0]
        })
    }
    fn scored_when(&self) -> ScoredWhen {
        ScoredWhen::RunTimeApartFromTurnOrder
    }
    fn mark_source(&self) -> MarkSource {
        MarkSource::Repeats
    }
    fn mark(&self, ev: &Evidence<'_>, _marks: &Marks<'_>) -> Signature {
        motor_heating(ev)
    }
    // Until repeats rule the winding out, it raises power through every manoeuvre as sinking
    // wheels do; its own drives tell them apart.
    fn also_rises_through_manoeuvres(&self, own: &Signature) -> Option<AlsoRises> {
        (!own.rules_out()).then_some(AlsoRises {
            words: "as a warming winding would too (drive a manoeuvre again and again in one run \
                    to tell)",
            told_apart_by_driving: true,
        })
    }
    // The same manoeuvre drawing more later in a run: one driven again and again, in a row.
    fn drives_to_show_mark(&self) -> Vec<MarkDrive> {
        vec![MarkDrive {
            r_over_r_prime: Some(0.0),
            turn_deg: 180.0,
            when: When::Late,
            repeats: MIN_LATE_REPEATS,
        }]
    }
    fn measurement(&self) -> Measurement {
        Measurement {
            what: "the windings' temperature (a thermistor on each motor case): a warming winding shows it, sinking wheels do not",
            pose_track: false,
        }
    }
}

/// `motor-heating`: the same manoeuvre drawing more later in a run: some run repeats a
/// manoeuvre, and the "where" analysis' run-time trend is significant and rising. Without a
/// repeat within a run, a trend over the runs' shuffled orders compares different runs, whose
/// own variation a winding's slow rise cannot be told from.
fn motor_heating(ev: &Evidence<'_>) -> Signature {
    let e = EffectId::MotorHeating;
    if !repeats_within_a_run(ev.rows) {
        return Signature::unobservable(
            e,
            "no run drives a manoeuvre twice (repeat manoeuvres within longer runs to see it)",
        );
    }
    let Some(trend) = ev.where_.run_time.trend.as_ref() else {
        return Signature::unobservable(
            e,
            ev.where_.run_time.note.clone().unwrap_or_else(|| {
                "run time is not identifiable apart from the turn order".to_owned()
            }),
        );
    };
    // The residuals' trend over run time mixes manoeuvres (a run that ends on a cheaper one
    // trends too): the mark is the same manoeuvre itself drawing more when driven again later
    // in the run, measured without the power model.
    let rises = repeat_rises(ev.rows);
    let rise = one_sample_upper(&rises, 0.0);
    let rise_moments = moments(&rises);
    let test = SignatureTest {
        statistic_name: "permutation",
        statistic: trend.slope_w_per_min,
        df: trend.n as f64,
        p: trend.p_value,
        present: trend.significant
            && trend.change_w > 0.0
            && rise.is_some_and(|(_, _, p)| p < ALPHA),
        sized: trend.change_w > trend.floor_w
            && rise_moments.is_some_and(|(mean, _, _)| mean > 0.0),
    };
    let repeats = match (rise, rise_moments) {
        (Some((t, df, p)), Some((mean, _, n))) => format!(
            "; driven again later in the same run, a manoeuvre draws {mean:+.1} W ({n} repeat(s), \
             t = {t:.2}, df {df:.0}, p = {})",
            format_p(p)
        ),
        _ => format!(
            "; {} repeat(s) of a manoeuvre later in its run: too few to tell whether it draws more",
            rises.len()
        ),
    };
    Signature::tested(
        e,
        test,
        format!(
            "the same manoeuvres draw {:+.1} W/min more later in a run ({:+.1} W over a {:.1} min \
             run; floor {:.1} W){repeats}",
            trend.slope_w_per_min, trend.change_w, trend.run_length_min, trend.floor_w
        ),
    )
}

/// Whether some run drives the same commanded radius twice, at run times at least
/// [`MIN_TREND_SPREAD_S`](MIN_TREND_SPREAD_S) apart.
fn repeats_within_a_run(rows: &[TurnRow]) -> bool {
    rows.iter().enumerate().any(|(i, a)| {
        rows[i + 1..].iter().any(|b| {
            a.run_index == b.run_index
                && radius_group(a) == radius_group(b)
                && (a.t_start_s - b.t_start_s).abs() >= MIN_TREND_SPREAD_S
        })
    })
}

/// Each manoeuvre driven again later in its run (the same radius, v_c and direction, at least
/// [`MIN_TREND_SPREAD_S`](MIN_TREND_SPREAD_S) after its first drive there): how
/// much more both sides' measured average power is than at that first drive [W].
fn repeat_rises(rows: &[TurnRow]) -> Vec<f64> {
    let total = |r: &TurnRow| r.sides[0].avg_power_w + r.sides[1].avg_power_w;
    let same = |a: &TurnRow, b: &TurnRow| {
        a.run_index == b.run_index
            && radius_group(a) == radius_group(b)
            && (a.v_c_mps - b.v_c_mps).abs() < 0.005
            && a.direction == b.direction
    };
    let measured: Vec<&TurnRow> = rows.iter().filter(|r| total(r).is_finite()).collect();
    measured
        .iter()
        .filter_map(|later| {
            // The first drive of the same manoeuvre (`later` itself when it is the first).
            let first = measured
                .iter()
                .filter(|r| same(r, later))
                .min_by(|a, b| a.t_start_s.total_cmp(&b.t_start_s))?;
            (later.t_start_s - first.t_start_s >= MIN_TREND_SPREAD_S)
                .then(|| total(later) - total(first))
        })
        .collect()
}
