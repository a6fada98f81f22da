//! `merge`: the demo's board logs, stripped of everything the robot knows, and the robot bags
//! `demo --robot-bag` wrote with the robot's clock 7.3 s ahead, merge back into runs that
//! validate and diagnose as the demo's own.

use crate::common;

use common::{host_tool, rover_toml, temp_dir};
use host_tool::log::convert::save_run;
use host_tool::log::load::load_run;
use model_core::Sides;
use serde_json::Value;
use std::path::{Path, PathBuf};

const CLOCK_OFFSET_S: f64 = 7.3;

/// The board's log alone: no commanded speeds, yaw, pitch or positions (a board recorded
/// without `--commands` on a robot that keeps them in its bag).
fn board_only(log: &Path, out: &Path) {
    let mut run = load_run(log).expect("demo log loads");
    for s in &mut run.samples {
        s.cmd_mps = Sides::new(0.0, 0.0);
        s.yaw_rad = None;
        s.pitch_deg = None;
        s.x_m = None;
        s.y_m = None;
    }
    run.commands.clear();
    save_run(out, host_tool::log::Existing::Replace, &run).expect("board-only log written");
}

/// `demo --robot-bag` into DIR/demo with the robot's clock `offset_s` ahead (`extra` options
/// added); returns the demo's directory.
fn robot_demo(dir: &Path, offset_s: f64, extra: &[&str]) -> PathBuf {
    let demo = dir.join("demo");
    let made = host_tool()
        .args(["demo", "--quiet", "--robot-bag", "--robot-clock-offset-s"])
        .arg(offset_s.to_string())
        .args(extra)
        .arg("--out")
        .arg(&demo)
        .output()
        .expect("demo runs");
    let stderr = String::from_utf8_lossy(&made.stderr);
    assert!(made.status.success(), "{stderr}");
    demo
}

/// `merge --board BOARD --bag BAG --out OUT` (`extra` options added): its exit code, stdout and
/// stderr.
fn merge(board: &Path, bag: &Path, out: &Path, extra: &[&str]) -> (Option<i32>, String, String) {
    let done = host_tool()
        .args(["merge", "--board"])
        .arg(board)
        .arg("--bag")
        .arg(bag)
        .args(extra)
        .arg("--out")
        .arg(out)
        .output()
        .expect("merge runs");
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (done.status.code(), text(&done.stdout), text(&done.stderr))
}

/// The offset `merge` reports: "the bag's clock is +7.298 s ahead".
fn reported_offset_s(stdout: &str) -> f64 {
    stdout
        .split("clock is ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no offset in {stdout}"))
}

fn json_of(args: &[&str], dir: &Path) -> Value {
    let out = host_tool()
        .args(args)
        .current_dir(dir)
        .output()
        .expect("runs");
    assert!(
        out.status.code().is_some_and(|c| c == 0 || c == 3),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{args:?}: {e}"))
}

#[test]
fn merged_board_logs_and_robot_bags_diagnose_as_the_demos_own_runs() {
    let dir = temp_dir("merge-cli");
    let demo = robot_demo(&dir, CLOCK_OFFSET_S, &[]);

    let mut merged: Vec<PathBuf> = Vec::new();
    let mut own: Vec<PathBuf> = Vec::new();
    for k in 1..=3 {
        let board = dir.join(format!("board-{k}.mcap"));
        board_only(&demo.join(format!("run-{k}.mcap")), &board);
        let out = dir.join(format!("merged-{k}.csv"));
        let bag = demo.join(format!("run-{k}-robot"));
        let (code, stdout, stderr) = merge(&board, &bag, &out, &["--pose-topic", "/tracker/pose"]);
        assert_eq!(code, Some(0), "{stdout}{stderr}");
        // Found to within 5 ms.
        let offset = reported_offset_s(&stdout);
        assert!(
            (offset - CLOCK_OFFSET_S).abs() <= 0.005,
            "run {k}: offset {offset} s\n{stdout}"
        );
        merged.push(out);
        own.push(demo.join(format!("run-{k}.csv")));
    }

    let rover = rover_toml();
    let rover = rover.to_str().expect("UTF-8 path");
    let args = |cmd: &str, runs: &[PathBuf]| -> Vec<String> {
        let mut a: Vec<String> = [cmd, "--rover", rover, "--json", "-", "--runs"]
            .map(String::from)
            .to_vec();
        a.extend(runs.iter().map(|p| p.display().to_string()));
        a
    };
    let run_json = |cmd: &str, runs: &[PathBuf]| {
        let a = args(cmd, runs);
        json_of(&a.iter().map(String::as_str).collect::<Vec<_>>(), &dir)
    };

    // Per turn: the angular slip and R_ACT of the merged runs are the demo's own.
    let (mine, theirs) = (run_json("validate", &merged), run_json("validate", &own));
    let turns = |v: &Value| v["manoeuvres"].as_array().cloned().unwrap_or_default();
    let (a, b) = (turns(&mine), turns(&theirs));
    assert_eq!(a.len(), b.len());
    assert!(a.len() >= 18, "{}", a.len());
    // The offset is measured to a few ms, so a command may land one 5 ms sample from where the
    // recorder put it: the turns' figures agree to that, not bit for bit.
    let tolerance = [
        ("regime", 0.0),
        ("r_over_r_prime", 1e-9),
        ("angular_slip", 1e-3), // 0.1 percentage point
        ("r_act_m", 5e-3),      // 5 mm
    ];
    for (x, y) in a.iter().zip(&b) {
        for (key, tol) in tolerance {
            let (p, q) = (&x[key], &y[key]);
            match (p.as_f64(), q.as_f64()) {
                (Some(p), Some(q)) => assert!((p - q).abs() <= tol, "{key}: {p} vs {q}"),
                _ => assert_eq!(p, q, "{key}"),
            }
        }
    }
    // The diagnosis: the same verdict.
    let (mine, theirs) = (run_json("diagnose", &merged), run_json("diagnose", &own));
    for key in ["effect", "regime", "significant"] {
        assert_eq!(mine[key], theirs[key], "{key}");
    }
    let names = |v: &Value| -> Vec<Value> {
        let steps = v["secondary"].as_array().cloned().unwrap_or_default();
        steps.iter().map(|s| s["effect"].clone()).collect()
    };
    assert_eq!(names(&mine), names(&theirs), "effects added stepwise");
    assert!(mine["effect"].is_string(), "{}", mine["effect"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_robot_clock_behind_the_boards_is_found_too() {
    let dir = temp_dir("merge-cli-behind");
    let demo = robot_demo(&dir, -9.6, &["--runs", "1", "--seed", "7"]);
    let bag = demo.join("run-1-robot");
    let (code, stdout, stderr) = merge(&demo.join("run-1.mcap"), &bag, &dir.join("m.mcap"), &[]);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    let offset = reported_offset_s(&stdout);
    assert!((offset + 9.6).abs() <= 0.005, "offset {offset} s\n{stdout}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_bag_that_does_not_overlap_the_board_log_is_refused() {
    let dir = temp_dir("merge-cli-far");
    let demo = robot_demo(&dir, -120.0, &["--runs", "1"]);
    let out = dir.join("merged.mcap");
    let (code, _, stderr) = merge(
        &demo.join("run-1.mcap"),
        &demo.join("run-1-robot"),
        &out,
        &[],
    );
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("do not overlap"), "{stderr}");
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn one_topic_given_for_two_roles_is_refused_naming_both_options() {
    let dir = temp_dir("merge-cli-two-roles");
    let (code, _, stderr) = merge(
        &dir.join("board.mcap"),
        &dir.join("bag"),
        &dir.join("m.mcap"),
        &["--cmd-topic", "/cmd_vel", "--pose-topic", "/cmd_vel"],
    );
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("--cmd-topic and --pose-topic both name /cmd_vel"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
