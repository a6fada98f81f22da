//! `[structure]`: how the world turns the baseline ICR power into what each side's driver draws
//! and how the rover yaws — the structural alternatives the seed allows, as switches, so a
//! diagnosis can be checked on worlds whose structure it was not built on (issue 10). The
//! defaults are the world as it was before the switches existed.
//!
//! - `split`: the per-side split of the skid power F|ω_z| (paper Eq 21 is a total):
//!   - `"threshold"` (default): the tread couple ±F/B_s fading as 1/(1 + (R/R_f)²) for wide
//!     arcs, so the inner side regenerates for R' < R < R_T and turns positive again past the
//!     threshold radius R_T (paper Section 4.4, Fig. 11: R_T = 18 m for the Husky on concrete).
//!     The seed only measures R_T; `threshold_radius_m` sets it and the fade radius R_f that puts
//!     the inner side's zero crossing there is derived ([`fade_radius_for_threshold_m`]); without
//!     it `[icr] traction_fade_radius_m` is used as given.
//!   - `"regenerating"`: the tread couple alone: the inner side regenerates for every R > R'
//!     (Dogru and Marques' picture, paper Section 4.4), its power shared with the outer side over
//!     the common bus.
//!   - `"clamped"`: the thesis' Section 1.1.3 rule for drivers that cannot regenerate: "any
//!     negative power calculated should be put to 0": the tread couple with each side's power
//!     clamped at zero, so the total exceeds Eq 21 for R > R'.
//! - `angular_slip`: a constant fraction by which the rover yaws slower than commanded in every
//!   turn, calibration turns included (thesis Section 6.2, Fig. 6.7: "a constant offset" between
//!   the actual and the expected time of a turn on hard ground). Distinct from the
//!   `angular-slip` effect (Eq 6.3, peaking at R').
//! - `drive_power`: `"electrical"` (default): Eq 21 is the power drawn at the drivers (the paper
//!   fitted μ and G to measured electrical power); `"mechanical"`: Eq 21 is the wheels'
//!   mechanical power and each motor adds its losses per Eq 1.18–1.19, P = τω/η + (τ/(K_T g η))²
//!   R_m (`[motor] efficiency`, `winding_resistance_ohm` set their strength; a generating side
//!   returns τωη).
//!
//! The standstill draw per side is the drivers' quiescent current (`[driver]`, thesis Fig. 3.3:
//! ≈ 0 A on the INA226 board), real power drawn from the battery; the `current-offset` effect is
//! a sensor offset (0.59 A on the built-in sensing), not a draw.

use serde::{Deserialize, Serialize};

/// The per-side split of the skid power (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PowerSplit {
    /// The tread couple fading past R_T: the inner side turns positive again (paper Fig. 11).
    #[default]
    Threshold,
    /// The tread couple alone: the inner side regenerates for every R > R'.
    Regenerating,
    /// The tread couple with negative side power put to 0 (thesis Section 1.1.3).
    Clamped,
}

impl PowerSplit {
    /// Every split, default first.
    pub const ALL: [PowerSplit; 3] = [
        PowerSplit::Threshold,
        PowerSplit::Regenerating,
        PowerSplit::Clamped,
    ];

    /// The TOML value.
    pub const fn id(self) -> &'static str {
        match self {
            PowerSplit::Threshold => "threshold",
            PowerSplit::Regenerating => "regenerating",
            PowerSplit::Clamped => "clamped",
        }
    }
}

/// What Eq 21's power is (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DrivePower {
    /// The drivers' electrical power.
    #[default]
    Electrical,
    /// The wheels' mechanical power; the motors add Eq 1.18–1.19's losses.
    Mechanical,
}

/// `[structure]` (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Structure {
    /// The per-side split of the skid power.
    pub split: PowerSplit,
    /// R_T [m, commanded radius]: where the `threshold` split's inner side turns positive again
    /// (None: `[icr] traction_fade_radius_m` as given).
    pub threshold_radius_m: Option<f64>,
    /// Constant fraction of the commanded yaw rate lost in every turn, in [0, 0.5].
    pub angular_slip: f64,
    /// What Eq 21's power is.
    pub drive_power: DrivePower,
}

/// The fade radius R_f [m] that puts the `threshold` split's inner-side zero crossing at the
/// commanded radius `threshold_radius_m`, or None when no R_f can (R_T ≤ R', or G ≥ F/B_s so the
/// inner side never regenerates).
///
/// At the model's radius r = R_T B_s/B_s,controller the inner side's power is
/// V_i (G + (1 − f) F/(2r) − f F/B_s) (the fade f = 1/(1 + (r/R_f)²) of the couple goes to the
/// sides in proportion to |V|), zero for f = (G + F/(2r)) / (F/B_s + F/(2r)).
pub fn fade_radius_for_threshold_m(
    threshold_radius_m: f64,
    controller_slip_track_m: f64,
    icr: &model_core::power::IcrHardGround,
) -> Option<f64> {
    let r_prime = controller_slip_track_m / 2.0;
    if !(threshold_radius_m.is_finite() && threshold_radius_m > r_prime) {
        return None;
    }
    let f_moment = icr.skid_moment_nm();
    let r = threshold_radius_m * icr.slip_track_m / controller_slip_track_m;
    let couple = f_moment / icr.slip_track_m;
    let spread = f_moment / (2.0 * r);
    let fade = (icr.rolling_resistance_n + spread) / (couple + spread);
    (fade > 0.0 && fade < 1.0).then(|| r / (1.0 / fade - 1.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::world::{
        IcrParams, Manoeuvre, Scenario, Side, Timeline, WorldConfig, TRACTION_FADE_RADIUS_M,
    };
    use model_core::Rover;

    /// The Husky's 18 m (paper Fig. 11) gives back the world's default fade radius, 11.1 m.
    #[test]
    fn husky_threshold_radius_gives_the_default_fade_radius() {
        let rover = Rover::HUSKY_A200;
        let icr = IcrParams::HARD_GROUND.model(&rover);
        let rf =
            fade_radius_for_threshold_m(18.0, f64::from(rover.slip_track_m), &icr).expect("exists");
        assert!((rf - TRACTION_FADE_RADIUS_M).abs() < 0.05, "{rf}");
        assert!(fade_radius_for_threshold_m(0.5, 1.1, &icr).is_none());
        let mut flat = icr;
        flat.rolling_resistance_n = 1e4;
        assert!(fade_radius_for_threshold_m(18.0, 1.1, &flat).is_none());
    }

    const V_C: f64 = 0.3;

    /// Noise-free 90° left turns at commanded radii `radii_m` (0: point turn), no quiescent draw.
    fn turns(world: WorldConfig, radii_m: &[f64]) -> Timeline {
        let mut world = world.without_noise();
        world.driver.quiescent_current_a = 0.0;
        let manoeuvres = radii_m
            .iter()
            .map(|&r| Manoeuvre::Turn {
                radius_m: Some(r),
                r_over_r_prime: None,
                angle_deg: 90.0,
                v_c_mps: V_C,
                direction: Side::Left,
            })
            .collect();
        let scenario = Scenario {
            repeats: 1,
            pause_s: 1.0,
            lead_in_s: 1.0,
            lead_out_s: 1.0,
            manoeuvres,
        };
        world.simulate(&scenario, 1).expect("simulates")
    }

    fn with_split(split: PowerSplit) -> WorldConfig {
        let mut w = WorldConfig::hard_ground();
        w.structure.split = split;
        w
    }

    fn inner_w(t: &Timeline) -> Vec<f64> {
        t.manoeuvres().iter().map(|m| m.avg_power_w.left).collect()
    }

    /// Section 1.1.3's clamp: the inner side never draws below zero, at any sample, and the
    /// total then exceeds Eq 21 past R' (the regenerated power is no longer netted).
    #[test]
    fn clamped_split_never_takes_the_inner_side_below_zero() {
        let radii = [0.0, 0.3, 0.55, 0.9, 2.0, 10.0, 30.0];
        let clamped = turns(with_split(PowerSplit::Clamped), &radii);
        for m in clamped.manoeuvres() {
            for k in 0..=20 {
                let t_us = m.start_us + (m.end_us - m.start_us) * k / 20;
                let load = clamped.true_load_at(t_us);
                assert!(load.left.current_a >= 0.0, "{}: {load:?}", m.label);
            }
        }
        let regen = turns(with_split(PowerSplit::Regenerating), &radii);
        for (c, r) in clamped.manoeuvres().iter().zip(regen.manoeuvres()) {
            let (pc, pr) = (c.avg_total_power_w(), r.avg_total_power_w());
            if r.avg_power_w.left < -1.0 {
                assert!(pc > pr + 1.0, "{}: {pc} vs {pr}", c.label);
            } else {
                assert!((pc - pr).abs() < 0.05, "{}: {pc} vs {pr}", c.label);
            }
        }
    }

    /// Every split draws the same G|V| on both sides of a straight line: with no yaw there is no
    /// skid couple to split (a couple there made the regenerating world misfit its own straights).
    #[test]
    fn straights_have_no_skid_couple_in_any_split() {
        for split in PowerSplit::ALL {
            let mut world = with_split(split).without_noise();
            world.driver.quiescent_current_a = 0.0;
            let scenario = Scenario {
                repeats: 1,
                pause_s: 1.0,
                lead_in_s: 1.0,
                lead_out_s: 1.0,
                manoeuvres: vec![Manoeuvre::Straight {
                    distance_m: 2.0,
                    speed_mps: V_C,
                }],
            };
            let t = world.simulate(&scenario, 1).expect("simulates");
            let p = t.manoeuvres()[0].avg_power_w;
            assert!(p.left > 0.0, "{split:?}: {p:?}");
            assert!(
                (p.left - p.right).abs() < 0.01 * p.right,
                "{split:?}: {p:?}"
            );
        }
    }

    /// The tread couple alone regenerates at every R > R', even at 100 m.
    #[test]
    fn regenerating_split_keeps_the_inner_side_negative_past_r_prime() {
        let inner = inner_w(&turns(
            with_split(PowerSplit::Regenerating),
            &[0.8, 5.0, 18.0, 30.0, 100.0],
        ));
        assert!(inner.iter().all(|&p| p < 0.0), "{inner:?}");
    }

    /// The R_T split with R_T set to 12 m (Husky) and 18 m (Argo J5 geometry): the inner side is
    /// negative between R' and R_T and positive beyond (paper Fig. 11).
    #[test]
    fn threshold_split_turns_positive_past_the_threshold_radius() {
        let mut w = with_split(PowerSplit::Threshold);
        w.structure.threshold_radius_m = Some(12.0);
        let inner = inner_w(&turns(w, &[0.8, 4.0, 11.0, 13.0, 25.0]));
        assert!(inner[..3].iter().all(|&p| p < 0.0), "{inner:?}");
        assert!(inner[3..].iter().all(|&p| p > 0.0), "{inner:?}");
        let mut argo = w;
        argo.rover = Rover {
            track_width_m: 1.14,
            length_m: 0.98,
            wheel_radius_m: 0.3,
            mass_kg: 372.0,
            slip_track_m: 1.14,
        };
        argo.structure.threshold_radius_m = Some(18.0);
        let inner = inner_w(&turns(argo, &[1.0, 10.0, 17.0, 19.0, 40.0]));
        assert!(inner[..3].iter().all(|&p| p < 0.0), "{inner:?}");
        assert!(inner[3..].iter().all(|&p| p > 0.0), "{inner:?}");
    }

    /// Fig. 6.7's constant offset: every turn, the calibration turns (0, 2R', 3R') included,
    /// lasts the commanded time / (1 − s); the yaw rate is short by s.
    #[test]
    fn constant_angular_slip_slows_every_turn_by_its_fraction() {
        let mut w = WorldConfig::hard_ground();
        w.structure.angular_slip = 0.1;
        for m in turns(w, &[0.0, 0.3, 0.55, 1.1, 1.65, 5.0]).manoeuvres() {
            let stretch = m.duration_s() * 0.9 / m.expected_duration_s;
            assert!((stretch - 1.0).abs() < 1e-3, "{}: {stretch}", m.label);
            assert!((m.angular_slip.expect("turn") - 0.1).abs() < 1e-9);
        }
    }

    /// The standstill draw is per side and real: each side's idle current is its driver's.
    #[test]
    fn standstill_draw_is_per_side() {
        let mut w = WorldConfig::hard_ground().without_noise();
        w.driver.left_quiescent_current_a = Some(0.0);
        w.driver.right_quiescent_current_a = Some(0.12);
        let t = w
            .simulate(&Scenario::seed_turns(V_C, 1), 1)
            .expect("simulates");
        let idle = t.true_load_at(0);
        assert_eq!(idle.left.current_a, 0.0);
        assert!((idle.right.current_a - 0.12).abs() < 1e-12);
        let m = &t.manoeuvres()[0];
        let mid = t.true_load_at((m.start_us + m.end_us) / 2);
        let p = t.true_power_w((m.start_us + m.end_us) / 2);
        // Quiescent draw is power from the battery, on the right side only.
        assert!((mid.right.current_a * mid.right.bus_v - p.right).abs() < 1e-9);
        assert!(mid.right.current_a - mid.left.current_a > 0.1);
    }

    /// Eq 1.18–1.19 losses: with η = 1 and R_m = 0 the mechanical world is the electrical one;
    /// with η < 1 a straight line draws 1/η of Eq 21 plus copper, and copper grows with R_m
    /// (∝ τ², so most in the point turn).
    #[test]
    fn mechanical_drive_power_adds_the_motor_losses() {
        let radii = [0.0, 0.55, 5.0];
        let electrical = turns(WorldConfig::hard_ground(), &radii);
        let mut lossless = WorldConfig::hard_ground();
        lossless.structure.drive_power = DrivePower::Mechanical;
        lossless.motor.efficiency = 1.0;
        lossless.motor.winding_resistance_ohm = 0.0;
        let ideal = turns(lossless, &radii);
        for (a, b) in electrical.manoeuvres().iter().zip(ideal.manoeuvres()) {
            let (pa, pb) = (a.avg_total_power_w(), b.avg_total_power_w());
            assert!((pa - pb).abs() < 1e-6 * pa.abs().max(1.0), "{pa} vs {pb}");
        }
        let lossy = |eta: f64, rm: f64| {
            let mut w = lossless;
            w.motor.efficiency = eta;
            w.motor.winding_resistance_ohm = rm;
            turns(w, &radii)
                .manoeuvres()
                .iter()
                .map(|m| m.avg_total_power_w())
                .collect::<Vec<f64>>()
        };
        let eq21: Vec<f64> = electrical
            .manoeuvres()
            .iter()
            .map(|m| m.avg_total_power_w())
            .collect();
        let no_copper = lossy(0.8, 0.0);
        // The point turn: both sides motoring, 1/η of Eq 21.
        assert!(
            (no_copper[0] - eq21[0] / 0.8).abs() < 1e-6 * eq21[0],
            "{no_copper:?}"
        );
        let (low, high) = (lossy(0.8, 0.05), lossy(0.8, 0.5));
        for k in 0..radii.len() {
            assert!(
                high[k] > low[k] && low[k] > no_copper[k],
                "{low:?} {high:?}"
            );
        }
        assert!(high[0] - low[0] > high[2] - low[2]);
    }

    /// At R′ the inner side is commanded to stand still, but its tread still carries the skid
    /// couple's force (it slides lengthwise by ω(B_s − B)/2): the motor holds it at stall and
    /// draws that torque's copper loss, R_m (F r / K_T g η)², and no other power. In every
    /// split: the clamp puts only negative power to 0.
    #[test]
    fn a_side_held_at_stall_draws_the_copper_loss_of_its_tread_force() {
        for split in [PowerSplit::Regenerating, PowerSplit::Clamped] {
            let mut world = with_split(split);
            world.structure.drive_power = DrivePower::Mechanical;
            world.motor.efficiency = 1.0;
            let r_prime = f64::from(world.rover.r_prime_m());
            let held_w = |rm: f64| {
                let mut w = world;
                w.motor.winding_resistance_ohm = rm;
                inner_w(&turns(w, &[r_prime]))[0]
            };
            let icr = world.icr.model(&world.rover);
            let force_n = icr.skid_moment_nm() / icr.slip_track_m;
            let torque_per_amp = world.motor.torque_constant_nm_per_a * world.motor.gear_ratio;
            let current_a = force_n * f64::from(world.rover.wheel_radius_m) / torque_per_amp;
            let expected_w = 0.4 * current_a * current_a;
            assert!(expected_w > 1.0, "{expected_w}");
            let got = held_w(0.4);
            assert!(
                (got - expected_w).abs() < 0.02 * expected_w,
                "{got} vs {expected_w}"
            );
            assert!(held_w(0.0).abs() < 1e-9);
        }
    }

    #[test]
    fn structure_toml_reads_and_checks_its_keys() {
        let w = crate::sim::world::parse_world(
            "[structure]\nsplit = \"clamped\"\nangular_slip = 0.05\n\
             drive_power = \"mechanical\"\n[driver]\nright_quiescent_current_a = 0.0\n",
        )
        .expect("parses");
        assert_eq!(w.structure.split, PowerSplit::Clamped);
        assert_eq!(w.structure.drive_power, DrivePower::Mechanical);
        assert_eq!(w.driver.quiescent_a().right, 0.0);
        assert_eq!(w.driver.quiescent_a().left, 0.05);
        assert_eq!(
            crate::sim::world::parse_world("").expect("empty").structure,
            Structure::default()
        );
        for bad in [
            "[structure]\nsplit = \"sideways\"",
            "[structure]\nangular_slip = 0.7",
            "[structure]\nthreshold_radius_m = 0.2",
            "[structure]\nfade = 1",
        ] {
            assert!(crate::sim::world::parse_world(bad).is_err(), "{bad}");
        }
    }
}
