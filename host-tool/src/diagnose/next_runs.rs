//! What to drive next: which rivals the runs given can tell apart, and the fewest extra
//! manoeuvres that would separate the ones an open verdict leaves in play.
//!
//! Model discrimination (Box and Hill 1967; Atkinson and Fedorov's T-optimality). Each rival —
//! the baseline alone (`none`), the copper-loss structure, each catalogue effect — is fitted to
//! the runs as the diagnosis fits it. Rival a is told apart from rival b on a set of manoeuvres
//! when b, with the baseline's skid force and rolling resistance free to move too, cannot
//! reproduce a's predicted extra power there: the residual sum of squares of that fit over σ²
//! is the non-centrality of the test that rejects b when a is true, and its root is the
//! separation in σ. σ is what a new manoeuvre meets: the repeat noise and the misfit the best
//! model leaves out of sample, which repeats do not average away. A pair is separated when
//! that reaches [`TARGET_SIGMA`] both ways (one way against the baseline alone, which every
//! rival nests).
//!
//! The manoeuvres are chosen greedily from what the rover can drive: 90° and 180° turns at
//! the thesis' turn set (R/R′ ∈ [`RADII`]) and straights, at the lowest and highest v_c of the
//! runs, in the runs' turn direction, or (when a warming winding is in play) one repeated in a
//! row so that the later repeats meet a warm winding; each repeated at most [`MAX_REPEATS`]
//! times and at most [`MAX_MANOEUVRES`] in all.
//! Each step takes the manoeuvre that separates the most open pairs per repeat. A manoeuvre
//! counts for a pair only where the rivals differ there by at least the diagnosis' practical
//! floor: a smaller difference would not move a signature test, however often repeated.
//!
//! A name needs its mark (issue 35), so a rival is in play only while it could be named: its
//! mark present, or not observable yet on these runs. Before any power separation, each rival
//! of the second kind gets the manoeuvres its signature test reads
//! ([`Effect::drives_to_show_mark`](super::effect::Effect::drives_to_show_mark)).

mod drivable;
mod identifiability;
mod noise;
mod pair;
mod rival;
mod scenario;
mod suggestion;

use super::calibration::Calibration;
use super::catalogue;
use super::effect::MarkDrive;
pub use super::effect::{When, MIN_LATE_REPEATS};
use super::features::TurnRow;
use super::gaps::MIN_TREND_SPREAD_S;
use super::stats::PRACTICAL_FLOOR_W;
use super::verdict::Verdict;
use super::Diagnosis;
use crate::effect_id::EffectId;
use drivable::{drivable, shown_late, thousandths};
pub use drivable::{MAX_MANOEUVRES, MAX_REPEATS, RADII, TURN_DEG};
use identifiability::in_play;
pub use identifiability::{Identifiability, MAX_CANDIDATES_IN_PLAY};
use model_core::Rover;
use noise::{repeat_noise, Noise};
use pair::Pair;
pub use pair::{PairSeparation, TARGET_SIGMA};
use rival::{fit_rivals, Setting};
pub use rival::{Rival, Unfitted};
pub use suggestion::{NextRun, NextRuns};

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

/// What to drive next after diagnosis `d` of `rows` (calibrated as `calibration`, with the
/// members `d`'s baseline came from).
pub fn plan(
    rover: &Rover,
    rows: &[TurnRow],
    calibration: Calibration<'_>,
    d: &Diagnosis,
) -> NextRuns {
    let s = Setting {
        rover,
        baseline: &d.baseline,
    };
    let train = calibration.training_rows(rows);
    let fitted_on = calibration.manoeuvres(rows);
    let (fitted, not_fitted) = fit_rivals(&s, &train, &fitted_on);
    let (repeat_w, repeat_from) = repeat_noise(&train, d);
    let noise = Noise::of(repeat_w, d);
    let noise_w = noise.sigma_w();
    let noise_from = format!(
        "repeat noise {repeat_w:.2} W ({repeat_from}) and {:.2} W the best model leaves \
         unexplained out of sample, the same on every repeat",
        noise.misfit_w
    );

    // Every pair over the manoeuvres driven.
    let mut pairs: Vec<Pair> = Vec::new();
    for a in 0..fitted.len() {
        for b in a + 1..fitted.len() {
            let mut p = Pair::new(&fitted, a, b);
            p.add(&s, &fitted, train.iter().copied(), 1.0);
            pairs.push(p);
        }
    }
    let separation = |p: &Pair| {
        let sigma = p.sigma(noise_w);
        PairSeparation {
            rivals: p.labels(&fitted),
            sigma,
            separable: sigma >= TARGET_SIGMA,
        }
    };
    let in_play: Vec<Rival> = in_play(d)
        .into_iter()
        .filter(|r| fitted.iter().any(|f| f.rival == *r))
        .collect();
    // A named effect stays open only against the runner-ups the runs do not separate from it.
    let in_play: Vec<Rival> = match d.effect {
        Verdict::Effect(e) => {
            let named = Rival::Effect(e);
            let unseparated = |r: &Rival| {
                pairs.iter().any(|p| {
                    let labels = p.labels(&fitted);
                    labels.contains(&named) && labels.contains(r) && p.sigma(noise_w) < TARGET_SIGMA
                })
            };
            in_play
                .into_iter()
                .filter(|r| *r == named || unseparated(r))
                .collect()
        }
        _ => in_play,
    };
    let in_play = if in_play.len() >= 2 {
        in_play
    } else {
        Vec::new()
    };
    let mut statements = Vec::new();
    if rows.iter().all(|r| r.measured.is_none()) {
        statements.push(
            "without a pose track, a slip track off the terrain's and a terrain-wide angular \
             slip are the same in timing and power: slip-track is read only as every turn \
             slipping alike beyond the calibration's terrain slip"
                .into(),
        );
    }
    for u in &not_fitted {
        if in_play.contains(&u.rival) {
            statements.push(format!(
                "{} cannot be fitted on these runs: {}",
                u.rival.label(),
                u.why
            ));
        }
    }
    let identifiability = Identifiability {
        noise_sigma_w: noise_w,
        noise_from,
        pairs: pairs.iter().map(separation).collect(),
        not_fitted,
        statements,
    };

    // Repeats in a row only when an effect whose mark late repeats show is in play (a warming
    // winding's trend over run time).
    let late = in_play
        .iter()
        .any(|r| matches!(r, Rival::Effect(e) if shown_late(*e)));
    let mut open: Vec<Pair> = pairs
        .iter()
        .filter(|p| {
            let [a, b] = p.labels(&fitted);
            in_play.contains(&a) && in_play.contains(&b) && p.sigma(noise_w) < TARGET_SIGMA
        })
        .cloned()
        .collect();
    // Rivals whose own mark these runs cannot test yet, or show in size but short of the
    // noise: the drives their signature test reads come first, whatever their power says (a
    // mark, not a fit, decides a name).
    // A mark another effect makes too needs that effect's drives as well, to tell them apart.
    let mut unseen: Vec<EffectId> = Vec::new();
    for r in &in_play {
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
    let options = if open.is_empty() && unseen.is_empty() {
        Vec::new()
    } else {
        drivable(&s, rows, late || unseen.iter().any(|&e| shown_late(e)))
    };
    let mut runs: Vec<NextRun> = Vec::new();
    let mut budget = MAX_MANOEUVRES;
    let fastest = options.iter().map(|o| o.run.v_c_mps).fold(0.0, f64::max);
    for &e in &unseen {
        let leader = in_play[0];
        for MarkDrive {
            r_over_r_prime: x,
            turn_deg,
            when,
            repeats: n,
        } in catalogue::of(e).drives_to_show_mark()
        {
            let Some(o) = options.iter().find(|o| {
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
            if n > budget {
                continue;
            }
            let (drives, weight) = (o.drives(n), noise.repeat_weight(n));
            let pair = pairs.iter().find(|p| {
                let labels = p.labels(&fitted);
                labels.contains(&leader) && labels.contains(&Rival::Effect(e))
            });
            let expected_sigma = pair.map_or(0.0, |p| {
                let mut q = p.clone();
                q.add(&s, &fitted, &drives, weight);
                q.sigma(noise_w)
            });
            for p in &mut open {
                p.add(&s, &fitted, &drives, weight);
            }
            runs.push(NextRun {
                repeats: n,
                separates: vec![leader, Rival::Effect(e)],
                expected_sigma,
                observes: Some(Rival::Effect(e)),
                ..o.run.clone()
            });
            budget -= n;
        }
    }
    open.retain(|p| p.sigma(noise_w) < TARGET_SIGMA);
    while budget > 0 && !open.is_empty() {
        // The manoeuvre that settles the most open pairs per repeat, then moves the others
        // furthest.
        let before: Vec<f64> = open.iter().map(|p| p.sigma(noise_w)).collect();
        let mut best: Option<Step> = None;
        for (oi, o) in options.iter().enumerate() {
            let usable: Vec<usize> = (0..open.len())
                .filter(|&p| {
                    open[p].increment(&s, &fitted, &o.row) >= PRACTICAL_FLOOR_W * PRACTICAL_FLOOR_W
                })
                .collect();
            if usable.is_empty() {
                continue;
            }
            for n in o.least_repeats..=o.most_repeats.min(budget) {
                let after: Vec<(usize, f64)> = usable
                    .iter()
                    .map(|&p| {
                        let mut q = open[p].clone();
                        q.add(&s, &fitted, &o.drives(n), noise.repeat_weight(n));
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
        let (o, n) = (&options[step.option], step.repeats);
        let settled: Vec<(usize, f64)> = step
            .after
            .iter()
            .copied()
            .filter(|(_, z)| *z >= TARGET_SIGMA)
            .collect();
        let mut separates: Vec<Rival> = Vec::new();
        for &(p, _) in &settled {
            for r in open[p].labels(&fitted) {
                if !separates.contains(&r) {
                    separates.push(r);
                }
            }
        }
        let least = settled
            .iter()
            .map(|&(_, z)| z)
            .fold(f64::INFINITY, f64::min);
        for p in &mut open {
            p.add(&s, &fitted, &o.drives(n), noise.repeat_weight(n));
        }
        runs.push(NextRun {
            repeats: n,
            separates,
            expected_sigma: least,
            ..o.run.clone()
        });
        budget -= n;
        open.retain(|p| p.sigma(noise_w) < TARGET_SIGMA);
    }
    let unresolved = open.iter().map(separation).collect();
    NextRuns {
        identifiability,
        in_play,
        runs,
        unresolved,
    }
}

#[cfg(test)]
mod tests;
