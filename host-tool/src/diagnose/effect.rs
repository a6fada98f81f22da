//! What the diagnosis needs to know about one catalogue effect: the [`Effect`] trait, which each
//! file of [`catalogue`](super::catalogue) implements, and the vocabulary its answers use.
//! Every stage asks the effect through this trait rather than branching on its name, so adding
//! an effect is one file and one line in the catalogue's list (`DESIGN.md`, "How to add an
//! effect").

use super::baseline::Baseline;
use super::features::TurnRow;
use super::signature::{Evidence, Signature};
use crate::effect_id::EffectId;
use model_core::Rover;

/// Most parameters any effect's term has.
pub const MAX_PARAMS: usize = 2;

/// Fewest repeats in a row that show a trend over run time.
pub const MIN_LATE_REPEATS: u32 = 3;

/// What an effect's regressors need besides the row.
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    /// The rover (B, L, m, R').
    pub rover: &'a Rover,
    /// The fitted baseline (for P_side of the multiplicative terms).
    pub baseline: &'a Baseline,
    /// τ of a term that heats the winding [s] (one of
    /// [`HEATING_TAU_GRID_S`](super::winding_heat::HEATING_TAU_GRID_S)).
    pub heating_tau_s: f64,
}

/// When a fitted term's sign is physical (the sign check of the verdict).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SignRule {
    /// Either sign: an offset reads either way, and a term whose resistance the baseline's G
    /// already takes on the straights can leave the turns drawing less.
    Either,
    /// Its coefficient is positive (the term's regressor carries the sign itself).
    PositiveCoefficient,
    /// Its own power over the diagnosed manoeuvres is positive (it adds power).
    AddsPower,
    /// Its coefficient is not negative, unless the turns are quicker by yaw than the terrain
    /// slip says (then a narrower track makes them cheaper).
    NonNegativeUnlessTurnsQuickerByYaw,
}

/// What the data must show before an effect is scored at all.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScoredWhen {
    /// Nothing: always scored.
    Always,
    /// Run time identifiable apart from the turn order (else its term fits the order).
    RunTimeApartFromTurnOrder,
    /// A standstill current beyond a driver's quiescent draw, or no standstill measured.
    StandstillCurrentSeen,
}

/// What a mark is read from: another effect's present mark can hide all marks read from one
/// source ([`Effect::hides`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MarkSource {
    /// The current at standstill.
    StandstillCurrent,
    /// The turns' timing by yaw, or the pose track.
    YawTiming,
    /// The same manoeuvre driven again later in a run.
    Repeats,
    /// The pitch.
    Pitch,
    /// Power rising through a manoeuvre.
    GrowthThroughManoeuvre,
    /// One side's residual of the power model at some radii.
    SideResidual,
}

/// A rise of power through every manoeuvre that another effect makes too: why it is not the
/// rising effect's own mark.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AlsoRises {
    /// The report's words for it ("as a warming winding would too …").
    pub words: &'static str,
    /// Whether this effect's own drives can still tell the two apart (the mark is then
    /// inconclusive, not missing).
    pub told_apart_by_driving: bool,
}

/// Where in a run a manoeuvre is driven.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum When {
    /// Anywhere.
    Any,
    /// Repeated in a row within one run, so that the later repeats meet a warm winding.
    Late,
}

/// A manoeuvre a mark's test reads: what lets it see the mark when the runs given cannot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkDrive {
    /// R/R′, or `None` for a straight (a standstill when `turn_deg` is 0).
    pub r_over_r_prime: Option<f64>,
    /// Turn angle [deg].
    pub turn_deg: f64,
    /// Where in a run.
    pub when: When,
    /// Fewest repeats.
    pub repeats: u32,
}

impl MarkDrive {
    /// A turn at R/R′ = `x` of `deg` degrees, anywhere, `repeats` times.
    pub const fn turn(x: f64, deg: f64, repeats: u32) -> Self {
        Self {
            r_over_r_prime: Some(x),
            turn_deg: deg,
            when: When::Any,
            repeats,
        }
    }
}

/// One segment of a path (thesis Table 6.1) at the path table's v_c, as a path-table term sees
/// it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathSegment {
    /// A straight line (then `dtheta_rad` carries its length [m]).
    pub line: bool,
    /// Its duration [s].
    pub t_s: f64,
    /// R/R′.
    pub rho: f64,
    /// Its hard-ground energy (0 on a line) [J].
    pub e_hg_j: f64,
    /// Whether R is R′ (within the regime bounds).
    pub at_r_prime: bool,
    /// v_c [m/s].
    pub v_mps: f64,
    /// R′ [m].
    pub r_prime_m: f64,
    /// Track width B [m].
    pub width_m: f64,
    /// Wheelbase L [m].
    pub length_m: f64,
    /// R [m] (infinite on a line).
    pub radius_m: f64,
    /// The turn angle [rad] (a line's length [m]).
    pub dtheta_rad: f64,
}

/// The marks tested so far (catalogue order; `None` not yet tested), for a mark that reads
/// another's.
#[derive(Debug, Clone, Copy)]
pub struct Marks<'a> {
    /// Each effect's entry and its mark.
    pub tested: &'a [(&'static dyn Effect, Option<Signature>)],
}

impl Marks<'_> {
    /// Whether some tested mark, of an effect that `of` selects, is present.
    pub fn present_where(&self, of: impl Fn(&dyn Effect) -> bool) -> bool {
        self.tested
            .iter()
            .any(|(e, s)| of(*e) && s.as_ref().is_some_and(Signature::present))
    }

    /// The first effect whose tested mark says it raises power through every manoeuvre too.
    pub fn also_rising(&self) -> Option<(EffectId, AlsoRises)> {
        self.tested.iter().find_map(|(e, s)| {
            let rises = e.also_rises_through_manoeuvres(s.as_ref()?)?;
            Some((e.id(), rises))
        })
    }
}

/// One catalogue effect: everything the diagnosis knows about it. The words of its mark and
/// whether the mark needs the power model are the neutral registry's
/// ([`EffectId::signature`]), shared with the simulator.
pub trait Effect: Sync + std::fmt::Debug {
    /// Its key (the report's and the simulator's id).
    fn id(&self) -> EffectId;

    // Its term in the power model: extra effective power per side, linear in its parameters.

    /// Parameters of its term (at most [`MAX_PARAMS`]).
    fn param_count(&self) -> usize {
        1
    }
    /// Whether it changes the average power (power-type), rather than only lengthening the turn
    /// (time-type). The baseline is fitted on the calibration rows' average power, so a
    /// power-type term is partly absorbed into a and G there (see
    /// [`FittedModel::fit`](super::effects::FittedModel::fit)).
    fn power_type(&self) -> bool {
        true
    }
    /// Whether it makes power rise through a turn, and so also predicts the growth target
    /// (second minus first half of the turn's average power) with its first regressor.
    fn grows(&self) -> bool {
        false
    }
    /// Whether it acts in some regimes only, so its gap may sit in a few of them (one acting on
    /// every manoeuvre is judged on all rows).
    fn confined_to_regimes(&self) -> bool {
        true
    }
    /// Whether its term carries a thermal time constant τ chosen on a grid (one more fitted
    /// parameter).
    fn fits_tau(&self) -> bool {
        false
    }
    /// Its regressors for side `side` of `row` (unused slots 0); `None` when the row lacks what
    /// the term needs, which counts as 0 extra power.
    fn regressors(
        &self,
        row: &TurnRow,
        side: usize,
        ctx: &Context<'_>,
    ) -> Option<[f64; MAX_PARAMS]>;
    /// When its fitted sign is physical.
    fn sign_rule(&self) -> SignRule {
        SignRule::AddsPower
    }
    /// What the data must show before it is scored.
    fn scored_when(&self) -> ScoredWhen {
        ScoredWhen::Always
    }
    /// Whether it scales every turn alike (so it acts where the turns are, straights aside).
    fn scales_every_turn(&self) -> bool {
        false
    }
    /// The report's words when the named term takes power from the diagnosed manoeuvres
    /// (its sign rule lets it): why that is still this effect.
    fn deficit_words(&self) -> Option<&'static str> {
        None
    }

    // Its mark: the observation only it produces.

    /// What its mark is read from.
    fn mark_source(&self) -> MarkSource;
    /// Whether its test reads other effects' marks (it is tested after those that do not).
    fn reads_other_marks(&self) -> bool {
        false
    }
    /// Its mark, tested on `ev`; `marks` holds the marks that read no other.
    fn mark(&self, ev: &Evidence<'_>, marks: &Marks<'_>) -> Signature;
    /// Whether its mark rises from the point turn towards R′ (a mark every turn shares alike
    /// must not).
    fn mark_rises_towards_r_prime(&self) -> bool {
        false
    }
    /// With its own mark present: the report's words for the marks read from `source` that it
    /// hides (what their terms fit there is its doing), or `None` when it hides none there.
    fn hides(&self, _source: MarkSource) -> Option<String> {
        None
    }
    /// Whether, with its mark `own`, it may raise power through every manoeuvre as well.
    fn also_rises_through_manoeuvres(&self, _own: &Signature) -> Option<AlsoRises> {
        None
    }
    /// The manoeuvres its mark's test reads, driven at the runs' highest v_c (none: its mark
    /// is the terrain's, not a manoeuvre's).
    fn drives_to_show_mark(&self) -> Vec<MarkDrive>;
    /// The measurement that reads its mark directly where no manoeuvre tells it from a rival
    /// (a sensor to add), and whether a pose track is it (then one already logged needs no
    /// suggestion).
    fn measurement(&self) -> Measurement;

    // Path-level summaries (thesis Table 6.1).

    /// Its extra energy over `segment` per unit of each parameter [J], or `None` when a path
    /// table cannot show it.
    fn path_segment(&self, _segment: &PathSegment) -> Option<Vec<f64>> {
        None
    }
}

/// A measurement that reads an effect's mark directly ([`Effect::measurement`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Measurement {
    /// What to measure, and what it shows.
    pub what: &'static str,
    /// Whether it is a pose track (the runs may already log one).
    pub pose_track: bool,
}
