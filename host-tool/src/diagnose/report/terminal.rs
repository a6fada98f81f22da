//! The terminal table (`diagnose` without `--json`).

use super::tables::{
    added_effect, candidate_rows, columns, gap_rows, not_testable_lines, regime_rows, METRIC,
};
use super::words::{baseline_line, calibration_line, conclusion, findings, next_runs_lines};
use crate::diagnose::{gaps, signature, Diagnosis};
use crate::wrap::folded;
use std::fmt::Write as _;

/// The terminal table: conclusion, calibration and baseline, gaps per regime × side, the
/// candidates ranked, the held-out error per regime.
pub fn table(d: &Diagnosis) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "{}", conclusion(d));
    for line in findings(d) {
        let _ = writeln!(out, "{}", folded(&format!("  {line}")));
    }
    let _ = writeln!(out, "{}", folded(&calibration_line(d)));
    let _ = writeln!(out, "{}", folded(&baseline_line(d)));
    if let Some(c) = &d.copper_from_runs {
        let _ = writeln!(out, "{}", folded(&format!("  {}", c.describe())));
    }
    let _ = writeln!(out, "{METRIC}");
    let _ = writeln!(
        out,
        "\ngaps: mean residual per regime and side (* significant: {}; straights: inner = left \
         by convention)",
        gaps::SIGNIFICANCE_RULE
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
            let _ = writeln!(out, "{}", folded(&format!("  {line}")));
        }
    }
    let heading = format!(
        "signatures (an effect is named only with its own in the data; against a misfitting \
         baseline only one measured without the power model; present: p < {} and the size \
         above its floor):",
        signature::ALPHA
    );
    let _ = writeln!(out, "\n{}", folded(&heading));
    for sig in &d.signatures {
        let line = format!("  {:<19} {}", sig.effect.id(), sig.describe());
        let _ = writeln!(out, "{}", folded(&line));
    }
    if let Some(effect) = added_effect(d) {
        let _ = writeln!(out, "\nheld-out error per regime with {effect}:");
        out.push_str(&columns(&regime_rows(d)));
    }
    let _ = writeln!(out, "\nwhat to drive next:");
    for line in next_runs_lines(d) {
        let _ = writeln!(out, "{}", folded(&format!("  {line}")));
    }
    out
}
