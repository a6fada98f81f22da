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

mod design;
mod drivable;
mod identifiability;
mod noise;
mod pair;
mod rival;
mod scenario;
pub(crate) mod suggestion;

use super::calibration::Calibration;
use super::catalogue;
use super::diagnosis::Diagnosis;
pub use super::effect::{When, MIN_LATE_REPEATS};
use super::features::TurnRow;
use design::{open_pairs, options, unseen_marks, Design};
pub use drivable::{MAX_MANOEUVRES, MAX_REPEATS, RADII, TURN_DEG};
pub use identifiability::MAX_CANDIDATES_IN_PLAY;
use identifiability::{rivals_in_play, statements_on};
use model_core::Rover;
use noise::measure_noise;
use pair::{pairs_driven, separation};
pub use pair::{PairSeparation, TARGET_SIGMA};
use rival::{fit_rivals, Setting};
pub use rival::{Rival, Unfitted};
pub use suggestion::{Identifiability, NextRun, NextRuns, SuggestedMeasurement};

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
    let (noise, noise_from) = measure_noise(&train, d);
    let noise_w = noise.sigma_w();
    let pairs = pairs_driven(&s, &fitted, &train);
    let in_play = rivals_in_play(d, &fitted, &pairs, noise_w);
    let statements = statements_on(rows, &not_fitted, &in_play);
    let identifiability = Identifiability {
        noise_sigma_w: noise_w,
        noise_from,
        pairs: pairs
            .iter()
            .map(|p| separation(p, &fitted, noise_w))
            .collect(),
        not_fitted,
        statements,
    };
    let open = open_pairs(&pairs, &fitted, &in_play, noise_w);
    let unseen = unseen_marks(d, &in_play);
    let options = options(&s, rows, &in_play, &open, &unseen);
    let mut design = Design::new(&s, &fitted, noise, options, open);
    design.show_marks(&unseen, &in_play, &pairs);
    design.separate();
    let unresolved: Vec<PairSeparation> = design
        .open
        .iter()
        .map(|p| separation(p, &fitted, noise_w))
        .collect();
    let measurements = measurements_for(rows, &in_play, &unresolved, design.runs.is_empty());
    NextRuns {
        identifiability,
        in_play,
        runs: design.runs,
        unresolved,
        measurements,
    }
}

/// The measurements of the effects in play that no manoeuvre settles: those in an unresolved
/// pair, or all of them when nothing is left to drive; a pose track only when the runs log
/// none.
fn measurements_for(
    rows: &[TurnRow],
    in_play: &[Rival],
    unresolved: &[PairSeparation],
    nothing_to_drive: bool,
) -> Vec<SuggestedMeasurement> {
    let posed = rows.iter().any(|r| r.measured.is_some());
    let stuck: Vec<Rival> = if nothing_to_drive {
        in_play.to_vec()
    } else {
        unresolved.iter().flat_map(|p| p.rivals).collect()
    };
    let mut out: Vec<SuggestedMeasurement> = Vec::new();
    for rival in stuck {
        let Rival::Effect(effect) = rival else {
            continue;
        };
        let m = catalogue::of(effect).measurement();
        if (m.pose_track && posed) || out.iter().any(|o| o.effect == effect) {
            continue;
        }
        out.push(SuggestedMeasurement {
            effect,
            what: m.what,
        });
    }
    out
}

#[cfg(test)]
mod tests;
