//! `diagnose`: where the hard-ground ICR model (paper Eq 21, fitted on calibration manoeuvres)
//! departs from measured power, which catalogued unmodelled effect explains it, and how much of
//! the held-out gap it closes. Its design (stages, invariants, how to add an effect): `DESIGN.md`
//! in this directory; measured figures: `docs/engineering-record.md`.
//!
//! Pipeline, read forward, each stage a function of the previous stages' values: the
//! [`Problem`] (rover, rows from [`features::rows`], calibration) → `fit_baseline`
//! ([`baseline::Baseline`], Eq 21 per side on the calibration manoeuvres, and its
//! [`adequacy`]) → `departures` (gaps per regime and side and the "where" groups, [`gaps`]) →
//! the marks ([`catalogue::test_marks`]: each effect's own, tested) → `candidates` (every
//! admitted term scored by grouped cross-validation, [`cv::score_all`]) → `conclude` (the
//! verdict, `select`: an effect only with its mark; against a misfitting baseline only with
//! one that needs no power model) → `findings` (held-out errors, regime). Then the same against
//! copper loss when the diagnosed runs show it ([`copper_from_runs`]), what to drive next
//! ([`next_runs`]), and the [`report`].

pub mod adequacy;
mod admission;
pub mod baseline;
pub mod calibration;
pub mod catalogue;
pub mod copper_from_runs;
pub mod cv;
pub mod diagnosis;
pub mod effect;
pub mod effects;
pub mod error;
pub mod features;
pub mod figures;
mod findings;
pub mod gaps;
pub mod loo;
pub mod model_file;
pub mod next_runs;
pub mod observe;
// Path-level summaries (thesis Table 6.1): their own reader and judgement.
pub(crate) mod matched_slip;
pub mod path_table;
pub mod reliability;
pub mod report;
pub(crate) mod select;
pub mod signature;
mod significance;
pub(crate) mod speed_ceiling;
pub mod stats;
pub mod summary;
pub mod verdict;
pub mod winding_heat;

#[cfg(test)]
mod tests;

use crate::effect_id::EffectId;
use adequacy::Adequacy;
use admission::Admission;
use baseline::Baseline;
use calibration::Calibration;
use cv::{CandidateScore, Scheme};
pub use diagnosis::{named_effect, CopperEvidence, Diagnosis, HeldOutError, StepwiseStep};
pub use effects::{extra_power_w, fit_model};
pub use error::{DiagnoseError, EffectFitError};
use features::TurnRow;
pub use gaps::{Gap, Part, WhereAnalysis};
use model_core::Rover;
use select::Selection;
use significance::SignificantGaps;
pub use verdict::{Scope, Verdict};

/// What is diagnosed, built once: the rover, the rows, and how the baseline is calibrated.
#[derive(Debug, Clone, Copy)]
pub struct Problem<'a> {
    /// The rover (geometry, R′).
    pub rover: &'a Rover,
    /// The diagnosed rows (see [`features::rows`]), with the calibration runs' rows when the
    /// runs calibrate themselves.
    pub rows: &'a [TurnRow],
    /// Where the baseline is fitted, and which members it chooses from.
    pub calibration: Calibration<'a>,
}

/// Diagnoses `rows` (see [`features::rows`]), calibrated on their own calibration manoeuvres.
pub fn diagnose(rover: &Rover, rows: &[TurnRow]) -> Result<Diagnosis, DiagnoseError> {
    diagnose_with(rover, rows, Calibration::FROM_RUNS)
}

/// Diagnoses `rows` with the baseline fitted as `calibration` says (e.g. on the calibration
/// manoeuvres of separate calibration runs, which are then not scored), and again against the
/// copper-loss members when the diagnosed runs show copper loss the calibration cannot
/// ([`copper_from_runs`]); then what to drive next ([`next_runs`]).
pub fn diagnose_with(
    rover: &Rover,
    rows: &[TurnRow],
    calibration: Calibration<'_>,
) -> Result<Diagnosis, DiagnoseError> {
    if rows.is_empty() {
        return Err(DiagnoseError::NoRows);
    }
    let problem = Problem {
        rover,
        rows,
        calibration,
    };
    let first = diagnose_against(problem)?;
    let mut d = copper_from_runs::reconsider(rover, rows, calibration, first, |calibration| {
        diagnose_against(Problem {
            calibration,
            ..problem
        })
    })?;
    d.next = next_runs::plan(rover, rows, d.fitted_with(calibration), &d);
    Ok(d)
}

/// One pass of the diagnosis against the baseline the problem's calibration chooses, read
/// forward: baseline → departures → marks → candidates → verdict → findings.
pub(crate) fn diagnose_against(p: Problem<'_>) -> Result<Diagnosis, DiagnoseError> {
    let Fitted { baseline, adequacy } = fit_baseline(p)?;
    let departures = departures(p, &baseline);
    let signatures = catalogue::test_marks(&signature::Evidence::new(
        p.rows,
        p.calibration,
        &baseline,
        &departures.where_,
    ));
    let mut candidates = candidates(p, &departures.where_)?;
    let conclusion = conclude(
        p,
        &baseline,
        &adequacy,
        &departures,
        &signatures,
        &candidates,
    )?;
    let Departures {
        gaps,
        mut where_,
        significant: significant_gaps,
    } = departures;
    // The headline and the "where" analysis state one verdict: a departure seen only out of
    // sample is recorded there too.
    if let Some((effect, errors, floor_w)) = conclusion.heldout_departure {
        where_.add_heldout_departure(effect, errors, candidates.primary.id(), floor_w);
    }
    let named = conclusion.verdict.effect();
    if let Some(named) = named {
        candidates.notes.extend(findings::deficit_note(
            p.rover,
            p.rows,
            named,
            p.calibration,
        ));
    }
    let added = named.or(candidates.ranked.first().map(|c| c.effect));
    let heldout = match added {
        Some(added) => findings::heldout_errors(
            p.rover,
            p.rows,
            candidates.primary,
            p.calibration,
            &candidates.before,
            added,
            &significant_gaps.regimes,
        )?,
        None => Vec::new(),
    };
    let regime = findings::scope_of(p.rover, p.rows, named, p.calibration, &significant_gaps)?;
    Ok(Diagnosis {
        heldout,
        effect: conclusion.verdict,
        regime,
        significant: conclusion.significant,
        baseline,
        adequacy,
        adequacy_with_effect: conclusion.adequacy_with_effect,
        gaps,
        where_,
        scheme: candidates.primary,
        candidates: candidates.ranked,
        not_testable: candidates.not_testable,
        other_scheme: candidates.other_scheme,
        gap_regimes: significant_gaps.regimes,
        secondary: conclusion.secondary,
        copper_from_runs: None,
        calibration: p.calibration.note(p.rows),
        notes: candidates.notes,
        signatures,
        mark_missing: conclusion.mark_missing,
        sign_checks: conclusion.sign_checks,
        next: next_runs::NextRuns::default(),
    })
}

/// The baseline on the calibration manoeuvres, and its lack-of-fit test there.
struct Fitted {
    baseline: Baseline,
    adequacy: Adequacy,
}

fn fit_baseline(p: Problem<'_>) -> Result<Fitted, DiagnoseError> {
    let baseline = p.calibration.baseline(p.rover, p.rows)?;
    // Judged as fitted: with the calibration's slope nuisance (`calibration_grade_n`).
    let adequacy = adequacy::test(&p.calibration.manoeuvres(p.rows), 2, |r, s| {
        baseline.calibration_side_power_w(r, s)
    });
    Ok(Fitted { baseline, adequacy })
}

/// Where the model departs: the mean gaps per regime and side, and every metric's groups.
struct Departures {
    gaps: Vec<Gap>,
    where_: WhereAnalysis,
    significant: SignificantGaps,
}

fn departures(p: Problem<'_>, baseline: &Baseline) -> Departures {
    // One significance rule for the gaps and the "where" groups (gaps::judge); groups without
    // repeats are judged row by row by leave-one-out prediction intervals.
    let verdicts = gaps::RowVerdicts::of(p.rows, p.calibration);
    let gaps = gaps::effective_gaps(baseline, p.rows, &verdicts);
    let where_ = gaps::analyse(baseline, p.rows, &verdicts);
    let significant = SignificantGaps::of(&gaps);
    Departures {
        gaps,
        where_,
        significant,
    }
}

/// Every admitted catalogue term scored out of sample: ranked (every fold tests it) or not
/// testable, under the primary scheme, and under the other one for the report.
struct Candidates {
    primary: Scheme,
    /// Held-out residuals of the baseline alone under `primary`.
    before: observe::HeldOut,
    admission: Admission,
    ranked: Vec<CandidateScore>,
    not_testable: Vec<CandidateScore>,
    other_scheme: Option<(Scheme, Vec<CandidateScore>)>,
    notes: Vec<String>,
}

fn candidates(p: Problem<'_>, where_: &WhereAnalysis) -> Result<Candidates, DiagnoseError> {
    let Problem {
        rover,
        rows,
        calibration,
    } = p;
    let (primary, secondary) = cv::schemes(rows);
    let before = cv::heldout_residuals(rover, rows, primary, &[], calibration)?
        .ok_or(DiagnoseError::NothingToHoldOut)?;
    let (admission, notes) = Admission::of(rows, where_);
    let admitted = || EffectId::ALL.into_iter().filter(|&e| admission.allows(e));
    let scored = cv::score_all(rover, rows, primary, calibration, &before, admitted())?
        .ok_or(DiagnoseError::NothingToHoldOut)?;
    // A candidate some fold does not test has no out-of-sample score: not ranked, not named.
    let (mut ranked, not_testable): (Vec<CandidateScore>, Vec<CandidateScore>) =
        scored.into_iter().partition(|c| c.not_testable.is_none());
    ranked.sort_by(|a, b| a.penalised_mse.total_cmp(&b.penalised_mse));
    let other_scheme = match cv::heldout_residuals(rover, rows, secondary, &[], calibration)? {
        Some(before) => cv::score_all(rover, rows, secondary, calibration, &before, admitted())?
            .map(|c| (secondary, c)),
        None => None,
    };
    Ok(Candidates {
        primary,
        before,
        admission,
        ranked,
        not_testable,
        other_scheme,
        notes,
    })
}

/// The verdict and what it brings along: whether the departure is significant, the stepwise
/// secondaries, the candidate whose mark is missing, each candidate's sign check, the
/// calibration's lack of fit with the named model, and a departure seen only out of sample
/// (effect, held-out RMS before and after, floor).
struct Conclusion {
    verdict: Verdict,
    significant: bool,
    secondary: Vec<StepwiseStep>,
    mark_missing: Option<EffectId>,
    sign_checks: Vec<(EffectId, Option<bool>)>,
    adequacy_with_effect: Option<Adequacy>,
    heldout_departure: Option<(EffectId, (f64, f64), f64)>,
}

/// Whether some catalogued effect could still explain the departure: one whose own mark is
/// present (whatever its term closes), or a candidate that improves the held-out fit (or one
/// not testable out of sample) whose mark is neither ruled out (looked for and missing, or
/// hidden by another's) nor unobservable whatever is driven. Without one, the departure is
/// outside the catalogue.
fn catalogue_could_explain(
    ranked: &[CandidateScore],
    not_testable: &[CandidateScore],
    signatures: &[signature::Signature],
) -> bool {
    let mark = |e: EffectId| signatures.iter().find(|s| s.effect == e);
    let still_nameable = |e: EffectId| mark(e).is_none_or(|s| !s.rules_out() && !s.masked);
    signatures.iter().any(|s| s.present())
        || ranked
            .iter()
            .filter(|c| c.shrink_pct > 0.0)
            .chain(not_testable)
            .any(|c| still_nameable(c.effect))
}

fn conclude(
    p: Problem<'_>,
    baseline: &Baseline,
    adequacy: &Adequacy,
    departures: &Departures,
    signatures: &[signature::Signature],
    candidates: &Candidates,
) -> Result<Conclusion, DiagnoseError> {
    let Problem {
        rover,
        rows,
        calibration,
    } = p;
    // A departure is significant when a mean gap is (beyond the repeat noise and the floor), or
    // when a catalogue term is the clear winner of the held-out selection and removes a
    // practically relevant RMS, √(MSE_before − MSE_after) ≥ the practical floor: an effect whose
    // power changes sign along the path (a slope) has mean gaps near 0 per regime but explains
    // the residuals' spread out of sample, which cross-validation itself tests.
    let selection = Selection {
        rover,
        rows,
        scheme: candidates.primary,
        calibration,
        before: &candidates.before,
    };
    // Each ranked candidate's evidence beside its fit, one plain table: its own signature and
    // whether its term has the sign its physics allows (fitted once; the selection reads what
    // the report shows).
    let marks = select::Marks::of(&candidates.ranked, signatures, |e| {
        select::physically_signed(rover, rows, &[e], calibration)
    });
    let misfit = adequacy.adequate == Some(false);
    let select::Decision {
        selected,
        mark_missing,
    } = selection.decide(select::Facts {
        candidates: &candidates.ranked,
        marks: &marks,
        misfit,
        gap_regimes: &departures.significant.regimes,
        trend: departures.where_.run_time.trend.as_ref(),
        reaches_the_gaps: &|e| select::reaches_the_gaps(rover, rows, baseline, &departures.gaps, e),
    })?;
    let spread = significance::explained_spread(baseline, rows, &candidates.ranked, selected);
    let in_groups = departures.significant.any || departures.where_.departs_over_run_time();
    let significant = in_groups || spread.is_some();
    let heldout_departure = spread.filter(|_| !in_groups).map(|(c, floor_w)| {
        (
            c.effect,
            (c.heldout_error_before, c.heldout_error_after),
            floor_w,
        )
    });
    let verdict = match selected {
        _ if !significant => Verdict::None,
        Some(e) => Verdict::Effect(e),
        None if misfit => Verdict::BaselineMisfit,
        None if !catalogue_could_explain(
            &candidates.ranked,
            &candidates.not_testable,
            signatures,
        ) =>
        {
            Verdict::OutsideCatalogue
        }
        None => Verdict::Ambiguous,
    };
    // The stepwise selection starts from the selected effect's own score (the selection may
    // have named it on the growth score, ahead of the best on effective power alone). The
    // adequacy check then judges the whole diagnosed model (a world may carry several effects).
    let stepwise_allowed = |e: EffectId| candidates.admission.allows(e) && marks.present(e);
    let mut secondary = match verdict
        .effect()
        .and_then(|e| candidates.ranked.iter().find(|c| c.effect == e))
    {
        Some(score) => selection.stepwise(score, &stepwise_allowed)?,
        None => Vec::new(),
    };
    if misfit {
        // Beside a misfitting baseline only what stands on its own is named.
        secondary.retain(|s| !s.effect.signature_needs_power_model());
    }
    let model_effects: Vec<EffectId> = verdict
        .effect()
        .into_iter()
        .chain(secondary.iter().map(|s| s.effect))
        .collect();
    let adequacy_with_effect = match verdict.effect() {
        Some(_) if misfit => {
            let (baseline, model) = fit_model(rover, rows, &model_effects, calibration)?;
            Some(findings::calibration_adequacy(
                rover,
                rows,
                calibration,
                &baseline,
                &model,
            ))
        }
        _ => None,
    };
    Ok(Conclusion {
        verdict,
        significant,
        secondary,
        mark_missing,
        sign_checks: marks.sign_checks(),
        adequacy_with_effect,
        heldout_departure,
    })
}
