//! Held-out scoring and selection: grouped cross-validation of the baseline with and without
//! each catalogue effect, the significance of the gap from a bootstrap over repeats, and the
//! clear-margin rule that names an effect or says `ambiguous`.
//!
//! - **Metric**: RMS over held-out manoeuvres and both sides of the effective-power residual,
//!   measured − predicted [W] (see [`features`](super::features)).
//! - **Folds**: leave-one-run-out (groups: runs; needs ≥ 2 runs) and leave-one-radius-out
//!   (groups: commanded R/R' rounded to 0.01, straights one group). In every fold the baseline is
//!   refitted on the training fold's calibration rows and the effect (with a correction of G for
//!   the terms acting on every row) on the training fold's residuals; a fold where the effect cannot be fitted (no training row where it acts) predicts
//!   no extra power.
//! - **Penalty**: Akaike's final prediction error on the pooled held-out MSE,
//!   MSE·(n + k)/(n − k) for k fitted parameters (the effect's, plus the G correction of the
//!   terms acting on every row, see [`FittedEffect::fit`]) and n held-out side observations.
//! - **Significance**: the mean baseline residual of a (regime, side) group is significant when
//!   its 95 % bootstrap interval (resampling runs, or manoeuvres within the group for one run)
//!   excludes 0 and its size exceeds [`PRACTICAL_FLOOR_W`].
//! - **Selection**: the effect with the lowest penalised error is named when the gap is
//!   significant, it closes at least [`MIN_SHRINK_PCT`] of the held-out gap, and the runner-up's
//!   penalised MSE is at least [`CLEAR_MARGIN`] times its own; otherwise `ambiguous`.

use super::baseline::{Baseline, BaselineError};
use super::effects::{fitted_params, Context, FittedEffect};
use super::features::TurnRow;
use super::observe::Residuals;
use crate::sim::world::EffectId;
use model_core::Rover;
use serde::Serialize;

/// Smallest mean gap that counts, per side [W] (below it a gap is not worth a term).
pub const PRACTICAL_FLOOR_W: f64 = 1.5;
/// Bootstrap resamples.
pub const BOOTSTRAP_RESAMPLES: usize = 2000;
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
            Scheme::LeaveOneRadiusOut if row.r_over_r_prime.is_finite() => {
                (row.r_over_r_prime * 100.0).round() as i64
            }
            Scheme::LeaveOneRadiusOut => i64::MAX,
        }
    }
}

/// Held-out residuals: (row index, residual of each observation [W]: inner/left and
/// outer/right, or the total of a total-only row), in row order.
pub type HeldOut = Vec<(usize, Residuals)>;

/// Held-out residuals of every row and side, before (baseline) and after adding `effect`
/// (`None`: the baseline alone), pooled over the folds of `scheme`. `Ok(None)` when the scheme
/// has fewer than 2 groups.
pub fn heldout_residuals(
    rover: &Rover,
    rows: &[TurnRow],
    scheme: Scheme,
    effect: Option<EffectId>,
) -> Result<Option<HeldOut>, BaselineError> {
    let mut groups: Vec<i64> = rows.iter().map(|r| scheme.group(r)).collect();
    groups.sort_unstable();
    groups.dedup();
    if groups.len() < 2 {
        return Ok(None);
    }
    let mut out = Vec::with_capacity(rows.len());
    for g in groups {
        let train: Vec<&TurnRow> = rows.iter().filter(|r| scheme.group(r) != g).collect();
        let cal: Vec<&TurnRow> = train
            .iter()
            .copied()
            .filter(|r| r.calibration_kind)
            .collect();
        let baseline = Baseline::fit(rover, &cal)?;
        let ctx = Context {
            rover,
            baseline: &baseline,
        };
        let fitted = effect.and_then(|e| FittedEffect::fit(e, &train, &ctx).ok());
        for (i, row) in rows
            .iter()
            .enumerate()
            .filter(|(_, r)| scheme.group(r) == g)
        {
            let mut res = baseline.observed_residuals_w(row);
            if let Some(f) = &fitted {
                res.subtract(|side| f.extra_w(row, side, &ctx));
            }
            out.push((i, res));
        }
    }
    out.sort_by_key(|(i, _)| *i);
    Ok(Some(out))
}

/// Mean square of the residuals of the rows `keep` selects [W²]; `None` if none.
pub fn mean_square(res: &[(usize, Residuals)], keep: impl Fn(usize) -> bool) -> Option<f64> {
    let (sum, n) = res
        .iter()
        .filter(|(i, _)| keep(*i))
        .flat_map(|(_, r)| r.iter())
        .fold((0.0, 0usize), |(s, n), r| (s + r * r, n + 1));
    (n > 0).then(|| sum / n as f64)
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
    /// FPE-penalised MSE after [W²].
    pub penalised_mse: f64,
}

/// Scores every catalogue effect under `scheme`; `Ok(None)` when the scheme has < 2 groups.
pub fn score_all(
    rover: &Rover,
    rows: &[TurnRow],
    scheme: Scheme,
) -> Result<Option<Vec<CandidateScore>>, BaselineError> {
    let Some(before) = heldout_residuals(rover, rows, scheme, None)? else {
        return Ok(None);
    };
    let rms_before = mean_square(&before, |_| true).unwrap_or(0.0).sqrt();
    let n = before.iter().map(|(_, r)| r.len()).sum();
    let mut out = Vec::new();
    for effect in EffectId::ALL {
        let Some(after) = heldout_residuals(rover, rows, scheme, Some(effect))? else {
            return Ok(None);
        };
        let mse = mean_square(&after, |_| true).unwrap_or(0.0);
        let rms_after = mse.sqrt();
        out.push(CandidateScore {
            effect,
            heldout_error_before: rms_before,
            heldout_error_after: rms_after,
            shrink_pct: if rms_before > 0.0 {
                100.0 * (1.0 - rms_after / rms_before)
            } else {
                0.0
            },
            penalised_mse: penalised(mse, n, fitted_params(effect)),
        });
    }
    Ok(Some(out))
}

/// SplitMix64: the bootstrap's deterministic generator (no dependency for 20 lines).
#[derive(Debug, Clone)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in 0..n (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// Mean and 95 % percentile-bootstrap interval of `values` grouped by `groups` (whole groups
/// are resampled: the repeats are the unit of noise); `None` for no values.
pub fn bootstrap_mean(values: &[f64], groups: &[usize], seed: u64) -> Option<(f64, f64, f64)> {
    if values.is_empty() || values.len() != groups.len() {
        return None;
    }
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let mut ids: Vec<usize> = groups.to_vec();
    ids.sort_unstable();
    ids.dedup();
    // One group: resample the values themselves.
    let units: Vec<Vec<f64>> = if ids.len() >= 2 {
        ids.iter()
            .map(|g| {
                values
                    .iter()
                    .zip(groups)
                    .filter(|(_, h)| *h == g)
                    .map(|(v, _)| *v)
                    .collect()
            })
            .collect()
    } else {
        values.iter().map(|v| vec![*v]).collect()
    };
    if units.len() < 2 {
        return Some((mean, f64::NEG_INFINITY, f64::INFINITY));
    }
    let mut rng = SplitMix64(seed);
    let mut means: Vec<f64> = (0..BOOTSTRAP_RESAMPLES)
        .map(|_| {
            let (mut s, mut n) = (0.0, 0usize);
            for _ in 0..units.len() {
                let u = &units[rng.below(units.len())];
                s += u.iter().sum::<f64>();
                n += u.len();
            }
            s / n.max(1) as f64
        })
        .collect();
    means.sort_by(f64::total_cmp);
    let lo = means[(0.025 * BOOTSTRAP_RESAMPLES as f64) as usize];
    let hi = means[(0.975 * BOOTSTRAP_RESAMPLES as f64) as usize - 1];
    Some((mean, lo, hi))
}
