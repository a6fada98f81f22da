//! The groups of the "where" analysis: residuals grouped by regime and side and by side, each
//! judged by [`judge`], with their resampling seeds.

use super::judge::{judge, repeat_key, Floor, Obs};
use super::residuals::{Metric, TurnResidual};
use crate::diagnose::loo::LooTest;
use crate::diagnose::observe::Part;
use model_core::kinematics::Regime;
use serde::Serialize;
use std::collections::BTreeMap;

/// The resampling seed of a `metric`'s (regime, side) group: the same for the gaps and the
/// "where" groups, so both draw the same interval.
pub(super) fn group_seed(metric: &str, regime: Regime, part: Part) -> u64 {
    seed_of(&format!("{metric}:{}/{}", regime.id(), part.id()))
}

/// The mean of one group with its 95 % bootstrap interval.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GroupStat {
    /// The group: `regime/side`, `side`, or a run-time third.
    pub group: String,
    /// Observations.
    pub n: usize,
    /// Mean residual (the metric's unit).
    pub mean: f64,
    /// 95 % bootstrap interval over repeats (±∞ with one unit to resample).
    pub ci: (f64, f64),
    /// Practical floor the mean must exceed (the metric's unit).
    pub floor: f64,
    /// Beyond the noise and the floor ([`judge`]).
    pub significant: bool,
    /// Without repeats: the leave-one-out test of each observation (power metrics only).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub loo: Vec<LooTest>,
}

/// A group's observations.
pub(super) type Values = Vec<Obs>;

/// The [`GroupStat::group`] of a regime and side: `regime/side` (`dragged-inner/inner`).
pub fn regime_side_label(regime: Regime, part: Part) -> String {
    format!("{}/{}", regime.id(), part.id())
}

pub(super) fn stat(
    group: String,
    values: &Values,
    floor: Floor,
    seed: u64,
    tests: &[LooTest],
) -> Option<GroupStat> {
    let j = judge(values, floor, seed, tests)?;
    Some(GroupStat {
        group,
        n: values.len(),
        mean: j.mean,
        ci: j.ci,
        floor: j.floor,
        significant: j.significant,
        loo: j.loo,
    })
}

pub(super) fn obs_of(t: &TurnResidual, value: f64, duration_s: f64, model_w: f64) -> Obs {
    Obs {
        value,
        run: t.run_index,
        key: repeat_key(t.r_over_r_prime),
        row: t.row,
        part: t.part,
        model_w,
        model_se_w: t.model_se_w,
        duration_s,
    }
}

/// Stable seed of a group label (FNV-1a), so every group has its own resampling stream.
pub(super) fn seed_of(label: &str) -> u64 {
    label.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Groups by regime × side and by side (turns only) of per-observation values (with each
/// observation's duration and model power, the floor's base).
pub(super) fn grouped(
    prefix: &str,
    items: &[(&TurnResidual, f64, f64, f64)],
    floor: Floor,
    tests: &[LooTest],
) -> (Vec<GroupStat>, Vec<GroupStat>) {
    let mut by_regime: BTreeMap<(Regime, Part), Values> = BTreeMap::new();
    let mut by_side: BTreeMap<Part, Values> = BTreeMap::new();
    for (t, v, dur, model_w) in items {
        let x = obs_of(t, *v, *dur, *model_w);
        by_regime.entry((t.regime, t.part)).or_default().push(x);
        if t.regime != Regime::Straight {
            by_side.entry(t.part).or_default().push(x);
        }
    }
    let regime_stats = by_regime
        .into_iter()
        .filter_map(|((regime, part), v)| {
            let label = regime_side_label(regime, part);
            stat(label, &v, floor, group_seed(prefix, regime, part), tests)
        })
        .collect();
    let side_stats = by_side
        .into_iter()
        .filter_map(|(part, v)| {
            let label = part.id().to_owned();
            let seed = seed_of(&format!("{prefix}:{label}"));
            // A side pools different regimes: its rows are judged in their regime's group.
            stat(label, &v, floor, seed, &[])
        })
        .collect();
    (regime_stats, side_stats)
}

/// One metric's groups.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MetricWhere {
    /// The metric.
    pub metric: Metric,
    /// Its unit.
    pub unit: &'static str,
    /// What its residual measures.
    pub what: &'static str,
    /// Per (regime, side), `regime/side`.
    pub by_regime_side: Vec<GroupStat>,
    /// Per side over the turns (straights excluded), `inner`/`outer`/`total`.
    pub by_side: Vec<GroupStat>,
}
