//! The simulated rover world: a Clearpath Husky A200 (Table 3.2, controller slip track 1.1 m)
//! executing a [`Scenario`] on hard ground or loose sand, producing the currents and bus
//! voltages the two INA226 see ([`Timeline::load_at`], [`Timeline::load_source`] for
//! [`SimBoard`](crate::sim::board::SimBoard)), the commands and tracker pose
//! ([`Timeline::commands`]), and the ground truth of every manoeuvre
//! ([`Timeline::manoeuvres`]).
//!
//! # Kinematics
//!
//! A turn of radius R at v_c is commanded with the constant side speeds of Appendix A
//! (Eq A.13–A.14, `model_core::kinematics::side_speeds_for`, with the rover's controller slip
//! track) until the **true** yaw has turned the requested angle, as the seed's tests did with
//! the IMU (paper Section 4.3). The true motion: v_y = (V_l + V_r)/2 (Eq 2.1) and
//! ω_z = (V_r − V_l)/B_s,terrain · (1 − s_ω) (Eq 2.2 with the `slip-track` effect's terrain slip
//! track, else the controller's, and the `angular-slip` effect's s_ω of Eq 6.3), so turns last
//! longer than expected when either is on. Straight lines run until the true distance is
//! reached; pauses are standstill. The world integrates every 10 ms ([`STEP_S`]); the last step
//! of a manoeuvre is shortened so it ends exactly on its angle or distance.
//!
//! # Power chain
//!
//! Baseline (both grounds): the ICR model of paper Eq 20–22,
//! P = F|ω_z| + G(|V_r| + |V_l|), F = 2μp√(L² + (W − B_s)²), on the commanded side speeds,
//! with paper Table 2's Husky parameters on hard ground (μ 0.74, G 30.85 N, B_s 1.29 m,
//! `IcrHardGround::HUSKY_HARD_GROUND`). It is the *electrical* power at the drivers (μ and G
//! were fitted to measured power). Per side, the skid term is carried by equal and opposite
//! tread forces ±F/B_s (their couple over B_s is the skid moment F, so the outer side delivers
//! F V_o/B_s and the inner −F V_i/B_s, summing to F|ω_z| exactly), and each side rolls against
//! G|V|. For R > R' the inner side therefore regenerates (negative power), as the paper
//! measured with its INA226 (paper Fig. 11), and, with the traction fading as
//! 1/(1 + (R/R_f)²) for wide arcs (the fade's share of F|ω_z| goes to the sides in proportion
//! to |V|, so the total is still exactly Eq 21), turns positive again near R_T = 18 m (paper
//! Section 4.4), with continuity into a straight line (P = G|V| per side, Lemma 1). At R' the
//! inner side is not commanded and draws only its driver's quiescent current.
//!
//! Structure switches (`[structure]`, [`structure`]; the defaults are the split above): the
//! per-side split — `threshold` (above; `threshold_radius_m` sets R_T and derives R_f),
//! `regenerating` (the tread couple alone, inner negative for every R > R') or `clamped` (thesis
//! Section 1.1.3: "any negative power … put to 0") —, a constant angular slip in every turn
//! (thesis Fig. 6.7's hard-ground offset), and whether Eq 21 is the drivers' electrical power or
//! the wheels' mechanical power with the motors' Eq 1.18–1.19 losses (efficiency, copper ∝ I²).
//! The standstill draw per side is `[driver]`'s quiescent current (≈ 0 A on the INA226 board,
//! thesis Fig. 3.3; distinct from the `current-offset` effect, a sensor offset).
//!
//! Effects (each its own TOML table, [`effects`]): torque-type terms (`inner-drag`,
//! `sinkage-bulldozing`, `braked-inner`) add wheel torque Δτ on a side and go through
//! `model_core::power::DcMotor` (Eq 1.18–1.19): ΔP = Δτω/η + (2τΔτ + Δτ²)R_m/(K_T g η)², with τ
//! the baseline torque that the motor model maps onto the baseline power; `motor-heating`
//! raises R_m with a first-order winding temperature; `slope` adds Φ m g v_y sin θ (Eq 1.16);
//! `current-offset` shifts what the sensors see. The driver current is
//! I = I_q + P/V_bus at the battery's bus voltage V_bus = V_0 − R_int I_total (solved exactly).
//! Per-side currents may be negative (regeneration, paper Fig. 11); the battery itself cannot
//! be charged (Section 1.1.3), so a net regeneration is dissipated in the drivers (the
//! generating side's current is clamped so the total is ≥ 0).
//!
//! # Defaults and the seed figures they reproduce
//!
//! Hard ground (`worlds/husky-hard-ground.toml`): paper Table 2; the turn power equals paper
//! Eq 21 (tests: within 0.1 % at every radius of the seed's set); the inner side regenerates
//! for R' < R < 18 m (paper Fig. 11); straight lines draw 2G v (paper Lemma 1).
//!
//! Sand (`worlds/husky-sand.toml`, the laboratory sandbox with GRC-1): ICR μ 1.3, G 46 N,
//! B_s 1.21 m (Table D.1, sandbox), plus the sand effects on by default, calibrated to:
//! - Section 4.4.1 / Fig 4.8: point-turn power about twice hard ground (μ, `sinkage-bulldozing`);
//! - Section 4.4.2 / Fig 4.9 and Chapter 7: average power 15–20 % above P(0), peaking in
//!   B/2 < R < R' (`inner-drag`, `sinkage-bulldozing`'s counter-rotation gain);
//! - Section 5.2 / Fig 5.6: the inner wheels' τ ∝ P/ω (Eq 5.14) about 70 % higher at 2R'/3
//!   than at R'/3 (`inner-drag` torque);
//! - Section 4.4.1 / Fig 4.8, 4.11: power rising through turns with R ≤ R'
//!   (`sinkage-bulldozing` growth, `inner-drag` ramp);
//! - Section 6.2 / Fig 6.7–6.8, Chapter 7: turns slower than commanded, the angular slip at R'
//!   40 % above R = 0's, the time offset at least double the hard ground's (`angular-slip`,
//!   `slip-track` 1.21 m vs hard ground 1.29 m);
//! - Section 6.2 / Fig 4.8: P(R') close to P(0) (`braked-inner` kept small, 15 N per held
//!   wheel, held while |V_i| < 0.04 m/s, Fig 6.11).
//! - Section 6.1 / Table 6.1: the 45° – 10 m – 45° CLC path cheapest at 2R' < R < 2.5R' and
//!   dearer than PLP at R' (`angular-slip` falling as (R'/R)³ above R' on sand); the slice
//!   around R' stays below the table's +14 % unless the held wheels plough harder
//!   (`worlds/husky-sand-table-6.1.toml`, 60 N: every slice within ±5 points, at the cost of
//!   P(R') ≈ P(0)); see the README's calibration table.
//!
//! The numbers the tests measure are in this module's tests (`calibration_*`).

mod domain;
pub mod effects;
mod engine;
mod file;
pub mod path_energy;
pub mod structure;
mod timeline;
pub mod tracker;

pub use effects::EffectId;
pub use file::{load_world, parse_world};
// The scenario (what the rover is commanded to do) and `WorldError`, which reading one returns,
// live in the neutral `crate::scenario`: the diagnosis writes scenarios without the simulator.
pub use crate::scenario;
pub use crate::scenario::{
    load_scenario, parse_scenario, Manoeuvre, ManoeuvreKind, Scenario, Side, WorldError,
};
pub use structure::{DrivePower, PowerSplit, Structure};
pub use timeline::{ManoeuvreTruth, Timeline, TimelineLoad};
pub use tracker::Tracker;

use model_core::power::{DcMotor, IcrHardGround};
use model_core::{Rover, Sides};
use serde::{Deserialize, Serialize};

/// Integration step of the world's mechanics [s].
pub const STEP_S: f64 = 0.01;

/// The terrain of a world: it picks the ICR parameters and which terrain effects are on by
/// default.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Ground {
    /// Concrete (paper Table 2).
    #[default]
    Hard,
    /// The laboratory sandbox, GRC-1 (Chapters 4–6).
    Sand,
}

/// `[icr]`: the ICR power model's parameters (paper Eq 20–22) and the traction fade of the
/// per-side split.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IcrParams {
    /// μ.
    pub mu: f64,
    /// G [N].
    pub rolling_resistance_n: f64,
    /// B_s of the power model [m].
    pub slip_track_m: f64,
    /// R_f: radius (from Eq 2.4 with this B_s) where the tread forces have faded to half [m].
    pub traction_fade_radius_m: f64,
}

/// R_f placing the inner side's zero crossing at R_T ≈ 18 m on hard ground (paper Section 4.4).
pub const TRACTION_FADE_RADIUS_M: f64 = 11.1;

impl IcrParams {
    /// Paper Table 2 (hard ground).
    pub const HARD_GROUND: IcrParams = IcrParams {
        mu: IcrHardGround::HUSKY_HARD_GROUND.mu,
        rolling_resistance_n: IcrHardGround::HUSKY_HARD_GROUND.rolling_resistance_n,
        slip_track_m: IcrHardGround::HUSKY_HARD_GROUND.slip_track_m,
        traction_fade_radius_m: TRACTION_FADE_RADIUS_M,
    };

    /// The sandbox baseline: B_s from Table D.1; μ calibrated so that a point turn draws about
    /// twice the hard-ground power with the sand effects on (Section 4.4.1); G 1.5 × hard
    /// ground (the seed has no straight-line sandbox measurement; the gap to hard ground
    /// shrinks for wide arcs, Section 4.4.1).
    pub const SAND: IcrParams = IcrParams {
        mu: 1.1,
        rolling_resistance_n: 46.0,
        slip_track_m: effects::SANDBOX_SLIP_TRACK_M,
        traction_fade_radius_m: TRACTION_FADE_RADIUS_M,
    };

    /// The paper's model with these parameters for `rover` (its L, W = B, m).
    pub fn model(&self, rover: &Rover) -> IcrHardGround {
        IcrHardGround {
            mu: self.mu,
            rolling_resistance_n: self.rolling_resistance_n,
            length_m: f64::from(rover.length_m),
            width_m: if rover == &Rover::HUSKY_A200 {
                // Paper Table 2 uses W = 0.55 m for the Husky (Table 3.2: B = 0.545 m).
                IcrHardGround::HUSKY_HARD_GROUND.width_m
            } else {
                f64::from(rover.track_width_m)
            },
            mass_kg: f64::from(rover.mass_kg),
            slip_track_m: self.slip_track_m,
        }
    }
}

/// `[battery]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Battery {
    /// Open-circuit voltage [V].
    pub nominal_v: f64,
    /// Internal resistance [Ω].
    pub internal_resistance_ohm: f64,
}

impl Default for Battery {
    /// The Husky's 24 V pack; 50 mΩ (not in the seed).
    fn default() -> Self {
        Self {
            nominal_v: 24.0,
            internal_resistance_ohm: 0.05,
        }
    }
}

/// `[driver]`: the standstill draw per side (the drivers' quiescent current, real power from the
/// battery; thesis Fig. 3.3 measures ≈ 0 A at rest on the INA226 board — not the
/// `current-offset` effect, a sensor offset).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Driver {
    /// Each motor driver's own draw, also at standstill [A].
    pub quiescent_current_a: f64,
    /// The left driver's draw when it differs from `quiescent_current_a` [A].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub left_quiescent_current_a: Option<f64>,
    /// The right driver's draw when it differs from `quiescent_current_a` [A].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub right_quiescent_current_a: Option<f64>,
}

impl Default for Driver {
    /// 50 mA per side (not in the seed).
    fn default() -> Self {
        Self {
            quiescent_current_a: 0.05,
            left_quiescent_current_a: None,
            right_quiescent_current_a: None,
        }
    }
}

impl Driver {
    /// The standstill draw of each side [A].
    pub fn quiescent_a(&self) -> Sides<f64> {
        Sides::new(
            self.left_quiescent_current_a
                .unwrap_or(self.quiescent_current_a),
            self.right_quiescent_current_a
                .unwrap_or(self.quiescent_current_a),
        )
    }
}

/// `[motor]`: one side's brushed DC motor and gearbox (Eq 1.17–1.19).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Motor {
    /// K_T [N·m/A].
    pub torque_constant_nm_per_a: f64,
    /// Gear ratio.
    pub gear_ratio: f64,
    /// η.
    pub efficiency: f64,
    /// R_m at ambient temperature [Ω].
    pub winding_resistance_ohm: f64,
}

impl Default for Motor {
    /// Not in the seed: a 24 V gearmotor of the Husky's class (K_T 0.044 N·m/A, 78.71:1,
    /// η 0.8, 0.15 Ω).
    fn default() -> Self {
        Self {
            torque_constant_nm_per_a: 0.044,
            gear_ratio: 78.71,
            efficiency: 0.8,
            winding_resistance_ohm: 0.15,
        }
    }
}

impl Motor {
    /// As a `model_core` motor.
    pub fn dc_motor(&self) -> DcMotor {
        DcMotor {
            torque_constant_nm_per_a: self.torque_constant_nm_per_a,
            gear_ratio: self.gear_ratio,
            efficiency: self.efficiency,
            winding_resistance_ohm: self.winding_resistance_ohm,
        }
    }
}

/// `[noise]`: measurement noise (Gaussian, from a counter-based hash of the seed and the time,
/// so a timeline is reproducible and cheap to query), and the variation of the terrain between
/// repeats and runs (from the same hash of the seed and the manoeuvre's index).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Noise {
    /// Current noise of the left sensor's input [A, std].
    pub left_current_std_a: f64,
    /// Current noise of the right sensor's input [A, std].
    pub right_current_std_a: f64,
    /// Bus voltage noise [V, std].
    pub bus_std_v: f64,
    /// Tracker yaw noise [rad, std].
    pub yaw_std_rad: f64,
    /// Tracker pitch noise [deg, std].
    pub pitch_std_deg: f64,
    /// Repeat-to-repeat variation: each manoeuvre's terrain resistance (the skid friction μ and
    /// the rolling resistance G of the baseline, so its whole Eq 21 power) is scaled by
    /// 1 + this × N(0, 1), drawn from the seed and the manoeuvre's index (real turns vary from
    /// one repeat to the next) [relative std, in [0, 0.5]; default 0].
    pub manoeuvre_power_std: f64,
    /// Run-to-run variation: one more such factor per run (drawn from the seed alone), for the
    /// ground and battery state that changes between runs [relative std, in [0, 0.5]; default 0].
    pub run_power_std: f64,
}

impl Default for Noise {
    /// 30 mA, 5 mV, 0.1°, 0.05° (not in the seed); no repeat-to-repeat or run-to-run variation.
    fn default() -> Self {
        Self {
            left_current_std_a: 0.03,
            right_current_std_a: 0.03,
            bus_std_v: 0.005,
            yaw_std_rad: 0.1f64.to_radians(),
            pitch_std_deg: 0.05,
            manoeuvre_power_std: 0.0,
            run_power_std: 0.0,
        }
    }
}

/// The effects' parameters and switches (see [`effects`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Effects {
    /// Which are on, in [`EffectId::ALL`] order.
    pub enabled: [bool; EffectId::COUNT],
    /// `[inner-drag]`.
    pub inner_drag: effects::InnerDrag,
    /// `[sinkage-bulldozing]`.
    pub sinkage_bulldozing: effects::SinkageBulldozing,
    /// `[angular-slip]`.
    pub angular_slip: effects::AngularSlip,
    /// `[slip-track]`.
    pub slip_track: effects::SlipTrack,
    /// `[braked-inner]`.
    pub braked_inner: effects::BrakedInner,
    /// `[current-offset]`.
    pub current_offset: effects::CurrentOffset,
    /// `[motor-heating]`.
    pub motor_heating: effects::MotorHeating,
    /// `[slope]`.
    pub slope: effects::Slope,
}

impl Effects {
    /// Whether `id` is on.
    pub fn is_enabled(&self, id: EffectId) -> bool {
        self.enabled[id as usize]
    }

    /// Switches `id`.
    pub fn set_enabled(&mut self, id: EffectId, on: bool) {
        self.enabled[id as usize] = on;
    }
}

/// A rover world: terrain, rover, power chain, sensors and effects. Read it from TOML with
/// [`load_world`]/[`parse_world`] (every key optional, unknown keys are errors):
///
/// ```toml
/// ground = "sand"                  # "hard" (default) or "sand"
/// rover = "../rovers/husky-a200.toml"  # optional; relative to the world file; default Husky
/// [icr]                            # defaults: paper Table 2 (hard) or the sand calibration
/// mu = 0.74
/// [battery]                        # nominal_v 24, internal_resistance_ohm 0.05
/// [driver]                         # quiescent_current_a 0.05 (both sides; left_/right_quiescent_current_a)
/// [motor]                          # torque_constant_nm_per_a, gear_ratio, efficiency, winding_resistance_ohm
/// [noise]                          # left/right_current_std_a, bus_std_v, yaw_std_rad, pitch_std_deg,
///                                  # manoeuvre_power_std, run_power_std (repeat/run variation, 0)
/// [tracker]                        # offset_m 0.21 (right of centre), rate_hz 5, position_std_m 0.002, dropout 0.05
/// [structure]                      # split = "threshold" | "regenerating" | "clamped", threshold_radius_m,
///                                  # angular_slip 0, drive_power = "electrical" | "mechanical"
/// [inner-drag]                     # every effect: enabled (ground default) + its parameters
/// enabled = true
/// torque_nm = 16.0
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WorldConfig {
    /// The terrain.
    pub ground: Ground,
    /// The rover (Table 3.2 Husky by default).
    pub rover: Rover,
    /// The baseline ICR power model.
    pub icr: IcrParams,
    /// The battery.
    pub battery: Battery,
    /// The motor drivers.
    pub driver: Driver,
    /// Each side's motor.
    pub motor: Motor,
    /// The structural switches ([`structure`]).
    pub structure: Structure,
    /// Measurement noise.
    pub noise: Noise,
    /// The pose tracker's position fixes.
    pub tracker: Tracker,
    /// The effects.
    pub effects: Effects,
}

impl WorldConfig {
    /// Hard ground, Husky, paper Table 2, no effects.
    pub fn hard_ground() -> Self {
        Self::for_ground(Ground::Hard)
    }

    /// The sandbox, Husky, with the sand effects on.
    pub fn sand() -> Self {
        Self::for_ground(Ground::Sand)
    }

    /// The defaults of a ground.
    pub fn for_ground(ground: Ground) -> Self {
        let mut effects = Effects::default();
        for id in EffectId::ALL {
            effects.set_enabled(id, ground == Ground::Sand && id.on_by_default_on_sand());
        }
        if ground == Ground::Sand {
            effects.angular_slip = effects::AngularSlip::SAND;
            effects.braked_inner = effects::BrakedInner::SAND;
        }
        Self {
            ground,
            rover: Rover::HUSKY_A200,
            icr: match ground {
                Ground::Hard => IcrParams::HARD_GROUND,
                Ground::Sand => IcrParams::SAND,
            },
            battery: Battery::default(),
            driver: Driver::default(),
            motor: Motor::default(),
            structure: Structure::default(),
            noise: Noise::default(),
            tracker: Tracker::default(),
            effects,
        }
    }

    /// The same world with only `id` switched (`on`).
    pub fn with_effect(mut self, id: EffectId, on: bool) -> Self {
        self.effects.set_enabled(id, on);
        self
    }

    /// The same world without measurement noise.
    pub fn without_noise(mut self) -> Self {
        self.noise = Noise {
            left_current_std_a: 0.0,
            right_current_std_a: 0.0,
            bus_std_v: 0.0,
            yaw_std_rad: 0.0,
            pitch_std_deg: 0.0,
            manoeuvre_power_std: 0.0,
            run_power_std: 0.0,
        };
        self.tracker.position_std_m = 0.0;
        self.tracker.dropout = 0.0;
        self
    }

    /// The terrain's slip track: the `slip-track` effect's (Table D.1 default per ground) when
    /// on, else the controller's [m].
    pub fn terrain_slip_track_m(&self) -> f64 {
        if self.effects.is_enabled(EffectId::SlipTrack) {
            self.effects
                .slip_track
                .slip_track_m
                .unwrap_or(match self.ground {
                    Ground::Hard => effects::HARD_GROUND_SLIP_TRACK_M,
                    Ground::Sand => effects::SANDBOX_SLIP_TRACK_M,
                })
        } else {
            f64::from(self.rover.slip_track_m)
        }
    }

    /// The `threshold` split's fade radius R_f [m]: derived from `[structure]
    /// threshold_radius_m` when given (None if no R_f puts the zero crossing there), else
    /// `[icr] traction_fade_radius_m`.
    pub fn traction_fade_radius_m(&self) -> Option<f64> {
        match self.structure.threshold_radius_m {
            None => Some(self.icr.traction_fade_radius_m),
            Some(rt) => structure::fade_radius_for_threshold_m(
                rt,
                f64::from(self.rover.slip_track_m),
                &self.icr.model(&self.rover),
            ),
        }
    }

    /// Simulates `scenario`; the same seed gives the same timeline.
    pub fn simulate(&self, scenario: &Scenario, seed: u64) -> Result<Timeline, WorldError> {
        self.validate("world")?;
        let segments = scenario.segments(&self.rover, "scenario")?;
        engine::run(self, &segments, seed)
    }
}

impl Default for WorldConfig {
    fn default() -> Self {
        Self::hard_ground()
    }
}

#[cfg(test)]
mod tests;
