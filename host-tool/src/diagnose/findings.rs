//! What the verdict's effect does, for the report: its held-out error before and after, over
//! all rows, the gap regimes and each regime; where it acts; the calibration's lack of fit with
//! it; and, when its term takes power, the effect's own words for that.

use super::adequacy::{self, Adequacy};
use super::baseline::Baseline;
use super::calibration::Calibration;
use super::catalogue;
use super::cv::{self, Scheme};
use super::diagnosis::HeldOutError;
use super::effects::{self, fit_model, FittedModel};
use super::error::DiagnoseError;
use super::features::TurnRow;
use super::observe;
use super::select;
use super::significance::SignificantGaps;
use super::stats;
use super::verdict::Scope;
use crate::effect_id::EffectId;
use model_core::kinematics::Regime;
use model_core::Rover;

/// Held-out RMS before and after adding `added`, over all rows, the gap regimes and each regime.
pub(super) fn heldout_errors(
    rover: &Rover,
    rows: &[TurnRow],
    primary: Scheme,
    calibration: Calibration<'_>,
    before: &[observe::RowResidual],
    added: EffectId,
    gap_regimes: &[Regime],
) -> Result<Vec<HeldOutError>, DiagnoseError> {
    let mut heldout = Vec::new();
    if let Some(after) = cv::heldout_residuals(rover, rows, primary, &[added], calibration)? {
        let mut push = |regime: Scope, keep: &dyn Fn(usize) -> bool| {
            if let (Some(b), Some(a)) =
                (cv::mean_square(before, keep), cv::mean_square(&after, keep))
            {
                let (b, a) = (b.sqrt(), a.sqrt());
                heldout.push(HeldOutError {
                    regime,
                    effect: added,
                    error_before: b,
                    error_after: a,
                    shrink_pct: cv::shrink_pct(b, a),
                });
            }
        };
        push(Scope::All, &|_| true);
        if !gap_regimes.is_empty() {
            push(Scope::Gap, &|i| gap_regimes.contains(&rows[i].regime));
        }
        for regime in Regime::ALL {
            push(Scope::Regime(regime), &|i| rows[i].regime == regime);
        }
    }
    Ok(heldout)
}

/// Where the departure acts: everywhere when the named effect acts in every regime, else the
/// regime of the largest significant gap. Without a named effect: `all` when every regime
/// present has a significant gap.
pub(super) fn scope_of(
    rover: &Rover,
    rows: &[TurnRow],
    named: Option<EffectId>,
    calibration: Calibration<'_>,
    gaps: &SignificantGaps,
) -> Result<Scope, DiagnoseError> {
    let largest = gaps.largest.map_or(Scope::All, Scope::Regime);
    Ok(match named {
        Some(e) if acts_in_every_regime(rover, rows, e, calibration)? => Scope::All,
        Some(_) => largest,
        None => {
            let present = Regime::ALL
                .iter()
                .filter(|r| rows.iter().any(|row| row.regime == **r))
                .count();
            if gaps.regimes.len() == present {
                Scope::All
            } else {
                largest
            }
        }
    })
}

/// The calibration manoeuvres' lack-of-fit test of `baseline` with `model`'s terms, fitted
/// jointly on all rows.
pub(super) fn calibration_adequacy(
    rover: &Rover,
    rows: &[TurnRow],
    calibration: Calibration<'_>,
    baseline: &Baseline,
    model: &FittedModel,
) -> Adequacy {
    let ctx = model.context(rover, baseline);
    let effects: Vec<EffectId> = model.effects.iter().map(|t| t.effect).collect();
    let params = 2 + effects::model_params(&effects);
    adequacy::test(&calibration.manoeuvres(rows), params, |r, s| {
        baseline.side_power_w(r, s) + model.extra_avg_power_w(r, s, &ctx)
    })
}

/// When the named term takes power from the turns (its sign rule lets it, as
/// [`select::physically_signed`] says), the report says so with the effect's own words
/// ([`Effect::deficit_words`](effect::Effect::deficit_words)). No note when the term cannot be
/// refitted alone (the verdict stands; only its wording is at stake).
pub(super) fn deficit_note(
    rover: &Rover,
    rows: &[TurnRow],
    named: EffectId,
    calibration: Calibration<'_>,
) -> Option<String> {
    let words = catalogue::of(named).deficit_words()?;
    let own = select::own_power_per_side_w(rover, rows, named, calibration)
        .ok()
        .flatten();
    own.filter(|w| *w < 0.0)
        .map(|w| format!("{named} is a deficit here ({w:+.1} W per diagnosed side): {words}"))
}

/// Whether `effect`, fitted on all rows, acts across the regimes: its own term (without the
/// baseline corrections) has an RMS per side of at least [`stats::PRACTICAL_FLOOR_W`] in some
/// regime and at least half of that floor on the straights (not for a term that scales every
/// turn alike: a straight has no yaw to scale) and in every other regime present but at most one (a slope term is
/// small on point turns, where v_y = 0 and only the sides' opposite climbs remain). Then
/// the departure is not confined to a regime and the diagnosis' regime is `all`. (The gaps
/// alone cannot say so: a term acting on every row is partly absorbed into a and G on the
/// calibration rows, so its gaps change sign between regimes.)
fn acts_in_every_regime(
    rover: &Rover,
    rows: &[TurnRow],
    effect: EffectId,
    calibration: Calibration<'_>,
) -> Result<bool, DiagnoseError> {
    let (baseline, model) = fit_model(rover, rows, &[effect], calibration)?;
    let ctx = model.context(rover, &baseline);
    let Some(term) = model.effects.first() else {
        return Ok(false);
    };
    let rms: Vec<(Regime, f64)> = Regime::ALL
        .iter()
        .filter_map(|&regime| {
            let of: Vec<&TurnRow> = rows.iter().filter(|r| r.regime == regime).collect();
            (!of.is_empty()).then(|| {
                let ms = of
                    .iter()
                    .flat_map(|r| (0..2).map(move |side| term.term_w(r, side, &ctx).powi(2)))
                    .sum::<f64>()
                    / (2 * of.len()) as f64;
                (regime, ms.sqrt())
            })
        })
        .collect();
    let largest = rms.iter().map(|(_, r)| *r).fold(0.0, f64::max);
    let acts = |r: f64| r >= 0.5 * stats::PRACTICAL_FLOOR_W;
    let missing = rms.iter().filter(|(_, r)| !acts(*r)).count();
    // A term that scales every turn alike acts where the turns are: a straight has no yaw.
    let on_straights = catalogue::of(effect).scales_every_turn()
        || rms
            .iter()
            .any(|(regime, r)| *regime == Regime::Straight && acts(*r));
    Ok(largest >= stats::PRACTICAL_FLOOR_W && on_straights && missing <= 1 && rms.len() >= 3)
}
