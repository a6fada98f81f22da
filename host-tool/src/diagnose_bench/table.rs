//! The bench's figures ([`tabulate`]) and its terminal table: per part, the confusion matrix
//! (true class × diagnosed label), the accuracy on effect datasets, the effects named on
//! controls and on structure-only datasets, the median held-out shrink of the true effect over
//! all rows, and the same per structure and per class; the diagnosis timing over all datasets.

use super::family::Part;
use super::run::LongLogTiming;
use super::run::{DatasetResult, BASELINE_MISFIT};
use super::{
    BenchOptions, GOAL_DIAGNOSE_MS, GOAL_ONE_HOUR_LOG_S, GOAL_SHOWN_NAMED_PCT, GOAL_WRONG_PCT,
    SHOWN_CEILING_PCT,
};
use crate::diagnose::stats::{median, PRACTICAL_FLOOR_W};
use crate::effect_id::EffectId;
use crate::sim::world::Side;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;

/// Counts of true class × diagnosed label.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConfusionMatrix {
    /// Row labels: `none` (controls), the catalogue, `structure-only`.
    pub true_labels: Vec<String>,
    /// Column labels: the catalogue, `none`, `ambiguous`, `outside-catalogue`,
    /// `baseline-misfit`, `error`.
    pub diagnosed_labels: Vec<String>,
    /// `counts[true][diagnosed]`.
    pub counts: Vec<Vec<usize>>,
}

impl ConfusionMatrix {
    fn of(results: &[&DatasetResult]) -> Self {
        let true_labels: Vec<String> = std::iter::once("none")
            .chain(EffectId::ALL.iter().map(|e| e.id()))
            .chain(["structure-only"])
            .map(String::from)
            .collect();
        let diagnosed_labels: Vec<String> = EffectId::ALL
            .iter()
            .map(|e| e.id())
            .chain([
                "none",
                "ambiguous",
                "outside-catalogue",
                BASELINE_MISFIT,
                "error",
            ])
            .map(String::from)
            .collect();
        let mut counts = vec![vec![0; diagnosed_labels.len()]; true_labels.len()];
        let last = diagnosed_labels.len() - 1;
        for r in results {
            let Some(i) = true_labels.iter().position(|l| l == r.true_label()) else {
                continue;
            };
            // An unknown label counts as `error`.
            let j = diagnosed_labels
                .iter()
                .position(|l| *l == r.diagnosed)
                .unwrap_or(last);
            counts[i][j] += 1;
        }
        Self {
            true_labels,
            diagnosed_labels,
            counts,
        }
    }

    /// Total count.
    pub fn total(&self) -> usize {
        self.counts.iter().flatten().sum()
    }
}

/// Figures for one true class.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClassFigures {
    /// The class (`none` for controls, `structure-only`).
    pub label: String,
    /// Datasets.
    pub n: usize,
    /// Right ([`DatasetResult::right`]).
    pub right: usize,
    /// `ambiguous`.
    pub ambiguous: usize,
    /// `outside-catalogue`.
    pub outside: usize,
    /// `baseline-misfit` (right on structure-only datasets, a miss on the others).
    pub misfit: usize,
    /// `none` on effect datasets (missed).
    pub none: usize,
    /// A catalogue effect that is not the true one.
    pub wrong: usize,
    /// Errors.
    pub errors: usize,
    /// Regime hits among the datasets named right.
    pub regime_hits: usize,
    /// Median held-out shrink of the true effect [%].
    pub median_shrink_pct: Option<f64>,
    /// Median shrink in the true regime [%].
    pub median_regime_shrink_pct: Option<f64>,
    /// Median of the shrink a perfect model of the effect would give
    /// ([`DatasetResult::ceiling_shrink_pct`]) [%].
    pub median_ceiling_pct: Option<f64>,
    /// Median of the truth's peak extra power [W].
    pub median_peak_extra_w: Option<f64>,
    /// Datasets whose effect the calibration runs do not absorb
    /// ([`DatasetResult::visible_after_calibration`]).
    pub visible: usize,
}

/// Figures for one world structure ([`super::family::StructureKind::label`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StructureFigures {
    /// The structure's label.
    pub structure: String,
    /// Datasets.
    pub n: usize,
    /// Right answers ([`DatasetResult::right`]).
    pub right: usize,
    /// Effect datasets and their effect named right.
    pub effect_datasets: usize,
    /// Of those, named right.
    pub effect_named_right: usize,
    /// Datasets without an effect on which an effect was named.
    pub false_effects: usize,
    /// `baseline-misfit` verdicts.
    pub misfit: usize,
}

/// The headline figures of a part.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BenchSummary {
    /// Datasets.
    pub datasets: usize,
    /// Datasets with an effect.
    pub effect_datasets: usize,
    /// Of those, the effect named right.
    pub effect_named_right: usize,
    /// Accuracy on effect datasets [%].
    pub accuracy_pct: f64,
    /// Datasets on which a wrong effect was named: another than the true one, or any on a
    /// dataset without one.
    pub wrong_names: usize,
    /// `wrong_names` over all datasets [%] (goal ≤ [`GOAL_WRONG_PCT`]).
    pub wrong_pct: f64,
    /// Effect datasets whose twin ceiling reaches [`SHOWN_CEILING_PCT`]: effects the data can
    /// show.
    pub shown_datasets: usize,
    /// Of those, the effect named right (goal ≥ [`GOAL_SHOWN_NAMED_PCT`] %).
    pub shown_named_right: usize,
    /// Effect datasets whose effect reaches the practical floor ([`DatasetResult::detectable`]).
    pub detectable_datasets: usize,
    /// Of those, the effect named right.
    pub detectable_named_right: usize,
    /// Effect datasets whose effect shows beyond what the calibration runs absorb
    /// ([`DatasetResult::visible_after_calibration`]).
    pub visible_datasets: usize,
    /// Of those, the effect named right.
    pub visible_named_right: usize,
    /// Control datasets (the default structure, no effect).
    pub controls: usize,
    /// Controls on which a catalogue effect was named (goal 0).
    pub control_false_effects: usize,
    /// Controls diagnosed `ambiguous`.
    pub control_ambiguous: usize,
    /// Controls diagnosed `baseline-misfit`.
    pub control_misfit: usize,
    /// Controls with a significant gap (diagnosed `ambiguous` or an effect).
    pub control_significant: usize,
    /// Structure-only datasets (a structure off the default, no effect).
    pub structure_only: usize,
    /// Of those, an effect named (goal 0).
    pub structure_only_false_effects: usize,
    /// Of those, `none` or `baseline-misfit` (right).
    pub structure_only_right: usize,
    /// Of those, `baseline-misfit`.
    pub structure_only_misfit: usize,
    /// Datasets named right whose regime is also right.
    pub regime_hits_named: usize,
    /// `regime_hits_named` over the datasets named right [%].
    pub regime_hit_rate_pct: Option<f64>,
    /// Median held-out shrink of the true effect, all rows, over the effect datasets [%]
    /// (goal ≥ 70).
    pub median_shrink_pct: Option<f64>,
    /// The same over the datasets named right [%].
    pub median_shrink_named_pct: Option<f64>,
    /// Median shrink in the true regime [%].
    pub median_regime_shrink_pct: Option<f64>,
    /// Median over the effect datasets of the shrink a perfect model of the effect would give
    /// ([`DatasetResult::ceiling_shrink_pct`]) [%]: where the shrink goal can be met at all.
    pub median_ceiling_pct: Option<f64>,

    /// Datasets that failed to simulate, validate or diagnose.
    pub errors: usize,
    /// Whether the bars are met: wrong names, none on controls and structure-only datasets,
    /// effects the data can show named right.
    pub goals_met: bool,
}

/// One part's figures.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PartFigures {
    /// `tuning` or `held-out`.
    pub part: Part,
    /// Headline figures.
    pub summary: BenchSummary,
    /// True class × diagnosed label.
    pub confusion: ConfusionMatrix,
    /// Per true class.
    pub per_class: Vec<ClassFigures>,
    /// Per world structure, by label.
    pub per_structure: Vec<StructureFigures>,
    /// Per switch value (`split=clamp`, …, `rover=argo-j5`, `turns=right`).
    pub per_switch: Vec<StructureFigures>,
    /// The closed loop: open verdicts after driving what the diagnosis suggested.
    pub closed_loop: LoopFigures,
}

/// What the closed loop did to a part's open verdicts ([`DatasetResult::opened`]).
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct LoopFigures {
    /// Rounds run at most.
    pub rounds: u32,
    /// Open first verdicts on effect datasets the data can show (twin ceiling ≥
    /// [`SHOWN_CEILING_PCT`]).
    pub open_shown: usize,
    /// Of those, something was suggested to drive.
    pub open_shown_driven: usize,
    /// Of those, settled on the true effect.
    pub settled_right: usize,
    /// Settled on a wrong effect (goal 0).
    pub settled_wrong: usize,
    /// Settled as `none` (a miss, not a wrong name).
    pub settled_none: usize,
    /// Still open after the rounds.
    pub still_open: usize,
    /// Extra manoeuvres driven over those datasets.
    pub extra_manoeuvres: u32,
    /// Most extra manoeuvres one dataset took.
    pub max_extra_manoeuvres: u32,
    /// Open first verdicts on controls and structure-only datasets.
    pub open_without_effect: usize,
    /// Of those, an effect named after the loop (goal 0).
    pub became_effect: usize,
    /// Every dataset of the part: an effect named after the loop that the first verdict did not
    /// name wrong, and is wrong (goal 0).
    pub new_wrong_names: usize,
}

impl LoopFigures {
    fn of(of: &[&DatasetResult], rounds: u32) -> Self {
        let mut f = LoopFigures {
            rounds,
            ..LoopFigures::default()
        };
        for r in of {
            let last = r.settled_label();
            if r.wrong_label(last) && !r.wrong_label(&r.diagnosed) {
                f.new_wrong_names += 1;
            }
            if !r.opened {
                continue;
            }
            if r.spec.effect().is_none() {
                f.open_without_effect += 1;
                f.became_effect += usize::from(EffectId::from_id(last).is_some());
                continue;
            }
            if !r.ceiling_shrink_pct.is_some_and(|c| c >= SHOWN_CEILING_PCT) {
                continue;
            }
            f.open_shown += 1;
            f.open_shown_driven += usize::from(!r.next_rounds.is_empty());
            f.extra_manoeuvres += r.extra_manoeuvres();
            f.max_extra_manoeuvres = f.max_extra_manoeuvres.max(r.extra_manoeuvres());
            if r.still_open() {
                f.still_open += 1;
            } else if r.right_label(last) {
                f.settled_right += 1;
            } else if r.wrong_label(last) {
                f.settled_wrong += 1;
            } else if last == "none" {
                f.settled_none += 1;
            } else {
                f.still_open += 1;
            }
        }
        f
    }
}

/// Diagnosis and simulation times.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Timing {
    /// Wall time of the whole bench [s].
    pub wall_s: f64,
    /// Summed simulation (and validation) time [s].
    pub simulate_s: f64,
    /// Summed diagnosis time [s].
    pub diagnose_s: f64,
    /// Median diagnosis time per dataset [s].
    pub median_diagnose_s: Option<f64>,
    /// Slowest diagnosis [s].
    pub max_diagnose_s: Option<f64>,
    /// Median diagnosis time of the layout (one turn set per test run) [s].
    pub median_diagnose_layout_s: Option<f64>,
    /// Median diagnosis time of the long datasets (8–12 sets per test run) [s].
    pub median_diagnose_long_s: Option<f64>,
    /// Datasets whose diagnosis took longer than the goal ([`GOAL_DIAGNOSE_MS`]).
    pub over_goal: usize,
    /// One diagnosis of a one-hour log (the first dataset's world), or why it failed.
    pub one_hour_log: Result<LongLogTiming, String>,
}

/// The bench's results: the figures per part, the timing, every dataset.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BenchReport {
    /// How it ran.
    pub options: BenchOptions,
    /// Diagnosis timing over every dataset.
    pub timing: Timing,
    /// The figures of each part run (tuning first).
    pub parts: Vec<PartFigures>,
    /// Every dataset.
    pub datasets: Vec<DatasetResult>,
}

pub(super) fn pct(a: usize, b: usize) -> Option<f64> {
    (b > 0).then(|| 100.0 * a as f64 / b as f64)
}

fn class_figures(label: &str, of: &[&DatasetResult]) -> ClassFigures {
    let count = |f: &dyn Fn(&DatasetResult) -> bool| of.iter().filter(|r| f(r)).count();
    let has_effect = EffectId::from_id(label).is_some();
    ClassFigures {
        label: label.into(),
        n: of.len(),
        right: count(&|r| r.right()),
        ambiguous: count(&|r| r.diagnosed == "ambiguous"),
        outside: count(&|r| r.diagnosed == "outside-catalogue"),
        misfit: count(&|r| r.diagnosed == BASELINE_MISFIT),
        none: if has_effect {
            count(&|r| r.diagnosed == "none")
        } else {
            0
        },
        wrong: count(&|r| r.named_an_effect() && r.diagnosed != label),
        errors: count(&|r| r.error.is_some()),
        regime_hits: count(&|r| r.named_right() && r.regime_hit()),
        median_shrink_pct: median(of.iter().filter_map(|r| r.true_effect_shrink_pct).collect()),
        median_regime_shrink_pct: median(
            of.iter().filter_map(|r| r.true_regime_shrink_pct).collect(),
        ),
        median_ceiling_pct: median(of.iter().filter_map(|r| r.ceiling_shrink_pct).collect()),
        median_peak_extra_w: has_effect
            .then(|| {
                median(
                    of.iter()
                        .filter_map(|r| r.truth.as_ref().map(|t| t.peak_extra_power_w))
                        .collect(),
                )
            })
            .flatten(),
        visible: count(&|r| r.visible_after_calibration()),
    }
}

/// The switch values of a dataset (`split=clamp`, `slip=on`, …, `rover=argo-j5`,
/// `turns=right`): each dataset counts once per switch.
fn switch_values(r: &DatasetResult) -> Vec<String> {
    let st = &r.spec.structure;
    let on = |b: bool| if b { "on" } else { "off" };
    let turns = match r.spec.direction {
        Side::Left => "left",
        Side::Right => "right",
    };
    vec![
        format!("split={}", st.split.id()),
        format!("slip={}", on(st.slip)),
        format!("loss={}", on(st.losses)),
        format!("standstill={}", st.standstill.id()),
        format!("rover={}", r.spec.rover.id()),
        format!("turns={turns}"),
    ]
}

fn structure_figures(
    results: &[&DatasetResult],
    keys: impl Fn(&DatasetResult) -> Vec<String>,
) -> Vec<StructureFigures> {
    let mut by: BTreeMap<String, Vec<&DatasetResult>> = BTreeMap::new();
    for r in results {
        for key in keys(r) {
            by.entry(key).or_default().push(r);
        }
    }
    by.into_iter()
        .map(|(label, of)| {
            let effects: Vec<_> = of.iter().filter(|r| r.spec.effect().is_some()).collect();
            StructureFigures {
                structure: label,
                n: of.len(),
                right: of.iter().filter(|r| r.right()).count(),
                effect_datasets: effects.len(),
                effect_named_right: effects.iter().filter(|r| r.named_right()).count(),
                false_effects: of
                    .iter()
                    .filter(|r| r.spec.effect().is_none() && r.named_an_effect())
                    .count(),
                misfit: of.iter().filter(|r| r.diagnosed == BASELINE_MISFIT).count(),
            }
        })
        .collect()
}

fn summary(results: &[&DatasetResult]) -> BenchSummary {
    use super::family::DatasetClass;
    let of = |class: fn(&DatasetClass) -> bool| -> Vec<&DatasetResult> {
        results
            .iter()
            .copied()
            .filter(|r| class(&r.spec.class))
            .collect()
    };
    let effects = of(|c| matches!(c, DatasetClass::Effect(_)));
    let controls = of(|c| *c == DatasetClass::Control);
    let structure_only = of(|c| *c == DatasetClass::StructureOnly);
    let named: Vec<&DatasetResult> = effects
        .iter()
        .copied()
        .filter(|r| r.named_right())
        .collect();
    let regime_hits_named = named.iter().filter(|r| r.regime_hit()).count();
    let count = |v: &[&DatasetResult], f: &dyn Fn(&DatasetResult) -> bool| {
        v.iter().filter(|r| f(r)).count()
    };
    let accuracy_pct = pct(named.len(), effects.len()).unwrap_or(0.0);
    let median_shrink_pct = median(
        effects
            .iter()
            .filter_map(|r| r.true_effect_shrink_pct)
            .collect(),
    );
    let control_false_effects = count(&controls, &|r| r.named_an_effect());
    let structure_only_false_effects = count(&structure_only, &|r| r.named_an_effect());
    let wrong_names = count(results, &|r| r.named_an_effect() && !r.right());
    let wrong_pct = pct(wrong_names, results.len()).unwrap_or(0.0);
    let shown = |r: &DatasetResult| r.ceiling_shrink_pct.is_some_and(|c| c >= SHOWN_CEILING_PCT);
    let shown_datasets = count(&effects, &shown);
    let shown_named_right = count(&named, &shown);
    BenchSummary {
        datasets: results.len(),
        effect_datasets: effects.len(),
        effect_named_right: named.len(),
        accuracy_pct,
        wrong_names,
        wrong_pct,
        shown_datasets,
        shown_named_right,
        detectable_datasets: count(&effects, &|r| r.detectable()),
        detectable_named_right: count(&named, &|r| r.detectable()),
        visible_datasets: count(&effects, &|r| r.visible_after_calibration()),
        visible_named_right: count(&named, &|r| r.visible_after_calibration()),
        controls: controls.len(),
        control_false_effects,
        control_ambiguous: count(&controls, &|r| r.diagnosed == "ambiguous"),
        control_misfit: count(&controls, &|r| r.diagnosed == BASELINE_MISFIT),
        control_significant: count(&controls, &|r| r.significant),
        structure_only: structure_only.len(),
        structure_only_false_effects,
        structure_only_right: count(&structure_only, &|r| r.right()),
        structure_only_misfit: count(&structure_only, &|r| r.diagnosed == BASELINE_MISFIT),
        regime_hits_named,
        regime_hit_rate_pct: pct(regime_hits_named, named.len()),
        median_shrink_pct,
        median_shrink_named_pct: median(
            named
                .iter()
                .filter_map(|r| r.true_effect_shrink_pct)
                .collect(),
        ),
        median_regime_shrink_pct: median(
            effects
                .iter()
                .filter_map(|r| r.true_regime_shrink_pct)
                .collect(),
        ),
        median_ceiling_pct: median(
            effects
                .iter()
                .filter_map(|r| r.ceiling_shrink_pct)
                .collect(),
        ),
        errors: count(results, &|r| r.error.is_some()),
        goals_met: wrong_pct <= GOAL_WRONG_PCT
            && control_false_effects == 0
            && structure_only_false_effects == 0
            && pct(shown_named_right, shown_datasets).is_none_or(|p| p >= GOAL_SHOWN_NAMED_PCT),
    }
}

/// The figures of `part` over its datasets in `results`.
pub fn part_figures(part: Part, results: &[DatasetResult], rounds: u32) -> PartFigures {
    let of: Vec<&DatasetResult> = results.iter().filter(|r| r.spec.part == part).collect();
    let confusion = ConfusionMatrix::of(&of);
    let per_class = confusion
        .true_labels
        .iter()
        .map(|label| {
            let rows: Vec<&DatasetResult> = of
                .iter()
                .copied()
                .filter(|r| r.true_label() == label)
                .collect();
            class_figures(label, &rows)
        })
        .collect();
    PartFigures {
        part,
        summary: summary(&of),
        confusion,
        per_class,
        per_structure: structure_figures(&of, |r| vec![r.spec.structure_label.clone()]),
        per_switch: structure_figures(&of, switch_values),
        closed_loop: LoopFigures::of(&of, rounds),
    }
}

/// The report of finished datasets.
pub fn tabulate(
    options: BenchOptions,
    datasets: Vec<DatasetResult>,
    wall_s: f64,
    one_hour_log: Result<LongLogTiming, String>,
) -> BenchReport {
    let parts = options
        .part
        .parts()
        .iter()
        .map(|&p| part_figures(p, &datasets, options.rounds))
        .collect();
    let ok = |f: &dyn Fn(&DatasetResult) -> bool| -> Vec<f64> {
        datasets
            .iter()
            .filter(|r| r.error.is_none() && f(r))
            .map(|r| r.diagnose_s)
            .collect()
    };
    let times = ok(&|_| true);
    let timing = Timing {
        wall_s,
        simulate_s: datasets.iter().map(|r| r.simulate_s).sum(),
        diagnose_s: datasets.iter().map(|r| r.diagnose_s).sum(),
        median_diagnose_s: median(times.clone()),
        max_diagnose_s: times.iter().copied().reduce(f64::max),
        median_diagnose_layout_s: median(ok(&|r| r.spec.repeats == 1)),
        median_diagnose_long_s: median(ok(&|r| r.spec.repeats > 1)),
        over_goal: times
            .iter()
            .filter(|&&t| t * 1e3 > GOAL_DIAGNOSE_MS)
            .count(),
        one_hour_log,
    };
    BenchReport {
        options,
        timing,
        parts,
        datasets,
    }
}

fn opt(v: Option<f64>, unit: &str) -> String {
    v.map_or_else(|| "–".into(), |v| format!("{v:.0}{unit}"))
}

impl BenchReport {
    /// The terminal table (also the `Display`).
    pub fn to_text(&self) -> String {
        self.to_string()
    }

    /// The JSON of the whole report.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
    }

    /// The figures of `part`, if it ran.
    pub fn part(&self, part: Part) -> Option<&PartFigures> {
        self.parts.iter().find(|p| p.part == part)
    }
}

impl fmt::Display for BenchReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = &self.timing;
        writeln!(
            f,
            "diagnose-bench over the world family: {} datasets (seed {}; part {}), {} thread(s), \
             {:.1} s wall (simulate+validate {:.1} s, diagnose {:.1} s summed)",
            self.datasets.len(),
            self.options.seed,
            self.options.part.id(),
            self.options.threads,
            t.wall_s,
            t.simulate_s,
            t.diagnose_s,
        )?;
        writeln!(
            f,
            "diagnosis per dataset: median {} ms (issue layout {} ms, long runs {} ms), max {} ms; \
             {} over the {GOAL_DIAGNOSE_MS:.0} ms goal",
            opt(t.median_diagnose_s.map(|s| s * 1e3), ""),
            opt(t.median_diagnose_layout_s.map(|s| s * 1e3), ""),
            opt(t.median_diagnose_long_s.map(|s| s * 1e3), ""),
            opt(t.max_diagnose_s.map(|s| s * 1e3), ""),
            t.over_goal
        )?;
        match &t.one_hour_log {
            Ok(h) => writeln!(
                f,
                "one-hour log ({:.0} s, {} samples, {} manoeuvres): validate {:.0} ms, diagnose \
                 {:.0} ms (goal < {GOAL_ONE_HOUR_LOG_S:.0} s)",
                h.run_s,
                h.samples,
                h.manoeuvres,
                h.validate_s * 1e3,
                h.diagnose_s * 1e3
            )?,
            Err(e) => writeln!(f, "one-hour log: not timed ({e})")?,
        }
        for p in &self.parts {
            writeln!(f)?;
            write_part(f, p)?;
        }
        let errors: Vec<&DatasetResult> =
            self.datasets.iter().filter(|r| r.error.is_some()).collect();
        if !errors.is_empty() {
            writeln!(f, "\nerrors: {}", errors.len())?;
            for r in errors {
                writeln!(
                    f,
                    "  {} dataset {}: {}",
                    r.spec.part.id(),
                    r.spec.index,
                    r.error.as_deref().unwrap_or("")
                )?;
            }
        }
        Ok(())
    }
}

/// Short column heads of the confusion matrix, in its column order.
fn short_heads() -> impl Iterator<Item = &'static str> {
    EffectId::ALL
        .into_iter()
        .map(EffectId::short)
        .chain(["none", "ambig", "misf", "err"])
}

fn row_label(label: &str) -> &str {
    if label == "none" {
        "none (control)"
    } else {
        label
    }
}

fn write_part(f: &mut fmt::Formatter<'_>, p: &PartFigures) -> fmt::Result {
    let s = &p.summary;
    writeln!(
        f,
        "=== {} part: {} datasets — goals {} ===",
        p.part.id(),
        s.datasets,
        if s.goals_met { "MET" } else { "not met" }
    )?;
    writeln!(
        f,
        "wrong names: {} of {} datasets = {:.1} % (goal ≤ {GOAL_WRONG_PCT:.0} %): another effect \
         than the true one, or any on a dataset without one",
        s.wrong_names, s.datasets, s.wrong_pct
    )?;
    writeln!(
        f,
        "effects the data can show (their twin ceiling ≥ {SHOWN_CEILING_PCT:.0} %): named right \
         {}/{} = {} (goal ≥ {GOAL_SHOWN_NAMED_PCT:.0} %)",
        s.shown_named_right,
        s.shown_datasets,
        opt(pct(s.shown_named_right, s.shown_datasets), " %")
    )?;
    writeln!(
        f,
        "effect named right: {}/{} = {:.1} %; over effects above the {PRACTICAL_FLOOR_W:.1} W \
         floor {}/{}",
        s.effect_named_right,
        s.effect_datasets,
        s.accuracy_pct,
        s.detectable_named_right,
        s.detectable_datasets
    )?;
    writeln!(
        f,
        "effects the calibration runs do not absorb (Eq 21 or the terrain's constant slip fitted \
         on them leaves the floor in some regime): {}/{}; named right among them {}/{}",
        s.visible_datasets, s.effect_datasets, s.visible_named_right, s.visible_datasets
    )?;
    writeln!(
        f,
        "controls (default structure): {} effect(s) named on {} (goal 0); {} ambiguous, {} \
         baseline-misfit",
        s.control_false_effects, s.controls, s.control_ambiguous, s.control_misfit
    )?;
    writeln!(
        f,
        "structure-only (no effect): {} effect(s) named on {} (goal 0); right (none or \
         baseline-misfit) {}, of which baseline-misfit {}",
        s.structure_only_false_effects,
        s.structure_only,
        s.structure_only_right,
        s.structure_only_misfit
    )?;
    writeln!(
        f,
        "median held-out shrink of the true effect, all rows: {} over effect datasets, {} where \
         named right, {} in the true regime; regime right on \
         {}/{} named right",
        opt(s.median_shrink_pct, " %"),
        opt(s.median_shrink_named_pct, " %"),
        opt(s.median_regime_shrink_pct, " %"),
        s.regime_hits_named,
        s.effect_named_right
    )?;
    writeln!(
        f,
        "a perfect model of the true effect would give {} (median; each dataset's twin, the same \
         world without the effect, sets its ceiling)",
        opt(s.median_ceiling_pct, " %"),
    )?;
    if s.errors > 0 {
        writeln!(f, "errors: {}", s.errors)?;
    }
    let l = &p.closed_loop;
    if l.rounds > 0 {
        writeln!(
            f,
            "closed loop (≤ {} rounds of what `diagnose --next-runs` suggests, driven in the same \
             world): of {} open verdicts on effects the data can show, {} had something to \
             drive; settled right {} = {}, wrong {} (goal 0), as none {}, still open {}; {} extra \
             manoeuvres (most {} on one dataset); controls and structure-only: {} open, {} \
             became an effect (goal 0); new wrong names over the part {}",
            l.rounds,
            l.open_shown,
            l.open_shown_driven,
            l.settled_right,
            opt(pct(l.settled_right, l.open_shown), " %"),
            l.settled_wrong,
            l.settled_none,
            l.still_open,
            l.extra_manoeuvres,
            l.max_extra_manoeuvres,
            l.open_without_effect,
            l.became_effect,
            l.new_wrong_names
        )?;
    }
    writeln!(f, "confusion matrix (rows: true class; columns: diagnosed)")?;
    write!(f, "{:<20}", "")?;
    for head in short_heads() {
        write!(f, "{head:>6}")?;
    }
    writeln!(f)?;
    for (label, row) in p.confusion.true_labels.iter().zip(&p.confusion.counts) {
        write!(f, "{:<20}", row_label(label))?;
        for c in row {
            if *c == 0 {
                write!(f, "{:>6}", ".")?;
            } else {
                write!(f, "{c:>6}")?;
            }
        }
        writeln!(f)?;
    }
    writeln!(
        f,
        "{:<28}{:>4}{:>7}{:>9}{:>10}{:>8}",
        "switch / structure", "n", "right", "effects", "false eff", "misfit"
    )?;
    for st in p.per_switch.iter().chain(&p.per_structure) {
        writeln!(
            f,
            "{:<28}{:>4}{:>7}{:>9}{:>10}{:>8}",
            st.structure,
            st.n,
            st.right,
            format!("{}/{}", st.effect_named_right, st.effect_datasets),
            st.false_effects,
            st.misfit
        )?;
    }
    writeln!(
        f,
        "{:<20}{:>4}{:>7}{:>7}{:>8}{:>7}{:>6}{:>7}{:>8}{:>9}{:>9}{:>10}{:>9}",
        "true class",
        "n",
        "right",
        "ambig",
        "outside",
        "misfit",
        "none",
        "wrong",
        "regime",
        "shrink",
        "ceiling",
        "peak W",
        "visible"
    )?;
    for c in &p.per_class {
        writeln!(
            f,
            "{:<20}{:>4}{:>7}{:>7}{:>8}{:>7}{:>6}{:>7}{:>8}{:>9}{:>9}{:>10}{:>9}",
            row_label(&c.label),
            c.n,
            c.right,
            c.ambiguous,
            c.outside,
            c.misfit,
            c.none,
            c.wrong,
            c.regime_hits,
            opt(c.median_shrink_pct, " %"),
            opt(c.median_ceiling_pct, " %"),
            c.median_peak_extra_w
                .map_or_else(|| "–".into(), |w| format!("{w:.2}")),
            c.visible,
        )?;
    }
    writeln!(
        f,
        "(structure: right = true effect / none on controls / none or baseline-misfit on \
         structure-only; effects: named right/effect datasets; false eff: effects named without \
         one. class: regime = hits among those named right; shrink = median held-out shrink of \
         the true effect, all rows; ceiling = median shrink a perfect model of it would give \
         (the dataset's twin without the effect); peak W = median of the true effect's largest \
         mean extra power per regime; visible = datasets whose effect the calibration runs do not absorb: Eq 21 \
         (power-type effects) or a positive constant angular slip (effects that slow the turns) \
         fitted to the effect's power on the calibration manoeuvres leaves a regime mean above \
         the practical floor; current-offset always, as it reads at standstill)"
    )
}
