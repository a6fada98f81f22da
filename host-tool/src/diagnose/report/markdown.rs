//! The Markdown report (`diagnosis.md` in the `--out` directory).

use super::names::MODEL_FILE;
use super::tables::{
    added_effect, candidate_rows, gap_rows, markdown_table, not_testable_lines, regime_rows,
    signature_rows, METRIC,
};
use super::words::{baseline_line, calibration_line, conclusion, findings, next_runs_lines};
use crate::diagnose::{gaps, signature, Diagnosis};
use crate::plan::EnergyModel;
use std::fmt::Write as _;

/// The Markdown report; `figures` are (caption, file name relative to the report), `model` the
/// model file written beside it.
pub fn markdown(
    d: &Diagnosis,
    figures: &[(String, String)],
    model: Option<&EnergyModel>,
) -> String {
    let mut out = String::new();
    summary(&mut out, d);
    where_section(&mut out, d);
    which_section(&mut out, d);
    signatures_section(&mut out, d);
    shrink_section(&mut out, d);
    next_section(&mut out, d);
    figures_section(&mut out, figures);
    model_section(&mut out, model);
    out
}

/// The title, the conclusion, the JSON summary and the findings as a list.
fn summary(out: &mut String, d: &Diagnosis) {
    let _ = writeln!(out, "# Sim-to-real gap diagnosis\n");
    let conclusion = conclusion(d);
    let _ = writeln!(out, "**{}**\n", conclusion.headline);
    for detail in &conclusion.details {
        let _ = writeln!(out, "- {detail}");
    }
    if !conclusion.details.is_empty() {
        let _ = writeln!(out);
    }
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
}

/// "Where": the gaps per regime and side.
fn where_section(out: &mut String, d: &Diagnosis) {
    let _ = writeln!(out, "## Where: gaps per regime and side\n");
    let _ = writeln!(
        out,
        "Mean effective-power residual against the baseline, with its 95 % interval. `*`: \
         significant ({}). On straights, `inner` is the left side by convention.\n",
        gaps::SIGNIFICANCE_RULE
    );
    out.push_str(&markdown_table(&gap_rows(d)));
}

/// "Which": the candidates ranked.
fn which_section(out: &mut String, d: &Diagnosis) {
    let _ = writeln!(out, "\n## Which: candidate effects\n");
    let _ = writeln!(
        out,
        "Each candidate is fitted on the training folds only and scored on the withheld ones \
         ({}; the other scheme's shrink is the extrapolation check). Penalised: Akaike's final \
         prediction error of the held-out MSE.\n",
        d.scheme.id()
    );
    out.push_str(&markdown_table(&candidate_rows(d)));
}

/// The signatures, and the candidates left out of the ranking.
fn signatures_section(out: &mut String, d: &Diagnosis) {
    let _ = writeln!(out, "\n## Signatures: each effect's own mark in the data\n");
    let _ = writeln!(
        out,
        "An effect is named only when its signature is in the data and it wins out of sample; \
         against a baseline that misfits its calibration, only a signature measured without \
         the power model stands (standstill current, yaw, pitch, power within a turn or between \
         repeats). `present`: p below {} and the effect's size above its practical floor.\n",
        signature::ALPHA
    );
    out.push_str(&markdown_table(&signature_rows(d)));
    let untested = not_testable_lines(d);
    if !untested.is_empty() {
        let _ = writeln!(out, "\nLeft out of the ranking:\n");
        for line in untested {
            let _ = writeln!(out, "- {line}");
        }
    }
}

/// How far the added effect shrinks the held-out error, per regime.
fn shrink_section(out: &mut String, d: &Diagnosis) {
    if let Some(effect) = added_effect(d) {
        let _ = writeln!(
            out,
            "\n## How far it shrinks: held-out error per regime with `{effect}`\n"
        );
        out.push_str(&markdown_table(&regime_rows(d)));
    }
}

/// What to drive next.
fn next_section(out: &mut String, d: &Diagnosis) {
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
}

/// The figures, embedded with their captions.
fn figures_section(out: &mut String, figures: &[(String, String)]) {
    if !figures.is_empty() {
        let _ = writeln!(out, "\n## Figures\n");
        for (caption, file) in figures {
            let _ = writeln!(out, "![{caption}]({file})\n\n*{caption}*\n");
        }
    }
}

/// The model file written beside the report.
fn model_section(out: &mut String, model: Option<&EnergyModel>) {
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
}
