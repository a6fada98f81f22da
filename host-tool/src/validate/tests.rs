//! End-to-end tests of `validate` on synthetic runs generated from the seed's models.

use super::*;
use model_core::kinematics::SideSpeeds;
use model_core::rng::{box_muller, XorShift64Star};
use model_core::Sides;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

const HUSKY: Rover = Rover::HUSKY_A200;
const HG: IcrHardGround = IcrHardGround::HUSKY_HARD_GROUND;
const DT_S: f64 = 0.02;
const V_C: f64 = 0.3;

/// A standard normal draw from the run's xorshift64* (Box–Muller; a 0 draw is lifted to 1e-300,
/// where the logarithm is finite).
fn normal(rng: &mut XorShift64Star) -> f64 {
    let u1 = rng.uniform().max(1e-300);
    let u2 = rng.uniform();
    box_muller(u1, u2)
}

/// One commanded manoeuvre of a synthetic run.
#[derive(Debug, Clone, Copy)]
struct Manoeuvre {
    /// Commanded radius [m] (`INFINITY` for straight).
    radius_m: f64,
    direction: TurnDirection,
    pitch_deg: Option<f64>,
    /// Angular slip applied to the yaw (`None`: no yaw column).
    slip: Option<f64>,
}

/// The seed's turn set (Sections 4.3–4.4): 0, R'/3, 2R'/3, R', 4R'/3, 2R' and straight.
fn seed_radii() -> [f64; 7] {
    let rp = f64::from(HUSKY.r_prime_m());
    [
        0.0,
        rp / 3.0,
        2.0 * rp / 3.0,
        rp,
        4.0 * rp / 3.0,
        2.0 * rp,
        f64::INFINITY,
    ]
}

/// A run: each manoeuvre preceded by 1.5 s of standstill, turns lasting until 90° of heading
/// change at the actual yaw rate (a turn without yaw lasts 90° at the commanded rate),
/// straight lines 5 s. `power` gives the true power per side for the commanded side speeds and
/// the manoeuvre; per-sample noise of `noise_w` per side goes into the current.
fn synth_run(
    manoeuvres: &[Manoeuvre],
    seed: u64,
    noise_w: f64,
    power: impl Fn(SideSpeeds, &Manoeuvre) -> Sides<f64>,
) -> Vec<RunSample> {
    let rp = HUSKY.r_prime_m();
    let mut rng = XorShift64Star::new(seed.max(1));
    let mut out = Vec::new();
    let mut t = 0.0;
    let mut yaw = 0.5_f64;
    let mut push = |t: f64,
                    cmd: SideSpeeds,
                    p: Sides<f64>,
                    yaw: f64,
                    m: Option<&Manoeuvre>,
                    rng: &mut XorShift64Star| {
        let bus = Sides::new(24.0 + 0.05 * normal(rng), 24.0 + 0.05 * normal(rng));
        let p = Sides::new(
            p.left + noise_w * normal(rng),
            p.right + noise_w * normal(rng),
        );
        let wrapped = yaw - TAU * ((yaw + PI) / TAU).floor();
        out.push(RunSample {
            t_s: t,
            bus_v: bus,
            current_a: Sides::new(p.left / bus.left, p.right / bus.right),
            cmd_mps: Sides::new(f64::from(cmd.left_mps), f64::from(cmd.right_mps)),
            yaw_rad: m.map_or(Some(wrapped), |m| m.slip.map(|_| wrapped)),
            pitch_deg: m.and_then(|m| m.pitch_deg),
            x_m: None,
            y_m: None,
        });
    };
    for m in manoeuvres {
        for _ in 0..75 {
            push(
                t,
                SideSpeeds::new(0.0, 0.0),
                Sides::new(1.0, 1.0),
                yaw,
                None,
                &mut rng,
            );
            t += DT_S;
        }
        let cmd = side_speeds_for(V_C as f32, m.radius_m as f32, rp, m.direction);
        let w_cmd = f64::from(kinematics::body_velocity(cmd, HUSKY.slip_track_m).yaw_rate_rad_s);
        let w_act = w_cmd * (1.0 - m.slip.unwrap_or(0.0));
        let duration = if m.radius_m.is_infinite() {
            5.0
        } else {
            FRAC_PI_2 / w_act.abs()
        };
        let n = (duration / DT_S).round() as usize + 1;
        let p = power(cmd, m);
        for _ in 0..n {
            push(t, cmd, p, yaw, Some(m), &mut rng);
            t += DT_S;
            yaw += w_act * DT_S;
        }
        yaw -= w_act * DT_S;
    }
    out
}

/// Paper Eq 21 split into sides: G|V_i| each, plus half the skid moment's power each.
fn hard_ground(cmd: SideSpeeds, _: &Manoeuvre) -> Sides<f64> {
    let (vl, vr) = (f64::from(cmd.left_mps), f64::from(cmd.right_mps));
    let skid = HG.skid_moment_nm() * ((vr - vl) / HG.slip_track_m).abs() / 2.0;
    let p = Sides::new(
        HG.rolling_resistance_n * vl.abs() + skid,
        HG.rolling_resistance_n * vr.abs() + skid,
    );
    debug_assert!((p.left + p.right - HG.power_w(vl, vr)).abs() < 1e-9);
    p
}

fn seed_turn_set(pitch_deg: Option<f64>, slip: impl Fn(f64) -> Option<f64>) -> Vec<Manoeuvre> {
    let mut set = Vec::new();
    for direction in [TurnDirection::Left, TurnDirection::Right] {
        for r in seed_radii() {
            set.push(Manoeuvre {
                radius_m: r,
                direction,
                pitch_deg,
                slip: slip(r),
            });
        }
    }
    set
}

fn report_of(runs: &[(String, Vec<RunSample>)]) -> ValidationReport {
    let inputs: Vec<RunInput<'_>> = runs
        .iter()
        .map(|(n, s)| RunInput::from_samples(n, s))
        .collect();
    validate(&HUSKY, &inputs, &ValidateOptions::for_rover(&HUSKY)).expect("validates")
}

/// c₁ and c₂ of the hard-ground model under the controller's slip track: for R ≥ R' the
/// commanded speeds give ω = 2 v_c R'/(R B_s,terrain), so P = F v_c (B_s/B_s,terrain)/R + 2 G v_c.
fn hard_ground_c1_c2() -> (f64, f64) {
    let bs = f64::from(HUSKY.slip_track_m);
    (
        HG.skid_moment_nm() * V_C * bs / HG.slip_track_m,
        2.0 * HG.rolling_resistance_n * V_C,
    )
}

#[test]
fn hard_ground_runs_recover_c1_c2_without_departures() {
    let runs: Vec<(String, Vec<RunSample>)> = (0..2)
        .map(|k| {
            (
                format!("hg-{k}.csv"),
                synth_run(&seed_turn_set(None, |_| None), 11 + k, 3.0, hard_ground),
            )
        })
        .collect();
    let report = report_of(&runs);
    println!("{report}");
    // 7 manoeuvres × 2 directions × 2 runs, all analysed.
    assert_eq!(report.manoeuvres.len(), 28);
    let fit = report.fit.as_ref().expect("fitted");
    let (c1, c2) = hard_ground_c1_c2();
    assert!(fit.c1_w_m.contains(c1), "c1 {c1} vs {:?}", fit.c1_w_m);
    assert!(fit.c2_w.contains(c2), "c2 {c2} vs {:?}", fit.c2_w);
    // Paper Table 2: c₂ = 2 G v_c = 18.51 W at v_c = 0.3 m/s.
    assert!((c2 - 18.51).abs() < 1e-9);
    assert!(fit.r_squared.expect("varies") > 0.99, "{fit:?}");
    assert!(fit.c3_w_per_deg.is_none());
    assert!(fit.c3_note.as_deref().is_some_and(|n| n.contains("pitch")));
    // R', 4R'/3, 2R' in both directions in both runs, and the four straight lines.
    assert_eq!(fit.n, 16);
    assert_eq!(report.flagged().count(), 0, "{report}");
    // The fitted plateau and straight line predict the turns outside the fit too, and the
    // hard-ground reference matches every manoeuvre.
    for m in &report.manoeuvres {
        let c = m.fit.expect("fit");
        assert!(c.residual_fraction.expect("nonzero").abs() < 0.02, "{m:?}");
        assert!(
            m.hard_ground_residual_fraction.expect("husky").abs() < 0.02,
            "{m:?}"
        );
    }
    assert!(report.regimes.iter().all(|g| g.flagged == 0));
    assert_eq!(report.regimes.len(), 6);
    // No yaw: 90° assumed; the measured duration is the expected one (the synthetic turn lasts
    // 90° at the commanded rate).
    for m in report
        .manoeuvres
        .iter()
        .filter(|m| m.kind == ManoeuvreKind::Turn)
    {
        let s = &m.stats;
        assert_eq!(s.turned_deg, Some(90.0));
        assert!(
            (s.duration_s - s.expected_duration_s.expect("turn")).abs() < DT_S,
            "{s:?}"
        );
        assert_eq!(s.angular_slip, None);
    }
    // Runs are independent: each has its own manoeuvres, none spans two files.
    assert_eq!(report.runs.len(), 2);
    assert!(report
        .runs
        .iter()
        .all(|r| r.analysed == 14 && r.cross_check.is_none()));
}

#[test]
fn a_power_bump_in_the_dragged_inner_range_is_flagged_exactly_there() {
    let half_track = f64::from(HUSKY.half_track_m());
    let rp = f64::from(HUSKY.r_prime_m());
    // +30 % where B/2 < R < R' (the seed's sand peak, Fig. 4.9).
    let bumped = |cmd: SideSpeeds, m: &Manoeuvre| {
        let p = hard_ground(cmd, m);
        let k = if m.radius_m > half_track && m.radius_m < rp {
            1.3
        } else {
            1.0
        };
        p.map(|v| v * k)
    };
    let runs: Vec<(String, Vec<RunSample>)> = (0..2)
        .map(|k| {
            (
                format!("bump-{k}.csv"),
                synth_run(&seed_turn_set(None, |_| None), 21 + k, 3.0, bumped),
            )
        })
        .collect();
    let report = report_of(&runs);
    println!("{report}");
    let flagged: Vec<Option<Regime>> = report.flagged().map(|m| m.regime).collect();
    assert_eq!(flagged, vec![Some(Regime::DraggedInner); 4], "{report}");
    let dragged = report
        .regimes
        .iter()
        .find(|g| g.regime == Some(Regime::DraggedInner))
        .expect("present");
    assert_eq!((dragged.manoeuvres, dragged.flagged), (4, 4));
    assert!(
        (dragged.mean_residual_fraction.expect("fit") - 0.3).abs() < 0.02,
        "{dragged:?}"
    );
    assert!((dragged.mean_hard_ground_residual_fraction.expect("hg") - 0.3).abs() < 0.02);
    assert!(report
        .regimes
        .iter()
        .filter(|g| g.regime != Some(Regime::DraggedInner))
        .all(|g| g.flagged == 0));
    let text = report.to_string();
    assert!(
        text.contains("DEP") && text.contains("dragged-inner"),
        "{text}"
    );
    // The plot data carry the flag and the model curve.
    assert_eq!(report.plot.points.iter().filter(|p| p.flagged).count(), 4);
    assert_eq!(report.plot.points.len(), 24, "straight lines have no R/R'");
    assert!(report
        .plot
        .model_curve
        .iter()
        .all(|c| c.fit_w.is_some() && c.hard_ground_w.is_some()));
}

#[test]
fn angular_slip_and_time_to_turn_from_yaw() {
    let rp = f64::from(HUSKY.r_prime_m());
    // Slip peaking at R' (Fig. 6.8): 10 % elsewhere, 40 % at R'.
    let slip = |r: f64| Some(if (r - rp).abs() < 1e-9 { 0.4 } else { 0.1 });
    let runs = vec![(
        "yaw.csv".to_owned(),
        synth_run(&seed_turn_set(None, slip), 5, 3.0, hard_ground),
    )];
    let report = report_of(&runs);
    assert!(report.runs[0].has_yaw);
    for m in report
        .manoeuvres
        .iter()
        .filter(|m| m.kind == ManoeuvreKind::Turn)
    {
        let s = &m.stats;
        let want = slip(m.radius_cmd_m.expect("turn")).expect("slip");
        let got = s.angular_slip.expect("yaw");
        assert!((got - want).abs() < 0.01, "{m:?}");
        // The turn ended after 90° of actual heading change.
        assert!(s.turned_from_yaw);
        assert!((s.turned_deg.expect("turn") - 90.0).abs() < 0.5, "{s:?}");
        // Duration / expected = ω_cmd / ω_act = 1 / (1 − s_ω).
        let ratio = s.duration_s / s.expected_duration_s.expect("turn");
        assert!((ratio - 1.0 / (1.0 - want)).abs() < 0.02, "{ratio}");
        let sign = match m.direction.expect("turn") {
            TurnDirection::Left => 1.0,
            TurnDirection::Right => -1.0,
        };
        assert!(s.yaw_rate_act_rad_s.expect("yaw") * sign > 0.0);
    }
    // Straight lines have no angular slip.
    assert!(report
        .manoeuvres
        .iter()
        .filter(|m| m.kind == ManoeuvreKind::Straight)
        .all(|m| m.stats.angular_slip.is_none() && m.stats.expected_duration_s.is_none()));
}

#[test]
fn table_4_3_coefficients_with_pitch_are_reproduced() {
    // The seed publishes Table 4.3 (c1 = 5.55 W·m [5.269, 5.831], c2 = 139.4 W [138.1, 140.7],
    // c3 = 6.608 W/deg [6.418, 6.799]) but no per-turn averages: turns generated from its
    // equation on slopes of −10…10° must give back its coefficients.
    let (c1, c2, c3) = (5.55, 139.4, 6.608);
    let rp = f64::from(HUSKY.r_prime_m());
    let mut set = Vec::new();
    for (k, r) in [rp, 1.5 * rp, 2.0 * rp, 3.0 * rp, 5.0 * rp, 10.0]
        .into_iter()
        .enumerate()
    {
        for (j, pitch) in [-10.0, -4.0, 2.0, 7.0].into_iter().enumerate() {
            set.push(Manoeuvre {
                radius_m: r,
                direction: if (k + j) % 2 == 0 {
                    TurnDirection::Left
                } else {
                    TurnDirection::Right
                },
                pitch_deg: Some(pitch),
                slip: None,
            });
        }
    }
    let table_4_3 = |_: SideSpeeds, m: &Manoeuvre| {
        let p = c1 / m.radius_m + c2 + c3 * m.pitch_deg.unwrap_or(0.0);
        Sides::new(p / 2.0, p / 2.0)
    };
    let runs = vec![(
        "white-sands.csv".to_owned(),
        synth_run(&set, 2019, 4.0, table_4_3),
    )];
    let report = report_of(&runs);
    let fit = report.fit.as_ref().expect("fitted");
    println!("{fit:?}");
    let c3_fit = fit.c3_w_per_deg.expect("pitch varies");
    assert!(fit.c1_w_m.contains(c1), "{:?}", fit.c1_w_m);
    assert!(fit.c2_w.contains(c2), "{:?}", fit.c2_w);
    assert!(c3_fit.contains(c3), "{c3_fit:?}");
    // And within the seed's own published bounds.
    assert!(
        (5.269..=5.831).contains(&fit.c1_w_m.value),
        "{:?}",
        fit.c1_w_m
    );
    assert!((138.1..=140.7).contains(&fit.c2_w.value));
    assert!((6.418..=6.799).contains(&c3_fit.value));
    assert_eq!(fit.n, 24);
    assert_eq!(report.flagged().count(), 0);
}

#[test]
fn no_fit_without_turns_at_or_above_r_prime_but_still_a_report() {
    let set: Vec<Manoeuvre> = [0.0, 0.1, f64::INFINITY]
        .into_iter()
        .map(|r| Manoeuvre {
            radius_m: r,
            direction: TurnDirection::Left,
            pitch_deg: None,
            slip: None,
        })
        .collect();
    let runs = vec![("point.csv".to_owned(), synth_run(&set, 3, 3.0, hard_ground))];
    let report = report_of(&runs);
    assert!(report.fit.is_none());
    assert!(
        report
            .fit_error
            .as_deref()
            .is_some_and(|e| e.contains("1 manoeuvres")),
        "{:?}",
        report.fit_error
    );
    assert!(report
        .manoeuvres
        .iter()
        .all(|m| m.fit.is_none() && !m.in_fit));
    assert!(report.to_string().contains("ICR fit: not possible"));
}

#[test]
fn json_and_csv_exports_hold_the_table() {
    let runs = vec![(
        "a,b.csv".to_owned(),
        synth_run(&seed_turn_set(Some(1.0), |_| None), 8, 3.0, hard_ground),
    )];
    let report = report_of(&runs);
    let json = serde_json::to_value(&report).expect("serialises");
    let rows = json["manoeuvres"].as_array().expect("array");
    assert_eq!(rows.len(), 14);
    assert_eq!(rows[0]["regime"], "point");
    assert_eq!(rows[0]["direction"], "left");
    assert_eq!(rows[0]["kind"], "turn");
    assert!(rows[0]["avg_power_w"]["total"]
        .as_f64()
        .is_some_and(|p| p > 0.0));
    assert_eq!(rows[6]["regime"], "straight");
    assert!(rows[6]["radius_cmd_m"].is_null());
    assert!(json["fit"]["c1_w_m"]["lower"].as_f64().is_some());
    assert!(json["plot"]["model_curve"]
        .as_array()
        .is_some_and(|c| c.len() == CURVE_POINTS));
    assert!(json["runs"][0]["cross_check"].is_null());
    // Growth through the turn in one unit (W), as diagnose reports it.
    let phases = &rows[0]["phases"];
    assert_eq!(
        phases["growth_w"].as_f64(),
        Some(
            phases["second_half_w"]["total"].as_f64().expect("W")
                - phases["first_half_w"]["total"].as_f64().expect("W")
        ),
        "{phases}"
    );
    assert!(phases.get("growth_fraction").is_none(), "{phases}");
    assert!(report.to_string().contains("grow[W]"));

    let mut csv = Vec::new();
    report.write_csv(&mut csv).expect("vec");
    let text = String::from_utf8(csv).expect("utf-8");
    // No f32 noise: v_c and the commanded yaw rate come from f32 kinematics (issue 11).
    assert!(!text.contains("0.30000001192092896"), "{text}");
    assert!(text.contains(",0.3,0.3,0,0,point,"), "{text}");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 15);
    assert!(lines[0].contains(",growth_w,") && !lines[0].contains("fraction,gaps"));
    assert_eq!(lines[0].split(',').count(), report::CSV_COLUMNS.len());
    // The run name with a comma is quoted; every row has every column.
    assert!(
        lines[1].starts_with("\"a,b.csv\",1,turn,left,"),
        "{}",
        lines[1]
    );
    for line in &lines[1..] {
        let unquoted = line.replacen("\"a,b.csv\"", "x", 1);
        assert_eq!(
            unquoted.split(',').count(),
            report::CSV_COLUMNS.len(),
            "{line}"
        );
    }
    assert!(report.to_string().contains("no frames"));
}

#[test]
fn malformed_input_is_a_clear_error() {
    let opts = ValidateOptions::for_rover(&HUSKY);
    assert!(matches!(
        validate(&HUSKY, &[], &opts),
        Err(ValidateError::NoRuns)
    ));
    let e =
        validate(&HUSKY, &[RunInput::from_samples("empty.csv", &[])], &opts).expect_err("empty");
    assert_eq!(e.to_string(), "run empty.csv: the run has no samples");
    let one = [RunSample {
        t_s: 0.0,
        bus_v: Sides::new(24.0, 24.0),
        current_a: Sides::new(0.0, 0.0),
        cmd_mps: Sides::new(0.3, 0.3),
        yaw_rad: None,
        pitch_deg: None,
        x_m: None,
        y_m: None,
    }];
    let e = validate(&HUSKY, &[RunInput::from_samples("one.csv", &one)], &opts).expect_err("one");
    assert!(e.to_string().contains("single sample"), "{e}");
    let still: Vec<RunSample> = (0..500)
        .map(|k| RunSample {
            t_s: k as f64 * 0.01,
            cmd_mps: Sides::new(0.0, 0.0),
            ..one[0]
        })
        .collect();
    let e = validate(
        &HUSKY,
        &[RunInput::from_samples("still.csv", &still)],
        &opts,
    )
    .expect_err("standstill");
    assert!(
        matches!(e, ValidateError::NoManoeuvres { standstill: 1, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("1 standstill"), "{e}");
    let bad = ValidateOptions {
        turn_deg: -90.0,
        ..opts
    };
    assert!(matches!(
        validate(&HUSKY, &[RunInput::from_samples("still.csv", &still)], &bad),
        Err(ValidateError::InvalidOption {
            name: "turn_deg",
            ..
        })
    ));
    // Other rovers get no hard-ground reference by default.
    assert!(ValidateOptions::for_rover(&HUSKY.with_slip_track(1.3))
        .hard_ground
        .is_none());
}

#[test]
fn runs_from_logs_carry_their_cross_check() {
    use crate::log::run_log::RunLog;
    use model_core::wire::{BoardFrame, Hello};
    let samples = synth_run(&seed_turn_set(None, |_| None)[..4], 1, 3.0, hard_ground);
    let hello = BoardFrame::Hello(Hello {
        protocol: model_core::wire::PROTOCOL_VERSION,
        firmware: model_core::wire::FirmwareVersion {
            major: 0,
            minor: 1,
            patch: 0,
        },
        scale: model_core::ina226::Scale::BOARD,
        power_lsb_uw: model_core::ina226::Scale::BOARD.power_lsb_uw(),
        shunt_lsb_nv: model_core::ina226::SHUNT_LSB_NV,
        bus_lsb_uv: model_core::ina226::BUS_LSB_UV,
        addresses: Sides::new(0x40, 0x45),
        adc: model_core::ina226::AdcConfig::BOARD_DEFAULT,
        sample_period_us: 5_000,
        identity: model_core::board_id::BoardIdentity::UNKNOWN,
        chips: Sides::new(
            model_core::wire::ChipProbe::NotRead,
            model_core::wire::ChipProbe::NotRead,
        ),
    });
    let log = RunLog {
        samples,
        frames: vec![(0.0, hello)],
        ..RunLog::default()
    };
    let report = validate(
        &HUSKY,
        &[RunInput::from_log("log.mcap", &log)],
        &ValidateOptions::for_rover(&HUSKY),
    )
    .expect("validates");
    let c = report.runs[0].cross_check.as_ref().expect("frames");
    assert_eq!((c.frames, c.model_frames), (1, 0));
}
