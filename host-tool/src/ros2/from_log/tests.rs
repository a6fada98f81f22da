use super::*;
use crate::log::mcap::{write_mcap_run, TOPIC_EVENT};
use crate::log::tests_support::TempDir;
use crate::ros2::cdr::CdrReader;
use crate::ros2::msgs::{decode_imu, decode_pose, decode_twist, yaw_pitch_of};
use std::collections::BTreeMap;
use std::io::Cursor;

const UNIX_NS: u64 = 1_764_000_000_123_456_789;
const HUSKY: BagOptions = BagOptions { slip_track_m: 1.1 };

/// A run of `n` samples at 100 Hz from 0.25 s: the commanded speeds change every 20 samples,
/// yaw on two samples in three, pitch on every other, a tracker fix every 10; events.
fn run(n: u32, clock_at: Option<f64>) -> RunLog {
    let samples = (0..n)
        .map(|i| {
            let t = f64::from(i);
            let step = f64::from(i / 20);
            RunSample {
                t_s: 0.25 + t * 0.01,
                bus_v: Sides::new(24.6 - 0.001 * t, 24.5),
                current_a: Sides::new(3.0 + (t * 0.1).sin(), 2.5),
                cmd_mps: Sides::new(0.3 - 0.1 * step, 0.3 + 0.1 * step),
                yaw_rad: (i % 3 != 0).then_some(0.01 * t),
                pitch_deg: (i % 2 == 0).then_some(-2.5),
                x_m: (i % 10 == 0).then_some(0.03 * t),
                y_m: (i % 10 == 0).then_some(-0.01 * t),
            }
        })
        .collect();
    let mut events = vec![
        (0.0, LogEvent::Started { port: "sim".into() }),
        (
            0.5,
            LogEvent::SamplesLost {
                after_seq: 20,
                missing: 3,
            },
        ),
        (
            0.9,
            LogEvent::Stopped {
                reason: "duration".into(),
            },
        ),
    ];
    if let Some(t) = clock_at {
        events.push((t, LogEvent::WallClock { unix_ns: UNIX_NS }));
        events.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    RunLog {
        samples,
        events,
        ..RunLog::default()
    }
}

/// Messages of `topic` in an MCAP file: (log time, data).
fn messages(bytes: &[u8], topic: &str) -> Vec<(u64, Vec<u8>)> {
    mcap::MessageStream::new(bytes)
        .expect("mcap")
        .map(|m| m.expect("message"))
        .filter(|m| m.channel.topic == topic)
        .map(|m| (m.log_time, m.data.into_owned()))
        .collect()
}

fn bag_of(run: &RunLog) -> (TempDir, BagWritten, Vec<u8>) {
    let dir = TempDir::new("ros2-bag");
    let bag = write_bag(dir.path(), "bag", run, &HUSKY).expect("bag");
    let bytes = std::fs::read(&bag.mcap).expect("mcap");
    (dir, bag, bytes)
}

fn log_times(messages: &[(u64, Vec<u8>)]) -> Vec<u64> {
    messages.iter().map(|m| m.0).collect()
}

/// The bag's log times are the MCAP log's, whichever clock the MCAP sink chose.
#[test]
fn log_times_are_the_mcap_logs() {
    let many_before = |n: usize| {
        let mut r = run(30, None);
        let bad = (0.0, LogEvent::BadFrames { count: 1 });
        let clock = (0.0, LogEvent::WallClock { unix_ns: UNIX_NS });
        r.events = std::iter::repeat_n(bad, n)
            .chain([clock])
            .chain(r.events)
            .collect();
        r
    };
    let cases = [
        ("anchor before the first sample", run(120, Some(0.25)), true),
        ("no wall clock", run(120, None), false),
        ("anchor after the first sample", run(120, Some(0.3)), false),
        ("held up to the limit", many_before(HELD_MAX), true),
        ("held past the limit", many_before(HELD_MAX + 1), false),
    ];
    for (what, run, unix) in cases {
        let mcap = write_mcap_run(Cursor::new(Vec::new()), &run)
            .expect("mcap log")
            .into_inner();
        let (_dir, bag, bytes) = bag_of(&run);
        assert_eq!(
            matches!(bag.clock, LogClock::Unix { .. }),
            unix,
            "{what}: {:?}",
            bag.clock
        );
        // The log's samples come in batches on one clock: log time = publish time + offset.
        let offsets: Vec<i128> = mcap::MessageStream::new(&mcap)
            .expect("mcap")
            .map(|m| m.expect("message"))
            .filter(|m| m.channel.topic == crate::log::mcap::TOPIC_SAMPLE_BATCH)
            .map(|m| i128::from(m.log_time) - i128::from(m.publish_time))
            .collect();
        assert!(offsets.windows(2).all(|w| w[0] == w[1]), "{what}");
        let in_log: Vec<u64> = run
            .samples
            .iter()
            .map(|s| (offsets[0] + (s.t_s * 1e9).round() as i128) as u64)
            .collect();
        assert_eq!(log_times(&messages(&bytes, TOPIC_SAMPLE)), in_log, "{what}");
        assert_eq!(
            log_times(&messages(&bytes, TOPIC_ROSOUT)),
            log_times(&messages(&mcap, TOPIC_EVENT)),
            "{what}: events"
        );
    }
}

#[test]
fn every_topic_decodes_to_the_logs_values() {
    let run = run(120, Some(0.0));
    let (dir, bag, bytes) = bag_of(&run);
    let zero = i128::from(UNIX_NS);
    assert_eq!(
        bag.clock,
        LogClock::Unix {
            unix_ns_at_run_zero: zero
        }
    );

    let samples = messages(&bytes, TOPIC_SAMPLE);
    assert_eq!(samples.len(), run.samples.len());
    for ((log_time, data), s) in samples.iter().zip(&run.samples) {
        assert_eq!(i128::from(*log_time), zero + (s.t_s * 1e9).round() as i128);
        let mut r = CdrReader::new(data).expect("cdr");
        let stamp = i64::from(r.i32("sec").expect("decodes")) * 1_000_000_000
            + i64::from(r.u32("nanosec").expect("decodes"));
        assert_eq!(stamp as u64, *log_time);
        let mut next = || r.f64("field").expect("decodes");
        let got = [(); 11].map(|()| next());
        let nan = f64::NAN;
        let want = [
            s.bus_v.left,
            s.current_a.left,
            s.bus_v.right,
            s.current_a.right,
            s.cmd_mps.left,
            s.cmd_mps.right,
            s.yaw_rad.unwrap_or(nan),
            s.pitch_deg.unwrap_or(nan),
            s.x_m.unwrap_or(nan),
            s.y_m.unwrap_or(nan),
            s.t_s,
        ];
        for (g, w) in got.iter().zip(want) {
            assert!(g.to_bits() == w.to_bits(), "{got:?} vs {want:?}");
        }
    }

    let cmd = messages(&bytes, TOPIC_CMD_VEL);
    let changes: Vec<&RunSample> = run
        .samples
        .iter()
        .enumerate()
        .filter(|(i, s)| *i == 0 || run.samples[i - 1].cmd_mps != s.cmd_mps)
        .map(|(_, s)| s)
        .collect();
    assert_eq!(cmd.len(), 6);
    assert_eq!(cmd.len(), changes.len());
    for ((log_time, data), s) in cmd.iter().zip(changes) {
        let twist = decode_twist(StdType::Twist, data).expect("twist");
        let l = s.cmd_mps.left;
        let r = s.cmd_mps.right;
        assert_eq!(
            (twist.linear_x, twist.angular_z),
            ((l + r) / 2.0, (r - l) / 1.1)
        );
        assert_eq!(i128::from(*log_time), zero + (s.t_s * 1e9).round() as i128);
    }

    let imu = messages(&bytes, TOPIC_IMU);
    let with_yaw: Vec<&RunSample> = run.samples.iter().filter(|s| s.yaw_rad.is_some()).collect();
    assert_eq!(imu.len(), with_yaw.len());
    for ((_, data), s) in imu.iter().zip(with_yaw) {
        let (yaw, pitch) = yaw_pitch_of(decode_imu(data).expect("imu").orientation);
        assert!((yaw - s.yaw_rad.expect("yaw")).abs() < 1e-12);
        assert!((pitch - s.pitch_deg.unwrap_or(0.0)).abs() < 1e-9);
    }

    let poses = messages(&bytes, TOPIC_TRACKER_POSE);
    let fixes: Vec<&RunSample> = run.samples.iter().filter(|s| s.x_m.is_some()).collect();
    assert_eq!(poses.len(), fixes.len());
    for ((_, data), s) in poses.iter().zip(fixes) {
        let pose = decode_pose(StdType::PoseStamped, data).expect("pose");
        assert_eq!((pose.x_m, pose.y_m), (s.x_m.expect("x"), s.y_m.expect("y")));
    }

    let lines = messages(&bytes, TOPIC_ROSOUT);
    let levels: Vec<(u8, String)> = lines
        .iter()
        .map(|(_, data)| {
            let mut r = CdrReader::new(data).expect("cdr");
            r.i32("sec").expect("decodes");
            r.u32("nanosec").expect("decodes");
            let level = r.u8("level").expect("decodes");
            assert_eq!(r.string("name").expect("decodes"), LOGGER_NAME);
            (level, r.string("msg").expect("decodes").to_owned())
        })
        .collect();
    assert_eq!(
        levels.iter().map(|l| l.0).collect::<Vec<_>>(),
        [20, 20, 30, 20],
        "{levels:?}"
    );
    assert_eq!(levels[2].1, "3 samples lost after sample 20");

    // The summary, metadata.yaml and the MCAP channels agree.
    let counts: BTreeMap<&str, u64> = bag.topics.iter().map(|(t, n)| (t.as_str(), *n)).collect();
    assert_eq!(
        counts,
        BTreeMap::from([
            (TOPIC_SAMPLE, 120),
            (TOPIC_CMD_VEL, 6),
            (TOPIC_IMU, 80),
            (TOPIC_TRACKER_POSE, 12),
            (TOPIC_ROSOUT, 4),
        ])
    );
    let yaml = std::fs::read_to_string(dir.path().join("metadata.yaml")).expect("yaml");
    for (topic, n) in &bag.topics {
        let at = yaml
            .find(&format!("name: \"{topic}\""))
            .unwrap_or_else(|| panic!("{topic} in {yaml}"));
        let count = yaml[at..]
            .lines()
            .find_map(|l| l.trim().strip_prefix("message_count: "))
            .expect("count");
        assert_eq!(count, n.to_string(), "{topic}");
    }
    assert!(yaml.contains("relative_file_paths:\n    - \"bag_0.mcap\"\n"));
    assert!(yaml.contains(&format!("message_count: {}\n", 120 + 6 + 80 + 12 + 4)));
}

#[test]
fn the_bag_is_a_ros2_mcap_with_our_definitions_and_one_qos_text() {
    let (dir, _, bytes) = bag_of(&run(30, Some(0.0)));
    let header = mcap::read::LinearReader::new(&bytes)
        .expect("mcap")
        .next()
        .expect("a record")
        .expect("header");
    let mcap::records::Record::Header(header) = header else {
        panic!("{header:?}");
    };
    assert_eq!(header.profile, "ros2");
    let yaml = std::fs::read_to_string(dir.path().join("metadata.yaml")).expect("yaml");
    let summary = mcap::read::Summary::read(&bytes)
        .expect("summary")
        .expect("a summary");
    assert_eq!(summary.channels.len(), 5);
    for channel in summary.channels.values() {
        assert_eq!(channel.message_encoding, "cdr");
        let schema = channel.schema.as_ref().expect("schema");
        assert_eq!(schema.encoding, "ros2msg");
        // metadata.yaml holds the channel's QoS text as a YAML string.
        let qos = &channel.metadata["offered_qos_profiles"];
        let quoted = format!(
            "offered_qos_profiles: \"{}\"",
            qos.replace('\n', "\\n").replace('"', "\\\"")
        );
        assert!(yaml.contains(&quoted), "{quoted} in {yaml}");
        if channel.topic == TOPIC_SAMPLE {
            assert_eq!(schema.name, SAMPLE_TYPE);
            assert_eq!(&schema.data[..], sample_definition().as_bytes());
        } else {
            let ty = StdType::named(&schema.name).expect("a standard type");
            assert_eq!(&schema.data[..], ty.definition().as_bytes());
        }
    }
}

#[test]
fn the_sample_definition_lists_the_fields_in_message_order() {
    let text = sample_definition();
    let (top, nested) = text.split_once(&"=".repeat(80)).expect("nested Time");
    let fields: Vec<&str> = top
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty())
        .collect();
    assert_eq!(
        fields,
        [
            "builtin_interfaces/Time stamp",
            "float64 left_bus_v",
            "float64 left_current_a",
            "float64 right_bus_v",
            "float64 right_current_a",
            "float64 cmd_left_mps",
            "float64 cmd_right_mps",
            "float64 yaw_rad",
            "float64 pitch_deg",
            "float64 x_m",
            "float64 y_m",
            "float64 t_s",
        ]
    );
    // `MSG: pkg/Type` as rosbag2 writes it: Foxglove resolves no `pkg/msg/Type` separator.
    assert_eq!(
        nested,
        "\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
    );
    assert_eq!(
        crate::ros2::msgs::tests::unresolved_types(&text),
        Vec::<String>::new()
    );
}

#[test]
fn save_bag_writes_the_directory_whole_and_refuses_a_non_empty_one() {
    let dir = TempDir::new("ros2-save");
    let out = dir.path().join("drive");
    let run = run(10, None);
    let bag = save_bag(&out, false, &run, &HUSKY).expect("bag");
    assert_eq!(bag.mcap, out.join("drive_0.mcap"));
    assert_eq!(bag.clock, LogClock::RunTime);
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["drive_0.mcap", "metadata.yaml"]);
    let e = save_bag(&out, false, &run, &HUSKY).expect_err("exists");
    assert!(e.to_string().contains("--force"), "{e}");
    save_bag(&out, true, &run, &HUSKY).expect("replaced");
    assert_eq!(dir.entries(), ["drive"]);
}

#[test]
fn negative_run_times_without_a_wall_clock_are_refused() {
    let mut run = run(10, None);
    run.samples[0].t_s = -0.5;
    let dir = TempDir::new("ros2-negative");
    let e = save_bag(&dir.path().join("bag"), false, &run, &HUSKY).expect_err("negative");
    assert!(e.to_string().contains("run time -0.5 s"), "{e}");
    assert_eq!(dir.entries(), Vec::<String>::new());
}

/// Issue 56: the bag is a run log too. Its directory (and its MCAP file) loads as the samples
/// it was written from, bit for bit, NaN back to "not measured".
#[test]
fn the_bag_loads_as_the_run_it_was_written_from() {
    let run = run(250, Some(0.1));
    let (dir, bag, _) = bag_of(&run);
    for path in [dir.path(), bag.mcap.as_path()] {
        let loaded = crate::log::load::load(path).expect("loads");
        assert_eq!(loaded.run.samples, run.samples, "{}", path.display());
        assert!(loaded.losses.is_empty() && loaded.truncated.is_none());
    }
}

/// Another type on our sample topic is refused by its name, not misread; a sample message cut
/// short is a loss, not a panic.
#[test]
fn a_foreign_type_on_the_sample_topic_is_refused_and_a_cut_message_is_a_loss() {
    let dir = TempDir::new("ros2-foreign-sample");
    let mut bag = BagWriter::create(dir.path(), "b").expect("create");
    let twist = StdType::Twist;
    let channel = bag
        .topic(TOPIC_SAMPLE, twist.name(), &twist.definition())
        .expect("topic");
    bag.write(channel, 1, &encode_twist(0.1, 0.2))
        .expect("write");
    bag.finish(dir.path()).expect("finish");
    let e = crate::log::load::load(dir.path()).expect_err("foreign");
    assert!(
        e.to_string().contains(
            "holds `geometry_msgs/msg/Twist` messages; this tool reads `rover_power/msg/Sample`"
        ),
        "{e}"
    );

    let dir = TempDir::new("ros2-cut-sample");
    let mut bag = BagWriter::create(dir.path(), "b").expect("create");
    let channel = bag
        .topic(TOPIC_SAMPLE, SAMPLE_TYPE, &sample_definition())
        .expect("topic");
    let mut samples = run(3, None).samples;
    // Beyond the board's ±40.96 A but physical: a bag may hold another rig's run CSV.
    samples[2].current_a.left = 150.0;
    for (i, s) in samples.iter().enumerate() {
        let mut cdr = encode_sample(i as i64, s);
        if i == 1 {
            cdr.truncate(50);
        }
        bag.write(channel, i as u64, &cdr).expect("write");
    }
    bag.finish(dir.path()).expect("finish");
    let loaded = crate::log::load::load(dir.path()).expect("salvaged");
    assert_eq!(loaded.run.samples, [samples[0], samples[2]]);
    assert_eq!(loaded.losses.len(), 1, "{:?}", loaded.losses);
    assert!(
        loaded.losses[0].detail.contains("inside `"),
        "{}",
        loaded.losses[0]
    );
}
