//! Live recording end to end: the simulated board (the firmware's own `Board` + `Link` on the
//! INA226 models) writes into a pty; `host_tool::record` reads it through `serial::open` — the
//! code path of `/dev/ttyACM0` — into a run CSV. Every sample arrives in order, the host's
//! energy equals the board's own total bit for bit, and the recorder survives what the field
//! does to it: an unplug and replug, a file read while it is written, corrupted and dropped
//! bytes, a chip that stops answering, and forwarded commands whose τ the host mirrors.

use host_tool::log::commands::{write_commands_csv_atomically, CommandRow};
use host_tool::log::csv_sink::{events_path, read_events, CsvRunSink};
use host_tool::log::run_csv::{read_run_csv, RunSample};
use host_tool::log::run_log::LogEvent;
use host_tool::record::{self, RecordOptions, RecordStatus, RecordSummary, StopReason};
use host_tool::sim::board::{Pacing, PtyBoard, PtyHooks, SimBoard};
use model_core::ina226::Scale;
use model_core::wire::{self, BoardFrame};
use model_core::Sides;
use rover_power_tests::sim_board;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Upper bound on any wait in these tests; the runs take well under it.
const DEADLINE: Duration = Duration::from_secs(60);
/// The board's sampling period [µs].
const PERIOD_US: u64 = 5_000;

/// A fresh directory, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        static N: AtomicU64 = AtomicU64::new(0);
        let path = std::env::temp_dir().join(format!(
            "record-e2e-{tag}-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&path).expect("temp dir");
        Self(path)
    }

    fn join(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn options(port: &str) -> RecordOptions {
    RecordOptions {
        reconnect_timeout: Duration::from_millis(300),
        retry_every: Duration::from_millis(20),
        status_every: Duration::from_millis(5),
        ..RecordOptions::new(port)
    }
}

/// Records `options.port` into a run CSV at `out` until the recording stops by itself.
fn record_to_csv(
    options: &RecordOptions,
    out: &Path,
    stop: &AtomicBool,
    mut on_status: impl FnMut(&RecordStatus),
) -> RecordSummary {
    let mut sink = CsvRunSink::create(out, false).expect("create the log");
    let mut open = record::serial_opener(options.read_timeout);
    record::record(options, &mut open, &mut sink, stop, &mut on_status).expect("recorded")
}

/// ∫ V·I dt per side from run CSV rows [J], each row's power covering the interval since the
/// previous row (the board's rule), restarting where `t_s` jumps by more than `max_step_s`.
fn csv_energy_j(rows: &[RunSample], max_step_s: f64) -> [f64; 2] {
    let mut e = [0.0; 2];
    for w in rows.windows(2) {
        let dt = w[1].t_s - w[0].t_s;
        if dt <= max_step_s {
            e[0] += w[1].bus_v.left * w[1].current_a.left * dt;
            e[1] += w[1].bus_v.right * w[1].current_a.right * dt;
        }
    }
    e
}

fn event_kinds(events: &[(f64, LogEvent)]) -> Vec<&'static str> {
    events
        .iter()
        .map(|(_, e)| e.short_name())
        .filter(|kind| *kind != "clock")
        .collect()
}

fn assert_strictly_increasing(rows: &[RunSample]) {
    assert!(
        rows.windows(2).all(|w| w[0].t_s < w[1].t_s),
        "t_s must strictly increase"
    );
}

#[test]
fn every_sample_arrives_in_order_and_the_energy_equals_the_boards() {
    const STEPS: u64 = 2_000; // 10 s of board time
    let dir = TempDir::new("all");
    let out = dir.join("run.csv");
    let pty = PtyBoard::spawn(sim_board(), STEPS, Pacing::AsFastAsPossible).expect("pty");
    let stop = AtomicBool::new(false);
    let summary = record_to_csv(&options(pty.path()), &out, &stop, |_| {});
    let run = pty.join().expect("writer");

    assert_eq!(summary.stop, StopReason::StreamEnded);
    assert_eq!(summary.samples, STEPS);
    let s = summary.stream;
    assert_eq!((s.lost_samples, s.bad_frames, s.board_resets), (0, 0, 0));
    // The first period only initialises the chips: no reading, no row.
    assert_eq!(summary.incomplete_samples, 1);
    let rows = read_run_csv(&out).expect("valid run CSV");
    assert_eq!(rows.len() as u64, STEPS - 1);
    assert_eq!(summary.rows, STEPS - 1);
    for (k, row) in rows.iter().enumerate() {
        assert_eq!(row.t_s, ((k as u64 + 1) * PERIOD_US) as f64 / 1e6);
        assert_eq!(row.cmd_mps, Sides::new(0.0, 0.0));
    }

    // The host's energy equals the board's own total, bit for bit, per side.
    assert_eq!(summary.segments.len(), 1);
    let board = run.board_energy_lsb_us();
    assert_ne!(board, [0, 0]);
    assert_eq!(summary.segments[0].host_energy_lsb_us, board);
    assert_eq!(s.model_mismatches, 0);
    assert!(s.models >= 99, "{}", s.models);

    // ∫V·I dt from the file agrees within the power register's quantisation (1 LSB per sample).
    let scale = Scale::BOARD;
    let from_csv = csv_energy_j(&rows, 1.0);
    let bound_j = rows.len() as f64 * scale.power_w(1) * PERIOD_US as f64 * 1e-6;
    for (side, (csv, board)) in from_csv.iter().zip(board).enumerate() {
        let board_j = scale.energy_j(board);
        assert!(
            (csv - board_j).abs() <= bound_j,
            "side {side}: file {csv} J, board {board_j} J, bound {bound_j} J"
        );
    }
    let events = read_events(&events_path(&out)).expect("events");
    assert_eq!(event_kinds(&events), ["started", "vanished", "stopped"]);
}

#[test]
fn unplug_and_replug_through_a_by_id_link_loses_nothing_and_marks_the_gap() {
    let dir = TempDir::new("replug");
    let out = dir.join("run.csv");
    let link = dir.join("usb-rover-power-if00");
    let repoint = |target: Option<&str>| {
        let _ = std::fs::remove_file(&link);
        if let Some(target) = target {
            std::os::unix::fs::symlink(target, &link).expect("symlink");
        }
    };
    let first = PtyBoard::spawn(sim_board(), 1_000_000, Pacing::AsFastAsPossible).expect("pty");
    repoint(Some(first.path()));
    let received = AtomicU64::new(0);
    let stop = AtomicBool::new(false);
    let options = RecordOptions {
        reconnect_timeout: Duration::from_secs(5),
        ..options(link.to_str().expect("utf-8 path"))
    };
    let (summary, first_run, second_run) = std::thread::scope(|scope| {
        let recorder = scope.spawn(|| {
            record_to_csv(&options, &out, &stop, |s| {
                received.store(s.samples, Ordering::Relaxed);
            })
        });
        let start = Instant::now();
        while received.load(Ordering::Relaxed) < 300 {
            assert!(
                start.elapsed() < DEADLINE,
                "no samples from the first board"
            );
            std::thread::sleep(Duration::from_millis(2));
        }
        // Unplug: the board stops mid-stream and its device disappears.
        first.stop();
        let first_run = first.join().expect("first board");
        repoint(None);
        std::thread::sleep(Duration::from_millis(100));
        // Replug: the board comes back (rebooted) under the same by-id name.
        let second = PtyBoard::spawn(sim_board(), 400, Pacing::AsFastAsPossible).expect("pty");
        repoint(Some(second.path()));
        let second_run = second.join().expect("second board");
        repoint(None);
        stop.store(true, Ordering::Relaxed);
        (recorder.join().expect("recorder"), first_run, second_run)
    });
    assert!(first_run.steps >= 300);
    assert_eq!(summary.samples, first_run.steps + second_run.steps);
    assert_eq!((summary.vanished, summary.reconnects), (2, 1));
    assert_eq!(summary.stream.lost_samples, 0);
    assert_eq!(summary.segments.len(), 2);
    assert_eq!(summary.segments[0].samples, first_run.steps);
    assert_eq!(summary.segments[1].samples, second_run.steps);
    assert_eq!(
        summary.segments[0].host_energy_lsb_us,
        first_run.board_energy_lsb_us()
    );
    assert_eq!(
        summary.segments[1].host_energy_lsb_us,
        second_run.board_energy_lsb_us()
    );

    let rows = read_run_csv(&out).expect("valid run CSV");
    assert_strictly_increasing(&rows);
    // Every sample of the first board (after its initialising one) is in the file, in order.
    let first_rows = first_run.steps as usize - 1;
    for (k, row) in rows[..first_rows].iter().enumerate() {
        assert_eq!(row.t_s, ((k as u64 + 1) * PERIOD_US) as f64 / 1e6);
    }
    assert_eq!(rows.len(), first_rows + second_run.steps as usize - 1);
    // The second board's samples follow after the time it was away, 5 ms apart again.
    let gap_s = rows[first_rows].t_s - rows[first_rows - 1].t_s;
    assert!(gap_s > 0.1, "gap {gap_s} s");
    assert!((rows[first_rows + 1].t_s - rows[first_rows].t_s - 0.005).abs() < 1e-9);

    let events = read_events(&events_path(&out)).expect("events");
    assert_eq!(
        event_kinds(&events),
        [
            "started",
            "vanished",
            "reconnected",
            "reset",
            "vanished",
            "stopped"
        ]
    );
    let (vanished_at, _) = *events
        .iter()
        .find(|(_, e)| matches!(e, LogEvent::DeviceVanished { .. }))
        .expect("vanished");
    assert_eq!(
        vanished_at,
        rows[first_rows - 1].t_s,
        "marked at the last sample"
    );
}

#[test]
fn the_run_csv_is_a_valid_prefix_while_it_is_being_written() {
    let dir = TempDir::new("live-read");
    let out = dir.join("run.csv");
    let pty = PtyBoard::spawn(sim_board(), 1_000_000, Pacing::Scaled(10.0)).expect("pty");
    let stop = AtomicBool::new(false);
    let options = options(pty.path());
    let (summary, snapshots) = std::thread::scope(|scope| {
        let recorder = scope.spawn(|| record_to_csv(&options, &out, &stop, |_| {}));
        let mut snapshots: Vec<Vec<RunSample>> = Vec::new();
        let start = Instant::now();
        while snapshots.iter().filter(|s| !s.is_empty()).count() < 4 {
            assert!(start.elapsed() < DEADLINE, "the file never grew");
            std::thread::sleep(Duration::from_millis(150));
            if out.exists() {
                // Whatever moment we look, the file is a valid run CSV.
                snapshots.push(read_run_csv(&out).expect("valid while recording"));
            }
        }
        // The board goes away; the recorder reads what it sent and stops (a pty hang-up is final).
        pty.stop();
        (recorder.join().expect("recorder"), snapshots)
    });
    assert_eq!(summary.stop, StopReason::StreamEnded);
    let last = read_run_csv(&out).expect("valid");
    assert_eq!(last.len() as u64, summary.rows);
    let mut previous = 0;
    for snapshot in &snapshots {
        assert!(snapshot.len() >= previous, "the file only grows");
        assert_eq!(snapshot.as_slice(), &last[..snapshot.len()], "a prefix");
        previous = snapshot.len();
    }
    let run = pty.join().expect("writer");
    assert_eq!(summary.samples, run.steps);
}

/// Indices (start, end) of the frames in `bytes` (each ends at its 0x00).
fn frame_spans(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut start = 0;
    for (i, &b) in bytes.iter().enumerate() {
        if b == 0 {
            spans.push((start, i));
            start = i + 1;
        }
    }
    spans
}

#[test]
fn corrupted_and_dropped_bytes_lose_exactly_the_frames_they_hit() {
    const STEPS: u64 = 3_000;
    let dir = TempDir::new("corrupt");
    let out = dir.join("run.csv");
    let hit = Arc::new(Mutex::new(0u64));
    let garbage = Arc::new(Mutex::new(0u64));
    let (hit_in_line, garbage_in_line) = (Arc::clone(&hit), Arc::clone(&garbage));
    let line = move |step: u64, bytes: &mut Vec<u8>| {
        if !(20..=STEPS - 20).contains(&step) {
            return;
        }
        if step.is_multiple_of(97) {
            // Noise on the line between frames: a bad frame, no sample lost.
            bytes.splice(0..0, [0x13, 0x37, 0x42, 0x00]);
            if let Ok(mut n) = garbage_in_line.lock() {
                *n += 1;
            }
            return;
        }
        if !step.is_multiple_of(37) {
            return;
        }
        let Some((start, end)) = frame_spans(bytes).into_iter().find(|&(s, e)| {
            let mut frame = bytes[s..e].to_vec();
            matches!(
                wire::decode_frame::<BoardFrame>(&mut frame),
                Ok(BoardFrame::Sample(_))
            )
        }) else {
            return;
        };
        let at = start + (step as usize / 37) % (end - start);
        if step.is_multiple_of(2) {
            bytes.remove(at); // a dropped byte
        } else {
            // A flipped byte, never into a delimiter.
            bytes[at] = if bytes[at] == 0xA5 {
                0x5A
            } else {
                bytes[at] ^ 0xA5
            };
            if bytes[at] == 0 {
                bytes[at] = 0x01;
            }
        }
        if let Ok(mut n) = hit_in_line.lock() {
            *n += 1;
        }
    };
    let hooks = PtyHooks {
        line: Some(Box::new(line)),
        ..PtyHooks::default()
    };
    let pty =
        PtyBoard::spawn_with(sim_board(), STEPS, Pacing::AsFastAsPossible, hooks).expect("pty");
    let stop = AtomicBool::new(false);
    let summary = record_to_csv(&options(pty.path()), &out, &stop, |_| {});
    pty.join().expect("writer");
    let hit = *hit.lock().expect("lock");
    let garbage = *garbage.lock().expect("lock");
    assert!(hit > 50, "{hit}");
    let s = summary.stream;
    assert_eq!(
        s.lost_samples, hit,
        "every corrupted sample, and only those, is lost"
    );
    assert_eq!(s.gaps, hit);
    assert_eq!(s.bad_frames, hit + garbage);
    assert_eq!(summary.samples, STEPS - hit);
    let rows = read_run_csv(&out).expect("valid run CSV");
    assert_eq!(rows.len() as u64, STEPS - 1 - hit);
    assert_strictly_increasing(&rows);
    // The log marks every loss.
    let events = read_events(&events_path(&out)).expect("events");
    let (mut lost, mut bad) = (0u64, 0u64);
    for (_, e) in &events {
        match e {
            LogEvent::SamplesLost { missing, .. } => lost += u64::from(*missing),
            LogEvent::BadFrames { count } => bad += count,
            _ => {}
        }
    }
    assert_eq!((lost, bad), (hit, hit + garbage));
}

#[test]
fn a_chip_that_nacks_mid_run_is_named_and_the_stream_goes_on() {
    const STEPS: u64 = 1_000;
    let dir = TempDir::new("nack");
    let out = dir.join("run.csv");
    let hooks = PtyHooks {
        before_step: Some(Box::new(|step, board: &mut SimBoard| {
            if step == 300 {
                board.bus_mut().unplug(0x45);
            }
            if step == 600 {
                board.bus_mut().plug(0x45);
            }
        })),
        ..PtyHooks::default()
    };
    let pty = PtyBoard::spawn_with(sim_board(), STEPS, Pacing::Scaled(20.0), hooks).expect("pty");
    let stop = AtomicBool::new(false);
    let mut named = Vec::new();
    let summary = record_to_csv(&options(pty.path()), &out, &stop, |status| {
        if status.chip_faults.right.is_some() {
            named.push(status.to_string());
        }
        assert_eq!(status.chip_faults.left, None, "the left chip never fails");
    });
    let run = pty.join().expect("writer");
    assert_eq!(summary.samples, STEPS, "the stream went on");
    assert_eq!(summary.stream.lost_samples, 0);
    assert!(
        named
            .iter()
            .any(|line| line.contains("right chip 0x45: AddressNack")),
        "{named:?}"
    );
    // 300 NACKed periods, then the chip is set up again before it reports.
    assert!(summary.incomplete_samples > 300 && summary.incomplete_samples < 320);
    assert_eq!(summary.rows, STEPS - summary.incomplete_samples);
    assert_eq!(
        summary.segments[0].host_energy_lsb_us,
        run.board_energy_lsb_us()
    );
    let status = run
        .board
        .board()
        .status(run.board.link(), run.board.now_us());
    assert!(status.i2c_errors.right >= 300);
    assert_eq!(status.last_fault.right, None, "recovered");
}

#[test]
fn forwarded_commands_are_acked_and_the_host_tau_equals_the_boards() {
    let dir = TempDir::new("commands");
    let out = dir.join("run.csv");
    let commands = dir.join("commands.csv");
    let row = |t_s: f64, left: f64, right: f64, yaw: Option<f64>| CommandRow {
        t_s,
        cmd_mps: Sides::new(left, right),
        yaw_rad: yaw,
        pitch_deg: None,
        x_m: None,
        y_m: None,
    };
    let rows = [
        row(0.0, 0.5, 0.5, Some(0.0)),
        row(0.5, 0.5, 0.5, None), // same speeds: no new command
        row(1.0, 0.2, 0.8, Some(0.4)),
        row(2.0, 0.55, 0.0, None), // inner wheel stopped: its τ is undefined
        row(3.0, -0.3, 0.3, Some(1.0)),
    ];
    write_commands_csv_atomically(&commands, host_tool::log::Existing::Replace, &rows)
        .expect("commands file");
    let pty = PtyBoard::spawn(sim_board(), 1_000, Pacing::Scaled(20.0)).expect("pty");
    let options = RecordOptions {
        commands: host_tool::log::commands::read_commands_csv(&commands).expect("read"),
        ..options(pty.path())
    };
    let stop = AtomicBool::new(false);
    let summary = record_to_csv(&options, &out, &stop, |_| {});
    let run = pty.join().expect("writer");

    assert_eq!(
        (
            summary.commands_sent,
            summary.commands_acked,
            summary.commands_rejected
        ),
        (4, 4, 0)
    );
    // Every model frame the board sent equals the host's recomputation: power, energy and τ.
    let s = summary.stream;
    assert!(s.models >= 45, "{}", s.models);
    assert_eq!(s.model_mismatches, 0);
    let last = summary.segments[0].last_model.expect("model frames");
    assert_eq!(last.board.snapshot, last.host);
    let tau = last.host.torque_proportional;
    assert!(tau.left.is_some() && tau.right.is_some(), "{tau:?}");
    let rates = options.wheel_rates(Sides::new(-0.3, 0.3));
    assert_eq!(
        run.board.board().sampler().measurements().wheel_rates(),
        Some(rates)
    );
    assert_eq!(
        summary.segments[0].host_energy_lsb_us,
        run.board_energy_lsb_us()
    );

    // The file's cmd and pose columns follow the commands file.
    let csv = read_run_csv(&out).expect("valid run CSV");
    let at = |t: f64| {
        csv.iter()
            .find(|r| (r.t_s - t).abs() < 1e-9)
            .copied()
            .expect("row")
    };
    assert_eq!(at(0.75).cmd_mps, Sides::new(0.5, 0.5));
    assert!((at(0.5).yaw_rad.expect("yaw") - 0.2).abs() < 1e-12);
    assert_eq!(at(2.5).cmd_mps, Sides::new(0.55, 0.0));
    assert_eq!(at(4.0).cmd_mps, Sides::new(-0.3, 0.3));
    assert_eq!(at(4.0).yaw_rad, Some(1.0));
}

#[test]
fn the_board_reports_wheel_rates_of_forwarded_commands_in_its_status() {
    // The command reaches the board through the pty before the board's stream ends, and the
    // board's own status frame shows it: the path is live, not only logged.
    let pty = PtyBoard::spawn(sim_board(), 600, Pacing::Scaled(20.0)).expect("pty");
    let options = RecordOptions {
        commands: vec![CommandRow {
            t_s: 0.1,
            cmd_mps: Sides::new(0.33, -0.33),
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        }],
        ..options(pty.path())
    };
    let mut log = host_tool::log::run_log::RunLog::default();
    let mut open = record::serial_opener(options.read_timeout);
    let stop = AtomicBool::new(false);
    record::record(&options, &mut open, &mut log, &stop, &mut |_| {}).expect("recorded");
    pty.join().expect("writer");
    let reported = log.frames.iter().rev().find_map(|(_, f)| match f {
        BoardFrame::Status(s) => s.wheel_rates_rad_s,
        _ => None,
    });
    assert_eq!(reported, Some(options.wheel_rates(Sides::new(0.33, -0.33))));
}

/// Issue 13: `record --rate-hz 2000` against the board at its default 200 Hz: the recorder
/// configures it at its hello, the board answers and samples every 500 µs from then on, and
/// nothing is lost on the way: every sample arrives and the host's energy is the board's.
#[test]
fn rate_hz_reconfigures_the_board_and_every_sample_still_arrives() {
    const STEPS: u64 = 4_000;
    let dir = TempDir::new("rate");
    let out = dir.join("run.csv");
    let pty = PtyBoard::spawn(sim_board(), STEPS, Pacing::Scaled(20.0)).expect("pty");
    let options = RecordOptions {
        sample_period_us: Some(500),
        ..options(pty.path())
    };
    let stop = AtomicBool::new(false);
    let summary = record_to_csv(&options, &out, &stop, |_| {});
    let run = pty.join().expect("writer");

    assert_eq!(summary.samples, STEPS);
    let s = summary.stream;
    assert_eq!((s.lost_samples, s.bad_frames, s.board_resets), (0, 0, 0));
    // Power-up, and the sample at which the new averaging started converting.
    assert_eq!(summary.incomplete_samples, 2);
    assert_eq!(
        summary.segments[0].host_energy_lsb_us,
        run.board_energy_lsb_us()
    );
    assert_eq!(s.model_mismatches, 0);
    let rows = read_run_csv(&out).expect("valid run CSV");
    let fast = rows
        .windows(2)
        .filter(|w| ((w[1].t_s - w[0].t_s) - 0.000_5).abs() < 1e-9)
        .count() as u64;
    assert!(
        fast > STEPS - 100,
        "{fast} of {} intervals at 500 µs",
        rows.len()
    );
    assert_strictly_increasing(&rows);
}
