//! The simulated board (the firmware's own `Board` + `Link` on the INA226 models) writes into a
//! pseudo-terminal; the host opens the pty's path with `host_tool::serial::open` and reads it with
//! `PortReader` into the `StreamDecoder` — the code path of a real `/dev/ttyACM0`.

use host_tool::decode::{Event, StreamDecoder};
use host_tool::serial::{self, PortReader, ReadOutcome};
use host_tool::sim::board::{Pacing, PtyBoard};
use model_core::wire::{BoardFrame, Sample};
use rover_power_tests::{assert_host_energy_is_the_boards, sim_board};
use std::time::{Duration, Instant};

/// Upper bound on any test's wall-clock time; the runs below take well under a second.
const DEADLINE: Duration = Duration::from_secs(30);

/// Everything the host saw until the device vanished.
struct Received {
    decoder: StreamDecoder,
    events: Vec<Event>,
    /// How it vanished: `None` for end of file.
    vanished_error: Option<std::io::ErrorKind>,
    bytes_read: u64,
}

impl Received {
    fn samples(&self) -> Vec<Sample> {
        self.events
            .iter()
            .filter_map(|e| match e {
                Event::Frame(BoardFrame::Sample(s)) => Some(*s),
                _ => None,
            })
            .collect()
    }
}

/// Reads `pty` until the device vanishes; `on_samples` sees the sample count after each read.
fn read_until_vanished(pty: &PtyBoard, mut on_samples: impl FnMut(u64)) -> Received {
    let port = serial::open(pty.path(), Duration::from_millis(20)).expect("open the pty slave");
    let mut reader = PortReader::new(port);
    let mut decoder = StreamDecoder::new();
    let mut events = Vec::new();
    let start = Instant::now();
    let vanished_error = loop {
        assert!(start.elapsed() < DEADLINE, "the stream never ended");
        match reader.poll(&mut decoder, |e| events.push(e)) {
            ReadOutcome::Data(_) => on_samples(decoder.stats().samples),
            ReadOutcome::NoData => {}
            ReadOutcome::Vanished { error } => break error.map(|e| e.kind()),
        }
    };
    Received {
        bytes_read: reader.bytes_read(),
        decoder,
        events,
        vanished_error,
    }
}

fn assert_in_order_without_gaps(samples: &[Sample]) {
    assert!(samples
        .iter()
        .enumerate()
        .all(|(i, s)| s.seq == i as u32 && s.t_us == i as u64 * 5_000));
}

#[test]
fn every_sample_arrives_through_the_pty_in_order_and_energy_matches_the_board() {
    const STEPS: u64 = 2_000; // 10 s of board time at 200 Hz
    let pty = PtyBoard::spawn(sim_board(), STEPS, Pacing::AsFastAsPossible).expect("pty");
    let got = read_until_vanished(&pty, |_| {});
    let run = pty.join().expect("writer");
    assert_eq!(run.steps, STEPS);

    assert!(
        matches!(got.events.first(), Some(Event::Frame(BoardFrame::Hello(_)))),
        "hello comes first"
    );
    let samples = got.samples();
    assert_eq!(samples.len() as u64, STEPS);
    assert_in_order_without_gaps(&samples);
    let stats = got.decoder.stats();
    assert_eq!(
        (stats.bad_frames, stats.lost_samples, stats.gaps),
        (0, 0, 0)
    );
    assert_eq!(run.board.link().queue_drops(), 0);

    // The board's latest model frame equals the host's recomputation, bit for bit, and the
    // board's own total at its last sample equals the host's.
    let (model_seq, board_total) = assert_host_energy_is_the_boards(&got.decoder, &run.board);
    assert!(model_seq >= 1_980);
    assert_ne!(board_total, 0);
    // The device vanished when the writer closed the pty, after the host had read every byte.
    assert_eq!(got.bytes_read, run.bytes);
    eprintln!("vanished with {:?}", got.vanished_error);
}

#[test]
fn a_board_that_vanishes_mid_stream_loses_no_sample_it_sent() {
    // Planned for much longer than the test runs; stopped once the host has 300 samples.
    let pty = PtyBoard::spawn(sim_board(), 1_000_000, Pacing::AsFastAsPossible).expect("pty");
    let got = read_until_vanished(&pty, |samples| {
        if samples >= 300 {
            pty.stop();
        }
    });
    let run = pty.join().expect("writer");
    assert!(run.steps >= 300 && run.steps < 1_000_000, "{}", run.steps);

    let samples = got.samples();
    // Every sample the board sent before the pty closed was read and decoded: exactly.
    assert_eq!(
        samples.len() as u64,
        u64::from(run.board.board().sampler().samples())
    );
    assert_eq!(samples.len() as u64, run.steps);
    assert_in_order_without_gaps(&samples);
    assert_eq!(got.decoder.stats().bad_frames, 0);
    assert_eq!(got.bytes_read, run.bytes);
    assert_eq!(
        got.decoder.measurements().total_energy_lsb_us(),
        run.board
            .board()
            .sampler()
            .measurements()
            .total_energy_lsb_us()
    );
}
