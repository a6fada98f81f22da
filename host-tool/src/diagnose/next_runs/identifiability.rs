//! The identifiability statement: which rivals an open verdict leaves in play, which of them
//! the runs given tell apart, and what the runs cannot tell apart, in words.

use super::super::cv::CLEAR_MARGIN;
use super::super::diagnosis::Diagnosis;
use super::super::features::TurnRow;
use super::super::verdict::Verdict;
use super::pair::{Pair, TARGET_SIGMA};
use super::rival::{Fitted, Rival, Unfitted};
use crate::effect_id::EffectId;

/// Most ranked candidates an open verdict keeps in play.
pub const MAX_CANDIDATES_IN_PLAY: usize = 3;

/// Decides the rivals in play: those the verdict leaves open that could be fitted, a named
/// effect only against runner-ups the runs do not separate from it, none unless two remain.
pub(super) fn rivals_in_play(
    d: &Diagnosis,
    fitted: &[Fitted],
    pairs: &[Pair],
    noise_w: f64,
) -> Vec<Rival> {
    let in_play: Vec<Rival> = in_play(d)
        .into_iter()
        .filter(|r| fitted.iter().any(|f| f.rival == *r))
        .collect();
    // A named effect stays open only against the runner-ups the runs do not separate from it.
    let in_play: Vec<Rival> = match d.effect {
        Verdict::Effect(e) => {
            let named = Rival::Effect(e);
            let unseparated = |r: &Rival| {
                pairs.iter().any(|p| {
                    let labels = p.labels(fitted);
                    labels.contains(&named) && labels.contains(r) && p.sigma(noise_w) < TARGET_SIGMA
                })
            };
            in_play
                .into_iter()
                .filter(|r| *r == named || unseparated(r))
                .collect()
        }
        _ => in_play,
    };
    if in_play.len() >= 2 {
        in_play
    } else {
        Vec::new()
    }
}

/// Decides what the runs `rows` cannot tell apart among the rivals `in_play`, in words.
pub(super) fn statements_on(
    rows: &[TurnRow],
    not_fitted: &[Unfitted],
    in_play: &[Rival],
) -> Vec<String> {
    let mut statements = Vec::new();
    if rows.iter().all(|r| r.measured.is_none()) {
        statements.push(
            "without a pose track, a slip track off the calibration ground's and a terrain-wide \
             angular slip are the same in timing and power: slip-track is read only as every \
             turn slipping alike beyond the calibration's own turns driven alike"
                .into(),
        );
    }
    for u in not_fitted {
        if in_play.contains(&u.rival) {
            statements.push(format!(
                "{} cannot be fitted on these runs: {}",
                u.rival.label(),
                u.why
            ));
        }
    }
    statements
}

/// The rivals an open verdict leaves in play: for `ambiguous`, the baseline alone and the best
/// ranked candidates that improve the held-out error and could be named (their signature
/// present first, then inconclusive or not yet observable; one looked for and missing is out); for
/// `baseline-misfit` also copper loss;
/// for a named effect, the candidates within the selection's clear margin of it, or, when the
/// baseline with it still misfits its calibration, copper loss and the best candidates. Empty when
/// the verdict is settled (`none`, or a clear winner).
fn in_play(d: &Diagnosis) -> Vec<Rival> {
    // The nameable first: a candidate with its signature in the data, then by held-out score.
    let marked = |e: EffectId| d.signature(e).is_some_and(|s| s.present());
    // A mark looked for and missing rules its candidate out, as in the verdict (issue 35's
    // rule); one these runs' terrain or sensors hide cannot be seen whatever is driven next.
    let missing = |e: EffectId| d.signature(e).is_some_and(|s| s.absent());
    let could_be_named = |e: EffectId| !missing(e) && !d.signature(e).is_some_and(|s| s.masked);
    let mut improving: Vec<_> = d
        .candidates
        .iter()
        .filter(|c| c.shrink_pct > 0.0 && could_be_named(c.effect))
        .collect();
    improving.sort_by_key(|c| !marked(c.effect));
    let ranked = improving
        .into_iter()
        .take(MAX_CANDIDATES_IN_PLAY)
        .map(|c| Rival::Effect(c.effect));
    let unmarked_choice = d.mark_missing.filter(|&e| !missing(e)).map(Rival::Effect);
    let mut v: Vec<Rival> = match d.effect {
        // Outside the catalogue: no catalogued rival can be named, so none is in play.
        Verdict::None | Verdict::OutsideCatalogue => Vec::new(),
        Verdict::Ambiguous => std::iter::once(Rival::None)
            .chain(ranked)
            .chain(unmarked_choice)
            .collect(),
        Verdict::BaselineMisfit => [Rival::None, Rival::CopperLoss]
            .into_iter()
            .chain(ranked)
            .chain(unmarked_choice)
            .collect(),
        // A named effect is open only against a rival that could still be named in its place
        // (issue 35's rule): one whose own mark the runs did not test and miss (present, or not
        // observable on them) and, beside a baseline the named effect does not repair, one
        // whose mark needs no power model (no other is named against a misfit). A candidate
        // whose mark was looked for and not found is not named however well it fits, and a
        // baseline structure (copper loss) is no rival of an effect: its misfit is reported
        // beside it.
        Verdict::Effect(e) => {
            let Some(named) = d.candidates.iter().find(|c| c.effect == e) else {
                return Vec::new();
            };
            let misfit = still_misfits(d);
            let nameable =
                |c: EffectId| could_be_named(c) && !(misfit && c.signature_needs_power_model());
            let close: Vec<Rival> = d
                .candidates
                .iter()
                .filter(|c| {
                    c.effect != e
                        && c.penalised_mse < CLEAR_MARGIN * named.penalised_mse
                        && nameable(c.effect)
                })
                .take(MAX_CANDIDATES_IN_PLAY - 1)
                .map(|c| Rival::Effect(c.effect))
                .collect();
            if close.is_empty() {
                return Vec::new();
            }
            std::iter::once(Rival::Effect(e)).chain(close).collect()
        }
    };
    // The diagnosed model's further effects (its stepwise steps) act beside the named one: not
    // its rivals.
    let in_model = |r: &Rival| d.secondary.iter().any(|s| Rival::Effect(s.effect) == *r);
    let mut seen = Vec::new();
    v.retain(|r| {
        let new = !seen.contains(r) && !in_model(r);
        seen.push(*r);
        new
    });
    v
}

/// Whether `d` named an effect beside a baseline that misfits its calibration, and the effect
/// was not shown to repair the misfit.
fn still_misfits(d: &Diagnosis) -> bool {
    let repaired = d
        .adequacy_with_effect
        .as_ref()
        .is_some_and(|a| a.adequate == Some(true));
    d.effect.effect().is_some() && d.adequacy.adequate == Some(false) && !repaired
}
