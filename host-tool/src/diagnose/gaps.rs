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
mod groups;
mod judge;
mod residuals;
mod run_time;

use super::baseline::Baseline;
use super::features::TurnRow;
use super::loo::LooTest;
pub use super::observe::Part;
pub use analysis::{analyse, WhereAnalysis};
use groups::group_seed;
pub use groups::{regime_side_label, GroupStat, MetricWhere};
use judge::{judge, repeat_key, Floor, Obs};
pub use judge::{practical_floor_w, RowVerdicts, SIGNIFICANCE_RULE};
use model_core::kinematics::Regime;
pub use residuals::{turn_residuals, Metric, TurnResidual};
pub use run_time::{heldout_run_time_change_w, RunTimeWhere, Trend, MIN_TREND_SPREAD_S};
use serde::Serialize;

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

#[cfg(test)]
mod tests;
