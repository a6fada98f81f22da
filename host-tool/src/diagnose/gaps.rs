//! Where the model departs: residuals of every manoeuvre and side against the baseline
//! (hard-ground Eq 21 fitted on the calibration manoeuvres), for four metrics, grouped by
//! regime, side, phase of the turn and run time, each group with a 95 % bootstrap interval over
//! the repeats ([`stats::bootstrap_mean`], resampling whole runs).
//!
//! | metric | measured | model prediction | unit |
//! |---|---|---|---|
//! | `avg-power` | average power over the steady part | Eq 21 side power | W |
//! | `max-power` | largest one-sample power of the steady part | Eq 21 side power (the steady model is all the ICR model says about a peak) | W |
//! | `energy` | energy over the manoeuvre | Eq 21 side power × expected duration | J |
//! | `effective-power` | E / T_expected (the selection's metric) | Eq 21 side power | W |
//!
//! The raw `max-power` residual is **peak over steady model**: it is positive on every
//! manoeuvre, from the sensor noise and ripple alone. Its groups are therefore tested as peak
//! over steady model **less the same quantity on the run's calibration manoeuvres** (mean over
//! their sides), i.e. against the peak excess the model is trusted with; the per-turn table keeps
//! the raw value.
//!
//! - **Phase**: the growth of a side's average power from the first to the second half of the
//!   steady part. The model is steady, so the residual's growth is the growth itself.
//! - **Run time**: the effective-power residual less its (regime, side) group mean, so that a
//!   fixed turn order (the same regime at the same time in every run) does not pass for a time
//!   pattern; grouped by third of the run's time and fitted as a within-group slope over run
//!   time. The slope needs each group to recur at different times (long runs with repeats);
//!   otherwise it is reported as not identifiable.
//! - **Significant**: the interval excludes 0 and the mean exceeds the practical floor
//!   ([`stats::PRACTICAL_FLOOR_W`]; for the effective-power gaps the selection uses, the larger of
//!   that and [`stats::RELATIVE_FLOOR`] of the group's mean |model power| ([`practical_floor_w`]);
//!   for energy, that power over the group's mean expected duration;
//!   for the trend, that power as the change over the median run length).
//!
//! Straights' sides are labelled inner/outer by convention only, so the by-side groups hold turns
//! only. Total-only rows (per-turn summaries) form their own `total` side and have average and
//! effective power only.

mod analysis;
mod judge;

use super::baseline::Baseline;
use super::features::{SideRole, TurnRow};
use super::loo::LooTest;
use super::observe::RowResidual;
use crate::effect_id::EffectId;
pub use analysis::analyse;
use judge::{judge, repeat_key, Floor, Obs};
pub use judge::{practical_floor_w, RowVerdicts, SIGNIFICANCE_RULE};
use model_core::kinematics::Regime;
use model_core::rng::SplitMix64;
use serde::Serialize;
use std::collections::BTreeMap;

/// Which part of a manoeuvre an observation is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Part {
    /// The side towards the turning centre (straights: by convention).
    Inner,
    /// The side away from it.
    Outer,
    /// Both sides together (total-only rows).
    Total,
}

impl Part {
    /// Stable identifier (`inner`, `outer`, `total`).
    pub const fn id(self) -> &'static str {
        match self {
            Part::Inner => "inner",
            Part::Outer => "outer",
            Part::Total => "total",
        }
    }
}

impl From<SideRole> for Part {
    fn from(role: SideRole) -> Self {
        match role {
            SideRole::Inner => Part::Inner,
            SideRole::Outer => Part::Outer,
        }
    }
}

impl PartialEq<SideRole> for Part {
    fn eq(&self, other: &SideRole) -> bool {
        *self == Part::from(*other)
    }
}

/// The mean effective-power residual of one (regime, side) group: the gaps the selection uses.
/// It is the `effective-power` group of the same name in [`WhereAnalysis`], judged by the same
/// rule ([`judge`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Gap {
    /// The regime.
    pub regime: Regime,
    /// Inner, outer (straights: by convention) or the total of total-only rows.
    pub side: Part,
    /// Observations.
    pub n: usize,
    /// Mean effective-power residual [W] (without repeats: of the leave-one-out residuals).
    pub mean_w: f64,
    /// 95 % interval [W]: over repeats, or without repeats from the leave-one-out prediction
    /// intervals (unadjusted; ±∞ when neither exists).
    pub ci_w: (f64, f64),
    /// The practical floor |mean| must exceed: max(1.5 W, 5 % of the group's mean model
    /// effective power) [W].
    pub floor_w: f64,
    /// Beyond the noise and the practical floor ([`judge`]).
    pub significant: bool,
    /// Without repeats: the leave-one-out test of each observation (empty with repeats).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub loo: Vec<LooTest>,
}

impl Gap {
    /// Whether the gap is at sides held at stall (commanded still in a turn: the inner side at
    /// R′, holding its tread's force), in every row of its regime; never for a total.
    pub fn at_sides_held_at_stall(&self, rows: &[TurnRow]) -> bool {
        self.side != Part::Total
            && rows.iter().filter(|r| r.regime == self.regime).all(|r| {
                (0..r.sides.len())
                    .filter(|&s| self.side == r.sides[s].role)
                    .all(|s| super::baseline::held_at_stall(r, s))
            })
    }
}

/// The observations of `row` with their part, effective-power residual, model power and the
/// model power's standard error [W].
fn effective_parts(baseline: &Baseline, row: &TurnRow) -> Vec<(Part, f64, f64, f64)> {
    let res = baseline.observed_residuals_w(row);
    if res.is_total() {
        vec![(
            Part::Total,
            res[0],
            baseline.power_w(row),
            baseline.effective_power_se_w(row),
        )]
    } else {
        row.sides
            .iter()
            .zip(res.iter())
            .enumerate()
            .map(|(k, (s, r))| {
                (
                    Part::from(s.role),
                    *r,
                    baseline.effective_side_power_w(row, k),
                    baseline.effective_side_power_se_w(row, k),
                )
            })
            .collect()
    }
}

/// Effective-power gaps per (regime, side), judged by [`judge`] (the selection's input): the
/// same numbers as the `effective-power` groups of [`analyse`].
pub fn effective_gaps(baseline: &Baseline, rows: &[TurnRow], verdicts: &RowVerdicts) -> Vec<Gap> {
    let mut gaps = Vec::new();
    for regime in Regime::ALL {
        for part in [Part::Inner, Part::Outer, Part::Total] {
            let picked: Vec<Obs> = rows
                .iter()
                .enumerate()
                .filter(|(_, r)| r.regime == regime)
                .flat_map(|(i, r)| {
                    effective_parts(baseline, r)
                        .into_iter()
                        .filter(|(p, ..)| *p == part)
                        .map(move |(_, value, model_w, model_se_w)| Obs {
                            value,
                            run: r.run_index,
                            key: repeat_key(r.r_over_r_prime),
                            row: i,
                            part,
                            model_w,
                            model_se_w,
                            duration_s: r.expected_duration_s,
                        })
                })
                .collect();
            let seed = group_seed(Metric::EffectivePower.id(), regime, part);
            if let Some(j) = judge(&picked, Floor::Power, seed, &verdicts.effective) {
                gaps.push(Gap {
                    regime,
                    side: part,
                    n: picked.len(),
                    mean_w: j.mean,
                    ci_w: j.ci,
                    floor_w: j.floor,
                    significant: j.significant,
                    loo: j.loo,
                });
            }
        }
    }
    gaps
}

/// The resampling seed of a `metric`'s (regime, side) group: the same for the gaps and the
/// "where" groups, so both draw the same interval.
fn group_seed(metric: &str, regime: Regime, part: Part) -> u64 {
    seed_of(&format!("{metric}:{}/{}", regime.id(), part.id()))
}

/// A residual metric of the "where" analysis (see the module's table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Metric {
    /// Average power over the steady part [W].
    AvgPower,
    /// Largest one-sample power of the steady part, over the steady model [W].
    MaxPower,
    /// Energy over the manoeuvre against model power × expected duration [J].
    Energy,
    /// E / T_expected [W].
    EffectivePower,
}

impl Metric {
    /// Every metric, in report order.
    pub const ALL: [Metric; 4] = [
        Metric::AvgPower,
        Metric::MaxPower,
        Metric::Energy,
        Metric::EffectivePower,
    ];

    /// Stable identifier.
    pub const fn id(self) -> &'static str {
        match self {
            Metric::AvgPower => "avg-power",
            Metric::MaxPower => "max-power",
            Metric::Energy => "energy",
            Metric::EffectivePower => "effective-power",
        }
    }

    /// Unit of the residual.
    pub const fn unit(self) -> &'static str {
        match self {
            Metric::Energy => "J",
            _ => "W",
        }
    }

    /// What the residual measures (measured minus model).
    pub const fn what(self) -> &'static str {
        match self {
            Metric::AvgPower => "steady-part average power minus Eq 21 power",
            Metric::MaxPower => {
                "peak one-sample power minus Eq 21 (steady) power, less the same peak excess \
                 on the run's calibration manoeuvres"
            }
            Metric::Energy => "manoeuvre energy minus Eq 21 power x expected duration",
            Metric::EffectivePower => "energy / expected duration minus Eq 21 power",
        }
    }
}

/// The residuals of one observation (a side, or a total-only row's total) of one manoeuvre.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TurnResidual {
    /// Index of the row in the diagnosis' input.
    pub row: usize,
    /// The run's index.
    pub run_index: usize,
    /// Regime.
    pub regime: Regime,
    /// R/R' (∞ for straights).
    pub r_over_r_prime: f64,
    /// Which side.
    pub part: Part,
    /// Whether the row is a calibration manoeuvre.
    pub calibration_kind: bool,
    /// The baseline's power of this observation [W] (the relative practical floor's base for
    /// the average and peak power).
    pub model_w: f64,
    /// The baseline's effective power of this observation [W] (the floor's base for the
    /// effective power and the energy, as in [`effective_gaps`]).
    pub model_effective_w: f64,
    /// Standard error of the baseline's effective power here [W].
    pub model_se_w: f64,
    /// Run time at the middle of the manoeuvre [s]; `None` for total-only rows.
    pub t_mid_s: Option<f64>,
    /// Average power minus model [W].
    pub avg_power_w: f64,
    /// Peak minus steady model power [W] (raw, see the module doc); `None` for total-only rows.
    pub peak_over_model_w: Option<f64>,
    /// Energy minus model power × expected duration [J]; `None` for total-only rows.
    pub energy_j: Option<f64>,
    /// Effective power minus model [W].
    pub effective_power_w: f64,
    /// Second minus first half of the steady part [W]; `None` if too short or total-only.
    pub growth_w: Option<f64>,
}

/// Per-turn residuals of every observation of `rows`.
pub fn turn_residuals(baseline: &Baseline, rows: &[TurnRow]) -> Vec<TurnResidual> {
    let mut out = Vec::new();
    for (i, row) in rows.iter().enumerate() {
        let base = |part: Part| TurnResidual {
            row: i,
            run_index: row.run_index,
            regime: row.regime,
            r_over_r_prime: row.r_over_r_prime,
            part,
            calibration_kind: row.calibration_kind,
            model_w: 0.0,
            model_effective_w: 0.0,
            model_se_w: 0.0,
            t_mid_s: None,
            avg_power_w: 0.0,
            peak_over_model_w: None,
            energy_j: None,
            effective_power_w: 0.0,
            growth_w: None,
        };
        if row.is_total_only() {
            let model_w = baseline.power_w(row);
            let r = row.effective_power_w() - model_w;
            out.push(TurnResidual {
                model_w,
                model_effective_w: model_w,
                model_se_w: baseline.effective_power_se_w(row),
                avg_power_w: r,
                effective_power_w: r,
                ..base(Part::Total)
            });
            continue;
        }
        for (k, s) in row.sides.iter().enumerate() {
            let model_w = baseline.side_power_w(row, k);
            let model_effective_w = baseline.effective_side_power_w(row, k);
            out.push(TurnResidual {
                model_w,
                model_effective_w,
                model_se_w: baseline.effective_side_power_se_w(row, k),
                t_mid_s: Some(row.t_start_s + 0.5 * row.duration_s),
                avg_power_w: s.avg_power_w - model_w,
                peak_over_model_w: Some(s.max_power_w - model_w),
                energy_j: Some(s.energy_j - model_effective_w * row.expected_duration_s),
                effective_power_w: s.effective_power_w - model_effective_w,
                growth_w: s.growth_w,
                ..base(Part::from(s.role))
            });
        }
    }
    out
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
type Values = Vec<Obs>;

/// The [`GroupStat::group`] of a regime and side: `regime/side` (`dragged-inner/inner`).
pub fn regime_side_label(regime: Regime, part: Part) -> String {
    format!("{}/{}", regime.id(), part.id())
}

fn stat(
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

fn obs_of(t: &TurnResidual, value: f64, duration_s: f64, model_w: f64) -> Obs {
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
fn seed_of(label: &str) -> u64 {
    label.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Groups by regime × side and by side (turns only) of per-observation values (with each
/// observation's duration and model power, the floor's base).
fn grouped(
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

/// The residual's trend over run time.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Trend {
    /// Observations in the fit.
    pub n: usize,
    /// Within-(regime, side) slope of the effective-power residual over run time [W/min].
    pub slope_w_per_min: f64,
    /// Two-sided permutation p-value (manoeuvre times shuffled within each run).
    pub p_value: f64,
    /// Median run length [min].
    pub run_length_min: f64,
    /// The slope's change over the median run length [W].
    pub change_w: f64,
    /// The practical floor |change| must exceed: the gaps' floor over the timed manoeuvres [W].
    pub floor_w: f64,
    /// p below [`TREND_ALPHA`] and |change| > `floor_w`.
    pub significant: bool,
}

/// Run-time grouping of the effective-power residual.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunTimeWhere {
    /// First, middle and last third of each run's time (residual less its (regime, side) mean).
    pub thirds: Vec<GroupStat>,
    /// The within-group slope, if the data identify it.
    pub trend: Option<Trend>,
    /// Why there is no trend, when there is none.
    pub note: Option<String>,
}

/// Within-group spread of run time below which the trend is not identifiable [s].
pub const MIN_TREND_SPREAD_S: f64 = 10.0;

/// One observation of the trend fit: ((regime, side), run time [s], residual [W]).
type TimedObs = ((Regime, Part), f64, f64);

/// The trend fit's observation of a timed residual (run time 0 when untimed).
fn timed_obs(t: &TurnResidual) -> TimedObs {
    (
        (t.regime, t.part),
        t.t_mid_s.unwrap_or(0.0),
        t.effective_power_w,
    )
}

/// The median of the runs' lengths (`run_end`: each run's latest manoeuvre middle) [s].
fn median_run_length_s(run_end: &BTreeMap<usize, f64>) -> f64 {
    let mut lengths: Vec<f64> = run_end.values().copied().collect();
    lengths.sort_by(f64::total_cmp);
    lengths.get(lengths.len() / 2).copied().unwrap_or(0.0)
}

/// The run-time trend of held-out residuals `res` of `rows`, as its change over the median run
/// length [W] (the within-(regime, side) slope of [`Trend`]); `None` when run time is not
/// identifiable or the rows are total-only.
pub fn heldout_run_time_change_w(rows: &[TurnRow], res: &[RowResidual]) -> Option<f64> {
    let mut obs: Vec<TimedObs> = Vec::new();
    let mut run_end: BTreeMap<usize, f64> = BTreeMap::new();
    for r in res.iter().filter(|r| !r.effective_w.is_total()) {
        let row = &rows[r.row];
        let t_mid = row.t_start_s + 0.5 * row.duration_s;
        let end = run_end.entry(row.run_index).or_insert(0.0);
        *end = end.max(t_mid);
        for (side, value) in row.sides.iter().zip(r.effective_w.iter()) {
            obs.push(((row.regime, Part::from(side.role)), t_mid, *value));
        }
    }
    Some(within_slope(&obs)? * median_run_length_s(&run_end))
}

/// Significance level of the run-time trend's permutation test.
const TREND_ALPHA: f64 = 0.01;

/// Permutations of the run-time trend's test.
const TREND_PERMUTATIONS: usize = 999;

/// Shuffles reaching the observed slope after which the test stops (Besag and Clifford's
/// sequential Monte Carlo p-value): with this many, the full test's p would be at least
/// (h + 1)/(N + 1) > [`TREND_ALPHA`], so the decision is already the full test's.
const TREND_STOP_EXCEEDANCES: usize = 10;

/// Two-sided permutation p-value of the within-(regime, side) slope `observed` of `timed`: each
/// run's manoeuvre times are shuffled among its manoeuvres (both sides of one manoeuvre keep one
/// time), and p is the share of shuffles whose |slope| reaches |observed| (without
/// [`within_slope`]'s spread gate: a shuffle it would drop must not count for the trend).
/// Without a trend the residuals do not depend on when in its run a manoeuvre was driven,
/// whatever a run's own level; with three runs a bootstrap over runs (10 distinct resamples)
/// called a control's noise a trend. The test stops at [`TREND_STOP_EXCEEDANCES`] such shuffles,
/// with p = h/L after L of them (a valid p-value, Besag and Clifford 1991): a trend far from
/// significant costs a few dozen shuffles, and every p up to h/(N + 1) = 0.01 is the full
/// test's.
fn permutation_p(timed: &[&TurnResidual], observed: f64) -> f64 {
    permutation_p_until(timed, observed, TREND_STOP_EXCEEDANCES)
}

/// [`permutation_p`] stopped at `stop_at` shuffles reaching the observed slope (never, with
/// `usize::MAX`: the full test).
fn permutation_p_until(timed: &[&TurnResidual], observed: f64, stop_at: usize) -> f64 {
    // Each run's manoeuvres (as slots, one per row) and their times.
    let mut manoeuvres: BTreeMap<usize, Vec<(usize, f64)>> = BTreeMap::new();
    let mut slot_of_row: BTreeMap<usize, usize> = BTreeMap::new();
    for t in timed {
        let next = slot_of_row.len();
        let slot = *slot_of_row.entry(t.row).or_insert(next);
        // A row's first side gives its manoeuvre a slot in its run (the other side shares it).
        if slot == next {
            let list = manoeuvres.entry(t.run_index).or_default();
            list.push((slot, t.t_mid_s.unwrap_or(0.0)));
        }
    }
    // Dense indices, so that a shuffle costs no map look-ups (999 of them per diagnosis).
    let slots: Vec<usize> = timed.iter().map(|t| slot_of_row[&t.row]).collect();
    let (groups, group_count) = group_ids(timed.iter().map(|t| (t.regime, t.part)));
    let y: Vec<f64> = timed.iter().map(|t| t.effective_power_w).collect();
    let mut within = WithinGroups::new(groups, group_count, &y);
    let mut rng = SplitMix64::new(seed_of("run-time-trend"));
    let mut time_of = vec![0.0; slot_of_row.len()];
    let mut t: Vec<f64> = vec![0.0; timed.len()];
    let mut times: Vec<f64> = Vec::new();
    let mut extreme = 0usize;
    for done in 1..=TREND_PERMUTATIONS {
        for list in manoeuvres.values() {
            times.clear();
            times.extend(list.iter().map(|m| m.1));
            for i in (1..times.len()).rev() {
                times.swap(i, rng.below(i + 1));
            }
            for (m, time) in list.iter().zip(&times) {
                time_of[m.0] = *time;
            }
        }
        for (ti, &slot) in t.iter_mut().zip(&slots) {
            *ti = time_of[slot];
        }
        // A shuffle that leaves no time spread within any group counts against the trend.
        if within
            .slope_and_spread(&t)
            .is_none_or(|(s, _)| s.abs() >= observed.abs())
        {
            extreme += 1;
            if extreme == stop_at {
                return extreme as f64 / done as f64;
            }
        }
    }
    (extreme + 1) as f64 / (TREND_PERMUTATIONS + 1) as f64
}

/// Each key's group index (in order of first appearance) and the number of groups.
fn group_ids<K: Ord>(keys: impl Iterator<Item = K>) -> (Vec<usize>, usize) {
    let mut index: BTreeMap<K, usize> = BTreeMap::new();
    let ids = keys
        .map(|k| {
            let next = index.len();
            *index.entry(k).or_insert(next)
        })
        .collect();
    (ids, index.len())
}

/// Within-(regime, side) slope of `y` on `t` [W/s]; `None` when the spread of t is too small.
fn within_slope(obs: &[TimedObs]) -> Option<f64> {
    let (slope, spread) = slope_and_spread(obs)?;
    (spread >= MIN_TREND_SPREAD_S).then_some(slope)
}

/// Within-(regime, side) slope of `y` on `t` [W/s] and the RMS within-group spread of t [s];
/// `None` when t does not vary within any group.
fn slope_and_spread(obs: &[TimedObs]) -> Option<(f64, f64)> {
    let (groups, count) = group_ids(obs.iter().map(|o| o.0));
    let t: Vec<f64> = obs.iter().map(|o| o.1).collect();
    let y: Vec<f64> = obs.iter().map(|o| o.2).collect();
    WithinGroups::new(groups, count, &y).slope_and_spread(&t)
}

/// The within-group regression of fixed values y on times that the permutation test shuffles:
/// each observation's group and y less its group's mean are computed once, and each set of
/// times costs two passes without allocation.
struct WithinGroups {
    groups: Vec<usize>,
    size: Vec<f64>,
    centred_y: Vec<f64>,
    /// Per group: the sum, then the mean, of the times (scratch of [`Self::slope_and_spread`]).
    mean_t: Vec<f64>,
}

impl WithinGroups {
    /// Observations `(groups[i], y[i])` in `group_count` groups.
    fn new(groups: Vec<usize>, group_count: usize, y: &[f64]) -> Self {
        let mut sum_y = vec![0.0; group_count];
        let mut size = vec![0.0; group_count];
        for (&g, &yi) in groups.iter().zip(y) {
            sum_y[g] += yi;
            size[g] += 1.0;
        }
        let centred_y = groups
            .iter()
            .zip(y)
            .map(|(&g, &yi)| yi - sum_y[g] / size[g])
            .collect();
        Self {
            groups,
            size,
            centred_y,
            mean_t: vec![0.0; group_count],
        }
    }

    /// The within-group slope of y on `t` [W/s] and the within-group spread of `t` (its RMS
    /// about the group means) [s]; `None` when no group's times vary.
    fn slope_and_spread(&mut self, t: &[f64]) -> Option<(f64, f64)> {
        self.mean_t.fill(0.0);
        for (&g, &ti) in self.groups.iter().zip(t) {
            self.mean_t[g] += ti;
        }
        for (m, n) in self.mean_t.iter_mut().zip(&self.size) {
            *m /= n;
        }
        let (mut stt, mut sty) = (0.0, 0.0);
        for ((&g, &ti), &dy) in self.groups.iter().zip(t).zip(&self.centred_y) {
            let dt = ti - self.mean_t[g];
            stt += dt * dt;
            sty += dt * dy;
        }
        let spread = (stt / self.groups.len().max(1) as f64).sqrt();
        (stt > 0.0).then(|| (sty / stt, spread))
    }
}

fn run_time(turns: &[TurnResidual]) -> RunTimeWhere {
    let timed: Vec<&TurnResidual> = turns.iter().filter(|t| t.t_mid_s.is_some()).collect();
    // Each run's length: the latest manoeuvre middle (a lower bound of the run's time).
    let mut run_end: BTreeMap<usize, f64> = BTreeMap::new();
    for t in &timed {
        let e = run_end.entry(t.run_index).or_insert(0.0);
        *e = e.max(t.t_mid_s.unwrap_or(0.0));
    }
    let mut group_mean: BTreeMap<(Regime, Part), (f64, f64)> = BTreeMap::new();
    for t in &timed {
        let e = group_mean.entry((t.regime, t.part)).or_default();
        e.0 += t.effective_power_w;
        e.1 += 1.0;
    }
    let centred = |t: &TurnResidual| {
        let (s, n) = group_mean[&(t.regime, t.part)];
        t.effective_power_w - s / n
    };
    let mut thirds_values: [Values; 3] = Default::default();
    for t in &timed {
        let end = run_end[&t.run_index];
        let tm = t.t_mid_s.unwrap_or(0.0);
        let k = if end > 0.0 {
            ((3.0 * tm / end) as usize).min(2)
        } else {
            0
        };
        thirds_values[k].push(obs_of(t, centred(t), 0.0, t.model_effective_w));
    }
    let thirds = ["first-third", "middle-third", "last-third"]
        .iter()
        .zip(&thirds_values)
        .filter_map(|(label, v)| {
            stat(
                (*label).to_owned(),
                v,
                Floor::CentredPower,
                seed_of(label),
                &[],
            )
        })
        .collect();

    let all: Vec<TimedObs> = timed.iter().map(|t| timed_obs(t)).collect();
    let Some(slope) = within_slope(&all) else {
        return RunTimeWhere {
            thirds,
            trend: None,
            note: Some(format!(
                "run-time trend not identifiable: the manoeuvres of a (regime, side) group do not \
                 recur at run times spread by {MIN_TREND_SPREAD_S} s or more (longer runs with \
                 repeats are needed)"
            )),
        };
    };
    let p_value = permutation_p(&timed, slope);
    let run_length_s = median_run_length_s(&run_end);
    let change_w = slope * run_length_s;
    // The floor of the gaps: a share of the model's effective power over the timed manoeuvres.
    let model_w: Vec<f64> = timed.iter().map(|t| t.model_effective_w).collect();
    let floor_w = practical_floor_w(&model_w);
    RunTimeWhere {
        thirds,
        trend: Some(Trend {
            n: all.len(),
            slope_w_per_min: slope * 60.0,
            p_value,
            run_length_min: run_length_s / 60.0,
            change_w,
            floor_w,
            significant: p_value < TREND_ALPHA && change_w.abs() > floor_w,
        }),
        note: None,
    }
}

/// The significant leave-one-out test with the largest |t| among `loo` whose residual exceeds
/// `floor`.
fn strongest(loo: &[LooTest], floor: f64) -> Option<&LooTest> {
    loo.iter()
        .filter(|t| t.beyond_noise && t.residual_w.abs() > floor)
        .max_by(|a, b| a.t.abs().total_cmp(&b.t.abs()))
}

impl LooTest {
    /// One line: the row, its leave-one-out residual and the significance statement.
    pub fn statement(&self, rows: &[TurnRow]) -> String {
        let what = rows.get(self.row).map_or_else(String::new, |r| {
            if r.radius_cmd_m.is_finite() {
                format!("R = {:.2} m ", r.radius_cmd_m)
            } else {
                "straight ".to_owned()
            }
        });
        format!(
            "{what}{:+.1} W against the baseline refitted without it ({:.1} W, 95 % prediction \
             interval [{:.1}, {:.1}]): t = {:.2}, df = {}, p = {:.3} (adjusted {:.3}; plain Holm \
             over all tested rows {:.3})",
            self.residual_w,
            self.prediction_w,
            self.interval_w.0,
            self.interval_w.1,
            self.t,
            self.df,
            self.p,
            self.p_adjusted,
            self.p_holm_all
        )
    }
}

/// Where the model departs: per-turn residuals and their groups.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WhereAnalysis {
    /// One line: the significant groups, or that there is no gap beyond the repeat noise.
    pub statement: String,
    /// Whether any finding of the diagnosed metric is (the headline's `significant` agrees).
    pub significant: bool,
    /// Every significant group of the diagnosed metric (effective power by regime and side, its
    /// run-time trend), one line each, largest (relative to its floor) first.
    pub findings: Vec<String>,
    /// The other metrics' significant groups (average and peak power, energy, growth, run-time
    /// thirds), same order: reported, not counted in the verdict.
    pub other_findings: Vec<String>,
    /// Caveats of the data (total-only rows, one run, ...).
    pub notes: Vec<String>,
    /// Groups of each metric (metrics with no observation are left out).
    pub metrics: Vec<MetricWhere>,
    /// Growth of average power through the turn (second minus first half of the steady part),
    /// `regime/side` and per side over turns [W].
    pub phase_by_regime_side: Vec<GroupStat>,
    /// Growth through the turn per side over turns [W].
    pub phase_by_side: Vec<GroupStat>,
    /// Run-time grouping.
    pub run_time: RunTimeWhere,
    /// Per-turn, per-side residuals.
    pub turns: Vec<TurnResidual>,
}

impl WhereAnalysis {
    /// Whether the effective-power residual's run-time trend is significant: a departure of the
    /// diagnosed metric that no regime's mean shows (heating grows in every regime), so the
    /// headline counts it.
    pub fn departs_over_run_time(&self) -> bool {
        self.run_time.trend.as_ref().is_some_and(|t| t.significant)
    }

    /// Records a departure that no group shows but cross-validation does: the selection's clear
    /// winner `effect` (held-out RMS `before` → `after` under `scheme`) removes at least the
    /// practical floor of held-out RMS (e.g. a slope, whose power
    /// changes sign along the path, so its group means are ~0). The diagnosis' `significant`
    /// counts it, so the "where" analysis must too.
    pub fn add_heldout_departure(
        &mut self,
        effect: EffectId,
        (before, after): (f64, f64),
        scheme: &str,
        floor_w: f64,
    ) {
        let removed = (before.powi(2) - after.powi(2)).max(0.0).sqrt();
        let finding = format!(
            "held out ({}): {} removes {removed:.1} W RMS ({:.2} → {:.2} W), more than the \
             {floor_w:.1} W floor, although no group's mean departs on its own",
            scheme, effect, before, after,
        );
        self.statement = if self.significant {
            format!("{}; {finding}", self.statement)
        } else {
            format!("departure beyond the noise out of sample: {finding}")
        };
        self.findings.push(finding);
        self.significant = true;
    }
}

#[cfg(test)]
mod tests;
