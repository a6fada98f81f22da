//! The baseline family (issue 10, part 2): the per-side split of the skid power (regenerating,
//! clamped, or returning a fraction of the generated power), chosen on the calibration
//! manoeuvres by leave-one-run-out cross-validation of their average power; copper loss
//! ([`Baseline::fit_member`] with `copper_loss`) only by escalation, when every copper-free member
//! misfits the calibration (see [`choose_uncached`]). The standstill draw is not a member: it is
//! measured, not fitted (see [`quiescent_draw_w`](super::quiescent_draw_w)).
//!
//! Not a member: the split turning positive past R_T (paper Fig. 11). With R_T ≈ 18 m the fade
//! is ≤ 2–4 % on the calibration radii (≤ 3R′), so it cannot be told from the plain split there,
//! and a fade short enough to be seen (R_f = 4–10 R′) bends the skid term between the point turn
//! and 3R′ and absorbed our simulator's sinkage (a point-turn effect) in the unit tests.
//!
//! Parsimony by the one-standard-error rule: the member with the fewest parameters whose CV
//! mean squared error is within one standard error of the best is chosen, so the plain model
//! (the paper's) wins whenever it fits. The returning member's fraction is a continuous
//! parameter, fitted inside each training fold (least squares over [0, 1]), and tried only when
//! the training manoeuvres have a generating side to identify it (an inner side beyond R′).

use super::{Baseline, BaselineError, Split, Structure};
use crate::diagnose::adequacy;
use crate::diagnose::features::TurnRow;
use crate::diagnose::observe;
use model_core::search::golden_section_min;
use model_core::Rover;
use serde::Serialize;
use std::cell::RefCell;

/// Which members the family chooses from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Members {
    /// The copper-free members, and the copper-loss ones by escalation when they all misfit
    /// the calibration ([`choose_uncached`]).
    #[default]
    Escalating,
    /// The copper-loss members only: what the diagnosed runs may show past what the
    /// calibration manoeuvres can (`diagnose`'s copper-loss check on the test runs).
    CopperLoss,
}

/// A member of the family: a fixed structure, or the returning split whose fraction is a
/// continuous parameter fitted on the training manoeuvres.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Member {
    /// A structure with nothing beyond a, G (and c) to fit.
    Fixed(Structure),
    /// [`Split::Returning`] with the fraction fitted in [0, 1] (least training RSS).
    Returning {
        /// Whether copper loss is modelled too.
        copper_loss: bool,
    },
}

impl Member {
    fn parameters(self) -> usize {
        match self {
            Member::Fixed(s) => s.parameters(),
            Member::Returning { copper_loss } => 3 + usize::from(copper_loss),
        }
    }

    fn with_copper_loss(self) -> Member {
        match self {
            Member::Fixed(s) => Member::Fixed(Structure {
                copper_loss: true,
                ..s
            }),
            Member::Returning { .. } => Member::Returning { copper_loss: true },
        }
    }
}

/// The family in parsimony order (fewest parameters first; ties: listed order).
fn copper_free() -> Vec<Member> {
    // Copper loss (`Structure::copper_loss`) is not an ordinary member (`copper_members` is
    // tried only when these all misfit): as a member it absorbed part of a current offset and
    // of point-turn sinkage (our unit tests' current-offset and sand worlds turned `ambiguous`;
    // the independent generator's dev seeds fell from 39/48 to 35/48 effects right). The
    // returning member carries most of the regeneration-efficiency misfit that copper loss +
    // efficiency make.
    let mut out = vec![
        Member::Fixed(Structure::PLAIN),
        Member::Fixed(Structure {
            split: Split::Returning { fraction: 0.0 },
            copper_loss: false,
        }),
        Member::Returning { copper_loss: false },
    ];
    out.sort_by_key(|m| m.parameters());
    out
}

/// The family's members with copper loss added: tried only when every member of [`copper_free`]
/// misfits its calibration (see [`choose_uncached`]), or when [`Members::CopperLoss`] asks.
fn copper_members() -> Vec<Member> {
    copper_free()
        .into_iter()
        .map(Member::with_copper_loss)
        .collect()
}

/// Golden-section steps of the returned fraction: the bracket [0, 1] shrinks to 0.618^n, about
/// 0.003 (a driver's efficiency is not known better than that).
const FRACTION_STEPS: usize = 12;

/// `member` fitted on `train` (the returning member's fraction by least training RSS); `None`
/// if it cannot be fitted, or when no training side generates: then the fraction is not
/// identified by these manoeuvres and the member is not tried.
fn fit_best(rover: &Rover, train: &[&TurnRow], member: Member) -> Option<Baseline> {
    let fit = |s: Structure| {
        Baseline::fit_member(rover, train, s)
            .ok()
            .map(|b| (rss(&b, train), b))
            .filter(|(r, _)| r.is_finite())
    };
    let copper_loss = match member {
        Member::Fixed(s) => return fit(s).map(|(_, b)| b),
        Member::Returning { copper_loss } => copper_loss,
    };
    let at = |fraction: f64| {
        fit(Structure {
            split: Split::Returning { fraction },
            copper_loss,
        })
    };
    if !generates(&at(1.0)?.1, train) {
        return None;
    }
    let score = |f: f64| at(f).map_or(f64::INFINITY, |(r, _)| r);
    let (fraction, _) = golden_section_min(score, 0.0, 1.0, 0.0, FRACTION_STEPS);
    at(fraction).map(|(_, b)| b)
}

/// Whether some side of `rows` draws negative motor power under `b` (a regenerating fit): only
/// then do the manoeuvres say what a driver returns.
fn generates(b: &Baseline, rows: &[&TurnRow]) -> bool {
    rows.iter()
        .any(|r| (0..2).any(|s| b.motor_power_w(r, s) < 0.0))
}

fn squared_errors<'a>(b: &'a Baseline, rows: &'a [&TurnRow]) -> impl Iterator<Item = f64> + 'a {
    rows.iter().flat_map(move |row| {
        observe::observations(row).iter().map(move |sides| {
            let model: f64 = sides
                .iter()
                .map(|&s| b.calibration_side_power_w(row, s))
                .sum();
            (observe::measured_avg_w(row, sides) - model).powi(2)
        })
    })
}

fn rss(b: &Baseline, rows: &[&TurnRow]) -> f64 {
    squared_errors(b, rows).sum()
}

/// Held-out squared errors of one member over leave-one-run-out folds; `None` if a fold cannot
/// be fitted.
fn cv_errors(
    rover: &Rover,
    calibration: &[&TurnRow],
    runs: &[usize],
    m: Member,
) -> Option<Vec<f64>> {
    let mut errors = Vec::new();
    for &run in runs {
        let (test, train): (Vec<&TurnRow>, Vec<&TurnRow>) =
            calibration.iter().partition(|r| r.run_index == run);
        let b = fit_best(rover, &train, m)?;
        errors.extend(squared_errors(&b, &test));
    }
    errors.iter().all(|e| e.is_finite()).then_some(errors)
}

/// Chooses the member (see the module docs) and refits it on all `calibration` rows. With fewer
/// than 2 calibration runs there is nothing to cross-validate: the plain member.
pub fn choose(
    rover: &Rover,
    calibration: &[&TurnRow],
    members: Members,
) -> Result<Baseline, BaselineError> {
    let key = key_of(rover, calibration, members);
    let memo = CHOSEN.with(|c| c.borrow().iter().find(|(k, _)| *k == key).map(|(_, v)| *v));
    if let Some((structure, cv_rmse_w, turn_slip, copper_refused)) = memo {
        let mut b = Baseline::fit_member(rover, calibration, structure)?;
        b.cv_rmse_w = cv_rmse_w;
        b.turn_slip = turn_slip;
        b.copper_refused = copper_refused;
        return Ok(b);
    }
    let b = choose_uncached(rover, calibration, members)?;
    CHOSEN.with(|c| {
        let mut c = c.borrow_mut();
        if c.len() >= MEMO_CAPACITY {
            c.remove(0);
        }
        c.push((
            key,
            (b.structure, b.cv_rmse_w, b.turn_slip, b.copper_refused),
        ));
    });
    Ok(b)
}

/// Identity of a calibration set: rover and each row's run, manoeuvre and measured powers.
type Key = Vec<[u64; 4]>;

fn key_of(rover: &Rover, calibration: &[&TurnRow], members: Members) -> Key {
    // The measured slip track decides the turn slip too (`explained_by_slip_track`).
    let measured = calibration
        .iter()
        .find_map(|r| r.measured)
        .map_or(0, |m| m.slip_track_m.to_bits());
    let mut key = vec![[
        u64::from(rover.slip_track_m.to_bits()),
        u64::from(rover.track_width_m.to_bits()),
        measured,
        members as u64,
    ]];
    key.extend(calibration.iter().map(|r| {
        [
            r.run_index as u64,
            r.manoeuvre as u64,
            r.sides[0].avg_power_w.to_bits(),
            r.sides[1].avg_power_w.to_bits() ^ observe::measured_avg_w(r, &[0, 1]).to_bits(),
        ]
    }));
    key
}

/// A remembered choice: the member, its CV RMS error [W], the turn slip and the copper-loss
/// member refused.
type Choice = (Structure, Option<f64>, f64, Option<super::Refused>);

/// Calibration sets remembered per thread.
const MEMO_CAPACITY: usize = 16;

thread_local! {
    /// The choice is a pure function of the calibration set, and a diagnosis refits the
    /// baseline on the same sets many times (every effect candidate, every fold): remember it
    /// so the cross-validation runs once per set (the 20 ms per dataset budget).
    static CHOSEN: RefCell<Vec<(Key, Choice)>> = const { RefCell::new(Vec::new()) };
}

fn choose_uncached(
    rover: &Rover,
    calibration: &[&TurnRow],
    members: Members,
) -> Result<Baseline, BaselineError> {
    // Pitched manoeuvres take part: each fit carries the calibration's slope as a nuisance
    // (`Baseline::calibration_grade_n`), so a calibration on undulating ground still chooses.
    let mut runs: Vec<usize> = calibration.iter().map(|r| r.run_index).collect();
    runs.sort_unstable();
    runs.dedup();
    if runs.len() < 2 {
        return Baseline::fit_plain(rover, calibration);
    }
    let level: Vec<&TurnRow> = calibration
        .iter()
        .copied()
        .filter(|r| adequacy::is_level(r))
        .collect();
    let turn_slip = constant_turn_slip(&level)
        .filter(|&s| !explained_by_slip_track(rover, &level, s))
        .unwrap_or(0.0);
    if members == Members::CopperLoss {
        return pick(rover, calibration, &runs, copper_members(), turn_slip)?
            .map_or_else(|| Baseline::fit_plain(rover, calibration), Ok);
    }
    let Some(plain) = pick(rover, calibration, &runs, copper_free(), turn_slip)? else {
        return Baseline::fit_plain(rover, calibration);
    };
    let mut plain = plain;
    if misfits(&plain, calibration) {
        // Escalation: copper loss is admitted only when the simpler family cannot fit the
        // calibration manoeuvres at all. As an ordinary member it absorbed current offsets and
        // point-turn sinkage in worlds the plain family fits (see `members`).
        if let Some(copper) = pick(rover, calibration, &runs, copper_members(), turn_slip)? {
            let fit = adequacy_of(&copper, calibration);
            if fits_testably(&fit) {
                return Ok(copper);
            }
            // Refused: the report says it was tried, so a user does not try it again.
            plain.copper_refused = Some(super::Refused {
                structure: copper.structure,
                cv_rmse_w: copper.cv_rmse_w,
                lack_of_fit_rms_w: fit
                    .per_side
                    .as_ref()
                    .unwrap_or(&fit.total)
                    .lack_of_fit_rms_w,
            });
        }
    }
    Ok(plain)
}

/// The member of `family` chosen by the one-standard-error rule on leave-one-run-out CV,
/// refitted on all `calibration` rows; `None` when no member can be cross-validated.
fn pick(
    rover: &Rover,
    calibration: &[&TurnRow],
    runs: &[usize],
    family: Vec<Member>,
    turn_slip: f64,
) -> Result<Option<Baseline>, BaselineError> {
    let scored: Vec<(Member, f64, f64)> = family
        .into_iter()
        .filter_map(|m| {
            let e = cv_errors(rover, calibration, runs, m)?;
            let (mean, se) = mean_and_se(&e)?;
            Some((m, mean, se))
        })
        .collect();
    let Some(best) = scored.iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
        return Ok(None);
    };
    let bar = best.1 + best.2;
    let chosen = scored
        .iter()
        .find(|(_, mse, _)| *mse <= bar)
        .unwrap_or(best);
    let mut b = fit_best(rover, calibration, chosen.0)
        .map_or_else(|| Baseline::fit_plain(rover, calibration), Ok)?;
    b.cv_rmse_w = Some(chosen.1.sqrt());
    b.turn_slip = turn_slip;
    Ok(Some(b))
}

/// `b`'s lack-of-fit tests on its own `calibration` manoeuvres, as fitted (with the
/// calibration's slope nuisance).
fn adequacy_of(b: &Baseline, calibration: &[&TurnRow]) -> adequacy::Adequacy {
    adequacy::test(calibration, b.structure.parameters(), |r, s| {
        b.calibration_side_power_w(r, s)
    })
}

/// Whether a member fits its own calibration manoeuvres statistically (`a`, its
/// [`adequacy_of`]): at least one lack-of-fit test (total, per side) has degrees of freedom to
/// spare, and none rejects at [`adequacy::ALPHA`] (the practical floor's leniency is not given:
/// escalating to a larger member must be earned by the data, or it bends a and c around an
/// effect such as point-turn sinkage).
fn fits_testably(a: &adequacy::Adequacy) -> bool {
    let p_values: Vec<f64> = [Some(&a.total), a.per_side.as_ref()]
        .into_iter()
        .flatten()
        .filter_map(|t| t.p_value)
        .collect();
    !p_values.is_empty() && p_values.iter().all(|&p| p >= adequacy::ALPHA)
}

/// Whether `b` fails the lack-of-fit test on its own `calibration` manoeuvres.
fn misfits(b: &Baseline, calibration: &[&TurnRow]) -> bool {
    adequacy_of(b, calibration).adequate == Some(false)
}

/// Whether the calibration turns' constant slip `slip` is what their pose track measured: a
/// slip track B_s,meas wider than the controller's makes every turn slower by
/// 1 − B_s,ctrl/B_s,meas (Eq 2.2, Appendix D). Then it is the `slip-track` effect, seen
/// directly, not a terrain constant for the baseline to absorb.
fn explained_by_slip_track(rover: &Rover, level: &[&TurnRow], slip: f64) -> bool {
    let mut tracks: Vec<f64> = level
        .iter()
        .filter(|r| !r.is_straight())
        .filter_map(|r| Some(r.measured?.slip_track_m))
        .collect();
    if tracks.is_empty() {
        return false;
    }
    tracks.sort_by(f64::total_cmp);
    let measured = tracks[tracks.len() / 2];
    let implied = 1.0 - f64::from(rover.slip_track_m) / measured;
    (implied - slip).abs() <= MAX_SLIP_SPREAD
}

/// Smallest constant slip taken into the baseline (below it, timing noise).
const MIN_TURN_SLIP: f64 = 0.01;

/// Largest spread of the calibration radii's mean slips around their common mean for the slip
/// to count as constant (a radius-dependent slip is the `angular-slip` effect).
pub(crate) const MAX_SLIP_SPREAD: f64 = 0.02;

/// The calibration turns' common angular slip (Eq 6.3) when it is significant (95 % t interval
/// above 0), at least [`MIN_TURN_SLIP`], and the same at every calibration radius within
/// [`MAX_SLIP_SPREAD`].
fn constant_turn_slip(level: &[&TurnRow]) -> Option<f64> {
    let turns: Vec<&TurnRow> = level
        .iter()
        .copied()
        .filter(|r| !r.is_straight() && r.turned_from_yaw && r.angular_slip.is_some())
        .collect();
    let slips: Vec<f64> = turns.iter().filter_map(|r| r.angular_slip).collect();
    let (mean, lo, _) = crate::diagnose::stats::t_interval(&slips)?;
    if !(lo > 0.0 && (MIN_TURN_SLIP..1.0).contains(&mean)) {
        return None;
    }
    let mut radii: Vec<i64> = turns
        .iter()
        .map(|r| (r.r_over_r_prime * 100.0).round() as i64)
        .collect();
    radii.sort_unstable();
    radii.dedup();
    let same = radii.iter().all(|&k| {
        let at: Vec<f64> = turns
            .iter()
            .filter(|r| (r.r_over_r_prime * 100.0).round() as i64 == k)
            .filter_map(|r| r.angular_slip)
            .collect();
        let m = at.iter().sum::<f64>() / at.len() as f64;
        (m - mean).abs() <= MAX_SLIP_SPREAD
    });
    same.then_some(mean)
}

/// Mean and its standard error; `None` with fewer than 2 values.
fn mean_and_se(e: &[f64]) -> Option<(f64, f64)> {
    if e.len() < 2 {
        return None;
    }
    let n = e.len() as f64;
    let mean = e.iter().sum::<f64>() / n;
    let var = e.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    Some((mean, (var / n).sqrt()))
}

impl Baseline {
    /// The baseline family's member chosen by leave-one-run-out cross-validation on the
    /// `calibration` rows (one-standard-error rule), refitted on all of them.
    pub fn fit(rover: &Rover, calibration: &[&TurnRow]) -> Result<Baseline, BaselineError> {
        choose(rover, calibration, Members::Escalating)
    }
}
