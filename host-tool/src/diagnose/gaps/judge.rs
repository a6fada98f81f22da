//! The one significance rule of the diagnosis ([`judge`]): the selection's gaps and every group
//! of the "where" analysis are decided by it, with repeats from the interval over them and
//! without from the leave-one-out tests of [`loo`](super::super::loo).

use super::super::calibration::Calibration;
use super::super::features::TurnRow;
use super::super::loo::{self, LooTest, Measure};
use super::super::observe::{self, Part};
use super::super::stats;
use model_core::kinematics::Regime;
use std::collections::BTreeMap;

/// Key of "the same manoeuvre" for repeats within one run: R/R' to 0.01 (straights one key).
pub(super) fn repeat_key(r_over_r_prime: f64) -> i64 {
    if r_over_r_prime.is_finite() {
        (r_over_r_prime * 100.0).round() as i64
    } else {
        i64::MAX
    }
}

/// Whether a group's values carry a noise estimate: ≥ 2 runs, or, in one run, at least one
/// manoeuvre repeated at the same R/R'. Otherwise the spread of a group is the spread between
/// different radii (model misfit, e.g. a summary table's one row per radius), not repeat noise.
fn has_repeats(runs_and_keys: &[(usize, i64)]) -> bool {
    let mut runs: Vec<usize> = runs_and_keys.iter().map(|x| x.0).collect();
    runs.sort_unstable();
    runs.dedup();
    let mut keys: Vec<i64> = runs_and_keys.iter().map(|x| x.1).collect();
    keys.sort_unstable();
    runs.len() >= 2 || keys.windows(2).any(|w| w[0] == w[1])
}

/// One observation of a group.
#[derive(Debug, Clone, Copy)]
pub(super) struct Obs {
    /// The residual (the metric's unit).
    pub(super) value: f64,
    pub(super) run: usize,
    pub(super) key: i64,
    pub(super) row: usize,
    pub(super) part: Part,
    /// The baseline's power of the observation [W] (the relative floor).
    pub(super) model_w: f64,
    /// Its standard error from the baseline's fit [W]: shared by every observation of a group,
    /// so it widens the interval of their mean instead of averaging out.
    pub(super) model_se_w: f64,
    /// Expected duration [s] (the energy floor).
    pub(super) duration_s: f64,
}

/// Which practical floor a group's mean must exceed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Floor {
    /// [`practical_floor_w`] of the observations' model power (power metrics) [W].
    Power,
    /// That power floor over the mean expected duration (energy) [J].
    Energy,
    /// The power floor for values centred on their (regime, side) mean (run-time groups): the
    /// baseline's error is common to a group, so centring removes it and it does not widen.
    CentredPower,
    /// [`stats::PRACTICAL_FLOOR_W`] (growth: no model power to take a share of) [W].
    Fixed,
}

/// [`judge`]'s rule in words, for reports.
pub const SIGNIFICANCE_RULE: &str = "with repeats, the 95 % interval over them, widened by the \
     baseline's own fit error, excludes 0; \
     without, a row lies outside its leave-one-out 95 % prediction interval (externally \
     studentised t, Holm-adjusted, turns with R ≤ R′ first); and |mean| above the practical \
     floor, max(1.5 W, 5 % of the model power)";

/// A group's verdict: mean, 95 % interval, practical floor, significance and, without repeats,
/// the leave-one-out tests behind it.
pub(super) struct Judgement {
    pub(super) mean: f64,
    pub(super) ci: (f64, f64),
    pub(super) floor: f64,
    pub(super) significant: bool,
    pub(super) loo: Vec<LooTest>,
}

/// **The one significance rule** of the diagnosis, for the selection's gaps and every group of
/// the "where" analysis alike:
/// - with repeats ([`has_repeats`]): the mean's 95 % interval over them
///   ([`stats::bootstrap_mean`]), widened in quadrature by the baseline's 95 % error there, excludes
///   0 and |mean| > the floor;
/// - without repeats, when the observations have leave-one-out tests ([`loo`], power metrics):
///   some observation lies outside its prediction interval after the multiple-testing
///   adjustment and its leave-one-out residual exceeds the floor;
/// - otherwise: no verdict (interval ±∞, not significant).
pub(super) fn judge(obs: &[Obs], floor: Floor, seed: u64, tests: &[LooTest]) -> Option<Judgement> {
    if obs.is_empty() {
        return None;
    }
    let model_w: Vec<f64> = obs.iter().map(|o| o.model_w).collect();
    let floor_kind = floor;
    let floor = match floor {
        Floor::Power | Floor::CentredPower => practical_floor_w(&model_w),
        Floor::Energy => {
            practical_floor_w(&model_w) * obs.iter().map(|o| o.duration_s).sum::<f64>()
                / obs.len() as f64
        }
        Floor::Fixed => stats::PRACTICAL_FLOOR_W,
    };
    let pairs: Vec<(usize, i64)> = obs.iter().map(|o| (o.run, o.key)).collect();
    let values: Vec<f64> = obs.iter().map(|o| o.value).collect();
    if has_repeats(&pairs) {
        let runs: Vec<usize> = obs.iter().map(|o| o.run).collect();
        let (mean, lo, hi) = stats::bootstrap_mean(&values, &runs, seed)?;
        // The baseline's own error is common to every row of the group (its parameters were fitted
        // once, on the calibration manoeuvres): add it in quadrature to the repeats' interval.
        let n = obs.len() as f64;
        let model_hw = 1.96
            * match floor_kind {
                Floor::Power => obs.iter().map(|o| o.model_se_w).sum::<f64>() / n,
                Floor::Energy => obs.iter().map(|o| o.model_se_w * o.duration_s).sum::<f64>() / n,
                Floor::CentredPower | Floor::Fixed => 0.0,
            };
        let widen = |half: f64| half.hypot(model_hw);
        let (lo, hi) = (mean - widen(mean - lo), mean + widen(hi - mean));
        return Some(Judgement {
            mean,
            ci: (lo, hi),
            floor,
            significant: (lo > 0.0 || hi < 0.0) && mean.abs() > floor,
            loo: Vec::new(),
        });
    }
    let loo: Vec<LooTest> = obs
        .iter()
        .filter_map(|o| {
            tests
                .iter()
                .find(|t| t.row == o.row && t.part == o.part)
                .copied()
        })
        .collect();
    if loo.len() < obs.len() {
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        return Some(Judgement {
            mean,
            ci: (f64::NEG_INFINITY, f64::INFINITY),
            floor,
            significant: false,
            loo: Vec::new(),
        });
    }
    let k = loo.len() as f64;
    let mean = loo.iter().map(|t| t.residual_w).sum::<f64>() / k;
    // The interval of the mean leave-one-out residual, treating the rows as independent (exact
    // for one row; the verdict itself is per row).
    let df = loo.iter().map(|t| t.df).min().unwrap_or(0);
    let half =
        stats::t_quantile_975(df) * loo.iter().map(|t| t.se_w * t.se_w).sum::<f64>().sqrt() / k;
    let significant = loo
        .iter()
        .any(|t| t.beyond_noise && t.residual_w.abs() > floor);
    Some(Judgement {
        mean,
        ci: (mean - half, mean + half),
        floor,
        significant,
        loo,
    })
}

/// The leave-one-out tests of the observations whose (regime, side) group has no repeats, for
/// the two power metrics the baseline predicts (see [`loo`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RowVerdicts {
    /// On effective power (the selection's metric).
    pub effective: Vec<LooTest>,
    /// On average power.
    pub average: Vec<LooTest>,
}

impl RowVerdicts {
    /// Tests every observation of `rows` in a (regime, side) group without repeats.
    pub fn of(rows: &[TurnRow], calibration: Calibration<'_>) -> Self {
        let part_of = |row: &TurnRow, sides: &[usize]| match sides {
            [side] => Part::from(row.sides[*side].role),
            _ => Part::Total,
        };
        let mut groups: BTreeMap<(Regime, Part), Vec<(usize, i64)>> = BTreeMap::new();
        for row in rows {
            for sides in observe::observations(row) {
                groups
                    .entry((row.regime, part_of(row, sides)))
                    .or_default()
                    .push((row.run_index, repeat_key(row.r_over_r_prime)));
            }
        }
        let wanted = |i: usize, part: Part| {
            groups
                .get(&(rows[i].regime, part))
                .is_some_and(|g| !has_repeats(g))
        };
        Self {
            effective: loo::tests(rows, calibration, Measure::Effective, wanted),
            average: loo::tests(rows, calibration, Measure::Average, wanted),
        }
    }

    /// No tests (every group has repeats, or the caller judges repeats only).
    pub fn none() -> Self {
        Self::default()
    }
}

/// The practical floor of a group whose observations have model powers `model_w`: the larger of
/// [`stats::PRACTICAL_FLOOR_W`] and [`stats::RELATIVE_FLOOR`] of their mean |model power| [W].
pub fn practical_floor_w(model_w: &[f64]) -> f64 {
    let mean_abs = if model_w.is_empty() {
        0.0
    } else {
        model_w.iter().map(|p| p.abs()).sum::<f64>() / model_w.len() as f64
    };
    stats::PRACTICAL_FLOOR_W.max(stats::RELATIVE_FLOOR * mean_abs)
}
