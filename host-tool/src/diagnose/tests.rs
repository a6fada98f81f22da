//! Diagnosis on simulated runs: the world's timeline sampled at 200 Hz straight into run
//! samples (no pty; noise is in `Timeline::load_at`).

use super::baseline::{Baseline, Split, Structure};
use super::features::{SideRole, TurnRow};
use crate::effect_id::EffectId;
use crate::log::run_csv::RunSample;
use crate::sim::world::{Scenario, WorldConfig};
use model_core::kinematics::Regime;
use model_core::power::IcrHardGround;
use model_core::Rover;

const HUSKY: Rover = Rover::HUSKY_A200;

/// One simulated run of `world` over `scenario`, sampled at 200 Hz.
pub(super) fn simulate_run(world: &WorldConfig, scenario: &Scenario, seed: u64) -> Vec<RunSample> {
    let timeline = world.simulate(scenario, seed).expect("scenario runs");
    crate::diagnose_bench::sample_run(&timeline, 200)
}

/// One simulated run sampled every `step_us` (coarser sampling keeps long runs cheap).
pub(super) fn simulate_run_every(
    world: &WorldConfig,
    scenario: &Scenario,
    seed: u64,
    step_us: u64,
) -> Vec<RunSample> {
    let timeline = world.simulate(scenario, seed).expect("scenario runs");
    crate::diagnose_bench::sample_run(&timeline, 1_000_000 / step_us)
}

/// Rows of `runs` (each a run's samples) through `validate` and `features::rows`.
pub(super) fn rows_of(runs: &[Vec<RunSample>]) -> Vec<TurnRow> {
    crate::diagnose_bench::rows_of(runs).expect("validates")
}

/// Adds `extra_w` of power drawn all through the manoeuvre to side `side` of `row`: its
/// average power, its energy and its effective power (over the expected duration).
fn add_steady_power(row: &mut TurnRow, side: usize, extra_w: f64) {
    let s = &mut row.sides[side];
    s.avg_power_w += extra_w;
    s.effective_power_w += extra_w * row.duration_s / row.expected_duration_s;
    s.energy_j += extra_w * row.duration_s;
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
    let rows = rows_of(&runs);
    if world.effects.is_enabled(EffectId::SlipTrack) {
        // A slip track present on the calibration manoeuvres is the terrain's, carried by the
        // baseline's constant turn slip (`slip_track_on_the_calibration_is_the_terrains`): the
        // effect is a slip track other than the calibration terrain's, so calibrate on the
        // control world.
        let cal_rows = control_calibration_rows();
        return super::diagnose_with(&HUSKY, &rows, super::Calibration::rows(&cal_rows))
            .expect("diagnoses");
    }
    super::diagnose(&HUSKY, &rows).expect("diagnoses")
}

/// The rows of two calibration runs driven in the control world (hard ground, no effect).
fn control_calibration_rows() -> Vec<TurnRow> {
    let cal: Vec<Vec<RunSample>> = (0..2)
        .map(|k| simulate_run(&WorldConfig::hard_ground(), &scenario(), 50 + k))
        .collect();
    rows_of(&cal)
}

/// The simulator's `slip-track` effect (terrain slip track 1.29 m against the controller's
/// 1.1 m) acts on every turn, calibration turns included, as one constant angular slip
/// 1 − 1.1/1.29 ≈ 15 %: on the runs' own calibration manoeuvres the baseline carries it as the
/// terrain's turn slip, and the verdict is `none` — the same timing as the structural constant
/// slip (thesis Fig. 6.7), which cannot be told apart from it on calibration data.
#[test]
fn slip_track_on_the_calibration_is_the_terrains() {
    let world = WorldConfig::hard_ground().with_effect(EffectId::SlipTrack, true);
    let runs: Vec<Vec<RunSample>> = (0..3)
        .map(|k| simulate_run(&world, &scenario(), 10 + k))
        .collect();
    let d = super::diagnose(&HUSKY, &rows_of(&runs)).expect("diagnoses");
    let expected = 1.0 - 1.1 / 1.29;
    assert!(
        (d.baseline.turn_slip - expected).abs() < 0.02,
        "{} vs {expected}",
        d.baseline.turn_slip
    );
    assert_eq!(d.effect, "none", "{}", summary(&d));
}

/// The same world with its pose track (the 5 Hz prism, 0.21 m right of the centre): the
/// calibration turns' constant slip is what the measured slip track (≈ 1.29 m) explains, so it
/// is not the terrain's; `slip-track` is named, with a higher held-out shrink than the
/// diagnosis without poses, and the notes say the regimes came from R_ACT.
#[test]
fn slip_track_is_named_with_a_pose_track() {
    let world = WorldConfig::hard_ground().with_effect(EffectId::SlipTrack, true);
    let runs: Vec<Vec<RunSample>> = (0..3)
        .map(|k| simulate_run(&world, &scenario(), 10 + k))
        .collect();
    let offset = Some(world.tracker.offset_m);
    let rows = crate::diagnose_bench::rows_for(&HUSKY, &runs, "run", offset).expect("validates");
    assert!(rows
        .iter()
        .filter(|r| !r.is_straight())
        .all(|r| r.measured.is_some()));
    let with = super::diagnose(&HUSKY, &rows).expect("diagnoses");
    let without = super::diagnose(&HUSKY, &rows_of(&runs)).expect("diagnoses");
    assert_eq!(with.baseline.turn_slip, 0.0);
    assert_eq!(with.effect, "slip-track", "{}", summary(&with));
    let shrink = |d: &super::Diagnosis| {
        d.candidates
            .iter()
            .find(|c| c.effect == EffectId::SlipTrack)
            .map_or(0.0, |c| c.shrink_pct)
    };
    assert!(
        shrink(&with) > shrink(&without) + 30.0,
        "{} vs {}",
        summary(&with),
        summary(&without)
    );
    assert!(
        with.notes.iter().any(|n| n.contains("measured R_ACT")),
        "{:?}",
        with.notes
    );
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
    let marks: Vec<String> = d
        .signatures
        .iter()
        .map(|s| format!("{}: {}", s.effect, s.describe()))
        .collect();
    format!(
        "{} @ {} sig={} | {} | signatures: {}",
        d.effect,
        d.regime,
        d.significant,
        c.join(", "),
        marks.join("; ")
    )
}

#[test]
fn control_world_has_no_significant_gap() {
    let d = diagnose_world(&WorldConfig::hard_ground());
    assert_eq!(d.effect, "none", "{}", summary(&d));
    assert!(!d.significant);
}

/// A world whose inner side never regenerates (thesis Section 1.1.3: negative power put to 0),
/// made from the control's rows: the plain tread couple misfits its wide calibration turns
/// (`adequacy::tests::a_no_regeneration_world_misfits_and_says_so`), the baseline family finds
/// the clamp on the calibration runs, and with it the world is a control again: `none`.
#[test]
fn a_no_regeneration_world_is_found_by_the_family() {
    let runs: Vec<Vec<RunSample>> = (0..3)
        .map(|k| simulate_run(&WorldConfig::hard_ground(), &scenario(), 10 + k))
        .collect();
    let rows = rows_of(&runs);
    let control = super::diagnose(&HUSKY, &rows).expect("diagnoses");
    assert_eq!(control.baseline.structure, Structure::PLAIN);
    assert_eq!(
        control.adequacy.adequate,
        Some(true),
        "{}",
        summary(&control)
    );
    let clamped: Vec<TurnRow> = rows
        .iter()
        .cloned()
        .map(|mut r| {
            for s in &mut r.sides {
                s.avg_power_w = s.avg_power_w.max(0.0);
                s.effective_power_w = s.effective_power_w.max(0.0);
                s.max_power_w = s.max_power_w.max(0.0);
                s.energy_j = s.energy_j.max(0.0);
            }
            r
        })
        .collect();
    let d = super::diagnose(&HUSKY, &clamped).expect("diagnoses");
    let line = format!(
        "{} | {}",
        summary(&d),
        super::report::adequacy_summary(&d.adequacy),
    );
    // The clamp, or a returned fraction fitted next to it (the averaged rows keep a trace of
    // generated power: 0.05 is what the continuous member finds).
    match d.baseline.structure.split {
        Split::Returning { fraction } => assert!(fraction < 0.1, "fraction {fraction}: {line}"),
        other => panic!("{other:?}: {line}"),
    }
    assert_eq!(d.adequacy.adequate, Some(true), "{line}");
    assert_eq!(d.effect, "none", "{line}");
    let json = d.to_json();
    assert_eq!(json["baseline"]["structure"]["split"]["kind"], "returning");
}

/// A driver that returns 60 % of the generated power (η ≈ 0.77 on both conversions), made from
/// the control's rows: the family fits the returned fraction as a continuous parameter (0.6, not
/// the 0.5 or 0.7 a grid would give), and with it the world is a control again: `none`.
#[test]
fn a_returning_driver_fraction_is_fitted_not_rounded() {
    const RETURNED: f64 = 0.6;
    let runs: Vec<Vec<RunSample>> = (0..3)
        .map(|k| simulate_run(&WorldConfig::hard_ground(), &scenario(), 20 + k))
        .collect();
    let returning: Vec<TurnRow> = rows_of(&runs)
        .into_iter()
        .map(|mut r| {
            for s in &mut r.sides {
                let scale = |w: f64| if w < 0.0 { w * RETURNED } else { w };
                s.avg_power_w = scale(s.avg_power_w);
                s.effective_power_w = scale(s.effective_power_w);
                s.energy_j = scale(s.energy_j);
            }
            r
        })
        .collect();
    let d = super::diagnose(&HUSKY, &returning).expect("diagnoses");
    let line = format!(
        "{} | {}",
        summary(&d),
        super::report::adequacy_summary(&d.adequacy)
    );
    match d.baseline.structure.split {
        Split::Returning { fraction } => {
            assert!(
                (fraction - RETURNED).abs() < 0.05,
                "fraction {fraction}: {line}"
            )
        }
        other => panic!("{other:?}: {line}"),
    }
    assert_eq!(d.adequacy.adequate, Some(true), "{line}");
    assert_eq!(d.effect, "none", "{line}");
}

/// The effects the catalogue names on their default strengths (hard ground, 3 runs of ~40 s),
/// with the regime: `all` for the terms acting on every manoeuvre. `motor-heating` needs long
/// runs (see `motor_heating_is_named_on_long_runs`).
#[test]
fn single_effect_worlds_are_named() {
    for (effect, regime, min_shrink_pct) in [
        (EffectId::InnerDrag, "dragged-inner", 50.0),
        (EffectId::SinkageBulldozing, "dragged-inner", 25.0),
        (EffectId::AngularSlip, "at-r-prime", 80.0),
        (EffectId::BrakedInner, "at-r-prime", 60.0),
        (EffectId::CurrentOffset, "all", 80.0),
        // 87 % before the calibration's slope became a nuisance of the baseline fit: the
        // grade-biased G (15 N against 33 N level, `a_sloped_calibration_leaves_a_and_g_level`)
        // happened to carry part of the slope power the mean-pitch term misses.
        (EffectId::Slope, "all", 60.0),
    ] {
        let d = diagnose_world(&WorldConfig::hard_ground().with_effect(effect, true));
        assert_eq!(d.effect, effect.id(), "{}", summary(&d));
        assert_eq!(d.regime, regime, "{}", summary(&d));
        let all = d
            .heldout
            .iter()
            .find(|h| h.regime == "all")
            .expect("all rows");
        assert_eq!(all.effect, effect);
        assert!(all.shrink_pct > min_shrink_pct, "{}", summary(&d));
        // The effect closes most of the gap where it is (the regimes with a significant gap).
        let gap = d.heldout.iter().find(|h| h.regime == "gap").expect("a gap");
        let min_gap_pct = if effect == EffectId::SinkageBulldozing {
            35.0
        } else {
            70.0
        };
        assert!(gap.shrink_pct > min_gap_pct, "{effect}: {gap:?}");
        // One effect in the world: no other effect explains a practically relevant power.
        if !matches!(effect, EffectId::SinkageBulldozing) {
            assert!(d.secondary.is_empty(), "{effect}: {:?}", d.secondary);
        }
    }
}

/// The fitted model tabulates: a synthetic 2R'/3 turn gets inner-drag's extra power on the
/// inner side only, a wide turn and a straight get none.
#[test]
fn fitted_model_evaluates_synthetic_turns() {
    let runs: Vec<Vec<RunSample>> = (0..2)
        .map(|k| {
            simulate_run(
                &WorldConfig::hard_ground().with_effect(EffectId::InnerDrag, true),
                &scenario(),
                k,
            )
        })
        .collect();
    let rows = rows_of(&runs);
    let (baseline, model) = super::fit_model(
        &HUSKY,
        &rows,
        &[EffectId::InnerDrag],
        super::calibration::Calibration::FROM_RUNS,
    )
    .expect("fits");
    let at = super::model_file::Conditions {
        v_c_mps: 0.3,
        turn_rad: std::f64::consts::FRAC_PI_2,
        bus_v: 24.0,
        t_start_s: 10.0,
    };
    let turn = |k: f64| super::model_file::synthetic_row(&HUSKY, &baseline, k, &at);
    let dragged = turn(2.0 / 3.0);
    assert_eq!(dragged.regime, Regime::DraggedInner);
    let [inner, outer] = super::extra_power_w(&HUSKY, &baseline, &model, &dragged);
    // The measured inner gap at 2R'/3 is about 6 W (inner_drag_leaves_a_gap…).
    assert!((4.0..9.0).contains(&inner), "{inner}");
    assert_eq!(outer, 0.0);
    for k in [2.0, f64::INFINITY] {
        assert_eq!(
            super::extra_power_w(&HUSKY, &baseline, &model, &turn(k)),
            [0.0, 0.0]
        );
    }
}

/// `world` with `effect` on at `scale` × its default strength (a rough bench point).
pub(super) fn scaled(effect: EffectId, scale: f64, current_std_a: f64) -> WorldConfig {
    let mut w = WorldConfig::hard_ground().with_effect(effect, true);
    w.noise.left_current_std_a = current_std_a;
    w.noise.right_current_std_a = current_std_a;
    crate::diagnose_bench::scale_effect(&mut w, effect, scale);
    w
}

/// A small grid of strengths (0.5×, 1×, 2× default) and current noise (30 and 100 mA): the
/// diagnosis names the true effect wherever the catalogue can see it, and never names a wrong
/// one. Known gaps: `motor-heating` is invisible in ~40 s runs (`docs/engineering-record.md`),
/// `sinkage-bulldozing` at 2× and `braked-inner` at half strength are `ambiguous`, and so is
/// `slip-track` (below).
#[test]
fn strengths_and_noise_grid_names_no_wrong_effect() {
    for effect in EffectId::ALL {
        for scale in [0.5, 1.0, 2.0] {
            for noise in [0.03, 0.1] {
                let d = diagnose_world(&scaled(effect, scale, noise));
                let line = format!("{effect} x{scale} noise {noise}: {}", summary(&d));
                // slip-track against calibration runs of the control world (`diagnose_world`)
                // ties with angular-slip (`ambiguous`): on the test radii both lengthen the
                // turns; on its own calibration it is the terrain's turn slip (`none`).
                let known_gap = effect == EffectId::MotorHeating
                    || effect == EffectId::SlipTrack
                    || (effect == EffectId::SinkageBulldozing && scale > 1.0)
                    || (effect == EffectId::BrakedInner && scale < 1.0);
                if known_gap {
                    assert!(
                        ["ambiguous", "none", "baseline-misfit", effect.id()]
                            .contains(&d.effect.label()),
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
    // Every catalogue effect but motor-heating (one pass through the turn set per run does not
    // separate run time from the turn order) and current-offset (the standstill current is the
    // drivers' 50 mA: no sensor offset reads there).
    assert_eq!(j["candidates"].as_array().map(Vec::len), Some(6));
    for skipped in ["motor-heating not scored", "current-offset not scored"] {
        assert!(d.notes.iter().any(|n| n.contains(skipped)), "{skipped}");
    }
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

/// Three long runs of `world` (15 repeats of the turn set, ~11 min each, sampled at 50 Hz),
/// seeded from `seed`.
fn long_runs(world: &WorldConfig, seed: u64) -> Vec<Vec<RunSample>> {
    let mut long = scenario();
    long.repeats = 15;
    (0..3)
        .map(|k| simulate_run_every(world, &long, seed + k, 20_000))
        .collect()
}

/// The rows of `runs` with a first-order winding heating added to each side's measured power,
/// ΔP = k I² (1 − e^(−t/τ)), I from the measured power, τ = 400 s (not on the grid).
fn with_winding_heat(runs: &[Vec<RunSample>], k: f64) -> Vec<TurnRow> {
    let mut rows = rows_of(runs);
    for row in &mut rows {
        let t_mid = row.t_start_s + 0.5 * row.duration_s;
        for side in 0..2 {
            let i = row.sides[side].avg_power_w / row.bus_v;
            add_steady_power(row, side, k * i * i * (1.0 - (-t_mid / 400.0).exp()));
        }
    }
    rows
}

/// The world's `motor-heating` is physically tiny at the thesis' speeds (≈ 2 A per side: copper
/// loss ≈ 0.6 W, a few kelvin, < 0.05 W of extra power even after 20 min at 2× its thermal
/// resistance), so the diagnosis rightly says `none` on it (`docs/engineering-record.md`). When the
/// data does hold a heating signal, the τ-grid term finds it: long runs of the hard-ground world
/// (15 repeats of the turn set, ~11 min each, sampled at 50 Hz) with a first-order winding heating
/// added to each side's measured power, ΔP = k I² (1 − e^(−t/τ)), I from the measured power, k such
/// that the last manoeuvres draw ~4 W more at a point turn, τ = 400 s (not on the grid).
#[test]
fn motor_heating_is_named_on_long_runs() {
    let runs = long_runs(&WorldConfig::hard_ground(), 20);
    let d = super::diagnose(&HUSKY, &with_winding_heat(&runs, 1.5)).expect("diagnoses");
    assert_eq!(d.effect, "motor-heating", "{}", summary(&d));
    // Its regime is where I² is largest (at-r-prime's outer side): the term is ∝ I², under
    // half the practical floor on the low-current straights, so the `all` rule does not fire.
    // The term follows each side's measured I² history (`winding_heat`), while the heat added
    // here follows run time alone, as if every manoeuvre's current had flowed since the start:
    // a shape it fits closely but not exactly (67 % closed; 72 % with the run-time term it had).
    assert!(d.candidates[0].shrink_pct > 60.0, "{}", summary(&d));
    // Without the added heating the same long runs show no significant gap.
    let plain = super::diagnose(&HUSKY, &rows_of(&runs)).expect("diagnoses");
    assert_eq!(plain.effect, "none", "{}", summary(&plain));
}

/// Heating grows in every regime, so with the repeat noise of real runs no regime's mean need
/// show it and its all-row shrink stays under the naming bar: the same long runs as
/// [`motor_heating_is_named_on_long_runs`] with 4 % manoeuvre-to-manoeuvre power noise and half
/// the heat. Its run-time trend is a departure of the diagnosed metric: the headline counts it,
/// as the "where" analysis does, and the verdict names the one term that removes the trend out
/// of sample. (Before, the headline said `none` while "where" listed the trend.)
#[test]
fn a_run_time_trend_is_a_departure_the_headline_counts() {
    let mut world = WorldConfig::hard_ground();
    world.noise.manoeuvre_power_std = 0.04;
    let runs = long_runs(&world, 40);
    let d = super::diagnose(&HUSKY, &with_winding_heat(&runs, 0.75)).expect("diagnoses");
    assert!(d.gaps.iter().all(|g| !g.significant), "{:?}", d.gaps);
    assert!(
        d.candidates[0].shrink_pct < super::cv::MIN_SHRINK_PCT,
        "{}",
        summary(&d)
    );
    assert!(d.where_.departs_over_run_time(), "{}", d.where_.statement);
    assert_eq!(d.significant, d.where_.significant);
    assert_eq!(d.effect, "motor-heating", "{}", summary(&d));
}

/// The sand world (every sand effect on at once, 3 runs): the diagnosis names a primary effect
/// and explains most of the held-out error with the stepwise secondaries; the test prints its
/// numbers (the demo's on the same world: `docs/diagnosing.md`, *What the demo finds*).
#[test]
fn sand_world_primary_and_secondary_effects() {
    let world = WorldConfig::sand();
    let runs: Vec<Vec<RunSample>> = (0..3)
        .map(|k| simulate_run(&world, &scenario(), 30 + k))
        .collect();
    let rows = rows_of(&runs);
    let d = super::diagnose(&HUSKY, &rows).expect("diagnoses");
    let secondary: Vec<String> = d
        .secondary
        .iter()
        .map(|s| {
            format!(
                "{} -> {:.2} W ({:.0} %)",
                s.effect, s.heldout_error_after, s.shrink_pct
            )
        })
        .collect();
    let adequacy = crate::diagnose::report::adequacy_summary(&d.adequacy);
    let line = format!(
        "{} | secondary: {} | {adequacy} | with: {:?}",
        summary(&d),
        secondary.join(", "),
        d.adequacy_with_effect
            .as_ref()
            .map(|w| crate::diagnose::adequacy::explained_fraction(&d.adequacy, w))
    );
    println!("{line}");
    assert!(d.significant, "{line}");
    // The hard-ground baseline does not hold on sand's own calibration manoeuvres (sinkage
    // on point turns): then the honest verdict is `baseline-misfit`, and the best candidate is
    // still one of the world's effects.
    if d.effect == super::Verdict::BaselineMisfit {
        assert_eq!(d.adequacy.adequate, Some(false), "{line}");
        assert!(world.effects.is_enabled(d.candidates[0].effect), "{line}");
        assert!(d.secondary.is_empty(), "{line}");
        return;
    }
    let Some(primary) = super::named_effect(&d) else {
        panic!("no primary: {line}");
    };
    assert!(world.effects.is_enabled(primary), "{line}");
    for s in &d.secondary {
        assert!(world.effects.is_enabled(s.effect), "{line}");
    }
    let mut model: Vec<EffectId> = vec![primary];
    model.extend(d.secondary.iter().map(|s| s.effect));
    let (baseline, fitted) = super::fit_model(
        &HUSKY,
        &rows,
        &model,
        super::calibration::Calibration::FROM_RUNS,
    )
    .expect("fits");
    let at = super::model_file::Conditions {
        v_c_mps: 0.3,
        turn_rad: 1.0,
        bus_v: 24.0,
        t_start_s: 0.0,
    };
    let turn = super::model_file::synthetic_row(&HUSKY, &baseline, 2.0 / 3.0, &at);
    let extra = super::extra_power_w(&HUSKY, &baseline, &fitted, &turn);
    println!("extra at 2R'/3: {extra:?}");
    assert!(extra.iter().all(|w| w.is_finite()));
}

/// A calibration driven on undulating ground (the runs' own calibration manoeuvres carry the
/// slope): the baseline fits the slope as a nuisance (`Baseline::calibration_grade_n`), so a and
/// G stay the level ground's, and the slope stays in the residuals, where `slope` is named.
#[test]
fn a_sloped_calibration_leaves_a_and_g_level() {
    let level = diagnose_world(&WorldConfig::hard_ground()).baseline;
    let world = scaled(EffectId::Slope, 2.0, 0.05);
    let d = diagnose_world(&world);
    let b = &d.baseline;
    let phi_mg = world.effects.slope.phi * f64::from(HUSKY.mass_kg) * 9.81;
    // Without the nuisance G came out 15.3 N against the level 32.6 N. The grade term is the
    // manoeuvre's mean pitch, not the pitch under each sample: Φ m g comes out ≈ 0.55 of the
    // world's.
    assert!((b.skid_force_n - level.skid_force_n).abs() < 0.1 * level.skid_force_n);
    let g_error = (b.rolling_resistance_n - level.rolling_resistance_n).abs();
    assert!(g_error < 0.2 * level.rolling_resistance_n, "{b:?}");
    assert!(
        (0.3 * phi_mg..1.5 * phi_mg).contains(&b.calibration_grade_n),
        "{b:?}"
    );
    assert_eq!(d.effect, "slope", "{}", summary(&d));
}

/// On a slope the downhill pull turns the rover too, so the yaw's timing is no slip's own mark:
/// with the slope's signature present, `angular-slip` and `slip-track` are not observable and
/// cannot be named (world E's Argo slopes were named `slip-track` on their yaw).
#[test]
fn on_a_slope_the_yaw_timing_is_no_slips_mark() {
    let d = diagnose_world(&scaled(EffectId::Slope, 2.0, 0.05));
    let mark = |e: EffectId| d.signatures.iter().find(|s| s.effect == e).expect("tested");
    assert!(mark(EffectId::Slope).present(), "{}", summary(&d));
    for e in [EffectId::AngularSlip, EffectId::SlipTrack] {
        let s = mark(e);
        assert!(s.test.is_none() && s.detail.contains("slope"), "{s:?}");
    }
    // Level ground, calibrated on calibration runs of its own (the slip's reference).
    let runs: Vec<Vec<RunSample>> = (0..3)
        .map(|k| simulate_run(&WorldConfig::hard_ground(), &scenario(), 10 + k))
        .collect();
    let cal_rows = control_calibration_rows();
    let level = super::diagnose_with(&HUSKY, &rows_of(&runs), super::Calibration::rows(&cal_rows))
        .expect("diagnoses");
    let slip = level
        .signatures
        .iter()
        .find(|s| s.effect == EffectId::SlipTrack)
        .expect("tested");
    assert!(slip.test.is_some(), "level ground tests the slip: {slip:?}");
}

/// A slip track rescales every turn's yaw rate alike (Eq 2.2), so its signature by yaw is the
/// same slip at every radius: present in the simulator's slip-track world, and absent once the
/// point turns alone slip 15 % more (as sand piling up at the point turn slows it), with the
/// report saying why.
#[test]
fn a_slip_track_slows_every_turn_alike() {
    let world = WorldConfig::hard_ground().with_effect(EffectId::SlipTrack, true);
    let runs: Vec<Vec<RunSample>> = (0..3)
        .map(|k| simulate_run(&world, &scenario(), 10 + k))
        .collect();
    let rows = rows_of(&runs);
    let cal_rows = control_calibration_rows();
    let slip_track = |rows: &[TurnRow]| {
        let d = super::diagnose_with(&HUSKY, rows, super::Calibration::rows(&cal_rows))
            .expect("diagnoses");
        d.signatures
            .into_iter()
            .find(|s| s.effect == EffectId::SlipTrack)
            .expect("tested")
    };
    let even = slip_track(&rows);
    assert!(even.present(), "{even:?}");
    let uneven_rows: Vec<TurnRow> = rows
        .iter()
        .cloned()
        .map(|mut r| {
            if r.regime == Regime::Point {
                r.angular_slip = r.angular_slip.map(|s| s + 0.15);
            }
            r
        })
        .collect();
    let uneven = slip_track(&uneven_rows);
    assert!(
        !uneven.present() && uneven.detail.contains("not the same on every turn"),
        "{uneven:?}"
    );
}

/// A power-type term is fitted net of what the baseline absorbed of it, measured on the rows the
/// baseline was fitted on. With calibration runs those are the calibration runs' manoeuvres,
/// not the diagnosed runs' point turns and straights: heat that builds up over long test runs
/// sits on their point turns too, and projecting it off there (as before) made the fitted
/// heating term negative. Here every row gets k·I²·x (τ = 60 s, the grid's first) added to
/// each side, short calibration runs and long test runs alike; the fit recovers k.
#[test]
fn an_absorbed_term_is_measured_on_the_baselines_own_rows() {
    let world = WorldConfig::hard_ground();
    let heat = |rows: &mut Vec<TurnRow>, k: f64| {
        for row in rows.iter_mut() {
            let h = row.copper_heat_a4.expect("samples")[0];
            for (side, h) in h.into_iter().enumerate() {
                add_steady_power(row, side, k * h);
            }
        }
    };
    let k = 0.05;
    let cal_runs: Vec<_> = (0..2)
        .map(|s| simulate_run_every(&world, &Scenario::seed_turns(0.3, 1), 40 + s, 20_000))
        .collect();
    let mut cal = rows_of(&cal_runs);
    heat(&mut cal, k);
    let test_runs: Vec<_> = (0..3)
        .map(|s| simulate_run_every(&world, &Scenario::seed_turns(0.3, 6), 50 + s, 20_000))
        .collect();
    let mut rows = rows_of(&test_runs);
    heat(&mut rows, k);
    let (_, model) = super::fit_model(
        &HUSKY,
        &rows,
        &[EffectId::MotorHeating],
        super::calibration::Calibration::rows(&cal),
    )
    .expect("fits");
    assert_eq!(model.heating_tau_s, 60.0, "{model:?}");
    let fitted = model.effects[0].params[0];
    assert!((fitted - k).abs() < 0.1 * k, "{model:?}");
}

/// Issue 34, item 7: one run of the seed's turn set on sand, as the demo's `run-1.csv`, is held
/// out radius by radius. With the straights held out, the calibration left is a point turn and
/// a wide turn, and `sinkage-bulldozing`'s share of a and G, measured there, was extrapolated to
/// the straight: the table printed it at −1000 % (−2311 % on the demo's run) and ranked it.
/// Such a candidate is reported as not testable out of sample and ranked nowhere; the table has
/// no column for a scheme one run does not have.
#[test]
fn one_run_reports_an_extrapolating_candidate_instead_of_ranking_it() {
    use super::cv::{HeldOutGroup, NotTestable, Scheme};
    let runs = [simulate_run(
        &WorldConfig::sand(),
        &Scenario::seed_turns(0.3, 1),
        1,
    )];
    let rows = rows_of(&runs);
    let d = super::diagnose(&HUSKY, &rows).expect("diagnoses");
    assert_eq!(d.scheme, Scheme::LeaveOneRadiusOut);
    assert!(d.other_scheme.is_none(), "one run: no leave-one-run-out");
    for c in &d.candidates {
        assert!(c.not_testable.is_none() && c.shrink_pct > -100.0, "{c:?}");
    }
    let sinkage = d
        .not_testable
        .iter()
        .find(|c| c.effect == EffectId::SinkageBulldozing)
        .expect("sinkage-bulldozing is not testable");
    assert!(
        matches!(
            sinkage.not_testable,
            Some(NotTestable::Extrapolation {
                held_out: HeldOutGroup::Straights,
                regime: Regime::Straight,
                leverage,
            }) if leverage > super::cv::MAX_HELDOUT_LEVERAGE
        ),
        "{sinkage:?}"
    );
    // What is named was ranked: tested on every fold, and one of the sand world's effects.
    if let super::Verdict::Effect(named) = d.effect {
        assert!(d.candidates.iter().any(|c| c.effect == named), "{named}");
        assert!(WorldConfig::sand().effects.is_enabled(named), "{named}");
    }

    let table = super::report::table(&d);
    let (_, ranking) = table.split_once("\ncandidates (").expect("the ranking");
    let ranking = ranking.split("\n\n").next().unwrap_or_default();
    let head = ranking.lines().nth(1).unwrap_or_default();
    assert_eq!(
        head.split("  ")
            .map(str::trim)
            .filter(|c| !c.is_empty())
            .collect::<Vec<_>>(),
        [
            "effect",
            "before [W]",
            "after [W]",
            "shrink",
            "penalised [W²]",
            "shrink of totals",
            "signature",
            "sign"
        ],
        "{ranking}"
    );
    // The table folds long lines: compare words.
    let words = ranking.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        words.contains(
            "sinkage-bulldozing: not testable out of sample: its held-out prediction for the \
             straight manoeuvre (fold holding out the straights) extrapolates beyond the \
             manoeuvres it was fitted on"
        ),
        "{ranking}"
    );
    // No shrink in the ranking is an extrapolation's.
    let shrinks: Vec<f64> = ranking
        .split(" %")
        .filter_map(|s| s.rsplit(' ').next()?.parse().ok())
        .collect();
    assert!(!shrinks.is_empty(), "{ranking}");
    assert!(shrinks.iter().all(|pct| *pct > -100.0), "{ranking}");
    assert!(
        super::report::conclusion(&d)
            .details
            .iter()
            .any(|l| l.contains("not testable out of sample, so not ruled out")),
        "{table}"
    );

    let json = d.to_json();
    let listed = &json["not_testable_out_of_sample"];
    let entry = listed
        .as_array()
        .and_then(|l| l.iter().find(|e| e["effect"] == "sinkage-bulldozing"))
        .expect("in the JSON");
    assert_eq!(entry["why"]["reason"], "extrapolation");
    assert_eq!(entry["why"]["held_out"]["kind"], "straights");
    assert_eq!(entry["why"]["regime"], "straight");
    assert!(json["candidates"]
        .as_array()
        .is_some_and(|c| c.iter().all(|c| c["effect"] != "sinkage-bulldozing")));
}

/// A terrain whose slip track is below the controller's B_s (thesis Appendix D: compacted
/// sand) makes every turn quicker than commanded, on the calibration ground as on the runs'.
/// The mark is measured against the calibration's own turns driven alike, so a slip track the
/// calibration shares is no effect: `slip-track` is not named and its mark reads a difference
/// near 0 (a fitted terrain slip clamped at 0 read −10 % here as a slip track).
#[test]
fn a_slip_track_the_calibration_shares_is_no_effect() {
    let mut world = WorldConfig::hard_ground().with_effect(EffectId::SlipTrack, true);
    world.effects.slip_track.slip_track_m = Some(0.99);
    let cal: Vec<Vec<RunSample>> = (0..2)
        .map(|k| simulate_run(&world, &scenario(), 50 + k))
        .collect();
    let runs: Vec<Vec<RunSample>> = (0..3)
        .map(|k| simulate_run(&world, &scenario(), 10 + k))
        .collect();
    let (cal_rows, rows) = (rows_of(&cal), rows_of(&runs));
    let quicker: Vec<f64> = rows.iter().filter_map(|r| r.angular_slip).collect();
    assert!(quicker.iter().all(|s| *s < -0.05), "{quicker:?}");
    let d = super::diagnose_with(&HUSKY, &rows, super::Calibration::rows(&cal_rows))
        .expect("diagnoses");
    assert_ne!(d.effect, "slip-track", "{}", summary(&d));
    let mark = d
        .signatures
        .iter()
        .find(|s| s.effect == EffectId::SlipTrack)
        .expect("tested");
    assert!(mark.absent(), "{mark:?}");
    assert!(mark.detail.contains("driven alike"), "{}", mark.detail);
}
