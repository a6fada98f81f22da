//! `diagnose`: where the hard-ground ICR model (paper Eq 21, fitted on calibration manoeuvres)
//! departs from measured power, which catalogued unmodelled effect explains it, and how much of
//! the held-out gap it closes. Its design (stages, invariants, how to add an effect): `DESIGN.md`
//! in this directory; measured figures: `docs/engineering-record.md`.
//!
//! Pipeline, read forward: [`features::rows`] (per-turn inner/outer rows from `validate`) →
//! [`baseline::Baseline`] (Eq 21 per side, calibration manoeuvres) → [`adequacy`] (does it fit
//! them?) → gaps per regime and side ([`gaps`]) → [`signature`] (each effect's own mark in the
//! data, tested) → every [`effects`] term scored by grouped cross-validation
//! ([`cv::score_all`]) → each candidate's marks, one table (`select::Marks`: its signature
//! and its sign check) → the verdict (`Selection::decide`: an effect only with its signature;
//! against a misfitting baseline only with one that needs no power model) → the same against
//! copper loss when the diagnosed runs show it ([`copper_from_runs`]) → [`report`].

pub mod adequacy;
pub mod baseline;
pub mod bench;
pub mod calibration;
pub mod copper_from_runs;
pub mod cv;
pub mod effects;
pub mod features;
pub mod figures;
pub mod gaps;
pub mod loo;
pub mod model_file;
pub mod next_runs;
pub mod observe;
// Path-level summaries (thesis Table 6.1): their own reader and judgement.
pub mod path_table;
pub mod report;
mod select;
pub mod signature;
pub mod summary;
pub mod verdict;
pub mod winding_heat;

#[cfg(test)]
mod tests;

use crate::effect_id::EffectId;
use adequacy::Adequacy;
use baseline::{Baseline, BaselineError};
use calibration::{Calibration, CalibrationNote};
use cv::{CandidateScore, Scheme};
use effects::{Context, EffectFitError, FittedModel, HEATING_TAU_GRID_S};
use features::TurnRow;
pub use gaps::{Gap, Part, WhereAnalysis};
use model_core::kinematics::Regime;
use model_core::Rover;
use select::Selection;
use serde::Serialize;
pub use verdict::{Scope, Verdict};

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
    /// The effects asked for cannot be fitted on these rows.
    #[error(transparent)]
    EffectFit(#[from] EffectFitError),
}

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
    pub copper_from_runs: Option<copper_from_runs::CopperEvidence>,
    /// Every effect's signature test, catalogue order ([`signature`]).
    pub signatures: Vec<signature::Signature>,
    /// The candidate the held-out selection fitted best whose signature is not in the data
    /// (not named).
    pub mark_missing: Option<EffectId>,
    /// Each ranked candidate's sign check, fitted alone with the baseline on all rows
    /// ([`select::physically_signed`]): `None` when it cannot be fitted there.
    pub sign_checks: Vec<(EffectId, Option<bool>)>,
    /// Which rivals the runs separate and what to drive next ([`next_runs`]).
    pub next: next_runs::NextRuns,
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
            "notes": self.notes,
        })
    }
}

/// The held-out RMS a model removes: √(before² − after²), 0 when it makes things worse [W].
fn removed_rms_w(before: f64, after: f64) -> f64 {
    (before * before - after * after).max(0.0).sqrt()
}

/// Diagnoses `rows` (see [`features::rows`]), calibrated on their own calibration manoeuvres.
pub fn diagnose(rover: &Rover, rows: &[TurnRow]) -> Result<Diagnosis, DiagnoseError> {
    diagnose_with(rover, rows, Calibration::FROM_RUNS)
}

/// Diagnoses `rows` with the baseline fitted as `calibration` says (e.g. on the calibration
/// manoeuvres of separate calibration runs, which are then not scored), and again against the
/// copper-loss members when the diagnosed runs show copper loss the calibration cannot
/// ([`copper_from_runs`]).
pub fn diagnose_with(
    rover: &Rover,
    rows: &[TurnRow],
    calibration: Calibration<'_>,
) -> Result<Diagnosis, DiagnoseError> {
    if rows.is_empty() {
        return Err(DiagnoseError::NoRows);
    }
    let first = diagnose_against(rover, rows, calibration)?;
    let mut d = copper_from_runs::reconsider(rover, rows, calibration, first, |c| {
        diagnose_against(rover, rows, c)
    })?;
    d.next = next_runs::plan(rover, rows, d.fitted_with(calibration), &d);
    Ok(d)
}

/// [`diagnose_with`] against the baseline `calibration` chooses, as it is.
pub(crate) fn diagnose_against(
    rover: &Rover,
    rows: &[TurnRow],
    calibration: Calibration<'_>,
) -> Result<Diagnosis, DiagnoseError> {
    let baseline = calibration.baseline(rover, rows)?;
    // Judged as fitted: with the calibration's slope nuisance (`calibration_grade_n`).
    let adequacy = adequacy::test(&calibration.manoeuvres(rows), 2, |r, s| {
        baseline.calibration_side_power_w(r, s)
    });

    // One significance rule for the gaps and the "where" groups (gaps::judge); groups without
    // repeats are judged row by row by leave-one-out prediction intervals.
    let verdicts = gaps::RowVerdicts::of(rows, calibration);
    let gaps = gaps::effective_gaps(&baseline, rows, &verdicts);
    let mut where_ = gaps::analyse(&baseline, rows, &verdicts);
    let significant_gaps = SignificantGaps::of(&gaps);
    let signatures = signature::test_all(&signature::Evidence::new(
        rows,
        calibration,
        &baseline,
        &where_,
    ));

    let (primary, secondary) = schemes(rows);
    let before = cv::heldout_residuals(rover, rows, primary, &[], calibration)?
        .ok_or(DiagnoseError::NothingToHoldOut)?;
    let (admission, mut notes) = Admission::of(rows, &where_);
    let allowed = |e: EffectId| admission.allows(e);
    let admitted = || EffectId::ALL.into_iter().filter(|&e| allowed(e));
    let scored = cv::score_all(rover, rows, primary, calibration, &before, admitted())?
        .ok_or(DiagnoseError::NothingToHoldOut)?;
    // A candidate some fold does not test has no out-of-sample score: not ranked, not named.
    let (mut candidates, not_testable): (Vec<CandidateScore>, Vec<CandidateScore>) =
        scored.into_iter().partition(|c| c.not_testable.is_none());
    candidates.sort_by(|a, b| a.penalised_mse.total_cmp(&b.penalised_mse));
    let other_scheme = match cv::heldout_residuals(rover, rows, secondary, &[], calibration)? {
        Some(before) => cv::score_all(rover, rows, secondary, calibration, &before, admitted())?
            .map(|c| (secondary, c)),
        None => None,
    };

    // A departure is significant when a mean gap is (beyond the repeat noise and the floor), or
    // when a catalogue term is the clear winner of the held-out selection and removes a
    // practically relevant RMS, √(MSE_before − MSE_after) ≥ the practical floor: an effect whose
    // power changes sign along the path (a slope) has mean gaps near 0 per regime but explains
    // the residuals' spread out of sample, which cross-validation itself tests.
    let selection = Selection {
        rover,
        rows,
        scheme: primary,
        calibration,
        before: &before,
    };
    // Each ranked candidate's evidence beside its fit, one plain table: its own signature and
    // whether its term has the sign its physics allows (fitted once; the selection reads what
    // the report shows).
    let marks = select::Marks::of(&candidates, &signatures, |e| {
        select::physically_signed(rover, rows, &[e], calibration)
    });
    let misfit = adequacy.adequate == Some(false);
    let select::Decision {
        selected,
        mark_missing,
    } = selection.decide(select::Facts {
        candidates: &candidates,
        marks: &marks,
        misfit,
        gap_regimes: &significant_gaps.regimes,
        trend: where_.run_time.trend.as_ref(),
        reaches_the_gaps: &|e| select::reaches_the_gaps(rover, rows, &baseline, &gaps, e),
    })?;
    let marked = |e: EffectId| marks.present(e);
    let spread = explained_spread(&baseline, rows, &candidates, selected);
    let in_groups = significant_gaps.any || where_.departs_over_run_time();
    let significant = in_groups || spread.is_some();
    // The headline and the "where" analysis state one verdict: a departure seen only out of
    // sample is recorded there too.
    if let (Some((c, floor_w)), false) = (spread, in_groups) {
        where_.add_heldout_departure(c, primary, floor_w);
    }
    let verdict = match selected {
        _ if !significant => Verdict::None,
        Some(e) => Verdict::Effect(e),
        None if misfit => Verdict::BaselineMisfit,
        None => Verdict::Ambiguous,
    };
    // The stepwise selection starts from the selected effect's own score (the selection may
    // have named it on the growth score, ahead of the best on effective power alone). The
    // adequacy check then judges the whole diagnosed model (a world may carry several effects).
    let mut secondary_steps = match verdict
        .effect()
        .and_then(|e| candidates.iter().find(|c| c.effect == e))
    {
        Some(score) => selection.stepwise(score, &|e| allowed(e) && marked(e))?,
        None => Vec::new(),
    };
    if misfit {
        // Beside a misfitting baseline only what stands on its own is named.
        secondary_steps.retain(|s| !s.effect.signature_needs_power_model());
    }
    let model_effects: Vec<EffectId> = verdict
        .effect()
        .into_iter()
        .chain(secondary_steps.iter().map(|s| s.effect))
        .collect();
    let adequacy_with_effect = match verdict.effect() {
        Some(_) if misfit => {
            let (baseline, model) = fit_model(rover, rows, &model_effects, calibration)?;
            Some(calibration_adequacy(
                rover,
                rows,
                calibration,
                &baseline,
                &model,
            ))
        }
        _ => None,
    };
    let effect = verdict;
    let named = effect.effect();
    if named == Some(EffectId::SinkageBulldozing) {
        notes.extend(sinkage_deficit_note(rover, rows, calibration));
    }
    let added = named.or(candidates.first().map(|c| c.effect));
    let heldout = match added {
        Some(added) => heldout_errors(
            rover,
            rows,
            primary,
            calibration,
            &before,
            added,
            &significant_gaps.regimes,
        )?,
        None => Vec::new(),
    };
    let regime = scope_of(rover, rows, named, calibration, &significant_gaps)?;
    Ok(Diagnosis {
        heldout,
        effect,
        regime,
        significant,
        baseline,
        adequacy,
        adequacy_with_effect,
        gaps,
        where_,
        scheme: primary,
        candidates,
        not_testable,
        other_scheme,
        gap_regimes: significant_gaps.regimes,
        secondary: secondary_steps,
        copper_from_runs: None,
        calibration: calibration.note(rows),
        notes,
        signatures,
        mark_missing,
        sign_checks: marks.sign_checks(),
        next: next_runs::NextRuns::default(),
    })
}

/// When the named `sinkage-bulldozing` term takes power from the turns (the sign rule of
/// [`select::physically_signed`] lets it), the report says so: sinkage then shows as turns
/// drawing less than the straights' resistance implies, not as an extra draw. No note when the
/// term cannot be refitted alone (the verdict stands; only its wording is at stake).
fn sinkage_deficit_note(
    rover: &Rover,
    rows: &[TurnRow],
    calibration: Calibration<'_>,
) -> Option<String> {
    let own = select::own_power_per_side_w(rover, rows, EffectId::SinkageBulldozing, calibration)
        .ok()
        .flatten();
    own.filter(|w| *w < 0.0).map(|w| {
        format!(
            "sinkage-bulldozing is a deficit here ({w:+.1} W per diagnosed side): G·|V| takes \
             the sand's resistance on every manoeuvre, straights included, and beyond it the \
             turns draw less, as when a turn's side compaction keeps the wheels' sinkage below \
             a straight's (the thesis' 2D slip-sinkage model, Eq 5.27)"
        )
    })
}

/// What the significant mean gaps say: whether there is one, their regimes (in gap order,
/// repeats next to each other merged) and the regime of the largest.
struct SignificantGaps {
    any: bool,
    regimes: Vec<Regime>,
    largest: Option<Regime>,
}

impl SignificantGaps {
    fn of(gaps: &[Gap]) -> Self {
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

/// The primary and secondary cross-validation schemes: leave one run out when there are two
/// runs or more, else leave one radius out.
fn schemes(rows: &[TurnRow]) -> (Scheme, Scheme) {
    let runs = rows.iter().map(|r| r.run_index).max().unwrap_or(0) + 1;
    if runs >= 2 {
        (Scheme::LeaveOneRunOut, Scheme::LeaveOneRadiusOut)
    } else {
        (Scheme::LeaveOneRadiusOut, Scheme::LeaveOneRunOut)
    }
}

/// Which catalogue effects the data can tell apart, and notes on those it cannot.
struct Admission {
    heating_identifiable: bool,
    offset_seen: bool,
}

impl Admission {
    fn of(rows: &[TurnRow], where_: &WhereAnalysis) -> (Self, Vec<String>) {
        // Motor heating acts through run time; when every run drives the same manoeuvres in the
        // same order, run time is confounded with the turn set and a heating term would fit turn
        // shapes instead. It is only a candidate when the "where" analysis can identify a
        // run-time trend (the same kind of manoeuvre recurring at run times spread apart).
        let mut notes = Vec::new();
        let heating_identifiable = where_.run_time.trend.is_some();
        if !heating_identifiable {
            notes.push(
                "motor-heating not scored: run time is not identifiable apart from the turn \
                 order (repeat manoeuvres within longer runs to test it)"
                    .to_owned(),
            );
        }
        // A sensor's current offset reads at standstill too (seed Fig 3.3: 0.59 A at rest):
        // when the runs have standstill samples and every side reads no more than a driver's
        // quiescent draw there, a constant extra power in the turns is something else (copper
        // loss, say).
        notes.extend(features::radius_source_note(rows));
        let offset_measured = offset_measured_at_standstill(rows);
        // Without standstill samples (a per-turn summary, runs without pauses) an offset
        // cannot be ruled out.
        let offset_seen = offset_measured || rows.iter().all(|r| r.standstill_current_a.is_none());
        if !offset_seen {
            notes.push(format!(
                "current-offset not scored: the standstill current is within ±{} A on both sides \
                 (a sensor offset would read there too)",
                baseline::QUIESCENT_MAX_A
            ));
        }
        let admission = Self {
            heating_identifiable,
            offset_seen,
        };
        (admission, notes)
    }

    fn allows(&self, e: EffectId) -> bool {
        match e {
            EffectId::MotorHeating => self.heating_identifiable,
            EffectId::CurrentOffset => self.offset_seen,
            EffectId::InnerDrag
            | EffectId::SinkageBulldozing
            | EffectId::AngularSlip
            | EffectId::SlipTrack
            | EffectId::BrakedInner
            | EffectId::Slope => true,
        }
    }
}

/// The selected effect's score and the floor [W] when it removes at least that practical floor
/// of RMS out of sample. The floor is the one of the gaps and the adequacy test: the larger of
/// the fixed floor and a share of the model power (a few watts are noise for a rover drawing
/// hundreds).
fn explained_spread<'a>(
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
        .filter(|c| removed_rms_w(c.heldout_error_before, c.heldout_error_after) >= floor_w)
        .map(|c| (c, floor_w))
}

/// Held-out RMS before and after adding `added`, over all rows, the gap regimes and each regime.
fn heldout_errors(
    rover: &Rover,
    rows: &[TurnRow],
    primary: Scheme,
    calibration: Calibration<'_>,
    before: &[cv::RowResidual],
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
fn scope_of(
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

/// Whether some run's standstill current on some side exceeds the drivers' quiescent draw
/// ([`baseline::QUIESCENT_MAX_A`]).
fn offset_measured_at_standstill(rows: &[TurnRow]) -> bool {
    rows.iter().filter_map(|r| r.standstill_current_a).any(|s| {
        s.left.abs() > baseline::QUIESCENT_MAX_A || s.right.abs() > baseline::QUIESCENT_MAX_A
    })
}

/// The calibration manoeuvres' lack-of-fit test of `baseline` with `model`'s terms, fitted
/// jointly on all rows.
fn calibration_adequacy(
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

/// Whether `effect`, fitted on all rows, acts across the regimes: its own term (without the
/// baseline corrections) has an RMS per side of at least [`cv::PRACTICAL_FLOOR_W`] in some
/// regime and at least half of that floor on the straights (not for `slip-track`: a straight
/// has no yaw to scale) and in every other regime present but at most one (a slope term is
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
    let acts = |r: f64| r >= 0.5 * cv::PRACTICAL_FLOOR_W;
    let missing = rms.iter().filter(|(_, r)| !acts(*r)).count();
    // A slip track scales every turn alike and a straight has no yaw to scale.
    let on_straights = effect == EffectId::SlipTrack
        || rms
            .iter()
            .any(|(regime, r)| *regime == Regime::Straight && acts(*r));
    Ok(largest >= cv::PRACTICAL_FLOOR_W && on_straights && missing <= 1 && rms.len() >= 3)
}

/// The baseline as `calibration` says and `effects` fitted jointly on all rows (plus the
/// calibration runs' manoeuvres): the diagnosed model, for tabulating (e.g. the model file of
/// `plan --model`, [`model_file`]) with [`extra_power_w`].
pub fn fit_model(
    rover: &Rover,
    rows: &[TurnRow],
    effects: &[EffectId],
    calibration: Calibration<'_>,
) -> Result<(Baseline, FittedModel), DiagnoseError> {
    let baseline = calibration.baseline(rover, rows)?;
    let ctx = Context {
        rover,
        baseline: &baseline,
        heating_tau_s: HEATING_TAU_GRID_S[0],
    };
    let model = FittedModel::fit(
        effects,
        &calibration.training_rows(rows),
        &calibration.manoeuvres(rows),
        &ctx,
    )?;
    Ok((baseline, model))
}

/// The extra effective power `model` predicts on top of `baseline` for each side of `row`
/// ([inner, outer] for turns) [W], baseline corrections included.
pub fn extra_power_w(
    rover: &Rover,
    baseline: &Baseline,
    model: &FittedModel,
    row: &TurnRow,
) -> [f64; 2] {
    let ctx = model.context(rover, baseline);
    [0, 1].map(|side| model.extra_w(row, side, &ctx))
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
