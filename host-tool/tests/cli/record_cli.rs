//! `host-tool record` stopped by a service manager or a closed terminal: SIGTERM and SIGHUP stop
//! it as cleanly as Ctrl-C (final flush, MCAP summary and footer, exit 0).

use crate::common;
use common::{host_tool, temp_dir};

use host_tool::log::mcap::read_mcap_run;
use host_tool::log::run_csv::{write_run_csv_atomically, RunSample};
use model_core::Sides;
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A minute of gentle driving at 200 Hz, as a run CSV for `replay --to-pty`.
fn write_source(path: &std::path::Path) {
    let samples: Vec<RunSample> = (0..12_000)
        .map(|i| RunSample {
            t_s: f64::from(i) * 0.005,
            bus_v: Sides::new(24.0, 24.1),
            current_a: Sides::new(2.0 + f64::from(i % 7) * 0.01, 2.5),
            cmd_mps: Sides::new(0.3, 0.3),
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        })
        .collect();
    write_run_csv_atomically(path, host_tool::log::Existing::Replace, &samples)
        .expect("source csv");
}

fn stops_cleanly_on(signal: &str) {
    let dir = temp_dir(&format!("record-{signal}"));
    let source = dir.join("source.csv");
    write_source(&source);
    let mut replay = host_tool()
        .args(["replay", "--to-pty"])
        .arg(&source)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("replay");
    let mut line = String::new();
    BufReader::new(replay.stdout.take().expect("stdout"))
        .read_line(&mut line)
        .expect("pty path");
    let out = dir.join("rec.mcap");
    let mut record = host_tool()
        .args(["record", "--port", line.trim(), "--out"])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("record");
    // Let it record (and flush) a while, then stop it the way systemd would.
    std::thread::sleep(Duration::from_millis(1500));
    let killed = Command::new("kill")
        .args([&format!("-{signal}"), &record.id().to_string()])
        .status()
        .expect("kill");
    assert!(killed.success());
    let deadline = Instant::now() + Duration::from_secs(20);
    let status = loop {
        if let Some(status) = record.try_wait().expect("wait") {
            break status;
        }
        assert!(Instant::now() < deadline, "record ignored SIG{signal}");
        std::thread::sleep(Duration::from_millis(50));
    };
    let _ = replay.kill();
    let _ = replay.wait();
    assert!(status.success(), "SIG{signal}: {status}");
    let got = read_mcap_run(&out).expect("readable");
    assert_eq!(got.truncated, None, "SIG{signal}: the footer is written");
    assert!(!got.run.samples.is_empty(), "SIG{signal}: samples recorded");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn sigterm_finishes_the_file_and_exits_0() {
    stops_cleanly_on("TERM");
}

#[test]
fn sighup_finishes_the_file_and_exits_0() {
    stops_cleanly_on("HUP");
}
