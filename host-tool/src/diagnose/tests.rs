//! Diagnosis on simulated runs: the world's timeline sampled at 200 Hz straight into run
//! samples (no pty; noise is in `Timeline::load_at`).

use super::baseline::Baseline;
use super::features::{self, SideRole, TurnRow};
use crate::log::run_csv::RunSample;
use crate::sim::world::{EffectId, Scenario, WorldConfig};
use crate::validate::{self, RunInput, ValidateOptions};
use model_core::kinematics::Regime;
use model_core::power::IcrHardGround;
use model_core::{Rover, Sides};

const HUSKY: Rover = Rover::HUSKY_A200;

/// One simulated run of `world` over `scenario`, sampled at 200 Hz.
pub(super) fn simulate_run(world: &WorldConfig, scenario: &Scenario, seed: u64) -> Vec<RunSample> {
    let timeline = world.simulate(scenario, seed).expect("scenario runs");
    let step_us = 5_000;
    (0..=timeline.duration_us() / step_us)
        .map(|k| {
            let t_us = k * step_us;
            let load = timeline.load_at(t_us);
            let (yaw_rad, pitch_deg) = timeline.pose_at(t_us);
            RunSample {
                t_s: t_us as f64 * 1e-6,
                bus_v: Sides::new(load.left.bus_v, load.right.bus_v),
                current_a: Sides::new(load.left.current_a, load.right.current_a),
                cmd_mps: timeline.command_at(t_us),
                yaw_rad: Some(yaw_rad),
                pitch_deg: Some(pitch_deg),
            }
        })
        .collect()
}

/// Rows of `runs` (each a run's samples) through `validate` and `features::rows`.
pub(super) fn rows_of(runs: &[Vec<RunSample>]) -> Vec<TurnRow> {
    let names: Vec<String> = (0..runs.len()).map(|k| format!("run-{k}")).collect();
    let inputs: Vec<RunInput<'_>> = runs
        .iter()
        .zip(&names)
        .map(|(s, n)| RunInput::from_samples(n, s))
        .collect();
    let report =
        validate::validate(&HUSKY, &inputs, &ValidateOptions::default()).expect("validates");
    let slices: Vec<&[RunSample]> = runs.iter().map(Vec::as_slice).collect();
    features::rows(&report, &slices)
}

/// The seed's turn set plus a wide turn (2R' and 4R') so the calibration has wide arcs.
pub(super) fn scenario() -> Scenario {
    let mut s = Scenario::seed_turns(0.3, 1);
    if let Some(crate::sim::world::Manoeuvre::Turn {
        r_over_r_prime: Some(k),
        ..
    }) = s.manoeuvres.get_mut(4)
    {
        *k = 4.0;
    }
    s
}

#[test]
fn rows_label_inner_and_outer_and_regimes() {
    let world = WorldConfig::hard_ground();
    let rows = rows_of(&[simulate_run(&world, &scenario(), 1)]);
    let regimes: Vec<Regime> = rows.iter().map(|r| r.regime).collect();
    assert_eq!(
        regimes,
        [
            Regime::Point,
            Regime::BelowHalfTrack,
            Regime::DraggedInner,
            Regime::AtRPrime,
            Regime::AboveRPrime,
            Regime::AboveRPrime,
            Regime::Straight
        ]
    );
    for row in rows.iter().filter(|r| !r.is_straight()) {
        // Left turns: the inner (left) side is the slower one.
        assert_eq!(row.sides[0].role, SideRole::Inner);
        assert!(row.sides[0].cmd_mps < row.sides[1].cmd_mps, "{row:?}");
        // Hard ground without slip effects: turns last as commanded.
        assert!(
            (row.duration_s / row.expected_duration_s - 1.0).abs() < 0.02,
            "{row:?}"
        );
    }
    let cal: Vec<bool> = rows.iter().map(|r| r.calibration_kind).collect();
    assert_eq!(cal, [true, false, false, false, true, true, true]);
    // The world's drivers draw 50 mA each at standstill.
    let still = rows[0].standstill_current_a.expect("pauses");
    assert!((still.left - 0.05).abs() < 0.01, "{still:?}");
}

#[test]
fn baseline_recovers_paper_table_2_on_hard_ground() {
    let world = WorldConfig::hard_ground();
    let runs: Vec<Vec<RunSample>> = (0..3)
        .map(|k| simulate_run(&world, &scenario(), k))
        .collect();
    let rows = rows_of(&runs);
    let cal: Vec<&TurnRow> = rows.iter().filter(|r| r.calibration_kind).collect();
    let b = Baseline::fit(&HUSKY, &cal).expect("fits");
    let hg = IcrHardGround::HUSKY_HARD_GROUND;
    let a_true = hg.skid_moment_nm() / hg.slip_track_m;
    // Measured 155 N vs Eq 22's 160 N: the world's traction fade (R_f = 11.1 m) and the
    // battery sag move a by a few percent.
    assert!(
        (b.skid_force_n - a_true).abs() < 0.05 * a_true,
        "{b:?} vs a = {a_true}"
    );
    // The drivers' quiescent draw (50 mA × 24 V = 1.2 W per side) is not in Eq 21; at a
    // constant v_c = 0.3 m/s it is indistinguishable from G and adds 1.2/0.3 = 4 N to it.
    let g_with_quiescent = hg.rolling_resistance_n + 1.2 / 0.3;
    assert!(
        (b.rolling_resistance_n - g_with_quiescent).abs() < 0.1 * g_with_quiescent,
        "{b:?}"
    );
    // Every manoeuvre, calibration or not, within a few watts per side.
    for row in &rows {
        for r in b.residual_w(row) {
            assert!(r.abs() < 4.0, "{row:?}: {r}");
        }
    }
}

#[test]
fn inner_drag_leaves_a_gap_on_the_inner_side_of_dragged_turns_only() {
    let world = WorldConfig::hard_ground().with_effect(EffectId::InnerDrag, true);
    let runs: Vec<Vec<RunSample>> = (0..2)
        .map(|k| simulate_run(&world, &scenario(), k))
        .collect();
    let rows = rows_of(&runs);
    let cal: Vec<&TurnRow> = rows.iter().filter(|r| r.calibration_kind).collect();
    let b = Baseline::fit(&HUSKY, &cal).expect("fits");
    for row in &rows {
        let [inner, outer] = b.residual_w(row);
        if row.regime == Regime::DraggedInner {
            // The world's default drag (7 N·m peak) at 2R'/3: about 6 W on hard ground.
            assert!(inner > 4.5, "{row:?}: {inner}");
        } else {
            assert!(inner.abs() < 3.0, "{:?}: {inner}", row.regime);
        }
        assert!(outer.abs() < 3.0, "{:?}: {outer}", row.regime);
    }
}

/// Three runs of `world` (different noise seeds), diagnosed.
fn diagnose_world(world: &WorldConfig) -> super::Diagnosis {
    let runs: Vec<Vec<RunSample>> = (0..3)
        .map(|k| simulate_run(world, &scenario(), 10 + k))
        .collect();
    super::diagnose(&HUSKY, &rows_of(&runs)).expect("diagnoses")
}

fn summary(d: &super::Diagnosis) -> String {
    let c: Vec<String> = d
        .candidates
        .iter()
        .map(|c| {
            format!(
                "{} {:.2}->{:.2} ({:.0}%)",
                c.effect, c.heldout_error_before, c.heldout_error_after, c.shrink_pct
            )
        })
        .collect();
    format!(
        "{} @ {} sig={} | {}",
        d.effect,
        d.regime,
        d.significant,
        c.join(", ")
    )
}

#[test]
fn control_world_has_no_significant_gap() {
    let d = diagnose_world(&WorldConfig::hard_ground());
    assert_eq!(d.effect, "none", "{}", summary(&d));
    assert!(!d.significant);
}

/// The effects the current catalogue already names on their default strengths (hard ground,
/// 3 runs); `sinkage-bulldozing` comes out `ambiguous` and `motor-heating` `none` for now (see
/// NOTES.md).
#[test]
fn single_effect_worlds_are_named() {
    for effect in [
        EffectId::InnerDrag,
        EffectId::AngularSlip,
        EffectId::SlipTrack,
        EffectId::BrakedInner,
        EffectId::CurrentOffset,
        EffectId::Slope,
    ] {
        let d = diagnose_world(&WorldConfig::hard_ground().with_effect(effect, true));
        assert_eq!(d.effect, effect.id(), "{}", summary(&d));
        let best = &d.candidates[0];
        assert!(best.shrink_pct > 50.0, "{}", summary(&d));
    }
}

/// `world` with `effect` on at `scale` × its default strength (a rough bench point).
pub(super) fn scaled(effect: EffectId, scale: f64, current_std_a: f64) -> WorldConfig {
    let mut w = WorldConfig::hard_ground().with_effect(effect, true);
    w.noise.left_current_std_a = current_std_a;
    w.noise.right_current_std_a = current_std_a;
    let e = &mut w.effects;
    match effect {
        EffectId::InnerDrag => e.inner_drag.torque_nm *= scale,
        EffectId::SinkageBulldozing => e.sinkage_bulldozing.resistance_n_per_mm *= scale,
        EffectId::AngularSlip => {
            e.angular_slip.at_zero *= scale.min(2.0);
            e.angular_slip.at_r_prime *= scale.min(2.0);
        }
        EffectId::SlipTrack => {
            let b = crate::sim::world::effects::HARD_GROUND_SLIP_TRACK_M;
            e.slip_track.slip_track_m = Some(1.1 + (b - 1.1) * scale);
        }
        EffectId::BrakedInner => e.braked_inner.resistance_n *= scale,
        EffectId::CurrentOffset => {
            e.current_offset.left_a *= scale;
            e.current_offset.right_a *= scale;
        }
        EffectId::MotorHeating => e.motor_heating.thermal_resistance_k_per_w *= scale,
        EffectId::Slope => e.slope.amplitude_deg *= scale,
    }
    w
}

/// A small grid of strengths (0.5×, 1×, 2× default) and current noise (30 and 100 mA): the
/// diagnosis names the true effect wherever the catalogue can already see it, and never names a
/// wrong one. Known gaps (NOTES.md): `sinkage-bulldozing` is `ambiguous`, `motor-heating` is
/// invisible in ~40 s runs, and `braked-inner` at half strength is `ambiguous`.
#[test]
fn strengths_and_noise_grid_names_no_wrong_effect() {
    for effect in EffectId::ALL {
        for scale in [0.5, 1.0, 2.0] {
            for noise in [0.03, 0.1] {
                let d = diagnose_world(&scaled(effect, scale, noise));
                let line = format!("{effect} x{scale} noise {noise}: {}", summary(&d));
                let known_gap =
                    matches!(effect, EffectId::SinkageBulldozing | EffectId::MotorHeating)
                        || (effect == EffectId::BrakedInner && scale < 1.0);
                if known_gap {
                    assert!(
                        ["ambiguous", "none", effect.id()].contains(&d.effect.as_str()),
                        "{line}"
                    );
                } else {
                    assert_eq!(d.effect, effect.id(), "{line}");
                }
            }
        }
    }
}

#[test]
fn json_has_the_issue_keys_and_per_regime_shrink() {
    let d = diagnose_world(&WorldConfig::hard_ground().with_effect(EffectId::InnerDrag, true));
    let j = d.to_json();
    assert_eq!(j["effect"], "inner-drag");
    assert_eq!(j["regime"], "dragged-inner");
    assert_eq!(j["significant"], true);
    assert_eq!(j["metric"]["unit"], "W");
    assert_eq!(j["heldout"]["scheme"], "leave-one-run-out");
    assert_eq!(j["candidates"].as_array().map(Vec::len), Some(8));
    let first = &j["candidates"][0];
    assert_eq!(first["effect"], "inner-drag");
    assert_eq!(j["heldout"]["shrink_pct"], first["shrink_pct"]);
    // Where the effect acts, it closes most of the gap.
    let dragged = d
        .heldout
        .iter()
        .find(|h| h.regime == "dragged-inner")
        .expect("regime present");
    assert!(dragged.shrink_pct > 70.0, "{dragged:?}");
}
