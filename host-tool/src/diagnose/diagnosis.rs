//! What the diagnosis concluded: the result every stage's value ends up in, and its JSON.

use super::adequacy::Adequacy;
use super::baseline::{self, Baseline};
use super::calibration::{Calibration, CalibrationNote};
use super::cv::{CandidateScore, Scheme};
use super::gaps::{Gap, WhereAnalysis};
use super::next_runs::suggestion::NextRuns;
use super::signature;
use super::verdict::{Scope, Verdict};
use crate::effect_id::EffectId;
use model_core::kinematics::Regime;
use serde::Serialize;

/// What the diagnosis concluded.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnosis {
    /// A catalogue effect, `none` (no significant gap), `ambiguous` or `baseline-misfit`.
    pub effect: Verdict,
    /// The regime of the largest significant gap, or `all`.
    pub regime: Scope,
    /// Whether the model departs significantly: a gap is significant, or the named effect
    /// removes at least the practical floor of held-out RMS (the gaps' floor: the larger of
    /// 1.5 W and 5 % of the mean model power; a departure seen as spread).
    pub significant: bool,
    /// The baseline on all calibration rows.
    pub baseline: Baseline,
    /// The baseline's lack-of-fit test on its calibration manoeuvres.
    pub adequacy: Adequacy,
    /// The same test of the baseline plus the selected effect, when the baseline alone misfits
    /// and an effect was selected (an effect acting on the calibration manoeuvres too may
    /// explain the misfit; if it does not, the verdict is `baseline-misfit`).
    pub adequacy_with_effect: Option<Adequacy>,
    /// Effective-power gaps per regime and side (the selection's input).
    pub gaps: Vec<Gap>,
    /// Where the model departs: every metric, side, phase and run-time group.
    #[serde(rename = "where")]
    pub where_: WhereAnalysis,
    /// The scheme the selection used.
    pub scheme: Scheme,
    /// Every candidate under `scheme` that every fold tests, best first (the ranking).
    pub candidates: Vec<CandidateScore>,
    /// The candidates some fold of `scheme` does not test ([`cv::NotTestable`]), catalogue
    /// order: their held-out figures would be an extrapolation's, so they are left out of the
    /// ranking, and so of the rules that name an effect from it.
    pub not_testable: Vec<CandidateScore>,
    /// Every candidate under the other scheme (if it has ≥ 2 groups), catalogue order.
    pub other_scheme: Option<(Scheme, Vec<CandidateScore>)>,
    /// Held-out error before/after the named effect (the best candidate when none is named),
    /// under `scheme`: all rows (`all`), the rows of the regimes with a significant gap
    /// (`gap`, absent without one), then per regime.
    pub heldout: Vec<HeldOutError>,
    /// What the baseline was fitted on.
    pub calibration: CalibrationNote,
    /// Caveats of the input the caller adds (e.g. a per-turn summary's missing quantities).
    pub notes: Vec<String>,
    /// The regimes with a significant gap on either side (the rows of `heldout`'s `gap`).
    pub gap_regimes: Vec<Regime>,
    /// Further effects added by forward stepwise selection after the named one, in order, each
    /// with the held-out error of the model up to it.
    pub secondary: Vec<StepwiseStep>,
    /// Why the baseline has copper loss the calibration did not choose, when the diagnosed runs
    /// showed it ([`copper_from_runs`]).
    pub copper_from_runs: Option<CopperEvidence>,
    /// Every effect's signature test, catalogue order ([`signature`]).
    pub signatures: Vec<signature::Signature>,
    /// The candidate the held-out selection fitted best whose signature is not in the data
    /// (not named).
    pub mark_missing: Option<EffectId>,
    /// Each ranked candidate's sign check, fitted alone with the baseline on all rows
    /// ([`select::physically_signed`]): `None` when it cannot be fitted there.
    pub sign_checks: Vec<(EffectId, Option<bool>)>,
    /// Which rivals the runs separate and what to drive next ([`next_runs`]).
    pub next: NextRuns,
}

/// One step of the forward stepwise selection after the named effect.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StepwiseStep {
    /// The effect added.
    pub effect: EffectId,
    /// Held-out RMS of the model with every effect up to this one, all rows [W].
    pub heldout_error_after: f64,
    /// 100·(1 − after/baseline's held-out RMS) [%].
    pub shrink_pct: f64,
    /// The selection score of the model up to this one (see [`cv::score`]) [W²].
    pub penalised_mse: f64,
    /// The score of the model before this step [W²].
    pub penalised_mse_before: f64,
}

/// Held-out RMS before and after one effect over a set of rows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldOutError {
    /// All rows, the gap rows or one regime.
    pub regime: Scope,
    /// The effect added.
    pub effect: EffectId,
    /// RMS before [W].
    pub error_before: f64,
    /// RMS after [W].
    pub error_after: f64,
    /// 100·(1 − after/before) [%].
    pub shrink_pct: f64,
}

/// Why the diagnosis was redone with copper loss in the baseline: held-out RMS over all
/// diagnosed rows under the diagnosis' scheme [W].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CopperEvidence {
    /// The member the calibration chose (copper-free).
    pub chosen_member_error_w: f64,
    /// The copper-loss member, fitted on the same calibration manoeuvres.
    pub copper_member_error_w: f64,
    /// The best single effect on top of the chosen member.
    pub best_effect: EffectId,
    /// Its held-out RMS [W].
    pub best_effect_error_w: f64,
    /// The copper-loss member plus the best effect, when copper loss won beside the effect
    /// rather than instead of it [W]; `None` when the copper member alone won.
    pub copper_with_effect_error_w: Option<f64>,
    /// When the sides held at stall decided it: their held-out RMS with the chosen member and
    /// with the copper member [W].
    pub at_stall_error_w: Option<[f64; 2]>,
}

impl CopperEvidence {
    /// One line for the report.
    pub fn describe(&self) -> String {
        let why = match self.copper_with_effect_error_w {
            None => format!(
                "predicts the held-out rows with {:.2} W RMS against {:.2} W for the copper-free \
                 member the calibration chose and {:.2} W for it plus the best single effect ({})",
                self.copper_member_error_w,
                self.chosen_member_error_w,
                self.best_effect_error_w,
                self.best_effect.id(),
            ),
            Some(both) => format!(
                "predicts the held-out rows with {:.2} W RMS against {:.2} W for the copper-free \
                 member the calibration chose, and with the best single effect ({}) {:.2} W \
                 against {:.2} W",
                self.copper_member_error_w,
                self.chosen_member_error_w,
                self.best_effect.id(),
                both,
                self.best_effect_error_w,
            ),
        };
        let why = match self.at_stall_error_w {
            Some([chosen, copper]) => format!(
                "predicts the sides held at stall (commanded still in a turn, holding the \
                 tread's force: the inner side at R′) with {copper:.2} W RMS against {chosen:.2} W \
                 for the copper-free member the calibration chose, which gives them no power; \
                 over all held-out rows, with the best single effect ({}), {}",
                self.best_effect.id(),
                self.copper_with_effect_error_w.map_or_else(
                    || "n/a".to_owned(),
                    |both| format!("{both:.2} W against {:.2} W", self.best_effect_error_w)
                ),
            ),
            None => why,
        };
        format!(
            "copper loss taken from the diagnosed runs: the copper-loss member, fitted on the \
             same calibration manoeuvres, {why}; the calibration manoeuvres cannot show it (they \
             never drive a side slowly against a large force, as the inner side between B/2 and \
             R′ is)"
        )
    }
}

impl Diagnosis {
    /// The JSON: `effect`, `regime`, `significant`, `candidates`, `metric`, `heldout`
    /// (all rows; `heldout_per_regime` has the rest), plus the baseline and the gaps.
    pub fn to_json(&self) -> serde_json::Value {
        let all = self.heldout.iter().find(|h| h.regime == Scope::All);
        let gap = self.heldout.iter().find(|h| h.regime == Scope::Gap);
        serde_json::json!({
            "effect": self.effect,
            "regime": self.regime,
            "significant": self.significant,
            "candidates": self.candidates.iter().map(|c| serde_json::json!({
                "effect": c.effect.id(),
                "heldout_error_before": c.heldout_error_before,
                "heldout_error_after": c.heldout_error_after,
                "shrink_pct": c.shrink_pct,
                "signature_present": self.signature(c.effect).is_some_and(|s| s.present()),
                "physically_signed": self.sign_check(c.effect),
            })).collect::<Vec<_>>(),
            "not_testable_out_of_sample": self.not_testable.iter().filter_map(|c| {
                let why = c.not_testable?;
                Some(serde_json::json!({
                    "effect": c.effect.id(),
                    "scheme": self.scheme.id(),
                    "why": why,
                    "statement": format!("not testable out of sample: {}", why.describe()),
                }))
            }).collect::<Vec<_>>(),
            "metric": {
                "what": "RMS over held-out manoeuvres and both sides of the effective-power \
                         residual (energy / expected duration, measured minus model)",
                "unit": "W",
            },
            "reliability": self.effect.effect().zip(all).and_then(|(e, h)| {
                super::reliability::of(e, h.shrink_pct).map(|r| serde_json::json!({
                    "bench": "World N (nuisance-swept), both parts",
                    "shrink_bin_pct": r.bin,
                    "named": r.cell.named,
                    "right": r.cell.right,
                }))
            }),
            "heldout": all.map(|h| serde_json::json!({
                "scheme": self.scheme.id(),
                "effect": h.effect.id(),
                "error_before": h.error_before,
                "error_after": h.error_after,
                "shrink_pct": h.shrink_pct,
            })),
            "heldout_gap": gap.map(|h| serde_json::json!({
                "scheme": self.scheme.id(),
                "rows": "regimes with a significant gap",
                "regimes": self.gap_regimes.iter().map(|r| r.id()).collect::<Vec<_>>(),
                "effect": h.effect.id(),
                "error_before": h.error_before,
                "error_after": h.error_after,
                "shrink_pct": h.shrink_pct,
            })),
            "heldout_per_regime": self.heldout.iter().filter(|h| matches!(h.regime, Scope::Regime(_))).collect::<Vec<_>>(),
            "secondary": self.secondary,
            "baseline": self.baseline,
            "adequacy": self.adequacy,
            "adequacy_with_effect": self.adequacy_with_effect,
            "gaps": self.gaps,
            "where": self.where_,
            "calibration": self.calibration,
            "copper_from_runs": self.copper_from_runs,
            "signatures": self.signatures,
            "mark_missing": self.mark_missing.map(|e| e.id()),
            "identifiability": self.next.identifiability,
            "in_play": self.next.in_play,
            "next_runs": self.next.runs,
            "next_runs_unresolved": self.next.unresolved,
            "next_measurements": self.next.measurements,
            "notes": self.notes,
        })
    }
}

impl Diagnosis {
    /// `effect`'s signature test.
    pub fn signature(&self, effect: EffectId) -> Option<&signature::Signature> {
        self.signatures.iter().find(|s| s.effect == effect)
    }

    /// `effect`'s sign check, if it was ranked and could be fitted on all rows.
    pub fn sign_check(&self, effect: EffectId) -> Option<bool> {
        self.sign_checks
            .iter()
            .find(|(e, _)| *e == effect)
            .and_then(|(_, s)| *s)
    }

    /// `calibration` (the diagnosis' input) with the baseline family members this diagnosis'
    /// baseline came from: the copper-loss members when the diagnosed runs decided copper loss
    /// ([`copper_from_runs`]). What its figures and model file must be fitted with.
    pub fn fitted_with<'a>(&self, calibration: Calibration<'a>) -> Calibration<'a> {
        if self.copper_from_runs.is_some() {
            calibration.with_members(baseline::family::Members::CopperLoss)
        } else {
            calibration
        }
    }

    /// The effects of the diagnosed model: the named one, then its stepwise secondaries; empty
    /// for `none` and `ambiguous`.
    pub fn model_effects(&self) -> Vec<EffectId> {
        self.effect
            .effect()
            .into_iter()
            .chain(self.secondary.iter().map(|s| s.effect))
            .collect()
    }
}

/// The effect a diagnosis named, if it named one.
pub fn named_effect(d: &Diagnosis) -> Option<EffectId> {
    d.effect.effect()
}
