//! The bag reader on bags a third-party writer made (`rosbags` 0.11.9 from PyPI;
//! tests/fixtures/ros2/make_fixtures.py, committed with its output): every message of every
//! supported topic decodes to the values the script wrote (expected.json), whether the bag is
//! MCAP or sqlite3, one file or split, compressed or not; unread storage or compression and
//! wrong types are refused with what is wrong.

use host_tool::ros2::msgs::yaw_pitch_of;
use host_tool::ros2::read::{read_bag, BagReadError, BagTopics, RobotBag};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/ros2")
}

fn expected() -> Value {
    let text = std::fs::read_to_string(fixtures().join("expected.json")).expect("expected.json");
    serde_json::from_str(&text).expect("JSON")
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn ints(v: &Value) -> Vec<u64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_u64().expect("integer"))
        .collect()
}

fn topics(cmd: &str, pose: &str) -> BagTopics {
    BagTopics {
        cmd: cmd.into(),
        imu: Some(("/imu/data".into(), false)),
        pose: Some(pose.into()),
    }
}

/// Checks that `bag` holds exactly the messages husky-drive's expected.json lists for
/// `cmd_topic`, the IMU (when `imu`) and `pose_topic`.
fn assert_drive(bag: &RobotBag, cmd_topic: &str, imu: bool, pose_topic: &str, what: &str) {
    let all = expected();
    let want = &all["husky-drive"];
    let w = &want[cmd_topic];
    assert_eq!(
        bag.cmd.len() as u64,
        w["count"].as_u64().expect("present"),
        "{what}"
    );
    let times: Vec<u64> = bag.cmd.iter().map(|m| m.0).collect();
    assert_eq!(times, ints(&w["log_time_ns"]), "{what}");
    let lin: Vec<f64> = bag.cmd.iter().map(|m| m.1.linear_x).collect();
    let ang: Vec<f64> = bag.cmd.iter().map(|m| m.1.angular_z).collect();
    assert_eq!(lin, floats(&w["linear_x"]), "{what}");
    assert_eq!(ang, floats(&w["angular_z"]), "{what}");
    if let Some(stamps) = w.get("stamp_ns") {
        let got: Vec<u64> = bag
            .cmd
            .iter()
            .map(|m| m.1.stamp_ns.expect("present") as u64)
            .collect();
        assert_eq!(got, ints(stamps), "{what}");
    }

    if imu {
        let w = &want["/imu/data"];
        assert_eq!(
            bag.imu.iter().map(|m| m.0).collect::<Vec<_>>(),
            ints(&w["log_time_ns"]),
            "{what}"
        );
        let (yaw, pitch) = (floats(&w["yaw_rad"]), floats(&w["pitch_deg"]));
        for (i, (_, m)) in bag.imu.iter().enumerate() {
            let (y, p) = yaw_pitch_of(m.orientation);
            assert!(
                (y - yaw[i]).abs() < 1e-9,
                "{what}: imu {i}: yaw {y} vs {}",
                yaw[i]
            );
            assert!(
                (p - pitch[i]).abs() < 1e-7,
                "{what}: imu {i}: pitch {p} vs {}",
                pitch[i]
            );
            assert_eq!(m.stamp_ns as u64, ints(&w["stamp_ns"])[i], "{what}");
        }
    }

    let w = &want[pose_topic];
    assert_eq!(
        bag.pose.iter().map(|m| m.0).collect::<Vec<_>>(),
        ints(&w["log_time_ns"]),
        "{what}"
    );
    assert_eq!(
        bag.pose.iter().map(|m| m.1.x_m).collect::<Vec<_>>(),
        floats(&w["x_m"]),
        "{what}"
    );
    assert_eq!(
        bag.pose.iter().map(|m| m.1.y_m).collect::<Vec<_>>(),
        floats(&w["y_m"]),
        "{what}"
    );
    let yaw = floats(&w["yaw_rad"]);
    for (i, (_, m)) in bag.pose.iter().enumerate() {
        assert!(
            (yaw_pitch_of(m.orientation).0 - yaw[i]).abs() < 1e-9,
            "{what}"
        );
    }
}

#[test]
fn every_message_of_a_rosbags_bag_decodes_to_what_was_written() {
    for (cmd_topic, pose_topic) in [
        ("/cmd_vel", "/odometry/filtered"),
        ("/cmd_vel_stamped", "/tracker/pose"),
    ] {
        // The directory and the MCAP file itself both open.
        for path in [
            fixtures().join("husky-drive"),
            fixtures().join("husky-drive/husky-drive.mcap"),
        ] {
            let bag = read_bag(&path, &topics(cmd_topic, pose_topic)).expect("reads");
            assert_drive(
                &bag,
                cmd_topic,
                true,
                pose_topic,
                &path.display().to_string(),
            );
        }
    }
}

/// The bags robots write: sqlite3 storage, split in two files, compressed per message and per
/// file. Each holds some of husky-drive's topics (expected.json) and reads to exactly its
/// messages, from the directory and (one-file bags) from the storage file itself.
#[test]
fn sqlite3_split_and_compressed_bags_read_the_same_messages_as_the_plain_one() {
    let all = expected();
    let kinds = [
        ("husky-drive-db3", Some("husky-drive-db3.db3")),
        ("husky-drive-split", None),
        (
            "husky-drive-zstd-message",
            Some("husky-drive-zstd-message.mcap"),
        ),
        (
            "husky-drive-zstd-file",
            Some("husky-drive-zstd-file.db3.zstd"),
        ),
    ];
    for (name, file) in kinds {
        assert_eq!(all[name]["same_as"], "husky-drive", "{name}");
        let has: Vec<&str> = all[name]["topics"]
            .as_array()
            .expect("topics")
            .iter()
            .map(|t| t.as_str().expect("topic"))
            .collect();
        let imu = has.contains(&"/imu/data");
        let mut read = 0;
        for (cmd_topic, pose_topic) in [
            ("/cmd_vel", "/odometry/filtered"),
            ("/cmd_vel_stamped", "/tracker/pose"),
        ] {
            if !has.contains(&cmd_topic) || !has.contains(&pose_topic) {
                continue;
            }
            let wanted = BagTopics {
                cmd: cmd_topic.into(),
                imu: imu.then(|| ("/imu/data".into(), false)),
                pose: Some(pose_topic.into()),
            };
            let mut paths = vec![fixtures().join(name)];
            paths.extend(file.map(|f| fixtures().join(name).join(f)));
            for path in paths {
                let what = path.display().to_string();
                let bag = read_bag(&path, &wanted).unwrap_or_else(|e| panic!("{what}: {e}"));
                assert_drive(&bag, cmd_topic, imu, pose_topic, &what);
                read += 1;
            }
        }
        assert!(read > 0, "{name}: no topic pair read");
    }
}

/// A split bag's files are each read: with the second one missing, the error says which.
#[test]
fn a_split_bag_missing_a_file_names_it() {
    let dir = std::env::temp_dir().join(format!("ros2-split-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    for f in ["metadata.yaml", "husky-drive-split_0.mcap"] {
        std::fs::copy(fixtures().join("husky-drive-split").join(f), dir.join(f)).expect("copy");
    }
    let e = read_bag(&dir, &topics("/cmd_vel", "/odometry/filtered")).expect_err("refused");
    assert!(
        matches!(&e, BagReadError::MissingFiles { missing, .. } if missing == &["husky-drive-split_1.mcap"]),
        "{e}"
    );
    // The first half alone, read as its file: half the drive.
    let bag = read_bag(
        &dir.join("husky-drive-split_0.mcap"),
        &topics("/cmd_vel", "/odometry/filtered"),
    )
    .expect("reads");
    assert_eq!(bag.cmd.len(), 30);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Compression this reader does not know is refused naming its mode and format.
#[test]
fn an_unknown_compression_is_refused_naming_mode_and_format() {
    let dir = std::env::temp_dir().join(format!("ros2-bz2-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    let yaml =
        std::fs::read_to_string(fixtures().join("husky-drive/metadata.yaml")).expect("metadata");
    let yaml = yaml
        .replace("compression_format: ''", "compression_format: bz2")
        .replace("compression_mode: ''", "compression_mode: MESSAGE");
    std::fs::write(dir.join("metadata.yaml"), yaml).expect("write");
    std::fs::copy(
        fixtures().join("husky-drive/husky-drive.mcap"),
        dir.join("husky-drive.mcap"),
    )
    .expect("copy");
    let e = read_bag(&dir, &topics("/cmd_vel", "/odometry/filtered")).expect_err("refused");
    assert_eq!(
        e.to_string(),
        format!(
            "{}: compression mode `message` with format `bz2` is not read here, only none, and \
             `message` or `file` with `zstd` or `lz4`",
            dir.display()
        )
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_unread_storage_and_wrong_types_are_refused_with_what_is_wrong() {
    // The one-second sqlite3 bag (with its message definitions) reads as the drive's start.
    let t = topics("/cmd_vel", "/tracker/pose");
    let bag = read_bag(&fixtures().join("husky-drive-sqlite3"), &t).expect("reads");
    let w = &expected()["husky-drive-sqlite3"];
    assert_eq!(
        bag.cmd.iter().map(|m| m.0).collect::<Vec<_>>(),
        ints(&w["/cmd_vel"]["log_time_ns"])
    );
    assert_eq!(
        bag.imu.len() as u64,
        w["/imu/data"]["count"].as_u64().expect("count")
    );

    let dir = std::env::temp_dir().join(format!("ros2-storage-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    let yaml = std::fs::read_to_string(fixtures().join("husky-drive/metadata.yaml"))
        .expect("metadata")
        .replace("storage_identifier: mcap", "storage_identifier: cassandra");
    std::fs::write(dir.join("metadata.yaml"), yaml).expect("write");
    let e = read_bag(&dir, &t).expect_err("refused");
    assert!(
        matches!(e, BagReadError::Storage { ref storage, .. } if storage == "cassandra"),
        "{e}"
    );
    assert!(e.to_string().contains("only MCAP and sqlite3"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);

    let t = BagTopics { pose: None, ..t };
    let e = read_bag(&fixtures().join("wrong-type"), &t).expect_err("refused");
    let text = e.to_string();
    assert!(matches!(e, BagReadError::WrongType { .. }), "{text}");
    assert!(
        text.contains("/imu/data")
            && text.contains("std_msgs/msg/String")
            && text.contains("sensor_msgs/msg/Imu"),
        "{text}"
    );

    // A topic the bag lacks names the topics it has.
    let t = BagTopics {
        cmd: "/teleop/cmd_vel".into(),
        imu: None,
        pose: None,
    };
    let e = read_bag(&fixtures().join("husky-drive"), &t).expect_err("refused");
    let text = e.to_string();
    assert!(
        text.contains("/teleop/cmd_vel") && text.contains("/cmd_vel_stamped"),
        "{text}"
    );
}

/// The bounded fuzz of the bag reader: every fixture kind (MCAP, sqlite3, split, compressed per
/// message and per file), one of its files damaged by byte flips, truncation or inserted bytes.
/// Each read succeeds or fails with one plain line naming a file of the bag, never a panic (CI
/// runs it longer under a 2 GB address limit, so an unbounded allocation aborts it:
/// `BAG_FUZZ_CASES`, `FUZZ_SEED`; the failing case prints its seed and mutation).
#[test]
fn mutated_bags_are_refused_in_one_line_never_panicked_on() {
    let cases: u64 = std::env::var("BAG_FUZZ_CASES")
        .map(|n| n.parse().expect("BAG_FUZZ_CASES: a count"))
        .unwrap_or(150);
    let seed: u64 = std::env::var("FUZZ_SEED")
        .map(|n| n.parse().expect("FUZZ_SEED: a number"))
        .unwrap_or(1128);
    let bags = [
        ("husky-drive", "/cmd_vel", "/odometry/filtered"),
        ("husky-drive-db3", "/cmd_vel_stamped", "/tracker/pose"),
        ("husky-drive-split", "/cmd_vel", "/odometry/filtered"),
        ("husky-drive-zstd-message", "/cmd_vel", "/odometry/filtered"),
        ("husky-drive-zstd-file", "/cmd_vel", "/odometry/filtered"),
    ];
    let root = std::env::temp_dir().join(format!("ros2-fuzz-{}", std::process::id()));
    let mut state = seed ^ 0x2026_1129;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as usize
    };
    let mut refused = 0;
    for case in 0..cases {
        let (name, cmd, pose) = bags[case as usize % bags.len()];
        let dir = root.join(name);
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        let mut files: Vec<String> = std::fs::read_dir(fixtures().join(name))
            .expect("fixture")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        files.sort();
        for f in &files {
            std::fs::copy(fixtures().join(name).join(f), dir.join(f)).expect("copy");
        }
        // A storage file, or now and then the metadata.
        let storage: Vec<&String> = files.iter().filter(|f| *f != "metadata.yaml").collect();
        let target = if next() % 10 == 0 {
            "metadata.yaml"
        } else {
            storage[next() % storage.len()].as_str()
        };
        let mut bytes = std::fs::read(dir.join(target)).expect("read");
        let at = next() % bytes.len();
        let mutation = match next() % 3 {
            0 => {
                let flips = 1 + next() % 4;
                let mut done = Vec::new();
                for _ in 0..flips {
                    let at = next() % bytes.len();
                    let mask = 1 + (next() % 255) as u8;
                    bytes[at] ^= mask;
                    done.push(format!("byte {at} ^= {mask:#04x}"));
                }
                done.join(", ")
            }
            1 => {
                bytes.truncate(at);
                format!("truncated to {at} bytes")
            }
            _ => {
                let n = 1 + next() % 16;
                // Runs of 0xff (huge lengths) or random bytes.
                let inserted: Vec<u8> = (0..n)
                    .map(|_| if next() % 2 == 0 { 0xff } else { next() as u8 })
                    .collect();
                bytes.splice(at..at, inserted.iter().copied());
                format!("{inserted:02x?} inserted at byte {at}")
            }
        };
        std::fs::write(dir.join(target), &bytes).expect("write");
        let what = format!("FUZZ_SEED={seed} case {case}: {name}/{target}: {mutation}");
        let wanted = BagTopics {
            cmd: cmd.into(),
            imu: None,
            pose: Some(pose.into()),
        };
        let result = std::panic::catch_unwind(|| read_bag(&dir, &wanted).map(|b| b.cmd.len()));
        match result {
            Err(_) => panic!("the reader panicked: {what}"),
            Ok(Ok(_)) => {}
            Ok(Err(e)) => {
                refused += 1;
                let text = host_tool::stderr::error_text(&anyhow::Error::new(e));
                assert!(
                    text.starts_with(&dir.display().to_string()),
                    "{what}: {text:?}"
                );
                assert!(
                    !text.contains('\x1b') && !text.contains(".rs:") && !text.contains('\n'),
                    "{what}: {text:?}"
                );
            }
        }
    }
    let _ = std::fs::remove_dir_all(&root);
    // Most mutations are damage the reader sees; a fuzz refusing nothing tests nothing.
    assert!(refused * 4 > cases, "only {refused} of {cases} refused");
}
