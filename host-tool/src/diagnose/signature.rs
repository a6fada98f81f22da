//! Each catalogue effect's signature ([`EffectId::signature`]): the observation only it
//! produces, tested on the data with its statistic, degrees of freedom and p-value. An effect
//! is named only when its signature is present; one whose signature needs no power model
//! ([`EffectId::signature_needs_power_model`]) is also named when the baseline misfits its
//! calibration, with the misfit reported beside it.
//!
//! | effect | observation | test |
//! |---|---|---|
//! | `current-offset` | standstill current per run and side | one-sided t of \|mean\| over the quiescent draw (0.25 A), per side, Bonferroni ×2 |
//! | `angular-slip` | yaw-timed slip of the turns with 0 < R ≤ R′ minus the point turns' (same yaw rate) | one-sided Welch t ≥ 0, rise ≥ 2 %, per regime, Bonferroni ×3 |
//! | `slip-track` | the turns' yaw-timed slip beyond the calibration runs' own turns driven alike (radius, yaw rate, angle), not rising towards R′ (pose: measured slip track vs the calibration's) | two-sided t of the matched difference, \|difference\| ≥ 2 %, angular slip's rise absent |
//! | `slope` | manoeuvres off level (\|pitch\| > 1°) | binomial tail against 5 % of level manoeuvres reading off level |
//! | `motor-heating` | within-manoeuvre-kind trend of power over run time, a manoeuvre repeated within a run | permutation test (the "where" analysis), rising |
//! | `sinkage-bulldozing` | growth through the manoeuvre (second half − first half of its steady part), each side: of turns below R′, or of turns below R′ and straights | Welch t per side against straights and wide turns, beyond their growth at the same power, or one-sample t per side against none (not with heating's or the slope's mark present); ≥ 1.5 W on both, the weaker side's p ×2, the stronger reading's p ×2 |
//! | `inner-drag` | inner-side residual in dragged-inner turns | Welch t against the inner side of each neighbouring regime, tested beyond the larger of 1.5 W and the largest step between neighbouring radii elsewhere on that side (the baseline's structure) |
//! | `braked-inner` | outer-side residual at R′ | Welch t against the outer side of each neighbouring radius, tested beyond the larger of 1.5 W and the largest step elsewhere, as for `inner-drag` |

use super::baseline::Baseline;
use super::calibration::{Calibration, Source};
use super::features::{SideRole, TurnRow};
use super::gaps::WhereAnalysis;
use super::matched_slip::{supply_below_calibration, supply_words};
use super::stats::{moments, welch_upper, PRACTICAL_FLOOR_W};
use crate::diagnose::features::radius_group;
use crate::effect_id::EffectId;
use serde::Serialize;

/// Significance level of every signature test (after its Bonferroni factor).
pub const ALPHA: f64 = 0.05;

/// Smallest angular slip beyond the reference that counts as seen in the yaw (the spread of a
/// calibration's constant slip).
pub const MIN_SLIP_EXCESS: f64 = 0.02;

/// Smallest relative difference of a measured slip track from the terrain's.
pub const MIN_SLIP_TRACK_DIFFERENCE: f64 = 0.02;

/// Share of level manoeuvres whose mean pitch may read beyond the level threshold (sensor
/// noise, a bump): the null of the slope signature's binomial test.
pub const OFF_LEVEL_BY_CHANCE: f64 = 0.05;

/// One effect's signature test.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Signature {
    /// The effect.
    pub effect: EffectId,
    /// What its signature is ([`EffectId::signature`]).
    pub observation: &'static str,
    /// Whether the observation is read off the power model's residuals.
    pub needs_power_model: bool,
    /// The test, when the data can show the signature at all.
    pub test: Option<SignatureTest>,
    /// What was measured, or why the data cannot show it.
    pub detail: String,
    /// Not observable on these runs whatever is driven next: a slope hides it, or a sensor it
    /// reads is not logged. (Any other unobservable signature needs more manoeuvres.)
    pub masked: bool,
    /// The effect whose own mark, present in the data, hides this one (a slope's pull turns
    /// the rover as a slip would): what this term fits there is that effect's doing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hidden_by: Option<EffectId>,
    /// The effect whose own mark must first be looked for and found missing before this mark,
    /// there in size, can be read as this effect's: it makes the same mark (a warming winding
    /// raises power through every manoeuvre as sinking wheels do). Its drives tell them apart.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub told_apart_by: Option<EffectId>,
}

/// A signature's statistical test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SignatureTest {
    /// `t`, `Welch t`, `binomial` or `permutation`.
    pub statistic_name: &'static str,
    /// The statistic's value.
    pub statistic: f64,
    /// Its degrees of freedom (observations for the binomial and permutation tests).
    pub df: f64,
    /// Its p-value, multiple-comparison factor applied.
    pub p: f64,
    /// p below [`ALPHA`] and the effect size beyond its practical floor.
    pub present: bool,
    /// The effect size beyond its practical floor, significant or not: without `present`, the
    /// mark is there in size but not yet beyond the noise (more of the same manoeuvres could
    /// show it), not missing.
    pub sized: bool,
}

impl SignatureTest {
    /// Whether its statistic is undefined: a sample without spread (or a single value) has no
    /// noise to test against ([`super::stats::MAX_STATISTIC`]); its p is 1, never 0.
    pub fn degenerate(&self) -> bool {
        self.statistic.is_nan()
    }

    /// `present`, `inconclusive` (its size in the data, not yet beyond the noise) or `absent`.
    pub fn verdict(&self) -> &'static str {
        match (self.present, self.sized) {
            (true, _) => "present",
            (false, true) => "inconclusive",
            (false, false) => "absent",
        }
    }
}

impl Signature {
    /// Whether the data show the signature.
    pub fn present(&self) -> bool {
        self.test.is_some_and(|t| t.present)
    }

    /// Whether it was looked for and is missing: tested, and not even its size reaches the
    /// floor (a mark of that size not yet beyond the noise is not missing).
    pub fn absent(&self) -> bool {
        self.test.is_some_and(|t| !t.present && !t.sized)
    }

    /// The test's outcome for the report: `present: t = 4.39, df 3, p = 0.011`, or
    /// `not observable`.
    pub fn outcome(&self) -> String {
        match &self.test {
            Some(t) if t.degenerate() => format!(
                "{}: degenerate {} (the values do not vary beyond rounding, or one value: no \
                 noise to test against), df {:.0}",
                t.verdict(),
                t.statistic_name,
                t.df
            ),
            Some(t) => format!(
                "{}: {} = {:.2}, df {:.0}, p = {}",
                t.verdict(),
                t.statistic_name,
                t.statistic,
                t.df,
                format_p(t.p)
            ),
            None => "not observable".to_owned(),
        }
    }

    /// One line for the report: the test and what it measured.
    pub fn describe(&self) -> String {
        match &self.test {
            Some(_) => format!("{} — {}", self.outcome(), self.detail),
            None => format!("not observable: {}", self.detail),
        }
    }

    /// Whether its candidate cannot be named on these runs: its mark was looked for and is
    /// missing, or another effect's present mark hides it (the verdict does not weigh it).
    pub fn rules_out(&self) -> bool {
        self.absent() || self.hidden_by.is_some()
    }

    /// Whether its size is in the data but not yet beyond the noise: more of the manoeuvres its
    /// test reads can show it.
    pub fn inconclusive(&self) -> bool {
        self.test.is_some_and(|t| !t.present && t.sized)
    }

    /// Whether the data cannot show it yet but more manoeuvres can (not tested, not masked).
    pub fn observable_by_driving(&self) -> bool {
        self.test.is_none() && !self.masked
    }

    pub(crate) fn unobservable(effect: EffectId, why: impl Into<String>) -> Self {
        Self {
            effect,
            observation: effect.signature(),
            needs_power_model: effect.signature_needs_power_model(),
            test: None,
            detail: why.into(),
            masked: false,
            hidden_by: None,
            told_apart_by: None,
        }
    }

    pub(crate) fn masked(effect: EffectId, why: impl Into<String>) -> Self {
        Self {
            masked: true,
            ..Self::unobservable(effect, why)
        }
    }

    pub(crate) fn tested(effect: EffectId, test: SignatureTest, detail: String) -> Self {
        Self {
            effect,
            observation: effect.signature(),
            needs_power_model: effect.signature_needs_power_model(),
            test: Some(test),
            detail,
            masked: false,
            hidden_by: None,
            told_apart_by: None,
        }
    }
}

/// A p-value for the report: 3 significant digits, scientific below 0.001.
pub fn format_p(p: f64) -> String {
    if p < 1e-3 {
        format!("{p:.2e}")
    } else {
        format!("{p:.3}")
    }
}

/// What the signature tests read.
#[derive(Debug, Clone, Copy)]
pub struct Evidence<'a> {
    /// The diagnosed rows.
    pub rows: &'a [TurnRow],
    /// Every row of the calibration runs (empty when the runs calibrate themselves).
    pub calibration_rows: &'a [TurnRow],
    /// The baseline on the calibration manoeuvres.
    pub baseline: &'a Baseline,
    /// The "where" analysis (its run-time trend).
    pub where_: &'a WhereAnalysis,
}

impl<'a> Evidence<'a> {
    /// The evidence of a diagnosis calibrated as `calibration` says.
    pub fn new(
        rows: &'a [TurnRow],
        calibration: Calibration<'a>,
        baseline: &'a Baseline,
        where_: &'a WhereAnalysis,
    ) -> Self {
        let calibration_rows = match calibration.source {
            Source::FromRuns => &[][..],
            Source::Rows(cal) => cal,
        };
        Self {
            rows,
            calibration_rows,
            baseline,
            where_,
        }
    }
}

impl Evidence<'_> {
    /// Whether any manoeuvre, the calibration's included, was timed by a logged yaw.
    pub(crate) fn yaw_logged(&self) -> bool {
        self.rows
            .iter()
            .chain(self.calibration_rows)
            .any(|r| r.turned_from_yaw)
    }

    /// The standstill current of each run, per side (left, right), diagnosed and calibration runs.
    pub(crate) fn standstill_currents(&self) -> [Vec<f64>; 2] {
        let mut seen: Vec<(bool, usize)> = Vec::new();
        let mut sides = [Vec::new(), Vec::new()];
        let all = self
            .rows
            .iter()
            .map(|r| (false, r))
            .chain(self.calibration_rows.iter().map(|r| (true, r)));
        for (cal, row) in all {
            let Some(s) = row.standstill_current_a else {
                continue;
            };
            if seen.contains(&(cal, row.run_index)) {
                continue;
            }
            seen.push((cal, row.run_index));
            sides[0].push(s.left);
            sides[1].push(s.right);
        }
        sides
    }
}

/// The residual of the `role` side of each of `rows` matching `keep` [W].
fn side_residuals(ev: &Evidence<'_>, role: SideRole, keep: impl Fn(&TurnRow) -> bool) -> Vec<f64> {
    ev.rows
        .iter()
        .filter(|r| !r.is_straight() && !r.is_total_only() && keep(r))
        .flat_map(|r| {
            let res = ev.baseline.residual_w(r);
            (0..2)
                .filter(move |&s| r.sides[s].role == role)
                .map(move |s| res[s])
        })
        .filter(|v| v.is_finite())
        .collect()
}

/// A step test of the `role` side's residual: the rows matching `at` against each group of
/// `around` that has rows (the neighbours below and above), by Welch t, beyond the larger of
/// [`PRACTICAL_FLOOR_W`] and the largest step between radii elsewhere. An effect confined to
/// some radii is a plateau with an edge on both sides; a misfit smooth in the radius (copper
/// loss, the split) rises towards it from a neighbour. The statistic is the weakest edge's, its
/// p doubled.
pub(crate) fn step_test(
    ev: &Evidence<'_>,
    effect: EffectId,
    role: SideRole,
    at: impl Fn(&TurnRow) -> bool,
    around: [&dyn Fn(&TurnRow) -> bool; 2],
    what: &str,
) -> Signature {
    if let Some(supply) = supply_below_calibration(ev.rows, ev.calibration_rows) {
        return Signature::masked(effect, supply_words(supply));
    }
    let here = side_residuals(ev, role, &at);
    // A step is this effect's own only where the model's residual does not step as far between
    // radii where no such effect acts: there the step is the baseline's structure. So the step
    // is tested beyond that size, not only compared with it.
    let elsewhere = largest_step_elsewhere(ev, role, &at);
    let floor = PRACTICAL_FLOOR_W.max(elsewhere);
    let beyond: Vec<f64> = here.iter().map(|v| v - floor).collect();
    let edges: Vec<(f64, f64, f64, f64, usize)> = around
        .iter()
        .map(|keep| side_residuals(ev, role, keep))
        .filter(|there| !there.is_empty())
        .filter_map(|there| {
            welch_upper(&beyond, &there).map(|(d, t, df, p)| (d + floor, t, df, p, there.len()))
        })
        .collect();
    let Some(&(diff, t, df, p, n)) = edges.iter().max_by(|a, b| a.3.total_cmp(&b.3)) else {
        return Signature::unobservable(
            effect,
            format!(
                "fewer than 2 turns {what} or beside it with the {} side",
                role.id()
            ),
        );
    };
    let p = (p * edges.len() as f64).min(1.0);
    let smallest_step = edges.iter().map(|e| e.0).fold(f64::INFINITY, f64::min);
    Signature::tested(
        effect,
        SignatureTest {
            statistic_name: "Welch t",
            statistic: t,
            df,
            p,
            present: p < ALPHA && smallest_step >= floor,
            sized: smallest_step >= floor,
        },
        format!(
            "the {} side {what} draws {diff:+.1} W beyond the model more than at its weaker edge \
             ({} against {n} turns; {} edge(s) tested), t beyond {floor:.1} W: the larger of \
             {PRACTICAL_FLOOR_W:.1} W and the largest step between neighbouring radii elsewhere \
             on that side ({elsewhere:.1} W)",
            role.id(),
            here.len(),
            edges.len()
        ),
    )
}

/// The largest |difference| of the `role` side's mean residual between neighbouring radii of
/// the turns, over the pairs where neither radius matches `at` [W] (0 without such a pair).
fn largest_step_elsewhere(
    ev: &Evidence<'_>,
    role: SideRole,
    at: &impl Fn(&TurnRow) -> bool,
) -> f64 {
    let mut groups: Vec<i64> = ev
        .rows
        .iter()
        .filter(|r| !r.is_straight() && !r.is_total_only())
        .map(radius_group)
        .collect();
    groups.sort_unstable();
    groups.dedup();
    let means: Vec<(bool, f64)> = groups
        .into_iter()
        .filter_map(|g| {
            let in_group = |r: &TurnRow| radius_group(r) == g;
            let values = side_residuals(ev, role, in_group);
            let (mean, _, _) = moments(&values)?;
            let is_at = ev.rows.iter().any(|r| in_group(r) && at(r));
            Some((is_at, mean))
        })
        .collect();
    means
        .windows(2)
        .filter(|w| !w[0].0 && !w[1].0)
        .map(|w| (w[1].1 - w[0].1).abs())
        .fold(0.0, f64::max)
}
