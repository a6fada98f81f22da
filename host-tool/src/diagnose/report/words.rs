//! The diagnosis in words: the one-line conclusion, the findings that back it, the baseline's
//! adequacy and calibration, and what to drive next. The terminal table and the Markdown report
//! both print these lines.

use crate::diagnose::adequacy::{Adequacy, LackOfFit, Observation};
use crate::diagnose::baseline::Split;
use crate::diagnose::calibration::CalibrationSource;
use crate::diagnose::cv;
use crate::diagnose::stats::PRACTICAL_FLOOR_W;
use crate::diagnose::{named_effect, next_runs, Diagnosis, Scope, Verdict};
use crate::effect_id::EffectId;

/// What backs the conclusion, one line each: the shrink where the gap is, the stepwise
/// secondary effects, where the model departs (the "where" analysis) and the data's caveats.
pub fn findings(d: &Diagnosis) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(s) = named_effect(d).and_then(|e| d.signature(e)) {
        out.push(format!("signature of {}: {}", s.effect, s.describe()));
    }
    if let Some(s) = d.mark_missing.and_then(|e| d.signature(e)) {
        out.push(format!(
            "{} fitted best out of sample but its signature is missing ({}): {}; not named",
            s.effect,
            s.observation,
            s.describe()
        ));
    }
    if let Some(h) = d.heldout.iter().find(|h| h.regime == Scope::Gap) {
        let regimes: Vec<&str> = d.gap_regimes.iter().map(|r| r.id()).collect();
        out.push(format!(
            "where the gap is ({}): held-out error {:.2} → {:.2} W with {} ({:.0} % closed)",
            regimes.join(", "),
            h.error_before,
            h.error_after,
            h.effect,
            h.shrink_pct
        ));
    }
    for s in &d.secondary {
        out.push(format!(
            "also: + {} → held-out error {:.2} W ({:.0} % of the baseline's closed; penalised \
             {:.3} → {:.3} W²)",
            s.effect, s.heldout_error_after, s.shrink_pct, s.penalised_mse_before, s.penalised_mse
        ));
    }
    out.push(format!("adequacy: {}", adequacy_summary(&d.adequacy)));
    for g in misfit_groups(&d.adequacy) {
        out.push(format!("  misfit: {g}"));
    }
    out.extend(
        d.adequacy
            .suggestions
            .iter()
            .map(|s| format!("  suggests: {s}")),
    );
    if let Some(with) = &d.adequacy_with_effect {
        out.push(format!(
            "adequacy with {}: {}",
            d.effect,
            adequacy_summary(with)
        ));
    }
    out.push(format!("where: {}", d.where_.statement));
    const SHOWN: usize = 6;
    out.extend(
        d.where_
            .findings
            .iter()
            .take(SHOWN)
            .map(|f| format!("  {f}")),
    );
    if d.where_.findings.len() > SHOWN {
        out.push(format!(
            "  … {} more significant groups in the JSON (`where`)",
            d.where_.findings.len() - SHOWN
        ));
    }
    out.extend(d.where_.notes.iter().map(|n| format!("note: {n}")));
    out.extend(d.notes.iter().map(|n| format!("note: {n}")));
    out
}

/// The verdict in words: a headline a user can act on, then the details behind it, one per
/// line. The terminal, the demo and the Markdown report print both.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Conclusion {
    /// `diagnosis: VERDICT @ REGIME: …`, one sentence.
    pub headline: String,
    /// The figures, cautions and rules behind the headline.
    pub details: Vec<String>,
}

impl std::fmt::Display for Conclusion {
    /// The headline, then each detail indented and wrapped to a terminal's width.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&crate::wrap::wrapped(&self.headline, "", "    "))?;
        for detail in &self.details {
            write!(f, "\n{}", crate::wrap::folded(&format!("  {detail}")))?;
        }
        Ok(())
    }
}

/// The candidates some fold does not test: their held-out figures would be an extrapolation's,
/// so they were not ranked, and not ruled out either.
fn untested(d: &Diagnosis) -> Option<String> {
    let untested: Vec<&str> = d.not_testable.iter().map(|c| c.effect.id()).collect();
    (!untested.is_empty()).then(|| {
        format!(
            "not testable out of sample, so not ruled out: {}",
            untested.join(", ")
        )
    })
}

/// The verdict's headline and details.
pub fn conclusion(d: &Diagnosis) -> Conclusion {
    if d.effect == Verdict::BaselineMisfit {
        misfit_conclusion(d)
    } else if let Some(effect) = named_effect(d) {
        named_conclusion(d, effect)
    } else if d.effect == Verdict::Ambiguous {
        ambiguous_conclusion(d)
    } else if d.effect == Verdict::OutsideCatalogue {
        outside_conclusion(d)
    } else if d
        .gaps
        .iter()
        .all(|g| !(g.ci_w.0.is_finite() && g.ci_w.1.is_finite()))
    {
        unrepeated_conclusion(d)
    } else {
        no_gap_conclusion()
    }
}

/// `baseline-misfit`: the baseline misfits its calibration and no mark stands without it.
fn misfit_conclusion(d: &Diagnosis) -> Conclusion {
    let mut details = vec![
        "no effect's mark stands without the power model; the adequacy test says which \
         calibration manoeuvres misfit"
            .to_owned(),
    ];
    details.extend(d.candidates.first().map(|c| {
        format!(
            "the best candidate, {}, would have closed {:.0} % of the held-out gap; not named",
            c.effect, c.shrink_pct
        )
    }));
    Conclusion {
        headline: "diagnosis: baseline-misfit: the hard-ground model does not fit its own \
                   calibration manoeuvres, so no effect is named"
            .to_owned(),
        details,
    }
}

/// A named effect, with its held-out shrink over all manoeuvres.
fn named_conclusion(d: &Diagnosis, effect: EffectId) -> Conclusion {
    let all = d.heldout.iter().find(|h| h.regime == Scope::All);
    let headline = match all {
        Some(h) => format!(
            "diagnosis: {effect} @ {}: adding it closes {:.0} % of the held-out gap \
             ({:.2} → {:.2} W)",
            d.regime, h.shrink_pct, h.error_before, h.error_after
        ),
        None => format!("diagnosis: {effect} @ {}", d.regime),
    };
    let mut details = vec![format!(
        "why: a significant gap, with {effect}'s own mark in the data; held out {}",
        d.scheme.id()
    )];
    if d.adequacy.adequate == Some(false) {
        details.push(format!(
            "caution: the hard-ground model misfits its own calibration manoeuvres; the name \
             rests on {effect}'s mark, which is measured without the power model (see adequacy)"
        ));
    }
    details.extend(
        all.and_then(|h| crate::diagnose::reliability::of(effect, h.shrink_pct))
            .map(|r| format!("confidence: {}", r.describe(effect))),
    );
    details.extend(untested(d));
    Conclusion { headline, details }
}

/// `outside-catalogue`: the departure's shape (where, which side, which way, how large, and
/// whether it grows over run time), what ruled each catalogued candidate out, and where to
/// look.
fn outside_conclusion(d: &Diagnosis) -> Conclusion {
    let ruled_out: Vec<String> = d
        .candidates
        .iter()
        .filter(|c| c.shrink_pct > 0.0)
        .filter_map(|c| {
            let s = d.signature(c.effect)?;
            Some(match s.hidden_by {
                Some(by) => format!("{} ({by} hides its mark)", c.effect),
                None if s.masked => format!("{} (its mark cannot be observed here)", c.effect),
                None => format!("{} (its mark is missing)", c.effect),
            })
        })
        .take(3)
        .collect();
    let mut details = vec![format!("shape: {}", departure_shape(d))];
    if !ruled_out.is_empty() {
        details.push(format!(
            "the catalogue's best fits lack their own marks: {}",
            ruled_out.join(", ")
        ));
    }
    details.push(
        "look beyond the catalogue: the model's power split between the sides, the battery \
         under load, the drivers' efficiency, the tyres' radii, the gearboxes, the load on the \
         wheels"
            .to_owned(),
    );
    Conclusion {
        headline: format!(
            "diagnosis: outside-catalogue @ {}: a significant departure that no catalogued \
             effect explains",
            d.regime
        ),
        details,
    }
}

/// The significant gaps in words: which way, at which regimes and sides, their size, and a
/// trend over run time.
fn departure_shape(d: &Diagnosis) -> String {
    let significant: Vec<_> = d.gaps.iter().filter(|g| g.significant).collect();
    let mut parts = Vec::new();
    for (more, way) in [(true, "more"), (false, "less")] {
        let these: Vec<_> = significant
            .iter()
            .filter(|g| (g.mean_w > 0.0) == more)
            .collect();
        if these.is_empty() {
            continue;
        }
        let mut sides: Vec<&str> = these.iter().map(|g| g.side.id()).collect();
        sides.sort_unstable();
        sides.dedup();
        let mut regimes: Vec<&str> = these.iter().map(|g| g.regime.id()).collect();
        regimes.dedup();
        let (lo, hi) = these.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), g| {
            (lo.min(g.mean_w.abs()), hi.max(g.mean_w.abs()))
        });
        parts.push(format!(
            "{way} than the model on the {} side(s) at {} ({lo:.1}–{hi:.1} W)",
            sides.join(" and "),
            regimes.join(", ")
        ));
    }
    let mut shape = if parts.is_empty() {
        "the held-out error, not one group's mean, departs".to_owned()
    } else {
        format!("the runs draw {}", parts.join("; and "))
    };
    if d.where_.departs_over_run_time() {
        shape.push_str("; and the departure changes over run time");
    }
    shape
}

/// `ambiguous`: the rivals weighed, and the better fits that could not be named.
fn ambiguous_conclusion(d: &Diagnosis) -> Conclusion {
    // The rivals the verdict weighed, and the better fits it did not: a candidate whose
    // mark is missing, or hidden by another effect's present mark, could not be named.
    let weighed = |e: EffectId| !d.signature(e).is_some_and(|s| s.rules_out());
    let best: Vec<String> = d
        .candidates
        .iter()
        .filter(|c| weighed(c.effect))
        .take(2)
        .map(|c| format!("{} closes {:.0} %", c.effect, c.shrink_pct))
        .collect();
    let best = if best.is_empty() {
        "no candidate has its mark in the data or still to be seen".to_owned()
    } else {
        best.join(", ")
    };
    let mut details = vec![
        format!("rivals: {best}"),
        format!(
            "naming one needs ≥ {:.0} % closed and a {:.1}× margin in penalised held-out error \
             over the runner-up",
            cv::MIN_SHRINK_PCT,
            cv::CLEAR_MARGIN
        ),
    ];
    let better: Vec<String> = d
        .candidates
        .iter()
        .take_while(|c| !weighed(c.effect))
        .filter_map(|c| {
            let s = d.signature(c.effect)?;
            Some(match s.hidden_by {
                Some(by) => format!("{} ({by} hides its mark)", c.effect),
                None => format!("{} (its mark is missing)", c.effect),
            })
        })
        .collect();
    if !better.is_empty() {
        details.push(format!(
            "fitting better but not weighed: {}",
            better.join(", ")
        ));
    }
    details.extend(untested(d));
    Conclusion {
        headline: format!(
            "diagnosis: ambiguous @ {}: a significant gap, but no one cause stands out; see what \
             to drive next",
            d.regime
        ),
        details,
    }
}

/// `none` because nothing was repeated: not judged.
fn unrepeated_conclusion(d: &Diagnosis) -> Conclusion {
    // No group has repeats: "none" means "not judged", not "the model fits".
    let mut details = vec![
        "no gap can be called significant without a second run or a radius \
                            driven twice to measure the noise against"
            .to_owned(),
    ];
    details.extend(d.candidates.first().map(|c| {
        format!(
            "held-out error of the model {:.2} W ({}); the best candidate, {}, closes {:.0} %",
            c.heldout_error_before,
            d.scheme.id(),
            c.effect,
            c.shrink_pct
        )
    }));
    Conclusion {
        headline: "diagnosis: none: not judged, as nothing was repeated; repeat the manoeuvres \
                   for a verdict"
            .to_owned(),
        details,
    }
}

/// `none`: no significant gap.
fn no_gap_conclusion() -> Conclusion {
    Conclusion {
        headline: "diagnosis: none: no significant gap; the hard-ground model explains the runs"
            .to_owned(),
        details: vec![format!(
            "no regime's residual, nor its trend over run time, is beyond its noise and above \
             the practical floor of {PRACTICAL_FLOOR_W} W or 5 % of the model power"
        )],
    }
}

/// One lack-of-fit test in words: F, df, p, repeat σ and the RMS misfit.
fn lack_of_fit_line(t: &LackOfFit) -> String {
    let what = match t.observation {
        Observation::Total => "total",
        Observation::PerSide => "per side",
    };
    match (t.f, t.p_value) {
        (Some(f), Some(p)) => format!(
            "{what}: lack of fit {:.1} W RMS against repeat σ {:.2} W, F({}, {}) = {:.1}, p = {:.2e} \
             ({})",
            t.lack_of_fit_rms_w,
            t.repeat_sigma_w,
            t.df_lack_of_fit,
            t.df_pure_error,
            f,
            p,
            match t.adequate() {
                Some(false) => "misfit",
                _ => "fits",
            }
        ),
        _ => format!(
            "{what}: not testable ({} manoeuvres, {} observations: {})",
            t.groups,
            t.n,
            if t.df_pure_error == 0 {
                "no repeats"
            } else {
                "no more manoeuvres than model parameters"
            }
        ),
    }
}

/// The adequacy of the baseline on its calibration manoeuvres, in one line.
pub fn adequacy_summary(a: &Adequacy) -> String {
    let verdict = match a.adequate {
        Some(true) => "the baseline fits its calibration manoeuvres",
        Some(false) => "the baseline MISFITS its calibration manoeuvres",
        None => {
            "adequacy could not be tested (calibration manoeuvres not repeated, or no more of \
             them than model parameters)"
        }
    };
    let mut parts = vec![lack_of_fit_line(&a.total)];
    parts.extend(a.per_side.as_ref().map(lack_of_fit_line));
    format!("{verdict}; {}", parts.join("; "))
}

/// The calibration manoeuvres (and sides) beyond the practical floor of a misfitting test.
fn misfit_groups(a: &Adequacy) -> Vec<String> {
    if a.adequate != Some(false) {
        return Vec::new();
    }
    [Some(&a.total), a.per_side.as_ref()]
        .into_iter()
        .flatten()
        .filter(|t| t.adequate() == Some(false))
        .flat_map(|t| {
            t.groups_fit
                .iter()
                .filter(|g| g.beyond_floor())
                .map(move |g| {
                    format!(
                        "{} {}: measured {:.1} W, model {:.1} W ({:+.1} W; repeat σ {:.2} W, n {})",
                        g.manoeuvre,
                        g.side.map_or("total", |s| s.id()),
                        g.mean_measured_w,
                        g.model_w,
                        g.mean_residual_w,
                        t.repeat_sigma_w,
                        g.n
                    )
                })
        })
        .collect()
}

/// Where the baseline came from, in words.
pub fn calibration_line(d: &Diagnosis) -> String {
    let c = &d.calibration;
    match c.source {
        CalibrationSource::Runs => format!(
            "calibration: {} manoeuvres taken from the runs themselves (straights, point turns, \
             R ≥ 2R′; no --calibration runs given), refitted in every cross-validation fold",
            c.manoeuvres
        ),
        CalibrationSource::CalibrationFiles => format!(
            "calibration: {} manoeuvres from the --calibration runs (straights, point turns, \
             R ≥ 2R′), not scored",
            c.manoeuvres
        ),
    }
}

pub(super) fn baseline_line(d: &Diagnosis) -> String {
    let b = &d.baseline;
    let split = match b.structure.split {
        Split::Regenerating => "tread couple with regeneration".to_string(),
        Split::Returning { fraction } if fraction <= 0.0 => {
            "no regeneration (negative side power put to 0)".to_string()
        }
        Split::Returning { fraction } => {
            format!("{:.0} % of generated power returned", 100.0 * fraction)
        }
    };
    // Copper loss enters only when the copper-free members misfit the calibration, or when the
    // diagnosed runs show it (`copper_from_runs`): say which.
    let why_copper = if d.copper_from_runs.is_some() {
        "the diagnosed runs show it; see below"
    } else {
        "the copper-free members misfit the calibration"
    };
    let split = if b.structure.copper_loss {
        format!(
            "{split}, plus copper loss c·F² with c = {:.3e} W/N² ({why_copper})",
            b.copper_w_per_n2
        )
    } else {
        split
    };
    let chosen = match b.cv_rmse_w {
        Some(cv) => format!("chosen by leave-one-run-out CV, RMS {cv:.2} W"),
        None => "plain (fewer than 2 calibration runs to choose by CV)".to_string(),
    };
    // The family's members are what the misfit suggestions name: say that the largest was
    // tried, so the suggestions are read as the structure still missing.
    let chosen = match &b.copper_refused {
        Some(r) => format!(
            "{chosen}; copper loss was tried on top of the copper-free members: the best with \
             it ({}) still misfits by {:.1} W RMS, so it is not taken",
            r.structure.label(),
            r.lack_of_fit_rms_w
        ),
        None => chosen,
    };
    // A constant yaw-rate loss is what a terrain slip track wider than the controller's gives
    // (ω = ΔV/B_s, Appendix D): say both readings, since yaw and power cannot tell them apart.
    let slip = if b.turn_slip > 0.0 {
        format!(
            "; calibration turns' constant slip {:.1} % taken as the terrain's, i.e. a terrain \
             slip track of {:.2} m against the controller's {:.2} m (Appendix D; `slip-track` and \
             a constant angular slip look alike in yaw and power)",
            100.0 * b.turn_slip,
            b.slip_track_m / (1.0 - b.turn_slip),
            b.slip_track_m
        )
    } else {
        String::new()
    };
    format!(
        "baseline (paper Eq 21 per side; {split}, {chosen}{slip}): a = F/B_s = {:.1} ± {:.1} N, \
         G = {:.2} ± {:.2} N, μ = {:.3} (Eq 22, B_s = {:.2} m), residual σ = {:.2} W per side \
         over {} sides",
        b.skid_force_n,
        b.skid_force_ci_n,
        b.rolling_resistance_n,
        b.rolling_resistance_ci_n,
        b.mu,
        b.slip_track_m,
        b.residual_std_w,
        b.n
    )
}

/// What to drive next, as lines: the rivals in play, each suggested manoeuvre with what it
/// separates, the pairs no drivable manoeuvre separates, and what the runs cannot tell apart.
pub fn next_runs_lines(d: &Diagnosis) -> Vec<String> {
    let n = &d.next;
    let id = &n.identifiability;
    let mut out = Vec::new();
    if !n.open() {
        out.push(match d.effect {
            Verdict::None => "nothing: the runs show no significant departure".to_owned(),
            Verdict::OutsideCatalogue => "nothing more of the same: the departure is outside the \
                catalogue (each catalogued candidate's own mark was looked for and is missing, \
                hidden or unobservable); measure what the catalogue does not hold"
                .to_owned(),
            v @ (Verdict::Ambiguous | Verdict::BaselineMisfit) => format!(
                "nothing: no further run could settle `{v}` (no candidate could be named: each \
                 one's own mark was looked for and is missing, or another effect's mark hides \
                 it); the departure is one the catalogue does not explain"
            ),
            v => format!(
                "nothing: the verdict `{v}` is settled (no rival within the selection's margin \
                 could be named in its place: each lacks its own mark, its mark needs the power \
                 model beside a misfitting baseline, or the runs already separate it)"
            ),
        });
    } else {
        out.push(format!(
            "in play: {} (separations in σ = {:.2} W per side: {}; {}σ settles a pair)",
            n.in_play
                .iter()
                .map(|r| r.label())
                .collect::<Vec<_>>()
                .join(", "),
            id.noise_sigma_w,
            id.noise_from,
            next_runs::TARGET_SIGMA
        ));
        for r in &n.runs {
            out.push(format!("drive {}", r.describe()));
        }
        if !n.unresolved.is_empty() {
            let pairs: Vec<String> = n
                .unresolved
                .iter()
                .map(|p| {
                    format!(
                        "{} / {} ({:.1}σ)",
                        p.rivals[0].label(),
                        p.rivals[1].label(),
                        p.sigma
                    )
                })
                .collect();
            out.push(format!(
                "{} separates: {}",
                if n.runs.is_empty() {
                    "no manoeuvre within the rover's limits (≤ 10 drives)"
                } else {
                    "nothing more within the limits"
                },
                pairs.join(", ")
            ));
        } else if n.runs.is_empty() {
            out.push(format!(
                "the runs already separate every pair in play by ≥ {}σ: the verdict is open \
                 because none of them has its mark or fits clearly better, which more of \
                 these manoeuvres would not change",
                next_runs::TARGET_SIGMA
            ));
        }
    }
    for m in &n.measurements {
        out.push(format!(
            "measure: {} (reads `{}`'s mark directly)",
            m.what, m.effect
        ));
    }
    for s in &id.statements {
        out.push(format!("cannot tell apart: {s}"));
    }
    out
}
