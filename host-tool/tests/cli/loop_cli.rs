//! The loop a user runs, from the command line: a demo log replayed into a pty, recorded,
//! validated, plotted and diagnosed, with no extra flags — the recording must give the same
//! manoeuvres as the original (issue 11). Plus the conventions every command shares.

use crate::common;
use common::{host_tool, rover_toml, temp_dir};

use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn run(cmd: &mut Command) -> Output {
    let out = cmd.output().expect("host-tool runs");
    assert!(
        out.status.success(),
        "{cmd:?}: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// `replay LOG --to-pty` and `record --port PTY --out OUT` on it, as a user types them.
fn replay_and_record(log: &Path, out: &Path) {
    let mut replay = host_tool()
        .arg("replay")
        .arg(log)
        .args(["--to-pty", "--as-fast-as-possible"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("replay starts");
    let mut line = String::new();
    BufReader::new(replay.stdout.take().expect("stdout"))
        .read_line(&mut line)
        .expect("the pty's path");
    let pty = line.trim();
    assert!(pty.starts_with("/dev/"), "{line:?}");
    let recorded = run(host_tool()
        .args(["record", "--port", pty, "--out"])
        .arg(out));
    let summary = String::from_utf8_lossy(&recorded.stdout);
    assert!(
        summary.contains("differing from the host's recomputation: 0"),
        "{summary}"
    );
    assert!(replay.wait().expect("replay ends").success());
}

fn validate_json(runs: &[PathBuf]) -> Value {
    let out = run(host_tool()
        .args(["validate", "--rover"])
        .arg(rover_toml())
        .arg("--runs")
        .args(runs)
        .args(["--json", "-"]));
    serde_json::from_slice(&out.stdout).expect("JSON")
}

/// What makes a manoeuvre the same: kind, direction, regime and segment exactly; commanded
/// speeds and radius to 1e-5 (the recording's speeds are the board's f32 wheel rates, rounded
/// to 1 µm/s; the demo's own carry f64 noise).
fn manoeuvres(report: &Value) -> Vec<String> {
    report["manoeuvres"]
        .as_array()
        .expect("manoeuvres")
        .iter()
        .map(|m| {
            let num = |v: &Value| v.as_f64().map(|x| format!("{x:.5}"));
            format!(
                "{} {} {} {} {:?} {:?} {:?}",
                m["kind"],
                m["direction"],
                m["regime"],
                m["segment"],
                num(&m["cmd_mps"]["left"]),
                num(&m["cmd_mps"]["right"]),
                num(&m["radius_cmd_m"]),
            )
        })
        .collect()
}

/// The longest time from a forwarded command to its ack in a recording [s].
fn max_ack_latency_s(path: &Path) -> f64 {
    use model_core::wire::BoardFrame;
    let run = host_tool::log::load::load_run(path).expect("log");
    let acks = run
        .frames
        .iter()
        .filter(|(_, f)| matches!(f, BoardFrame::Ack { .. } | BoardFrame::Rejected { .. }))
        .map(|(t, _)| *t);
    run.commands
        .iter()
        .zip(acks)
        .map(|(c, t)| t - c.t_s)
        .fold(0.0, f64::max)
}

#[test]
fn replay_record_validate_plot_diagnose_gives_the_original_manoeuvres() {
    let dir = temp_dir("loop-cli");
    let demo = dir.join("demo");
    run(host_tool()
        .args(["demo", "--runs", "2", "--out"])
        .arg(&demo));
    let originals: Vec<PathBuf> = (1..=2)
        .map(|k| demo.join(format!("run-{k}.mcap")))
        .collect();
    let recordings: Vec<PathBuf> = (1..=2).map(|k| dir.join(format!("rec-{k}.mcap"))).collect();
    for (original, recording) in originals.iter().zip(&recordings) {
        replay_and_record(original, recording);
    }

    let (before, after) = (validate_json(&originals), validate_json(&recordings));
    let (m_before, m_after) = (manoeuvres(&before), manoeuvres(&after));
    assert!(m_before.len() >= 10, "{m_before:?}");
    assert_eq!(m_after, m_before);
    // A recording of a replay switches commands where the board applied them (its ack), the
    // original where the recorder sent them: boundaries move later by at most the original's
    // ack latency (at the demo's 25x, ms of wall time are tens to hundreds of ms of run time;
    // at real time ~2 ms).
    let latency_s = originals
        .iter()
        .map(|path| max_ack_latency_s(path))
        .fold(0.0, f64::max);
    for (a, b) in after["manoeuvres"]
        .as_array()
        .expect("rows")
        .iter()
        .zip(before["manoeuvres"].as_array().expect("rows"))
    {
        let (ta, tb) = (a["t_start_s"].as_f64(), b["t_start_s"].as_f64());
        let (ta, tb) = (ta.expect("t"), tb.expect("t"));
        assert!(
            ta - tb > -0.006 && ta - tb <= latency_s + 0.006,
            "{ta} vs {tb} (ack latency up to {latency_s} s)"
        );
    }
    for run in after["runs"].as_array().expect("runs") {
        assert_eq!(run["cross_check"]["model_mismatches"], 0, "{run}");
    }

    let plots = dir.join("plots");
    let plotted = run(host_tool()
        .args(["plot", "--format", "png", "--rover"])
        .arg(rover_toml())
        .arg("--runs")
        .args(&recordings)
        .arg("--out")
        .arg(&plots));
    let files = String::from_utf8_lossy(&plotted.stdout);
    for name in [
        "power-vs-time-rec-1.png",
        "power-vs-time-rec-2.png",
        "residuals.png",
    ] {
        assert!(plots.join(name).is_file(), "{name}: {files}");
    }

    let diagnose = |runs: &[PathBuf], out: &Path| -> Value {
        let o = run(host_tool()
            .args(["diagnose", "--rover"])
            .arg(rover_toml())
            .arg("--runs")
            .args(runs)
            .arg("--out")
            .arg(out)
            .args(["--json", "-"]));
        serde_json::from_slice(&o.stdout).expect("JSON")
    };
    let (d_before, d_after) = (
        diagnose(&originals, &dir.join("diag-original")),
        diagnose(&recordings, &dir.join("diag")),
    );
    // The same departure is found. (The effect named can differ when the demo's ack latency
    // under load shifts the boundaries by a few samples: the sand world's effects compete.)
    assert_eq!(d_before["significant"], true);
    assert_eq!(d_after["significant"], d_before["significant"]);
    assert!(d_after["effect"].is_string(), "{}", d_after["effect"]);
    assert!(dir.join("diag/model.toml").is_file() || dir.join("diag/diagnosis.md").is_file());

    // Scripted checks: sand departs from the hard-ground model.
    let status = host_tool()
        .args(["diagnose", "--fail-on-departure", "--rover"])
        .arg(rover_toml())
        .arg("--runs")
        .args(&recordings)
        .stdout(Stdio::null())
        .status()
        .expect("runs");
    assert_eq!(status.code(), Some(3));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn decode_recognises_run_logs_and_survives_a_closed_stdout() {
    let dir = temp_dir("decode-cli");
    let csv = dir.join("run.csv");
    std::fs::write(
        &csv,
        "t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,cmd_left_mps,cmd_right_mps\n\
         0,24,1,24,1,0,0\n0.005,24,1,24,1,0,0\n",
    )
    .expect("csv");
    let out = host_tool().arg("decode").arg(&csv).output().expect("runs");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("not a raw capture") && err.contains("replay"),
        "{err}"
    );

    let capture = dir.join("capture.bin");
    run(host_tool()
        .arg("replay")
        .arg(&csv)
        .arg("--to")
        .arg(&capture));
    // `decode --json | head`: stdout closed before anything is written.
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    let out = host_tool()
        .arg("decode")
        .arg(&capture)
        .arg("--json")
        .stdout(writer)
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(out.status.code(), Some(0), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn existing_outputs_need_force_and_every_help_shows_the_conventions() {
    let dir = temp_dir("force-cli");
    let json = dir.join("sub/plan.json");
    let plan = |force: bool| {
        let mut c = host_tool();
        c.args([
            "plan",
            "--start-deg",
            "45",
            "--end-deg",
            "45",
            "--distance-m",
            "10",
        ])
        .arg("--json")
        .arg(&json);
        if force {
            c.arg("--force");
        }
        c.output().expect("runs")
    };
    assert!(plan(false).status.success(), "the directory is created");
    let again = plan(false);
    assert_eq!(again.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&again.stderr).contains("--force"));
    assert!(plan(true).status.success());

    for command in [
        "demo",
        "ports",
        "record",
        "validate",
        "plot",
        "convert",
        "replay",
        "decode",
        "diagnose",
        "diagnose-bench",
        "plan",
    ] {
        let help = run(host_tool().args([command, "--help"]));
        let text = String::from_utf8_lossy(&help.stdout);
        for convention in ["--json FILE|-", "--force", "Exit codes"] {
            assert!(text.contains(convention), "{command} --help: {convention}");
        }
    }
    // Units in names; the old spelling still parses (hidden).
    let help = run(host_tool().args(["record", "--help"]));
    let text = String::from_utf8_lossy(&help.stdout);
    assert!(text.contains("--duration-s") && text.contains("--reconnect-timeout-s"));
    assert!(!text.contains("--duration "));
    let old = host_tool()
        .args(["record", "--port", "/nonexistent/port", "--out"])
        .arg(dir.join("x.mcap"))
        .args(["--duration", "1", "--reconnect-timeout", "1"])
        .output()
        .expect("runs");
    assert_eq!(old.status.code(), Some(1), "parsed; the port is what fails");
    let _ = std::fs::remove_dir_all(&dir);
}
