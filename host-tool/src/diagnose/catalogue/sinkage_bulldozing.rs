//! `sinkage-bulldozing` (thesis Section 5.3–5.4, Eq 5.15–5.39): 2D slip-sinkage growth, the
//! resistance it adds, and sand bulldozing.
//!
//! - Term: |V_side|·|ω_cmd|·(L/2)/v_c · (1, T/T_ref) on turns (sinkage grows with lateral slip
//!   and time), either sign (G·|V| takes the sand's resistance on the straights); it grows
//!   through the turn.
//! - Mark: power rising through the manoeuvre on each side as the wheels sink: the turns below
//!   R′ beyond what the straights and wide turns grow at the same power (Welch t per side), or
//!   the tight turns and straights beyond none (one-sample t per side; not while another
//!   effect's mark says it raises every manoeuvre too); ≥ 1.5 W on both sides, the weaker
//!   side's p ×2, the stronger reading's p ×2.

use crate::diagnose::effect::{
    AlsoRises, Context, Effect, MarkDrive, MarkSource, Marks, Measurement, PathSegment, SignRule,
    MAX_PARAMS,
};
use crate::diagnose::features::TurnRow;
use crate::diagnose::signature::{Evidence, Signature, SignatureTest, ALPHA};
use crate::diagnose::stats::{one_sample_upper, welch_upper, PRACTICAL_FLOOR_W};
use crate::effect_id::EffectId;

/// Reference turn time of the term's growth [s] (a 90° point turn at 0.3 m/s on the Husky).
pub const SINKAGE_REF_TIME_S: f64 = 3.0;

/// `sinkage-bulldozing`.
#[derive(Debug)]
pub struct SinkageBulldozing;

impl Effect for SinkageBulldozing {
    fn id(&self) -> EffectId {
        EffectId::SinkageBulldozing
    }
    fn param_count(&self) -> usize {
        2
    }
    fn grows(&self) -> bool {
        true
    }
    fn regressors(
        &self,
        row: &TurnRow,
        side: usize,
        ctx: &Context<'_>,
    ) -> Option<[f64; MAX_PARAMS]> {
        Some(if !row.is_straight() && row.v_c_mps > 0.0 {
            let v = row.sides[side].cmd_mps.abs();
            let lateral = row.yaw_rate_cmd_rad_s * f64::from(ctx.rover.length_m) / 2.0;
            let base = v * lateral / row.v_c_mps;
            [base, base * row.expected_duration_s / SINKAGE_REF_TIME_S]
        } else {
            [0.0, 0.0]
        })
    }
    fn sign_rule(&self) -> SignRule {
        SignRule::Either
    }
    fn deficit_words(&self) -> Option<&'static str> {
        Some(
            "G·|V| takes the sand's resistance on every manoeuvre, straights included, and \
             beyond it the turns draw less, as when a turn's side compaction keeps the wheels' \
             sinkage below a straight's (the thesis' 2D slip-sinkage model, Eq 5.27)",
        )
    }
    fn mark_source(&self) -> MarkSource {
        MarkSource::GrowthThroughManoeuvre
    }
    fn reads_other_marks(&self) -> bool {
        true
    }
    fn mark(&self, ev: &Evidence<'_>, marks: &Marks<'_>) -> Signature {
        sinkage(ev, marks.also_rising())
    }
    // Power rising through turns below R′: long turns there.
    fn drives_to_show_mark(&self) -> Vec<MarkDrive> {
        vec![MarkDrive::turn(1.0 / 3.0, 180.0, 2)]
    }
    fn measurement(&self) -> Measurement {
        Measurement {
            what: "the wheels' sinkage at the tight turns (a camera or a depth gauge beside the track): it is the mark itself",
            pose_track: false,
        }
    }
    // |V_o| + |V_i| = 2v_c times |ω| L/2 / v_c, over the turn: L |Δθ|.
    fn path_segment(&self, s: &PathSegment) -> Option<Vec<f64>> {
        Some(vec![if s.line {
            0.0
        } else {
            s.length_m * s.dtheta_rad.abs()
        }])
    }
}

/// `sinkage-bulldozing`: the wheels sink after each start, so power rises through the
/// manoeuvre on **each** side by at least [`PRACTICAL_FLOOR_W`], read two ways: the turns below
/// R′ beyond what the straights and wide turns grow at the same power (runs and calibration;
/// slip sinks them deeper), by Welch t per side; or, where the sand yields on the straights as
/// much (a heavy rover), the turns below R′ and the straights beyond no growth at all, by
/// one-sample t per side, unless `rising_otherwise` raises a manoeuvre's power through it as
/// well: a warmer winding (motor heating's mark not yet looked for and missing; it does not
/// start over at the next manoeuvre as sinkage does: heating's drives tell them apart, so such a
/// rise in size leaves the mark inconclusive, not missing) or a grade changing under the rover
/// (the slope's mark). The weaker side's test, its p doubled, of the stronger reading, its p
/// doubled again. A drag of the inner side alone (which also grows) does not pass on the outer
/// side; an acceleration transient makes power fall through the manoeuvre, not rise.
fn sinkage(ev: &Evidence<'_>, rising_otherwise: Option<(EffectId, AlsoRises)>) -> Signature {
    let e = EffectId::SinkageBulldozing;
    // The turns below R′ with both sides' growth.
    let tight: Vec<(&TurnRow, [f64; 2])> = ev
        .rows
        .iter()
        .filter(|r| !r.is_straight() && r.r_over_r_prime < 1.0)
        .filter_map(|r| Some((r, both_growths(r)?)))
        .collect();
    if tight.len() < 2 {
        return Signature::unobservable(e, "fewer than 2 turns below R′ with their growth");
    }
    let rows = || ev.rows.iter().chain(ev.calibration_rows);
    // The straights' and wide turns' growth against their power, side by side: a rise that
    // scales with the power a side draws (a lagging speed loop still bringing a loaded drive
    // up to speed; a regenerating side's falls) is expected of a tight turn's side at its own
    // power, not only at theirs. Each of them counts once, as the mean of its sides' growth
    // beyond that line.
    let reference: Vec<[(f64, f64); 2]> = rows()
        .filter(|r| r.is_straight() || r.r_over_r_prime > 1.0)
        .filter_map(|r| {
            let g = both_growths(r)?;
            Some([0, 1].map(|s| (r.sides[s].avg_power_w, g[s])))
        })
        .collect();
    let line = GrowthLine::fit(&reference.concat());
    let mut wide: Vec<f64> = reference
        .iter()
        .map(|sides| 0.5 * sides.iter().map(|&(p, g)| g - line.at(p)).sum::<f64>())
        .collect();
    if wide.len() < 2 {
        // Nothing to compare with: against no growth at all.
        wide = vec![0.0, 0.0];
    }
    let driven: Vec<[f64; 2]> = tight
        .iter()
        .map(|&(_, g)| g)
        .chain(rows().filter(|r| r.is_straight()).filter_map(both_growths))
        .collect();
    // Per side: (growth beyond the reference, t, df, p).
    let beyond_wide = |s: usize| -> Option<(f64, f64, f64, f64)> {
        let growth: Vec<f64> = tight
            .iter()
            .map(|(r, g)| g[s] - line.at(r.sides[s].avg_power_w))
            .collect();
        welch_upper(&growth, &wide)
    };
    let beyond_none = |s: usize| -> Option<(f64, f64, f64, f64)> {
        let growth: Vec<f64> = driven.iter().map(|g| g[s]).collect();
        let (t, df, p) = one_sample_upper(&growth, 0.0)?;
        Some((growth.iter().sum::<f64>() / growth.len() as f64, t, df, p))
    };
    let weaker = |inner: (f64, f64, f64, f64), outer: (f64, f64, f64, f64)| {
        let w = if inner.3 >= outer.3 { inner } else { outer };
        (inner.0.min(outer.0), w.1, w.2, (2.0 * w.3).min(1.0))
    };
    let (Some(inner), Some(outer)) = (beyond_wide(0), beyond_wide(1)) else {
        return Signature::unobservable(e, "growth without spread");
    };
    let turns = weaker(inner, outer);
    let sized = |r: &(f64, f64, f64, f64)| r.0 >= PRACTICAL_FLOOR_W;
    let all_grow = match (beyond_none(0), beyond_none(1)) {
        (Some(i), Some(o)) => Some((weaker(i, o), i.0, o.0)),
        _ => None,
    };
    let everywhere = all_grow.filter(|_| rising_otherwise.is_none());
    // A rise through every manoeuvre that the other effect's drives can still tell apart.
    let told_apart_by = rising_otherwise
        .filter(|(_, rises)| rises.told_apart_by_driving)
        .map(|(other, _)| other)
        .filter(|_| all_grow.is_some_and(|(all, _, _)| sized(&all)));
    let turns_detail = format!(
        "turns below R′ grow {:+.1} W on the inner side and {:+.1} W on the outer side \
         through the turn beyond what {} straight(s) and wide turn(s) grow at the same power \
         ({:+.1} W per kW drawn)",
        inner.0,
        outer.0,
        wide.len(),
        line.slope * 1000.0
    );
    // The stronger reading: the one reaching the floor, else the smaller p.
    let (chosen, name, detail) = match everywhere {
        Some((all, i, o)) if sized(&all) && (!sized(&turns) || all.3 < turns.3) => (
            all,
            "t",
            format!(
                "{} tight turns and straights grow {i:+.1} W on the inner (left) side and \
                 {o:+.1} W on the outer (right) side through the manoeuvre ({turns_detail})",
                driven.len()
            ),
        ),
        _ => match (all_grow, rising_otherwise) {
            (Some((all, i, o)), Some((_, rises))) if sized(&all) => (
                turns,
                "Welch t",
                format!(
                    "{turns_detail}; the tight turns and straights grow {i:+.1} W and {o:+.1} W \
                     through the manoeuvre, {}",
                    rises.words
                ),
            ),
            _ => (turns, "Welch t", turns_detail),
        },
    };
    let readings = if everywhere.is_some() { 2.0 } else { 1.0 };
    let test = reading_test(name, chosen, readings, told_apart_by.is_some());
    Signature {
        told_apart_by,
        ..Signature::tested(e, test, detail)
    }
}

/// The growth a side of a straight or wide turn shows at its power: the least-squares line of
/// growth against power through those sides when it rises with power, else their mean growth
/// (fewer than 3 of them, or no spread in power).
struct GrowthLine {
    mean_power_w: f64,
    mean_growth_w: f64,
    /// [W of growth per W drawn], ≥ 0.
    slope: f64,
}

impl GrowthLine {
    /// The line through `reference` (power, growth) [W].
    fn fit(reference: &[(f64, f64)]) -> Self {
        let n = reference.len().max(1) as f64;
        let mean_power_w = reference.iter().map(|r| r.0).sum::<f64>() / n;
        let mean_growth_w = reference.iter().map(|r| r.1).sum::<f64>() / n;
        let sxx: f64 = reference.iter().map(|r| (r.0 - mean_power_w).powi(2)).sum();
        let sxy: f64 = reference
            .iter()
            .map(|r| (r.0 - mean_power_w) * (r.1 - mean_growth_w))
            .sum();
        let slope = if reference.len() >= 3 && sxx > 0.0 {
            (sxy / sxx).max(0.0)
        } else {
            0.0
        };
        Self {
            mean_power_w,
            mean_growth_w,
            slope,
        }
    }

    /// The growth expected at `power_w` [W].
    fn at(&self, power_w: f64) -> f64 {
        self.mean_growth_w + self.slope * (power_w - self.mean_power_w)
    }
}

/// The growth through the turn of both sides of `row`, when both have it.
fn both_growths(row: &TurnRow) -> Option<[f64; 2]> {
    Some([row.sides[0].growth_w?, row.sides[1].growth_w?])
}

/// The chosen reading's test, (growth beyond the reference, t, df, p): its p multiplied by the
/// number of readings tried; sized at [`PRACTICAL_FLOOR_W`] of growth, or when another effect's
/// drives can still tell the rise apart (`told_apart`).
fn reading_test(
    name: &'static str,
    (growth, t, df, p): (f64, f64, f64, f64),
    readings: f64,
    told_apart: bool,
) -> SignatureTest {
    let sized = growth >= PRACTICAL_FLOOR_W;
    SignatureTest {
        statistic_name: name,
        statistic: t,
        df,
        p: (readings * p).min(1.0),
        present: readings * p < ALPHA && sized,
        sized: sized || told_apart,
    }
}

#[cfg(test)]
mod tests {
    use super::GrowthLine;

    /// A lagging loop's rise, 0.4 % of the power drawn, on straights and wide turns: a tight
    /// turn at 1.3 kW is expected to rise as much (5.2 W), not as their mean (2.5 W).
    #[test]
    fn a_rise_with_power_is_expected_at_the_turns_power() {
        let reference: Vec<(f64, f64)> = [200.0, 640.0, 600.0, 660.0, 250.0]
            .iter()
            .map(|&p| (p, 0.004 * p))
            .collect();
        let line = GrowthLine::fit(&reference);
        assert!((line.slope - 0.004).abs() < 1e-12, "{}", line.slope);
        assert!((line.at(1300.0) - 5.2).abs() < 1e-9);
    }

    /// Growth that falls with power is not a loop's rise: the reference stays their mean, as
    /// without a line (fewer than 3 manoeuvres, or all at one power).
    #[test]
    fn otherwise_the_reference_is_the_mean_growth() {
        let falling = [(100.0, 3.0), (500.0, 1.0), (900.0, -1.0)];
        let line = GrowthLine::fit(&falling);
        assert_eq!(line.slope, 0.0);
        assert!((line.at(2000.0) - 1.0).abs() < 1e-12);
        let two = GrowthLine::fit(&[(100.0, 1.0), (900.0, 5.0)]);
        assert_eq!((two.slope, two.at(900.0)), (0.0, 3.0));
        let one_power = GrowthLine::fit(&[(300.0, 1.0), (300.0, 2.0), (300.0, 3.0)]);
        assert_eq!((one_power.slope, one_power.at(1000.0)), (0.0, 2.0));
        assert_eq!(GrowthLine::fit(&[]).at(500.0), 0.0);
    }
}
