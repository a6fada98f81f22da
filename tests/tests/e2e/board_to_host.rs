//! The firmware's own `Board` (sampler + link) against the host tool's register-level INA226
//! model (`host_tool::sim::SimBus`: conversion timing, averaging, quantisation, NACK), its USB
//! bytes drained in 64-byte packets and read by the host's `StreamDecoder`: every sample arrives
//! in order, the board's energy equals the host's recomputation and ∫V·I dt, and faults are
//! reported.

use firmware::sampler::SamplerConfig;
use host_tool::decode::{Event, StreamDecoder, Summary};
use host_tool::sim::board::{SideLoad, SimBoard};
use host_tool::sim::ina226::reg;
use model_core::ina226::AdcConfig;
use model_core::wire::{self, BoardFrame, ChipFault, ChipReading, Command, HostFrame, Rejection};
use model_core::Sides;
use rover_power_tests::{assert_host_energy_is_the_boards, turn_like_load};

/// The board's sampling period in these tests [µs] (none of them reconfigures it).
const PERIOD_US: u64 = 5_000;

/// The shared turn-like load, held over each period: what flows from tick `k` until the next.
fn load(k: u64) -> Sides<SideLoad> {
    turn_like_load(k * PERIOD_US)
}

/// The simulated board with a host attached, and everything it sent.
struct Rig {
    sim: SimBoard,
    wire: Vec<u8>,
}

impl Rig {
    fn new() -> Self {
        let mut sim = SimBoard::new(SamplerConfig::BOARD);
        sim.set_host_connected(true);
        // The load of a period flows from its tick until the next; the chips convert
        // continuously and the board reads the results completed by then.
        sim.set_load(|t_us: u64| load(t_us / PERIOD_US));
        Self {
            sim,
            wire: Vec::new(),
        }
    }

    fn command(&mut self, id: u16, command: Command) {
        let mut buf = [0u8; wire::MAX_FRAME];
        let n = wire::encode(&HostFrame { id, command }, &mut buf).expect("fits");
        self.sim.receive(&buf[..n]);
    }

    /// `ticks` sample periods, USB drained after each in full-speed packets.
    fn run(&mut self, ticks: u64) {
        for _ in 0..ticks {
            self.sim.step();
            self.sim
                .drain_into(&mut self.wire)
                .expect("a Vec takes every byte");
        }
    }
}

fn decode(bytes: &[u8]) -> (StreamDecoder, Vec<Event>) {
    let mut dec = StreamDecoder::new();
    let mut events = Vec::new();
    dec.feed(bytes, |e| events.push(e));
    (dec, events)
}

fn samples(events: &[Event]) -> Vec<model_core::wire::Sample> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Frame(BoardFrame::Sample(s)) => Some(*s),
            _ => None,
        })
        .collect()
}

#[test]
fn every_sample_arrives_in_order_and_energy_matches_the_board() {
    let mut rig = Rig::new();
    rig.run(4_000); // 20 s at 200 Hz
    let (dec, events) = decode(&rig.wire);
    assert!(
        matches!(events.first(), Some(Event::Frame(BoardFrame::Hello(_)))),
        "hello comes first"
    );
    let samples = samples(&events);
    assert_eq!(samples.len(), 4_000);
    assert!(samples
        .iter()
        .enumerate()
        .all(|(i, s)| s.seq == i as u32 && s.t_us == i as u64 * 5_000));
    // The first period only initialises the chips (the configuration write restarts their
    // conversions); every later one reads a fresh 4.48 ms result, 5 ms apart.
    assert_eq!(
        samples[0].chips,
        Sides::new(
            ChipReading::Failed(ChipFault::AwaitingConversion),
            ChipReading::Failed(ChipFault::AwaitingConversion)
        )
    );
    assert!(samples.iter().skip(1).all(|s| matches!(
        s.chips,
        Sides {
            left: ChipReading::Fresh(_),
            right: ChipReading::Fresh(_)
        }
    )));
    let stats = dec.stats();
    assert_eq!((stats.bad_frames, stats.lost_samples), (0, 0));

    // The board's latest model frame equals the host's recomputation at that sample, bit for
    // bit, and the board's own total at the end equals the host's.
    let (model_seq, board_total) = assert_host_energy_is_the_boards(&dec, &rig.sim);
    assert!(model_seq >= 3_980);

    // Against physics: ∫ V·I dt of the applied load (the load set at tick k flows until tick
    // k + 1; the board integrates from its first good reading at tick 1 to its last, 3999),
    // within the registers' quantisation and the one-period lag of the averaging window.
    let scale = dec.scale();
    let expected_j: f64 = (1..3_999u64)
        .map(|k| {
            let l = load(k);
            (l.left.current_a * l.left.bus_v + l.right.current_a * l.right.bus_v)
                * PERIOD_US as f64
                * 1e-6
        })
        .sum();
    let got_j = scale.energy_j(board_total);
    assert!(
        (got_j - expected_j).abs() < 0.002 * expected_j.abs(),
        "{got_j} J vs {expected_j} J"
    );
    // The capture summary (`host-tool decode`) tells the same story.
    let summary = Summary::of(&rig.wire);
    assert_eq!(summary.stats.samples, 4_000);
    assert_eq!(
        summary.host_energy_lsb_us[0] + summary.host_energy_lsb_us[1],
        board_total
    );
    assert_eq!(
        summary.hello.map(|h| h.addresses),
        Some(Sides::new(0x40, 0x45))
    );
    let text = summary.to_string();
    assert!(text.contains("lost samples 0 in 0 gaps"), "{text}");
    assert!(
        text.contains("differs by 0.000000 J / 0.000000 J"),
        "{text}"
    );
    // The regenerating side reports negative power at times (sign from the current register).
    assert!(samples.iter().any(|s| s
        .chips
        .left
        .registers()
        .is_some_and(|r| r.signed_power_lsb() < 0)));
}

#[test]
fn a_chip_that_nacks_mid_run_does_not_stop_the_stream_and_is_reinitialised_after_replug() {
    let mut rig = Rig::new();
    rig.run(500);
    assert!(rig.sim.bus_mut().unplug(0x45));
    rig.run(300);
    // Plugged back in: it powers up with its defaults (no calibration).
    assert!(rig.sim.bus_mut().plug(0x45));
    assert_eq!(rig.sim.bus_mut().peek(0x45, reg::CALIBRATION), Some(0));
    rig.run(300);
    let (dec, events) = decode(&rig.wire);
    let samples = samples(&events);
    assert_eq!(samples.len(), 1_100, "the stream never stopped");
    assert!(samples[500..800]
        .iter()
        .all(|s| s.chips.right == ChipReading::Failed(ChipFault::AddressNack)));
    assert!(samples[500..800]
        .iter()
        .all(|s| matches!(s.chips.left, ChipReading::Fresh(_))));
    // Replugged at sample 800: re-initialised there, read from the next period on.
    assert_eq!(
        samples[800].chips.right,
        ChipReading::Failed(ChipFault::AwaitingConversion)
    );
    assert!(samples[801..]
        .iter()
        .all(|s| s.chips.right.registers().is_some()));
    let statuses: Vec<_> = events
        .iter()
        .filter_map(|e| match e {
            Event::Frame(BoardFrame::Status(s)) => Some(*s),
            _ => None,
        })
        .collect();
    let during = statuses
        .iter()
        .find(|s| s.samples > 600 && s.samples < 800)
        .expect("a status while unplugged");
    assert_eq!(
        during.last_fault,
        Sides::new(None, Some(ChipFault::AddressNack))
    );
    assert!(during.i2c_errors.right > 0 && during.i2c_errors.left == 0);
    assert_eq!(rig.sim.board().sampler().i2c_errors(), Sides::new(0, 300));
    assert_eq!(rig.sim.board().sampler().reinits(), Sides::new(0, 1));
    // One NACKed transaction per period while unplugged; none on the left.
    assert_eq!(rig.sim.bus().counts(0x45).failed, 300);
    assert_eq!(rig.sim.bus().counts(0x40).failed, 0);
    assert_eq!(rig.sim.bus_mut().peek(0x45, reg::CALIBRATION), Some(2048));
    assert_eq!(dec.stats().lost_samples, 0);
}

#[test]
fn a_chip_that_resets_under_load_is_caught_and_set_up_again() {
    let mut rig = Rig::new();
    rig.run(100);
    // Brown-out: registers back to power-on defaults (CAL 0, AVG 1, 1.1 ms + 1.1 ms) while
    // current keeps flowing; the chip converts on with the default configuration.
    assert!(rig.sim.bus_mut().brown_out(0x40));
    rig.run(100);
    let (_, events) = decode(&rig.wire);
    let samples = samples(&events);
    assert_eq!(
        samples[100].chips.left,
        ChipReading::Failed(ChipFault::ResetDetected)
    );
    assert_eq!(
        samples[101].chips.left,
        ChipReading::Failed(ChipFault::AwaitingConversion)
    );
    assert!(samples[102..]
        .iter()
        .all(|s| s.chips.left.registers().is_some()));
    assert_eq!(rig.sim.board().sampler().reinits(), Sides::new(1, 0));
    // Calibration really was rewritten.
    assert_eq!(rig.sim.bus_mut().peek(0x40, reg::CALIBRATION), Some(2048));
    assert_eq!(
        rig.sim.bus_mut().peek(0x40, reg::CONFIG),
        Some(firmware::ina226::Ina226::config_word(
            AdcConfig::BOARD_DEFAULT
        ))
    );
}

#[test]
fn corrupted_bytes_lose_exactly_the_corrupted_frames() {
    let mut rig = Rig::new();
    rig.run(1_000);
    // Split the stream into frames, corrupt every 7th frame in its middle, and count how many of
    // those were samples.
    let frames: Vec<&[u8]> = rig.wire.split_inclusive(|&b| b == 0).collect();
    let mut corrupted = Vec::new();
    let mut lost_samples = 0;
    let mut bad_frames = 0;
    for (i, f) in frames.iter().enumerate() {
        let mut f = f.to_vec();
        if i % 7 == 3 {
            let is_sample = matches!(
                wire::decode_frame::<BoardFrame>(&mut f.clone()[..f.len() - 1]),
                Ok(BoardFrame::Sample(_))
            );
            lost_samples += u64::from(is_sample);
            bad_frames += 1;
            let mid = f.len() / 2;
            f[mid] = if f[mid] == 0xA5 { 0x5A } else { 0xA5 };
        }
        corrupted.extend(f);
    }
    let (dec, events) = decode(&corrupted);
    assert!(lost_samples > 100);
    assert_eq!(dec.stats().lost_samples, lost_samples);
    // Each corrupted frame fails its COBS or CRC check; nothing else is lost.
    assert_eq!(dec.stats().bad_frames, bad_frames);
    assert_eq!(samples(&events).len() as u64, 1_000 - lost_samples);
}

#[test]
fn host_commands_are_answered_and_take_effect() {
    let mut rig = Rig::new();
    rig.run(10);
    // R' turn of a Husky at v_c = 0.3 m/s: inner wheel still, outer 0.6 m/s.
    rig.command(1, Command::SetWheelRates(Sides::new(0.0, 0.6 / 0.165)));
    rig.command(
        2,
        Command::Configure {
            adc: AdcConfig::BOARD_DEFAULT,
            sample_period_us: 100,
        },
    );
    rig.command(3, Command::ResetEnergy);
    rig.command(4, Command::GetStatus);
    rig.sim.receive(&[1, 2, 3, 0]); // garbage frame
    rig.run(30);
    let (_, events) = decode(&rig.wire);
    let frames: Vec<BoardFrame> = events
        .iter()
        .filter_map(|e| match e {
            Event::Frame(f) => Some(*f),
            _ => None,
        })
        .collect();
    let replies: Vec<BoardFrame> = frames
        .iter()
        .copied()
        .filter(|f| matches!(f, BoardFrame::Ack { .. } | BoardFrame::Rejected { .. }))
        .collect();
    assert_eq!(
        replies,
        vec![
            BoardFrame::Rejected {
                id: None,
                reason: Rejection::Malformed
            },
            BoardFrame::Ack { id: 1 },
            BoardFrame::Rejected {
                id: Some(2),
                reason: Rejection::OutOfRange
            },
            BoardFrame::Ack { id: 3 },
            BoardFrame::Ack { id: 4 },
        ]
    );
    let last_model = frames.iter().rev().find_map(|f| match f {
        BoardFrame::Model(m) => Some(*m),
        _ => None,
    });
    let tau = last_model
        .expect("model frame")
        .snapshot
        .torque_proportional;
    assert_eq!(tau.left, None, "inner wheel at R' has no τ ∝ P/ω");
    assert!(tau.right.is_some_and(|t| t > 0.0));
    // Energy restarted at the reset: 30 periods of at most ~150 W.
    let total = rig
        .sim
        .board()
        .sampler()
        .measurements()
        .total_energy_lsb_us();
    assert!(model_core::ina226::Scale::BOARD.energy_j(total) < 30.0 * 0.005 * 150.0);
}
