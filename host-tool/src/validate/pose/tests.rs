use super::*;
use crate::validate::ManoeuvreKind;

const HUSKY: Rover = Rover::HUSKY_A200;
const DT_S: f64 = 0.2;

/// Fixes of a rigid turn: the rover's centre circles (3, −2) at `r_act_m` with `yaw_rate`
/// (counter-clockwise positive: a left turn), the tracked point `offset_m` right of the centre,
/// one fix every 0.2 s with a deterministic wobble of up to ±`noise_m` per coordinate.
fn track(r_act_m: f64, yaw_rate: f64, seconds: f64, offset_m: f64, noise_m: f64) -> Vec<RunSample> {
    let n = (seconds / DT_S).round() as usize + 1;
    (0..n)
        .map(|k| {
            let t = k as f64 * DT_S;
            let psi = 0.3 + yaw_rate * t;
            // The turn centre is on the rover's left in a left turn, on its right in a right one.
            let left = (-psi.sin(), psi.cos());
            let side = yaw_rate.signum();
            let centre = (
                3.0 - side * r_act_m * left.0,
                -2.0 - side * r_act_m * left.1,
            );
            let point = (
                centre.0 + offset_m * psi.sin(),
                centre.1 - offset_m * psi.cos(),
            );
            let wobble =
                |j: f64| noise_m * (2.0 * ((k as f64 * 12.9898 + j).sin() * 43_758.545).fract());
            RunSample {
                t_s: t,
                bus_v: Sides::new(24.0, 24.0),
                current_a: Sides::new(1.0, 1.0),
                cmd_mps: Sides::new(0.0, 0.0),
                yaw_rad: None,
                pitch_deg: None,
                x_m: Some(point.0 + wobble(1.0)),
                y_m: Some(point.1 + wobble(2.0)),
            }
        })
        .collect()
}

fn context(direction: TurnDirection, radius_cmd_m: f64, offset_m: f64) -> TurnContext<'static> {
    // Commanded: v_c 0.3 m/s at R' rates (0.545 rad/s), inner side still.
    let (inner, outer) = (0.0, 0.6);
    let (cmd_mps, yaw) = match direction {
        TurnDirection::Left => (Sides::new(inner, outer), 0.6 / 1.1),
        TurnDirection::Right => (Sides::new(outer, inner), -0.6 / 1.1),
    };
    TurnContext {
        rover: &HUSKY,
        cmd_mps,
        direction: Some(direction),
        radius_cmd_m: Some(radius_cmd_m),
        yaw_rate_cmd_rad_s: yaw,
        tracker_offset_m: offset_m,
    }
}

/// Eq 5.6–5.10 for a rigid turn: a wheel at lateral distance d from the turn centre and L/2
/// ahead or behind moves at ω √(d² + (L/2)²).
fn wheel_speed(yaw_rate: f64, lateral_m: f64) -> f64 {
    let half_l = f64::from(HUSKY.length_m) / 2.0;
    yaw_rate.abs() * lateral_m.hypot(half_l)
}

#[test]
fn left_and_right_turns_give_r_act_slip_and_wheel_speeds() {
    // The rover turns at 80 % of the commanded 0.545 rad/s (s_ω = 0.2) on a 0.7 m circle.
    let rate = 0.8 * 0.6 / 1.1;
    let half_b = f64::from(HUSKY.track_width_m) / 2.0;
    for (direction, sign) in [(TurnDirection::Left, 1.0), (TurnDirection::Right, -1.0)] {
        let fixes = track(0.7, sign * rate, 4.0, 0.21, 0.002);
        let t = analyse_track(&fixes, &context(direction, 0.55, 0.21));
        let r = t.r_act_m.expect("R_ACT");
        assert!((r - 0.7).abs() < 0.01, "{direction:?}: R_ACT {r}, {t:?}");
        let slip = t.angular_slip.expect("slip");
        assert!((slip - 0.2).abs() < 0.02, "{direction:?}: s {slip}");
        assert!(t.fit_rms_m.expect("rms") < 0.003);
        let v = t.wheel_speed_mps.expect("speeds");
        assert!(
            (v.inner - wheel_speed(rate, 0.7 - half_b)).abs() < 0.01,
            "{v:?}"
        );
        assert!(
            (v.outer - wheel_speed(rate, 0.7 + half_b)).abs() < 0.01,
            "{v:?}"
        );
        // Appendix D: inner side still, B_s = 2 R_ACT.
        let bs = t.slip_track_m.expect("B_s");
        assert!((bs - 1.4).abs() < 0.02, "{bs}");
        assert!(t.swept_deg.expect("swept") * sign > 80.0);
    }
}

#[test]
fn point_turns_with_the_prism_outboard_inboard_or_at_the_centre() {
    let rate = 0.6 / 0.545 * 0.5;
    // Left: the prism circles at 0.21 m, R_ACT = 0.
    let t = analyse_track(
        &track(0.0, rate, 4.0, 0.21, 0.001),
        &context(TurnDirection::Left, 0.0, 0.21),
    );
    assert!(t.r_act_m.expect("R_ACT") < 0.01, "{t:?}");
    // Right: the prism is inboard; 0 and 0.42 m both fit, the command picks 0.
    let t = analyse_track(
        &track(0.0, -rate, 4.0, 0.21, 0.001),
        &context(TurnDirection::Right, 0.0, 0.21),
    );
    assert!(t.r_act_m.expect("R_ACT") < 0.01, "{t:?}");
    assert!(
        matches!(t.notes[..], [TrackNote::AmbiguousRadius { other_m }] if (other_m - 0.42).abs() < 0.01),
        "{:?}",
        t.notes
    );
    // A tracker on the centre sees no circle: the rover turned about it.
    let t = analyse_track(
        &track(0.0, rate, 4.0, 0.0, 0.002),
        &context(TurnDirection::Left, 0.0, 0.0),
    );
    assert_eq!(t.r_act_m, Some(0.0));
    assert_eq!(t.notes, [TrackNote::TurnedAboutTrackedPoint]);
}

#[test]
fn lost_fixes_are_filled_and_the_rate_keeps_its_time_base() {
    let rate = 0.3;
    let mut fixes = track(1.5, rate, 6.0, 0.21, 0.001);
    let total = fixes.len();
    // Every 6th fix lost (an empty cell, as in the run CSV).
    for s in fixes.iter_mut().skip(3).step_by(6) {
        (s.x_m, s.y_m) = (None, None);
    }
    let t = analyse_track(&fixes, &context(TurnDirection::Left, 1.5, 0.21));
    assert!(t.filled >= 4, "{t:?}");
    assert_eq!(t.fixes + t.filled, total, "{t:?}");
    assert!((t.r_act_m.expect("R_ACT") - 1.5).abs() < 0.01);
    let measured = t.yaw_rate_act_rad_s.expect("rate");
    assert!((measured - rate).abs() < 0.005, "{measured}");
}

#[test]
fn bad_tracks_get_a_note_not_an_error() {
    let ctx = context(TurnDirection::Left, 0.55, 0.21);
    let mut fixes = track(0.7, 0.4, 4.0, 0.21, 0.0);
    // No fix at all, then one.
    let none: Vec<RunSample> = without_positions(&fixes);
    assert_eq!(analyse_track(&none, &ctx).notes, [TrackNote::NoFixes]);
    assert_eq!(
        analyse_track(&fixes[..1], &ctx).notes,
        [TrackNote::TooFewFixes { fixes: 1 }]
    );
    // Collinear: a straight drive.
    let line: Vec<RunSample> = (0..20)
        .map(|k| RunSample {
            x_m: Some(0.06 * f64::from(k)),
            y_m: Some(1.0 + 0.03 * f64::from(k)),
            ..fixes[0]
        })
        .collect();
    let t = analyse_track(&line, &ctx);
    assert_eq!(
        (t.r_act_m, &t.notes[..]),
        (None, &[TrackNote::Collinear][..])
    );
    // 10° of arc.
    let short = track(0.7, 0.4, 0.4, 0.21, 0.0);
    let t = analyse_track(&short, &ctx);
    assert!(t.r_act_m.is_none());
    assert!(
        matches!(t.notes[..], [TrackNote::TooShortTurn { swept_deg }] if swept_deg < 15.0),
        "{:?}",
        t.notes
    );
    // NaN cells are skipped fixes, noted; the turn still has its radius.
    fixes[5].x_m = Some(f64::NAN);
    fixes[9].y_m = Some(f64::INFINITY);
    let t = analyse_track(&fixes, &ctx);
    assert_eq!(t.notes[0], TrackNote::NonFiniteFixes { count: 2 });
    assert!((t.r_act_m.expect("R_ACT") - 0.7).abs() < 0.01, "{t:?}");
    for note in &t.notes {
        assert!(!note.to_string().is_empty());
    }
}

#[test]
fn slip_track_is_the_median_with_its_spread() {
    assert_eq!(measured_slip_track(&[]), None);
    let m = measured_slip_track(&[1.2, 1.4, 1.3, f64::NAN]).expect("some");
    assert_eq!((m.slip_track_m, m.turns), (1.3, 3));
    assert!((m.spread_m - 0.1).abs() < 1e-12);
    let one = measured_slip_track(&[1.29]).expect("one");
    assert_eq!((one.slip_track_m, one.spread_m), (1.29, 0.0));
}

/// The simulated world's truth recovered through `validate`: each turn's R_ACT within
/// max(2 cm, 3 %) of the world's true radius and each run's measured slip track within 3 % of
/// the Appendix D value of the true radii of its turns commanded at R′ (the terrain's B_s when
/// no angular slip widens the turns), from the 5 Hz prism track 0.21 m right of the centre with 2 mm noise and 5 % lost
/// fixes.
#[test]
fn validate_recovers_the_worlds_radius_and_slip_track() {
    use crate::diagnose_bench::run::sample_run;
    use crate::sim::world::{EffectId, Scenario, WorldConfig};
    use crate::validate::{validate, RunInput, ValidateOptions};

    let worlds = [
        ("sand", WorldConfig::sand(), None),
        (
            "slip-track only",
            WorldConfig::hard_ground().with_effect(EffectId::SlipTrack, true),
            Some(WorldConfig::hard_ground().with_effect(EffectId::SlipTrack, true)),
        ),
    ];
    for (name, world, slip_track_only) in worlds {
        let timeline = world
            .simulate(&Scenario::seed_turns(0.3, 2), 7)
            .expect("simulates");
        let samples = sample_run(&timeline, 200);
        let options = ValidateOptions {
            tracker_offset_m: world.tracker.offset_m,
            ..ValidateOptions::for_rover(&world.rover)
        };
        let report = validate(
            &world.rover,
            &[RunInput::from_samples(name, &samples)],
            &options,
        )
        .expect("validates");
        let mut true_slip_tracks = Vec::new();
        let mut turns = 0;
        for row in report
            .manoeuvres
            .iter()
            .filter(|m| m.kind == ManoeuvreKind::Turn)
        {
            let truth = timeline
                .manoeuvres()
                .iter()
                .find(|t| (t.start_us as f64 * 1e-6 - row.t_start_s).abs() < 0.02)
                .expect("the turn's truth");
            let r_true = truth.true_radius_m.expect("a radius");
            let r_act = row.r_act_m.unwrap_or(f64::NAN);
            let bound = (0.03 * r_true).max(0.02);
            println!(
                "{name}: R_cmd {:.3} R_true {r_true:.3} R_ACT {r_act:.3}",
                row.radius_cmd_m.unwrap_or(0.0)
            );
            assert!(
                (r_act - r_true).abs() <= bound,
                "{name}: {r_act} vs {r_true}: {:?}",
                row.track
            );
            let speeds =
                kinematics::SideSpeeds::new(row.cmd_mps.left as f32, row.cmd_mps.right as f32);
            if row.regime == Some(kinematics::Regime::AtRPrime) {
                true_slip_tracks.extend(
                    kinematics::slip_track_from_measured_radius_m(r_true as f32, speeds)
                        .map(f64::from),
                );
            }
            turns += 1;
        }
        assert_eq!(turns, 12, "{name}: every turn analysed");
        let truth = measured_slip_track(&true_slip_tracks)
            .expect("truth")
            .slip_track_m;
        let run = &report.runs[0];
        let measured = run.slip_track_measured_m.expect("measured slip track");
        println!(
            "{name}: slip track measured {measured:.4} m, truth {truth:.4} m, {:?}",
            run.slip_track_measured
        );
        assert!(
            (measured - truth).abs() <= 0.03 * truth,
            "{name}: {measured} vs {truth}"
        );
        if let Some(w) = slip_track_only {
            let terrain = w.terrain_slip_track_m();
            assert!(
                (measured - terrain).abs() <= 0.03 * terrain,
                "{measured} vs {terrain}"
            );
        }
    }
}

/// Runs without positions validate as before: no pose field in the JSON, the CSV's columns
/// unchanged; with positions, every other figure is the same.
#[test]
fn runs_without_positions_validate_as_before() {
    use crate::diagnose_bench::run::sample_run;
    use crate::sim::world::{Scenario, WorldConfig};
    use crate::validate::report::CSV_COLUMNS;
    use crate::validate::{validate, RunInput, ValidateOptions};

    let world = WorldConfig::sand();
    let timeline = world
        .simulate(&Scenario::seed_turns(0.3, 1), 3)
        .expect("simulates");
    let with = sample_run(&timeline, 100);
    let without: Vec<RunSample> = without_positions(&with);
    let options = ValidateOptions {
        tracker_offset_m: 0.21,
        ..ValidateOptions::for_rover(&world.rover)
    };
    let run = |samples: &[RunSample]| {
        validate(
            &world.rover,
            &[RunInput::from_samples("r", samples)],
            &options,
        )
        .expect("validates")
    };
    let (plain, posed) = (run(&without), run(&with));
    let json = serde_json::to_string(&plain).expect("json");
    for key in [
        "r_act_m",
        "track",
        "slip_track_measured",
        "tracker_offset_m",
    ] {
        assert!(!json.contains(&format!("\"{key}\":")), "{key} in {json}");
    }
    let mut csv = Vec::new();
    plain.write_csv(&mut csv).expect("csv");
    let csv = String::from_utf8(csv).expect("utf8");
    assert_eq!(csv.lines().next(), Some(CSV_COLUMNS.join(",").as_str()));
    assert!(!plain.to_string().contains("pose track"));
    assert_eq!(plain.manoeuvres.len(), posed.manoeuvres.len());
    for (a, b) in plain.manoeuvres.iter().zip(&posed.manoeuvres) {
        assert_eq!(a.stats, b.stats);
        assert_eq!(a.fit, b.fit);
    }
    let json = serde_json::to_string(&posed).expect("json");
    for key in ["r_act_m", "r_act_over_r_prime_act", "slip_track_measured_m"] {
        assert!(json.contains(&format!("\"{key}\"")), "{key}");
    }
    let mut csv = Vec::new();
    posed.write_csv(&mut csv).expect("csv");
    let csv = String::from_utf8(csv).expect("utf8");
    assert!(csv.lines().next().expect("header").ends_with("track_notes"));
    assert!(posed
        .to_string()
        .contains("measured slip track (Appendix D)"));
}
