use super::*;

fn husky(a: f64, c: f64, d: f64) -> PlanReport {
    plan_preset(Preset::HuskyHardGround, a, c, d).expect("valid plan")
}

#[test]
fn preset_reproduces_paper_table_3() {
    let r = husky(45.0, 45.0, 10.0);
    assert!((r.clc.energy_j - 965.83).abs() < 0.1, "{r:?}");
    assert!((r.plp.energy_j - 1004.38).abs() < 0.1, "{r:?}");
    assert!((r.clc.r1_m - 0.645).abs() < 1e-3 && (r.clc.r2_m - 0.645).abs() < 1e-3);
    // Table 3 gives θ_B in rad; the report in degrees, as the headings.
    assert!(
        (r.clc.line_heading_deg.to_radians() - -0.0417).abs() < 1e-3,
        "{r:?}"
    );
    assert!((r.clc.first_turn_deg - (45.0 - r.clc.line_heading_deg)).abs() < 1e-9);
    let r = husky(60.0, 30.0, 8.0);
    assert!((r.clc.energy_j - 851.21).abs() < 0.1, "{r:?}");
    assert!((r.plp.energy_j - 880.98).abs() < 0.1, "{r:?}");
    assert!((r.clc.r1_m - 0.645).abs() < 1e-3 && (r.clc.r2_m - 0.645).abs() < 1e-3);
    assert!(
        (r.clc.line_heading_deg.to_radians() - -0.0577).abs() < 1e-3,
        "{r:?}"
    );
    assert_eq!(r.plp.line_heading_deg, 0.0);
    assert_eq!((r.plp.first_turn_deg, r.plp.second_turn_deg), (60.0, 30.0));
    assert!((r.saving_j - (880.98 - 851.21)).abs() < 0.2);
    assert!((r.saving_pct - 100.0 * r.saving_j / r.plp.energy_j).abs() < 1e-12);
}

#[test]
fn preset_is_the_model_core_hard_ground_model() {
    let model = EnergyModel::husky_hard_ground();
    assert_eq!(model.hard_ground(), IcrHardGround::HUSKY_HARD_GROUND);
    let law = model.law().expect("valid");
    let ends = ClcEnds::new(1.0, 0.3, 7.0).expect("valid");
    assert_eq!(
        optimise_clc(&law, &ends),
        optimise_clc(&IcrHardGround::HUSKY_HARD_GROUND, &ends)
    );
}

#[test]
fn durations_at_constant_v_c() {
    let r = husky(45.0, 45.0, 10.0);
    // PLP: two point turns of π/4 at ω = v_c/R' plus 10 m at v_c.
    let rp = 0.645;
    let plp = 2.0 * core::f64::consts::FRAC_PI_4 * rp / 0.3 + 10.0 / 0.3;
    assert!((r.plp.duration_s - plp).abs() < 1e-9, "{r:?}");
    // Hard ground: power × time is the energy, at R' (P = F v_c/R' + 2G v_c) and on lines.
    let law = EnergyModel::husky_hard_ground().law().expect("valid");
    let hg = law.hard_ground();
    let p_turn = hg.skid_moment_nm() * 0.3 / rp + 2.0 * hg.rolling_resistance_n * 0.3;
    let e = law.arc_energy_j(rp, 1.2);
    assert!((e - p_turn * law.arc_duration_s(rp, 1.2)).abs() < 1e-9);
    assert!((law.arc_duration_s(2.0, 1.0) - 2.0 / 0.3).abs() < 1e-12);
}

#[test]
fn negative_headings_mirror() {
    let left = husky(60.0, 30.0, 8.0);
    let right = husky(-60.0, -30.0, 8.0);
    assert!((left.clc.energy_j - right.clc.energy_j).abs() < 1e-9);
    assert!((left.clc.line_heading_deg + right.clc.line_heading_deg).abs() < 1e-12);
}

#[test]
fn bad_inputs_are_errors() {
    let p = |a, c, d| plan_preset(Preset::HuskyHardGround, a, c, d);
    assert!(matches!(
        p(f64::NAN, 45.0, 10.0),
        Err(PlanError::NonFiniteHeading { which: "start", .. })
    ));
    assert!(matches!(
        p(45.0, f64::INFINITY, 10.0),
        Err(PlanError::NonFiniteHeading { which: "end", .. })
    ));
    for d in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            p(45.0, 45.0, d),
            Err(PlanError::InvalidDistance(_))
        ));
    }
    for (a, c) in [(45.0, -45.0), (0.0, 30.0), (95.0, 30.0), (30.0, -91.0)] {
        let e = p(a, c, 5.0).expect_err("outside Eq 50");
        assert!(matches!(e, PlanError::HeadingsOutsideEq50 { .. }), "{e}");
        assert!(e.to_string().contains("Eq 50"), "{e}");
    }
    // ±90° is inside Eq 50 (and the optimum there is the PLP path).
    let r = p(90.0, 90.0, 6.0).expect("valid");
    assert_eq!(r.clc.energy_j, r.plp.energy_j);
    assert_eq!(r.saving_j, 0.0);
    let mut model = EnergyModel::husky_hard_ground();
    model.v_c_mps = 0.0;
    let e = plan(
        &model,
        &ModelSource::File("m.toml".into()),
        45.0,
        45.0,
        10.0,
    )
    .expect_err("v_c = 0");
    assert!(e.to_string().contains("v_c_mps"), "{e}");
}

const PRESET_FILE: &str = "version = 1
v_c_mps = 0.3

[rover]
track_width_m = 0.55
length_m = 0.52
wheel_radius_m = 0.165
mass_kg = 63
slip_track_m = 1.1

[base]
mu = 0.74
rolling_resistance_n = 30.85
slip_track_m = 1.29
";

#[test]
fn model_file_without_effects_is_the_preset() {
    let model = parse_model(PRESET_FILE).expect("valid model file");
    let file = plan(
        &model,
        &ModelSource::File("hg.toml".into()),
        45.0,
        45.0,
        10.0,
    )
    .expect("plan");
    let preset = husky(45.0, 45.0, 10.0);
    assert_eq!(file.clc, preset.clc);
    assert_eq!(file.plp, preset.plp);
    assert_eq!(file.setting.model.as_deref(), Some("hg.toml"));
    assert_eq!(file.setting.preset, None);
    assert_eq!(model.hard_ground(), IcrHardGround::HUSKY_HARD_GROUND);
}

#[test]
fn model_file_round_trip() {
    let preset = EnergyModel::husky_hard_ground();
    let text = preset.to_toml().expect("writes");
    assert!(text.contains("track_width_m = 0.55\n"), "{text}");
    assert_eq!(parse_model(&text).expect("reads back"), preset);
    let mut sand = preset.clone();
    sand.description = None;
    sand.effects = vec![
        EffectTerm {
            name: "dragged inner wheels".into(),
            r_over_r_prime: vec![0.0, 0.5, 1.0, 2.0],
            extra_power_w: vec![0.0, 12.5, 30.0, 0.0],
        },
        EffectTerm {
            name: "sinkage".into(),
            r_over_r_prime: vec![0.0],
            extra_power_w: vec![-1.25],
        },
    ];
    let text = sand.to_toml().expect("writes");
    assert_eq!(parse_model(&text).expect("reads back"), sand, "{text}");
}

#[test]
fn effects_add_power_times_duration() {
    let mut model = EnergyModel::husky_hard_ground();
    model.effects = vec![EffectTerm {
        name: "peak at R'".into(),
        r_over_r_prime: vec![0.0, 1.0, 3.0],
        extra_power_w: vec![10.0, 40.0, 4.0],
    }];
    let law = model.law().expect("valid");
    let hg = IcrHardGround::HUSKY_HARD_GROUND;
    let rp = hg.r_prime_m();
    // Interpolation, clamping, and the end value on straight lines.
    let term = &model.effects[0];
    assert_eq!(term.extra_power_w(0.5), 25.0);
    assert_eq!(term.extra_power_w(2.0), 22.0);
    assert_eq!(term.extra_power_w(10.0), 4.0);
    assert_eq!(term.extra_power_w(f64::INFINITY), 4.0);
    // Point turn of 1 rad: 10 W for R'/v_c seconds.
    let e0 = law.arc_energy_j(0.0, 1.0) - hg.arc_energy_j(0.0, 1.0);
    assert!((e0 - 10.0 * rp / 0.3).abs() < 1e-9);
    // An arc at 2R' through 0.5 rad: 22 W for 2R'·0.5/v_c seconds.
    let e2 = law.arc_energy_j(2.0 * rp, 0.5) - hg.arc_energy_j(2.0 * rp, 0.5);
    assert!((e2 - 22.0 * rp / 0.3).abs() < 1e-9);
    assert!((law.line_energy_j_per_m() - (2.0 * 30.85 + 4.0 / 0.3)).abs() < 1e-12);
    assert!(law.arc_energy_j(-1.0, 1.0).is_nan());
    // A costly R' pushes the optimum off R' (to a point turn or a wider arc).
    let r = plan(
        &model,
        &ModelSource::File("m.toml".into()),
        45.0,
        45.0,
        10.0,
    )
    .expect("plan");
    assert!((r.clc.r1_m - rp).abs() > 1e-3, "{r:?}");
    assert!(r.clc.energy_j <= r.plp.energy_j);
}

#[test]
fn bad_model_files_are_clear_errors() {
    let with = |from: &str, to: &str| PRESET_FILE.replace(from, to);
    let cases = [
            (with("version = 1", "version = 2"), "version 2"),
            (with("v_c_mps = 0.3", "v_c_mps = -0.3"), "v_c_mps"),
            (with("mu = 0.74", "mu = -0.1"), "base.mu"),
            (with("slip_track_m = 1.29", "slip_track_m = 0"), "base.slip_track_m"),
            (with("mu = 0.74", "mu = 0.74\nnu = 1"), "nu"),
            (with("mu = 0.74\n", ""), "mu"),
            (with("length_m = 0.52", "lenght_m = 0.52"), "lenght_m"),
            (with("mass_kg = 63", "mass_kg = -63"), "mass_kg"),
            (
                format!("{PRESET_FILE}\n[[effects]]\nname = \"x\"\nr_over_r_prime = [0.0, 1.0]\nextra_power_w = [1.0]\n"),
                "2 values",
            ),
            (
                format!("{PRESET_FILE}\n[[effects]]\nname = \"x\"\nr_over_r_prime = [1.0, 1.0]\nextra_power_w = [1.0, 2.0]\n"),
                "increase",
            ),
            (
                format!("{PRESET_FILE}\n[[effects]]\nname = \"x\"\nr_over_r_prime = [-1.0]\nextra_power_w = [1.0]\n"),
                ">= 0",
            ),
            (
                format!("{PRESET_FILE}\n[[effects]]\nname = \"x\"\nr_over_r_prime = []\nextra_power_w = []\n"),
                "no breakpoints",
            ),
            (
                format!("{PRESET_FILE}\n[[effects]]\nname = \"x\"\nr_over_r_prime = [0.0]\nextra_power_w = [1e308]\n"),
                "beyond the rover's measurable power",
            ),
            ("not toml at all".into(), "line 1"),
        ];
    for (text, needle) in cases {
        let e = parse_model(&text).expect_err(&text).to_string();
        assert!(e.contains(needle), "{needle:?} not in {e:?}\n{text}");
    }
}

/// The `[rover]` table is checked as a rover file, but its own text is not the model's: the
/// error's line is the model file's (the table's), never one counted in the table alone.
#[test]
fn a_rover_type_error_in_a_model_names_the_models_line() {
    let text = PRESET_FILE.replace("wheel_radius_m = 0.165", "wheel_radius_m = [0.165]");
    let e = parse_model(&text).expect_err("array").to_string();
    assert!(
        e.starts_with(
            "line 4, column 1: rover: `wheel_radius_m` must be a number, found an array ([0.165])"
        ),
        "{e}"
    );
}

#[test]
fn missing_model_file_names_the_path() {
    let e = load_model(Path::new("/nonexistent/model.toml")).expect_err("missing");
    assert!(e.to_string().contains("/nonexistent/model.toml"), "{e}");
}

#[test]
fn table_shows_the_numbers() {
    let text = husky(45.0, 45.0, 10.0).to_string();
    for needle in [
        "CLC",
        "PLP",
        "965.8",
        "1004.38",
        "0.645",
        // Table 3's θ_B = −0.0417 rad, in degrees as the headings.
        "-2.39",
        "saves 38.5",
    ] {
        assert!(text.contains(needle), "{needle:?} not in\n{text}");
    }
}
