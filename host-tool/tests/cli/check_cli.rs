//! `host-tool check` end to end: the simulated board through a pty, JSON and exit codes.

use crate::common;

use common::{host_tool, temp_dir};

fn check_json(args: &[&str], tag: &str) -> (i32, serde_json::Value) {
    let dir = temp_dir(tag);
    let json = dir.join("check.json");
    let out = host_tool()
        .args(["check", "--simulated", "--window-s", "1", "--json"])
        .arg(&json)
        .args(args)
        .output()
        .expect("runs");
    let text = std::fs::read_to_string(&json).expect("the JSON report is written either way");
    let _ = std::fs::remove_dir_all(&dir);
    (
        out.status.code().unwrap_or(-1),
        serde_json::from_str(&text).expect("JSON"),
    )
}

#[test]
fn a_healthy_simulated_board_exits_0() {
    let (code, json) = check_json(&[], "check-ok");
    assert_eq!(code, 0, "{json:#}");
    assert_eq!(json["passed"], true);
    assert!(json["steps"]
        .as_array()
        .expect("steps")
        .iter()
        .all(|s| s["outcome"] == "pass"));
}

#[test]
fn a_fault_exits_1_and_names_its_hint() {
    let (code, json) = check_json(&["--fault", "wrong-protocol"], "check-fault");
    assert_eq!(code, 1);
    assert_eq!(json["passed"], false);
    let failed: Vec<&serde_json::Value> = json["steps"]
        .as_array()
        .expect("steps")
        .iter()
        .filter(|s| s["outcome"] == "fail")
        .collect();
    assert_eq!(failed[0]["step"], "hello");
    assert_eq!(failed[0]["hint_kind"], "protocol-mismatch");
}

#[test]
fn an_unknown_fault_is_a_usage_error() {
    let out = host_tool()
        .args(["check", "--simulated", "--fault", "gremlins"])
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing-chip"));
}
