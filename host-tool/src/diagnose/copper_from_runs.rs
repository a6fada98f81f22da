//! Copper loss the calibration manoeuvres cannot show, decided by the diagnosed runs.
//!
//! Copper loss (∝ torque², thesis Eq 1.17–1.19) shows most where a side carries a large force at
//! a low speed: the inner side between B/2 and R′, which no calibration manoeuvre (straights,
//! point turns, R ≥ 2R′) drives. There a and G absorb it on the calibration manoeuvres, the
//! no-regeneration clamp mimics it at 2R′–3R′, and the baseline family takes copper loss only by
//! escalation ([`family`](super::baseline::family)): on the diagnosed turns it then reads as an
//! inner-side gap that `inner-drag`, `braked-inner` or `motor-heating` compete for, and the
//! verdict is `ambiguous` or `baseline-misfit`.
//!
//! The diagnosed runs can decide it out of sample, by one of two comparisons on the held-out
//! diagnosed rows, with the copper-loss member fitted on the same calibration manoeuvres only:
//!
//! - **instead of an effect**: the copper member alone predicts them better than the chosen
//!   member ([`COPPER_ERROR_RATIO`]) and better than the chosen member plus any single
//!   catalogue effect;
//! - **beside an effect**: the copper member with the best single effect predicts them better
//!   (by the same ratio) than the chosen member with it, whatever the copper member does alone
//!   (a strong effect's gap hides what copper loss improves elsewhere);
//! - **at stall**: the first diagnosis has a significant excess at the sides held at stall
//!   (commanded still in a turn: the inner side at R′, holding its tread's force), to which a
//!   copper-free member gives no power, and the copper member predicts those sides better
//!   (by the same ratio). They are few rows, so over all rows copper loss can lose.
//!
//! Then copper loss is a structure of the rover, not a shape that happens to fit one effect's
//! gap, and the diagnosis is redone against it. Asked only when the first diagnosis names no
//! effect; its answer is kept only when it is `none`, `ambiguous` or an effect that closes at
//! least [`cv::MIN_SHRINK_PCT`] of the held-out error against the copper member; never a
//! `baseline-misfit`.

use super::baseline::family::Members;
use super::baseline::held_at_stall;
use super::calibration::Calibration;
use super::cv;
use super::diagnosis::{CopperEvidence, Diagnosis};
use super::error::DiagnoseError;
use super::features::TurnRow;
use model_core::Rover;

/// The copper-loss member's held-out RMS must be below this share of the chosen member's.
pub const COPPER_ERROR_RATIO: f64 = 0.95;

/// `first`, or the diagnosis against the copper-loss member when the diagnosed runs show copper
/// loss (see the module docs). `diagnose_against` diagnoses with a given calibration.
pub(super) fn reconsider(
    rover: &Rover,
    rows: &[TurnRow],
    calibration: Calibration<'_>,
    first: Diagnosis,
    diagnose_against: impl Fn(Calibration<'_>) -> Result<Diagnosis, DiagnoseError>,
) -> Result<Diagnosis, DiagnoseError> {
    if first.effect.effect().is_some()
        || first.baseline.structure.copper_loss
        || calibration.members == Members::CopperLoss
    {
        return Ok(first);
    }
    let Some(evidence) = evidence(rover, rows, calibration, &first) else {
        return Ok(first);
    };
    // A fit that fails with copper loss (e.g. c < 0) leaves the first diagnosis standing.
    let Ok(mut second) = diagnose_against(calibration.with_members(Members::CopperLoss)) else {
        return Ok(first);
    };
    let keep = match second.effect.effect() {
        // Named against the copper member, an effect must close the bar there too. (Until
        // session 14 the effect copper loss beat was never kept; once a side held at stall drew
        // its copper loss in the world and the baseline, that rule only cost right names.)
        Some(e) => second
            .candidates
            .iter()
            .any(|c| c.effect == e && c.shrink_pct >= cv::MIN_SHRINK_PCT),
        None => second.effect != super::verdict::Verdict::BaselineMisfit,
    };
    if !keep {
        return Ok(first);
    }
    second.copper_from_runs = Some(evidence);
    Ok(second)
}

/// The held-out comparison of the module docs, when the copper-loss member wins it.
pub(crate) fn evidence(
    rover: &Rover,
    rows: &[TurnRow],
    calibration: Calibration<'_>,
    first: &Diagnosis,
) -> Option<CopperEvidence> {
    let best = first
        .candidates
        .iter()
        .min_by(|a, b| a.heldout_error_after.total_cmp(&b.heldout_error_after))?;
    let copper = calibration.with_members(Members::CopperLoss);
    if !copper.baseline(rover, rows).ok()?.structure.copper_loss {
        return None;
    }
    // The chosen member's held-out RMS is every candidate's "before" in the first diagnosis.
    let chosen = best.heldout_error_before;
    let copper_alone = cv::heldout_residuals(rover, rows, first.scheme, &[], copper).ok()??;
    let with_copper = cv::mean_square(&copper_alone, |_| true)?.sqrt();
    if with_copper < COPPER_ERROR_RATIO * chosen && with_copper < best.heldout_error_after {
        return Some(CopperEvidence {
            chosen_member_error_w: chosen,
            copper_member_error_w: with_copper,
            best_effect: best.effect,
            best_effect_error_w: best.heldout_error_after,
            copper_with_effect_error_w: None,
            at_stall_error_w: None,
        });
    }
    // Or copper loss beside the best effect: the copper member and the effect together beat
    // the chosen member and the effect (the effect then stays in the running), whatever the
    // copper member does alone (a strong effect's gap can hide what copper loss improves).
    let res = cv::heldout_residuals(rover, rows, first.scheme, &[best.effect], copper).ok()??;
    let both = cv::mean_square(&res, |_| true)?.sqrt();
    let beside = CopperEvidence {
        chosen_member_error_w: chosen,
        copper_member_error_w: with_copper,
        best_effect: best.effect,
        best_effect_error_w: best.heldout_error_after,
        copper_with_effect_error_w: Some(both),
        at_stall_error_w: None,
    };
    if both < COPPER_ERROR_RATIO * best.heldout_error_after {
        return Some(beside);
    }
    // Or the sides held at stall: a copper-free member gives a side commanded still in a turn
    // no power, but it holds its tread's force and draws that torque's copper loss. A
    // significant excess there that the copper member predicts out of sample is the rover's
    // copper loss; no catalogue term puts power on a side that does not move.
    let excess_at_stall = first
        .gaps
        .iter()
        .any(|g| g.significant && g.mean_w > 0.0 && g.at_sides_held_at_stall(rows));
    if !excess_at_stall {
        return None;
    }
    let chosen_res = cv::heldout_residuals(rover, rows, first.scheme, &[], calibration).ok()??;
    let at_stall = [&chosen_res, &copper_alone].map(|res| stalled_rms_w(rows, res));
    match at_stall {
        [Some(chosen), Some(copper)] if copper < COPPER_ERROR_RATIO * chosen => {
            Some(CopperEvidence {
                at_stall_error_w: Some([chosen, copper]),
                ..beside
            })
        }
        _ => None,
    }
}

/// RMS of the held-out residuals of the sides held at stall [W]; `None` without one.
fn stalled_rms_w(rows: &[TurnRow], res: &[crate::diagnose::observe::RowResidual]) -> Option<f64> {
    let (sum, n) = res
        .iter()
        .filter(|r| !r.effective_w.is_total())
        .flat_map(|r| {
            (0..2)
                .filter(|&s| held_at_stall(&rows[r.row], s))
                .map(move |s| r.effective_w[s])
        })
        .fold((0.0, 0usize), |(sum, n), v| (sum + v * v, n + 1));
    (n > 0).then(|| (sum / n as f64).sqrt())
}
