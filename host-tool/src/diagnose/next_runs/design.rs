//! The greedy design: the drives that let an unseen rival's mark be tested first, then, while
//! the budget lasts, the manoeuvre that separates the most open pairs per repeat.

use super::super::catalogue;
use super::super::diagnosis::Diagnosis;
use super::super::effect::{MarkDrive, When};
use super::super::features::TurnRow;
use super::super::gaps::MIN_TREND_SPREAD_S;
use super::super::stats::PRACTICAL_FLOOR_W;
use super::drivable::{drivable, shown_late, thousandths, Drivable, MAX_MANOEUVRES};
use super::noise::Noise;
use super::pair::{Pair, TARGET_SIGMA};
use super::rival::{Fitted, Rival, Setting};
use super::suggestion::NextRun;
use crate::effect_id::EffectId;

/// Decides which pairs in play the runs given leave open (short of [`TARGET_SIGMA`]).
pub(super) fn open_pairs(
    pairs: &[Pair],
    fitted: &[Fitted],
    in_play: &[Rival],
    noise_w: f64,
) -> Vec<Pair> {
    pairs
        .iter()
        .filter(|p| {
            let [a, b] = p.labels(fitted);
            in_play.contains(&a) && in_play.contains(&b) && p.sigma(noise_w) < TARGET_SIGMA
        })
        .cloned()
        .collect()
}

/// Decides which effects' marks must be driven to be seen before any power separation.
pub(super) fn unseen_marks(d: &Diagnosis, in_play: &[Rival]) -> Vec<EffectId> {
    // Rivals whose own mark these runs cannot test yet, or show in size but short of the
    // noise: the drives their signature test reads come first, whatever their power says (a
    // mark, not a fit, decides a name).
    // A mark another effect makes too needs that effect's drives as well, to tell them apart.
    let mut unseen: Vec<EffectId> = Vec::new();
    for r in in_play {
        let Rival::Effect(e) = *r else { continue };
        let Some(sig) = d.signature(e) else { continue };
        if !(sig.observable_by_driving() || sig.inconclusive()) {
            continue;
        }
        for e in std::iter::once(e).chain(sig.told_apart_by) {
            if !unseen.contains(&e) {
                unseen.push(e);
            }
        }
    }
    unseen
}

/// Decides what the design may choose from: nothing when no pair is open and no mark unseen,
/// else the drivable manoeuvres, repeated in a row too when a mark late repeats show is at stake.
pub(super) fn options(
    s: &Setting<'_>,
    rows: &[TurnRow],
    in_play: &[Rival],
    open: &[Pair],
    unseen: &[EffectId],
) -> Vec<Drivable> {
    // Repeats in a row only when an effect whose mark late repeats show is in play (a warming
    // winding's trend over run time).
    let late = in_play
        .iter()
        .any(|r| matches!(r, Rival::Effect(e) if shown_late(*e)));
    if open.is_empty() && unseen.is_empty() {
        Vec::new()
    } else {
        drivable(s, rows, late || unseen.iter().any(|&e| shown_late(e)))
    }
}

/// The greedy design under way: what it weighs drives with, what it may choose from, the pairs
/// still open, the manoeuvres chosen and the budget left.
pub(super) struct Design<'a> {
    s: &'a Setting<'a>,
    fitted: &'a [Fitted],
    noise: Noise,
    options: Vec<Drivable>,
    pub(super) open: Vec<Pair>,
    pub(super) runs: Vec<NextRun>,
    budget: u32,
}

impl<'a> Design<'a> {
    /// A design choosing from `options` to separate the `open` pairs, nothing chosen yet.
    pub(super) fn new(
        s: &'a Setting<'a>,
        fitted: &'a [Fitted],
        noise: Noise,
        options: Vec<Drivable>,
        open: Vec<Pair>,
    ) -> Self {
        Self {
            s,
            fitted,
            noise,
            options,
            open,
            runs: Vec::new(),
            budget: MAX_MANOEUVRES,
        }
    }

    /// Decides the drives that let each `unseen` mark be tested: the ones its signature test
    /// reads, at the fastest v_c, before any power separation.
    pub(super) fn show_marks(&mut self, unseen: &[EffectId], in_play: &[Rival], pairs: &[Pair]) {
        let (s, fitted, noise) = (self.s, self.fitted, self.noise);
        let noise_w = noise.sigma_w();
        let fastest = self
            .options
            .iter()
            .map(|o| o.run.v_c_mps)
            .fold(0.0, f64::max);
        for &e in unseen {
            let leader = in_play[0];
            for MarkDrive {
                r_over_r_prime: x,
                turn_deg,
                when,
                repeats: n,
            } in catalogue::of(e).drives_to_show_mark()
            {
                let Some(o) = self.options.iter().find(|o| {
                    o.run.r_over_r_prime == x.map(thousandths)
                        && o.run.turn_deg == turn_deg
                        && o.run.when == when
                        && o.run.v_c_mps == fastest
                }) else {
                    continue;
                };
                // Heating's test compares drives at least MIN_TREND_SPREAD_S after the first of the
                // row: enough repeats that three of them are.
                let n = match when {
                    When::Late => n.max(3 + (MIN_TREND_SPREAD_S / o.cycle_s).ceil() as u32),
                    When::Any => n,
                };
                if n > self.budget {
                    continue;
                }
                let (drives, weight) = (o.drives(n), noise.repeat_weight(n));
                let pair = pairs.iter().find(|p| {
                    let labels = p.labels(fitted);
                    labels.contains(&leader) && labels.contains(&Rival::Effect(e))
                });
                let expected_sigma = pair.map_or(0.0, |p| {
                    let mut q = p.clone();
                    q.add(s, fitted, &drives, weight);
                    q.sigma(noise_w)
                });
                for p in &mut self.open {
                    p.add(s, fitted, &drives, weight);
                }
                self.runs.push(NextRun {
                    repeats: n,
                    separates: vec![leader, Rival::Effect(e)],
                    expected_sigma,
                    observes: Some(Rival::Effect(e)),
                    ..o.run.clone()
                });
                self.budget -= n;
            }
        }
        self.open.retain(|p| p.sigma(noise_w) < TARGET_SIGMA);
    }

    /// Decides, while the budget lasts and pairs are open, the manoeuvre and repeats that settle
    /// the most open pairs per repeat.
    pub(super) fn separate(&mut self) {
        let (s, fitted, noise) = (self.s, self.fitted, self.noise);
        let noise_w = noise.sigma_w();
        while self.budget > 0 && !self.open.is_empty() {
            // The manoeuvre that settles the most open pairs per repeat, then moves the others
            // furthest.
            let before: Vec<f64> = self.open.iter().map(|p| p.sigma(noise_w)).collect();
            let mut best: Option<Step> = None;
            for (oi, o) in self.options.iter().enumerate() {
                let usable: Vec<usize> = (0..self.open.len())
                    .filter(|&p| {
                        self.open[p].increment(s, fitted, &o.row)
                            >= PRACTICAL_FLOOR_W * PRACTICAL_FLOOR_W
                    })
                    .collect();
                if usable.is_empty() {
                    continue;
                }
                for n in o.least_repeats..=o.most_repeats.min(self.budget) {
                    let after: Vec<(usize, f64)> = usable
                        .iter()
                        .map(|&p| {
                            let mut q = self.open[p].clone();
                            q.add(s, fitted, &o.drives(n), noise.repeat_weight(n));
                            (p, q.sigma(noise_w))
                        })
                        .collect();
                    let settled = after.iter().filter(|(_, z)| *z >= TARGET_SIGMA).count();
                    if settled == 0 {
                        continue;
                    }
                    let gain: f64 = after
                        .iter()
                        .map(|&(p, z)| z.min(TARGET_SIGMA) - before[p].min(TARGET_SIGMA))
                        .sum();
                    let step = Step {
                        option: oi,
                        repeats: n,
                        settled_per_repeat: settled as f64 / f64::from(n),
                        gain_per_repeat: gain / f64::from(n),
                        after,
                    };
                    if best.as_ref().is_none_or(|b| step.better_than(b)) {
                        best = Some(step);
                    }
                }
            }
            let Some(step) = best else {
                break;
            };
            let (o, n) = (&self.options[step.option], step.repeats);
            let settled: Vec<(usize, f64)> = step
                .after
                .iter()
                .copied()
                .filter(|(_, z)| *z >= TARGET_SIGMA)
                .collect();
            let mut separates: Vec<Rival> = Vec::new();
            for &(p, _) in &settled {
                for r in self.open[p].labels(fitted) {
                    if !separates.contains(&r) {
                        separates.push(r);
                    }
                }
            }
            let least = settled
                .iter()
                .map(|&(_, z)| z)
                .fold(f64::INFINITY, f64::min);
            for p in &mut self.open {
                p.add(s, fitted, &o.drives(n), noise.repeat_weight(n));
            }
            self.runs.push(NextRun {
                repeats: n,
                separates,
                expected_sigma: least,
                ..o.run.clone()
            });
            self.budget -= n;
            self.open.retain(|p| p.sigma(noise_w) < TARGET_SIGMA);
        }
    }
}

/// One candidate step of the greedy design.
struct Step {
    option: usize,
    repeats: u32,
    settled_per_repeat: f64,
    gain_per_repeat: f64,
    /// Each usable open pair's separation after it [σ].
    after: Vec<(usize, f64)>,
}

impl Step {
    fn better_than(&self, other: &Step) -> bool {
        (self.settled_per_repeat, self.gain_per_repeat)
            > (other.settled_per_repeat, other.gain_per_repeat)
    }
}
