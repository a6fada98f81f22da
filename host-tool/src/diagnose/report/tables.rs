//! The tables the terminal table and the Markdown report share: the gaps per regime and side,
//! the ranked candidates, the signatures and the held-out error per regime, as rows, and the two
//! layouts they are printed in ([`columns`], [`markdown_table`]).

use crate::diagnose::{named_effect, signature, Diagnosis};

/// Columns aligned: the first left, the others right, two spaces apart.
pub(super) fn columns(rows: &[Vec<String>]) -> String {
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
pub(super) fn markdown_table(rows: &[Vec<String>]) -> String {
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

pub(super) fn gap_rows(d: &Diagnosis) -> Vec<Vec<String>> {
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
pub(super) fn candidate_rows(d: &Diagnosis) -> Vec<Vec<String>> {
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
            Some(t) => format!("{} (p {})", t.verdict(), signature::format_p(t.p)),
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
pub(super) fn signature_rows(d: &Diagnosis) -> Vec<Vec<String>> {
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
pub(super) fn not_testable_lines(d: &Diagnosis) -> Vec<String> {
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

pub(super) fn regime_rows(d: &Diagnosis) -> Vec<Vec<String>> {
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
pub(super) fn added_effect(d: &Diagnosis) -> Option<crate::effect_id::EffectId> {
    d.heldout
        .first()
        .map(|h| h.effect)
        .or_else(|| d.candidates.first().map(|c| c.effect))
}

pub(super) const METRIC: &str =
    "metric: RMS over held-out manoeuvres and both sides of the effective-power \
                      residual (energy / expected duration, measured − model) [W]";
