use super::*;
use crate::decode::{Event, StreamDecoder};
use crate::log::run_log::RunLogSink;
use crate::log::tests_support::TempDir;
use crate::sim::board::{SideLoad, SimBoard};
use firmware::sampler::SamplerConfig;
use model_core::ina226::Scale;
use model_core::wire::BoardFrame;
use proptest::prelude::*;
use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::Path;

/// A run time of whole nanoseconds (what an MCAP log time holds exactly).
fn ns(ns: u64) -> f64 {
    ns as f64 / 1e9
}

/// The bytes a simulated board sends over `steps` periods (a hello, samples, model and status
/// frames), and the run a recorder would log from them: every frame at the run time it
/// arrived (its sample period), the physical samples, two commands and some events.
pub(crate) fn sim_run(steps: u64) -> (RunLog, Vec<u8>) {
    let mut sim = SimBoard::new(SamplerConfig::BOARD);
    sim.set_host_connected(true);
    sim.set_load(|t_us: u64| {
        let t = t_us as f64 * 1e-6;
        Sides::new(
            SideLoad {
                current_a: 2.0 * (t * 3.0).sin() - 0.4,
                bus_v: 24.6,
            },
            SideLoad {
                current_a: 4.0 + 0.5 * (t * 5.0).cos(),
                bus_v: 24.5,
            },
        )
    });
    let mut bytes = Vec::new();
    let mut run = RunLog::default();
    let mut decoder = StreamDecoder::new();
    for step in 0..steps {
        let t_s = ns(step * 5_000_000 + 1_234);
        sim.step();
        let start = bytes.len();
        sim.drain_into(&mut bytes).expect("memory");
        let scale = Scale::BOARD;
        decoder.feed(&bytes[start..], |event| {
            if let Event::Frame(frame) = event {
                if let BoardFrame::Sample(s) = &frame {
                    let side = |c: &model_core::wire::ChipReading| {
                        c.registers().map_or((0.0, 0.0), |r| {
                            (scale.bus_v(r.bus), scale.current_a(r.current))
                        })
                    };
                    let (lv, la) = side(&s.chips.left);
                    let (rv, ra) = side(&s.chips.right);
                    run.samples.push(RunSample {
                        t_s,
                        bus_v: Sides::new(lv, rv),
                        current_a: Sides::new(la, ra),
                        cmd_mps: Sides::new(0.3, 0.5),
                        yaw_rad: (step % 3 != 0).then_some(0.01 * step as f64),
                        pitch_deg: None,
                        x_m: None,
                        y_m: None,
                    });
                }
                run.frames.push((t_s, frame));
            }
        });
    }
    run.commands = vec![
        CommandRow {
            t_s: 0.0,
            cmd_mps: Sides::new(0.3, 0.5),
            yaw_rad: Some(0.0),
            pitch_deg: Some(-1.5),
            x_m: None,
            y_m: None,
        },
        CommandRow {
            t_s: 0.1,
            cmd_mps: Sides::new(-0.2, 0.2),
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        },
    ];
    run.events = vec![
        (
            0.0,
            LogEvent::Started {
                port: "/dev/ttyACM0".into(),
            },
        ),
        (
            0.05,
            LogEvent::SamplesLost {
                after_seq: 9,
                missing: 2,
            },
        ),
        (
            0.07,
            LogEvent::Reconnected {
                port: "/dev/ttyACM0".into(),
                offline_s: 1.25,
            },
        ),
        (0.08, LogEvent::BadFrames { count: 3 }),
        (0.09, LogEvent::BoardReset),
        (
            0.2,
            LogEvent::Stopped {
                reason: "Ctrl-C".into(),
            },
        ),
    ];
    (run, bytes)
}

pub(super) fn to_bytes(run: &RunLog) -> Vec<u8> {
    write_mcap_run(Cursor::new(Vec::new()), run)
        .expect("written")
        .into_inner()
}

pub(super) fn read(bytes: &[u8]) -> Result<McapRun, McapError> {
    read_mcap_bytes(bytes, Path::new("test.mcap"))
}

/// Writes `run` through a sink that flushes every `every` records, like a recorder; returns
/// the bytes without finishing the file when `finish` is false (a killed process).
pub(super) fn recorded(run: &RunLog, every: usize, finish: bool) -> Vec<u8> {
    let mut sink = McapSink::new(Cursor::new(Vec::new())).expect("sink");
    let mut n = 0;
    let mut tick = |sink: &mut McapSink<Cursor<Vec<u8>>>| {
        n += 1;
        if n % every == 0 {
            sink.flush().expect("flush");
        }
    };
    let mut samples = run.samples.iter().peekable();
    for (t_s, frame) in &run.frames {
        sink.frame(*t_s, frame).expect("frame");
        tick(&mut sink);
        while let Some(s) = samples.next_if(|s| s.t_s <= *t_s) {
            sink.sample(s).expect("sample");
            tick(&mut sink);
        }
    }
    for c in &run.commands {
        sink.command(c).expect("command");
    }
    for (t, e) in &run.events {
        sink.event(*t, e).expect("event");
    }
    sink.flush().expect("flush");
    if finish {
        sink.finish().expect("finish").into_inner()
    } else {
        // What a killed recorder leaves: everything flushed, no summary, no footer.
        sink.killed().into_inner()
    }
}

#[test]
fn round_trip_keeps_everything() {
    let (run, _) = sim_run(250);
    assert!(run.frames.len() > 250 && run.samples.len() == 250);
    assert!(run
        .frames
        .iter()
        .any(|(_, f)| matches!(f, BoardFrame::Status(_))));
    let bytes = to_bytes(&run);
    let back = read(&bytes).expect("readable");
    assert_eq!(back.truncated, None);
    assert_eq!(back.run, run);
}

/// Every message's (log_time, publish_time, foxglove.Log timestamp in ns if an event).
fn times(bytes: &[u8]) -> Vec<(u64, u64, Option<u64>)> {
    ::mcap::MessageStream::new(bytes)
        .expect("stream")
        .map(|m| {
            let m = m.expect("message");
            let stamp = (m.channel.topic == TOPIC_EVENT).then(|| {
                let v: serde_json::Value = serde_json::from_slice(&m.data).expect("JSON");
                let t = &v["timestamp"];
                t["sec"].as_u64().expect("sec") * 1_000_000_000 + t["nsec"].as_u64().expect("ns")
            });
            (m.log_time, m.publish_time, stamp)
        })
        .collect()
}

#[test]
fn log_time_is_unix_time_from_the_wall_clock_anchor_and_publish_time_run_time() {
    let (mut run, _) = sim_run(40);
    let first_t_s = run.samples[0].t_s;
    let unix_ns = 1_795_000_000_123_456_789;
    run.events
        .insert(1, (first_t_s, LogEvent::WallClock { unix_ns }));
    let zero = unix_ns - sink::run_time_ns(first_t_s).expect("time");
    let check = |bytes: &[u8]| {
        let times = times(bytes);
        assert!(times.len() > 10, "{} messages", times.len());
        for (log_time, publish_time, stamp) in times {
            // Messages before the anchor (the start event at 0, hello) are on Unix time too.
            assert_eq!(log_time, zero + publish_time);
            assert!(stamp.is_none_or(|s| s == log_time));
        }
        let back = read(bytes).expect("readable");
        assert_eq!(back.run.samples, run.samples);
        back.run
    };
    // Converted whole, and written live (flushes in between), as the recorder does: the
    // anchor before its sample.
    assert_eq!(check(&to_bytes(&run)), run);
    let mut sink = McapSink::new(Cursor::new(Vec::new())).expect("sink");
    sink.event(0.0, &run.events[0].1).expect("event");
    sink.frame(run.frames[0].0, &run.frames[0].1)
        .expect("hello");
    sink.flush().expect("flush");
    sink.event(first_t_s, &run.events[1].1).expect("anchor");
    for s in &run.samples {
        sink.sample(s).expect("sample");
        sink.flush().expect("flush");
    }
    let bytes = sink.finish().expect("finish").into_inner();
    let live = check(&bytes);
    assert_eq!(live.events, run.events[..2]);
    assert_eq!(live.frames, run.frames[..1], "frames keep their run time");
    let summary = ::mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("present");
    assert!(summary
        .metadata_indexes
        .iter()
        .any(|m| m.name == "rover_power.wall_clock"));
}

#[test]
fn without_a_wall_clock_log_time_stays_run_time_as_in_older_files() {
    let (run, _) = sim_run(40);
    for bytes in [to_bytes(&run), recorded(&run, 7, true)] {
        for (log_time, publish_time, _) in times(&bytes) {
            assert_eq!(log_time, publish_time);
        }
        assert_eq!(read(&bytes).expect("readable").run.samples, run.samples);
    }
    // An older file's frames: log_time = publish_time = run time, read as run time.
    let back = read(&to_bytes(&run)).expect("readable");
    assert_eq!(back.run.frames, run.frames);
}

#[test]
fn the_mcap_crate_reads_it_with_summary_channels_and_schemas() {
    let (run, _) = sim_run(100);
    let bytes = to_bytes(&run);
    let summary = ::mcap::Summary::read(&bytes)
        .expect("valid")
        .expect("summary present");
    let stats = summary.stats.as_ref().expect("statistics");
    let topics: BTreeMap<&str, (&str, Option<&str>)> = summary
        .channels
        .values()
        .map(|c| {
            (
                c.topic.as_str(),
                (
                    c.message_encoding.as_str(),
                    c.schema.as_ref().map(|s| s.encoding.as_str()),
                ),
            )
        })
        .collect();
    assert_eq!(topics[TOPIC_SAMPLE_BATCH], ("protobuf", Some("protobuf")));
    assert!(!topics.contains_key(TOPIC_SAMPLE), "samples go in batches");
    assert_eq!(topics[TOPIC_MODEL], ("protobuf", Some("protobuf")));
    assert_eq!(topics[TOPIC_STATUS], ("protobuf", Some("protobuf")));
    assert_eq!(topics[TOPIC_COMMAND], ("json", Some("jsonschema")));
    assert_eq!(topics[TOPIC_EVENT], ("json", Some("jsonschema")));
    assert_eq!(topics[TOPIC_FRAME], ("protobuf", Some("protobuf")));
    assert!(!summary.chunk_indexes.is_empty());
    assert_eq!(summary.metadata_indexes.len(), 2, "rover_power + one hello");

    // Every message, through the crate's own reader; JSON channels hold valid JSON objects,
    // protobuf ones their schema's message (decoded by its descriptor table).
    let mut count = 0u64;
    let mut models = 0;
    for message in ::mcap::MessageStream::new(&bytes).expect("stream") {
        let message = message.expect("message");
        count += 1;
        let schema = message.channel.schema.as_ref().expect("a schema");
        let value: serde_json::Value = match message.channel.message_encoding.as_str() {
            "json" => serde_json::from_slice(&message.data).expect("JSON message"),
            _ => proto::to_json(&schema.name, &message.data).expect("protobuf message"),
        };
        if message.channel.topic != TOPIC_FRAME {
            assert!(value.is_object());
            // A batch is at its first sample's time.
            let t_s = match &value["t_s"] {
                serde_json::Value::Array(times) => &times[0],
                one => one,
            };
            let t_s = t_s.as_f64().expect("t_s");
            assert_eq!(sink::run_time_ns(t_s).expect("time"), message.publish_time);
            if message.channel.topic == TOPIC_MODEL {
                models += 1;
                assert!(value["left"]["energy_j"].is_number());
            }
        }
    }
    assert_eq!(count, stats.message_count);
    let frame_models = run
        .frames
        .iter()
        .filter(|(_, f)| matches!(f, BoardFrame::Model(_)))
        .count();
    assert_eq!(models, frame_models);
    // The JSON schemas are valid JSON.
    for schema in summary
        .schemas
        .values()
        .filter(|s| s.encoding == "jsonschema")
    {
        serde_json::from_slice::<serde_json::Value>(&schema.data).expect("JSON schema");
    }
}

/// `a`'s items are the first items of `b`.
fn is_prefix<T: PartialEq + std::fmt::Debug>(a: &[T], b: &[T]) -> bool {
    a.len() <= b.len() && a == &b[..a.len()]
}

#[test]
fn a_file_cut_anywhere_reads_up_to_its_last_complete_record() {
    let (run, _) = sim_run(200);
    let bytes = recorded(&run, 25, true);
    let full = read(&bytes).expect("full");
    assert_eq!(full.truncated, None);
    let mut previous = 0;
    let mut partial = 0;
    for cut in (0..bytes.len()).step_by(97) {
        match read(&bytes[..cut]) {
            Err(McapError::NotMcap { .. }) => assert!(cut < 8, "cut {cut}"),
            Err(e) => panic!("cut at {cut}: {e}"),
            Ok(got) => {
                let t = got
                    .truncated
                    .unwrap_or_else(|| panic!("cut at {cut} of {} not reported", bytes.len()));
                assert_eq!(t.file_bytes, cut as u64);
                assert!(t.complete_bytes <= cut as u64);
                assert!(is_prefix(&got.run.samples, &full.run.samples), "cut {cut}");
                assert!(is_prefix(&got.run.frames, &full.run.frames), "cut {cut}");
                assert!(is_prefix(&got.run.commands, &full.run.commands));
                assert!(is_prefix(&got.run.events, &full.run.events));
                assert!(got.run.frames.len() >= previous, "cut {cut}");
                previous = got.run.frames.len();
                if !got.run.frames.is_empty() && got.run.frames.len() < full.run.frames.len() {
                    partial += 1;
                }
            }
        }
    }
    assert!(
        partial > 10,
        "only {partial} cuts recovered part of the run"
    );
}

#[test]
fn a_killed_recorder_leaves_everything_it_flushed() {
    let (run, _) = sim_run(120);
    let bytes = recorded(&run, 10, false);
    let got = read(&bytes).expect("readable");
    let t = got.truncated.expect("no footer");
    assert_eq!(t.complete_bytes, t.file_bytes, "cut at a record boundary");
    assert_eq!(got.run, run);
    assert!(
        !matches!(::mcap::Summary::read(&bytes), Ok(Some(_))),
        "no summary section"
    );
}

/// The walk is read ahead on another thread ([`super::ahead`]): a file of many chunks reads
/// whole and in order, and a sink's error stops the read there, the walk with it.
#[test]
fn a_walk_read_ahead_keeps_the_order_and_stops_with_the_sink() {
    let (run, _) = sim_run(600);
    let bytes = recorded(&run, 10, true);
    let chunks = ::mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("finished")
        .chunk_indexes
        .len();
    assert!(chunks > 40, "{chunks} chunks");
    assert_eq!(read(&bytes).expect("readable").run, run);

    /// Takes `0` samples, then fails.
    struct FailsAfter(usize);
    impl RunLogSink for FailsAfter {
        fn sample(&mut self, _: &RunSample) -> io::Result<()> {
            match self.0.checked_sub(1) {
                Some(left) => {
                    self.0 = left;
                    Ok(())
                }
                None => Err(io::Error::other("the sink is full")),
            }
        }
    }
    let dir = TempDir::new("read-ahead");
    let path = dir.path().join("run.mcap");
    std::fs::write(&path, &bytes).expect("write");
    let mut sink = FailsAfter(300);
    let e = stream_mcap_run(&path, &mut sink).expect_err("the sink stops it");
    assert!(matches!(e, McapError::Io { .. }), "{e}");
    assert!(e.to_string().ends_with("the sink is full"), "{e}");
}

#[test]
fn sink_on_a_file_is_readable_before_finish_and_finished_on_drop() {
    let dir = TempDir::new("mcap-sink");
    let path = dir.path().join("run.mcap");
    let (run, _) = sim_run(40);
    let mut sink = McapSink::create(&path, false).expect("create");
    let got = read_mcap_run(&path).expect("header and channels on disk at once");
    assert!(got.truncated.is_some() && got.run == RunLog::default());
    for s in &run.samples {
        sink.sample(s).expect("sample");
    }
    sink.flush().expect("flush");
    let got = read_mcap_run(&path).expect("flushed samples on disk");
    assert_eq!(got.run.samples, run.samples);
    // Samples after the flush wait in a batch: dropping the sink writes them too.
    let more: Vec<RunSample> = run
        .samples
        .iter()
        .map(|s| RunSample {
            t_s: s.t_s + 100.0,
            ..*s
        })
        .collect();
    for s in &more {
        sink.sample(s).expect("sample");
    }
    drop(sink);
    let got = read_mcap_run(&path).expect("finished");
    assert_eq!(got.truncated, None);
    assert_eq!(got.run.samples[..run.samples.len()], run.samples[..]);
    assert!(
        got.run.samples[run.samples.len()..] == more[..],
        "the last batch"
    );
}

#[test]
fn sink_refuses_what_the_reader_would_reject() {
    let mut sink = McapSink::new(Cursor::new(Vec::new())).expect("sink");
    let (run, _) = sim_run(3);
    sink.sample(&run.samples[1]).expect("first");
    let e = sink.sample(&run.samples[0]).expect_err("time goes back");
    assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
    assert!(e.to_string().contains("not after the previous"), "{e}");
    let mut nan = run.samples[2];
    nan.current_a.left = f64::NAN;
    assert!(sink.sample(&nan).is_err());
    let e = sink
        .event(-1.0, &LogEvent::BoardReset)
        .expect_err("negative time");
    assert!(e.to_string().contains("run time -1 s"), "{e}");
    assert!(sink.frame(f64::INFINITY, &run.frames[0].1).is_err());
    // The sink still works after refusing.
    sink.sample(&run.samples[2]).expect("valid");
    let bytes = sink.finish().expect("finish").into_inner();
    let got = read(&bytes).expect("readable");
    assert_eq!(got.run.samples, [run.samples[1], run.samples[2]]);
}

#[test]
fn not_mcap_foreign_and_other_versions_are_clear_errors() {
    let e = read(b"t_s,left_bus_v\n0,24\n").expect_err("CSV");
    assert_eq!(
        e.to_string(),
        "test.mcap: not an MCAP file (it does not start with the MCAP magic bytes)"
    );
    assert!(matches!(read(b""), Err(McapError::NotMcap { .. })));

    // A finished MCAP file of someone else's topics.
    let mut writer = ::mcap::Writer::new(Cursor::new(Vec::new())).expect("writer");
    let no_metadata = BTreeMap::new();
    let odom = writer
        .add_channel(0, "/odom", "json", &no_metadata)
        .expect("channel");
    writer
        .add_channel(0, "/tf", "cdr", &no_metadata)
        .expect("channel");
    writer
        .write_to_known_channel(
            &::mcap::records::MessageHeader {
                channel_id: odom,
                sequence: 0,
                log_time: 0,
                publish_time: 0,
            },
            b"{}",
        )
        .expect("message");
    writer.finish().expect("finish");
    let bytes = writer.into_inner().into_inner();
    let e = read(&bytes).expect_err("foreign");
    assert_eq!(
        e.to_string(),
        "test.mcap: an MCAP file without rover-power channels (its topics: /odom, /tf)"
    );

    // Frames of another protocol version, bare (as files before the protobuf wrapping) or
    // wrapped.
    let v9 = BTreeMap::from([("wire_encoding".to_owned(), "rover-power-wire-v9".to_owned())]);
    for (encoding, metadata) in [("rover-power-wire-v9", &no_metadata), ("protobuf", &v9)] {
        let mut writer = ::mcap::Writer::new(Cursor::new(Vec::new())).expect("writer");
        writer
            .add_channel(0, TOPIC_FRAME, encoding, metadata)
            .expect("channel");
        writer.finish().expect("finish");
        let bytes = writer.into_inner().into_inner();
        let e = read(&bytes).expect_err("v9");
        assert!(matches!(e, McapError::Foreign { .. }), "{e}");
        assert!(
            e.to_string().contains(&format!(
                "holds \"rover-power-wire-v9\" frames; this tool reads \"rover-power-wire-v{}\"",
                model_core::wire::PROTOCOL_VERSION
            )),
            "{e}"
        );
    }
}

#[test]
fn a_damaged_uncompressed_chunk_is_skipped_and_reported() {
    let (run, _) = sim_run(30);
    let mut bytes = write_mcap_run_with(Cursor::new(Vec::new()), &run, None)
        .expect("written")
        .into_inner();
    // Find a sample message's JSON inside the (only data) chunk and change a digit.
    let at = bytes
        .windows(7)
        .position(|w| w.starts_with(b"\"t_s\":") && w[6].is_ascii_digit())
        .expect("a JSON message")
        + 6;
    bytes[at] ^= 0x01;
    let got = read(&bytes).expect("salvaged");
    assert_eq!(got.losses.len(), 1, "{:?}", got.losses);
    assert!(
        got.losses[0].detail.contains("chunk CRC mismatch"),
        "{}",
        got.losses[0]
    );
    // The first such message is a command, alone in its chunk with the events.
    let count = |r: &RunLog| r.samples.len() + r.commands.len() + r.events.len();
    assert!(
        count(&got.run) < count(&run),
        "its chunk's messages are lost"
    );
    assert!(got.run.samples.iter().all(|s| run.samples.contains(s)));
}

/// A message that does not hold what its channel promises is one loss, named by its topic and
/// time; the rest of the file is read (issue 34, item 9: one malformed sample message rejected
/// the whole file, even with `--salvage`).
#[test]
fn a_bad_message_is_a_loss_naming_its_topic_and_time() {
    let (run, _) = sim_run(10);
    let mut sink = McapSink::new(Cursor::new(Vec::new())).expect("sink");
    // Bypass the encoders: a frame message that is not a frame, a sample that is not protobuf.
    let not_a_frame = frame_proto::encode(b"\x05garbage\x00");
    sink.write(sink::Ch::Frame, 0.001, &not_a_frame)
        .expect("written");
    for (i, s) in run.samples.iter().enumerate() {
        if i == 4 {
            // The batch gathered so far first, so that the bad message keeps its place.
            sink.flush().expect("flushed");
            sink.write(sink::Ch::Sample, s.t_s, b"{\"t_s\":")
                .expect("written");
            // (`{` is field 15 with wire type 3, a group)
        } else {
            sink.sample(s).expect("sample");
        }
    }
    let bytes = sink.finish().expect("finish").into_inner();
    let got = read(&bytes).expect("read, with its losses");
    let details: Vec<&str> = got.losses.iter().map(|l| l.detail.as_str()).collect();
    assert_eq!(
        details,
        [
            "/rover_power/frame message at run time 1000000 ns: frame does not decode: invalid \
             COBS encoding",
            &format!(
                "/rover_power/sample_batch message at run time {} ns: field 15 has wire type 3",
                (run.samples[4].t_s * 1e9).round()
            ),
        ]
    );
    let mut kept = run.samples.clone();
    kept.remove(4);
    assert_eq!(got.run.samples, kept);
}

#[test]
fn merged_with_other_topics_reads_only_ours() {
    let (run, _) = sim_run(10);
    let mut sink = McapSink::new(Cursor::new(Vec::new())).expect("sink");
    let no_metadata = BTreeMap::new();
    let tf = sink
        .raw_writer()
        .add_channel(0, "/tf", "cdr", &no_metadata)
        .expect("channel");
    for s in &run.samples {
        sink.sample(s).expect("sample");
        sink.raw_writer()
            .write_to_known_channel(
                &::mcap::records::MessageHeader {
                    channel_id: tf,
                    sequence: 0,
                    log_time: 1,
                    publish_time: 1,
                },
                b"\x00\x01",
            )
            .expect("foreign message");
    }
    let bytes = sink.finish().expect("finish").into_inner();
    assert_eq!(read(&bytes).expect("ours").run.samples, run.samples);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Cut anywhere and flip any bytes: an error or a run, never a panic.
    #[test]
    fn damaged_files_never_panic(
        cut in any::<prop::sample::Index>(),
        flips in proptest::collection::vec((any::<prop::sample::Index>(), 1u8..=255), 0..6),
    ) {
        thread_local! {
            static BYTES: Vec<u8> = {
                let (run, _) = sim_run(60);
                recorded(&run, 7, true)
            };
        }
        let mut bytes = BYTES.with(Clone::clone);
        for (at, flip) in &flips {
            let i = at.index(bytes.len());
            bytes[i] ^= flip;
        }
        let cut = cut.index(bytes.len() + 1);
        let _ = read(&bytes[..cut]);
    }

    /// Arbitrary records after the magic: never a panic.
    #[test]
    fn arbitrary_records_never_panic(
        records in proptest::collection::vec(
            (prop_oneof![Just(0x01u8), Just(0x03), Just(0x04), Just(0x05), Just(0x06), Just(0x0c), Just(0x0f), any::<u8>()],
             proptest::collection::vec(any::<u8>(), 0..64),
             any::<bool>()),
            0..8),
    ) {
        let mut bytes = ::mcap::MAGIC.to_vec();
        for (opcode, body, honest) in &records {
            bytes.push(*opcode);
            let len = if *honest { body.len() as u64 } else { u64::from(body.first().copied().unwrap_or(0)) << 40 };
            bytes.extend_from_slice(&len.to_le_bytes());
            bytes.extend_from_slice(body);
        }
        let _ = read(&bytes);
    }
}

/// Files written before the protobuf wrapping hold each frame bare under the message encoding
/// `rover-power-wire-v<N>`: they still read, frame for frame.
#[test]
fn bare_frames_of_earlier_files_still_read() {
    let (run, _) = sim_run(60);
    let mut writer = ::mcap::Writer::new(Cursor::new(Vec::new())).expect("writer");
    let channel = writer
        .add_channel(0, TOPIC_FRAME, &frame_encoding(), &BTreeMap::new())
        .expect("channel");
    for (sequence, (t_s, frame)) in run.frames.iter().enumerate() {
        let mut buf = [0u8; model_core::wire::MAX_FRAME];
        let n = model_core::wire::encode(frame, &mut buf).expect("encodes");
        let time = sink::run_time_ns(*t_s).expect("time");
        writer
            .write_to_known_channel(
                &::mcap::records::MessageHeader {
                    channel_id: channel,
                    sequence: sequence as u32,
                    log_time: time,
                    publish_time: time,
                },
                &buf[..n],
            )
            .expect("message");
    }
    writer.finish().expect("finish");
    let bytes = writer.into_inner().into_inner();
    assert_eq!(read(&bytes).expect("readable").run.frames, run.frames);
}

/// Every channel and message passes Foxglove Studio's reader rules, with the values that are
/// sometimes unknown (a side without power or τ, a chip fault, no wheel rates) among them.
#[test]
fn every_channel_and_message_is_one_studio_reads() {
    let (mut run, _) = sim_run(200);
    let mut faulted = None;
    for (_, frame) in &mut run.frames {
        match frame {
            BoardFrame::Model(m) if faulted.is_none() => {
                m.snapshot.power_lsb.left = None;
                m.snapshot.torque_proportional.right = None;
                faulted = Some(());
            }
            BoardFrame::Status(s) => {
                s.last_fault.left = None;
                s.last_fault.right = Some(model_core::wire::ChipFault::AddressNack);
                s.wheel_rates_rad_s = None;
            }
            _ => {}
        }
    }
    let bytes = to_bytes(&run);
    assert_eq!(
        studio::problems(&bytes).expect("MCAP"),
        Vec::<String>::new()
    );
    // The unknown values are absent (proto2 `optional`: the field is not written).
    let mut seen = (false, false, false);
    for message in ::mcap::MessageStream::new(&bytes).expect("stream") {
        let message = message.expect("message");
        let Some(schema) = message.channel.schema.as_ref() else {
            continue;
        };
        let value: serde_json::Value = match message.channel.message_encoding.as_str() {
            "json" => serde_json::from_slice(&message.data).expect("JSON"),
            _ => proto::to_json(&schema.name, &message.data).expect("decodes"),
        };
        let text = value.to_string();
        if message.channel.topic == TOPIC_SAMPLE_BATCH {
            // In a column, a value one sample lacks is NaN (`null` in this JSON).
            seen.2 |= value["yaw_rad"]
                .as_array()
                .is_some_and(|yaw| yaw.iter().any(|v| v.is_null()) && yaw[0].is_number());
            continue;
        }
        assert!(!text.contains("null"), "{}: {text}", message.channel.topic);
        seen.0 |= message.channel.topic == TOPIC_MODEL
            && value["left"].get("power_w").is_none()
            && value["left"]["energy_j"].is_number();
        seen.1 |= message.channel.topic == TOPIC_STATUS
            && value["last_fault"] == serde_json::json!({"right": "AddressNack"});
    }
    assert_eq!(seen, (true, true, true));
    // A file of today's schemas before this change is refused by the same rules.
    let mut writer = ::mcap::Writer::new(Cursor::new(Vec::new())).expect("writer");
    let schema = br##"{"type": "object", "properties": {"left": {"$ref": "#/$defs/side"}}}"##;
    let id = writer
        .add_schema("old.Sample", "jsonschema", schema)
        .expect("schema");
    let json = writer
        .add_channel(id, "/old", "json", &BTreeMap::new())
        .expect("channel");
    let bare = writer
        .add_channel(0, "/bare", "rover-power-wire-v3", &BTreeMap::new())
        .expect("channel");
    // Channel records closed in a chunk of their own, as the sink declared them before.
    writer
        .write_metadata(&::mcap::records::Metadata {
            name: "m".into(),
            metadata: BTreeMap::new(),
        })
        .expect("metadata");
    for channel_id in [json, bare] {
        let header = ::mcap::records::MessageHeader {
            channel_id,
            sequence: 0,
            log_time: 0,
            publish_time: 0,
        };
        writer
            .write_to_known_channel(&header, b"{}")
            .expect("message");
    }
    writer.finish().expect("finish");
    let problems = studio::problems(&writer.into_inner().into_inner()).expect("MCAP");
    assert_eq!(problems.len(), 3, "{problems:?}");
    assert!(
        problems[0].contains("Chunks without message indexes"),
        "{problems:?}"
    );
    assert!(
        problems[1].contains("Unsupported type null for old.Sample.left"),
        "{problems:?}"
    );
    assert_eq!(
        problems[2],
        "/bare: Unsupported encoding rover-power-wire-v3"
    );
}

/// A log recorded before the protobuf channels (samples, model and status in JSON: 300 samples
/// of a replayed demo run, `tests/fixtures/mcap/json-channels-v3.mcap`) reads whole, and
/// rewritten (`convert OLD.mcap NEW.mcap`) reads back the same with protobuf samples.
#[test]
fn a_log_with_json_channels_reads_and_rewrites_to_the_same_run() {
    let old = include_bytes!("../../../tests/fixtures/mcap/json-channels-v3.mcap");
    let topics = |bytes: &[u8]| -> BTreeMap<String, String> {
        ::mcap::Summary::read(bytes)
            .expect("valid")
            .expect("summary")
            .channels
            .values()
            .map(|c| (c.topic.clone(), c.message_encoding.clone()))
            .collect()
    };
    assert_eq!(topics(old)[TOPIC_SAMPLE], "json");
    let got = read(old).expect("an old log reads");
    assert!(got.losses.is_empty() && got.truncated.is_none());
    let run = got.run;
    assert_eq!(run.samples.len(), 299, "one sample without both chips");
    assert_eq!(run.frames.len(), 320);
    assert_eq!(
        run.events
            .iter()
            .map(|(_, e)| e.short_name())
            .collect::<Vec<_>>(),
        ["started", "clock", "stopped"]
    );
    assert!(run.samples.iter().all(|s| s.bus_v.left > 20.0));
    let new = to_bytes(&run);
    assert_eq!(topics(&new)[TOPIC_SAMPLE_BATCH], "protobuf");
    assert_eq!(read(&new).expect("rewritten").run, run);
    assert!(
        new.len() < old.len(),
        "{} B against {} B",
        new.len(),
        old.len()
    );
}

/// A log of one protobuf message a sample (`rover_power.Sample` on `/rover_power/sample`, the
/// layout since issue 55's first step; `tests/fixtures/mcap/protobuf-samples-v4.mcap` is the
/// v3 fixture's run rewritten by `convert` on 2026-12-07) reads as that same run, whatever the
/// writer lays out today.
#[test]
fn a_log_with_a_protobuf_message_a_sample_reads_as_the_same_run() {
    let v3 = include_bytes!("../../../tests/fixtures/mcap/json-channels-v3.mcap");
    let v4 = include_bytes!("../../../tests/fixtures/mcap/protobuf-samples-v4.mcap");
    let summary = ::mcap::Summary::read(v4).expect("valid").expect("summary");
    let samples = summary
        .channels
        .values()
        .find(|c| c.topic == TOPIC_SAMPLE)
        .expect("a sample channel");
    assert_eq!(
        samples.schema.as_ref().map(|s| s.name.as_str()),
        Some("rover_power.Sample")
    );
    let got = read(v4).expect("a v4 log reads");
    assert!(got.losses.is_empty() && got.truncated.is_none());
    assert_eq!(got.run, read(v3).expect("a v3 log reads").run);
    assert_eq!(got.run.samples.len(), 299);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// The sample reader's fixed-offset path reads what the field-by-field path reads, for any
    /// values, any optional fields and with or without a board part; any bytes give the two
    /// paths' one answer (or an error), never a panic.
    #[test]
    fn the_fast_sample_path_reads_as_the_general_one(
        values in proptest::collection::vec(any::<f64>(), 7),
        optional in proptest::collection::vec(proptest::option::of(any::<f64>()), 4),
        board in any::<bool>(),
        noise in proptest::collection::vec(any::<u8>(), 0..120),
    ) {
        let sample = RunSample {
            t_s: values[0],
            bus_v: Sides::new(f64::from(values[1] as f32), values[2]),
            current_a: Sides::new(values[3], values[4]),
            cmd_mps: Sides::new(values[5], values[6]),
            yaw_rad: optional[0],
            pitch_deg: optional[1],
            x_m: optional[2],
            y_m: optional[3],
        };
        // A simulated board's sample frame (the message's bus voltages are the values
        // above: the fast path reads the part whether or not it rebuilds a frame from them).
        let part = board.then(|| {
            let (run, _) = sim_run(3);
            // (The harness's first sample has no chip reading behind it: the second.)
            let s = run.samples[1];
            run.frames.iter().find_map(|(t, f)| match f {
                BoardFrame::Sample(f) if *t == s.t_s => board_sample::BoardSample::of(f, &s),
                _ => None,
            }).expect("the sample's frame folds into it")
        });
        let bytes = SampleMsg::of(&sample).protobuf(part.as_ref());
        let fast = SampleMsg::from_own_protobuf(&bytes).expect("our layout").expect("reads");
        let general = SampleMsg::from_protobuf_fields(&bytes).expect("reads");
        // Bitwise (NaN included).
        let bits = |s: &RunSample| format!("{:?}", [s.t_s, s.bus_v.left, s.bus_v.right,
            s.current_a.left, s.current_a.right, s.cmd_mps.left, s.cmd_mps.right]
            .map(f64::to_bits));
        prop_assert_eq!(bits(&fast.0), bits(&general.0));
        prop_assert_eq!(bits(&fast.0), bits(&sample));
        prop_assert_eq!(format!("{:?}", fast.1), format!("{:?}", general.1));
        prop_assert_eq!(fast.1.is_some(), part.is_some());
        // Noise: both paths answer without panicking, the same where the fast one takes it.
        if let Some(fast) = SampleMsg::from_own_protobuf(&noise) {
            let general = SampleMsg::from_protobuf_fields(&noise);
            prop_assert_eq!(format!("{fast:?}"), format!("{general:?}"));
        }
        let _ = SampleMsg::from_protobuf(&noise);
    }
}
