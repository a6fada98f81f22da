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

use super::baseline::{self, Baseline};
use super::calibration::Calibration;
use super::catalogue;
use super::cv::CLEAR_MARGIN;
use super::effect::{Context, MarkDrive};
pub use super::effect::{When, MIN_LATE_REPEATS};
use super::effects::{self, FittedModel, HEATING_TAU_GRID_S};
use super::features::{Observed, TurnRow};
use super::gaps::MIN_TREND_SPREAD_S;
use super::model_file::{synthetic_row, Conditions};
use super::observe;
use super::stats::upper_median;
use super::stats::PRACTICAL_FLOOR_W;
use super::verdict::Verdict;
use super::Diagnosis;
use crate::effect_id::EffectId;
use crate::scenario::{Manoeuvre, Scenario, Side};
use model_core::fit::LinearFit;
use model_core::kinematics::TurnDirection;
use model_core::Rover;
use serde::{Serialize, Serializer};
use std::fmt::Write as _;

/// Separation a pair needs [σ].
pub const TARGET_SIGMA: f64 = 3.0;
/// Most extra manoeuvres one round suggests (repeats counted).
pub const MAX_MANOEUVRES: u32 = 10;
/// Most repeats of one suggested manoeuvre.
pub const MAX_REPEATS: u32 = 5;
/// Most ranked candidates an open verdict keeps in play.
pub const MAX_CANDIDATES_IN_PLAY: usize = 3;
/// The radii suggestions are drawn from, R/R′ (the thesis' turn set, 0.8 R′ and 3 R′).
pub const RADII: [f64; 8] = [0.0, 1.0 / 3.0, 2.0 / 3.0, 0.8, 1.0, 4.0 / 3.0, 2.0, 3.0];
/// The turn angles suggestions are drawn from [deg] (a longer turn shows growth through it).
pub const TURN_DEG: [f64; 2] = [90.0, 180.0];
/// Standstill between the scenario's manoeuvres and before and after them [s] (the
/// scenario file's defaults).
const PAUSE_S: f64 = 2.0;
/// Straight length when the runs have no straight [m].
const DEFAULT_STRAIGHT_M: f64 = 2.0;
/// The smallest noise σ taken, a fraction of the practical floor (a perfectly repeatable
/// simulation would otherwise make every difference infinitely many σ).
const MIN_SIGMA_OF_FLOOR: f64 = 0.05;

/// A hypothesis the next runs should tell apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rival {
    /// The baseline alone.
    None,
    /// The baseline with copper loss (the baseline family's escalation member).
    CopperLoss,
    /// The baseline with a catalogue effect.
    Effect(EffectId),
}

impl Rival {
    /// `none`, `copper-loss` or the effect id.
    pub const fn label(self) -> &'static str {
        match self {
            Rival::None => "none",
            Rival::CopperLoss => "copper-loss",
            Rival::Effect(e) => e.id(),
        }
    }
}

impl Serialize for Rival {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.label())
    }
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

/// How far the runs separate two rivals.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PairSeparation {
    /// The two rivals.
    pub rivals: [Rival; 2],
    /// Their separation over the manoeuvres driven [σ].
    pub sigma: f64,
    /// `sigma` ≥ [`TARGET_SIGMA`].
    pub separable: bool,
}

/// A rival that cannot be fitted on the runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Unfitted {
    /// The rival.
    pub rival: Rival,
    /// Why.
    pub why: String,
}

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

    /// The suggestions as a scenario (what `demo --scenario` and the simulator drive).
    pub fn scenario(&self) -> Scenario {
        let manoeuvres = self
            .runs
            .iter()
            .flat_map(|r| std::iter::repeat_n(manoeuvre_of(r), r.repeats as usize))
            .collect();
        Scenario {
            repeats: 1,
            pause_s: PAUSE_S,
            lead_in_s: PAUSE_S,
            lead_out_s: PAUSE_S,
            manoeuvres,
        }
    }

    /// [`NextRuns::scenario`] as a scenario file, each manoeuvre with what it separates.
    pub fn scenario_toml(&self) -> String {
        let mut out = String::from(
            "# What to drive next, written by `host-tool diagnose --next-runs`: the manoeuvres\n\
             # that separate the rivals the diagnosis left in play, by the repeat noise σ of the\n\
             # runs diagnosed. Drive it as one run (`host-tool demo --scenario FILE` drives it on\n\
             # the simulated rover), then diagnose the runs again with it added.\n",
        );
        let _ = writeln!(
            out,
            "# In play: {}.",
            self.in_play
                .iter()
                .map(|r| r.label())
                .collect::<Vec<_>>()
                .join(", ")
        );
        let _ = writeln!(
            out,
            "repeats = 1\npause_s = {PAUSE_S:?}\nlead_in_s = {PAUSE_S:?}\nlead_out_s = {PAUSE_S:?}"
        );
        for r in &self.runs {
            let _ = writeln!(out, "\n# {}", r.describe());
            let block = match manoeuvre_of(r) {
                Manoeuvre::Straight {
                    distance_m,
                    speed_mps,
                } => format!(
                    "[[manoeuvres]]\nkind = \"straight\"\ndistance_m = {distance_m:?}\n\
                     speed_mps = {speed_mps:?}\n"
                ),
                Manoeuvre::Turn {
                    r_over_r_prime,
                    angle_deg,
                    v_c_mps,
                    direction,
                    ..
                } => format!(
                    "[[manoeuvres]]\nkind = \"turn\"\nr_over_r_prime = {:?}\nangle_deg = \
                     {angle_deg:?}\nv_c_mps = {v_c_mps:?}\ndirection = \"{}\"\n",
                    r_over_r_prime.unwrap_or(0.0),
                    match direction {
                        Side::Left => "left",
                        Side::Right => "right",
                    }
                ),
                _ => unreachable!("suggestions are turns and straights"),
            };
            for _ in 0..r.repeats {
                out.push_str(&block);
            }
        }
        out
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

/// The scenario entry of `r`.
fn manoeuvre_of(r: &NextRun) -> Manoeuvre {
    match r.r_over_r_prime {
        Some(x) => Manoeuvre::Turn {
            radius_m: None,
            r_over_r_prime: Some(x),
            angle_deg: r.turn_deg,
            v_c_mps: r.v_c_mps,
            direction: r.direction,
        },
        None => Manoeuvre::Straight {
            distance_m: r.distance_m.unwrap_or(DEFAULT_STRAIGHT_M),
            speed_mps: r.v_c_mps,
        },
    }
}

/// A rival fitted to the runs.
struct Fitted {
    rival: Rival,
    prediction: Prediction,
}

/// How a fitted rival predicts extra effective power.
enum Prediction {
    /// The baseline alone: none.
    Nothing,
    /// Copper loss with the baseline's features refitted: coefficients on [F², skid, |V|].
    Copper([f64; 3]),
    /// A catalogue term.
    Effect(FittedModel),
}

impl Prediction {
    /// How many regressors of its own the rival has (the baseline's two come after them).
    fn own_columns(&self) -> usize {
        match self {
            Prediction::Nothing => 0,
            Prediction::Copper(_) => 1,
            Prediction::Effect(m) => effects::param_count(m.effects[0].effect),
        }
    }
}

/// Columns of a mimicking fit: a rival's own regressors (≤ 2) and the baseline's two.
const MIMIC_COLUMNS: usize = effects::MAX_PARAMS + 2;

/// What the rivals are evaluated with.
struct Setting<'a> {
    rover: &'a Rover,
    baseline: &'a Baseline,
}

impl Setting<'_> {
    fn ctx(&self, tau_s: f64) -> Context<'_> {
        Context {
            rover: self.rover,
            baseline: self.baseline,
            heating_tau_s: tau_s,
        }
    }

    /// The predicted extra effective power of `f` on side `side` of `row` [W].
    fn eta(&self, f: &Fitted, row: &TurnRow, side: usize) -> f64 {
        match &f.prediction {
            Prediction::Nothing => 0.0,
            Prediction::Copper(c) => {
                let x = copper_columns(self.baseline, row, side);
                c[0] * x[0] + c[1] * x[1] + c[2] * x[2]
            }
            Prediction::Effect(m) => m.extra_w(row, side, &self.ctx(m.heating_tau_s)),
        }
    }

    /// `f`'s own regressors on side `side` of `row`, then the baseline's features.
    fn columns(&self, f: &Fitted, row: &TurnRow, side: usize) -> ([f64; MIMIC_COLUMNS], usize) {
        let mut x = [0.0; MIMIC_COLUMNS];
        let own = f.prediction.own_columns();
        match &f.prediction {
            Prediction::Nothing => {}
            Prediction::Copper(_) => x[0] = baseline::copper_regressor(self.baseline, row, side),
            Prediction::Effect(m) => {
                let r =
                    effects::regressors(m.effects[0].effect, row, side, &self.ctx(m.heating_tau_s))
                        .unwrap_or([0.0; effects::MAX_PARAMS]);
                x[..own].copy_from_slice(&r[..own]);
            }
        }
        x[own..own + 2].copy_from_slice(&effects::baseline_features(row, side));
        (x, own + 2)
    }
}

/// [F², skid, |V|] of side `side` of `row`.
fn copper_columns(b: &Baseline, row: &TurnRow, side: usize) -> [f64; 3] {
    let [skid, v] = effects::baseline_features(row, side);
    [baseline::copper_regressor(b, row, side), skid, v]
}

/// One ordered mimicking fit: `mimic`'s columns fitted to `target`'s predictions.
#[derive(Clone)]
struct Mimic {
    target: usize,
    mimic: usize,
    fit: LinearFit<MIMIC_COLUMNS>,
}

impl Mimic {
    fn new(target: usize, mimic: usize, columns: usize) -> Self {
        Self {
            target,
            mimic,
            fit: LinearFit::with_columns(columns).expect("2 to 4 columns"),
        }
    }

    /// Adds the observations of `row` (each side, or the total of a total-only row), each
    /// weighted by `weight`.
    fn add(&mut self, s: &Setting<'_>, fitted: &[Fitted], row: &TurnRow, weight: f64) {
        let w = weight.sqrt();
        for &sides in observe::observations(row) {
            let y: f64 = sides
                .iter()
                .map(|&side| s.eta(&fitted[self.target], row, side))
                .sum();
            let mut x = [0.0; MIMIC_COLUMNS];
            let mut k = 0;
            for &side in sides {
                let (c, n) = s.columns(&fitted[self.mimic], row, side);
                for (xi, ci) in x.iter_mut().zip(c) {
                    *xi += ci;
                }
                k = n;
            }
            for xi in &mut x {
                *xi *= w;
            }
            // A non-finite prediction (a term without its input) is no observation.
            let _ = self.fit.add_row(&x[..k], y * w);
        }
    }
}

/// A pair of rivals and the fits that separate them.
#[derive(Clone)]
struct Pair {
    rivals: [usize; 2],
    fits: Vec<Mimic>,
}

impl Pair {
    fn new(fitted: &[Fitted], a: usize, b: usize) -> Self {
        let columns = |i: usize| fitted[i].prediction.own_columns() + 2;
        // Every rival nests the baseline alone: only the other one must fail to mimic it.
        let fits = match (&fitted[a].prediction, &fitted[b].prediction) {
            (Prediction::Nothing, _) => vec![Mimic::new(b, a, columns(a))],
            (_, Prediction::Nothing) => vec![Mimic::new(a, b, columns(b))],
            _ => vec![Mimic::new(a, b, columns(b)), Mimic::new(b, a, columns(a))],
        };
        Self {
            rivals: [a, b],
            fits,
        }
    }

    /// Adds the drives `rows`, each weighted by `weight`.
    fn add<'r>(
        &mut self,
        s: &Setting<'_>,
        fitted: &[Fitted],
        rows: impl IntoIterator<Item = &'r TurnRow> + Clone,
        weight: f64,
    ) {
        for f in &mut self.fits {
            for row in rows.clone() {
                f.add(s, fitted, row, weight);
            }
        }
    }

    /// The separation [σ]: the weaker direction's.
    fn sigma(&self, noise_w: f64) -> f64 {
        self.fits
            .iter()
            .map(|f| f.fit.residual_sum_of_squares().max(0.0).sqrt() / noise_w)
            .fold(f64::INFINITY, f64::min)
    }

    /// The smallest increase of the mimicking fits' residual sum of squares one drive of `row`
    /// brings [W²].
    fn increment(&self, s: &Setting<'_>, fitted: &[Fitted], row: &TurnRow) -> f64 {
        self.fits
            .iter()
            .map(|f| {
                let mut g = f.clone();
                g.add(s, fitted, row, 1.0);
                g.fit.residual_sum_of_squares() - f.fit.residual_sum_of_squares()
            })
            .fold(f64::INFINITY, f64::min)
    }

    fn labels(&self, fitted: &[Fitted]) -> [Rival; 2] {
        self.rivals.map(|i| fitted[i].rival)
    }
}

/// The noise a separation is measured against: the repeat noise, and the misfit the best
/// model leaves (held-out), which is the same on every repeat of a manoeuvre.
#[derive(Debug, Clone, Copy)]
struct Noise {
    repeat_w: f64,
    misfit_w: f64,
}

impl Noise {
    /// The repeat noise `repeat_w` and the misfit of `d`'s best model: the held-out RMS error
    /// of its best candidate, of the baseline alone or of the diagnosed model with its stepwise
    /// steps, whichever is lowest, beyond the repeat noise.
    fn of(repeat_w: f64, d: &Diagnosis) -> Self {
        // The diagnosed model with its stepwise steps, when it has them, leaves the least.
        let stepwise = d.secondary.last().map(|s| s.heldout_error_after);
        let best = d
            .candidates
            .first()
            .map(|c| c.heldout_error_after.min(c.heldout_error_before))
            .into_iter()
            .chain(stepwise)
            .filter(|e| e.is_finite())
            .reduce(f64::min)
            .unwrap_or(repeat_w);
        Self {
            repeat_w,
            misfit_w: (best * best - repeat_w * repeat_w).max(0.0).sqrt(),
        }
    }

    /// σ of one side of one manoeuvre [W].
    fn sigma_w(&self) -> f64 {
        self.repeat_w.hypot(self.misfit_w)
    }

    /// The weight of each of `n` repeats of one manoeuvre: their mean is worth n / (1 + (n − 1)ρ)
    /// independent drives, ρ the misfit's share of the variance (the design effect of
    /// correlated repeats).
    fn repeat_weight(&self, n: u32) -> f64 {
        let total = self.sigma_w().powi(2);
        let rho = if total > 0.0 {
            self.misfit_w.powi(2) / total
        } else {
            0.0
        };
        1.0 / (1.0 + f64::from(n.saturating_sub(1)) * rho)
    }
}

/// Manoeuvres driven alike: R/R′ in hundredths (straights `i64::MAX`), v_c in cm/s, the turned
/// angle in tens of degrees, and the side (2: a total-only row).
type DriveKey = (i64, i64, i64, usize);

/// The repeat noise of one side of one manoeuvre [W] and where it was measured: the pooled
/// standard deviation of the effective power of manoeuvres driven alike (radius, v_c and turned
/// angle), over the diagnosed and calibration runs; else the calibration's lack-of-fit test's
/// pure error; else the practical floor.
fn repeat_noise(train: &[&TurnRow], d: &Diagnosis) -> (f64, String) {
    let mut groups: Vec<(DriveKey, Vec<f64>)> = Vec::new();
    for row in train {
        let angle = (row.expected_duration_s * row.yaw_rate_cmd_rad_s).to_degrees();
        let key_of = |side| {
            (
                if row.is_straight() {
                    i64::MAX
                } else {
                    (row.r_over_r_prime * 100.0).round() as i64
                },
                (row.v_c_mps * 100.0).round() as i64,
                (angle / 10.0).round() as i64,
                side,
            )
        };
        let values: Vec<(usize, f64)> = match row.observed {
            Observed::Sides => vec![
                (0, row.sides[0].effective_power_w),
                (1, row.sides[1].effective_power_w),
            ],
            Observed::Total { avg_power_w } => vec![(2, avg_power_w)],
        };
        for (side, v) in values {
            if !v.is_finite() {
                continue;
            }
            let key = key_of(side);
            match groups.iter_mut().find(|(k, _)| *k == key) {
                Some((_, g)) => g.push(v),
                None => groups.push((key, vec![v])),
            }
        }
    }
    let (mut ss, mut df) = (0.0, 0usize);
    for (_, g) in &groups {
        if g.len() < 2 {
            continue;
        }
        let mean = g.iter().sum::<f64>() / g.len() as f64;
        ss += g.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
        df += g.len() - 1;
    }
    let floor = MIN_SIGMA_OF_FLOOR * PRACTICAL_FLOOR_W;
    if df >= 2 {
        return (
            (ss / df as f64).sqrt().max(floor),
            format!("manoeuvres driven alike, {df} df"),
        );
    }
    let pure = d
        .adequacy
        .per_side
        .as_ref()
        .unwrap_or(&d.adequacy.total)
        .repeat_sigma_w;
    if pure.is_finite() && pure > 0.0 {
        return (pure.max(floor), "the calibration's repeats".into());
    }
    (
        PRACTICAL_FLOOR_W,
        "no repeated manoeuvre: the practical floor taken".into(),
    )
}

/// Fits every rival on the training rows: the baseline alone, copper loss (unless the
/// baseline has it), each catalogue effect. Those that cannot be fitted are returned apart.
fn fit_rivals(
    s: &Setting<'_>,
    train: &[&TurnRow],
    fitted_on: &[&TurnRow],
) -> (Vec<Fitted>, Vec<Unfitted>) {
    let mut fitted = vec![Fitted {
        rival: Rival::None,
        prediction: Prediction::Nothing,
    }];
    let mut not_fitted = Vec::new();
    if s.baseline.copper_w_per_n2 == 0.0 {
        let obs: Vec<(Vec<f64>, f64)> = train
            .iter()
            .flat_map(|&row| {
                let res = s.baseline.observed_residuals_w(row);
                observe::observations(row)
                    .iter()
                    .zip(res.to_vec())
                    .map(move |(&sides, y)| {
                        let x =
                            observe::sum_sides(sides, |side| copper_columns(s.baseline, row, side));
                        (x.to_vec(), y)
                    })
            })
            .filter(|(x, y)| y.is_finite() && x.iter().all(|v| v.is_finite()))
            .collect();
        match effects::least_squares(&obs) {
            Some((c, _)) => fitted.push(Fitted {
                rival: Rival::CopperLoss,
                prediction: Prediction::Copper([c[0], c[1], c[2]]),
            }),
            None => not_fitted.push(Unfitted {
                rival: Rival::CopperLoss,
                why: "its force² regressor is a combination of the baseline's features here".into(),
            }),
        }
    }
    for e in EffectId::ALL {
        match FittedModel::fit(&[e], train, fitted_on, &s.ctx(HEATING_TAU_GRID_S[0])) {
            Ok(m) => fitted.push(Fitted {
                rival: Rival::Effect(e),
                prediction: Prediction::Effect(m),
            }),
            Err(err) => not_fitted.push(Unfitted {
                rival: Rival::Effect(e),
                why: err.reason,
            }),
        }
    }
    (fitted, not_fitted)
}

/// The rivals an open verdict leaves in play: for `ambiguous`, the baseline alone and the best
/// ranked candidates that improve the held-out error and could be named (their signature
/// present first, then inconclusive or not yet observable; one looked for and missing is out); for
/// `baseline-misfit` also copper loss;
/// for a named effect, the candidates within the selection's clear margin of it, or, when the
/// baseline with it still misfits its calibration, copper loss and the best candidates. Empty when
/// the verdict is settled (`none`, or a clear winner).
fn in_play(d: &Diagnosis) -> Vec<Rival> {
    // The nameable first: a candidate with its signature in the data, then by held-out score.
    let marked = |e: EffectId| d.signature(e).is_some_and(|s| s.present());
    // A mark looked for and missing rules its candidate out, as in the verdict (issue 35's
    // rule); one these runs' terrain or sensors hide cannot be seen whatever is driven next.
    let missing = |e: EffectId| d.signature(e).is_some_and(|s| s.absent());
    let could_be_named = |e: EffectId| !missing(e) && !d.signature(e).is_some_and(|s| s.masked);
    let mut improving: Vec<_> = d
        .candidates
        .iter()
        .filter(|c| c.shrink_pct > 0.0 && could_be_named(c.effect))
        .collect();
    improving.sort_by_key(|c| !marked(c.effect));
    let ranked = improving
        .into_iter()
        .take(MAX_CANDIDATES_IN_PLAY)
        .map(|c| Rival::Effect(c.effect));
    let unmarked_choice = d.mark_missing.filter(|&e| !missing(e)).map(Rival::Effect);
    let mut v: Vec<Rival> = match d.effect {
        Verdict::None => Vec::new(),
        Verdict::Ambiguous => std::iter::once(Rival::None)
            .chain(ranked)
            .chain(unmarked_choice)
            .collect(),
        Verdict::BaselineMisfit => [Rival::None, Rival::CopperLoss]
            .into_iter()
            .chain(ranked)
            .chain(unmarked_choice)
            .collect(),
        // A named effect is open only against a rival that could still be named in its place
        // (issue 35's rule): one whose own mark the runs did not test and miss (present, or not
        // observable on them) and, beside a baseline the named effect does not repair, one
        // whose mark needs no power model (no other is named against a misfit). A candidate
        // whose mark was looked for and not found is not named however well it fits, and a
        // baseline structure (copper loss) is no rival of an effect: its misfit is reported
        // beside it.
        Verdict::Effect(e) => {
            let Some(named) = d.candidates.iter().find(|c| c.effect == e) else {
                return Vec::new();
            };
            let misfit = still_misfits(d);
            let nameable =
                |c: EffectId| could_be_named(c) && !(misfit && c.signature_needs_power_model());
            let close: Vec<Rival> = d
                .candidates
                .iter()
                .filter(|c| {
                    c.effect != e
                        && c.penalised_mse < CLEAR_MARGIN * named.penalised_mse
                        && nameable(c.effect)
                })
                .take(MAX_CANDIDATES_IN_PLAY - 1)
                .map(|c| Rival::Effect(c.effect))
                .collect();
            if close.is_empty() {
                return Vec::new();
            }
            std::iter::once(Rival::Effect(e)).chain(close).collect()
        }
    };
    // The diagnosed model's further effects (its stepwise steps) act beside the named one: not
    // its rivals.
    let in_model = |r: &Rival| d.secondary.iter().any(|s| Rival::Effect(s.effect) == *r);
    let mut seen = Vec::new();
    v.retain(|r| {
        let new = !seen.contains(r) && !in_model(r);
        seen.push(*r);
        new
    });
    v
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

/// Whether `d` named an effect beside a baseline that misfits its calibration, and the effect
/// was not shown to repair the misfit.
fn still_misfits(d: &Diagnosis) -> bool {
    let repaired = d
        .adequacy_with_effect
        .as_ref()
        .is_some_and(|a| a.adequate == Some(true));
    d.effect.effect().is_some() && d.adequacy.adequate == Some(false) && !repaired
}

/// A manoeuvre the rover could drive next, and its synthetic row.
struct Drivable {
    run: NextRun,
    row: TurnRow,
    /// One drive and the pause after it [s].
    cycle_s: f64,
    least_repeats: u32,
    most_repeats: u32,
}

impl Drivable {
    /// `n` drives of it in a row: at the start of a fresh run, or (late) one after the other,
    /// each starting where the one before ended.
    fn drives(&self, n: u32) -> Vec<TurnRow> {
        (0..n)
            .map(|k| {
                let mut row = self.row.clone();
                if self.run.when == When::Late {
                    row.t_start_s = PAUSE_S + f64::from(k) * self.cycle_s;
                }
                row
            })
            .collect()
    }
}

/// What the runs could be extended by: the radii, v_c, angles and times of the module's design
/// space, in the runs' turn direction.
fn drivable(s: &Setting<'_>, rows: &[TurnRow], late: bool) -> Vec<Drivable> {
    let moving: Vec<f64> = rows
        .iter()
        .map(|r| r.v_c_mps)
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    let lo = moving.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = moving.iter().copied().fold(0.0, f64::max);
    let mut speeds = vec![];
    if lo.is_finite() {
        speeds.push((lo * 100.0).round() / 100.0);
        if hi - lo >= 0.05 {
            speeds.push((hi * 100.0).round() / 100.0);
        }
    }
    let count = |d| rows.iter().filter(|r| r.direction == Some(d)).count();
    let direction = if count(TurnDirection::Right) > count(TurnDirection::Left) {
        Side::Right
    } else {
        Side::Left
    };
    let straight_m = upper_median(
        rows.iter()
            .filter(|r| r.is_straight())
            .map(|r| r.v_c_mps * r.duration_s)
            .filter(|d| d.is_finite() && *d > 0.0)
            .collect(),
    )
    .map_or(DEFAULT_STRAIGHT_M, |d| (d * 10.0).round() / 10.0);
    let bus_v =
        upper_median(rows.iter().map(|r| r.bus_v).filter(|v| *v > 0.0).collect()).unwrap_or(0.0);
    let r_prime = f64::from(s.rover.r_prime_m());
    let whens: &[When] = if late {
        &[When::Any, When::Late]
    } else {
        &[When::Any]
    };
    let mut out = Vec::new();
    for &when in whens {
        let (least_repeats, most_repeats) = match when {
            When::Any => (1, MAX_REPEATS),
            When::Late => (MIN_LATE_REPEATS, MAX_MANOEUVRES),
        };
        for &v_c in &speeds {
            let at = |turn_deg: f64| Conditions {
                v_c_mps: v_c,
                turn_rad: turn_deg.to_radians(),
                bus_v,
                t_start_s: PAUSE_S,
            };
            let run = |x: Option<f64>, turn_deg: f64| NextRun {
                r_over_r_prime: x.map(thousandths),
                radius_m: x.map(|x| thousandths(x * r_prime)),
                distance_m: x.is_none().then_some(straight_m),
                v_c_mps: v_c,
                turn_deg,
                direction,
                repeats: 1,
                when,
                separates: Vec::new(),
                expected_sigma: 0.0,
                observes: None,
            };
            let mut straight = synthetic_row(s.rover, s.baseline, f64::INFINITY, &at(90.0));
            straight.duration_s = straight_m / v_c;
            straight.expected_duration_s = straight.duration_s;
            let turns = RADII.into_iter().flat_map(|x| {
                TURN_DEG.map(|deg| {
                    (
                        run(Some(x), deg),
                        synthetic_row(s.rover, s.baseline, x, &at(deg)),
                    )
                })
            });
            for (run, row) in std::iter::once((run(None, 0.0), straight)).chain(turns) {
                out.push(Drivable {
                    cycle_s: row.duration_s + PAUSE_S,
                    run,
                    row,
                    least_repeats,
                    most_repeats,
                });
            }
        }
    }
    out
}

/// Whether `e`'s mark is shown by a manoeuvre repeated in a row, late in a run.
fn shown_late(e: EffectId) -> bool {
    catalogue::of(e)
        .drives_to_show_mark()
        .iter()
        .any(|d| d.when == When::Late)
}

/// `x` to 3 decimals: how the design writes R/R′ and R (and finds them again).
fn thousandths(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
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
