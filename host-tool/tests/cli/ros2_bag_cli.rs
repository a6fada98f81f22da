//! `convert LOG OUT --to ros2-bag`, read back with the `mcap` crate (rosbags reads it in CI:
//! .ci/check-ros2-bag.py).

use crate::common;

use common::{demo_once, host_tool, temp_dir};
use std::collections::BTreeMap;
use std::path::Path;

/// (topic, log time) of every message in an MCAP file, checking that each channel is a ROS 2
/// one (CDR messages, ros2msg schema).
fn ros2_messages(bytes: &[u8]) -> Vec<(String, u64)> {
    mcap::MessageStream::new(bytes)
        .expect("mcap")
        .map(|m| {
            let m = m.expect("message");
            assert_eq!(m.channel.message_encoding, "cdr", "{}", m.channel.topic);
            let schema = m.channel.schema.as_ref().expect("schema");
            assert_eq!(schema.encoding, "ros2msg", "{}", m.channel.topic);
            (m.channel.topic.clone(), m.log_time)
        })
        .collect()
}

fn log_times(messages: &[(String, u64)], topic: &str) -> Vec<u64> {
    messages
        .iter()
        .filter(|m| m.0 == topic)
        .map(|m| m.1)
        .collect()
}

fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// `convert LOG BAG --to ros2-bag`, which must succeed; its stdout.
fn convert_to_bag(log: &Path, bag: &Path) -> String {
    let done = host_tool()
        .arg("convert")
        .arg(log)
        .arg(bag)
        .args(["--to", "ros2-bag"])
        .output()
        .expect("runs");
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    String::from_utf8_lossy(&done.stdout).into_owned()
}

#[test]
fn a_demo_log_becomes_a_ros2_bag_with_every_sample_at_its_log_time() {
    let dir = temp_dir("ros2-bag-cli");
    let log = demo_once(&dir).join("run-1.mcap");
    let bag = dir.join("drive");
    let stdout = convert_to_bag(&log, &bag);
    assert_eq!(names(&bag), ["drive_0.mcap", "metadata.yaml"]);

    let bytes = std::fs::read(bag.join("drive_0.mcap")).expect("bag");
    let header = mcap::read::LinearReader::new(&bytes)
        .expect("mcap")
        .next()
        .expect("a record")
        .expect("header");
    let mcap::records::Record::Header(header) = header else {
        panic!("{header:?}");
    };
    assert_eq!(header.profile, "ros2");
    let messages = ros2_messages(&bytes);

    // Every sample of the log, each at the log time the MCAP log gives it: its batches are on
    // one clock, log time = publish time (run time) + the wall-clock offset.
    let offsets: Vec<i128> = mcap::MessageStream::new(&std::fs::read(&log).expect("log"))
        .expect("log mcap")
        .map(|m| m.expect("message"))
        .filter(|m| m.channel.topic == "/rover_power/sample_batch")
        .map(|m| i128::from(m.log_time) - i128::from(m.publish_time))
        .collect();
    assert!(offsets.windows(2).all(|w| w[0] == w[1]) && !offsets.is_empty());
    let run = host_tool::log::mcap::read_mcap_run(&log).expect("log").run;
    let in_log: Vec<u64> = run
        .samples
        .iter()
        .map(|s| (offsets[0] + (s.t_s * 1e9).round() as i128) as u64)
        .collect();
    assert!(in_log.len() > 1000, "{}", in_log.len());
    assert_eq!(log_times(&messages, "/rover_power/sample"), in_log);

    let mut counts: BTreeMap<&str, u64> = BTreeMap::new();
    for (topic, _) in &messages {
        *counts.entry(topic).or_default() += 1;
    }
    assert_eq!(
        counts.keys().copied().collect::<Vec<_>>(),
        [
            "/cmd_vel",
            "/imu/data",
            "/rosout",
            "/rover_power/sample",
            "/rover_power/tracker_pose"
        ]
    );
    let yaml = std::fs::read_to_string(bag.join("metadata.yaml")).expect("metadata");
    for (topic, n) in &counts {
        let at = yaml
            .find(&format!("name: \"{topic}\""))
            .unwrap_or_else(|| panic!("{topic} in {yaml}"));
        let count = yaml[at..]
            .lines()
            .find_map(|l| l.trim().strip_prefix("message_count: "))
            .expect("its count");
        assert_eq!(count, n.to_string(), "{topic}");
        assert!(stdout.contains(&format!("{n} {topic}")), "{stdout}");
    }
    assert!(yaml.contains(&format!("  message_count: {}\n", messages.len())));
}

#[test]
fn an_existing_output_is_refused_without_force_and_a_file_name_is_not_a_bag() {
    let dir = temp_dir("ros2-bag-refused");
    let csv = dir.join("run.csv");
    std::fs::write(
        &csv,
        "t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,cmd_left_mps,cmd_right_mps\n\
         0.005,24.6,1.5,24.5,1.25,0.3,0.3\n\
         0.01,24.6,1.5,24.5,1.25,0.2,0.4\n",
    )
    .expect("csv");
    let convert = |out: &Path, extra: &[&str]| {
        host_tool()
            .arg("convert")
            .arg(&csv)
            .arg(out)
            .args(["--to", "ros2-bag"])
            .args(extra)
            .output()
            .expect("runs")
    };

    let bag = dir.join("bag");
    std::fs::create_dir(&bag).expect("dir");
    std::fs::write(bag.join("notes.txt"), "mine").expect("file");
    let refused = convert(&bag, &[]);
    assert_eq!(refused.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        stderr.contains("exists and is not empty (pass --force to replace it)"),
        "{stderr}"
    );
    assert_eq!(names(&bag), ["notes.txt"]);

    let replaced = convert(&bag, &["--force"]);
    assert!(
        replaced.status.success(),
        "{}",
        String::from_utf8_lossy(&replaced.stderr)
    );
    assert_eq!(names(&bag), ["bag_0.mcap", "metadata.yaml"]);
    let stdout = String::from_utf8_lossy(&replaced.stdout);
    assert!(
        stdout.ends_with("(ROS 2 bag): 2 /rover_power/sample, 2 /cmd_vel\n"),
        "{stdout}"
    );
    // A run CSV has no wall clock: said on stderr.
    let stderr = String::from_utf8_lossy(&replaced.stderr);
    assert!(stderr.contains("has no wall clock"), "{stderr}");

    for name in ["bag.mcap", "bag.csv"] {
        let out = dir.join(name);
        let e = convert(&out, &[]);
        assert_eq!(e.status.code(), Some(1));
        let stderr = String::from_utf8_lossy(&e.stderr);
        assert!(
            stderr.contains("--to ros2-bag writes a bag directory"),
            "{stderr}"
        );
        assert!(!out.exists());
    }
}

/// `validate --json -` of `runs`, parsed.
fn validate_json(runs: &Path) -> serde_json::Value {
    let done = host_tool()
        .args(["--quiet", "validate", "--runs"])
        .arg(runs)
        .args(["--json", "-"])
        .output()
        .expect("runs");
    assert!(
        done.status.success(),
        "{}: {}",
        runs.display(),
        String::from_utf8_lossy(&done.stderr)
    );
    serde_json::from_slice(&done.stdout).expect("json")
}

/// Issue 56: a user who keeps only the bag `convert --to ros2-bag` wrote can analyse it. The
/// bag directory and its MCAP file give `validate` the report the log gives (every turn's
/// power, energy and fit), but for the file's name and what only the board's wire frames tell
/// (the bag holds none, as a run CSV): the cross-check of the board's own model and the
/// count of samples lost on the wire.
#[test]
fn validate_reads_the_bag_as_it_reads_the_log() {
    let dir = temp_dir("ros2-bag-validate");
    let log = demo_once(&dir).join("run-1.mcap");
    let bag = dir.join("drive");
    convert_to_bag(&log, &bag);

    let mut expected = validate_json(&log);
    let runs = expected["runs"].as_array_mut().expect("runs");
    assert_eq!(runs.len(), 1);
    let run = &mut runs[0];
    assert!(run["cross_check"].is_object(), "{run}");
    assert_eq!(run["lost_samples"], 0, "{run}");
    run["cross_check"] = serde_json::Value::Null;
    run["lost_samples"] = serde_json::Value::Null;
    let expected = expected.to_string();
    assert!(expected.contains("energy_j"), "{expected}");
    let name = serde_json::Value::from(log.display().to_string()).to_string();
    for runs in [bag.clone(), bag.join("drive_0.mcap")] {
        let shown = serde_json::Value::from(runs.display().to_string()).to_string();
        let report = validate_json(&runs).to_string().replace(&shown, &name);
        assert!(
            report == expected,
            "{}:\n{report}\n!=\n{expected}",
            runs.display()
        );
    }
}
