//! `host-tool validate` from the command line: run CSVs in, table out, JSON and CSV exports,
//! clear errors.

use crate::common;
use common::{host_tool, rover_toml, temp_dir};

use host_tool::log::run_csv::{write_run_csv_atomically, RunSample};
use model_core::kinematics::{side_speeds_for, TurnDirection};
use model_core::power::IcrHardGround;
use model_core::{Rover, Sides};
use std::path::Path;

/// Turns at R', 4R'/3 and 2R' (both directions) drawing the hard-ground model's power, each
/// after 1.5 s of standstill; or only standstill.
fn write_run(path: &Path, standstill_only: bool) {
    let hg = IcrHardGround::HUSKY_HARD_GROUND;
    let rp = Rover::HUSKY_A200.r_prime_m();
    let mut samples = Vec::new();
    let mut t = 0.0;
    for direction in [TurnDirection::Left, TurnDirection::Right] {
        for k in [3.0, 4.0, 6.0] {
            let cmd = side_speeds_for(0.3, k * rp / 3.0, rp, direction);
            let (vl, vr) = (f64::from(cmd.left_mps), f64::from(cmd.right_mps));
            for (n, (vl, vr)) in [(75, (0.0, 0.0)), (200, (vl, vr))] {
                let (vl, vr) = if standstill_only {
                    (0.0, 0.0)
                } else {
                    (vl, vr)
                };
                let p = hg.power_w(vl, vr) / 2.0 + 1.0;
                for i in 0..n {
                    // Deterministic ±0.5 W ripple.
                    let ripple = if i % 2 == 0 { 0.5 } else { -0.5 };
                    samples.push(RunSample {
                        t_s: t,
                        bus_v: Sides::new(24.0, 24.0),
                        current_a: Sides::new((p + ripple) / 24.0, (p - ripple) / 24.0),
                        cmd_mps: Sides::new(vl, vr),
                        yaw_rad: None,
                        pitch_deg: None,
                        x_m: None,
                        y_m: None,
                    });
                    t += 0.02;
                }
            }
        }
    }
    write_run_csv_atomically(path, host_tool::log::Existing::Replace, &samples).expect("write run");
}

#[test]
fn validate_prints_the_table_and_writes_json_and_csv() {
    let dir = temp_dir("validate-cli-ok");
    let run = dir.join("run.csv");
    write_run(&run, false);
    let (json, csv) = (dir.join("report.json"), dir.join("turns.csv"));
    let out = host_tool()
        .args(["validate", "--rover"])
        .arg(rover_toml())
        .arg("--runs")
        .arg(&run)
        .arg("--json")
        .arg(&json)
        .arg("--csv")
        .arg(&csv)
        .output()
        .expect("runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("c1 = ") && stdout.contains("at-r-prime"),
        "{stdout}"
    );
    assert!(
        stdout.contains("departures from the fitted model: none"),
        "{stdout}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("json written")).expect("json");
    assert_eq!(report["manoeuvres"].as_array().map(Vec::len), Some(6));
    assert!(report["fit"]["r_squared"]
        .as_f64()
        .is_some_and(|r| r > 0.99));
    let csv_text = std::fs::read_to_string(&csv).expect("csv written");
    assert_eq!(csv_text.lines().count(), 7);

    // `--json -`: JSON only, on stdout.
    let out = host_tool()
        .args(["validate", "--rover"])
        .arg(rover_toml())
        .arg("--runs")
        .arg(&run)
        .args(["--json", "-"])
        .output()
        .expect("runs");
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("stdout is JSON");
    assert!(v["hard_ground"]["mu"].as_f64().is_some());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn validate_fails_clearly_on_standstill_only_runs() {
    let dir = temp_dir("validate-cli-still");
    let run = dir.join("still.csv");
    write_run(&run, true);
    let out = host_tool()
        .args(["validate", "--rover"])
        .arg(rover_toml())
        .arg("--runs")
        .arg(&run)
        .output()
        .expect("runs");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    // About the runs as a whole, and naming them (issue 34, item 5).
    assert!(
        stderr.contains(&format!(
            "Error: {}: no manoeuvre to validate",
            run.display()
        )),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 34 item 6: another rig's run (the same power at a lower bus voltage: currents to
/// 20 A, beyond the INA226 board's ±16.384 A) is validated by default; `--rig-range board`
/// holds it to the board's range, naming the file, line, column, the range and the way out.
#[test]
fn validate_reads_another_rigs_currents_unless_held_to_the_boards_range() {
    use host_tool::log::run_csv::{read_run_csv, CURRENT_A_MAX};
    let dir = temp_dir("validate-cli-rig-range");
    let run = dir.join("rig.csv");
    write_run(&run, false);
    let samples = read_run_csv(&run).expect("read");
    let peak = samples
        .iter()
        .map(|s| s.current_a.left.abs().max(s.current_a.right.abs()))
        .fold(0.0, f64::max);
    let k = 20.0 / peak;
    let rig: Vec<RunSample> = samples
        .iter()
        .map(|s| RunSample {
            bus_v: Sides::new(s.bus_v.left / k, s.bus_v.right / k),
            current_a: Sides::new(s.current_a.left * k, s.current_a.right * k),
            ..*s
        })
        .collect();
    write_run_csv_atomically(&run, host_tool::log::Existing::Replace, &rig).expect("write");
    let (first, column) = rig
        .iter()
        .enumerate()
        .find_map(|(i, s)| {
            if s.current_a.left.abs() > CURRENT_A_MAX {
                Some((i, "3 (left_current_a)"))
            } else {
                (s.current_a.right.abs() > CURRENT_A_MAX).then_some((i, "5 (right_current_a)"))
            }
        })
        .expect("beyond the board's range");
    let validate = |range: Option<&str>| {
        let mut cmd = host_tool();
        cmd.args(["validate", "--rover"])
            .arg(rover_toml())
            .arg("--runs")
            .arg(&run);
        if let Some(range) = range {
            cmd.args(["--rig-range", range]);
        }
        cmd.output().expect("runs")
    };
    for range in [None, Some("physical"), Some("30,25")] {
        let out = validate(range);
        assert!(
            out.status.success(),
            "{range:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.contains("at-r-prime"), "{stdout}");
    }
    let out = validate(Some("board"));
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains(&format!(
            "{}: line {}, column {column}: ",
            run.display(),
            first + 2
        )),
        "{stderr}"
    );
    assert!(
        stderr.contains(
            "is outside the INA226 board's range (bus 0 to 40.96 V, current ±16.384 A), which \
             --rig-range board holds the file to; for another rig's file leave the option out \
             (any physical reading) or state that rig's range: --rig-range BUS_V,CURRENT_A"
        ),
        "{stderr}"
    );
    let out = validate(Some("16,amps"));
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("BUS_V,CURRENT_A"), "{stderr}");
    // Only on the commands that read run CSVs for analysis.
    for (command, has) in [
        ("validate", true),
        ("plot", true),
        ("diagnose", true),
        ("record", false),
        ("plan", false),
    ] {
        let out = host_tool()
            .args([command, "--help"])
            .output()
            .expect("help");
        let help = String::from_utf8_lossy(&out.stdout);
        assert_eq!(help.contains("--rig-range"), has, "{command}: {help}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
