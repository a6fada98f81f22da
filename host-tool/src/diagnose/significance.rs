//! Whether the model departs significantly: a mean gap beyond the noise and the floor, or the
//! named effect removing at least the practical floor of held-out RMS (a departure seen as
//! spread, such as a slope's, whose power changes sign along the path).

use super::baseline::Baseline;
use super::cv::CandidateScore;
use super::features::TurnRow;
use super::gaps::{self, Gap};
use super::stats;
use crate::effect_id::EffectId;
use model_core::kinematics::Regime;

/// What the significant mean gaps say: whether there is one, their regimes (in gap order,
/// repeats next to each other merged) and the regime of the largest.
pub(super) struct SignificantGaps {
    pub any: bool,
    pub regimes: Vec<Regime>,
    pub largest: Option<Regime>,
}

impl SignificantGaps {
    pub(super) fn of(gaps: &[Gap]) -> Self {
        let mut regimes: Vec<Regime> = gaps
            .iter()
            .filter(|g| g.significant)
            .map(|g| g.regime)
            .collect();
        regimes.dedup();
        let largest = gaps
            .iter()
            .filter(|g| g.significant)
            .max_by(|a, b| a.mean_w.abs().total_cmp(&b.mean_w.abs()))
            .map(|g| g.regime);
        Self {
            any: gaps.iter().any(|g| g.significant),
            regimes,
            largest,
        }
    }
}

/// The selected effect's score and the floor [W] when it removes at least that practical floor
/// of RMS out of sample. The floor is the one of the gaps and the adequacy test: the larger of
/// the fixed floor and a share of the model power (a few watts are noise for a rover drawing
/// hundreds).
pub(super) fn explained_spread<'a>(
    baseline: &Baseline,
    rows: &[TurnRow],
    candidates: &'a [CandidateScore],
    selected: Option<EffectId>,
) -> Option<(&'a CandidateScore, f64)> {
    let model_w: Vec<f64> = rows
        .iter()
        .flat_map(|r| [0, 1].map(|s| baseline.effective_side_power_w(r, s)))
        .collect();
    let floor_w = gaps::practical_floor_w(&model_w);
    selected
        .and_then(|e| candidates.iter().find(|c| c.effect == e))
        .filter(|c| stats::removed_rms_w(c.heldout_error_before, c.heldout_error_after) >= floor_w)
        .map(|c| (c, floor_w))
}
