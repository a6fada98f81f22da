//! A stop signal during a write leaves no temporary file or staging directory behind, and what
//! a SIGKILL leaves (it cannot be caught) is swept by the next writer of the same name.

use crate::common;

use common::{host_tool, temp_dir};
use host_tool::log::run_csv::{write_run_csv_atomically, RunSample};
use host_tool::log::Existing;
use model_core::Sides;
use std::path::Path;
use std::process::{Child, Command};
use std::time::{Duration, Instant};

/// Names in `dir` that start with `prefix`.
fn hidden(dir: &Path, prefix: &str) -> Vec<String> {
    std::fs::read_dir(dir)
        .expect("dir")
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with(prefix))
        .collect()
}

/// Waits until `child` has a temporary path in `dir` (names starting with `prefix`), then sends
/// it `signal`; false if it exited first.
fn signal_while_writing(child: &mut Child, dir: &Path, prefix: &str, signal: &str) -> bool {
    let start = Instant::now();
    while hidden(dir, prefix).is_empty() {
        if child.try_wait().expect("wait").is_some() || start.elapsed() > Duration::from_secs(120) {
            return false;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    let sent = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .expect("kill");
    assert!(sent.success());
    true
}

/// A run CSV long enough that converting it takes a while (its MCAP output is tens of MB).
fn long_csv(path: &Path) {
    let samples: Vec<RunSample> = (0..400_000)
        .map(|i| RunSample {
            t_s: f64::from(i) * 0.005,
            bus_v: Sides::new(24.0, 24.1),
            current_a: Sides::new(2.0 + f64::from(i % 7) * 0.01, 1.5),
            cmd_mps: Sides::new(0.3, 0.3),
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        })
        .collect();
    write_run_csv_atomically(path, Existing::Replace, &samples).expect("csv");
}

#[test]
fn convert_stopped_by_a_signal_leaves_no_temporary_file_and_a_killed_ones_is_swept() {
    let dir = temp_dir("signals-convert");
    let input = dir.join("long.csv");
    long_csv(&input);
    let out = dir.join("out.mcap");
    for signal in ["-TERM", "-INT", "-HUP"] {
        let mut child = host_tool()
            .args(["convert"])
            .arg(&input)
            .arg(&out)
            .spawn()
            .expect("convert");
        assert!(
            signal_while_writing(&mut child, &dir, ".out.mcap.", signal),
            "convert ended before its temporary file was seen"
        );
        let status = child.wait().expect("wait");
        assert!(!status.success(), "{signal}: {status:?}");
        assert_eq!(hidden(&dir, ".out.mcap."), Vec::<String>::new(), "{signal}");
        assert!(!out.exists(), "{signal}");
    }

    let mut child = host_tool()
        .args(["convert"])
        .arg(&input)
        .arg(&out)
        .spawn()
        .expect("convert");
    assert!(signal_while_writing(
        &mut child,
        &dir,
        ".out.mcap.",
        "-KILL"
    ));
    child.wait().expect("wait");
    let left = hidden(&dir, ".out.mcap.");
    assert_eq!(
        left.len(),
        1,
        "a SIGKILL leaves its temporary file: {left:?}"
    );
    let done = host_tool()
        .args(["convert"])
        .arg(&input)
        .arg(&out)
        .output()
        .expect("convert");
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    assert_eq!(hidden(&dir, ".out.mcap."), Vec::<String>::new(), "swept");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn demo_stopped_by_ctrl_c_leaves_no_staging_directory() {
    let dir = temp_dir("signals-demo");
    let out = dir.join("demo-out");
    let mut child = host_tool()
        .args(["--quiet", "demo", "--out"])
        .arg(&out)
        .spawn()
        .expect("demo");
    assert!(
        signal_while_writing(&mut child, &dir, ".demo-out.partial-", "-INT"),
        "the demo ended before its staging directory was seen"
    );
    let status = child.wait().expect("wait");
    assert_eq!(status.code(), Some(130));
    assert_eq!(hidden(&dir, ".demo-out."), Vec::<String>::new());
    let _ = std::fs::remove_dir_all(&dir);
}
