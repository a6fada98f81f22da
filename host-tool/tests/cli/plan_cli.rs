//! `host-tool plan` from the command line: the preset's table and JSON (paper Table 3), a model
//! file equal to the preset, clear errors.

use crate::common;
use common::temp_dir;

use std::process::Output;

fn plan(args: &[&str]) -> Output {
    common::host_tool()
        .arg("plan")
        .args(args)
        .output()
        .expect("runs")
}

fn json_of(args: &[&str]) -> serde_json::Value {
    let out = plan(&[args, &["--json", "-"]].concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("stdout is only the JSON")
}

fn number(v: &serde_json::Value, path: &str) -> f64 {
    v.pointer(path)
        .and_then(serde_json::Value::as_f64)
        .unwrap_or_else(|| panic!("{path} missing in {v}"))
}

#[test]
fn preset_json_has_table_3() {
    let v = json_of(&["--start-deg", "45", "--end-deg", "45", "--distance-m", "10"]);
    assert!((number(&v, "/clc/energy_j") - 965.83).abs() < 0.1, "{v}");
    assert!((number(&v, "/plp/energy_j") - 1004.38).abs() < 0.1, "{v}");
    assert!((number(&v, "/clc/r1_m") - 0.645).abs() < 1e-3, "{v}");
    assert!((number(&v, "/clc/r2_m") - 0.645).abs() < 1e-3, "{v}");
    assert!(
        (number(&v, "/clc/line_heading_deg").to_radians() + 0.0417).abs() < 1e-3,
        "{v}"
    );
    assert_eq!(v["preset"], "husky-hard-ground");
    assert!(v["model"].is_null());
    assert_eq!(number(&v, "/v_c_mps"), 0.3);
    assert_eq!(number(&v, "/distance_m"), 10.0);
    for key in [
        "/start_deg",
        "/end_deg",
        "/saving_j",
        "/saving_pct",
        "/r_prime_m",
    ] {
        number(&v, key);
    }
}

#[test]
fn table_and_json_file() {
    let dir = temp_dir("plan-cli-table");
    let json = dir.join("plan.json");
    let out = plan(&[
        "--start-deg",
        "-60",
        "--end-deg",
        "-30",
        "--distance-m",
        "8",
        "--json",
        json.to_str().expect("utf-8 path"),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // θ_B in degrees as the headings: 0.0577 rad of Table 3 is 3.30°.
    for needle in [
        "CLC",
        "PLP",
        "851.2",
        "880.98",
        "θ_B °",
        " 3.30 ",
        "saves 29.78 J",
    ] {
        assert!(stdout.contains(needle), "{needle:?} not in\n{stdout}");
    }
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("json written")).expect("json");
    assert!((number(&v, "/clc/energy_j") - 851.21).abs() < 0.1, "{v}");
    assert!((number(&v, "/plp/energy_j") - 880.98).abs() < 0.1, "{v}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn model_file_without_effects_matches_the_preset() {
    let dir = temp_dir("plan-cli-model");
    let model = dir.join("hard-ground.toml");
    std::fs::write(
        &model,
        "version = 1\nv_c_mps = 0.3\n\n[rover]\ntrack_width_m = 0.55\nlength_m = 0.52\n\
         wheel_radius_m = 0.165\nmass_kg = 63.0\nslip_track_m = 1.1\n\n[base]\nmu = 0.74\n\
         rolling_resistance_n = 30.85\nslip_track_m = 1.29\n",
    )
    .expect("write model");
    let args = ["--start-deg", "60", "--end-deg", "30", "--distance-m", "8"];
    let path = model.to_str().expect("utf-8 path");
    let file = json_of(&[&args[..], &["--model", path]].concat());
    let preset = json_of(&args);
    assert_eq!(file["clc"], preset["clc"]);
    assert_eq!(file["plp"], preset["plp"]);
    assert_eq!(file["model"], path);
    assert!(file["preset"].is_null());
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn bad_input_is_a_clear_error() {
    let cases: [(&[&str], &str); 5] = [
        (
            &["--start-deg", "45", "--end-deg", "-45", "--distance-m", "8"],
            "Eq 50",
        ),
        (
            &["--start-deg", "45", "--end-deg", "45", "--distance-m", "0"],
            "--distance-m must be finite and > 0",
        ),
        (
            &["--start-deg", "NaN", "--end-deg", "45", "--distance-m", "3"],
            "--start-deg must be a finite angle",
        ),
        (
            &[
                "--start-deg",
                "45",
                "--end-deg",
                "45",
                "--distance-m",
                "3",
                "--model",
                "/nonexistent/model.toml",
            ],
            "/nonexistent/model.toml",
        ),
        (
            &[
                "--start-deg",
                "45",
                "--end-deg",
                "45",
                "--distance-m",
                "3",
                "--preset",
                "husky-sand",
            ],
            "husky-hard-ground",
        ),
    ];
    for (args, needle) in cases {
        let out = plan(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(stderr.contains(needle), "{needle:?} not in {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(out.stdout.is_empty(), "{args:?}");
    }
}

/// Issue 18's check: the hard-ground sweep's minimum is at R' with Table 3's CLC energy, and
/// `--figure` writes thesis Fig. 6.3.
#[test]
fn sweep_of_the_preset_has_its_minimum_at_r_prime() {
    let args = [
        "--sweep",
        "--preset",
        "husky-hard-ground",
        "--start-deg",
        "45",
        "--end-deg",
        "45",
        "--distance-m",
        "10",
    ];
    let v = json_of(&args);
    assert!(
        (number(&v, "/optimum/r_over_r_prime") - 1.0).abs() < 1e-6,
        "{v}"
    );
    assert!(
        (number(&v, "/optimum/clc_energy_j") - 965.83).abs() < 0.1,
        "{v}"
    );
    assert!((number(&v, "/plp_energy_j") - 1004.38).abs() < 0.1, "{v}");
    assert_eq!(v["points"].as_array().map(Vec::len), Some(61));
    assert_eq!(number(&v, "/slices/1/thesis_delta_e_pct"), 14.38);
    let dir = temp_dir("sweep-figure");
    let figure = dir.join("fig-6.3.svg");
    let out = plan(&[&args[..], &["--figure", figure.to_str().expect("utf-8")]].concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("optimum R = 1.000 R'"), "{text}");
    assert!(std::fs::metadata(&figure).expect("figure").len() > 1000);
    let out = plan(&[
        "--sweep-max",
        "2",
        "--start-deg",
        "45",
        "--end-deg",
        "45",
        "--distance-m",
        "10",
    ]);
    assert!(!out.status.success(), "--sweep-max needs --sweep");
}
