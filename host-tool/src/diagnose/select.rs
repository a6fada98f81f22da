//! The verdict stage: which catalogue term to name. It reads plain values ([`Facts`]: the
//! ranked candidates, their [`Marks`], the adequacy, where the departure is) and hands back a
//! [`Decision`]. It weighs only the rivals, the candidates that could be named: their mark
//! present, inconclusive or not yet observable, and not hidden by another effect's present
//! mark. Inside:
//! the clear winner of the held-out selection among them and the rules that decide
//! near ties (the one candidate in it with its signature, the manoeuvres' total power), the
//! regimes of the gap, the run-time trend, the physics' signs and the gaps' places; and the
//! forward stepwise secondaries.

use super::baseline::Baseline;
use super::calibration::{Calibration, Source};
use super::catalogue;
use super::cv::{self, CandidateScore, Scheme};
use super::diagnosis::StepwiseStep;
use super::effect::{Context, SignRule};
use super::effects::{self, FittedEffect, HEATING_TAU_GRID_S};
use super::effects::{fit_model, FittedModel};
use super::error::DiagnoseError;
use super::features::TurnRow;
use super::gaps::{self, Gap, Part};
use super::matched_slip::{slip_against_calibration, SlipAgainstCalibration};
use super::signature;
use super::stats;
use super::stats::removed_rms_w;
use crate::effect_id::EffectId;
use model_core::kinematics::Regime;
use model_core::Rover;

/// What each ranked candidate shows besides its held-out fit.
#[derive(Debug, Clone)]
pub(super) struct Marks(Vec<Mark>);

#[derive(Debug, Clone, Copy)]
struct Mark {
    effect: EffectId,
    /// Its own signature is in the data ([`signature`]).
    present: bool,
    /// Its signature is measured without the power model.
    model_free: bool,
    /// Its signature is hidden by another effect whose own mark is present
    /// ([`signature::Signature::hidden_by`]).
    hidden: bool,
    /// It cannot be named on these runs ([`signature::Signature::rules_out`]).
    ruled_out: bool,
    /// Its term, fitted alone on all rows, has the sign its physics allows; `None` when the
    /// fit failed.
    signed: Option<bool>,
}

impl Marks {
    /// The marks of `candidates`, with `signed` asked once per candidate.
    pub fn of(
        candidates: &[CandidateScore],
        signatures: &[signature::Signature],
        signed: impl Fn(EffectId) -> Result<bool, DiagnoseError>,
    ) -> Marks {
        Marks(
            candidates
                .iter()
                .map(|c| {
                    let s = signatures.iter().find(|s| s.effect == c.effect);
                    Mark {
                        effect: c.effect,
                        present: s.is_some_and(signature::Signature::present),
                        ruled_out: s.is_some_and(signature::Signature::rules_out),
                        hidden: s.is_some_and(|s| s.hidden_by.is_some()),
                        model_free: !c.effect.signature_needs_power_model(),
                        signed: signed(c.effect).ok(),
                    }
                })
                .collect(),
        )
    }

    fn get(&self, e: EffectId) -> Option<&Mark> {
        self.0.iter().find(|m| m.effect == e)
    }

    /// Whether `e`'s own signature is in the data.
    pub fn present(&self, e: EffectId) -> bool {
        self.get(e).is_some_and(|m| m.present)
    }

    /// Whether `e`'s signature is measured without the power model.
    fn model_free(&self, e: EffectId) -> bool {
        self.get(e).is_some_and(|m| m.model_free)
    }

    /// Whether `e` cannot be named on these runs.
    fn ruled_out(&self, e: EffectId) -> bool {
        self.get(e).is_some_and(|m| m.ruled_out)
    }

    /// Whether another effect's present mark hides `e`'s.
    fn hidden(&self, e: EffectId) -> bool {
        self.get(e).is_some_and(|m| m.hidden)
    }

    /// Whether `e`'s term has its physical sign (`false` when unknown).
    fn signed(&self, e: EffectId) -> bool {
        self.get(e).and_then(|m| m.signed) == Some(true)
    }

    /// Each ranked candidate's sign check, for the report.
    pub fn sign_checks(&self) -> Vec<(EffectId, Option<bool>)> {
        self.0.iter().map(|m| (m.effect, m.signed)).collect()
    }
}

/// What the verdict stage reads: the ranked candidates with their marks, whether the baseline
/// misfits its calibration, and where the departure is.
pub(super) struct Facts<'a> {
    pub candidates: &'a [CandidateScore],
    pub marks: &'a Marks,
    pub misfit: bool,
    pub gap_regimes: &'a [Regime],
    pub trend: Option<&'a gaps::Trend>,
    /// Whether a candidate's term, fitted alone, lowers the significant gaps.
    pub reaches_the_gaps: &'a dyn Fn(EffectId) -> bool,
}

/// The verdict stage's answer.
pub(super) struct Decision {
    /// The effect named (its signature in the data, physically signed, and reaching the gaps
    /// when its signature is read off the residuals).
    pub selected: Option<EffectId>,
    /// The best fit out of sample when it was not named because its signature is missing (or,
    /// else, the choice among the rivals when its signature is).
    pub mark_missing: Option<EffectId>,
}

/// Whether every term of the model `effects`, fitted jointly on all rows, has the sign its
/// physics allows ([`SignRule`], each effect's own): a term that adds power must have its own
/// power over the diagnosed manoeuvres ([`term_own_power_w`]) positive; one whose regressor
/// carries the sign (a slope's pitch), a positive coefficient; one that may go either way (a
/// sensor offset; sinkage, whose resistance G takes on the straights), any; and a slip track
/// narrower than the controller's (every turn quicker) must not contradict turns the yaw timed
/// as slow as the calibration's turns driven alike ([`turns_no_quicker_by_yaw`]). A term fitted against its
/// physics is a shape that happens to match a deficit, not the effect.
pub(super) fn physically_signed(
    rover: &Rover,
    rows: &[TurnRow],
    effects: &[EffectId],
    calibration: Calibration<'_>,
) -> Result<bool, DiagnoseError> {
    let (baseline, model) = fit_model(rover, rows, effects, calibration)?;
    Ok(terms_physically_signed(
        rover,
        rows,
        &baseline,
        &model,
        calibration,
    ))
}

/// [`physically_signed`] of a model already fitted with `baseline`.
fn terms_physically_signed(
    rover: &Rover,
    rows: &[TurnRow],
    baseline: &Baseline,
    model: &FittedModel,
    calibration: Calibration<'_>,
) -> bool {
    let ctx = model.context(rover, baseline);
    model
        .effects
        .iter()
        .all(|term| match catalogue::of(term.effect).sign_rule() {
            SignRule::Either => true,
            SignRule::NonNegativeUnlessTurnsQuickerByYaw => {
                term.params[0] >= 0.0 || !turns_no_quicker_by_yaw(rows, calibration)
            }
            SignRule::PositiveCoefficient => term.params[0] > 0.0,
            SignRule::AddsPower => term_own_power_w(rows, term, &ctx) > 0.0,
        })
}

/// A term's own power summed over the sides of the diagnosed manoeuvres, before the baseline's
/// absorption [W]: its coefficients are those of the joint model (baseline + terms), whatever
/// the baseline took of it on the calibration manoeuvres (which can leave a true drag as a
/// deficit in some regimes).
fn term_own_power_w(rows: &[TurnRow], term: &FittedEffect, ctx: &Context<'_>) -> f64 {
    rows.iter()
        .filter(|r| !r.calibration_kind)
        .flat_map(|r| (0..r.sides.len()).map(move |s| (r, s)))
        .map(|(r, s)| term.term_w(r, s, ctx))
        .sum()
}

/// The mean own power per diagnosed side of `effect` fitted alone with the baseline on all
/// rows ([`term_own_power_w`]) [W]; `None` without a diagnosed side.
pub(super) fn own_power_per_side_w(
    rover: &Rover,
    rows: &[TurnRow],
    effect: EffectId,
    calibration: Calibration<'_>,
) -> Result<Option<f64>, DiagnoseError> {
    let (baseline, model) = fit_model(rover, rows, &[effect], calibration)?;
    let sides: usize = rows
        .iter()
        .filter(|r| !r.calibration_kind)
        .map(|r| r.sides.len())
        .sum();
    let ctx = model.context(rover, &baseline);
    Ok(model
        .effects
        .first()
        .filter(|_| sides > 0)
        .map(|term| term_own_power_w(rows, term, &ctx) / sides as f64))
}

/// Largest significant gap an effect may leave where it does not act, as a fraction of the
/// largest it reaches.
const UNREACHED_GAP_FRACTION: f64 = 0.5;

/// Whether `effect` acts where the significant gaps are: no significant gap in a group
/// (regime, side) where its term is 0 on every manoeuvre is at least
/// [`UNREACHED_GAP_FRACTION`] of the largest significant gap where it acts. A term confined to
/// some regimes (an inner drag past B/2, a braked inner side at R′) that matches the largest
/// gap while an equal gap sits where it cannot act is a shape that fits one part of a wider
/// misfit (e.g. copper loss at every slow, high-force inner side), not the effect. (That a
/// term acting at one radius stands out from the neighbouring radii is its signature's test,
/// [`signature`].)
pub(super) fn reaches_the_gaps(
    rover: &Rover,
    rows: &[TurnRow],
    baseline: &Baseline,
    gaps: &[Gap],
    effect: EffectId,
) -> bool {
    let ctx = Context {
        rover,
        baseline,
        heating_tau_s: HEATING_TAU_GRID_S[0],
    };
    let acts = |gap: &Gap| {
        rows.iter().filter(|r| r.regime == gap.regime).any(|r| {
            (0..r.sides.len())
                .filter(|&s| gap.side == Part::Total || gap.side == r.sides[s].role)
                .any(|s| {
                    effects::regressors(effect, r, s, &ctx)
                        .is_some_and(|x| x.iter().any(|v| *v != 0.0))
                })
        })
    };
    // Any extra force on a side held at stall shows there as copper loss alone, which no
    // term's power models: with copper loss in the baseline, its gap is not one the term
    // could be asked to reach, nor one it is credited with.
    let held = |gap: &Gap| baseline.structure.copper_loss && gap.at_sides_held_at_stall(rows);
    let significant: Vec<&Gap> = gaps.iter().filter(|g| g.significant && !held(g)).collect();
    let Some(largest) = significant
        .iter()
        .filter(|g| acts(g))
        .max_by(|a, b| a.mean_w.abs().total_cmp(&b.mean_w.abs()))
    else {
        // Every significant gap where the term cannot act: it explains none of them.
        return significant.is_empty();
    };
    !significant.iter().any(|g| {
        g.mean_w * largest.mean_w > 0.0
            && g.mean_w.abs() >= UNREACHED_GAP_FRACTION * largest.mean_w.abs()
            && !acts(g)
    })
}

/// Whether the turns timed by yaw took, on average, at least as long as the calibration's own
/// turns driven alike: then no narrower slip track (a negative `slip-track` term, every turn
/// quicker) is what the power shows. `false` when not measured.
fn turns_no_quicker_by_yaw(rows: &[TurnRow], calibration: Calibration<'_>) -> bool {
    let Source::Rows(cal) = calibration.source else {
        return false;
    };
    matches!(
        slip_against_calibration(rows, cal, |_| true),
        SlipAgainstCalibration::Measured(m) if m.difference >= 0.0
    )
}

/// Without a clear winner: the one candidate in a near tie with the best (penalised error
/// within [`cv::CLEAR_MARGIN`]) whose signature is present (`marked`) and that closes part of
/// the held-out error (any part when its signature is measured without the power model, else
/// [`cv::MIN_SHRINK_PCT`]). The direct observation decides a tie the power cannot (the
/// standstill current, the yaw, the pitch); when two candidates in the tie show their
/// signatures, the data do not decide between them and none is chosen.
pub(super) fn marked_in_near_tie(
    candidates: &[CandidateScore],
    marked: &dyn Fn(EffectId) -> bool,
) -> Option<EffectId> {
    let best = candidates.first()?;
    let shown: Vec<EffectId> = candidates
        .iter()
        .take_while(|c| c.penalised_mse < cv::CLEAR_MARGIN * best.penalised_mse)
        .filter(|c| {
            let closes = if c.effect.signature_needs_power_model() {
                c.shrink_pct >= cv::MIN_SHRINK_PCT
            } else {
                c.shrink_pct > 0.0
            };
            marked(c.effect) && closes
        })
        .map(|c| c.effect)
        .collect();
    match shown[..] {
        [e] => Some(e),
        _ => None,
    }
}

/// Against a baseline that misfits its calibration: the best candidate whose signature is
/// present and measured without the power model (`marked`), physically `signed`. Its evidence
/// stands without the baseline, and so is not asked to lower a held-out error measured against
/// it (a term beside a misfit can fit it worse out of sample as a run of new manoeuvres comes
/// in, though its mark stays); the misfit is reported beside it. No other candidate is named
/// against a misfit: a term that also acts on the calibration
/// manoeuvres can absorb a structural misfit without its own mark.
pub(super) fn standing_on_its_own(
    candidates: &[CandidateScore],
    marks: &Marks,
) -> Option<EffectId> {
    candidates
        .iter()
        .find(|c| {
            marks
                .get(c.effect)
                .is_some_and(|m| m.present && m.model_free)
                && marks.signed(c.effect)
        })
        .map(|c| c.effect)
}

/// The clear winner of `candidates` (sorted by `penalised_mse`): the best on the effective
/// power if it beats the runner-up by [`cv::CLEAR_MARGIN`]; else the best on effective power
/// and growth pooled if that beats its runner-up by the margin (the growth through the turn
/// separates terms of similar average shape, e.g. sinkage from angular slip); else the best on
/// effective and average power pooled by the same margin (terms that lengthen the turn against
/// terms that draw more power). Either way it must
/// close [`cv::MIN_SHRINK_PCT`] of the held-out gap.
pub(crate) fn select(candidates: &[CandidateScore]) -> Option<EffectId> {
    let shrink = |c: &CandidateScore| c.shrink_pct;
    clear_winner(candidates, |c| c.penalised_mse, shrink)
        .or_else(|| clear_winner(candidates, |c| c.penalised_mse_with_growth, shrink))
        .or_else(|| clear_winner(candidates, |c| c.penalised_mse_with_avg_power, shrink))
        .map(|c| c.effect)
}

/// Whether a penalised error `best` beats the runner-up's by [`cv::CLEAR_MARGIN`]; a lone
/// rival (no runner-up) has none to beat.
fn clear_of(best: f64, runner_up: Option<f64>) -> bool {
    runner_up.is_none_or(|r| r >= cv::CLEAR_MARGIN * best)
}

/// The best of `candidates` by `score` (a penalised error) when it closes
/// [`cv::MIN_SHRINK_PCT`] by `shrink` and the runner-up's `score` is at least
/// [`cv::CLEAR_MARGIN`] times its own.
fn clear_winner(
    candidates: &[CandidateScore],
    score: fn(&CandidateScore) -> f64,
    shrink: fn(&CandidateScore) -> f64,
) -> Option<&CandidateScore> {
    let mut sorted: Vec<&CandidateScore> = candidates.iter().collect();
    sorted.sort_by(|a, b| score(a).total_cmp(&score(b)));
    match sorted.as_slice() {
        [best, rest @ ..]
            if shrink(best) >= cv::MIN_SHRINK_PCT
                && clear_of(score(best), rest.first().map(|r| score(r))) =>
        {
            Some(best)
        }
        _ => None,
    }
}

/// The clear winner on each manoeuvre's total effective power (the sides summed: Eq 21's own
/// observation, which does not depend on how the power splits between the sides): it closes
/// [`cv::MIN_SHRINK_PCT`] of the held-out total and the runner-up's penalised error there is
/// at least [`cv::CLEAR_MARGIN`] times its own. Asked when the per-side targets leave a tie,
/// as when the chosen split misfits the test turns (a split error moves power from one side to
/// the other and hides the term's share of each). Only for terms that draw power: the two
/// that lengthen the turn (`angular-slip`, `slip-track`) share a signature the total does not
/// separate either.
pub(crate) fn clear_in_total(candidates: &[CandidateScore]) -> Option<EffectId> {
    clear_winner(
        candidates,
        |c| c.penalised_mse_total,
        |c| c.shrink_total_pct,
    )
    .map(|c| c.effect)
    .filter(|e| effects::is_power_type(*e))
}

/// What every held-out selection rule reads: the rover and rows, how the baseline is
/// calibrated, the cross-validation scheme and the held-out residuals without a term.
#[derive(Clone, Copy)]
pub(super) struct Selection<'a> {
    pub rover: &'a Rover,
    pub rows: &'a [TurnRow],
    pub scheme: Scheme,
    pub calibration: Calibration<'a>,
    pub before: &'a [crate::diagnose::observe::RowResidual],
}

impl Selection<'_> {
    /// The verdict stage. What the held-out selection chooses: the clear winner on the effective
    /// power, its growth or its average; else a near tie the direct observations decide (the
    /// one candidate in it with its signature); else the clear winner on the manoeuvres'
    /// totals; else where the gap is; else what explains a run-time trend. It is named only
    /// with its signature in the data, physically signed and reaching the gaps. Against a
    /// misfitting baseline only a signature measured without the power model stands
    /// ([`standing_on_its_own`]): the misfit is not absorbed.
    pub fn decide(&self, facts: Facts<'_>) -> Result<Decision, DiagnoseError> {
        let Facts { marks, .. } = facts;
        // The rivals: the candidates that could be named. One whose mark was looked for and is
        // not in the data is not, however well it fits (its term absorbs a misfit of another
        // shape); nor one whose mark another effect's present mark hides: what its term fits
        // is that effect's doing (the slips' and heating's on a slope). A mark the runs cannot
        // show yet, or show only short of the noise, keeps its candidate a rival.
        let rivals: Vec<CandidateScore> = facts
            .candidates
            .iter()
            .filter(|c| !marks.ruled_out(c.effect))
            .cloned()
            .collect();
        let candidates = &rivals[..];
        let marked = |e: EffectId| marks.present(e);
        let chosen = match select(candidates) {
            Some(e) => Some(e),
            None => match marked_in_near_tie(candidates, &marked) {
                Some(e) => Some(e),
                None => match clear_in_total(candidates) {
                    Some(e) => Some(e),
                    None if !facts.gap_regimes.is_empty() => {
                        self.where_the_gap_is(candidates, facts.gap_regimes)?
                    }
                    None => None,
                },
            },
        };
        let chosen = match (chosen, facts.trend) {
            (None, Some(trend)) if trend.significant => {
                self.what_explains_the_trend(candidates, trend.floor_w)?
            }
            (chosen, _) => chosen,
        };
        let selected = if facts.misfit {
            standing_on_its_own(candidates, marks)
        } else {
            // A mark measured without the power model stands on its own here as against a
            // misfit; one read off the residuals must also reach the gaps.
            chosen.filter(|&e| {
                marked(e) && marks.signed(e) && (marks.model_free(e) || (facts.reaches_the_gaps)(e))
            })
        };
        // The best fit of all when its mark is not in the data, else the choice among the
        // rivals when its mark is not.
        let unmarked = |e: EffectId| !marked(e) && !marks.hidden(e) && selected != Some(e);
        let best_unmarked = facts
            .candidates
            .first()
            .map(|c| c.effect)
            .filter(|&e| unmarked(e));
        Ok(Decision {
            selected,
            mark_missing: best_unmarked.or(chosen.filter(|&e| unmarked(e))),
        })
    }

    /// The clear winner on the rows where the gap is (the regimes of `gap_regimes`), for effects
    /// confined to a few regimes: over all rows their improvement is diluted by the baseline's
    /// mismatch elsewhere, which no catalogue term should explain. The best candidate by FPE over
    /// those rows' held-out residuals is named when it closes [`cv::MIN_SHRINK_PCT`] of their
    /// held-out RMS, the runner-up's FPE there is at least [`cv::CLEAR_MARGIN`] times its own, and
    /// over all rows it does no harm out of sample (held-out RMS after ≤ before).
    pub fn where_the_gap_is(
        &self,
        candidates: &[CandidateScore],
        gap_regimes: &[Regime],
    ) -> Result<Option<EffectId>, DiagnoseError> {
        let Selection { rows, before, .. } = *self;
        let in_gap = |i: usize| gap_regimes.contains(&rows[i].regime);
        let Some(ms_before) = cv::mean_square(before, in_gap) else {
            return Ok(None);
        };
        let Some(each) = self.heldout_with_each(candidates)? else {
            return Ok(None);
        };
        let mut scored: Vec<(f64, f64, &CandidateScore)> = Vec::new();
        for (c, after) in each {
            if !catalogue::of(c.effect).confined_to_regimes() {
                continue;
            }
            let gap_rows: Vec<crate::diagnose::observe::RowResidual> =
                after.into_iter().filter(|r| in_gap(r.row)).collect();
            let Some(ms_after) = cv::mean_square(&gap_rows, |_| true) else {
                return Ok(None);
            };
            let fpe = cv::penalised(
                ms_after,
                cv::observations(&gap_rows),
                effects::model_params(&[c.effect]),
            );
            scored.push((fpe, cv::shrink_pct(ms_before.sqrt(), ms_after.sqrt()), c));
        }
        scored.sort_by(|a, b| a.0.total_cmp(&b.0));
        Ok(match scored.as_slice() {
            [(best, shrink, c), rest @ ..]
                if *shrink >= cv::MIN_SHRINK_PCT
                    && clear_of(*best, rest.first().map(|r| r.0))
                    && c.heldout_error_after <= c.heldout_error_before =>
            {
                Some(c.effect)
            }
            _ => None,
        })
    }

    /// Each candidate with its held-out residuals under `scheme`; `None` when some cannot be held
    /// out.
    fn heldout_with_each<'c>(
        &self,
        candidates: &'c [CandidateScore],
    ) -> Result<Option<Vec<(&'c CandidateScore, crate::diagnose::observe::HeldOut)>>, DiagnoseError>
    {
        let Selection {
            rover,
            rows,
            scheme,
            calibration,
            ..
        } = *self;
        let mut each = Vec::with_capacity(candidates.len());
        for c in candidates {
            match cv::heldout_residuals(rover, rows, scheme, &[c.effect], calibration)? {
                Some(after) => each.push((c, after)),
                None => return Ok(None),
            }
        }
        Ok(Some(each))
    }

    /// The one candidate that explains a significant run-time trend (heating grows in every
    /// regime, so no regime's mean shows it and its all-row shrink is diluted by the repeat noise):
    /// the trend of the held-out residuals reaches `floor_w` without a term, stays under it with
    /// this candidate's term, and reaches it with every other candidate's; and the term does no
    /// harm out of sample (held-out RMS after ≤ before).
    pub fn what_explains_the_trend(
        &self,
        candidates: &[CandidateScore],
        floor_w: f64,
    ) -> Result<Option<EffectId>, DiagnoseError> {
        let Selection { rows, before, .. } = *self;
        let beyond = |res: &[crate::diagnose::observe::RowResidual]| {
            gaps::heldout_run_time_change_w(rows, res).is_none_or(|c| c.abs() >= floor_w)
        };
        if !beyond(before) {
            return Ok(None);
        }
        let Some(each) = self.heldout_with_each(candidates)? else {
            return Ok(None);
        };
        let explains: Vec<&CandidateScore> = each
            .into_iter()
            .filter(|(_, after)| !beyond(after))
            .map(|(c, _)| c)
            .collect();
        Ok(match explains.as_slice() {
            [c] if c.heldout_error_after <= c.heldout_error_before => Some(c.effect),
            _ => None,
        })
    }

    /// Forward stepwise selection after the named effect (`first_score`): adds, one at a time, the
    /// effect whose joint model has every term physically signed ([`physically_signed`]) and the
    /// lowest score while that score beats the current one by [`cv::CLEAR_MARGIN`] and the
    /// held-out RMS it removes is at least [`stats::PRACTICAL_FLOOR_W`].
    pub fn stepwise(
        &self,
        first_score: &CandidateScore,
        allowed: &dyn Fn(EffectId) -> bool,
    ) -> Result<Vec<StepwiseStep>, DiagnoseError> {
        let Selection {
            rover,
            rows,
            scheme,
            calibration,
            before,
        } = *self;
        let mut chosen = vec![first_score.effect];
        let mut current = first_score.penalised_mse;
        let mut steps = Vec::new();
        loop {
            let mut best: Option<CandidateScore> = None;
            for e in EffectId::ALL
                .into_iter()
                .filter(|e| !chosen.contains(e) && allowed(*e))
            {
                let mut model = chosen.clone();
                model.push(e);
                // A joint model that cannot be fitted on all rows is no step either.
                if !physically_signed(rover, rows, &model, calibration).unwrap_or(false) {
                    continue;
                }
                if let Some(c) = cv::score_model(rover, rows, scheme, calibration, before, &model)?
                {
                    if best.is_none_or(|b| c.penalised_mse < b.penalised_mse) {
                        best = Some(c);
                    }
                }
            }
            // The step must beat the current model clearly and explain a practically relevant
            // power: the RMS it removes, √(MSE_before − MSE_after), at least the practical floor.
            let rms_now = steps
                .last()
                .map_or(first_score.heldout_error_after, |s: &StepwiseStep| {
                    s.heldout_error_after
                });
            match best {
                Some(b)
                    if current >= cv::CLEAR_MARGIN * b.penalised_mse
                        && removed_rms_w(rms_now, b.heldout_error_after)
                            >= stats::PRACTICAL_FLOOR_W =>
                {
                    chosen.push(b.effect);
                    steps.push(StepwiseStep {
                        effect: b.effect,
                        heldout_error_after: b.heldout_error_after,
                        shrink_pct: b.shrink_pct,
                        penalised_mse: b.penalised_mse,
                        penalised_mse_before: current,
                    });
                    current = b.penalised_mse;
                }
                _ => return Ok(steps),
            }
        }
    }
}

#[cfg(test)]
mod tests;
