//! A closed stderr or stdout ends no command badly (issue 34, item 2): warnings to a closed
//! stderr are dropped (no panic, exit 101), and a byte stream to a closed stdout given as a file
//! (`replay --to /dev/stdout | head`) ends quietly with 0, as `--json -` does.

use crate::common;
use common::{host_tool, rover_toml, temp_dir};

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};

/// A run CSV of `rows` rows at 200 Hz, every 10th one damaged (a bus voltage that is not a
/// number): with `--salvage`, one warning line on stderr per damaged row.
fn run_csv_with_bad_rows(dir: &Path, rows: u32) -> PathBuf {
    let mut text = String::from(
        "t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,cmd_left_mps,cmd_right_mps\n",
    );
    for i in 0..rows {
        let t = f64::from(i) * 0.005;
        let right = if (t as u64) % 20 < 10 { 0.3 } else { -0.3 };
        let left_bus = if i % 10 == 5 { "x" } else { "24" };
        writeln!(
            text,
            "{t},{left_bus},{},24.1,{},0.3,{right}",
            2.0 + t.sin(),
            2.5 + t.cos()
        )
        .expect("string");
    }
    let path = dir.join("many-bad.csv");
    std::fs::write(&path, text).expect("write csv");
    path
}

/// Runs `command` with the read end of its stderr (`stderr`) or stdout pipe closed before it
/// writes anything; the other stream is collected.
fn with_closed(mut command: std::process::Command, close_stderr: bool) -> Output {
    if close_stderr {
        command.stdout(Stdio::null()).stderr(Stdio::piped());
    } else {
        command.stdout(Stdio::piped()).stderr(Stdio::piped());
    }
    let mut child = command.spawn().expect("spawn host-tool");
    if close_stderr {
        drop(child.stderr.take());
    } else {
        drop(child.stdout.take());
    }
    child.wait_with_output().expect("wait")
}

#[test]
fn warnings_to_a_closed_stderr_do_not_panic() {
    let dir = temp_dir("closed-stderr");
    // 2,000 warnings of ~100 bytes: more than a pipe holds, so writing them must fail.
    let csv = run_csv_with_bad_rows(&dir, 20_000);
    let mut c = host_tool();
    c.args(["validate", "--salvage", "--rover"])
        .arg(rover_toml())
        .arg("--runs")
        .arg(&csv);
    let out = with_closed(c, true);
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    // An error message to a closed stderr: still exit 1.
    let mut c = host_tool();
    c.args(["validate", "--rover"])
        .arg(rover_toml())
        .arg("--runs")
        .arg(dir.join("nosuch.csv"));
    let out = with_closed(c, true);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    std::fs::remove_dir_all(&dir).expect("clean up");
}

#[test]
fn a_stream_to_a_closed_stdout_file_ends_quietly() {
    let dir = temp_dir("closed-stdout");
    let csv = run_csv_with_bad_rows(&dir, 20_000);
    // `replay --to /dev/stdout | head`: the stream is far larger than a pipe holds.
    let mut c = host_tool();
    c.args(["replay", "--salvage", "--as-fast-as-possible"])
        .arg(&csv)
        .args(["--to", "/dev/stdout"]);
    let out = with_closed(c, false);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(!stderr.contains("Error"), "{stderr}");
    // `--json -` (stdout written directly) ends the same way.
    let mut c = host_tool();
    c.args(["validate", "--salvage", "--json", "-", "--rover"])
        .arg(rover_toml())
        .arg("--runs")
        .arg(&csv);
    let out = with_closed(c, false);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(!stderr.contains("Error"), "{stderr}");
    std::fs::remove_dir_all(&dir).expect("clean up");
}
