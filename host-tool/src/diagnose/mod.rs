//! `diagnose`: where the hard-ground ICR model (paper Eq 21, fitted on calibration manoeuvres)
//! departs from measured power, which catalogued unmodelled effect explains it, and how much of
//! the held-out gap it closes. Work in progress: see `NOTES.md` in this directory.
//!
//! Pipeline: [`features::rows`] (per-turn inner/outer rows from `validate`) →
//! [`baseline::Baseline`] (Eq 21 per side, calibration manoeuvres) → gaps per regime and side
//! with bootstrap significance ([`cv::bootstrap_mean`]) → every [`effects`] term scored by
//! grouped cross-validation ([`cv::score_all`]) → [`diagnose`]'s selection.

pub mod baseline;
pub mod bench;
pub mod cv;
pub mod effects;
pub mod features;

#[cfg(test)]
mod tests;

use crate::sim::world::EffectId;
use baseline::{Baseline, BaselineError};
use cv::{CandidateScore, Scheme};
use features::{SideRole, TurnRow};
use model_core::kinematics::Regime;
use model_core::Rover;
use serde::Serialize;

/// Why there is no diagnosis.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DiagnoseError {
    /// No turn or straight to diagnose.
    #[error("no manoeuvre to diagnose")]
    NoRows,
    /// The baseline cannot be fitted.
    #[error(transparent)]
    Baseline(#[from] BaselineError),
    /// One run and one radius: nothing to hold out.
    #[error("cross-validation needs at least two runs or two radii")]
    NothingToHoldOut,
}

/// The mean baseline residual of one (regime, side) group.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Gap {
    /// The regime.
    pub regime: Regime,
    /// Inner or outer (straights: both sides under `outer`/`inner` by convention).
    pub side: SideRole,
    /// Side observations.
    pub n: usize,
    /// Mean effective-power residual [W].
    pub mean_w: f64,
    /// 95 % bootstrap interval [W].
    pub ci_w: (f64, f64),
    /// Beyond the repeat noise and [`cv::PRACTICAL_FLOOR_W`].
    pub significant: bool,
}

/// What the diagnosis concluded.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnosis {
    /// A catalogue id, `none` (no significant gap) or `ambiguous`.
    pub effect: String,
    /// The regime of the largest significant gap, or `all`.
    pub regime: String,
    /// Whether any gap is significant.
    pub significant: bool,
    /// The baseline on all calibration rows.
    pub baseline: Baseline,
    /// Gaps per regime and side.
    pub gaps: Vec<Gap>,
    /// The scheme the selection used.
    pub scheme: Scheme,
    /// Every candidate under `scheme`, best first.
    pub candidates: Vec<CandidateScore>,
    /// Every candidate under the other scheme (if it has ≥ 2 groups), catalogue order.
    pub other_scheme: Option<(Scheme, Vec<CandidateScore>)>,
    /// Held-out error before/after the named effect (the best candidate when none is named),
    /// all rows and per regime, under `scheme`.
    pub heldout: Vec<HeldOutError>,
}

/// Held-out RMS before and after one effect over a set of rows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldOutError {
    /// `all` or a regime id.
    pub regime: String,
    /// The effect added.
    pub effect: EffectId,
    /// RMS before [W].
    pub error_before: f64,
    /// RMS after [W].
    pub error_after: f64,
    /// 100·(1 − after/before) [%].
    pub shrink_pct: f64,
}

impl Diagnosis {
    /// The JSON: `effect`, `regime`, `significant`, `candidates`, `metric`, `heldout`
    /// (all rows; `heldout_per_regime` has the rest), plus the baseline and the gaps.
    pub fn to_json(&self) -> serde_json::Value {
        let all = self.heldout.iter().find(|h| h.regime == "all");
        serde_json::json!({
            "effect": self.effect,
            "regime": self.regime,
            "significant": self.significant,
            "candidates": self.candidates.iter().map(|c| serde_json::json!({
                "effect": c.effect.id(),
                "heldout_error_before": c.heldout_error_before,
                "heldout_error_after": c.heldout_error_after,
                "shrink_pct": c.shrink_pct,
            })).collect::<Vec<_>>(),
            "metric": {
                "what": "RMS over held-out manoeuvres and both sides of the effective-power \
                         residual (energy / expected duration, measured minus model)",
                "unit": "W",
            },
            "heldout": all.map(|h| serde_json::json!({
                "scheme": self.scheme.id(),
                "effect": h.effect.id(),
                "error_before": h.error_before,
                "error_after": h.error_after,
                "shrink_pct": h.shrink_pct,
            })),
            "heldout_per_regime": self.heldout.iter().filter(|h| h.regime != "all").collect::<Vec<_>>(),
            "baseline": self.baseline,
            "gaps": self.gaps,
        })
    }
}

fn shrink_pct(before: f64, after: f64) -> f64 {
    if before > 0.0 {
        100.0 * (1.0 - after / before)
    } else {
        0.0
    }
}

/// Diagnoses `rows` (see [`features::rows`]).
pub fn diagnose(rover: &Rover, rows: &[TurnRow]) -> Result<Diagnosis, DiagnoseError> {
    if rows.is_empty() {
        return Err(DiagnoseError::NoRows);
    }
    let cal: Vec<&TurnRow> = rows.iter().filter(|r| r.calibration_kind).collect();
    let baseline = Baseline::fit(rover, &cal)?;

    let mut gaps = Vec::new();
    for regime in Regime::ALL {
        for (k, side) in [(0usize, SideRole::Inner), (1, SideRole::Outer)] {
            let of: Vec<&TurnRow> = rows.iter().filter(|r| r.regime == regime).collect();
            if of.is_empty() {
                continue;
            }
            let values: Vec<f64> = of.iter().map(|r| baseline.residual_w(r)[k]).collect();
            let groups: Vec<usize> = of.iter().map(|r| r.run_index).collect();
            let seed = 0x5EED ^ ((regime as u64) << 8) ^ k as u64;
            if let Some((mean_w, lo, hi)) = cv::bootstrap_mean(&values, &groups, seed) {
                gaps.push(Gap {
                    regime,
                    side,
                    n: values.len(),
                    mean_w,
                    ci_w: (lo, hi),
                    significant: (lo > 0.0 || hi < 0.0) && mean_w.abs() > cv::PRACTICAL_FLOOR_W,
                });
            }
        }
    }
    let significant = gaps.iter().any(|g| g.significant);
    let regime = gaps
        .iter()
        .filter(|g| g.significant)
        .max_by(|a, b| a.mean_w.abs().total_cmp(&b.mean_w.abs()))
        .map_or("all", |g| g.regime.id())
        .to_owned();

    let runs = rows.iter().map(|r| r.run_index).max().unwrap_or(0) + 1;
    let (primary, secondary) = if runs >= 2 {
        (Scheme::LeaveOneRunOut, Scheme::LeaveOneRadiusOut)
    } else {
        (Scheme::LeaveOneRadiusOut, Scheme::LeaveOneRunOut)
    };
    let mut candidates =
        cv::score_all(rover, rows, primary)?.ok_or(DiagnoseError::NothingToHoldOut)?;
    candidates.sort_by(|a, b| a.penalised_mse.total_cmp(&b.penalised_mse));
    let other_scheme = cv::score_all(rover, rows, secondary)?.map(|c| (secondary, c));

    let effect = if !significant {
        "none".to_owned()
    } else {
        match candidates.as_slice() {
            [best, runner_up, ..]
                if best.shrink_pct >= cv::MIN_SHRINK_PCT
                    && runner_up.penalised_mse >= cv::CLEAR_MARGIN * best.penalised_mse =>
            {
                best.effect.id().to_owned()
            }
            _ => "ambiguous".to_owned(),
        }
    };
    let added = named_id(&effect).unwrap_or(candidates[0].effect);
    let mut heldout = Vec::new();
    if let (Some(before), Some(after)) = (
        cv::heldout_residuals(rover, rows, primary, None)?,
        cv::heldout_residuals(rover, rows, primary, Some(added))?,
    ) {
        let mut push = |regime: String, keep: &dyn Fn(usize) -> bool| {
            if let (Some(b), Some(a)) = (
                cv::mean_square(&before, keep),
                cv::mean_square(&after, keep),
            ) {
                let (b, a) = (b.sqrt(), a.sqrt());
                heldout.push(HeldOutError {
                    regime,
                    effect: added,
                    error_before: b,
                    error_after: a,
                    shrink_pct: shrink_pct(b, a),
                });
            }
        };
        push("all".to_owned(), &|_| true);
        for regime in Regime::ALL {
            push(regime.id().to_owned(), &|i| rows[i].regime == regime);
        }
    }
    Ok(Diagnosis {
        heldout,
        effect,
        regime,
        significant,
        baseline,
        gaps,
        scheme: primary,
        candidates,
        other_scheme,
    })
}

/// The effect a diagnosis named, if it named one.
pub fn named_effect(d: &Diagnosis) -> Option<EffectId> {
    named_id(&d.effect)
}

fn named_id(effect: &str) -> Option<EffectId> {
    EffectId::from_id(effect)
}
