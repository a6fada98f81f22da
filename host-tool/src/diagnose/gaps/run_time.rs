//! The run-time grouping of the effective-power residual: thirds of each run's time and the
//! within-(regime, side) trend over run time with its permutation test.

use super::groups::{obs_of, seed_of, stat, GroupStat, Values};
use super::judge::{practical_floor_w, Floor};
use super::residuals::TurnResidual;
use crate::diagnose::features::TurnRow;
use crate::diagnose::observe::{Part, RowResidual};
use model_core::kinematics::Regime;
use model_core::rng::SplitMix64;
use serde::Serialize;
use std::collections::BTreeMap;

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
pub(super) type TimedObs = ((Regime, Part), f64, f64);

/// The trend fit's observation of a timed residual (run time 0 when untimed).
pub(super) fn timed_obs(t: &TurnResidual) -> TimedObs {
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
pub(super) const TREND_ALPHA: f64 = 0.01;

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
pub(super) fn permutation_p(timed: &[&TurnResidual], observed: f64) -> f64 {
    permutation_p_until(timed, observed, TREND_STOP_EXCEEDANCES)
}

/// [`permutation_p`] stopped at `stop_at` shuffles reaching the observed slope (never, with
/// `usize::MAX`: the full test).
pub(super) fn permutation_p_until(timed: &[&TurnResidual], observed: f64, stop_at: usize) -> f64 {
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
pub(super) fn within_slope(obs: &[TimedObs]) -> Option<f64> {
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

pub(super) fn run_time(turns: &[TurnResidual]) -> RunTimeWhere {
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
