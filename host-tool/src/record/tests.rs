use super::*;
use crate::log::run_log::{LogEvent, RunLog};
use firmware::sampler::{Sampler, SamplerConfig};
use model_core::energy::RunningMeasurements;
use model_core::ina226::{BusVoltageRaw, CurrentRaw, PowerRaw, Registers, ShuntVoltageRaw};
use model_core::wire::{BoardFrame, ChipReading, HostFrame, Model, Sample};
use std::collections::VecDeque;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

/// A port that hands out scripted chunks, then reports end of file (the device vanished), and
/// keeps what the host wrote.
struct Script {
    chunks: VecDeque<Vec<u8>>,
    written: Arc<Mutex<Vec<u8>>>,
}

impl Read for Script {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.chunks.pop_front() {
            None => Ok(0),
            Some(chunk) => {
                let n = chunk.len().min(buf.len());
                buf[..n].copy_from_slice(&chunk[..n]);
                if n < chunk.len() {
                    self.chunks.push_front(chunk[n..].to_vec());
                }
                Ok(n)
            }
        }
    }
}

impl Write for Script {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.written
            .lock()
            .map_err(|_| io::Error::other("poisoned"))?
            .extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

fn encode_all(frames: &[BoardFrame]) -> Vec<u8> {
    let mut out = Vec::new();
    for f in frames {
        let mut buf = [0u8; wire::MAX_FRAME];
        let n = wire::encode(f, &mut buf).expect("fits");
        out.extend_from_slice(&buf[..n]);
    }
    out
}

fn regs(current: i16, power: u16) -> Registers {
    Registers {
        shunt: ShuntVoltageRaw(current / 10),
        bus: BusVoltageRaw(19_600), // 24.5 V
        current: CurrentRaw(current),
        power: PowerRaw(power),
    }
}

/// Feeds `sample` to the board's measurements and appends its frame, and a model frame after
/// every 20th sample, as the firmware sends them.
fn push_sample(frames: &mut Vec<BoardFrame>, board: &mut RunningMeasurements, sample: Sample) {
    board.update(sample.t_us, sample.chips.map(|c| c.registers()));
    frames.push(BoardFrame::Sample(sample));
    if sample.seq % 20 == 19 {
        frames.push(BoardFrame::Model(Model {
            t_us: sample.t_us,
            seq: sample.seq,
            snapshot: board.snapshot(),
        }));
    }
}

/// A board's stream: hello, then `n` samples from `t0_us` every 5 ms with model frames every
/// 20 samples, as the firmware's measurements see them. Returns the bytes and the board's
/// measurements after the last sample.
fn board_stream(t0_us: u64, n: u32, failed_right: &[u32]) -> (Vec<u8>, RunningMeasurements) {
    let mut frames = vec![BoardFrame::Hello(
        Sampler::new(SamplerConfig::BOARD).hello(),
    )];
    let mut board = RunningMeasurements::new(Scale::BOARD);
    for seq in 0..n {
        let t_us = t0_us.wrapping_add(u64::from(seq) * 5_000);
        let right = if failed_right.contains(&seq) {
            ChipReading::Failed(ChipFault::AddressNack)
        } else {
            ChipReading::Fresh(regs(-2_000 + seq as i16, 400))
        };
        let chips = Sides::new(ChipReading::Fresh(regs(4_000, 3_920 + seq as u16)), right);
        push_sample(&mut frames, &mut board, Sample { t_us, seq, chips });
    }
    (encode_all(&frames), board)
}

fn script(chunks: Vec<Vec<u8>>) -> (Box<dyn BoardPort>, Arc<Mutex<Vec<u8>>>) {
    let written = Arc::new(Mutex::new(Vec::new()));
    let port = Script {
        chunks: chunks.into(),
        written: Arc::clone(&written),
    };
    (Box::new(port), written)
}

fn fast_options() -> RecordOptions {
    RecordOptions {
        reconnect_timeout: Duration::from_millis(100),
        retry_every: Duration::from_millis(10),
        ..RecordOptions::new("/dev/test")
    }
}

/// Records the scripted ports in order (the first at the start, the rest on reconnection).
fn record_ports(
    options: &RecordOptions,
    ports: Vec<Box<dyn BoardPort>>,
) -> (
    Result<RecordSummary, RecordError>,
    RunLog,
    Vec<RecordStatus>,
) {
    let mut ports: VecDeque<_> = ports.into();
    let mut open = |_: &str| {
        ports.pop_front().ok_or_else(|| SerialError::Open {
            path: "/dev/test".into(),
            source: serialport::Error::new(serialport::ErrorKind::NoDevice, "gone"),
        })
    };
    let mut log = RunLog::default();
    let mut statuses = Vec::new();
    let stop = AtomicBool::new(false);
    let result = record(options, &mut open, &mut log, &stop, &mut |s| {
        statuses.push(s.clone())
    });
    (result, log, statuses)
}

fn kinds(log: &RunLog) -> Vec<&'static str> {
    log.events
        .iter()
        .map(|(_, e)| e.short_name())
        .filter(|kind| *kind != "clock")
        .collect()
}

#[test]
fn timestamps_wrapping_past_u64_max_give_a_continuous_run_and_exact_energy() {
    let t0 = u64::MAX - 250_000; // wraps after 50 samples
    let (bytes, board) = board_stream(t0, 200, &[]);
    let (port, _) = script(bytes.chunks(97).map(<[u8]>::to_vec).collect());
    let (result, log, _) = record_ports(&fast_options(), vec![port]);
    let summary = result.expect("recorded");
    assert_eq!(summary.stop, StopReason::DeviceGone);
    assert_eq!((summary.samples, summary.rows), (200, 200));
    for (k, s) in log.samples.iter().enumerate() {
        assert_eq!(s.t_s, (k as u64 * 5_000) as f64 / 1e6);
        assert_eq!(s.bus_v, Sides::new(24.5, 24.5));
        assert_eq!(s.current_a.left, 2.0);
        assert_eq!(s.cmd_mps, Sides::new(0.0, 0.0));
    }
    let host = summary.segments[0].host_energy_lsb_us;
    let e = board.snapshot().energy_lsb_us;
    assert_eq!(host, [e.left, e.right]);
    assert_ne!(e.left, 0);
    assert_eq!(summary.stream.model_mismatches, 0);
    assert_eq!(summary.stream.models, 10);
    assert_eq!(kinds(&log), ["started", "vanished", "stopped"]);
}

#[test]
fn a_failed_chip_skips_the_row_and_the_status_names_it() {
    let (bytes, _) = board_stream(0, 50, &[10, 11, 12, 49]);
    let (port, _) = script(vec![bytes]);
    let (result, log, statuses) = record_ports(&fast_options(), vec![port]);
    let summary = result.expect("recorded");
    assert_eq!(
        (summary.samples, summary.rows, summary.incomplete_samples),
        (50, 46, 4)
    );
    assert_eq!(log.samples.len(), 46);
    assert_eq!(
        log.frames
            .iter()
            .filter(|(_, f)| matches!(f, BoardFrame::Sample(_)))
            .count(),
        50
    );
    let last = statuses.last().expect("final status");
    assert_eq!(
        last.chip_faults,
        Sides::new(None, Some(ChipFault::AddressNack))
    );
    assert_eq!(last.chip_failed_samples, Sides::new(0, 4));
    let line = last.to_string();
    assert!(line.contains("right chip 0x45: AddressNack"), "{line}");
}

#[test]
fn stops_after_the_sample_count_mid_chunk() {
    let (bytes, _) = board_stream(0, 100, &[]);
    let (port, _) = script(vec![bytes]);
    let options = RecordOptions {
        max_samples: Some(37),
        ..fast_options()
    };
    let (result, log, _) = record_ports(&options, vec![port]);
    let summary = result.expect("recorded");
    assert_eq!(summary.stop, StopReason::Samples);
    assert_eq!(summary.samples, 37);
    assert_eq!(log.samples.len(), 37);
    assert_eq!(kinds(&log), ["started", "stopped"]);
}

#[test]
fn a_reconnection_to_a_rebooted_board_is_marked_and_time_continues() {
    let (first, _) = board_stream(1_000_000, 30, &[]);
    let (second, _) = board_stream(0, 30, &[]);
    let (a, _) = script(vec![first]);
    let (b, _) = script(vec![second]);
    let (result, log, _) = record_ports(&fast_options(), vec![a, b]);
    let summary = result.expect("recorded");
    assert_eq!(
        (summary.samples, summary.vanished, summary.reconnects),
        (60, 2, 1)
    );
    assert_eq!(
        kinds(&log),
        [
            "started",
            "vanished",
            "reconnected",
            "reset",
            "vanished",
            "stopped"
        ]
    );
    assert!(log.samples.windows(2).all(|w| w[0].t_s < w[1].t_s));
    // The second board's first sample comes after the offline time, and its own steps follow.
    let offline_s = log
        .events
        .iter()
        .find_map(|(_, e)| match e {
            LogEvent::Reconnected { offline_s, .. } => Some(*offline_s),
            _ => None,
        })
        .expect("reconnected");
    assert!(log.samples[30].t_s - log.samples[29].t_s >= offline_s * 0.5);
    assert!((log.samples[31].t_s - log.samples[30].t_s - 0.005).abs() < 1e-9);
    assert_eq!(summary.segments.len(), 2);
    assert_eq!(summary.segments[0].samples, 30);
    assert_eq!(summary.stream.lost_samples, 0);
}

#[test]
fn bytes_queued_for_the_previous_connection_are_not_recorded() {
    // The same board re-opened: its USB buffers still hold the tail of the first connection's
    // stream (a cut frame, then samples 30..32) before the new connection's hello.
    let (all, _) = board_stream(0, 60, &[]);
    let (first, _) = board_stream(0, 30, &[]);
    let hello_len = all.iter().position(|&b| b == 0).expect("hello") + 1;
    let stale_start = first.len() - 7;
    let stale_end = {
        // Through the delimiter of sample 32 (the first connection ended after sample 29).
        let mut end = first.len();
        for _ in 0..3 {
            end += all[end..].iter().position(|&b| b == 0).expect("frame") + 1;
        }
        end
    };
    let stale = all[stale_start..stale_end].to_vec();
    let mut second = stale.clone();
    second.extend(&all[..hello_len]);
    second.extend(&all[stale_end..]);
    let (a, _) = script(vec![first]);
    let (b, _) = script(vec![second]);
    let (result, log, _) = record_ports(&fast_options(), vec![a, b]);
    let summary = result.expect("recorded");
    assert_eq!(
        (summary.stream.stale_bytes, summary.stream.stale_frames),
        (stale.len() as u64, 4)
    );
    assert_eq!(
        summary.stream.bad_frames, 0,
        "the cut frame is stale, not bad"
    );
    // 30 + the 27 after the stale ones; the 3 stale samples are a gap, not data.
    assert_eq!(summary.samples, 57);
    assert_eq!(summary.stream.lost_samples, 3);
    assert_eq!(log.samples.len(), 57);
}

#[test]
fn commands_are_forwarded_once_per_change_and_copied_into_the_samples() {
    let rows = vec![
        CommandRow {
            t_s: 0.0,
            cmd_mps: Sides::new(0.33, 0.66),
            yaw_rad: Some(0.0),
            pitch_deg: None,
            x_m: None,
            y_m: None,
        },
        CommandRow {
            t_s: 0.05,
            cmd_mps: Sides::new(0.33, 0.66),
            yaw_rad: Some(0.1),
            pitch_deg: None,
            x_m: None,
            y_m: None,
        },
        CommandRow {
            t_s: 0.1,
            cmd_mps: Sides::new(-0.165, 0.165),
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        },
    ];
    let options = RecordOptions {
        commands: rows,
        ..fast_options()
    };
    let (bytes, _) = board_stream(0, 40, &[]);
    let (port, written) = script(vec![bytes]);
    let (result, log, _) = record_ports(&options, vec![port]);
    let summary = result.expect("recorded");
    assert_eq!(summary.commands_sent, 2);
    // The scripted board never answers (issue 11, bug 7: the demo now fails on this).
    assert_eq!(summary.unanswered_commands(), 2);
    assert_eq!(log.commands.len(), 2);
    let mut sent = Vec::new();
    wire::FrameDecoder::new().feed::<HostFrame>(&written.lock().expect("lock"), |f| {
        sent.push(f.expect("valid"));
    });
    assert_eq!(sent.len(), 2);
    let rates = |c: Command| match c {
        Command::SetWheelRates(r) => [r.left, r.right],
        other => panic!("{other:?}"),
    };
    // ω = v / r with r = 0.165 m (stored as f32).
    for (got, want) in [
        (rates(sent[0].command), [2.0, 4.0]),
        (rates(sent[1].command), [-1.0, 1.0]),
    ] {
        assert!(
            got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-6),
            "{got:?}"
        );
    }
    assert_ne!(sent[0].id, sent[1].id);
    // The cmd and pose columns come from the file at each sample's time.
    let at = |t: f64| {
        log.samples
            .iter()
            .find(|s| (s.t_s - t).abs() < 1e-9)
            .expect("sample")
    };
    assert_eq!(at(0.025).cmd_mps, Sides::new(0.33, 0.66));
    assert!((at(0.025).yaw_rad.expect("yaw") - 0.05).abs() < 1e-12);
    assert_eq!(at(0.15).cmd_mps, Sides::new(-0.165, 0.165));
    assert_eq!(at(0.15).yaw_rad, Some(0.1));
}

#[test]
fn bad_commands_and_unknown_formats_are_refused_up_front() {
    let options = RecordOptions {
        commands: vec![CommandRow {
            t_s: 0.0,
            cmd_mps: Sides::new(0.0, 200.0),
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        }],
        ..fast_options()
    };
    let (port, _) = script(Vec::new());
    let (result, _, _) = record_ports(&options, vec![port]);
    let e = result.expect_err("too fast");
    assert!(
        e.to_string().starts_with("commands row 1 (t_s = 0 s)"),
        "{e}"
    );
    let Err(e) = create_sink(Path::new("/tmp/run.parquet"), false) else {
        panic!("accepted an unknown format");
    };
    assert!(e.to_string().contains("unknown log format"), "{e}");
}

#[test]
fn a_port_that_cannot_be_opened_at_the_start_is_an_error() {
    let (result, log, _) = record_ports(&fast_options(), Vec::new());
    assert!(matches!(result, Err(RecordError::Open(_))));
    assert!(log.events.is_empty());
}

#[test]
fn the_stop_flag_ends_a_recording_waiting_for_its_device() {
    let (port, _) = script(Vec::new());
    let mut ports = VecDeque::from([port]);
    let mut open = |_: &str| {
        ports.pop_front().ok_or_else(|| SerialError::Open {
            path: "/dev/test".into(),
            source: serialport::Error::new(serialport::ErrorKind::NoDevice, "gone"),
        })
    };
    let options = RecordOptions {
        reconnect_timeout: Duration::from_secs(3600),
        ..fast_options()
    };
    let stop = AtomicBool::new(false);
    let mut log = RunLog::default();
    let started = Instant::now();
    let summary = std::thread::scope(|scope| {
        scope.spawn(|| {
            std::thread::sleep(Duration::from_millis(100));
            stop.store(true, Ordering::Relaxed);
        });
        record(&options, &mut open, &mut log, &stop, &mut |_| {})
    })
    .expect("stopped");
    assert_eq!(summary.stop, StopReason::Interrupted);
    assert!(started.elapsed() < Duration::from_secs(10));
    assert_eq!(kinds(&log), ["started", "vanished", "stopped"]);
}

/// A stream whose board reports wheel rates (Status frames) it was commanded by someone else: a
/// replay of a recording. `changes`: (sample seq, side speeds [m/s]) at which the rates change.
fn stream_with_reported_rates(n: u32, changes: &[(u32, Sides<f64>)]) -> Vec<u8> {
    let hello = Sampler::new(SamplerConfig::BOARD).hello();
    let r = f64::from(Rover::HUSKY_A200.wheel_radius_m);
    let mut frames = vec![BoardFrame::Hello(hello)];
    let mut board = RunningMeasurements::new(Scale::BOARD);
    for seq in 0..n {
        let t_us = u64::from(seq) * 5_000;
        if let Some((_, v)) = changes.iter().find(|(at, _)| *at == seq) {
            let rates = v.map(|v| (v / r) as f32);
            board.set_wheel_rates(Some(rates));
            frames.push(BoardFrame::Status(crate::replay::command_report(
                None, &hello, t_us, seq, rates,
            )));
        }
        let chips = Sides::new(
            ChipReading::Fresh(regs(4_000, 3_920)),
            ChipReading::Fresh(regs(-2_000, 400)),
        );
        push_sample(&mut frames, &mut board, Sample { t_us, seq, chips });
    }
    encode_all(&frames)
}

#[test]
fn without_a_commands_file_the_boards_reported_rates_are_the_commands() {
    // Issue 11, bug 1: a recording of a replay held no /command messages; bug 3: every model
    // frame then differed (the host had no rates for τ) while validate found none differing.
    let changes = [
        (0, Sides::new(0.0, 0.0)),
        (40, Sides::new(-0.3, 0.3)),
        (120, Sides::new(0.0, 0.6)),
    ];
    let (port, written) = script(vec![stream_with_reported_rates(200, &changes)]);
    let (result, log, _) = record_ports(&fast_options(), vec![port]);
    let summary = result.expect("recorded");
    let cmds: Vec<Sides<f64>> = log.commands.iter().map(|c| c.cmd_mps).collect();
    assert_eq!(
        cmds,
        changes.map(|(_, v)| v),
        "exact decimal speeds, no f32 noise"
    );
    assert_eq!(log.samples[100].cmd_mps, Sides::new(-0.3, 0.3));
    assert_eq!(log.samples[150].cmd_mps, Sides::new(0.0, 0.6));
    assert!(
        written.lock().expect("lock").is_empty(),
        "nothing sent back"
    );
    assert_eq!(summary.stream.models, 10);
    assert_eq!(summary.stream.model_mismatches, 0, "{summary}");
    // validate's cross-check counts by the same definition.
    let check =
        crate::validate::crosscheck::cross_check(&log.frames, &log.commands, &Rover::HUSKY_A200)
            .expect("frames");
    assert_eq!(check.model_mismatches, summary.stream.model_mismatches);
    assert!(check.agrees());
}

#[test]
fn while_waiting_for_a_vanished_device_the_status_says_how_long_and_how_to_stop() {
    let (bytes, _) = board_stream(0, 50, &[]);
    let (port, _) = script(vec![bytes]);
    let options = RecordOptions {
        reconnect_timeout: Duration::from_millis(400),
        status_every: Duration::from_millis(50),
        ..fast_options()
    };
    let (result, _, statuses) = record_ports(&options, vec![port]);
    assert_eq!(result.expect("recorded").stop, StopReason::DeviceGone);
    let waiting: Vec<String> = statuses
        .iter()
        .filter(|s| !s.connected && s.stopped.is_none())
        .map(ToString::to_string)
        .collect();
    assert!(!waiting.is_empty());
    for line in &waiting {
        assert!(line.contains("s more") && line.contains("Ctrl-C"), "{line}");
    }
    assert!(statuses
        .iter()
        .filter_map(|s| s.reconnect_left)
        .all(|left| left <= Duration::from_millis(400)));
}

#[test]
fn after_the_recording_stopped_its_last_status_promises_no_wait() {
    // Issue 34, item 9c: a recording of a replay's pty ended on "waiting 60 s more".
    let (bytes, _) = board_stream(0, 50, &[]);
    let (port, _) = script(vec![bytes]);
    let options = RecordOptions {
        port: "/dev/pts/77".into(), // a pty is not waited for; the default timeout is 60 s
        ..RecordOptions::new("")
    };
    let (result, _, statuses) = record_ports(&options, vec![port]);
    assert_eq!(result.expect("recorded").stop, StopReason::StreamEnded);
    let last = statuses.last().expect("final status");
    let line = last.to_string();
    assert!(
        !line.contains("waiting") && !line.contains("more") && !line.contains("Ctrl-C"),
        "{line}"
    );
    assert!(line.contains("[stopped]"), "{line}");
    assert_eq!(
        (last.stopped, last.reconnect_left),
        (Some(StopReason::StreamEnded), None)
    );
    assert!(statuses[..statuses.len() - 1]
        .iter()
        .all(|s| s.stopped.is_none()));
}

#[test]
fn the_status_shows_the_boards_rate_not_the_pace_the_samples_arrive_at() {
    // Issue 34, item 9c: a replay at --speed 10 showed 2000 Hz for the board's 200 Hz. Here
    // the 200 samples (one every 5 ms of board time) arrive in one read, far faster still.
    let (bytes, _) = board_stream(0, 200, &[]);
    let (port, _) = script(vec![bytes]);
    let options = RecordOptions {
        status_every: Duration::from_secs(3600), // one status, at the end, over every sample
        ..fast_options()
    };
    let (result, _, statuses) = record_ports(&options, vec![port]);
    assert_eq!(result.expect("recorded").samples, 200);
    let last = statuses.last().expect("final status");
    assert!((last.rate_hz - 200.0).abs() < 1e-9, "{} Hz", last.rate_hz);
    assert!(last.to_string().contains(" 200.0 Hz"), "{last}");
}

#[test]
fn the_log_says_when_the_run_happened() {
    let before = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("after 1970")
        .as_nanos() as u64;
    let (bytes, _) = board_stream(7_000_000, 30, &[]);
    let (port, _) = script(vec![bytes]);
    let (result, log, _) = record_ports(&fast_options(), vec![port]);
    result.expect("recorded");
    let clocks: Vec<(f64, u64)> = log
        .events
        .iter()
        .filter_map(|(t, e)| match e {
            LogEvent::WallClock { unix_ns } => Some((*t, *unix_ns)),
            _ => None,
        })
        .collect();
    assert_eq!(clocks.len(), 1, "{:?}", log.events);
    let (t_s, unix_ns) = clocks[0];
    assert_eq!(t_s, 0.0, "at the first sample's run time");
    assert!(unix_ns >= before - 1_000_000_000 && unix_ns <= before + 60_000_000_000);
}

#[test]
fn rate_hz_configures_the_board_at_its_hello_and_refuses_what_it_cannot_sustain() {
    let options = RecordOptions {
        sample_period_us: Some(500),
        ..fast_options()
    };
    let (bytes, _) = board_stream(0, 10, &[]);
    // The board acks the Configure (id 1): the recorder asks for its hello again.
    let ack = encode_all(&[BoardFrame::Ack { id: 1 }]);
    let (port, written) = script(vec![bytes, ack]);
    let (result, _, _) = record_ports(&options, vec![port]);
    result.expect("recorded");
    let mut sent = Vec::new();
    wire::FrameDecoder::new().feed::<HostFrame>(&written.lock().expect("lock"), |f| {
        sent.push(f.expect("valid"));
    });
    let want = Command::Configure {
        adc: AdcConfig::smoothest_for_period(500).expect("2 kHz"),
        sample_period_us: 500,
    };
    assert_eq!(
        sent.iter().map(|f| f.command).collect::<Vec<_>>(),
        [want, Command::GetHello]
    );
    assert_eq!(sent[0].id, 1);

    // The board's own period: nothing to send.
    let same = RecordOptions {
        sample_period_us: Some(5_000),
        ..fast_options()
    };
    let (bytes, _) = board_stream(0, 10, &[]);
    let (port, written) = script(vec![bytes]);
    record_ports(&same, vec![port]).0.expect("recorded");
    assert!(written.lock().expect("lock").is_empty());

    // Faster than the bus, or a period the averaging cannot have: refused before recording.
    for period in [499, 2_000_000] {
        let bad = RecordOptions {
            sample_period_us: Some(period),
            ..fast_options()
        };
        let err = bad.validate().expect_err("refused");
        assert!(err.to_string().contains("2000 Hz"), "{err}");
    }

    // A board that refuses it ends the recording with the reason.
    let (mut bytes, _) = board_stream(0, 3, &[]);
    bytes.extend(encode_all(&[BoardFrame::Rejected {
        id: Some(1),
        reason: wire::Rejection::OutOfRange,
    }]));
    let (port, _) = script(vec![bytes]);
    let err = record_ports(&options, vec![port]).0.expect_err("refused");
    assert!(
        err.to_string().contains("refused sampling every 500 µs"),
        "{err}"
    );
}
