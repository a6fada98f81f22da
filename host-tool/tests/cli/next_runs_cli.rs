//! `host-tool diagnose --next-runs`: what to drive next, written as a scenario file that
//! `demo --scenario` drives unchanged, on datasets of an independent simulator
//! (`tests/fixtures/foreign/`).

use crate::common;
use common::{host_tool, temp_dir};

use std::path::{Path, PathBuf};
use std::process::Output;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/foreign")
        .join(name)
}

/// `diagnose … --next-runs next --json -` on the fixture `name`.
fn diagnose(name: &str, next: &Path, extra: &[&str]) -> Output {
    let dir = fixture(name);
    host_tool()
        .arg("diagnose")
        .arg("--rover")
        .arg(dir.join("rover.toml"))
        .arg("--calibration")
        .args(["cal_0.csv", "cal_1.csv"].map(|f| dir.join(f)))
        .arg("--runs")
        .args(["run_0.csv", "run_1.csv", "run_2.csv"].map(|f| dir.join(f)))
        .arg("--next-runs")
        .arg(next)
        .args(extra)
        .output()
        .expect("runs")
}

/// control-a's verdict is open (`baseline-misfit`): the suggestions are in the JSON with the
/// issue's keys, and the scenario file is written and driven by `demo --scenario` as it is.
#[test]
fn an_open_verdict_writes_a_scenario_the_demo_drives() {
    let dir = temp_dir("next-runs-open");
    let next = dir.join("next.toml");
    let out = diagnose("control-a", &next, &["--json", "-"]);
    assert!(
        matches!(out.status.code(), Some(0 | 1)),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let d: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(d["effect"], "baseline-misfit");
    let runs = d["next_runs"].as_array().expect("a list");
    assert!(!runs.is_empty(), "{}", d["next_runs"]);
    let in_play: Vec<&str> = d["in_play"]
        .as_array()
        .expect("in play")
        .iter()
        .filter_map(|r| r.as_str())
        .collect();
    for r in runs {
        for key in ["v_c_mps", "turn_deg", "direction", "repeats", "when"] {
            assert!(!r[key].is_null(), "{key}: {r}");
        }
        // A straight: no radius, a length; a turn: both radii.
        let straight = r["r_over_r_prime"].is_null();
        assert_eq!(r["radius_m"].is_null(), straight, "{r}");
        assert_eq!(r["distance_m"].is_null(), !straight, "{r}");
        assert!(r["expected_sigma"].as_f64().expect("σ") >= 3.0, "{r}");
        for rival in r["separates"].as_array().expect("separates") {
            assert!(in_play.contains(&rival.as_str().expect("a label")), "{r}");
        }
    }
    let text = std::fs::read_to_string(&next).expect("the scenario file is written");
    assert!(text.contains("[[manoeuvres]]"), "{text}");

    let demo_out = dir.join("demo");
    let demo = host_tool()
        .arg("demo")
        .arg("--scenario")
        .arg(&next)
        .args(["--runs", "1", "--speed", "1000", "--quiet", "--out"])
        .arg(&demo_out)
        .output()
        .expect("runs");
    let stdout = String::from_utf8_lossy(&demo.stdout);
    assert!(
        demo.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&demo.stderr)
    );
    assert!(demo_out.join("run-1.csv").is_file());
    // Two point turns alone have no calibration to fit the baseline on: said, not an error.
    assert!(stdout.contains("diagnose them together"), "{stdout}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// offset-a: the offset is named by its own mark (the standstill current) beside a baseline it
/// does not repair; no other candidate could be named in its place (their marks are absent, and
/// copper loss is the baseline's structure, not a rival effect): the verdict is settled,
/// nothing to drive, no file, and the table says why.
#[test]
fn nothing_to_drive_writes_no_scenario() {
    let dir = temp_dir("next-runs-nothing");
    let next = dir.join("next.toml");
    let out = diagnose("offset-a", &next, &[]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("what to drive next:"), "{stdout}");
    assert!(
        stdout.contains("the verdict `current-offset` is settled"),
        "{stdout}"
    );
    assert!(stdout.contains("not written"), "{stdout}");
    assert!(!next.exists());
    // An existing file is kept without --force.
    std::fs::write(&next, "mine").expect("file");
    let refused = diagnose("control-a", &next, &[]);
    assert_eq!(refused.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("--force"));
    assert_eq!(std::fs::read_to_string(&next).expect("kept"), "mine");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A path table (thesis Table 6.1) has no manoeuvres to suggest more of: refused, no file.
#[test]
fn a_path_table_refuses_next_runs() {
    let dir = temp_dir("next-runs-path-table");
    let next = dir.join("next.toml");
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = host_tool()
        .arg("diagnose")
        .arg("--rover")
        .arg(root.join("rovers/husky-a200.toml"))
        .arg("--runs")
        .arg(root.join("examples/husky-sand-table-6.1.csv"))
        .arg("--next-runs")
        .arg(&next)
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--next-runs do not apply"));
    assert!(!next.exists());
    let _ = std::fs::remove_dir_all(&dir);
}
