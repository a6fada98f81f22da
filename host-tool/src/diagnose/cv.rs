//! Held-out scoring and selection: grouped cross-validation of the baseline with and without
//! each catalogue effect, the significance of the gap from a bootstrap over repeats, and the
//! clear-margin rule that names an effect or says `ambiguous`.
//!
//! - **Metric**: RMS over held-out manoeuvres and both sides of the effective-power residual,
//!   measured − predicted [W] (see [`features`](super::features)).
//! - **Folds**: leave-one-run-out (groups: runs; needs ≥ 2 runs) and leave-one-radius-out
//!   (groups: commanded R/R' rounded to 0.01, straights one group). In every fold the baseline is
//!   refitted on the training fold's calibration rows and the effects on the training fold's
//!   residuals ([`FittedModel::fit`]); a fold where they cannot be fitted (no training row where
//!   they act) predicts no extra power.
//! - **Penalty**: Akaike's final prediction error on the pooled held-out MSE,
//!   MSE·(n + k)/(n − k) for k fitted parameters ([`model_params`]: the terms', their growth
//!   coefficients, τ of `motor-heating`) and n held-out side observations. A second score pools
//!   the growth residuals (second minus first half of each turn) with the effective power.
//! - **Significance**: the mean baseline residual of a (regime, side) group is significant when
//!   its 95 % interval excludes 0 and its size exceeds the group's practical floor, the larger
//!   of [`PRACTICAL_FLOOR_W`] and [`RELATIVE_FLOOR`] of the group's mean |model power|. The
//!   interval is a bootstrap resampling whole runs when there are at least
//!   [`MIN_BOOTSTRAP_RUNS`], else Student's t over the manoeuvres ([`bootstrap_mean`]).
//! - **Selection**: the effect with the lowest penalised error is named when the gap is
//!   significant, it closes at least [`MIN_SHRINK_PCT`] of the held-out gap, and the runner-up's
//!   penalised MSE is at least [`CLEAR_MARGIN`] times its own; failing that, the same rule on the
//!   score with growth, then on the score with average power, then on the rows of the regimes
//!   with a significant gap only; otherwise `ambiguous`.

use super::baseline::{Baseline, BaselineError};
use super::calibration::{Calibration, Source};
use super::effects::{model_params, Context, FittedModel, HEATING_TAU_GRID_S};
use super::features::TurnRow;
use super::observe::{HeldOut, RowResidual};
use crate::diagnose::features::radius_group;
use crate::effect_id::EffectId;
use model_core::kinematics::Regime;
use model_core::Rover;
use serde::Serialize;

/// Fraction of the held-out gap the named effect must close [%].
pub const MIN_SHRINK_PCT: f64 = 30.0;
/// The runner-up's penalised MSE over the best's must be at least this.
pub const CLEAR_MARGIN: f64 = 1.5;

/// A grouping of the cross-validation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Scheme {
    /// Leave one run out.
    LeaveOneRunOut,
    /// Leave one commanded radius out.
    LeaveOneRadiusOut,
}

impl Scheme {
    /// Stable id (`leave-one-run-out`, `leave-one-radius-out`).
    pub const fn id(self) -> &'static str {
        match self {
            Scheme::LeaveOneRunOut => "leave-one-run-out",
            Scheme::LeaveOneRadiusOut => "leave-one-radius-out",
        }
    }

    fn group(self, row: &TurnRow) -> i64 {
        match self {
            Scheme::LeaveOneRunOut => row.run_index as i64,
            Scheme::LeaveOneRadiusOut => radius_group(row),
        }
    }
}

/// The manoeuvres one fold holds out.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum HeldOutGroup {
    /// One run (leave-one-run-out): its index among the diagnosed runs, from 0.
    Run {
        /// The run's index.
        run: usize,
    },
    /// One commanded radius (leave-one-radius-out), R/R′ to 0.01.
    Radius {
        /// R/R′ of the held-out turns.
        r_over_r_prime: f64,
    },
    /// The straights (leave-one-radius-out's group of them).
    Straights,
}

impl HeldOutGroup {
    /// The group `row` belongs to under `scheme`.
    fn of(scheme: Scheme, row: &TurnRow) -> Self {
        match (scheme, radius_group(row)) {
            (Scheme::LeaveOneRunOut, _) => HeldOutGroup::Run { run: row.run_index },
            (Scheme::LeaveOneRadiusOut, i64::MAX) => HeldOutGroup::Straights,
            (Scheme::LeaveOneRadiusOut, k) => HeldOutGroup::Radius {
                r_over_r_prime: k as f64 / 100.0,
            },
        }
    }

    /// In words: `run 2`, `R/R′ = 1.00`, `the straights`.
    pub fn describe(self) -> String {
        match self {
            HeldOutGroup::Run { run } => format!("run {}", run + 1),
            HeldOutGroup::Radius { r_over_r_prime } => format!("R/R′ = {r_over_r_prime:.2}"),
            HeldOutGroup::Straights => "the straights".to_owned(),
        }
    }
}

/// Largest leverage of a held-out observation that is still a prediction within what the model
/// was fitted on. Every training observation lies inside the ellipsoid z′(Z′Z)⁻¹z ≤ 1 of the
/// fitted columns Z (its own leverage is at most 1); a held-out observation beyond it is
/// predicted less precisely than one measurement (variance h·σ² > σ²): the term's shape is not
/// tested there, its extrapolation is (the regressor-hull test of regression texts, with the
/// hull's enclosing ellipsoid, so that a repeat of a training manoeuvre whose noise puts it a
/// hair past its twins is not called one).
pub const MAX_HELDOUT_LEVERAGE: f64 = 1.0;

/// Why a candidate has no out-of-sample score: one of its folds does not test it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "reason", rename_all = "kebab-case")]
pub enum NotTestable {
    /// The fold holding out `held_out` leaves no training observation that identifies the term
    /// (its columns are zero or collinear there), yet it acts on the held-out manoeuvres: its
    /// prediction there would be a guess (e.g. a term acting at one radius, one run).
    NotIdentifiable {
        /// The fold's held-out group.
        held_out: HeldOutGroup,
    },
    /// The held-out prediction for a manoeuvre of `regime` lies beyond what the term was fitted
    /// on: its leverage relative to the training fold exceeds [`MAX_HELDOUT_LEVERAGE`].
    Extrapolation {
        /// The fold's held-out group.
        held_out: HeldOutGroup,
        /// The regime of the held-out manoeuvre with the largest leverage.
        regime: Regime,
        /// That leverage, z′(Z′Z)⁻¹z.
        leverage: f64,
    },
}

impl NotTestable {
    /// Why, in words (after "not testable out of sample: ").
    pub fn describe(&self) -> String {
        match self {
            NotTestable::NotIdentifiable { held_out } => format!(
                "the fold holding out {} leaves nothing to fit the term on, yet it acts there",
                held_out.describe()
            ),
            NotTestable::Extrapolation {
                held_out,
                regime,
                leverage,
            } => format!(
                "its held-out prediction for the {} manoeuvre (fold holding out {}) extrapolates \
                 beyond the manoeuvres it was fitted on (leverage {} > {MAX_HELDOUT_LEVERAGE})",
                regime.id(),
                held_out.describe(),
                if *leverage < 1e3 {
                    format!("{leverage:.2}")
                } else {
                    format!("{leverage:.1e}")
                }
            ),
        }
    }
}

/// Held-out residuals of every row and side, before (the baseline; `effects` empty) or after
/// adding the jointly fitted `effects`, pooled over the folds of `scheme`. `Ok(None)` when the
/// scheme has fewer than 2 groups. With in-run calibration the baseline is refitted on each
/// training fold's calibration manoeuvres; with calibration runs it is theirs in every fold,
/// and their manoeuvres join every training fold of the effects (an effect must not claim power
/// on the manoeuvres the model is trusted on) but are never scored.
pub fn heldout_residuals(
    rover: &Rover,
    rows: &[TurnRow],
    scheme: Scheme,
    effects: &[EffectId],
    calibration: Calibration<'_>,
) -> Result<Option<HeldOut>, BaselineError> {
    Ok(heldout(rover, rows, scheme, effects, calibration, false)?.map(|(res, _)| res))
}

/// [`heldout_residuals`], and with `check` whether some fold does not test `effects`
/// ([`NotTestable`]: not identifiable there, else the largest extrapolation).
fn heldout(
    rover: &Rover,
    rows: &[TurnRow],
    scheme: Scheme,
    effects: &[EffectId],
    calibration: Calibration<'_>,
    check: bool,
) -> Result<Option<(HeldOut, Option<NotTestable>)>, BaselineError> {
    let mut groups: Vec<i64> = rows.iter().map(|r| scheme.group(r)).collect();
    groups.sort_unstable();
    groups.dedup();
    if groups.len() < 2 {
        return Ok(None);
    }
    // With calibration runs: their baseline and manoeuvres, the same in every fold.
    let fixed = match calibration.source {
        Source::FromRuns => None,
        Source::Rows(_) => Some((
            calibration.baseline(rover, rows)?,
            calibration.manoeuvres(rows),
        )),
    };
    let mut out = Vec::with_capacity(rows.len());
    let (mut unidentified, mut extrapolated): (Option<NotTestable>, Option<NotTestable>) =
        (None, None);
    for g in groups {
        let mut train: Vec<&TurnRow> = rows.iter().filter(|r| scheme.group(r) != g).collect();
        // The rows the baseline is fitted on: what it absorbs of a power-type term is measured
        // there (`FittedModel::fit`).
        let fold_cal: Vec<&TurnRow>;
        let (baseline, fitted_on): (Baseline, &[&TurnRow]) = match &fixed {
            Some((b, cal)) => {
                train.extend(cal.iter().copied());
                (*b, cal)
            }
            None => {
                fold_cal = train
                    .iter()
                    .copied()
                    .filter(|r| r.calibration_kind)
                    .collect();
                (calibration.baseline_on(rover, &fold_cal)?, &fold_cal)
            }
        };
        let ctx = Context {
            rover,
            baseline: &baseline,
            heating_tau_s: HEATING_TAU_GRID_S[0],
        };
        // A fold where the model cannot be fitted predicts no extra power.
        let fitted = FittedModel::fit(effects, &train, fitted_on, &ctx);
        if check {
            let held: Vec<&TurnRow> = rows.iter().filter(|r| scheme.group(r) == g).collect();
            let group = || held.first().map(|r| HeldOutGroup::of(scheme, r));
            match &fitted {
                Err(_) if unidentified.is_none() && acts_on_any(effects, &held, &ctx) => {
                    unidentified =
                        group().map(|held_out| NotTestable::NotIdentifiable { held_out });
                }
                Err(_) => {}
                Ok(model) => match largest_leverage(model, &train, &held, &ctx) {
                    None => {
                        unidentified = unidentified.or_else(|| {
                            group().map(|held_out| NotTestable::NotIdentifiable { held_out })
                        });
                    }
                    Some(Some((leverage, row))) if leverage > MAX_HELDOUT_LEVERAGE => {
                        let worse = match extrapolated {
                            Some(NotTestable::Extrapolation { leverage: h, .. }) => leverage > h,
                            _ => true,
                        };
                        if worse {
                            extrapolated = Some(NotTestable::Extrapolation {
                                held_out: HeldOutGroup::of(scheme, row),
                                regime: row.regime,
                                leverage,
                            });
                        }
                    }
                    Some(_) => {}
                },
            }
        }
        let fitted = fitted.unwrap_or_else(|_| FittedModel::empty());
        for (i, row) in rows
            .iter()
            .enumerate()
            .filter(|(_, r)| scheme.group(r) == g)
        {
            out.push(row_residual(i, row, &baseline, &fitted, &ctx));
        }
    }
    out.sort_by_key(|r| r.row);
    Ok(Some((out, unidentified.or(extrapolated))))
}

/// The held-out residuals of row `i` (`row`) under `baseline` and `fitted`.
fn row_residual(
    i: usize,
    row: &TurnRow,
    baseline: &Baseline,
    fitted: &FittedModel,
    ctx: &Context<'_>,
) -> RowResidual {
    let mut effective_w = baseline.observed_residuals_w(row);
    effective_w.subtract(|side| fitted.extra_w(row, side, ctx));
    let mut growth_w = [row.sides[0].growth_w, row.sides[1].growth_w];
    for (side, growth) in growth_w.iter_mut().enumerate() {
        if let Some(gw) = growth {
            *gw -= fitted.growth_w(row, side, ctx);
        }
    }
    let avg_w = if row.is_total_only() {
        [None, None]
    } else {
        [0, 1].map(|side| {
            Some(
                row.sides[side].avg_power_w
                    - baseline.side_power_w(row, side)
                    - fitted.extra_avg_power_w(row, side, ctx),
            )
        })
    };
    RowResidual {
        row: i,
        effective_w,
        growth_w,
        avg_w,
    }
}

/// Whether some term of `effects` has a nonzero regressor on some side of `rows`.
fn acts_on_any(effects: &[EffectId], rows: &[&TurnRow], ctx: &Context<'_>) -> bool {
    rows.iter().any(|row| {
        effects.iter().any(|&e| {
            (0..row.sides.len()).any(|side| {
                super::effects::regressors(e, row, side, ctx)
                    .is_some_and(|x| x.iter().any(|v| *v != 0.0))
            })
        })
    })
}

/// The largest leverage z′(Z′Z)⁻¹z of the observations of `held` with respect to the
/// training observations of `train`, in `model`'s fitted columns ([`FittedModel::design_row`]),
/// with its row: `Some(None)` when the model predicts nothing there (every column 0), `None`
/// when it would have to but Z′Z is not positive definite (nothing identifies the columns).
fn largest_leverage<'r>(
    model: &FittedModel,
    train: &[&TurnRow],
    held: &[&'r TurnRow],
    ctx: &Context<'_>,
) -> Option<Option<(f64, &'r TurnRow)>> {
    let k = model.columns();
    let observations = |row: &TurnRow| {
        super::observe::observations(row)
            .iter()
            .map(|sides| model.design_row(row, sides, ctx))
            .collect::<Vec<_>>()
    };
    let mut gram = vec![0.0; k * k];
    for z in train.iter().flat_map(|r| observations(r)) {
        for i in 0..k {
            for j in 0..k {
                gram[i * k + j] += z[i] * z[j];
            }
        }
    }
    let factor = cholesky(&gram, k);
    let mut largest: Option<(f64, &TurnRow)> = None;
    for &row in held {
        for z in observations(row) {
            let z = &z[..k];
            if z.iter().all(|v| *v == 0.0) {
                continue;
            }
            let h = leverage(factor.as_deref()?, k, z);
            if largest.is_none_or(|(l, _)| h > l) {
                largest = Some((h, row));
            }
        }
    }
    Some(largest)
}

/// The lower-triangular Cholesky factor L (row-major, k × k) of the symmetric `a` = LL′; `None`
/// unless `a` is positive definite.
fn cholesky(a: &[f64], k: usize) -> Option<Vec<f64>> {
    let mut l = vec![0.0; k * k];
    for i in 0..k {
        for j in 0..=i {
            let s: f64 = (0..j).map(|m| l[i * k + m] * l[j * k + m]).sum();
            if i == j {
                let d = a[i * k + i] - s;
                if !(d > 0.0 && d.is_finite()) {
                    return None;
                }
                l[i * k + i] = d.sqrt();
            } else {
                l[i * k + j] = (a[i * k + j] - s) / l[j * k + j];
            }
        }
    }
    Some(l)
}

/// z′(LL′)⁻¹z = |L⁻¹z|² for the Cholesky factor `l` ([`cholesky`]).
fn leverage(l: &[f64], k: usize, z: &[f64]) -> f64 {
    let mut y = vec![0.0; k];
    for i in 0..k {
        let s: f64 = (0..i).map(|m| l[i * k + m] * y[m]).sum();
        y[i] = (z[i] - s) / l[i * k + i];
    }
    y.iter().map(|v| v * v).sum()
}

/// Mean square of the effective-power residuals of the rows `keep` selects [W²]; `None` if
/// none.
pub fn mean_square(res: &[RowResidual], keep: impl Fn(usize) -> bool) -> Option<f64> {
    let (sum, n) = res
        .iter()
        .filter(|r| keep(r.row))
        .flat_map(|r| r.effective_w.iter())
        .fold((0.0, 0usize), |(s, n), r| (s + r * r, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// Number of observations in held-out residuals (2 per per-side row, 1 per total-only row).
pub fn observations(res: &[RowResidual]) -> usize {
    res.iter().map(|r| r.effective_w.len()).sum()
}

/// Sum of squares and count of the growth residuals [W², –].
pub fn growth_sum_squares(res: &[RowResidual]) -> (f64, usize) {
    res.iter()
        .flat_map(|r| r.growth_w.iter().flatten())
        .fold((0.0, 0usize), |(s, n), g| (s + g * g, n + 1))
}

/// Akaike's final prediction error of a mean square over `n` observations with `k` parameters.
pub fn penalised(mse: f64, n: usize, k: usize) -> f64 {
    if n > k {
        mse * (n + k) as f64 / (n - k) as f64
    } else {
        f64::INFINITY
    }
}

/// The held-out score of one candidate under one scheme.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CandidateScore {
    /// The effect.
    pub effect: EffectId,
    /// RMS before (the baseline) [W].
    pub heldout_error_before: f64,
    /// RMS after adding the effect [W].
    pub heldout_error_after: f64,
    /// 100·(1 − after/before) on the RMS [%].
    pub shrink_pct: f64,
    /// FPE-penalised MSE of the effective power after (the selection's score) [W²].
    pub penalised_mse: f64,
    /// FPE-penalised MSE of the effective power and the growth through the turn pooled (the
    /// selection's second target, used when the first leaves the choice ambiguous) [W²].
    pub penalised_mse_with_growth: f64,
    /// FPE-penalised MSE of the effective and the average power pooled (the third target: it
    /// separates terms that lengthen the turn from terms that draw more power, which the
    /// effective power alone cannot when their shapes agree, e.g. angular slip and a braked inner
    /// side at R') [W²].
    pub penalised_mse_with_avg_power: f64,
    /// FPE-penalised MSE of each row's total effective-power residual (the sides summed: Eq
    /// 21's own observation, blind to how the power splits between the sides) [W²].
    pub penalised_mse_total: f64,
    /// 100·(1 − after/before) on the RMS of the total residuals [%].
    pub shrink_total_pct: f64,
    /// Why some fold does not test the candidate out of sample (then the scores above are not
    /// a test of it, and it is left out of the ranking); `None` when every fold does.
    pub not_testable: Option<NotTestable>,
}

/// 100·(1 − after/before) of two RMS errors: the share of the held-out error a model closes
/// [%]; 0 when there is no error before.
pub fn shrink_pct(before: f64, after: f64) -> f64 {
    if before > 0.0 {
        100.0 * (1.0 - after / before)
    } else {
        0.0
    }
}

/// Mean square of each row's total effective-power residual (the sides summed) [W²].
pub fn total_mean_square(res: &[RowResidual]) -> f64 {
    let sum: f64 = res
        .iter()
        .map(|r| r.effective_w.iter().sum::<f64>().powi(2))
        .sum();
    sum / res.len().max(1) as f64
}

/// The third selection score of held-out residuals: FPE of the pooled mean square of the
/// effective-power and average-power residuals with `k` parameters [W²].
pub fn score_with_avg_power(res: &[RowResidual], k: usize) -> f64 {
    let n_eff = observations(res);
    let eff = mean_square(res, |_| true).unwrap_or(0.0) * n_eff as f64;
    let (avg, n_avg) = res
        .iter()
        .flat_map(|r| r.avg_w.iter().flatten())
        .fold((0.0, 0usize), |(s, n), a| (s + a * a, n + 1));
    let n = n_eff + n_avg;
    penalised((eff + avg) / n.max(1) as f64, n, k)
}

/// The second selection score of held-out residuals: FPE of the pooled mean square of the
/// effective-power and growth residuals with `k` parameters [W²].
pub fn score_with_growth(res: &[RowResidual], k: usize) -> f64 {
    let n_eff = observations(res);
    let eff = mean_square(res, |_| true).unwrap_or(0.0) * n_eff as f64;
    let (growth, n_growth) = growth_sum_squares(res);
    let n = n_eff + n_growth;
    penalised((eff + growth) / n.max(1) as f64, n, k)
}

/// The score of the model `base` + `effect` (jointly fitted) against `before` under `scheme`.
pub fn score_model(
    rover: &Rover,
    rows: &[TurnRow],
    scheme: Scheme,
    calibration: Calibration<'_>,
    before: &[RowResidual],
    effects: &[EffectId],
) -> Result<Option<CandidateScore>, BaselineError> {
    let Some(&effect) = effects.last() else {
        return Ok(None);
    };
    let Some((after, not_testable)) = heldout(rover, rows, scheme, effects, calibration, true)?
    else {
        return Ok(None);
    };
    let rms_before = mean_square(before, |_| true).unwrap_or(0.0).sqrt();
    let rms_after = mean_square(&after, |_| true).unwrap_or(0.0).sqrt();
    Ok(Some(CandidateScore {
        effect,
        heldout_error_before: rms_before,
        heldout_error_after: rms_after,
        shrink_pct: shrink_pct(rms_before, rms_after),
        penalised_mse: penalised(
            rms_after * rms_after,
            observations(&after),
            model_params(effects),
        ),
        penalised_mse_with_growth: score_with_growth(&after, model_params(effects)),
        penalised_mse_with_avg_power: score_with_avg_power(&after, model_params(effects)),
        penalised_mse_total: penalised(
            total_mean_square(&after),
            after.len(),
            model_params(effects),
        ),
        shrink_total_pct: shrink_pct(
            total_mean_square(before).sqrt(),
            total_mean_square(&after).sqrt(),
        ),
        not_testable,
    }))
}

/// Scores each of `effects` alone under `scheme` against `before` (the held-out residuals of
/// the baseline alone under the same scheme); `Ok(None)` when one cannot be held out.
pub fn score_all(
    rover: &Rover,
    rows: &[TurnRow],
    scheme: Scheme,
    calibration: Calibration<'_>,
    before: &[RowResidual],
    effects: impl IntoIterator<Item = EffectId>,
) -> Result<Option<Vec<CandidateScore>>, BaselineError> {
    let mut out = Vec::new();
    for effect in effects {
        match score_model(rover, rows, scheme, calibration, before, &[effect])? {
            Some(c) => out.push(c),
            None => return Ok(None),
        }
    }
    Ok(Some(out))
}

/// The primary and secondary cross-validation schemes: leave one run out when there are two
/// runs or more, else leave one radius out.
pub fn schemes(rows: &[TurnRow]) -> (Scheme, Scheme) {
    let runs = rows.iter().map(|r| r.run_index).max().unwrap_or(0) + 1;
    if runs >= 2 {
        (Scheme::LeaveOneRunOut, Scheme::LeaveOneRadiusOut)
    } else {
        (Scheme::LeaveOneRadiusOut, Scheme::LeaveOneRunOut)
    }
}
