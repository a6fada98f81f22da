//! World tests: the hard-ground baseline against paper Eq 21, the sand calibration against the
//! seed's figures, each effect alone, determinism, TOML errors, mirror symmetry and the
//! simulated board.

use super::*;
use crate::sim::board::SimBoard;
use model_core::kinematics::side_speeds_for;
use model_core::kinematics::Regime;
use std::path::Path;
use std::sync::Arc;

const V_C: f64 = 0.3;
const R_PRIME: f64 = 0.55;

fn turns(ks: &[f64], direction: Side, repeats: u32) -> Scenario {
    Scenario {
        repeats,
        pause_s: 1.0,
        lead_in_s: 1.0,
        lead_out_s: 1.0,
        manoeuvres: ks
            .iter()
            .map(|&k| Manoeuvre::Turn {
                radius_m: None,
                r_over_r_prime: Some(k),
                angle_deg: 90.0,
                v_c_mps: V_C,
                direction,
            })
            .collect(),
    }
}

/// The seed's set: 0, R'/3, 2R'/3, R', 4R'/3, 2R' (indices 0–5) and a 1 m straight (6).
fn seed_set(world: &WorldConfig, repeats: u32) -> Timeline {
    world
        .without_noise()
        .simulate(&Scenario::seed_turns(V_C, repeats), 42)
        .expect("simulates")
}

fn motion_power_w(world: &WorldConfig, m: &ManoeuvreTruth) -> f64 {
    // Quiescent draw at the mean bus voltage of the manoeuvre ≈ nominal: removed exactly in the
    // tests that need it by setting it to zero instead.
    m.avg_total_power_w() - 2.0 * world.driver.quiescent_current_a * world.battery.nominal_v
}

fn no_quiescent(mut w: WorldConfig) -> WorldConfig {
    w.driver.quiescent_current_a = 0.0;
    w
}

#[test]
fn hard_ground_reproduces_the_icr_model() {
    let world = no_quiescent(WorldConfig::hard_ground());
    let icr = IcrParams::HARD_GROUND.model(&world.rover);
    let ks = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0, 4.0 / 3.0, 2.0, 6.0];
    let t = world
        .without_noise()
        .simulate(&turns(&ks, Side::Left, 1), 1)
        .expect("simulates");
    for (m, k) in t.manoeuvres().iter().zip(ks) {
        let s = side_speeds_for(
            0.3,
            (k * R_PRIME) as f32,
            0.55,
            model_core::TurnDirection::Left,
        );
        let model = icr.power_w(f64::from(s.left_mps), f64::from(s.right_mps));
        let got = m.avg_total_power_w();
        assert!(
            (got - model).abs() < 1e-3 * model,
            "R = {k} R': {got} W vs Eq 21 {model} W"
        );
        // Hard ground: the turn lasts exactly as commanded.
        assert!((m.duration_s() - m.expected_duration_s).abs() < 1e-5);
        assert!(m.angular_slip.expect("a turn").abs() < 1e-9);
    }
    // Constant below R' (Eq 2.16, Fig 4.6): 114.7 W at v_c = 0.3.
    let p0 = t.manoeuvres()[0].avg_total_power_w();
    assert!(
        (p0 - (206.82 * 0.6 / 1.29 + 30.85 * 0.6)).abs() < 0.05,
        "{p0}"
    );
    // At R' the inner side only draws its driver's quiescent current (here 0).
    assert!(t.manoeuvres()[3].avg_power_w.left.abs() < 1e-9);
    // Straight line: 2 G v (paper Lemma 1).
    let straight = seed_set(&world, 1);
    let s = &straight.manoeuvres()[6];
    assert!((s.avg_total_power_w() - 2.0 * 30.85 * 0.3).abs() < 1e-6);
    assert!((s.avg_power_w.left - s.avg_power_w.right).abs() < 1e-9);
    // With the default quiescent draw: Eq 21 plus two drivers' 50 mA.
    let world = WorldConfig::hard_ground();
    let t = seed_set(&world, 1);
    let m = &t.manoeuvres()[0];
    assert!((motion_power_w(&world, m) - p0).abs() < 0.05);
}

#[test]
fn hard_ground_inner_side_regenerates_between_r_prime_and_r_t() {
    // Paper Fig. 11 and Section 4.4: negative inner power for R' < R < R_T ≈ 18 m.
    let world = no_quiescent(WorldConfig::hard_ground());
    let ks: Vec<f64> = [1.5 * R_PRIME, 2.0, 10.0, 16.5, 19.5, 30.0]
        .iter()
        .map(|r| r / R_PRIME)
        .collect();
    let t = world
        .without_noise()
        .simulate(&turns(&ks, Side::Left, 1), 1)
        .expect("simulates");
    let inner: Vec<f64> = t.manoeuvres().iter().map(|m| m.avg_power_w.left).collect();
    assert!(inner[..4].iter().all(|&p| p < 0.0), "{inner:?}");
    assert!(inner[4..].iter().all(|&p| p > 0.0), "{inner:?}");
}

#[test]
fn calibration_sand_point_turn_about_twice_hard_ground() {
    // Section 4.4.1 (Fig 4.8): "the magnitude of the power consumed on sand reach around twice
    // the power consumed on hard ground for turns with 0 ≤ R ≤ R'"; the gap shrinks above R'.
    let sand = seed_set(&WorldConfig::sand(), 1);
    let hard = seed_set(&WorldConfig::hard_ground(), 1);
    let ratio = |i: usize| {
        sand.manoeuvres()[i].avg_total_power_w() / hard.manoeuvres()[i].avg_total_power_w()
    };
    let r0 = ratio(0);
    assert!((1.9..=2.2).contains(&r0), "P_sand(0) / P_hard(0) = {r0}");
    for i in 1..=3 {
        assert!((1.8..=2.6).contains(&ratio(i)), "R = {i}R'/3: {}", ratio(i));
    }
    assert!(
        ratio(5) < ratio(3) && ratio(4) < ratio(3),
        "gap shrinks above R'"
    );
}

#[test]
fn calibration_sand_average_power_peaks_15_to_20_percent_above_p0_in_the_dragged_region() {
    // Section 4.4.2 (Fig 4.9): "to values 15% to 20% higher than P(0)) and peak in the special
    // case region ... (B/2 < R < R')".
    let t = seed_set(&WorldConfig::sand(), 1);
    let p: Vec<f64> = t.manoeuvres()[..4]
        .iter()
        .map(|m| m.avg_total_power_w())
        .collect();
    let peak = p[2] / p[0];
    assert!(
        (1.15..=1.20).contains(&peak),
        "P(2R'/3)/P(0) = {peak} ({p:?})"
    );
    assert_eq!(t.manoeuvres()[2].regime, Some(Regime::DraggedInner));
    assert!(p[1] < p[2] && p[3] < p[2], "{p:?}");
    // Hard ground: flat (Eq 2.16).
    let h = seed_set(&WorldConfig::hard_ground(), 1);
    let q: Vec<f64> = h.manoeuvres()[..4]
        .iter()
        .map(|m| m.avg_total_power_w())
        .collect();
    assert!(q.iter().all(|x| (x - q[0]).abs() < 1e-6 * q[0]), "{q:?}");
}

#[test]
fn calibration_sand_inner_torque_70_percent_higher_at_two_thirds_r_prime() {
    // Section 5.2 (Fig 5.6, Eq 5.14): "it requires around 70% more torque for these wheels to
    // rotate versus the R'/3 case", τ ∝ P / ω_CMD.
    let t = seed_set(&WorldConfig::sand(), 1);
    let tau = |i: usize| {
        let m = &t.manoeuvres()[i];
        m.avg_power_w.left / (m.cmd_mps.left.abs() / 0.165)
    };
    let ratio = tau(2) / tau(1);
    assert!((1.6..=1.8).contains(&ratio), "τ(2R'/3)/τ(R'/3) = {ratio}");
    // Hard ground: the ICR model's inner torque is the same at both radii.
    let h = seed_set(&WorldConfig::hard_ground(), 1);
    let tau_h = |i: usize| {
        let m = &h.manoeuvres()[i];
        (m.avg_power_w.left - 0.05 * 24.0) / (m.cmd_mps.left.abs() / 0.165)
    };
    assert!((tau_h(2) / tau_h(1) - 1.0).abs() < 0.01);
}

#[test]
fn calibration_sand_power_rises_through_turns_up_to_r_prime() {
    // Section 4.4.1 (Fig 4.8): "For R ≤ R' ... power rises as the turn progresses"; Fig 4.11:
    // the rise is largest at 2R'/3 and the gap almost closes above R'.
    let world = WorldConfig::sand();
    let t = seed_set(&world, 1);
    let rise = |m: &ManoeuvreTruth| {
        let p = |t_us| {
            let s = t.true_power_w(t_us);
            s.left + s.right
        };
        p(m.end_us - 20_000) / p(m.start_us + 20_000) - 1.0
    };
    let r: Vec<f64> = t.manoeuvres()[..6].iter().map(rise).collect();
    for (i, x) in r[..4].iter().enumerate() {
        assert!(*x > 0.1, "R = {i}R'/3 rises by {x}");
    }
    assert!(r[2] >= r[0] && r[2] >= r[1] && r[2] >= r[3], "{r:?}");
    assert!(r[4] < r[3] && r[5] < r[3], "{r:?}");
    let h = seed_set(&WorldConfig::hard_ground(), 1);
    for m in &h.manoeuvres()[..6] {
        let a = h.true_power_w(m.start_us + 20_000);
        let b = h.true_power_w(m.end_us - 20_000);
        assert!(((a.left + a.right) - (b.left + b.right)).abs() < 1e-6);
    }
}

#[test]
fn calibration_sand_angular_slip_peaks_at_r_prime() {
    // Chapter 7: angular slip "peaks at R' to a value 40% higher than when R = 0"; Fig 6.7: the
    // time offset on sand is "at least double" the hard ground's (hard ground: its Table D.1
    // slip track 1.29 m).
    let sand = seed_set(&WorldConfig::sand(), 1);
    let s: Vec<f64> = sand.manoeuvres()[..6]
        .iter()
        .map(|m| m.angular_slip.expect("turn"))
        .collect();
    assert!((s[3] / s[0] - 1.4).abs() < 0.02, "{s:?}");
    let peak = s.iter().cloned().fold(f64::MIN, f64::max);
    assert_eq!(peak, s[3]);
    let hard = seed_set(
        &WorldConfig::hard_ground().with_effect(EffectId::SlipTrack, true),
        1,
    );
    for i in 0..4 {
        let off = |t: &Timeline| {
            let m = &t.manoeuvres()[i];
            m.duration_s() - m.expected_duration_s
        };
        assert!(off(&sand) >= 2.0 * off(&hard), "R = {i}R'/3");
    }
}

/// Runs the seed set ×2 on hard ground with only `id` on; returns it and the baseline.
fn alone(id: EffectId) -> (Timeline, Timeline) {
    let base = WorldConfig::hard_ground();
    let with = base.with_effect(id, true);
    let mut sc = Scenario::seed_turns(V_C, 2);
    sc.manoeuvres.push(Manoeuvre::PointTurn {
        angle_deg: 90.0,
        side_speed_mps: 0.3,
        direction: Side::Right,
    });
    let run = |w: &WorldConfig| w.without_noise().simulate(&sc, 3).expect("simulates");
    (run(&with), run(&base))
}

fn same_durations(a: &Timeline, b: &Timeline) -> bool {
    a.manoeuvres()
        .iter()
        .zip(b.manoeuvres())
        .all(|(x, y)| x.start_us == y.start_us && x.end_us == y.end_us)
}

fn power_changed(a: &ManoeuvreTruth, b: &ManoeuvreTruth) -> bool {
    (a.avg_total_power_w() - b.avg_total_power_w()).abs() > 1e-6
}

#[test]
fn each_effect_alone_changes_what_it_should_and_nothing_else() {
    for id in EffectId::ALL {
        let (with, base) = alone(id);
        let pairs: Vec<_> = with.manoeuvres().iter().zip(base.manoeuvres()).collect();
        assert_eq!(pairs.len(), 16);
        for (a, _) in &pairs {
            let ids: Vec<EffectId> = a.effect_energy_j.iter().map(|(e, _)| *e).collect();
            assert_eq!(ids, vec![id]);
        }
        match id {
            EffectId::InnerDrag | EffectId::BrakedInner => {
                assert!(same_durations(&with, &base), "{id}");
                let target = if id == EffectId::InnerDrag { 2 } else { 3 };
                for (a, b) in &pairs {
                    let expect = a.scenario_index == target;
                    assert_eq!(power_changed(a, b), expect, "{id}: {}", a.label);
                    if expect {
                        assert!(a.avg_total_power_w() > b.avg_total_power_w());
                        assert!(a.effect_energy(id).expect("on") > 0.0);
                    }
                }
            }
            EffectId::SinkageBulldozing => {
                assert!(same_durations(&with, &base));
                for (a, b) in &pairs {
                    assert!(a.avg_total_power_w() > b.avg_total_power_w(), "{}", a.label);
                }
            }
            EffectId::AngularSlip | EffectId::SlipTrack => {
                let stretch: Vec<f64> = pairs
                    .iter()
                    .map(|(a, b)| a.duration_s() / b.duration_s())
                    .collect();
                for ((a, b), s) in pairs.iter().zip(&stretch) {
                    assert!((a.avg_total_power_w() - b.avg_total_power_w()).abs() < 1e-6);
                    if a.kind == ManoeuvreKind::Straight {
                        assert!((s - 1.0).abs() < 1e-5);
                    } else {
                        assert!(*s > 1.05, "{id}: {} {s}", a.label);
                    }
                }
                if id == EffectId::AngularSlip {
                    // Peaks at R' (index 3).
                    let peak = (0..6).max_by(|&i, &j| stretch[i].total_cmp(&stretch[j]));
                    assert_eq!(peak, Some(3), "{stretch:?}");
                } else {
                    // The same for every turn: B_s,terrain / B_s,controller = 1.29 / 1.1.
                    for i in 0..6 {
                        assert!((stretch[i] - 1.29 / 1.1).abs() < 1e-4, "{stretch:?}");
                    }
                }
            }
            EffectId::CurrentOffset => {
                assert!(same_durations(&with, &base));
                for (a, b) in &pairs {
                    assert!(!power_changed(a, b));
                }
                // Visible at standstill (lead-in) in what the sensors see.
                let seen = with.load_at(500_000);
                let truth = base.load_at(500_000);
                assert!((seen.left.current_a - truth.left.current_a - 0.59).abs() < 1e-9);
                assert!((seen.right.current_a - truth.right.current_a - 0.59).abs() < 1e-9);
            }
            EffectId::MotorHeating => {
                assert!(same_durations(&with, &base));
                // Grows with run time: the same manoeuvre costs more in the second repeat.
                let extra = |m: &ManoeuvreTruth| m.effect_energy(id).expect("on") / m.duration_s();
                for i in 0..8 {
                    let (first, second) = (&pairs[i].0, &pairs[i + 8].0);
                    assert!(extra(first) > 0.0);
                    assert!(
                        extra(second) > extra(first),
                        "{} {} {}",
                        first.label,
                        extra(first),
                        extra(second)
                    );
                }
            }
            EffectId::Slope => {
                assert!(same_durations(&with, &base));
                let mut pitched_point_turns = 0;
                for (a, b) in &pairs {
                    if a.commanded_radius_m == Some(0.0) {
                        // No forward motion in a point turn: v_y = 0, so the total is
                        // unchanged, but each track pushes its half of the weight along
                        // itself: on a pitch the forward side climbs what the other descends.
                        assert!(!power_changed(a, b));
                        let left = a.avg_power_w.left - b.avg_power_w.left;
                        let right = a.avg_power_w.right - b.avg_power_w.right;
                        assert!((left + right).abs() < 1e-6, "{left} {right}");
                        if a.mean_pitch_deg.abs() > 0.1 {
                            assert!(left.abs() > 0.1, "{left} at {}°", a.mean_pitch_deg);
                            pitched_point_turns += 1;
                        }
                    }
                }
                assert!(pitched_point_turns > 0);
                let straight = &pairs[6];
                assert!(power_changed(straight.0, straight.1));
                assert!(straight.0.mean_pitch_deg.abs() > 0.0);
            }
        }
    }
}

#[test]
fn same_seed_same_timeline_other_seed_other_noise() {
    let w = WorldConfig::sand();
    let sc = turns(&[0.0, 2.0 / 3.0], Side::Left, 1);
    let a = w.simulate(&sc, 7).expect("simulates");
    let b = w.simulate(&sc, 7).expect("simulates");
    let c = w.simulate(&sc, 8).expect("simulates");
    assert_eq!(a, b);
    assert_eq!(
        a.manoeuvres(),
        c.manoeuvres(),
        "truth does not depend on the noise"
    );
    let times: Vec<u64> = (0..2000).map(|k| k * 4_480).collect();
    let la: Vec<_> = times.iter().map(|&t| a.load_at(t)).collect();
    let lb: Vec<_> = times.iter().map(|&t| b.load_at(t)).collect();
    let lc: Vec<_> = times.iter().map(|&t| c.load_at(t)).collect();
    assert_eq!(la, lb);
    assert!(la.iter().zip(&lc).filter(|(x, y)| x != y).count() > 1900);
    // Queried out of order, the same values.
    assert_eq!(a.load_at(times[1500]), la[1500]);
    assert_eq!(a.commands(5.0), b.commands(5.0));
    assert_ne!(a.commands(5.0), c.commands(5.0));
}

/// `manoeuvre_power_std` and `run_power_std`: each repeat's baseline power scaled by its own
/// factor (recorded in the truth), reproducible from the seed; 0 (the default) changes nothing.
#[test]
fn terrain_varies_from_repeat_to_repeat_and_run_to_run() {
    let sc = turns(&[0.0], Side::Left, 200);
    let plain = no_quiescent(WorldConfig::hard_ground().without_noise());
    let base = plain.simulate(&sc, 5).expect("simulates");
    assert!(base.manoeuvres().iter().all(|m| m.resistance_scale == 1.0));
    let mut varied = plain;
    varied.noise.manoeuvre_power_std = 0.05;
    let a = varied.simulate(&sc, 5).expect("simulates");
    assert_eq!(a, varied.simulate(&sc, 5).expect("simulates"));
    let scales: Vec<f64> = a.manoeuvres().iter().map(|m| m.resistance_scale).collect();
    let n = scales.len() as f64;
    let mean = scales.iter().sum::<f64>() / n;
    let std = (scales.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    assert!((mean - 1.0).abs() < 0.015, "{mean}");
    assert!((std - 0.05).abs() < 0.01, "{std}");
    // The whole Eq 21 power (both sides) scales; the duration does not.
    for (m, b) in a.manoeuvres().iter().zip(base.manoeuvres()) {
        assert_eq!(m.end_us - m.start_us, b.end_us - b.start_us);
        let (pm, pb) = (motion_power_w(&varied, m), motion_power_w(&plain, b));
        assert!(
            (pm / pb - m.resistance_scale).abs() < 1e-9,
            "{pm} vs {pb} × {}",
            m.resistance_scale
        );
    }
    // One factor for the whole run, another for another seed.
    let mut per_run = plain;
    per_run.noise.run_power_std = 0.05;
    let run_scale = |seed| {
        let t = per_run.simulate(&sc, seed).expect("simulates");
        let s: Vec<f64> = t.manoeuvres().iter().map(|m| m.resistance_scale).collect();
        assert!(s.iter().all(|x| *x == s[0]), "{s:?}");
        s[0]
    };
    assert_ne!(run_scale(5), run_scale(6));
    let e = parse_world("[noise]\nmanoeuvre_power_std = 0.7\n").expect_err("too large");
    assert!(e.to_string().contains("noise.manoeuvre_power_std"), "{e}");
    let w = parse_world("[noise]\nrun_power_std = 0.02\n").expect("valid");
    assert_eq!(w.noise.run_power_std, 0.02);
}

#[test]
fn left_and_right_turns_mirror() {
    let w = WorldConfig::sand().with_effect(EffectId::Slope, true);
    let ks = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0, 2.0];
    let l = w
        .without_noise()
        .simulate(&turns(&ks, Side::Left, 1), 1)
        .expect("left");
    let r = w
        .without_noise()
        .simulate(&turns(&ks, Side::Right, 1), 1)
        .expect("right");
    for (a, b) in l.manoeuvres().iter().zip(r.manoeuvres()) {
        assert_eq!((a.start_us, a.end_us), (b.start_us, b.end_us));
        assert!((a.avg_power_w.left - b.avg_power_w.right).abs() < 1e-9);
        assert!((a.avg_power_w.right - b.avg_power_w.left).abs() < 1e-9);
        assert!((a.true_yaw_rate_rad_s + b.true_yaw_rate_rad_s).abs() < 1e-12);
        assert_eq!(a.cmd_mps, b.cmd_mps.mirrored());
    }
    let end = l.duration_us();
    assert!((l.pose_at(end).0 + r.pose_at(end).0).abs() < 1e-9);
    assert!((l.pose_at(end).0 - 5.0 * std::f64::consts::FRAC_PI_2).abs() < 1e-6);
}

#[test]
fn commands_rows_follow_the_scenario_and_the_tracker() {
    let w = WorldConfig::sand();
    let t = w
        .simulate(&turns(&[1.0], Side::Left, 1), 1)
        .expect("simulates");
    let rows = t.commands(5.0);
    assert!(rows.windows(2).all(|p| p[0].t_s < p[1].t_s));
    let m = &t.manoeuvres()[0];
    // A row exactly where the turn starts, with its command; the tracker's yaw ends at 90°.
    let start = rows
        .iter()
        .find(|r| (r.t_s - m.start_us as f64 * 1e-6).abs() < 1e-9)
        .expect("a row at the command change");
    assert_eq!(start.cmd_mps, m.cmd_mps);
    let after = rows
        .iter()
        .find(|r| r.t_s > m.end_us as f64 * 1e-6)
        .expect("rows after the turn");
    assert_eq!(after.cmd_mps, model_core::Sides::new(0.0, 0.0));
    let yaw = after.yaw_rad.expect("tracked");
    assert!((yaw - std::f64::consts::FRAC_PI_2).abs() < 0.02, "{yaw}");
    assert!(rows.len() as f64 >= t.duration_s() * 5.0);
}

#[test]
fn world_toml_defaults_errors_and_files() {
    let w = parse_world("ground = \"sand\"\n[inner-drag]\nenabled = false\ntorque_nm = 3.0\n")
        .expect("valid");
    assert_eq!(w.ground, Ground::Sand);
    assert!(!w.effects.is_enabled(EffectId::InnerDrag));
    assert!(w.effects.is_enabled(EffectId::SinkageBulldozing));
    assert_eq!(w.effects.inner_drag.torque_nm, 3.0);
    assert_eq!(w.icr, IcrParams::SAND);
    assert_eq!(
        parse_world("").expect("empty is hard ground"),
        WorldConfig::hard_ground()
    );
    let e = parse_world("[inner-drag]\ntorq_nm = 1.0\n").expect_err("typo");
    let msg = e.to_string();
    assert!(
        msg.contains("inner-drag") && msg.contains("torq_nm"),
        "{msg}"
    );
    let e = parse_world("grund = \"sand\"\n").expect_err("typo");
    assert!(e.to_string().contains("grund"), "{e}");
    let e = parse_world("[icr]\nmu = -1\n").expect_err("negative");
    assert!(e.to_string().contains("icr.mu"), "{e}");
    let e = parse_world("[angular-slip]\nenabled = 1\n").expect_err("not a bool");
    assert!(e.to_string().contains("angular-slip.enabled"), "{e}");
    assert!(
        e.to_string()
            .ends_with("must be true or false, found an integer (1)"),
        "{e}"
    );
    let e = parse_world("[wheels]\nn = 4\n").expect_err("unknown table");
    assert!(e.to_string().contains("wheels"), "{e}");

    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let hard = load_world(&root.join("worlds/husky-hard-ground.toml")).expect("loads");
    assert_eq!(hard.ground, Ground::Hard);
    assert_eq!(hard.icr, IcrParams::HARD_GROUND);
    let sand = load_world(&root.join("worlds/husky-sand.toml")).expect("loads");
    let mut expected = WorldConfig::sand();
    expected.effects.slip_track.slip_track_m = Some(effects::SANDBOX_SLIP_TRACK_M);
    assert_eq!(sand, expected, "the file spells out the defaults");
    assert_eq!(
        sand.terrain_slip_track_m(),
        WorldConfig::sand().terrain_slip_track_m()
    );
    let seed = load_scenario(&root.join("scenarios/seed-turns.toml")).expect("loads");
    assert_eq!(seed, Scenario::seed_turns(0.3, 3));
    let clc = load_scenario(&root.join("scenarios/clc-path.toml")).expect("loads");
    let t = hard.simulate(&clc, 1).expect("simulates");
    assert!(t.manoeuvres().len() >= 6);
    let e = load_world(&root.join("worlds/missing.toml")).expect_err("no file");
    assert!(e.to_string().contains("missing.toml"), "{e}");
}

#[test]
fn clc_on_hard_ground_beats_plp_as_the_paper_predicts() {
    // Paper Table 3: the R'-CLC path (45°, 10 m, 45°) needs less energy than its PLP path. The
    // paper's energies assume the rover turns with B_s = 1.29 m (Table D.1 on concrete): the
    // slip-track effect. Commanded at the controller's R' = 0.55 m, the rover then drives
    // R'_H = 0.645 m, as the paper measured.
    let world = no_quiescent(WorldConfig::hard_ground())
        .with_effect(EffectId::SlipTrack, true)
        .without_noise();
    let ends = "start_heading_deg = 45\nend_heading_deg = 45\ndistance_m = 10\n";
    let run = |kind: &str, extra: &str| {
        let sc = parse_scenario(&format!("[[manoeuvres]]\nkind = \"{kind}\"\n{ends}{extra}"))
            .expect("valid");
        let t = world.simulate(&sc, 1).expect("simulates");
        t.manoeuvres()
            .iter()
            .map(|m| m.energy_j.left + m.energy_j.right)
            .sum::<f64>()
    };
    let clc = run("clc", "r_over_r_prime = 1.0\n");
    let plp = run("plp", "");
    // Paper Table 3: 1004.38 J for the PLP path.
    assert!((plp - 1004.38).abs() < 0.5, "{plp}");
    assert!(clc < plp, "{clc} vs {plp}");
}

#[test]
fn the_simulated_board_measures_the_world() {
    let world = WorldConfig::hard_ground().without_noise();
    let t = Arc::new(
        world
            .simulate(&turns(&[0.0], Side::Left, 1), 1)
            .expect("simulates"),
    );
    let mut sim = SimBoard::new(firmware::sampler::SamplerConfig::BOARD);
    sim.set_load(t.load_source());
    let m = t.manoeuvres()[0].clone();
    while sim.now_us() < m.start_us + 1_000_000 {
        sim.step();
    }
    let raw = sim
        .bus_mut()
        .peek(0x40, crate::sim::ina226::reg::CURRENT)
        .expect("left chip");
    let current_a = f64::from(raw as i16) * 0.0005;
    let truth = t.load_at(sim.now_us()).left.current_a;
    assert!(truth > 2.0, "a point turn draws amps: {truth}");
    assert!(
        (current_a - truth).abs() < 0.002,
        "{current_a} A vs {truth} A"
    );
}

/// ΔE of `scenarios/table-6.1.toml` driven in `world` (noise-free truth), per CLC entry.
fn table_6_1(world: &WorldConfig) -> Vec<super::path_energy::PathDeltaE> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let sc = load_scenario(&root.join("scenarios/table-6.1.toml")).expect("loads");
    let t = world.without_noise().simulate(&sc, 1).expect("simulates");
    super::path_energy::path_delta_e(&sc, t.manoeuvres(), f64::from(world.rover.r_prime_m()))
}

/// Thesis Table 6.1's slice means (45° – 10 m – 45° on sand) [%].
const TABLE_6_1_PCT: [f64; 5] = [4.55, 14.38, -8.63, -13.2, -12.03];

/// The Table 6.1-tuned sand world (`worlds/husky-sand-table-6.1.toml`).
fn table_6_1_world() -> WorldConfig {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    load_world(&root.join("worlds/husky-sand-table-6.1.toml")).expect("loads")
}

#[test]
fn table_6_1_sand_world_matches_the_thesis_slices() {
    // Thesis Table 6.1 (45° – 10 m – 45° on sand): slice means +4.55, +14.38, −8.63, −13.2,
    // −12.03 %. The sand world, driven through CLC paths at the slice centres and the PLP path
    // (three repeats), gives +0.71, +3.55, −10.82, −11.51, −11.17 %: four slices within ±5
    // points, the optimum in 2R' < R < 2.5R' and CLC dearer than PLP around R', but the slice
    // around R' 10.8 points short (the trade-off: `table_6_1_world_meets_every_slice_*`).
    let got = table_6_1(&WorldConfig::sand());
    let x: Vec<f64> = got.iter().map(|p| p.r_over_r_prime).collect();
    assert_eq!(x, [0.25, 1.0, 1.75, 2.25, 2.75]);
    let d: Vec<f64> = got.iter().map(|p| p.mean_delta_e_pct).collect();
    for p in &got {
        assert_eq!(p.delta_e_pct.len(), 3);
    }
    for (got, want) in d.iter().zip([0.71, 3.55, -10.82, -11.51, -11.17]) {
        assert!((got - want).abs() < 0.05, "{d:?}");
    }
    let within: Vec<bool> = d
        .iter()
        .zip(TABLE_6_1_PCT)
        .map(|(g, s)| (g - s).abs() <= 5.0)
        .collect();
    assert_eq!(within, [true, false, true, true, true], "{d:?}");
    let best = d.iter().cloned().fold(f64::INFINITY, f64::min);
    assert_eq!(best, d[3], "optimum in the 2–2.5 R' slice: {d:?}");
    assert!(d[1] > 0.0, "CLC dearer than PLP around R': {d:?}");
    // The thesis sorts by the actual radius over the actual R' (R_ACT/R'_ACT): slower turns near
    // R' drive wider circles there, so the commanded 2.25 R' is 1.57 R'_ACT.
    let ract: Vec<f64> = got
        .iter()
        .filter_map(|p| p.r_act_over_r_prime_act)
        .collect();
    assert!((ract[3] - 1.57).abs() < 0.01, "{ract:?}");
}

#[test]
fn table_6_1_world_meets_every_slice_at_the_cost_of_p_r_prime() {
    // Section 6.2: the R' turn's held inner wheels plough like a braked wheel (Fig 6.10–6.11).
    // At 60 N per wheel (the sand world: 15 N) the driven table gives +0.71, +10.99, −10.82,
    // −11.51, −11.17 %: every slice within ±5 points, the optimum in 2 – 2.5 R', CLC dearer
    // than PLP around R'.
    let world = table_6_1_world();
    let mut expected = WorldConfig::sand();
    expected.effects.braked_inner.resistance_n = 60.0;
    assert_eq!(
        world, expected,
        "the sand world but for the held wheels' resistance"
    );
    let d: Vec<f64> = table_6_1(&world)
        .iter()
        .map(|p| p.mean_delta_e_pct)
        .collect();
    for (got, want) in d.iter().zip([0.71, 10.99, -10.82, -11.51, -11.17]) {
        assert!((got - want).abs() < 0.05, "{d:?}");
    }
    for (g, s) in d.iter().zip(TABLE_6_1_PCT) {
        assert!((g - s).abs() <= 5.0, "{d:?} vs {TABLE_6_1_PCT:?}");
    }
    let best = d.iter().cloned().fold(f64::INFINITY, f64::min);
    assert_eq!(best, d[3], "{d:?}");
    assert!(d[1] > 0.0, "{d:?}");
    // The price in the laboratory figures: P(R') 14 % above P(0) (sand world 0.97; Section 6.2:
    // "there isn't a large difference"), still below the 2R'/3 peak (Fig 4.9); no other turn of
    // the seed set changes (their inner sides turn at ≥ 0.07 m/s, Table 5.2).
    let p_of = |w: &WorldConfig| -> Vec<f64> {
        seed_set(w, 1).manoeuvres()[..6]
            .iter()
            .map(|m| m.avg_total_power_w())
            .collect()
    };
    let (tuned, sand) = (p_of(&world), p_of(&WorldConfig::sand()));
    assert!((tuned[3] / tuned[0] - 1.14).abs() < 0.01, "{tuned:?}");
    assert!((sand[3] / sand[0] - 0.97).abs() < 0.01, "{sand:?}");
    assert!(tuned[3] < tuned[2], "{tuned:?}");
    for i in [0, 1, 2, 4, 5] {
        assert_eq!(tuned[i], sand[i], "{i}");
    }
}

/// ΔE [%] of the 45° – 10 m – 45° CLC path at each R/R' of `ks` against PLP (one repeat).
fn clc_delta_e(world: &WorldConfig, ks: &[f64]) -> Vec<f64> {
    let ends = "start_heading_deg = 45.0\nend_heading_deg = 45.0\ndistance_m = 10.0\n";
    let mut text = format!("repeats = 1\n[[manoeuvres]]\nkind = \"plp\"\n{ends}");
    for k in ks {
        text += &format!("[[manoeuvres]]\nkind = \"clc\"\n{ends}r_over_r_prime = {k}\n");
    }
    let sc = parse_scenario(&text).expect("valid");
    let t = world.without_noise().simulate(&sc, 1).expect("simulates");
    super::path_energy::path_delta_e(&sc, t.manoeuvres(), f64::from(world.rover.r_prime_m()))
        .iter()
        .map(|p| p.mean_delta_e_pct)
        .collect()
}

#[test]
fn braked_inner_holds_the_inner_wheels_near_r_prime() {
    // Held while |V_i| < 0.04 m/s (Fig 6.11): a CLC arc near R' ploughs too (less than at R'),
    // one at 0.8 R' or 1.25 R' does not.
    let world = table_6_1_world();
    let mut at_r_prime_only = world;
    at_r_prime_only.effects.braked_inner.held_speed_mps = 0.0;
    let ks = [0.8, 0.95, 1.0, 1.05, 1.25];
    let (band, only) = (clc_delta_e(&world, &ks), clc_delta_e(&at_r_prime_only, &ks));
    for i in [0, 2, 4] {
        assert!((band[i] - only[i]).abs() < 1e-9, "{band:?} vs {only:?}");
    }
    for i in [1, 3] {
        assert!(band[i] > only[i] + 1.0, "{band:?} vs {only:?}");
        assert!(band[i] < band[2], "{band:?}");
    }
    // A sand world file that leaves the band out keeps the sand's; a negative one is refused.
    let w = parse_world("ground = \"sand\"\n[braked-inner]\nresistance_n = 20.0\n").expect("valid");
    assert_eq!(w.effects.braked_inner.held_speed_mps, 0.04);
    assert_eq!(
        parse_world("")
            .expect("hard")
            .effects
            .braked_inner
            .held_speed_mps,
        0.0
    );
    let e = parse_world("[braked-inner]\nheld_speed_mps = -0.1\n").expect_err("negative");
    assert!(e.to_string().contains("braked-inner.held_speed_mps"), "{e}");
}

#[test]
fn table_6_1_the_fall_of_the_slip_above_r_prime_sets_the_optimum() {
    // With the slip falling as R'/R (the effect's default elsewhere) the savings keep growing
    // to 2.75 R' and stay near −7 %: the fall above R' is what the table calibrates.
    let mut world = WorldConfig::sand();
    world.effects.angular_slip.decay_exponent = 1.0;
    let d: Vec<f64> = table_6_1(&world)
        .iter()
        .map(|p| p.mean_delta_e_pct)
        .collect();
    assert!(d[3] > -8.0 && d[4] <= d[3] + 0.1, "{d:?}");
    // A sand world file that leaves the exponent out keeps the sand's.
    let w = parse_world("ground = \"sand\"\n[angular-slip]\nat_zero = 0.2\n").expect("valid");
    assert_eq!(w.effects.angular_slip, effects::AngularSlip::SAND);
    let e = parse_world("[angular-slip]\ndecay_exponent = -1\n").expect_err("negative");
    assert!(e.to_string().contains("angular-slip.decay_exponent"), "{e}");
}
