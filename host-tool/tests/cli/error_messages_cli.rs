//! What the user reads when a command fails (issue 34, item 5): each cause once, the file named
//! (inputs and outputs, a full disk included), quoted input and numbers short.

use crate::common;
use common::{host_tool, rover_toml, temp_dir};

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};

/// Runs `command`, which must fail with exit 1, and returns its one-line error message.
fn error_of(command: &mut Command) -> String {
    let out = command.output().expect("run host-tool");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let line = stderr
        .lines()
        .find_map(|l| l.strip_prefix("Error: "))
        .unwrap_or_else(|| panic!("no error line in {stderr:?}"))
        .to_owned();
    assert!(line.len() < 500, "{} bytes: {line:.500}", line.len());
    line
}

/// No part of `message` (split at `: `) appears twice.
fn assert_each_cause_once(message: &str) {
    let parts: Vec<&str> = message.split(": ").collect();
    for (i, part) in parts.iter().enumerate() {
        assert!(
            !parts[i + 1..].contains(part),
            "{part:?} twice in {message:?}"
        );
    }
}

#[test]
fn a_missing_file_or_port_is_named_with_its_cause_once() {
    let dir = temp_dir("errors-missing");
    let missing = dir.join("nosuch.csv");
    let shown = missing.display().to_string();
    let cases: [(&str, Vec<String>); 4] = [
        (
            "missing run file",
            vec![
                "validate".into(),
                "--rover".into(),
                rover_toml().display().to_string(),
                "--runs".into(),
                shown.clone(),
            ],
        ),
        (
            "missing rover file",
            vec![
                "validate".into(),
                "--rover".into(),
                dir.join("nosuch.toml").display().to_string(),
                "--runs".into(),
                shown.clone(),
            ],
        ),
        (
            "missing port",
            vec![
                "record".into(),
                "--port".into(),
                "/dev/ttyNOPE".into(),
                "--out".into(),
                dir.join("rec.mcap").display().to_string(),
            ],
        ),
        (
            "diagnose, missing runs",
            vec![
                "diagnose".into(),
                "--rover".into(),
                rover_toml().display().to_string(),
                "--runs".into(),
                shown.clone(),
            ],
        ),
    ];
    for (what, args) in cases {
        let message = error_of(host_tool().args(&args));
        assert_each_cause_once(&message);
        assert_eq!(
            message.matches("No such file or directory").count(),
            1,
            "{what}: {message}"
        );
        let named = if what == "missing port" {
            "/dev/ttyNOPE".to_owned()
        } else if what == "missing rover file" {
            dir.join("nosuch.toml").display().to_string()
        } else {
            shown.clone()
        };
        assert!(message.contains(&named), "{what}: {message}");
    }
    std::fs::remove_dir_all(&dir).expect("clean up");
}

#[test]
fn errors_found_after_reading_name_their_file() {
    let dir = temp_dir("errors-named");
    // A path table whose third slice the model cannot price (the arcs overlap): found after
    // the table was read, by line.
    let table = dir.join("paths.csv");
    std::fs::write(
        &table,
        "start_deg,end_deg,distance_m,r_lo_over_r_prime,r_hi_over_r_prime,delta_e_pct\n\
         30,30,5,0.1,0.5,-5\n30,30,5,0.5,1,-6\n30,30,0.01,0.1,100,-8\n",
    )
    .expect("write table");
    let message = error_of(
        host_tool()
            .args(["diagnose", "--rover"])
            .arg(rover_toml())
            .arg("--runs")
            .arg(&table),
    );
    assert!(
        message.starts_with(&format!("{}: line 4: ", table.display())),
        "{message}"
    );
    // A commands CSV row the board would refuse: found when the options are checked; 1e308
    // printed short.
    let commands = dir.join("cmds.csv");
    std::fs::write(
        &commands,
        "t_s,cmd_left_mps,cmd_right_mps\n0,0.1,0.1\n1e308,1e308,0.1\n",
    )
    .expect("write commands");
    let message = error_of(
        host_tool()
            .args(["record", "--port", "/dev/ttyNOPE", "--out"])
            .arg(dir.join("rec.mcap"))
            .arg("--commands")
            .arg(&commands),
    );
    assert!(
        message.starts_with(&format!(
            "{}: commands row 2 (t_s = 1e308 s): side speeds 1e308 / 0.1 m/s",
            commands.display()
        )),
        "{message}"
    );
    std::fs::remove_dir_all(&dir).expect("clean up");
}

/// `No space left on device` names the output file, once.
#[cfg(target_os = "linux")]
#[test]
fn a_full_disk_names_the_output() {
    let full = Path::new("/dev/full");
    if !full.exists() {
        return; // no /dev/full here: nothing to check
    }
    let dir = temp_dir("errors-full");
    let run = dir.join("run.csv");
    let mut text = String::from(
        "t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,cmd_left_mps,cmd_right_mps\n",
    );
    for i in 0..12_000u32 {
        let t = f64::from(i) * 0.005;
        let right = if (t as u64) % 20 < 10 { 0.3 } else { -0.3 };
        text.push_str(&format!("{t},24,2.5,24.1,2.5,0.3,{right}\n"));
    }
    std::fs::write(&run, text).expect("write run");
    let check = |message: String, file: &Path| {
        assert!(
            message.starts_with(&format!("{}: ", file.display())),
            "{message}"
        );
        assert_eq!(
            message.matches("No space left on device").count(),
            1,
            "{message}"
        );
        assert_each_cause_once(&message);
    };
    for option in ["--json", "--csv"] {
        let message = error_of(
            host_tool()
                .args(["validate", "--rover"])
                .arg(rover_toml())
                .arg("--runs")
                .arg(&run)
                .args([option, "/dev/full"]),
        );
        check(message, full);
    }
    let message = error_of(
        host_tool()
            .args(["replay", "--as-fast-as-possible"])
            .arg(&run)
            .args(["--to", "/dev/full"]),
    );
    check(message, full);
    // `record` into a log that is /dev/full (by a link with the log's extension).
    #[cfg(unix)]
    for ext in ["mcap", "csv"] {
        let log = dir.join(format!("full.{ext}"));
        std::os::unix::fs::symlink(full, &log).expect("link");
        let mut replay = host_tool()
            .args(["replay", "--to-pty"])
            .arg(&run)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("replay");
        let mut pty = String::new();
        BufReader::new(replay.stdout.take().expect("stdout"))
            .read_line(&mut pty)
            .expect("pty path");
        let message = error_of(
            host_tool()
                .args(["record", "--force", "--port", pty.trim(), "--out"])
                .arg(&log),
        );
        let _ = replay.kill();
        let _ = replay.wait();
        check(message, &log);
    }
    std::fs::remove_dir_all(&dir).expect("clean up");
}
