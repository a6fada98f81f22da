//! Bench tests: the family draws what it says, the parts are disjoint, the truth follows the
//! effect, and a small bench tabulates every dataset.

use super::family::*;
use super::*;
use crate::effect_id::EffectId;
use crate::sim::world::{DrivePower, PowerSplit, Side, WorldConfig};
use model_core::kinematics::Regime;
use std::collections::BTreeSet;

fn both(datasets: usize, seed: u64) -> Vec<DatasetSpec> {
    generate_all(&BenchOptions {
        datasets,
        seed,
        threads: 1,
        part: PartChoice::Both,
        poses: false,
        rounds: 0,
    })
}

#[test]
fn the_family_draws_what_it_says() {
    let specs = generate(Part::Tuning, 200, 3);
    assert_eq!(specs, generate(Part::Tuning, 200, 3));
    assert_ne!(specs, generate(Part::Tuning, 200, 4));
    for s in &specs {
        let w = s.world();
        w.validate("bench").expect("valid world");
        // The class: exactly its effect on; controls default, structure-only not.
        let on: Vec<EffectId> = EffectId::ALL
            .into_iter()
            .filter(|e| w.effects.is_enabled(*e))
            .collect();
        assert_eq!(on, s.effect().into_iter().collect::<Vec<_>>());
        match s.class {
            DatasetClass::Control => assert_eq!(s.structure, DEFAULT_STRUCTURE),
            DatasetClass::StructureOnly => assert_ne!(s.structure, DEFAULT_STRUCTURE),
            DatasetClass::Effect(_) => assert!((0.5..=2.0).contains(&s.strength)),
        }
        // The structure reaches the world.
        let st = s.structure;
        assert_eq!(
            w.structure.split,
            match st.split {
                SplitDraw::Default | SplitDraw::Rt => PowerSplit::Threshold,
                SplitDraw::Regen => PowerSplit::Regenerating,
                SplitDraw::Clamp => PowerSplit::Clamped,
            }
        );
        assert_eq!(
            w.structure.threshold_radius_m.is_some(),
            st.split == SplitDraw::Rt
        );
        if let Some(rt) = w.structure.threshold_radius_m {
            assert!((10.0..=30.0).contains(&rt));
        }
        assert_eq!(w.structure.angular_slip > 0.0, st.slip);
        assert!(w.structure.angular_slip <= 0.15);
        assert_eq!(w.structure.drive_power == DrivePower::Mechanical, st.losses);
        let iq = w.driver.quiescent_a();
        match st.standstill {
            Standstill::Zero => assert!(iq.left <= 0.005 && iq.right <= 0.005),
            Standstill::Uneven => assert!((0.02..=0.12).contains(&iq.left)),
            Standstill::Default => assert_eq!(iq.left, iq.right),
        }
        assert_eq!(w.rover, s.rover.rover());
        assert!((0.2..=0.5).contains(&s.v_c_mps));
        assert!((50..=200).contains(&s.sample_hz));
        assert!((0.01..=0.1).contains(&s.current_std_a.left));
        if s.effect() == Some(EffectId::MotorHeating) {
            assert!(s.repeats >= 8);
        }
        if s.effect() == Some(EffectId::InnerDrag) {
            assert_eq!(s.rover, RoverKind::HuskyA200);
        }
        // The layout: 2 calibration runs of 4 manoeuvres, 3 shuffled test runs of 9.
        assert_eq!(s.calibration_scenario().manoeuvres.len(), 4);
        let tests = s.test_scenarios();
        assert_eq!(tests.len(), TEST_RUNS);
        for order in &s.test_orders {
            let set: BTreeSet<usize> = order.iter().copied().collect();
            assert_eq!(set.len(), TEST_R_OVER_R_PRIME.len());
        }
    }
    for class in (0..DatasetClass::COUNT).map(DatasetClass::of) {
        assert_eq!(specs.iter().filter(|s| s.class == class).count(), 20);
    }
    // Every switch value, both rovers, both sides and a spread of v_c are drawn.
    let labels: BTreeSet<&str> = specs.iter().map(|s| s.structure_label.as_str()).collect();
    for part in ["rt", "regen", "clamp", "slip", "loss", "iq0", "iq-uneven"] {
        assert!(
            labels.iter().any(|l| l.split('+').any(|p| p == part)),
            "{part}"
        );
    }
    assert!(specs.iter().any(|s| s.rover == RoverKind::ArgoJ5));
    assert!(specs.iter().any(|s| s.direction == Side::Right));
    assert!(specs.iter().any(|s| s.v_c_mps < 0.25) && specs.iter().any(|s| s.v_c_mps > 0.45));
    assert_eq!(
        specs
            .iter()
            .map(|s| s.sample_hz)
            .collect::<BTreeSet<_>>()
            .len(),
        SAMPLE_HZ.len()
    );
}

#[test]
fn held_out_and_tuning_parts_are_disjoint() {
    let specs = both(300, 1);
    let (tuning, held): (Vec<_>, Vec<_>) = specs.iter().partition(|s| s.part == Part::Tuning);
    assert_eq!((tuning.len(), held.len()), (300, 300));
    for s in &tuning {
        assert!(!is_held_out(s.rover, s.direction, &s.structure), "{s:?}");
        assert_ne!(s.structure, HELD_OUT_STRUCTURE);
        assert!(!(s.rover == RoverKind::ArgoJ5 && s.direction == Side::Right));
    }
    for s in &held {
        assert!(is_held_out(s.rover, s.direction, &s.structure), "{s:?}");
    }
    // Both held-out kinds occur, and no dataset seed is shared.
    assert!(held.iter().any(|s| s.structure == HELD_OUT_STRUCTURE));
    assert!(held
        .iter()
        .any(|s| s.rover == RoverKind::ArgoJ5 && s.direction == Side::Right));
    let seeds: BTreeSet<u64> = tuning.iter().map(|s| s.seed).collect();
    assert!(held.iter().all(|s| !seeds.contains(&s.seed)));
    // The held-out part of seed 1 is drawn from bench seed 1001.
    assert_eq!(
        held.into_iter().cloned().collect::<Vec<_>>(),
        generate(Part::HeldOut, 300, 1)
    );
    assert_ne!(
        generate(Part::HeldOut, 10, 1),
        generate(Part::Tuning, 10, 1001)
    );
}

#[test]
fn the_argo_world_file_is_the_family_argo() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let file = crate::sim::world::load_world(&root.join("worlds/argo-j5-hard-ground.toml"))
        .expect("loads");
    let family = RoverKind::ArgoJ5.world();
    assert_eq!(file.rover, family.rover);
    assert_eq!(file.icr, family.icr);
    assert!((file.motor.gear_ratio - family.motor.gear_ratio).abs() < 1e-4);
    assert_eq!(file.motor.efficiency, family.motor.efficiency);
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b;
    assert!(close(
        file.motor.winding_resistance_ohm,
        family.motor.winding_resistance_ohm
    ));
    assert!(close(
        file.battery.internal_resistance_ohm,
        family.battery.internal_resistance_ohm
    ));
    assert_eq!(file.battery.nominal_v, family.battery.nominal_v);
    assert_eq!(file.effects.slip_track, family.effects.slip_track);
    let rover = crate::rover::load_rover(&root.join("rovers/argo-j5.toml")).expect("rover");
    assert_eq!(rover, ARGO_J5);
}

#[test]
fn scaling_an_effect_scales_its_parameters() {
    let base = WorldConfig::hard_ground();
    let mut w = base;
    scale_effect(&mut w, EffectId::SlipTrack, 2.0);
    let b = w.effects.slip_track.slip_track_m.expect("set");
    let controller = f64::from(base.rover.slip_track_m);
    let hard = crate::sim::world::effects::HARD_GROUND_SLIP_TRACK_M;
    assert!((b - (controller + 2.0 * (hard - controller))).abs() < 1e-12);
    let mut w = base;
    scale_effect(&mut w, EffectId::InnerDrag, 0.5);
    assert_eq!(w.effects.inner_drag.torque_nm, 3.5);
    let mut w = base;
    scale_effect(&mut w, EffectId::AngularSlip, 4.0);
    assert_eq!(w.effects.angular_slip.at_r_prime, 0.95);
}

/// A Husky dataset of `effect` with the default structure, one pass per run (a slip track
/// wider than the controller's).
fn husky_spec(effect: EffectId) -> DatasetSpec {
    let mut s = generate(Part::Tuning, 100, 11)
        .into_iter()
        .find(|s| s.effect() == Some(effect) && s.rover == RoverKind::HuskyA200)
        .expect("class present");
    s.repeats = 1;
    s.structure = DEFAULT_STRUCTURE;
    (s.threshold_radius_m, s.angular_slip, s.motor_losses) = (None, 0.0, None);
    s.narrower_slip_track = false;
    s
}

/// The truth of [`husky_spec`].
fn husky_truth(effect: EffectId) -> Truth {
    simulate(&husky_spec(effect)).expect("simulates").truth
}

/// A terrain slip track narrower than the controller's (Table D.1's CSA terrain) turns every
/// turn faster than commanded, which no slip does: the calibration takes none of it (the
/// diagnosis' constant slip must be positive), so it stays visible, and `slip-track` is named
/// over every turn (`all`, as the truth says).
#[test]
fn a_narrower_slip_track_stays_visible_and_is_named() {
    let mut s = husky_spec(EffectId::SlipTrack);
    s.narrower_slip_track = true;
    let (truth, d) = super::run::explain(&s, false).expect("simulates");
    assert!(truth.visible_after_calibration, "{truth:?}");
    assert!(
        truth.unabsorbed_peak_w > 0.5 * truth.peak_extra_power_w,
        "{truth:?}"
    );
    assert_eq!(
        d.effect,
        crate::diagnose::Verdict::Effect(EffectId::SlipTrack)
    );
    assert_eq!(d.regime.label(), "all");
}

/// Truth regimes on Husky datasets: braked-inner and angular-slip at R', current-offset and
/// slope `all`, no effect `none`.
#[test]
fn truth_regimes_follow_where_the_extra_power_goes() {
    assert_eq!(husky_truth(EffectId::BrakedInner).regime, "at-r-prime");
    assert_eq!(husky_truth(EffectId::AngularSlip).regime, "at-r-prime");
    let t = husky_truth(EffectId::CurrentOffset);
    assert_eq!(t.regime, "all", "{t:?}");
    assert_eq!(husky_truth(EffectId::Slope).regime, "all");
    assert_eq!(truth_of(None, &[], &[]).regime, "none");
}

/// What the calibration runs absorb: a slip track of the test ground (the calibration ground
/// keeps the controller's, [`DatasetSpec::calibration_world`]) is none of the calibration's, so
/// it stays visible, as do braked inner wheels at R′ (a radius the calibration does not drive).
#[test]
fn the_truth_says_what_calibration_absorbs() {
    let slip_track = husky_truth(EffectId::SlipTrack);
    assert!(slip_track.peak_extra_power_w > 5.0, "{slip_track:?}");
    assert!(
        slip_track.unabsorbed_peak_w > 0.5 * slip_track.peak_extra_power_w,
        "{slip_track:?}"
    );
    assert!(slip_track.visible_after_calibration);
    let braked = husky_truth(EffectId::BrakedInner);
    assert!(
        braked.unabsorbed_peak_w > 0.8 * braked.peak_extra_power_w,
        "{braked:?}"
    );
    assert!(braked.visible_after_calibration);
}

/// A small bench over both parts (20 datasets each: every class twice): the tables add up,
/// every dataset is evaluated, and the scoring follows the class.
#[test]
fn small_bench_tabulates_every_dataset_per_part() {
    let opts = BenchOptions {
        datasets: 20,
        seed: 7,
        threads: 2,
        part: PartChoice::Both,
        poses: false,
        rounds: 2,
    };
    let report = run_bench(&opts);
    assert_eq!(report.datasets.len(), 40);
    assert_eq!(report.parts.len(), 2);
    for p in &report.parts {
        let s = &p.summary;
        assert_eq!(p.confusion.total(), 20);
        assert_eq!(
            (s.controls, s.structure_only, s.effect_datasets),
            (2, 2, 16)
        );
        assert_eq!(s.errors, 0, "{report}");
        for c in &p.per_class {
            // Every dataset in exactly one column: a structure-only `baseline-misfit` is right.
            let misfit_wrong = if c.label == "structure-only" {
                0
            } else {
                c.misfit
            };
            let sum =
                c.right + c.ambiguous + c.outside + misfit_wrong + c.none + c.wrong + c.errors;
            assert_eq!(sum, c.n, "{c:?}");
        }
        let per_structure: usize = p.per_structure.iter().map(|st| st.n).sum();
        assert_eq!(per_structure, 20);
        // Each switch partitions the part once.
        for switch in [
            "split=",
            "slip=",
            "loss=",
            "standstill=",
            "rover=",
            "turns=",
        ] {
            let n: usize = p
                .per_switch
                .iter()
                .filter(|st| st.structure.starts_with(switch))
                .map(|st| st.n)
                .sum();
            assert_eq!(n, 20, "{switch}");
        }
    }
    for r in &report.datasets {
        let expected = match r.spec.class {
            DatasetClass::Effect(e) => r.diagnosed == e.id(),
            DatasetClass::Control => r.diagnosed == "none",
            DatasetClass::StructureOnly => {
                r.diagnosed == "none" || r.diagnosed == run::BASELINE_MISFIT
            }
        };
        assert_eq!(r.right(), expected);
        assert!(r.diagnose_s > 0.0);
    }
    // The closed loop: only open verdicts drive, each round within the limits, and its figures
    // count every open dataset once.
    for r in &report.datasets {
        assert!(r.opened || r.next_rounds.is_empty(), "{r:?}");
        assert!(r.next_rounds.len() <= 2);
        for round in &r.next_rounds {
            let most = crate::diagnose::next_runs::MAX_MANOEUVRES;
            assert!((1..=most).contains(&round.manoeuvres), "{round:?}");
        }
    }
    for p in &report.parts {
        let l = &p.closed_loop;
        assert_eq!(
            l.settled_right + l.settled_wrong + l.settled_none + l.still_open,
            l.open_shown,
            "{l:?}"
        );
        assert!(l.open_shown_driven <= l.open_shown);
    }
    let text = report.to_text();
    assert!(text.contains("closed loop"), "{text}");
    assert!(text.contains("=== tuning part"), "{text}");
    assert!(text.contains("=== held-out part"), "{text}");
    assert!(text.contains("structure-only"), "{text}");
    let json = report.to_json();
    assert_eq!(json["parts"][1]["part"], "held-out");
    assert_eq!(json["parts"][0]["summary"]["controls"], 2);
    assert_eq!(json["datasets"].as_array().map(Vec::len), Some(40));
}

/// The Argo J5's current offsets at one v_c (bench seed 1, tuning 46, 56, 66: the offset is
/// absorbed by G·|V| except where a side stands still, and the Argo's 5 % manoeuvre-to-manoeuvre
/// power variation hides the rest) are named from the standstill current that measures them.
#[test]
fn argo_offsets_measured_at_standstill_are_named() {
    let specs = generate(Part::Tuning, 100, 1);
    for index in [46, 56, 66] {
        let spec = &specs[index];
        assert_eq!(spec.class, DatasetClass::Effect(EffectId::CurrentOffset));
        assert_eq!(spec.rover, RoverKind::ArgoJ5);
        let result = run_dataset(spec);
        let report =
            run::explain(spec, false).map(|(_, d)| crate::diagnose::report::table(&d).to_string());
        assert!(
            result.named_right(),
            "{index}: {} {report:?}",
            result.diagnosed
        );
    }
}

/// A measured standstill offset decides a near tie in the turns: on bench seed 3, tuning 26 (an
/// Argo offset at one v_c) `braked-inner` scored a little better out of sample than
/// `current-offset`, and the dataset was `ambiguous` while the standstill samples showed the
/// offset directly.
#[test]
fn a_measured_offset_decides_a_near_tie() {
    let spec = &generate(Part::Tuning, 100, 3)[26];
    assert_eq!(spec.class, DatasetClass::Effect(EffectId::CurrentOffset));
    let result = run_dataset(spec);
    assert!(result.named_right(), "{}", result.diagnosed);
    assert_ne!(
        result.best_candidate.as_ref().map(|b| b.0),
        Some(EffectId::CurrentOffset),
        "no longer a near tie: the test shows nothing"
    );
}

/// A motor-loss world whose calibration the copper-free members misfit (bench seed 1, tuning 2:
/// a structure with losses): the family escalates to copper loss, and the report says so.
#[test]
fn an_escalated_copper_baseline_is_reported() {
    let spec = &generate(Part::Tuning, 100, 1)[2];
    assert!(spec.structure.losses, "{spec:?}");
    let (_, d) = run::explain(spec, false).expect("diagnoses");
    assert!(d.baseline.structure.copper_loss, "{:?}", d.baseline);
    let text = crate::diagnose::report::table(&d).to_string();
    assert!(text.contains("plus copper loss c·F²"), "{text}");
}

/// Every drawn world can be driven: the bus stays well above the battery's collapse point
/// (V₀/2, where the demanded power exceeds V₀²/4R_int). The Argo with motor losses and the
/// Husky's windings and battery asked 2.8 kW a side and sat at 12 V.
#[test]
fn no_drawn_world_collapses_the_bus() {
    for spec in both(100, 1) {
        let world = spec.world();
        let timeline = world
            .simulate(&spec.calibration_scenario(), spec.seed)
            .expect("simulates");
        let min_v = run::sample_run(&timeline, 50)
            .iter()
            .map(|s| s.bus_v.left.min(s.bus_v.right))
            .fold(f64::INFINITY, f64::min);
        assert!(
            min_v > 0.8 * world.battery.nominal_v,
            "{:?}-{}: {min_v:.1} V",
            spec.part,
            spec.index
        );
    }
}

/// Tuning dataset 73 of bench seed 1 (a Husky with motor losses and the angular-slip effect):
/// `angular-slip` closes 51 % and `slip-track`, which scales every turn's power, 46 %, a
/// penalised ratio of 1.18, under the clear margin. The yaw decides: the turns below R′ run
/// slower than the calibration's constant slip, rising from the point turn, which a slip track
/// does not. Before, `ambiguous`.
#[test]
fn measured_slip_decides_angular_slip_against_slip_track() {
    let d = diagnosed(
        Part::Tuning,
        1,
        73,
        DatasetClass::Effect(EffectId::AngularSlip),
    );
    let score = |e: EffectId| {
        d.candidates
            .iter()
            .find(|c| c.effect == e)
            .expect("scored")
            .penalised_mse
    };
    let ratio = score(EffectId::SlipTrack) / score(EffectId::AngularSlip);
    assert!(
        ratio > 1.0 && ratio < crate::diagnose::cv::CLEAR_MARGIN,
        "{ratio}"
    );
    assert_eq!(
        d.effect,
        crate::diagnose::Verdict::Effect(EffectId::AngularSlip)
    );
}

/// Tuning dataset 40 of bench seed 3, a Husky control: the outer side at R′ draws 5.6 W less
/// than the model (a significant gap), and the `braked-inner` term, fitted with a negative
/// coefficient, closes 61 % of it. A held inner side dragged by the outer one can only add
/// power, so a term fitted against its physics is a shape that matches a deficit, not the
/// effect: nothing is named. Before, `braked-inner`.
#[test]
fn a_term_fitted_against_its_physics_is_not_named() {
    let d = diagnosed(Part::Tuning, 3, 40, DatasetClass::Control);
    assert!(d.gaps.iter().any(|g| g.significant && g.mean_w < 0.0));
    assert!(d.effect.effect().is_none(), "{:?}", d.effect);
}

/// Tuning dataset 69 of bench seed 1, a Husky whose motors have losses and no effect: against
/// the copper-free member the calibration chose, copper loss shows at every slow, high-force
/// inner side, +9.0 W at dragged-inner and +6.0 W below half the track, both significant.
/// `inner-drag` acts only past B/2 and closes the first, so it is a shape fitting part of a
/// wider misfit: nothing is named. Before, `inner-drag`. The diagnosed runs then show the copper
/// loss itself (`copper_from_runs`): the copper-loss member predicts them better than the
/// chosen member with any single effect, and the diagnosis against it names nothing either.
#[test]
fn a_term_that_misses_an_equal_gap_where_it_cannot_act_is_not_named() {
    let (rover, cal_rows, rows) = dataset_rows(Part::Tuning, 1, 69, DatasetClass::StructureOnly);
    let calibration = crate::diagnose::calibration::Calibration::rows(&cal_rows);
    let d = crate::diagnose::diagnose_against(crate::diagnose::Problem {
        rover: &rover,
        rows: &rows,
        calibration,
    })
    .expect("diagnoses");
    let inner_gap = |regime: Regime| {
        d.gaps
            .iter()
            .find(|g| g.regime == regime && g.side == crate::diagnose::Part::Inner)
            .filter(|g| g.significant)
            .map(|g| g.mean_w)
    };
    let (below, dragged) = (
        inner_gap(Regime::BelowHalfTrack).expect("significant below B/2"),
        inner_gap(Regime::DraggedInner).expect("significant past B/2"),
    );
    assert!(below > 0.5 * dragged && dragged > 0.0, "{below} {dragged}");
    assert_eq!(d.candidates[0].effect, EffectId::InnerDrag);
    assert!(d.effect.effect().is_none(), "{:?}", d.effect);
    assert!(!d.baseline.structure.copper_loss && d.copper_from_runs.is_none());

    let d = crate::diagnose::diagnose_with(&rover, &rows, calibration).expect("diagnoses");
    let evidence = d.copper_from_runs.expect("copper loss from the runs");
    assert!(d.baseline.structure.copper_loss);
    assert!(evidence.copper_member_error_w < evidence.best_effect_error_w);
    // The report's figures and model file refit the baseline the diagnosis used
    // (`Diagnosis::fitted_with`), not the copper-free one the calibration chose.
    let refitted = d
        .fitted_with(calibration)
        .baseline(&rover, &rows)
        .expect("fits");
    assert_eq!(refitted.structure, d.baseline.structure);
    assert_eq!(refitted.copper_w_per_n2, d.baseline.copper_w_per_n2);
    assert!(
        !calibration
            .baseline(&rover, &rows)
            .expect("fits")
            .structure
            .copper_loss
    );
    assert!(d.effect.effect().is_none(), "{:?}", d.effect);
}

/// Tuning dataset 25 of bench seed 1, a Husky with a braked inner side on a rover whose motors
/// have losses (threshold split, ≈ 0 A standstill). While the returned fraction was a grid
/// (0.3/0.5/0.7/0.85) even the copper-loss members left a lack of fit on the calibration
/// manoeuvres, so copper loss was refused there and had to come from the diagnosed runs
/// ([`copper_from_runs`](crate::diagnose::copper_from_runs)). With the fraction fitted as a
/// continuous parameter, the calibration identifies it itself (copper loss with ≈ 58 %
/// returned fits), and against it `braked-inner` is named.
#[test]
fn a_returning_driver_with_copper_loss_is_found_on_the_calibration() {
    let class = DatasetClass::Effect(EffectId::BrakedInner);
    let (rover, cal_rows, rows) = dataset_rows(Part::Tuning, 1, 25, class);
    let calibration = crate::diagnose::calibration::Calibration::rows(&cal_rows);
    let d = crate::diagnose::diagnose_with(&rover, &rows, calibration).expect("diagnoses");
    let summary = format!("{:?} {:?}", d.effect, d.baseline.structure);
    assert!(d.baseline.structure.copper_loss, "{summary}");
    assert!(
        matches!(d.baseline.structure.split, crate::diagnose::baseline::Split::Returning { fraction } if (0.4..0.75).contains(&fraction)),
        "{summary}"
    );
    assert_eq!(d.adequacy.adequate, Some(true), "{summary}");
    assert!(d.copper_from_runs.is_none(), "{summary}");
    assert_eq!(
        d.effect,
        crate::diagnose::Verdict::Effect(EffectId::BrakedInner)
    );
}

/// Tuning dataset 44 of bench seed 12, a Husky on a terrain whose slip track is narrower than
/// the controller's (threshold split, motor losses): every turn is faster than commanded. On
/// power alone `slip-track` (70 %) and `angular-slip` (68 %) tie, as they share the signature
/// of a turn's time; the yaw decides it, since no angular slip makes a turn faster. Before,
/// `ambiguous`.
#[test]
fn turns_measured_faster_than_commanded_decide_for_slip_track() {
    let d = diagnosed(
        Part::Tuning,
        12,
        44,
        DatasetClass::Effect(EffectId::SlipTrack),
    );
    let [best, runner_up] = [&d.candidates[0], &d.candidates[1]];
    let mut top = [best.effect, runner_up.effect];
    top.sort_by_key(|e| e.id());
    assert_eq!(top, [EffectId::AngularSlip, EffectId::SlipTrack]);
    assert!(runner_up.penalised_mse < crate::diagnose::cv::CLEAR_MARGIN * best.penalised_mse);
    assert_eq!(
        d.effect,
        crate::diagnose::Verdict::Effect(EffectId::SlipTrack)
    );
}

/// Tuning dataset 98 of bench seed 7, an Argo on undulating ground with a threshold split,
/// a constant slip and motor losses: efficiency makes a climb cost more than a descent
/// returns, so the linear grade term closes only 26 % and no candidate clears the 30 % bar.
/// The pitch is measured, and the grade's power is physics on it: `slope`, the best
/// candidate, is named. (Session 10 pinned this on seed 11 tuning-48, whose world changed
/// when a side held at stall began to draw its copper loss.)
#[test]
fn a_measured_pitch_names_slope_when_it_is_the_best_candidate() {
    let d = diagnosed(Part::Tuning, 7, 98, DatasetClass::Effect(EffectId::Slope));
    let best = &d.candidates[0];
    assert_eq!(best.effect, EffectId::Slope);
    assert!(
        (0.0..crate::diagnose::cv::MIN_SHRINK_PCT).contains(&best.shrink_pct),
        "{}",
        best.shrink_pct
    );
    assert_eq!(d.effect, crate::diagnose::Verdict::Effect(EffectId::Slope));
}

/// Tuning dataset 49 of bench seed 6, a Husky whose motors have losses and no effect. The
/// diagnosed runs show copper loss (12.5 W held-out RMS without it, 4.0 W with it, 9.3 W with
/// `inner-drag` instead), and against the copper-loss member `inner-drag` still closed 31 % of
/// what is left at dragged-inner and was named: the member's own error where copper and the
/// drag share a signature. The effect copper loss beat is not named against it. Before,
/// `inner-drag`.
#[test]
fn the_effect_copper_loss_displaced_is_not_named_against_it() {
    let d = diagnosed(Part::Tuning, 6, 49, DatasetClass::StructureOnly);
    assert!(d.effect.effect().is_none(), "{:?}", d.effect);
}

/// Tuning dataset 53 of bench seed 14, a Husky with `angular-slip`, a regenerating split and
/// motor losses. Against the copper-free member the calibration chose, `angular-slip` led
/// (17.8 W held-out RMS) without a clear margin; the copper-loss member alone (23.8 W against
/// 25.3 W) does not beat that, but together with `angular-slip` it does (14.5 W): copper loss
/// beside the effect. Since issue 35 the yaw's signature decides the near tie against the
/// copper-free member already (the turns slow towards R′), so the diagnosis names
/// `angular-slip` without the second pass; the evidence for copper loss beside it stands.
#[test]
fn copper_loss_beside_the_best_effect_is_evidence_from_the_runs() {
    let spec = generate(Part::Tuning, 100, 14).swap_remove(53);
    assert_eq!(spec.class, DatasetClass::Effect(EffectId::AngularSlip));
    let rover = spec.rover.rover();
    let (cal_rows, rows) = simulate(&spec)
        .expect("simulates")
        .rows(&rover, None)
        .expect("validates");
    let calibration = crate::diagnose::calibration::Calibration::rows(&cal_rows);
    let first = crate::diagnose::diagnose_against(crate::diagnose::Problem {
        rover: &rover,
        rows: &rows,
        calibration,
    })
    .expect("diagnoses");
    assert_eq!(
        first.effect,
        crate::diagnose::Verdict::Effect(EffectId::AngularSlip)
    );
    assert!(first.signatures[EffectId::AngularSlip as usize].present());
    let evidence = crate::diagnose::copper_from_runs::evidence(&rover, &rows, calibration, &first)
        .expect("copper loss from the runs");
    assert_eq!(evidence.best_effect, EffectId::AngularSlip);
    assert!(evidence.copper_member_error_w > evidence.best_effect_error_w);
    let both = evidence
        .copper_with_effect_error_w
        .expect("beside the effect");
    assert!(
        both < crate::diagnose::copper_from_runs::COPPER_ERROR_RATIO * evidence.best_effect_error_w
    );
}

/// Held-out dataset 29 of bench seed 2, an Argo with a threshold split and a constant slip and
/// no effect: the only significant gaps are on the straights (−6.4 W a side), where
/// `sinkage-bulldozing` does not act. It explained the turns' spread out of sample and was
/// named, at `straight`. A term that acts on none of the significant gaps is not named.
#[test]
fn a_term_that_acts_on_none_of_the_gaps_is_not_named() {
    let d = diagnosed(Part::HeldOut, 2, 29, DatasetClass::StructureOnly);
    let significant: Vec<_> = d.gaps.iter().filter(|g| g.significant).collect();
    assert!(!significant.is_empty());
    assert!(significant.iter().all(|g| g.regime == Regime::Straight));
    assert!(d.effect.effect().is_none(), "{:?}", d.effect);
}

/// Tuning dataset 90 of bench seed 3, a Husky control: one significant gap, +5.8 W on the
/// outer side at dragged-inner, is repeat noise. `motor-heating` closed 66 % of it (the
/// dragged-inner turns came late in the runs) though over all rows only 28 %, and was named
/// where the gap is. A warm winding acts on every manoeuvre; a gap in a few regimes is not
/// its: nothing is named. Before, `motor-heating @ dragged-inner`.
#[test]
fn an_effect_of_every_manoeuvre_is_not_named_on_a_gap_in_one_regime() {
    let d = diagnosed(Part::Tuning, 3, 90, DatasetClass::Control);
    let regimes: BTreeSet<_> = d
        .gaps
        .iter()
        .filter(|g| g.significant)
        .map(|g| g.regime)
        .collect();
    assert_eq!(
        regimes.into_iter().collect::<Vec<_>>(),
        [Regime::DraggedInner]
    );
    assert_eq!(d.candidates[0].effect, EffectId::MotorHeating);
    assert!(d.effect.effect().is_none(), "{:?}", d.effect);
}

/// The diagnosis of dataset `index` of bench seed `seed`'s `part` (100 datasets), checked to be
/// of class `class`.
/// The rover, calibration rows and diagnosed rows of one bench dataset, for diagnosing it
/// other than the bench does.
fn dataset_rows(
    part: Part,
    seed: u64,
    index: usize,
    class: DatasetClass,
) -> (
    model_core::Rover,
    Vec<crate::diagnose::features::TurnRow>,
    Vec<crate::diagnose::features::TurnRow>,
) {
    let spec = generate(part, 100, seed).swap_remove(index);
    assert_eq!(spec.class, class);
    let rover = spec.rover.rover();
    let (cal_rows, rows) = super::simulate(&spec)
        .expect("simulates")
        .rows(&rover, None)
        .expect("rows");
    (rover, cal_rows, rows)
}

fn diagnosed(
    part: Part,
    seed: u64,
    index: usize,
    class: DatasetClass,
) -> crate::diagnose::Diagnosis {
    let spec = generate(part, 100, seed).swap_remove(index);
    assert_eq!(spec.class, class);
    super::run::explain(&spec, false).expect("simulates").1
}

/// Tuning dataset 22 of bench seed 1, a Husky on sand (sinkage and bulldozing) with a threshold
/// split and motor losses: the baseline misfits its calibration manoeuvres (the point turns
/// draw 21 W more than Eq 21 allows, the 2R′ turns 7 W less), and out of sample no term wins
/// clearly. Of the candidates, only `sinkage-bulldozing` makes the calibration manoeuvres fit:
/// they are the evidence, and it is named. Before, `baseline-misfit`.
#[test]
fn the_one_term_that_explains_the_calibration_misfit_is_named() {
    let d = diagnosed(
        Part::Tuning,
        1,
        22,
        DatasetClass::Effect(EffectId::SinkageBulldozing),
    );
    assert_eq!(d.adequacy.adequate, Some(false));
    assert_ne!(d.candidates[0].effect, EffectId::SinkageBulldozing);
    assert_eq!(
        d.effect,
        crate::diagnose::Verdict::Effect(EffectId::SinkageBulldozing)
    );
    let with = d
        .adequacy_with_effect
        .as_ref()
        .expect("judged with the effect");
    assert!(
        crate::diagnose::adequacy::explained_fraction(&d.adequacy, with)
            >= crate::diagnose::adequacy::EXPLAINED_BY_EFFECT
            || with.adequate != Some(false)
    );
}

/// Tuning dataset 85 of bench seed 4, a Husky whose motors have losses, with its inner side
/// braked at R′: `braked-inner` is the best term but per side it closes 26 % (the split's own
/// misfit stays in each side's residual) and no candidate wins there; on each manoeuvre's total
/// power, Eq 21's own observation, it closes 48 % and clears the margin, and is named.
/// (Session 9 pinned this on seed 3 tuning-18, a slope now named on its sides.)
#[test]
fn the_total_power_decides_when_the_sides_leave_a_tie() {
    let d = diagnosed(
        Part::Tuning,
        4,
        85,
        DatasetClass::Effect(EffectId::BrakedInner),
    );
    let braked = d
        .candidates
        .iter()
        .find(|c| c.effect == EffectId::BrakedInner)
        .expect("scored");
    assert!(
        braked.shrink_pct < crate::diagnose::cv::MIN_SHRINK_PCT,
        "{braked:?}"
    );
    assert_eq!(crate::diagnose::select::select(&d.candidates), None);
    assert_eq!(
        crate::diagnose::select::clear_in_total(&d.candidates),
        Some(EffectId::BrakedInner)
    );
    assert_eq!(
        d.effect,
        crate::diagnose::Verdict::Effect(EffectId::BrakedInner)
    );
}

/// The ceiling of the shrink comes from the dataset's twin without the effect: a strong
/// angular slip (bench seed 1, tuning 23: 97 % shrink) leaves a twin whose baseline error is a
/// small share of the dataset's, a twin that kept the effect would give 0 %, and datasets
/// without an effect have no ceiling.
#[test]
fn the_shrink_ceiling_is_the_twin_without_the_effect() {
    let specs = generate(Part::Tuning, 100, 1);
    let strong = run_dataset(&specs[23]);
    assert_eq!(specs[23].class, DatasetClass::Effect(EffectId::AngularSlip));
    let ceiling = strong
        .ceiling_shrink_pct
        .expect("an effect dataset has a ceiling");
    assert!(ceiling >= 70.0, "{ceiling}");
    assert!(
        strong
            .true_effect_shrink_pct
            .is_some_and(|s| s <= ceiling + 5.0),
        "{strong:?}"
    );
    for index in [20, 29] {
        assert_eq!(specs[index].effect(), None);
        assert_eq!(run_dataset(&specs[index]).ceiling_shrink_pct, None);
    }
}

/// A power deficit is not a narrower slip track unless the yaw says the turns were quicker:
/// bench seed 5, tuning 59 (a structure-only Husky with a regenerating split) has its turns
/// below B/2 drawing 2–5 W less than the baseline while taking as long as the terrain slip
/// says, and was named `slip-track` (a negative term) on that deficit.
#[test]
fn a_deficit_with_turns_on_time_is_no_narrower_slip_track() {
    let spec = &generate(Part::Tuning, 100, 5)[59];
    assert_eq!(spec.class, DatasetClass::StructureOnly);
    let result = run_dataset(spec);
    assert!(!result.named_an_effect(), "{}", result.diagnosed);
}

/// Sand sinks the wheels on the straights too, and the calibration puts that resistance into
/// G: on the Argo the simulator's sinkage is largest on the straights (bench seed 5, tuning 82:
/// +123 W straight, +70 W point turn), so beyond G·|V| the turn-only term is a deficit, and the
/// baseline misfits its calibration. The turns below R′ then grow no more than the straights
/// (the thesis' slip sinkage of a heavy rover is longitudinal as much as lateral), so the mark
/// read against the straights is missing; but every manoeuvre's power still rises after its
/// start as the wheels sink, on both sides. A warming winding raises it too, and these runs
/// never repeat a manoeuvre, so the mark is inconclusive and not named: what to drive next asks
/// for heating's repeats, and with them driven in the same world heating's mark is missing, the
/// rise is sinkage's and it is named beside the misfit. Its twin without sinkage reads no rise.
/// Until issue 36, `baseline-misfit` with the mark missing and nothing to drive.
#[test]
fn argo_sinkage_rising_on_the_straights_too_is_named_once_repeats_rule_out_heating() {
    let spec = &generate(Part::Tuning, 100, 5)[82];
    assert_eq!(
        spec.class,
        DatasetClass::Effect(EffectId::SinkageBulldozing)
    );
    assert_eq!(spec.rover, RoverKind::ArgoJ5);
    let (_, d) = run::explain(spec, false).expect("diagnoses");
    assert!(d.effect.effect().is_none(), "{:?}", d.effect);
    let sinkage = &d.signatures[EffectId::SinkageBulldozing as usize];
    assert!(sinkage.inconclusive(), "{}", sinkage.describe());
    assert_eq!(sinkage.told_apart_by, Some(EffectId::MotorHeating));
    let heating_drive = d.next.runs.iter().find(|r| {
        r.observes
            == Some(crate::diagnose::next_runs::Rival::Effect(
                EffectId::MotorHeating,
            ))
    });
    assert!(heating_drive.is_some(), "{:?}", d.next.runs);
    let r = run_dataset_closing(spec, false, 2);
    assert_eq!(
        r.settled_label(),
        "sinkage-bulldozing",
        "{:?}",
        r.next_rounds
    );
    let twin = DatasetSpec {
        class: DatasetClass::StructureOnly,
        ..spec.clone()
    };
    let (_, d) = run::explain(&twin, false).expect("diagnoses");
    let sinkage = &d.signatures[EffectId::SinkageBulldozing as usize];
    assert!(sinkage.absent(), "{}", sinkage.describe());
    assert_eq!(sinkage.told_apart_by, None);
}

/// Tuning dataset 19 of bench seed 22, an Argo with the clamp split and no effect: the outer
/// side at R′ draws 40 W more than the model (n = 3), and `braked-inner` (the outer side at R′
/// only) closed 85 % of it and was named. But the outer side at 0.8R′ draws 28 W more too:
/// the gap is a hump across the radii, not the step a held inner side makes at R′, and the
/// regime pools 0.8R′ with R′/3 and 2R′/3, so only the neighbouring radius shows it. Before,
/// `braked-inner`.
#[test]
fn a_braked_inner_side_is_a_step_at_r_prime_not_a_hump() {
    let d = diagnosed(Part::Tuning, 22, 19, DatasetClass::StructureOnly);
    assert!(d.effect.effect().is_none(), "{:?}", d.effect);
    let at_r_prime_outer = d
        .gaps
        .iter()
        .find(|g| {
            g.regime == model_core::kinematics::Regime::AtRPrime
                && g.side == crate::diagnose::Part::Outer
        })
        .expect("gap at R′ outer");
    assert!(at_r_prime_outer.significant && at_r_prime_outer.mean_w > 20.0);
}

/// Tuning dataset 8 of bench seed 12, an Argo on undulating ground whose motors have losses:
/// `slope` closes 62 % out of sample, but the only significant gap is the inner side at R′,
/// held at stall, where the grade term is 0. A force there shows as copper loss alone, which
/// no term's power models, so with copper loss in the baseline that gap neither vetoes a term
/// nor credits one. Before, `ambiguous`.
#[test]
fn a_gap_at_a_side_held_at_stall_does_not_veto_a_term() {
    let d = diagnosed(Part::Tuning, 12, 8, DatasetClass::Effect(EffectId::Slope));
    assert!(d.baseline.structure.copper_loss);
    let significant: Vec<_> = d.gaps.iter().filter(|g| g.significant).collect();
    assert!(significant.iter().all(|g| {
        g.regime == model_core::kinematics::Regime::AtRPrime
            && g.side == crate::diagnose::Part::Inner
    }));
    assert_eq!(d.effect, crate::diagnose::Verdict::Effect(EffectId::Slope));
}

/// Tuning dataset 68 of bench seed 9, a Husky on undulating ground with the clamp split and
/// motor losses: the calibration chose a copper-free member, which gives the inner side at R′
/// (commanded still) no power, while it holds its tread's force and draws that torque's
/// copper loss. `slope` is named on its pitch, a mark measured without the power model, although
/// its term cannot reach that gap. (Until stop 50 the gap vetoed it, and copper loss taken from
/// the runs named it.) The runs still show the copper loss at the sides held at stall: over all
/// held-out rows the copper member beats neither the chosen one nor it with `slope`, but there it
/// does.
#[test]
fn the_sides_held_at_stall_show_the_copper_loss() {
    let spec = generate(Part::Tuning, 100, 9).swap_remove(68);
    assert_eq!(spec.class, DatasetClass::Effect(EffectId::Slope));
    let rover = spec.rover.rover();
    let (cal_rows, rows) = run::simulate(&spec)
        .expect("simulates")
        .rows(&rover, None)
        .expect("rows");
    let calibration = crate::diagnose::calibration::Calibration::rows(&cal_rows);
    let d = crate::diagnose::diagnose_with(&rover, &rows, calibration).expect("diagnoses");
    assert_eq!(d.effect, crate::diagnose::Verdict::Effect(EffectId::Slope));
    assert!(!d.baseline.structure.copper_loss);
    let evidence = crate::diagnose::copper_from_runs::evidence(&rover, &rows, calibration, &d)
        .expect("copper loss from the runs");
    let [chosen, copper] = evidence.at_stall_error_w.expect("decided at stall");
    assert!(copper < crate::diagnose::copper_from_runs::COPPER_ERROR_RATIO * chosen);
}

/// Tuning dataset 91 of bench seed 5, a Husky with motor losses, a constant slip and an inner
/// drag. The copper member alone predicts the runs better than the chosen copper-free member
/// with `inner-drag`, and against the copper member `inner-drag` still closes the bar: both
/// are the rover's, and it is named. Before (the effect copper loss beat was never kept),
/// `ambiguous`.
#[test]
fn an_effect_that_closes_the_bar_against_copper_loss_is_named() {
    let d = diagnosed(
        Part::Tuning,
        5,
        91,
        DatasetClass::Effect(EffectId::InnerDrag),
    );
    let evidence = d
        .copper_from_runs
        .as_ref()
        .expect("copper loss from the runs");
    assert_eq!(evidence.best_effect, EffectId::InnerDrag);
    assert_eq!(evidence.copper_with_effect_error_w, None);
    assert_eq!(
        d.effect,
        crate::diagnose::Verdict::Effect(EffectId::InnerDrag)
    );
}

/// The closed loop on an open verdict it settles (bench seed 1, tuning 45): braked inner wheels
/// at R′, `ambiguous` on the turn set (R′'s outer side draws 12 W more than the model, but
/// three turns cannot show that step beyond the baseline's own steps between radii); the
/// diagnosis asks for more R′ turns, and with them driven in the same world (two rounds, each
/// within the budget of one suggestion) the signature is present and the effect named.
#[test]
fn the_closed_loop_settles_an_open_verdict_with_what_it_suggests() {
    let spec = generate(Part::Tuning, 100, 1).remove(45);
    assert_eq!(spec.class, DatasetClass::Effect(EffectId::BrakedInner));
    let r = run_dataset_closing(&spec, false, 2);
    assert!(r.opened, "{r:?}");
    assert_eq!(r.diagnosed, "ambiguous");
    assert!(!r.next_rounds.is_empty(), "something to drive");
    assert!(
        r.next_rounds
            .iter()
            .all(|round| round.manoeuvres <= crate::diagnose::next_runs::MAX_MANOEUVRES),
        "{:?}",
        r.next_rounds
    );
    assert_eq!(r.settled_label(), "braked-inner", "{:?}", r.next_rounds);
    assert!(!r.still_open());
    // Without rounds nothing is driven.
    assert!(run_dataset_closing(&spec, false, 0).next_rounds.is_empty());
}

/// A control the closed loop drives to see motor heating's mark (bench seed 1, held-out 10:
/// three point turns in a row, then a straight, as one short run): the residuals then trend
/// over run time (+22 W over the 0.8 min run, the runs' mix of manoeuvres), but the repeated
/// turns themselves draw no more later, so no heating is named.
#[test]
fn repeats_that_draw_no_more_later_show_no_heating() {
    let spec = generate(Part::HeldOut, 100, 1).remove(10);
    assert_eq!(spec.class, DatasetClass::Control);
    let r = run_dataset_closing(&spec, false, 2);
    assert!(r.opened, "{r:?}");
    assert!(!r.next_rounds.is_empty(), "something to drive");
    assert!(
        EffectId::from_id(r.settled_label()).is_none(),
        "{:?}",
        r.next_rounds
    );
}

/// A step at one radius no larger than the model's steps between other neighbouring radii on
/// that side is the baseline's structure, not an effect's mark (bench seed 27, tuning 31: inner
/// drag on lossy motors, once named `braked-inner` from R′'s outer side stepping +1.7 W at
/// p = 0.041 where that side steps 4.7 W between other radii). Inner drag's own step (+6.8 W)
/// stands beyond them.
#[test]
fn a_step_no_larger_than_the_steps_elsewhere_is_not_a_mark() {
    let spec = generate(Part::Tuning, 100, 27).remove(31);
    assert_eq!(spec.class, DatasetClass::Effect(EffectId::InnerDrag));
    let (_, d) = run::explain(&spec, false).expect("diagnosed");
    assert_ne!(d.effect.label(), "braked-inner");
    let braked = d.signature(EffectId::BrakedInner).expect("tested");
    assert!(!braked.present(), "{}", braked.describe());
    assert!(braked.detail.contains("elsewhere"), "{}", braked.describe());
    let drag = d.signature(EffectId::InnerDrag).expect("tested");
    assert!(drag.present(), "{}", drag.describe());
}
