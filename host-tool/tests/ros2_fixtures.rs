//! The bag reader on bags a third-party writer made (`rosbags` 0.11.9 from PyPI;
//! tests/fixtures/ros2/make_fixtures.py, committed with its output): every message of every
//! supported topic decodes to the values the script wrote (expected.json), and unsupported
//! storage and wrong types are refused with what is wrong.

use host_tool::ros2::msgs::yaw_pitch_of;
use host_tool::ros2::read::{read_bag, BagReadError, BagTopics};
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

#[test]
fn every_message_of_a_rosbags_bag_decodes_to_what_was_written() {
    let all = expected();
    let want = &all["husky-drive"];
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
            let w = &want[cmd_topic];
            assert_eq!(bag.cmd.len() as u64, w["count"].as_u64().expect("present"));
            let times: Vec<u64> = bag.cmd.iter().map(|m| m.0).collect();
            assert_eq!(times, ints(&w["log_time_ns"]));
            let lin: Vec<f64> = bag.cmd.iter().map(|m| m.1.linear_x).collect();
            let ang: Vec<f64> = bag.cmd.iter().map(|m| m.1.angular_z).collect();
            assert_eq!(lin, floats(&w["linear_x"]));
            assert_eq!(ang, floats(&w["angular_z"]));
            if let Some(stamps) = w.get("stamp_ns") {
                let got: Vec<u64> = bag
                    .cmd
                    .iter()
                    .map(|m| m.1.stamp_ns.expect("present") as u64)
                    .collect();
                assert_eq!(got, ints(stamps));
            }

            let w = &want["/imu/data"];
            assert_eq!(
                bag.imu.iter().map(|m| m.0).collect::<Vec<_>>(),
                ints(&w["log_time_ns"])
            );
            let (yaw, pitch) = (floats(&w["yaw_rad"]), floats(&w["pitch_deg"]));
            for (i, (_, m)) in bag.imu.iter().enumerate() {
                let (y, p) = yaw_pitch_of(m.orientation);
                assert!((y - yaw[i]).abs() < 1e-9, "imu {i}: yaw {y} vs {}", yaw[i]);
                assert!(
                    (p - pitch[i]).abs() < 1e-7,
                    "imu {i}: pitch {p} vs {}",
                    pitch[i]
                );
                assert_eq!(m.stamp_ns as u64, ints(&w["stamp_ns"])[i]);
            }

            let w = &want[pose_topic];
            assert_eq!(
                bag.pose.iter().map(|m| m.0).collect::<Vec<_>>(),
                ints(&w["log_time_ns"])
            );
            assert_eq!(
                bag.pose.iter().map(|m| m.1.x_m).collect::<Vec<_>>(),
                floats(&w["x_m"])
            );
            assert_eq!(
                bag.pose.iter().map(|m| m.1.y_m).collect::<Vec<_>>(),
                floats(&w["y_m"])
            );
            let yaw = floats(&w["yaw_rad"]);
            for (i, (_, m)) in bag.pose.iter().enumerate() {
                assert!((yaw_pitch_of(m.orientation).0 - yaw[i]).abs() < 1e-9);
            }
        }
    }
}

#[test]
fn sqlite3_storage_and_wrong_types_are_refused_with_what_is_wrong() {
    let t = topics("/cmd_vel", "/tracker/pose");
    let e = read_bag(&fixtures().join("husky-drive-sqlite3"), &t).expect_err("refused");
    assert!(
        matches!(e, BagReadError::Storage { ref storage, .. } if storage == "sqlite3"),
        "{e}"
    );
    assert!(e.to_string().contains("ros2 bag convert"), "{e}");
    let e = read_bag(
        &fixtures().join("husky-drive-sqlite3/husky-drive-sqlite3.db3"),
        &t,
    )
    .expect_err("refused");
    assert!(matches!(e, BagReadError::Storage { .. }), "{e}");

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

/// Damaged bags never panic the reader: each of 300 truncations and 300 byte flips of the
/// fixture reads or is refused with an error (seeded; the failing mutation is printed).
#[test]
fn damaged_bags_are_refused_not_panicked_on() {
    let original = std::fs::read(fixtures().join("husky-drive/husky-drive.mcap")).expect("fixture");
    let dir = std::env::temp_dir().join(format!("ros2-damaged-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("present");
    let path = dir.join("damaged.mcap");
    let topics = topics("/cmd_vel", "/odometry/filtered");
    let mut state = 0x2026_1129_u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as usize
    };
    for i in 0..600 {
        let mut bytes = original.clone();
        let what = if i < 300 {
            let at = next() % bytes.len();
            bytes.truncate(at);
            format!("truncated at {at}")
        } else {
            let at = next() % bytes.len();
            let bit = next() % 8;
            bytes[at] ^= 1 << bit;
            format!("bit {bit} of byte {at} flipped")
        };
        std::fs::write(&path, &bytes).expect("present");
        let result = std::panic::catch_unwind(|| read_bag(&path, &topics).map(|b| b.cmd.len()));
        assert!(
            result.is_ok(),
            "the reader panicked on the fixture with {what}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
