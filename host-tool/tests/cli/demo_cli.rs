//! `demo`'s terminal output leads with the answer in a screenful: each run's end-to-end check,
//! the validation and the diagnosis in a few lines, the plan, where the files are; the full
//! tables are in the files it names.

use crate::common;
use common::{host_tool, temp_dir};

#[test]
fn the_demo_prints_its_answer_in_a_screenful_and_names_the_files_with_the_tables() {
    let dir = temp_dir("demo-cli");
    let out = dir.join("demo");
    let made = host_tool()
        .args(["demo", "--runs", "2", "--out"])
        .arg(&out)
        .output()
        .expect("demo runs");
    let stdout = String::from_utf8_lossy(&made.stdout);
    assert!(
        made.status.success(),
        "{}",
        String::from_utf8_lossy(&made.stderr)
    );
    let lines: Vec<&str> = stdout.lines().collect();
    assert!(lines.len() <= 45, "{} lines:\n{stdout}", lines.len());
    // Folded to a terminal's width (issue 57: lines of 267 characters).
    assert!(lines.iter().all(|l| l.chars().count() <= 100), "{stdout}");
    assert!(lines[0].starts_with("demo: "), "{stdout}");
    let run_1 = lines.iter().position(|l| l.starts_with("run-1.mcap: "));
    let run_2 = lines.iter().position(|l| l.starts_with("run-2.mcap: "));
    assert!(
        run_1.is_some_and(|a| run_2.is_some_and(|b| a < b)),
        "{stdout}"
    );
    let words = stdout.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        words.contains("equal to the board's own total bit for bit")
            && words.contains("the first only starts the chips"),
        "{stdout}"
    );
    // The sections in order, each naming the file with its full tables, which exists.
    let at = |what: &str| {
        lines
            .iter()
            .position(|l| l.starts_with(what))
            .unwrap_or_else(|| panic!("no {what}:\n{stdout}"))
    };
    assert!(at("== validation") < at("== diagnosis"));
    assert!(at("== diagnosis") < at("== plan") || stdout.contains("not made"));
    for file in ["report.txt", "diagnosis/diagnosis.md"] {
        assert!(
            stdout.contains(&format!("{}/{file}", out.display())),
            "{stdout}"
        );
        assert!(out.join(file).is_file(), "{file}");
    }
    // The statistics stay in the files.
    assert!(!stdout.contains("F(1,"), "{stdout}");
    let _ = std::fs::remove_dir_all(&dir);
}
