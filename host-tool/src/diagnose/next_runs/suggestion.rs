//! The suggestions: one manoeuvre to drive, and what to drive next in all (the identifiability
//! table, the rivals in play, the manoeuvres, the pairs left unresolved): the types the
//! diagnosis' result carries.

use super::super::effect::When;
use super::pair::PairSeparation;
use super::rival::{Rival, Unfitted};
use crate::effect_id::EffectId;
use crate::scenario::Side;
use serde::Serialize;

/// Which rivals the runs given can tell apart.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Identifiability {
    /// The repeat noise of one side of one manoeuvre the separations are in [W].
    pub noise_sigma_w: f64,
    /// Where it was measured.
    pub noise_from: String,
    /// Every pair of fitted rivals.
    pub pairs: Vec<PairSeparation>,
    /// Rivals the runs cannot fit at all.
    pub not_fitted: Vec<Unfitted>,
    /// What the data cannot tell apart, in words.
    pub statements: Vec<String>,
}

/// One suggested manoeuvre.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NextRun {
    /// R/R′; `None` for a straight.
    pub r_over_r_prime: Option<f64>,
    /// R [m]; `None` for a straight.
    pub radius_m: Option<f64>,
    /// A straight's length [m]; `None` for a turn.
    pub distance_m: Option<f64>,
    /// v_c [m/s] (a straight's speed).
    pub v_c_mps: f64,
    /// Turn angle [deg] (0 for a straight).
    pub turn_deg: f64,
    /// Side of the turn.
    pub direction: Side,
    /// How many times in a row.
    pub repeats: u32,
    /// Where in a run.
    pub when: When,
    /// The rivals of the pairs it separates.
    pub separates: Vec<Rival>,
    /// The smallest separation of those pairs once it is driven [σ].
    pub expected_sigma: f64,
    /// The rival whose own mark it lets the signature test read (the test cannot on the runs
    /// given), when that is what it is driven for.
    pub observes: Option<Rival>,
}

/// What to drive next.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct NextRuns {
    /// Which rivals the runs separate.
    pub identifiability: Identifiability,
    /// The rivals the verdict leaves in play (empty when it is settled).
    pub in_play: Vec<Rival>,
    /// The manoeuvres to drive, in order.
    pub runs: Vec<NextRun>,
    /// Pairs in play no manoeuvre within the limits separates.
    pub unresolved: Vec<PairSeparation>,
    /// What to measure where manoeuvres cannot settle the verdict: each effect in play whose
    /// mark a sensor reads directly (a pose track, encoders, a thermistor), when it is in a pair
    /// no manoeuvre separates or nothing is left to drive.
    pub measurements: Vec<SuggestedMeasurement>,
}

/// A measurement to add ([`crate::diagnose::effect::Effect::measurement`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SuggestedMeasurement {
    /// The effect whose mark it reads.
    pub effect: EffectId,
    /// What to measure, and what it shows.
    pub what: &'static str,
}

impl NextRuns {
    /// Whether the verdict is open (rivals in play).
    pub fn open(&self) -> bool {
        !self.in_play.is_empty()
    }

    /// Manoeuvres the scenario drives (repeats and the list's repeats counted).
    pub fn manoeuvres(&self) -> u32 {
        self.runs.iter().map(|r| r.repeats).sum()
    }
}

impl NextRun {
    /// One line: `3 × 90° left turn at R = 0.67 R′ (0.37 m), v_c 0.30 m/s — separates …`.
    pub fn describe(&self) -> String {
        let what = match (self.r_over_r_prime, self.radius_m) {
            (Some(x), Some(r)) => format!(
                "{:.0}° {} turn at R = {x:.2} R′ ({r:.2} m), v_c {:.2} m/s",
                self.turn_deg,
                match self.direction {
                    Side::Left => "left",
                    Side::Right => "right",
                },
                self.v_c_mps
            ),
            _ => format!(
                "{:.1} m straight at {:.2} m/s",
                self.distance_m.unwrap_or(0.0),
                self.v_c_mps
            ),
        };
        let when = match self.when {
            When::Any => "",
            When::Late => " in a row (the later ones on a warm winding)",
        };
        let observes = match self.observes {
            Some(r) => format!(": lets {}'s own mark be tested", r.label()),
            None => String::new(),
        };
        format!(
            "{} × {what}{when}{observes}: separates {} by {:.1}σ",
            self.repeats,
            self.separates
                .iter()
                .map(|r| r.label())
                .collect::<Vec<_>>()
                .join(" / "),
            self.expected_sigma
        )
    }
}
