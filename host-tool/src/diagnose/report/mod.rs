//! The diagnosis' outputs: the terminal table ([`table`]), the JSON ([`write_json`]:
//! [`Diagnosis::to_json`], which carries the calibration note) and the `--out` directory
//! ([`write_out_dir`]: `diagnosis.md` with the figures embedded, the figures as PNG and SVG, and
//! `model.toml` for `plan --model`). Every file is written atomically.

use super::adequacy::{Adequacy, LackOfFit, Observation};
use super::baseline::{BaselineError, Split};
use super::calibration::{Calibration, CalibrationSource};
use super::cv::{self, PRACTICAL_FLOOR_W};
use super::features::TurnRow;
use super::model_file::{self, ModelFileError};
use super::{figures, named_effect, Diagnosis};
use crate::effect_id::EffectId;
use crate::log::{write_atomically, AtomicWriteError};
use crate::plan::{EnergyModel, ModelError};
use crate::plot::{render_figure, PlotError};
use model_core::Rover;
use std::fmt::Write as _;
use std::io::{self, Write as _};
use std::path::{Path, PathBuf};

/// The Markdown report's file name in the output directory.
pub const REPORT_FILE: &str = "diagnosis.md";
/// The model file's name in the output directory.
pub const MODEL_FILE: &str = "model.toml";
/// Figure of held-out residuals vs R/R′ (without extension).
pub const RESIDUALS_FIGURE: &str = "residuals-vs-radius";
/// Figure of growth through the turn vs R/R′ (without extension).
pub const GROWTH_FIGURE: &str = "growth-vs-radius";

/// Why an output was not written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Recomputing the held-out residuals for the figures failed.
    #[error(transparent)]
    Baseline(#[from] BaselineError),
    /// The scheme of the diagnosis has fewer than 2 groups (cannot happen for a diagnosis).
    #[error("no held-out residuals to draw")]
    NothingToHoldOut,
    /// A figure could not be drawn or written.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// The plan model could not be made.
    #[error("model file: {0}")]
    ModelFile(#[from] ModelFileError),
    /// The plan model could not be written as TOML.
    #[error("model file: {0}")]
    Model(#[from] ModelError),
    /// The output directory could not be created.
    #[error("{}: {source}", path.display())]
    Dir {
        /// The directory.
        path: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// A file could not be written (a previous file of that name is untouched).
    #[error(transparent)]
    Write(#[from] AtomicWriteError<io::Error>),
}

/// Columns aligned: the first left, the others right, two spaces apart.
fn columns(rows: &[Vec<String>]) -> String {
    let n = rows.iter().map(Vec::len).max().unwrap_or(0);
    let widths: Vec<usize> = (0..n)
        .map(|c| {
            rows.iter()
                .filter_map(|r| r.get(c))
                .map(|s| s.chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for row in rows {
        let cells: Vec<String> = row
            .iter()
            .zip(&widths)
            .enumerate()
            .map(|(c, (s, &w))| {
                if c == 0 {
                    format!("{s:<w$}")
                } else {
                    format!("{s:>w$}")
                }
            })
            .collect();
        out.push_str("  ");
        out.push_str(cells.join("  ").trim_end());
        out.push('\n');
    }
    out
}

/// A Markdown table (header row first).
fn markdown_table(rows: &[Vec<String>]) -> String {
    let mut out = String::new();
    for (k, row) in rows.iter().enumerate() {
        out.push_str("| ");
        out.push_str(&row.join(" | "));
        out.push_str(" |\n");
        if k == 0 {
            out.push('|');
            out.push_str(&"---|".repeat(row.len()));
            out.push('\n');
        }
    }
    out
}

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
    if let Some(h) = d.heldout.iter().find(|h| h.regime == super::Scope::Gap) {
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

/// The candidates some fold does not test, for the conclusion: their held-out figures would be
/// an extrapolation's, so they were not ranked, and not ruled out either.
fn untested(d: &Diagnosis) -> String {
    let untested: Vec<&str> = d.not_testable.iter().map(|c| c.effect.id()).collect();
    if untested.is_empty() {
        String::new()
    } else {
        format!(
            "; not testable out of sample, so not ruled out: {}",
            untested.join(", ")
        )
    }
}

/// The one-line conclusion.
pub fn conclusion(d: &Diagnosis) -> String {
    let all = d.heldout.iter().find(|h| h.regime == super::Scope::All);
    let heldout = |h: &super::HeldOutError| {
        format!(
            "held-out error {:.2} → {:.2} W ({:.0} % of the gap closed), {}",
            h.error_before,
            h.error_after,
            h.shrink_pct,
            d.scheme.id()
        )
    };
    if d.effect == super::Verdict::BaselineMisfit {
        let best = d.candidates.first().map_or(String::new(), |c| {
            format!(
                " (the best candidate, {}, would have closed {:.0} %; not named)",
                c.effect, c.shrink_pct
            )
        });
        format!(
            "diagnosis: baseline-misfit: the hard-ground model does not fit its own calibration \
             manoeuvres beyond their repeat noise ({}), and no effect's signature stands without \
             it, so none is named{best}",
            adequacy_summary(&d.adequacy)
        )
    } else if let Some(effect) = named_effect(d) {
        let h = all.map_or_else(|| d.scheme.id().to_owned(), heldout);
        let misfit = if d.adequacy.adequate == Some(false) {
            "; named beside a baseline that misfits its calibration (its signature needs no \
             power model; see adequacy)"
        } else {
            ""
        };
        format!(
            "diagnosis: {effect} @ {} (significant gap, its signature in the data); {h}{misfit}{}",
            d.regime,
            untested(d)
        )
    } else if d.effect == super::Verdict::Ambiguous {
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
        let hidden = if better.is_empty() {
            String::new()
        } else {
            format!("; fitting better but not weighed: {}", better.join(", "))
        };
        let untested = untested(d);
        format!(
            "diagnosis: ambiguous @ {} (significant gap, no clear cause): {}; naming one needs ≥ \
             {:.0} % closed and a {:.1}× margin in penalised held-out error over the runner-up\
             {hidden}{untested}",
            d.regime,
            best,
            cv::MIN_SHRINK_PCT,
            cv::CLEAR_MARGIN
        )
    } else if d
        .gaps
        .iter()
        .all(|g| !(g.ci_w.0.is_finite() && g.ci_w.1.is_finite()))
    {
        // No group has repeats: "none" means "not judged", not "the model fits".
        let best = d.candidates.first().map_or(String::new(), |c| {
            format!(
                "; held-out error of the model {:.2} W ({}), the best candidate {} closes {:.0} %",
                c.heldout_error_before,
                d.scheme.id(),
                c.effect,
                c.shrink_pct
            )
        });
        format!(
            "diagnosis: none: no gap can be called significant because nothing was repeated \
             (no second run, no radius driven twice) to measure the noise against{best}; \
             repeat the manoeuvres to get a verdict"
        )
    } else {
        format!(
            "diagnosis: none: no significant gap (no regime's residual, nor its trend over run \
             time, is beyond its noise and above the practical floor of {PRACTICAL_FLOOR_W} W or \
             5 % of the model power); the hard-ground model explains the runs"
        )
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

fn baseline_line(d: &Diagnosis) -> String {
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

fn gap_rows(d: &Diagnosis) -> Vec<Vec<String>> {
    let mut rows = vec![["regime", "side", "n", "mean [W]", "95 % CI [W]", "sig"]
        .map(String::from)
        .to_vec()];
    for g in &d.gaps {
        rows.push(vec![
            g.regime.id().to_owned(),
            g.side.id().to_owned(),
            g.n.to_string(),
            format!("{:+.2}", g.mean_w),
            format!("[{:+.2}, {:+.2}]", g.ci_w.0, g.ci_w.1),
            if g.significant { "*" } else { "" }.to_owned(),
        ]);
    }
    rows
}

/// The ranked candidates' table: the other scheme's shrink only when there is another scheme
/// (one run has no leave-one-run-out), `not testable` where that scheme's folds do not test one.
fn candidate_rows(d: &Diagnosis) -> Vec<Vec<String>> {
    let other = d.other_scheme.as_ref();
    let mut head = vec![
        "effect".to_owned(),
        "before [W]".to_owned(),
        "after [W]".to_owned(),
        "shrink".to_owned(),
        "penalised [W²]".to_owned(),
        "shrink of totals".to_owned(),
    ];
    head.extend(other.map(|(s, _)| format!("shrink {}", s.id())));
    head.push("signature".to_owned());
    head.push("sign".to_owned());
    head.push(String::new());
    let mut rows = vec![head];
    let named = named_effect(d);
    for c in &d.candidates {
        let mut row = vec![
            c.effect.id().to_owned(),
            format!("{:.2}", c.heldout_error_before),
            format!("{:.2}", c.heldout_error_after),
            format!("{:.0} %", c.shrink_pct),
            format!("{:.3}", c.penalised_mse),
            format!("{:.0} %", c.shrink_total_pct),
        ];
        row.extend(other.map(
            |(_, list)| match list.iter().find(|o| o.effect == c.effect) {
                Some(o) if o.not_testable.is_some() => "not testable".to_owned(),
                Some(o) => format!("{:.0} %", o.shrink_pct),
                None => "-".to_owned(),
            },
        ));
        row.push(match d.signature(c.effect).and_then(|s| s.test) {
            Some(t) => format!("{} (p {})", t.verdict(), super::signature::format_p(t.p)),
            None => "not observable".to_owned(),
        });
        row.push(
            match d.sign_check(c.effect) {
                Some(true) => "ok",
                Some(false) => "against physics",
                None => "-",
            }
            .to_owned(),
        );
        row.push(
            if Some(c.effect) == named {
                "<- named"
            } else {
                ""
            }
            .to_owned(),
        );
        rows.push(row);
    }
    rows
}

/// The signature table: per effect, its observation and its test.
fn signature_rows(d: &Diagnosis) -> Vec<Vec<String>> {
    let mut rows = vec![["effect", "signature", "test", "what was measured"]
        .map(String::from)
        .to_vec()];
    for s in &d.signatures {
        let model = if s.needs_power_model {
            " (on the model's residuals)"
        } else {
            ""
        };
        rows.push(vec![
            s.effect.id().to_owned(),
            format!("{}{model}", s.observation),
            s.outcome(),
            s.detail.clone(),
        ]);
    }
    rows
}

/// One line per candidate left out of the ranking: `effect: not testable out of sample: why`.
fn not_testable_lines(d: &Diagnosis) -> Vec<String> {
    d.not_testable
        .iter()
        .filter_map(|c| {
            let why = c.not_testable?;
            Some(format!(
                "{}: not testable out of sample: {}",
                c.effect,
                why.describe()
            ))
        })
        .collect()
}

fn regime_rows(d: &Diagnosis) -> Vec<Vec<String>> {
    let mut rows = vec![["regime", "before [W]", "after [W]", "shrink"]
        .map(String::from)
        .to_vec()];
    for h in &d.heldout {
        rows.push(vec![
            h.regime.label().to_owned(),
            format!("{:.2}", h.error_before),
            format!("{:.2}", h.error_after),
            format!("{:.0} %", h.shrink_pct),
        ]);
    }
    rows
}

/// The effect the per-regime table and the figures add (the named one, else the best).
fn added_effect(d: &Diagnosis) -> Option<crate::sim::world::EffectId> {
    d.heldout
        .first()
        .map(|h| h.effect)
        .or_else(|| d.candidates.first().map(|c| c.effect))
}

const METRIC: &str = "metric: RMS over held-out manoeuvres and both sides of the effective-power \
                      residual (energy / expected duration, measured − model) [W]";

/// The terminal table: conclusion, calibration and baseline, gaps per regime × side, the
/// candidates ranked, the held-out error per regime.
pub fn table(d: &Diagnosis) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "{}", conclusion(d));
    for line in findings(d) {
        let _ = writeln!(out, "  {line}");
    }
    let _ = writeln!(out, "{}", calibration_line(d));
    let _ = writeln!(out, "{}", baseline_line(d));
    if let Some(c) = &d.copper_from_runs {
        let _ = writeln!(out, "  {}", c.describe());
    }
    let _ = writeln!(out, "{METRIC}");
    let _ = writeln!(
        out,
        "\ngaps: mean residual per regime and side (* significant: {}; straights: inner = left \
         by convention)",
        super::gaps::SIGNIFICANCE_RULE
    );
    out.push_str(&columns(&gap_rows(d)));
    let _ = writeln!(
        out,
        "\ncandidates ({}, best first by penalised held-out error):",
        d.scheme.id()
    );
    out.push_str(&columns(&candidate_rows(d)));
    let untested = not_testable_lines(d);
    if !untested.is_empty() {
        let _ = writeln!(out, "left out of the ranking:");
        for line in untested {
            let _ = writeln!(out, "  {line}");
        }
    }
    let _ = writeln!(
        out,
        "\nsignatures (an effect is named only with its own in the data; against a misfitting \
         baseline only one measured without the power model; present: p < {} and the size \
         above its floor):",
        super::signature::ALPHA
    );
    for sig in &d.signatures {
        let _ = writeln!(out, "  {:<19} {}", sig.effect.id(), sig.describe());
    }
    if let Some(effect) = added_effect(d) {
        let _ = writeln!(out, "\nheld-out error per regime with {effect}:");
        out.push_str(&columns(&regime_rows(d)));
    }
    let _ = writeln!(out, "\nwhat to drive next:");
    for line in next_runs_lines(d) {
        let _ = writeln!(out, "  {line}");
    }
    out
}

/// What to drive next, as lines: the rivals in play, each suggested manoeuvre with what it
/// separates, the pairs no drivable manoeuvre separates, and what the runs cannot tell apart.
pub fn next_runs_lines(d: &Diagnosis) -> Vec<String> {
    let n = &d.next;
    let id = &n.identifiability;
    let mut out = Vec::new();
    if !n.open() {
        out.push(match d.effect {
            super::Verdict::None => "nothing: the runs show no significant departure".to_owned(),
            v @ (super::Verdict::Ambiguous | super::Verdict::BaselineMisfit) => format!(
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
            super::next_runs::TARGET_SIGMA
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
                super::next_runs::TARGET_SIGMA
            ));
        }
    }
    for s in &id.statements {
        out.push(format!("cannot tell apart: {s}"));
    }
    out
}

/// The Markdown report; `figures` are (caption, file name relative to the report), `model` the
/// model file written beside it.
pub fn markdown(
    d: &Diagnosis,
    figures: &[(String, String)],
    model: Option<&EnergyModel>,
) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "# Sim-to-real gap diagnosis\n");
    let _ = writeln!(out, "**{}**\n", conclusion(d));
    let _ = writeln!(
        out,
        "JSON summary: effect `{}`, regime `{}`, significant `{}`, scheme `{}`.\n",
        d.effect,
        d.regime,
        d.significant,
        d.scheme.id()
    );
    for line in findings(d) {
        let _ = writeln!(out, "- {line}");
    }
    let _ = writeln!(out, "- {}", calibration_line(d));
    let _ = writeln!(out, "- {}", baseline_line(d));
    if let Some(c) = &d.copper_from_runs {
        let _ = writeln!(out, "- {}", c.describe());
    }
    let _ = writeln!(out, "- {METRIC}\n");
    let _ = writeln!(out, "## Where: gaps per regime and side\n");
    let _ = writeln!(
        out,
        "Mean effective-power residual against the baseline, with its 95 % interval. `*`: \
         significant ({}). On straights, `inner` is the left side by convention.\n",
        super::gaps::SIGNIFICANCE_RULE
    );
    out.push_str(&markdown_table(&gap_rows(d)));
    let _ = writeln!(out, "\n## Which: candidate effects\n");
    let _ = writeln!(
        out,
        "Each candidate is fitted on the training folds only and scored on the withheld ones \
         ({}; the other scheme's shrink is the extrapolation check). Penalised: Akaike's final \
         prediction error of the held-out MSE.\n",
        d.scheme.id()
    );
    out.push_str(&markdown_table(&candidate_rows(d)));
    let _ = writeln!(out, "\n## Signatures: each effect's own mark in the data\n");
    let _ = writeln!(
        out,
        "An effect is named only when its signature is in the data and it wins out of sample; \
         against a baseline that misfits its calibration, only a signature measured without \
         the power model stands (standstill current, yaw, pitch, power within a turn or between \
         repeats). `present`: p below {} and the effect's size above its practical floor.\n",
        super::signature::ALPHA
    );
    out.push_str(&markdown_table(&signature_rows(d)));
    let untested = not_testable_lines(d);
    if !untested.is_empty() {
        let _ = writeln!(out, "\nLeft out of the ranking:\n");
        for line in untested {
            let _ = writeln!(out, "- {line}");
        }
    }
    if let Some(effect) = added_effect(d) {
        let _ = writeln!(
            out,
            "\n## How far it shrinks: held-out error per regime with `{effect}`\n"
        );
        out.push_str(&markdown_table(&regime_rows(d)));
    }
    let _ = writeln!(out, "\n## What to drive next\n");
    let _ = writeln!(
        out,
        "The manoeuvres that would separate the explanations still in play, chosen where their \
         fitted models differ most against the runs' repeat noise (model discrimination, Box \
         and Hill 1967). `diagnose --next-runs FILE.toml` writes them as a scenario.\n"
    );
    for line in next_runs_lines(d) {
        let _ = writeln!(out, "- {line}");
    }
    if !figures.is_empty() {
        let _ = writeln!(out, "\n## Figures\n");
        for (caption, file) in figures {
            let _ = writeln!(out, "![{caption}]({file})\n\n*{caption}*\n");
        }
    }
    if let Some(m) = model {
        let _ = writeln!(out, "## Model file for `plan --model`\n");
        let _ = writeln!(
            out,
            "`{MODEL_FILE}`: μ = {:.3}, G = {:.2} N, B_s = {:.2} m at v_c = {:.3} m/s{}.\n",
            m.base.mu,
            m.base.rolling_resistance_n,
            m.base.slip_track_m,
            m.v_c_mps,
            match m.effects.first() {
                Some(e) => format!(
                    ", plus `{}` tabulated at {} R/R′ breakpoints (the last one is the straight \
                     line)",
                    e.name,
                    e.r_over_r_prime.len()
                ),
                None => ", no effect term".to_owned(),
            }
        );
        let _ = writeln!(
            out,
            "The effect is extra *effective* power (energy over the commanded duration); `plan` \
             multiplies it by the commanded arc duration |Δθ| max(R, R′)/v_c, so time-type \
             effects (turning slower than commanded) are priced as the energy they cost. \
             Use: `host-tool plan --model {MODEL_FILE} --start-deg A --end-deg C --distance-m D`."
        );
    }
    out
}

/// Writes `d.to_json()` (pretty) to `path`.
pub fn write_json(path: &Path, d: &Diagnosis) -> Result<(), ReportError> {
    write_atomically(path, |w| {
        serde_json::to_writer_pretty(&mut *w, &d.to_json()).map_err(io::Error::from)?;
        writeln!(w)
    })?;
    Ok(())
}

/// Writes the figures, `model.toml` and `diagnosis.md` into `dir` (created if missing) and
/// returns the files written. `rows` and `calibration` must be the diagnosis' inputs.
pub fn write_out_dir(
    dir: &Path,
    rover: &Rover,
    d: &Diagnosis,
    rows: &[TurnRow],
    calibration: Calibration<'_>,
) -> Result<Vec<PathBuf>, ReportError> {
    let calibration = d.fitted_with(calibration);
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Dir {
        path: dir.to_owned(),
        source,
    })?;
    let mut files = Vec::new();
    let mut captions = Vec::new();
    let mut draw = |name: &str, caption: String, figure: &crate::plot::Figure| {
        for ext in ["png", "svg"] {
            let path = dir.join(format!("{name}.{ext}"));
            render_figure(figure, &path)?;
            files.push(path);
        }
        captions.push((caption, format!("{name}.png")));
        Ok::<(), ReportError>(())
    };
    if let Some(effect) = added_effect(d) {
        // "After" is the diagnosed model: the named effect and its stepwise secondaries (or the
        // best candidate when none is named).
        let mut effects = d.model_effects();
        if effects.is_empty() {
            effects.push(effect);
        }
        let label = effects
            .iter()
            .map(|e| e.id())
            .collect::<Vec<_>>()
            .join(" + ");
        // The figure names the baseline the residuals are against.
        let baseline = if d.baseline.structure.copper_loss {
            "hard-ground model + copper loss"
        } else {
            "hard-ground model"
        };
        let before = cv::heldout_residuals(rover, rows, d.scheme, &[], calibration)?
            .ok_or(ReportError::NothingToHoldOut)?;
        let after = cv::heldout_residuals(rover, rows, d.scheme, &effects, calibration)?
            .ok_or(ReportError::NothingToHoldOut)?;
        draw(
            RESIDUALS_FIGURE,
            format!(
                "Held-out residual of every turn vs R/R′ ({}), before and after adding {label}; \
                 bars: each regime's mean gap with its 95 % interval",
                d.scheme.id()
            ),
            &figures::residuals_vs_radius(rover, rows, &before, &after, baseline, &label, &d.gaps),
        )?;
    }
    draw(
        GROWTH_FIGURE,
        "Power growth through each turn (second half − first half) vs R/R′; bars: each regime's \
         mean with its 95 % interval"
            .to_owned(),
        &figures::growth_vs_radius(rover, rows, &d.where_.phase_by_regime_side),
    )?;
    // A fitted base the planner cannot use (e.g. G < 0 when the plain split misfits a rover
    // with large motor losses) costs the model file, not the report.
    let (model, no_model) = match model_file::energy_model(rover, d, rows, calibration) {
        Ok(model) => (Some(model), None),
        Err(e) => (None, Some(e)),
    };
    if let Some(model) = &model {
        let text = model.to_toml()?;
        let path = dir.join(MODEL_FILE);
        write_atomically(&path, |w| w.write_all(text.as_bytes()))?;
        files.push(path);
    }
    let path = dir.join(REPORT_FILE);
    let mut md = markdown(d, &captions, model.as_ref());
    if let Some(e) = no_model {
        let _ = writeln!(
            md,
            "## Model file for `plan --model`\n\nNot written: the diagnosed model is not a valid \
             plan model ({e})."
        );
    }
    write_atomically(&path, |w| w.write_all(md.as_bytes()))?;
    files.push(path);
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::diagnose;
    use crate::diagnose::tests::{rows_of, simulate_run};
    use crate::effect_id::EffectId;
    use crate::sim::world::{Scenario, WorldConfig};

    fn diagnosis_of(world: &WorldConfig) -> (Diagnosis, Vec<TurnRow>) {
        let runs: Vec<_> = (0..2)
            .map(|k| simulate_run(world, &Scenario::seed_turns(0.3, 1), 30 + k))
            .collect();
        let rows = rows_of(&runs);
        (
            diagnose(&Rover::HUSKY_A200, &rows).expect("diagnoses"),
            rows,
        )
    }

    #[test]
    fn table_states_the_conclusion_the_calibration_and_every_candidate() {
        let (d, _) = diagnosis_of(&WorldConfig::hard_ground().with_effect(EffectId::Slope, true));
        assert_eq!(d.effect, "slope");
        let t = table(&d);
        let first = t.lines().next().expect("conclusion");
        assert!(first.starts_with("diagnosis: slope @ "), "{t}");
        assert!(first.contains("leave-one-run-out"), "{t}");
        assert!(t.contains("taken from the runs themselves"), "{t}");
        for effect in EffectId::ALL {
            assert!(t.contains(effect.id()), "{effect}: {t}");
        }
        assert_eq!(t.matches("<- named").count(), 1, "{t}");

        let mut ambiguous = d.clone();
        ambiguous.effect = super::super::Verdict::Ambiguous;
        let c = conclusion(&ambiguous);
        // The two best rivals (a mark present or still to be seen); the better fits whose
        // marks are missing are listed apart.
        let missing = |e: EffectId| d.signature(e).is_some_and(|s| s.rules_out());
        let (weighed, apart) = c.split_once("not weighed").unwrap_or((&c, ""));
        assert!(weighed.contains("no clear cause"), "{c}");
        let rivals: Vec<_> = d
            .candidates
            .iter()
            .filter(|c| !missing(c.effect))
            .take(2)
            .collect();
        assert!(!rivals.is_empty(), "{c}");
        for rival in rivals {
            assert!(weighed.contains(&format!("{} closes", rival.effect)), "{c}");
        }
        for better in d.candidates.iter().take_while(|c| missing(c.effect)) {
            assert!(apart.contains(&better.effect.to_string()), "{c}");
        }
        assert!(!table(&ambiguous).contains("<- named"));
    }

    #[test]
    fn control_report_says_there_is_no_gap_and_writes_a_base_only_model() {
        let (d, rows) = diagnosis_of(&WorldConfig::hard_ground());
        assert!(table(&d).starts_with("diagnosis: none: no significant gap"));
        let dir = std::env::temp_dir().join(format!("diagnose-report-{}", std::process::id()));
        let files = write_out_dir(&dir, &Rover::HUSKY_A200, &d, &rows, Calibration::FROM_RUNS)
            .expect("writes");
        for name in [
            "residuals-vs-radius.png",
            "residuals-vs-radius.svg",
            "growth-vs-radius.png",
            "growth-vs-radius.svg",
            MODEL_FILE,
            REPORT_FILE,
        ] {
            assert!(files.contains(&dir.join(name)), "{name}: {files:?}");
        }
        let model = crate::plan::load_model(&dir.join(MODEL_FILE)).expect("loads");
        assert!(model.effects.is_empty());
        let md = std::fs::read_to_string(dir.join(REPORT_FILE)).expect("report");
        assert!(md.contains("no effect term"), "{md}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
