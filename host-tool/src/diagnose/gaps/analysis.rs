//! The "where" analysis: each metric's groups, the findings ranked by strength, the headline
//! and the notes on what the data cannot show.

use super::groups::{grouped, GroupStat, MetricWhere};
use super::judge::{Floor, RowVerdicts};
use super::residuals::{turn_residuals, Metric, TurnResidual};
use super::run_time::{run_time, RunTimeWhere};
use crate::diagnose::baseline::Baseline;
use crate::diagnose::features::TurnRow;
use crate::diagnose::loo::LooTest;
use crate::effect_id::EffectId;
use serde::Serialize;
use std::collections::BTreeMap;

/// The "where" analysis of `rows` against `baseline`; groups without repeats are judged by
/// `verdicts` (see [`judge`]).
pub fn analyse(baseline: &Baseline, rows: &[TurnRow], verdicts: &RowVerdicts) -> WhereAnalysis {
    let turns = turn_residuals(baseline, rows);
    let metrics = metric_wheres(&turns, rows, verdicts);
    // Growth has a fixed floor: no model power.
    let growth: Vec<(&TurnResidual, f64, f64, f64)> = turns
        .iter()
        .filter_map(|t| t.growth_w.map(|g| (t, g, 0.0, 0.0)))
        .collect();
    let (phase_by_regime_side, phase_by_side) = grouped("growth", &growth, Floor::Fixed, &[]);
    let run_time = run_time(&turns);
    let Ranked {
        findings,
        other_findings,
        any_finite,
    } = ranked_findings(
        rows,
        &metrics,
        phase_by_regime_side.iter().chain(&phase_by_side),
        &run_time,
    );
    let significant = !findings.is_empty();
    let statement = where_statement(&findings, &other_findings, any_finite);
    let notes = where_notes(rows, &run_time);
    WhereAnalysis {
        statement,
        significant,
        findings,
        other_findings,
        notes,
        metrics,
        phase_by_regime_side,
        phase_by_side,
        run_time,
        turns,
    }
}

/// Each metric's groups by regime and side and by side.
fn metric_wheres(
    turns: &[TurnResidual],
    rows: &[TurnRow],
    verdicts: &RowVerdicts,
) -> Vec<MetricWhere> {
    let mut metrics = Vec::new();
    // The max metric's reference: each run's mean peak over steady model on its calibration
    // manoeuvres (pooled over runs for a run without any).
    let mut reference: BTreeMap<usize, (f64, f64)> = BTreeMap::new();
    for t in turns.iter().filter(|t| t.calibration_kind) {
        if let Some(p) = t.peak_over_model_w {
            let e = reference.entry(t.run_index).or_default();
            e.0 += p;
            e.1 += 1.0;
        }
    }
    let pooled = reference
        .values()
        .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    let reference_of = |run: usize| {
        let (s, n) = reference.get(&run).copied().unwrap_or(pooled);
        (n > 0.0).then(|| s / n)
    };
    for metric in Metric::ALL {
        let items: Vec<(&TurnResidual, f64, f64, f64)> = turns
            .iter()
            .filter_map(|t| {
                let dur = rows[t.row].expected_duration_s;
                let v = match metric {
                    Metric::AvgPower => Some(t.avg_power_w),
                    Metric::MaxPower => t
                        .peak_over_model_w
                        .and_then(|p| reference_of(t.run_index).map(|r| p - r)),
                    Metric::Energy => t.energy_j,
                    Metric::EffectivePower => Some(t.effective_power_w),
                }?;
                // The floor is a share of the power the metric's model stands for: the
                // effective power for it and for the energy (so these groups are the gaps'
                // to the bit), the steady power for the average and the peak.
                let model_w = match metric {
                    Metric::AvgPower | Metric::MaxPower => t.model_w,
                    Metric::Energy | Metric::EffectivePower => t.model_effective_w,
                };
                Some((t, v, dur, model_w))
            })
            .collect();
        if items.is_empty() {
            continue;
        }
        let (floor, tests): (Floor, &[LooTest]) = match metric {
            Metric::AvgPower => (Floor::Power, &verdicts.average),
            Metric::MaxPower => (Floor::Power, &[]),
            Metric::Energy => (Floor::Energy, &[]),
            Metric::EffectivePower => (Floor::Power, &verdicts.effective),
        };
        let (by_regime_side, by_side) = grouped(metric.id(), &items, floor, tests);
        metrics.push(MetricWhere {
            metric,
            unit: metric.unit(),
            what: metric.what(),
            by_regime_side,
            by_side,
        });
    }
    metrics
}

/// The significant findings, strongest (relative to their floor) first.
struct Ranked {
    /// Of the diagnosed metric: effective power by regime and side, and its run-time trend.
    findings: Vec<String>,
    /// Of the other metrics (average and peak power, energy, growth through the turn) and the
    /// run-time thirds.
    other_findings: Vec<String>,
    /// Whether any group had a finite interval (something could be judged).
    any_finite: bool,
}

/// Ranks the significant groups of `metrics`, `phase_groups` and `run_time`.
fn ranked_findings<'a>(
    rows: &[TurnRow],
    metrics: &[MetricWhere],
    phase_groups: impl Iterator<Item = &'a GroupStat>,
    run_time: &RunTimeWhere,
) -> Ranked {
    // (strength relative to the floor, text, of the diagnosed metric)
    let mut scored: Vec<(f64, String, bool)> = Vec::new();
    let mut any_finite = false;
    let mut note_group = |label: &str, unit: &str, g: &GroupStat, diagnosed: bool| {
        any_finite |= g.ci.0.is_finite() && g.ci.1.is_finite();
        if g.significant {
            let text = match strongest(&g.loo, g.floor) {
                Some(t) => format!("{label} {}: {}", g.group, t.statement(rows)),
                None => format!(
                    "{label} {}: {:+.1} {unit} [{:.1}, {:.1}] (n = {})",
                    g.group, g.mean, g.ci.0, g.ci.1, g.n
                ),
            };
            scored.push((
                g.mean.abs() / g.floor.max(f64::MIN_POSITIVE),
                text,
                diagnosed,
            ));
        }
    };
    for m in metrics {
        let diagnosed = m.metric == Metric::EffectivePower;
        for g in m.by_regime_side.iter().chain(&m.by_side) {
            note_group(m.metric.id(), m.unit, g, diagnosed);
        }
    }
    for g in phase_groups {
        note_group("growth through the turn", "W", g, false);
    }
    // The thirds describe where in the runs a trend sits; the trend's permutation test decides
    // (a bootstrap over three runs has ten distinct resamples: too coarse to count).
    for g in &run_time.thirds {
        note_group(
            "run time (effective power less its regime/side mean)",
            "W",
            g,
            false,
        );
    }
    if let Some(t) = &run_time.trend {
        any_finite = true;
        if t.significant {
            scored.push((
                t.change_w.abs() / t.floor_w.max(f64::MIN_POSITIVE),
                format!(
                    "run-time trend: {:+.2} W/min, {:+.1} W over a {:.1} min run (permutation \
                     p = {:.3}, floor {:.1} W)",
                    t.slope_w_per_min, t.change_w, t.run_length_min, t.p_value, t.floor_w
                ),
                true,
            ));
        }
    }
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    let (findings, other_findings) = scored.into_iter().fold(
        (Vec::new(), Vec::new()),
        |(mut mine, mut other), (_, text, diagnosed)| {
            if diagnosed { &mut mine } else { &mut other }.push(text);
            (mine, other)
        },
    );
    Ranked {
        findings,
        other_findings,
        any_finite,
    }
}

/// The headline of the "where" analysis: the diagnosed metric's groups (the headline verdict
/// counts these), then the other metrics' (reported, not counted).
fn where_statement(findings: &[String], other_findings: &[String], any_finite: bool) -> String {
    let others = other_findings.first().map_or_else(String::new, |first| {
        format!(
            "; other metrics (not counted in the verdict): {} group(s), largest: {first}",
            other_findings.len()
        )
    });
    if !findings.is_empty() {
        let shown: Vec<&str> = findings.iter().take(3).map(String::as_str).collect();
        format!(
            "gap beyond the noise in {} group(s); largest: {}{others}",
            findings.len(),
            shown.join("; ")
        )
    } else if any_finite && others.is_empty() {
        "no gap beyond the noise".to_owned()
    } else if any_finite {
        format!("no gap beyond the noise in effective power{others}")
    } else {
        "no gap can be judged: no group has repeats (two runs, or the same radius twice) to \
         estimate the noise from"
            .to_owned()
    }
}

/// Notes on what the data cannot show (one run, total-only rows, run time).
fn where_notes(rows: &[TurnRow], run_time: &RunTimeWhere) -> Vec<String> {
    let mut notes = Vec::new();
    let n_runs = rows
        .iter()
        .map(|r| r.run_index)
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    if n_runs < 2 {
        notes.push(
            "one run: intervals resample the repeated manoeuvres within a group; a power group \
             without a radius driven twice is judged row by row against the leave-one-out \
             prediction interval of the baseline refitted without the row (Holm, R ≤ R′ first); \
             other groups without repeats have no verdict"
                .to_owned(),
        );
    }
    if rows.iter().any(TurnRow::is_total_only) {
        notes.push(
            "total-only rows (per-turn summaries): no sides, no peak, no energy, no duration \
             (effective power = average power, so time-type effects such as angular slip are \
             invisible), no growth and no run time"
                .to_owned(),
        );
    }
    if let Some(n) = &run_time.note {
        notes.push(n.clone());
    }
    notes
}

/// The significant leave-one-out test with the largest |t| among `loo` whose residual exceeds
/// `floor`.
fn strongest(loo: &[LooTest], floor: f64) -> Option<&LooTest> {
    loo.iter()
        .filter(|t| t.beyond_noise && t.residual_w.abs() > floor)
        .max_by(|a, b| a.t.abs().total_cmp(&b.t.abs()))
}

/// Where the model departs: per-turn residuals and their groups.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WhereAnalysis {
    /// One line: the significant groups, or that there is no gap beyond the repeat noise.
    pub statement: String,
    /// Whether any finding of the diagnosed metric is (the headline's `significant` agrees).
    pub significant: bool,
    /// Every significant group of the diagnosed metric (effective power by regime and side, its
    /// run-time trend), one line each, largest (relative to its floor) first.
    pub findings: Vec<String>,
    /// The other metrics' significant groups (average and peak power, energy, growth, run-time
    /// thirds), same order: reported, not counted in the verdict.
    pub other_findings: Vec<String>,
    /// Caveats of the data (total-only rows, one run, ...).
    pub notes: Vec<String>,
    /// Groups of each metric (metrics with no observation are left out).
    pub metrics: Vec<MetricWhere>,
    /// Growth of average power through the turn (second minus first half of the steady part),
    /// `regime/side` and per side over turns [W].
    pub phase_by_regime_side: Vec<GroupStat>,
    /// Growth through the turn per side over turns [W].
    pub phase_by_side: Vec<GroupStat>,
    /// Run-time grouping.
    pub run_time: RunTimeWhere,
    /// Per-turn, per-side residuals.
    pub turns: Vec<TurnResidual>,
}

impl WhereAnalysis {
    /// Whether the effective-power residual's run-time trend is significant: a departure of the
    /// diagnosed metric that no regime's mean shows (heating grows in every regime), so the
    /// headline counts it.
    pub fn departs_over_run_time(&self) -> bool {
        self.run_time.trend.as_ref().is_some_and(|t| t.significant)
    }

    /// Records a departure that no group shows but cross-validation does: the selection's clear
    /// winner `effect` (held-out RMS `before` → `after` under `scheme`) removes at least the
    /// practical floor of held-out RMS (e.g. a slope, whose power
    /// changes sign along the path, so its group means are ~0). The diagnosis' `significant`
    /// counts it, so the "where" analysis must too.
    pub fn add_heldout_departure(
        &mut self,
        effect: EffectId,
        (before, after): (f64, f64),
        scheme: &str,
        floor_w: f64,
    ) {
        let removed = (before.powi(2) - after.powi(2)).max(0.0).sqrt();
        let finding = format!(
            "held out ({}): {} removes {removed:.1} W RMS ({:.2} → {:.2} W), more than the \
             {floor_w:.1} W floor, although no group's mean departs on its own",
            scheme, effect, before, after,
        );
        self.statement = if self.significant {
            format!("{}; {finding}", self.statement)
        } else {
            format!("departure beyond the noise out of sample: {finding}")
        };
        self.findings.push(finding);
        self.significant = true;
    }
}
