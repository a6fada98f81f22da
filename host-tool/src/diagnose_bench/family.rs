//! The world family the bench draws its datasets from ([`generate`]): structure, rover, turn
//! direction, v_c, sample rate, noise and effect strength per dataset, split into a tuning part
//! and a held-out part that no tuning decision looks at (see the module docs of
//! [`bench`](super)).

use crate::effect_id::EffectId;
use crate::sim::world::{
    effects::HARD_GROUND_SLIP_TRACK_M, DrivePower, IcrParams, Manoeuvre, PowerSplit, Scenario,
    Side, WorldConfig,
};
use model_core::rng::SplitMix64;
use model_core::{Rover, Sides};
use serde::Serialize;

/// Strength factors are log-uniform in [1/`STRENGTH_SPAN`, `STRENGTH_SPAN`].
pub const STRENGTH_SPAN: f64 = 2.0;

/// The narrowest terrain slip track over the controller's, Table D.1 (CSA Mars analogue
/// terrain, wet and compacted: 0.65 m against the Husky's 1.1 m): a narrower `slip-track`
/// world reaches it at the strongest draw (0.90 at the weakest). Turns then run faster than
/// commanded, which no slip does; a wider track is a constant slip the calibration takes as the
/// terrain's.
pub const NARROWEST_TRACK_RATIO: f64 = 0.65 / 1.1;
/// Relative range of the base-world perturbation (μ, G, battery, quiescent draw).
pub const BASE_PERTURBATION: f64 = 0.2;
/// Current noise range per sensor [A].
pub const CURRENT_STD_RANGE_A: (f64, f64) = (0.01, 0.1);
/// Range of the repeat-to-repeat terrain variation (relative std).
pub const MANOEUVRE_STD_RANGE: (f64, f64) = (0.0, 0.05);
/// Range of the run-to-run terrain variation (relative std).
pub const RUN_STD_RANGE: (f64, f64) = (0.0, 0.02);
/// v_c range [m/s].
pub const V_C_RANGE_MPS: (f64, f64) = (0.2, 0.5);
/// Sample rates drawn from [Hz] (each a whole number of µs per sample).
pub const SAMPLE_HZ: [u64; 4] = [50, 100, 125, 200];
/// The calibration runs' manoeuvres as R/R' (∞: the straight), the independent check.
pub const CALIBRATION_R_OVER_R_PRIME: [f64; 4] = [0.0, 2.0, 3.0, f64::INFINITY];
/// The test runs' turn set as R/R' (the seed's, ∞: the straight), shuffled in each run.
pub const TEST_R_OVER_R_PRIME: [f64; 9] = [
    0.0,
    1.0 / 3.0,
    2.0 / 3.0,
    0.8,
    1.0,
    4.0 / 3.0,
    2.0,
    3.0,
    f64::INFINITY,
];
/// Share of the datasets without `motor-heating` whose test runs repeat the set 8–12 times.
pub const LONG_SHARE: f64 = 0.05;
/// Calibration runs per dataset.
pub const CALIBRATION_RUNS: usize = 2;
/// Test runs per dataset.
pub const TEST_RUNS: usize = 3;
/// The held-out part's bench seed is this plus `--seed` (tuning seeds are below it).
pub const HELD_OUT_SEED_BASE: u64 = 1000;
/// Range of the constant angular slip drawn (`[structure] angular_slip`).
pub const ANGULAR_SLIP_RANGE: (f64, f64) = (0.03, 0.15);
/// Range of R_T drawn for the `rt` split [m, commanded radius].
pub const THRESHOLD_RADIUS_RANGE_M: (f64, f64) = (10.0, 30.0);
/// Motor efficiency range of the `loss` structure.
pub const EFFICIENCY_RANGE: (f64, f64) = (0.6, 0.95);
/// Winding resistance range of the `loss` structure [Ω] (the Husky's; divided by the mass ratio
/// for the Argo, see [`RoverKind::world`]).
pub const WINDING_RESISTANCE_RANGE_OHM: (f64, f64) = (0.05, 0.5);

/// The part of the family a dataset belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Part {
    /// Structures, geometries and seeds that tuning may look at.
    Tuning,
    /// The Argo J5 turning right, the held-out structure [`HELD_OUT_STRUCTURE`], seeds ≥ 1000.
    HeldOut,
}

impl Part {
    /// `tuning` or `held-out`.
    pub const fn id(self) -> &'static str {
        match self {
            Part::Tuning => "tuning",
            Part::HeldOut => "held-out",
        }
    }
}

/// The two rovers of the family.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RoverKind {
    /// `rovers/husky-a200.toml` (seed Table 3.2).
    HuskyA200,
    /// `rovers/argo-j5.toml` (seed Table 3.1), world `worlds/argo-j5-hard-ground.toml`.
    ArgoJ5,
}

impl RoverKind {
    /// `husky-a200` or `argo-j5`.
    pub const fn id(self) -> &'static str {
        match self {
            RoverKind::HuskyA200 => "husky-a200",
            RoverKind::ArgoJ5 => "argo-j5",
        }
    }

    /// The geometry (the same numbers as the rover files).
    pub const fn rover(self) -> Rover {
        match self {
            RoverKind::HuskyA200 => Rover::HUSKY_A200,
            RoverKind::ArgoJ5 => ARGO_J5,
        }
    }

    /// The hard-ground world of this rover without effects.
    pub fn world(self) -> WorldConfig {
        let mut w = WorldConfig::hard_ground();
        if self == RoverKind::ArgoJ5 {
            w.rover = ARGO_J5;
            w.icr = ARGO_HARD_GROUND;
            // The same motors geared for the Argo's wheel radius, so current ∝ power as on
            // the Husky (K_T g ∝ r at a given bus voltage and speed).
            w.motor.gear_ratio *=
                f64::from(ARGO_J5.wheel_radius_m / Rover::HUSKY_A200.wheel_radius_m);
            w.effects.slip_track.slip_track_m = Some(ARGO_HARD_GROUND.slip_track_m);
            // Motors and battery sized for the load: at the same bus voltage the Argo's currents
            // are the mass ratio larger, so its windings and battery have that much less
            // resistance, and copper loss and sag take the same share of the power as on the
            // Husky. With the Husky's, an Argo with motor losses asked more than the battery
            // can give (V₀²/4R_int ≈ 3.6 kW): the bus sat at its collapse floor (V₀/2).
            w.motor.winding_resistance_ohm /= self.force_scale();
            w.battery.internal_resistance_ohm /= self.force_scale();
            // A winding sized for the load sheds its larger loss through a larger surface: the
            // same temperature rise at the same share of its rating. With the Husky's thermal
            // resistance, Argo heating worlds with motor losses sat at the insulation limit,
            // where the extra power is copper loss ∝ I² (no longer a heating shape).
            w.effects.motor_heating.thermal_resistance_k_per_w /= self.force_scale();
        }
        w
    }

    /// Factor on the force-like effect parameters (torques, resistances): the mass ratio to
    /// the Husky, whose defaults they are.
    fn force_scale(self) -> f64 {
        f64::from(self.rover().mass_kg / Rover::HUSKY_A200.mass_kg)
    }
}

/// Seed Table 3.1 (`rovers/argo-j5.toml`).
pub const ARGO_J5: Rover = Rover {
    track_width_m: 1.14,
    length_m: 0.98,
    wheel_radius_m: 0.3,
    mass_kg: 372.0,
    slip_track_m: 1.14,
};

/// The Argo J5 on hard ground (`worlds/argo-j5-hard-ground.toml`): the seed has no such test,
/// so the Husky's concrete figures are carried over: μ 0.74 (paper Table 2), G scaled by mass
/// (30.85 N × 372/63, the same rolling resistance per kg) and the power model's slip track
/// 1.29/1.1 × the controller's B (Table D.1's concrete-to-controller ratio).
pub const ARGO_HARD_GROUND: IcrParams = IcrParams {
    mu: 0.74,
    rolling_resistance_n: 30.85 * 372.0 / 63.0,
    slip_track_m: 1.14 * 1.29 / 1.1,
    traction_fade_radius_m: crate::sim::world::TRACTION_FADE_RADIUS_M,
};

/// The standstill draw of a structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Standstill {
    /// The drivers' default 50 mA per side (perturbed ±20 %).
    Default,
    /// ≈ 0 A on both sides (thesis Fig. 3.3, the INA226 board): 0–5 mA.
    Zero,
    /// Each side its own draw in 20–120 mA.
    Uneven,
}

impl Standstill {
    /// `default`, `zero` or `uneven`.
    pub const fn id(self) -> &'static str {
        match self {
            Standstill::Default => "default",
            Standstill::Zero => "zero",
            Standstill::Uneven => "uneven",
        }
    }
}

/// The split switch of a structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SplitDraw {
    /// `threshold` with the default fade radius (the world's default).
    Default,
    /// `threshold` with R_T drawn in [`THRESHOLD_RADIUS_RANGE_M`].
    Rt,
    /// `regenerating`.
    Regen,
    /// `clamped`.
    Clamp,
}

impl SplitDraw {
    /// `default`, `rt`, `regen` or `clamp`.
    pub const fn id(self) -> &'static str {
        match self {
            SplitDraw::Default => "default",
            SplitDraw::Rt => "rt",
            SplitDraw::Regen => "regen",
            SplitDraw::Clamp => "clamp",
        }
    }
}

/// A dataset's world structure: which switches are off their defaults.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct StructureKind {
    /// The per-side split.
    pub split: SplitDraw,
    /// A constant angular slip in every turn.
    pub slip: bool,
    /// Eq 21 as mechanical power plus the motors' losses.
    pub losses: bool,
    /// The standstill draw.
    pub standstill: Standstill,
}

/// The family's default structure (the controls').
pub const DEFAULT_STRUCTURE: StructureKind = StructureKind {
    split: SplitDraw::Default,
    slip: false,
    losses: false,
    standstill: Standstill::Default,
};

/// The held-out combination: the independent generator (R_T split, constant slip,
/// copper and efficiency, ≈ 0 A standstill). Never drawn in the tuning part.
pub const HELD_OUT_STRUCTURE: StructureKind = StructureKind {
    split: SplitDraw::Rt,
    slip: true,
    losses: true,
    standstill: Standstill::Zero,
};

impl StructureKind {
    /// `default`, or the switches off their defaults joined by `+` (`rt`, `regen`, `clamp`,
    /// `slip`, `loss`, `iq0`, `iq-uneven`).
    pub fn label(&self) -> String {
        let mut parts = Vec::new();
        if self.split != SplitDraw::Default {
            parts.push(self.split.id());
        }
        if self.slip {
            parts.push("slip");
        }
        if self.losses {
            parts.push("loss");
        }
        match self.standstill {
            Standstill::Default => {}
            Standstill::Zero => parts.push("iq0"),
            Standstill::Uneven => parts.push("iq-uneven"),
        }
        if parts.is_empty() {
            "default".into()
        } else {
            parts.join("+")
        }
    }
}

/// What a dataset is: a control (default structure, no effect), one effect (any structure), or
/// a non-default structure without effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DatasetClass {
    /// No effect, the default structure.
    Control,
    /// One effect switched on.
    Effect(EffectId),
    /// No effect, a structure off the default.
    StructureOnly,
}

impl DatasetClass {
    /// Classes per round: control, the catalogue, structure-only.
    pub const COUNT: usize = EffectId::COUNT + 2;

    /// The class of dataset `index`, round robin.
    pub fn of(index: usize) -> Self {
        match index % Self::COUNT {
            0 => DatasetClass::Control,
            k if k <= EffectId::COUNT => DatasetClass::Effect(EffectId::ALL[k - 1]),
            _ => DatasetClass::StructureOnly,
        }
    }

    /// The effect, if any.
    pub fn effect(self) -> Option<EffectId> {
        match self {
            DatasetClass::Effect(e) => Some(e),
            DatasetClass::Control | DatasetClass::StructureOnly => None,
        }
    }

    /// Row label: `none` (control), the effect id, `structure-only`.
    pub fn label(self) -> &'static str {
        match self {
            DatasetClass::Control => "none",
            DatasetClass::Effect(e) => e.id(),
            DatasetClass::StructureOnly => "structure-only",
        }
    }
}

/// One generated dataset: everything needed to rebuild its worlds and scenarios.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DatasetSpec {
    /// Index in its part.
    pub index: usize,
    /// Tuning or held-out.
    pub part: Part,
    /// Control, effect or structure-only.
    pub class: DatasetClass,
    /// The world structure.
    pub structure: StructureKind,
    /// Its label ([`StructureKind::label`]).
    pub structure_label: String,
    /// The rover.
    pub rover: RoverKind,
    /// Every turn's side.
    pub direction: Side,
    /// Factor on the effect's default parameters ([`scale_effect`]; 1 without effect).
    pub strength: f64,
    /// v_c [m/s].
    pub v_c_mps: f64,
    /// Sample rate [Hz].
    pub sample_hz: u64,
    /// Current noise of each sensor [A, std].
    pub current_std_a: Sides<f64>,
    /// `[noise] manoeuvre_power_std`.
    pub manoeuvre_power_std: f64,
    /// `[noise] run_power_std`.
    pub run_power_std: f64,
    /// Repeats of the turn set per test run (1; 8–12 for `motor-heating`, whose time constant
    /// is 10 min, and for [`LONG_SHARE`] of the others so long runs are seen without heating).
    pub repeats: u32,
    /// Straight-line length [m].
    pub straight_m: f64,
    /// Perturbed μ.
    pub mu: f64,
    /// Perturbed G [N].
    pub rolling_resistance_n: f64,
    /// Perturbed battery internal resistance [Ω].
    pub internal_resistance_ohm: f64,
    /// Standstill draw per side [A].
    pub quiescent_current_a: Sides<f64>,
    /// `rt`: R_T [m].
    pub threshold_radius_m: Option<f64>,
    /// `slip`: the constant angular slip.
    pub angular_slip: f64,
    /// `loss`: motor efficiency and winding resistance [Ω].
    pub motor_losses: Option<(f64, f64)>,
    /// Right current offset over left (`current-offset` datasets; 1 otherwise).
    pub offset_right_over_left: f64,
    /// Slope wavelength [m] (`slope` datasets).
    pub slope_wavelength_m: f64,
    /// Each test run's order of [`TEST_R_OVER_R_PRIME`].
    pub test_orders: Vec<Vec<usize>>,
    /// Seed of the runs: calibration run k is `seed + k`, test run k `seed + 2 + k`.
    pub seed: u64,
    /// `slip-track`: the terrain's slip track is narrower than the controller's (Table D.1's
    /// CSA terrain, 0.65 m against 1.1 m) instead of wider (its concrete, 1.29 m).
    pub narrower_slip_track: bool,
}

impl DatasetSpec {
    /// The effect, if any.
    pub fn effect(&self) -> Option<EffectId> {
        self.class.effect()
    }

    /// The calibration runs' world: the test runs' ([`DatasetSpec::world`]) on the reference
    /// ground's slip track. A slip track is the ground's (thesis Appendix D); the one the
    /// calibration ground shares with the test ground is absorbed by the baseline as the
    /// terrain's constant slip, so `slip-track` is the test ground's departure from it (its mark
    /// is measured against the calibration's own turns).
    pub fn calibration_world(&self) -> WorldConfig {
        let mut w = self.world();
        w.effects.set_enabled(EffectId::SlipTrack, false);
        w
    }

    /// The test runs' world (every other effect and all structure are the calibration's too).
    pub fn world(&self) -> WorldConfig {
        let mut w = self.rover.world();
        w.icr.mu = self.mu;
        w.icr.rolling_resistance_n = self.rolling_resistance_n;
        w.battery.internal_resistance_ohm = self.internal_resistance_ohm;
        w.driver.quiescent_current_a = self.quiescent_current_a.left;
        w.driver.left_quiescent_current_a = Some(self.quiescent_current_a.left);
        w.driver.right_quiescent_current_a = Some(self.quiescent_current_a.right);
        w.noise.left_current_std_a = self.current_std_a.left;
        w.noise.right_current_std_a = self.current_std_a.right;
        w.noise.manoeuvre_power_std = self.manoeuvre_power_std;
        w.noise.run_power_std = self.run_power_std;
        w.structure.split = match self.structure.split {
            SplitDraw::Default | SplitDraw::Rt => PowerSplit::Threshold,
            SplitDraw::Regen => PowerSplit::Regenerating,
            SplitDraw::Clamp => PowerSplit::Clamped,
        };
        w.structure.threshold_radius_m = self.threshold_radius_m;
        w.structure.angular_slip = self.angular_slip;
        if let Some((efficiency, winding_resistance_ohm)) = self.motor_losses {
            w.structure.drive_power = DrivePower::Mechanical;
            w.motor.efficiency = efficiency;
            w.motor.winding_resistance_ohm = winding_resistance_ohm;
        }
        if let Some(effect) = self.effect() {
            w = w.with_effect(effect, true);
            if effect == EffectId::SlipTrack && self.narrower_slip_track {
                // The narrow terrain at strength 1, so the strongest draw reaches Table D.1's.
                let ratio = 1.0 - (1.0 - NARROWEST_TRACK_RATIO) / STRENGTH_SPAN;
                w.effects.slip_track.slip_track_m = Some(f64::from(w.rover.slip_track_m) * ratio);
            }
            scale_effect(&mut w, effect, self.strength * self.effect_size(effect));
            let e = &mut w.effects;
            e.current_offset.right_a = e.current_offset.left_a * self.offset_right_over_left;
            e.slope.wavelength_m = self.slope_wavelength_m;
        }
        w
    }

    /// The rover's factor on a force-like effect (1 for the others).
    fn effect_size(&self, effect: EffectId) -> f64 {
        match effect {
            EffectId::InnerDrag | EffectId::SinkageBulldozing | EffectId::BrakedInner => {
                self.rover.force_scale()
            }
            EffectId::AngularSlip
            | EffectId::SlipTrack
            | EffectId::CurrentOffset
            | EffectId::MotorHeating
            | EffectId::Slope => 1.0,
        }
    }

    fn scenario(&self, ks: impl IntoIterator<Item = f64>, repeats: u32) -> Scenario {
        let manoeuvres = ks
            .into_iter()
            .map(|k| {
                if k.is_finite() {
                    Manoeuvre::Turn {
                        radius_m: None,
                        r_over_r_prime: Some(k),
                        angle_deg: 90.0,
                        v_c_mps: self.v_c_mps,
                        direction: self.direction,
                    }
                } else {
                    Manoeuvre::Straight {
                        distance_m: self.straight_m,
                        speed_mps: self.v_c_mps,
                    }
                }
            })
            .collect();
        Scenario::with_default_pauses(manoeuvres, repeats)
    }

    /// A calibration run: R ∈ {0, 2R′, 3R′, straight}.
    pub fn calibration_scenario(&self) -> Scenario {
        self.scenario(CALIBRATION_R_OVER_R_PRIME, 1)
    }

    /// The test runs: the seed's turn set, each in its own order.
    pub fn test_scenarios(&self) -> Vec<Scenario> {
        self.test_orders
            .iter()
            .map(|order| self.scenario(order.iter().map(|&i| TEST_R_OVER_R_PRIME[i]), self.repeats))
            .collect()
    }
}

/// Scales `effect`'s strength in `world` by `factor` (1 = the world's default): the torque,
/// resistance, offset, thermal resistance or slope amplitude; for `angular-slip` both slips
/// (capped at 0.95); for `slip-track` the terrain slip track's departure from the controller's
/// (Table D.1's 1.29 m at 1).
pub fn scale_effect(world: &mut WorldConfig, effect: EffectId, factor: f64) {
    let controller = f64::from(world.rover.slip_track_m);
    let e = &mut world.effects;
    match effect {
        EffectId::InnerDrag => e.inner_drag.torque_nm *= factor,
        EffectId::SinkageBulldozing => e.sinkage_bulldozing.resistance_n_per_mm *= factor,
        EffectId::AngularSlip => {
            e.angular_slip.at_zero = (e.angular_slip.at_zero * factor).min(0.95);
            e.angular_slip.at_r_prime = (e.angular_slip.at_r_prime * factor).min(0.95);
        }
        EffectId::SlipTrack => {
            let terrain = e
                .slip_track
                .slip_track_m
                .unwrap_or(HARD_GROUND_SLIP_TRACK_M);
            e.slip_track.slip_track_m = Some(controller + (terrain - controller) * factor);
        }
        EffectId::BrakedInner => e.braked_inner.resistance_n *= factor,
        EffectId::CurrentOffset => {
            e.current_offset.left_a *= factor;
            e.current_offset.right_a *= factor;
        }
        EffectId::MotorHeating => e.motor_heating.thermal_resistance_k_per_w *= factor,
        EffectId::Slope => e.slope.amplitude_deg *= factor,
    }
}

/// Uniform in [lo, hi) (the ranges below are (lo, hi) pairs).
fn within(rng: &mut SplitMix64, (lo, hi): (f64, f64)) -> f64 {
    rng.range(lo, hi)
}

/// A random permutation of 0..n (Fisher–Yates).
fn shuffled(rng: &mut SplitMix64, n: usize) -> Vec<usize> {
    let mut v: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        v.swap(i, rng.below(i + 1));
    }
    v
}

/// Whether a dataset of this rover, direction and structure belongs to the held-out part.
pub fn is_held_out(rover: RoverKind, direction: Side, structure: &StructureKind) -> bool {
    (rover == RoverKind::ArgoJ5 && direction == Side::Right) || *structure == HELD_OUT_STRUCTURE
}

/// Every switch drawn independently (about half the draws keep each default).
fn draw_structure(rng: &mut SplitMix64) -> StructureKind {
    StructureKind {
        split: match rng.below(5) {
            0 => SplitDraw::Rt,
            1 => SplitDraw::Regen,
            2 => SplitDraw::Clamp,
            _ => SplitDraw::Default,
        },
        slip: rng.chance(0.3),
        losses: rng.chance(0.3),
        standstill: match rng.below(4) {
            0 => Standstill::Zero,
            1 => Standstill::Uneven,
            _ => Standstill::Default,
        },
    }
}

/// Rover, direction and structure of one dataset of `class` in `part`: the tuning part never
/// draws a held-out combination; the held-out part draws only those (half the Argo turning
/// right with any structure, half the held-out structure on either rover and side).
fn draw_setting(
    rng: &mut SplitMix64,
    part: Part,
    class: DatasetClass,
) -> (RoverKind, Side, StructureKind) {
    let side = |rng: &mut SplitMix64| {
        if rng.chance(0.5) {
            Side::Left
        } else {
            Side::Right
        }
    };
    let rover = |rng: &mut SplitMix64| {
        if rng.chance(0.5) {
            RoverKind::HuskyA200
        } else {
            RoverKind::ArgoJ5
        }
    };
    let structure = |rng: &mut SplitMix64| match class {
        DatasetClass::Control => DEFAULT_STRUCTURE,
        DatasetClass::Effect(_) => draw_structure(rng),
        DatasetClass::StructureOnly => loop {
            let s = draw_structure(rng);
            if s != DEFAULT_STRUCTURE {
                break s;
            }
        },
    };
    loop {
        let (r, d, s) = match part {
            Part::Tuning => (rover(rng), side(rng), structure(rng)),
            Part::HeldOut if class == DatasetClass::Control || rng.chance(0.5) => {
                (RoverKind::ArgoJ5, Side::Right, structure(rng))
            }
            Part::HeldOut => (rover(rng), side(rng), HELD_OUT_STRUCTURE),
        };
        // The Argo's controller uses B_s = B, so its inner wheels are never dragged forward
        // while counter-rotating (no B/2 < R < R' range): `inner-drag` has nothing to act on.
        let no_effect =
            r == RoverKind::ArgoJ5 && class == DatasetClass::Effect(EffectId::InnerDrag);
        if !no_effect && is_held_out(r, d, &s) == (part == Part::HeldOut) {
            return (r, d, s);
        }
    }
}

/// The `datasets` datasets of `part` for bench seed `seed` (the held-out part uses
/// [`HELD_OUT_SEED_BASE`] + `seed`).
pub fn generate(part: Part, datasets: usize, seed: u64) -> Vec<DatasetSpec> {
    let bench_seed = match part {
        Part::Tuning => seed,
        Part::HeldOut => HELD_OUT_SEED_BASE + seed,
    };
    (0..datasets)
        .map(|index| draw(part, index, bench_seed))
        .collect()
}

fn draw(part: Part, index: usize, bench_seed: u64) -> DatasetSpec {
    let mut rng = SplitMix64::new(bench_seed.wrapping_mul(0xA076_1D64_78BD_642F) ^ index as u64);
    rng.next_u64();
    let class = DatasetClass::of(index);
    let effect = class.effect();
    let (rover, direction, structure) = draw_setting(&mut rng, part, class);
    let base = rover.world();
    let perturb = |rng: &mut SplitMix64, v: f64| {
        v * within(rng, (1.0 - BASE_PERTURBATION, 1.0 + BASE_PERTURBATION))
    };
    let strength = if effect.is_some() {
        let ln = STRENGTH_SPAN.ln();
        within(&mut rng, (-ln, ln)).exp()
    } else {
        1.0
    };
    let long = effect == Some(EffectId::MotorHeating) || rng.chance(LONG_SHARE);
    let repeats = if long { 8 + rng.below(5) as u32 } else { 1 };
    let quiescent_current_a = match structure.standstill {
        Standstill::Default => {
            let q = perturb(&mut rng, base.driver.quiescent_current_a);
            Sides::new(q, q)
        }
        Standstill::Zero => Sides::new(
            within(&mut rng, (0.0, 0.005)),
            within(&mut rng, (0.0, 0.005)),
        ),
        Standstill::Uneven => Sides::new(
            within(&mut rng, (0.02, 0.12)),
            within(&mut rng, (0.02, 0.12)),
        ),
    };
    DatasetSpec {
        index,
        part,
        class,
        structure,
        structure_label: structure.label(),
        rover,
        direction,
        strength,
        v_c_mps: within(&mut rng, V_C_RANGE_MPS),
        sample_hz: SAMPLE_HZ[rng.below(SAMPLE_HZ.len())],
        current_std_a: Sides::new(
            within(&mut rng, CURRENT_STD_RANGE_A),
            within(&mut rng, CURRENT_STD_RANGE_A),
        ),
        manoeuvre_power_std: within(&mut rng, MANOEUVRE_STD_RANGE),
        run_power_std: within(&mut rng, RUN_STD_RANGE),
        repeats,
        straight_m: within(&mut rng, (1.0, 2.0)),
        mu: perturb(&mut rng, base.icr.mu),
        rolling_resistance_n: perturb(&mut rng, base.icr.rolling_resistance_n),
        internal_resistance_ohm: perturb(&mut rng, base.battery.internal_resistance_ohm),
        quiescent_current_a,
        threshold_radius_m: (structure.split == SplitDraw::Rt)
            .then(|| within(&mut rng, THRESHOLD_RADIUS_RANGE_M)),
        angular_slip: if structure.slip {
            within(&mut rng, ANGULAR_SLIP_RANGE)
        } else {
            0.0
        },
        motor_losses: structure.losses.then(|| {
            (
                within(&mut rng, EFFICIENCY_RANGE),
                within(&mut rng, WINDING_RESISTANCE_RANGE_OHM) / rover.force_scale(),
            )
        }),
        offset_right_over_left: if effect == Some(EffectId::CurrentOffset) {
            within(&mut rng, (0.7, 1.3))
        } else {
            1.0
        },
        slope_wavelength_m: if effect == Some(EffectId::Slope) {
            within(&mut rng, (3.0, 6.0))
        } else {
            base.effects.slope.wavelength_m
        },
        test_orders: (0..TEST_RUNS)
            .map(|_| shuffled(&mut rng, TEST_R_OVER_R_PRIME.len()))
            .collect(),
        seed: rng.next_u64(),
        // Drawn last, so every earlier draw stays what it was.
        narrower_slip_track: effect == Some(EffectId::SlipTrack) && rng.chance(0.5),
    }
}
