//! The firmware's own `Board` (sampler + link) against a register-level INA226 fake, its USB
//! bytes drained in 64-byte packets and read by the host's `StreamDecoder`: every sample arrives
//! in order, the board's energy equals the host's recomputation, and faults are reported.

use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use firmware::board::Board;
use firmware::link::Link;
use firmware::sampler::SamplerConfig;
use host_tool::decode::{Event, StreamDecoder, Summary};
use model_core::ina226::AdcConfig;
use model_core::wire::{self, BoardFrame, ChipFault, ChipReading, Command, HostFrame, Rejection};
use model_core::Sides;
use std::collections::BTreeMap;

/// Register file of one INA226 with the behaviour the driver relies on: ID registers, pointer
/// writes, software reset, conversion-ready flag cleared on read, and current/power derived from
/// shunt and bus through the calibration register exactly as the datasheet's Eq 3–4.
#[derive(Debug, Clone)]
struct FakeIna226 {
    regs: [u16; 256],
    pointer: u8,
    present: bool,
}

impl FakeIna226 {
    fn powered_on() -> Self {
        let mut regs = [0u16; 256];
        regs[0x00] = 0x4127;
        regs[0xFE] = 0x5449;
        regs[0xFF] = 0x2260;
        Self {
            regs,
            pointer: 0,
            present: true,
        }
    }

    /// A new conversion result for `amps` at `volts` on a 5 mΩ shunt.
    fn convert(&mut self, amps: f64, volts: f64) {
        let shunt = (amps * 0.005 / 2.5e-6).round().clamp(-32768.0, 32767.0) as i16;
        let bus = (volts / 1.25e-3).round() as u16;
        let cal = i32::from(self.regs[0x05]);
        let current = (i32::from(shunt) * cal / 2048) as i16;
        let power = (i32::from(current).unsigned_abs() * u32::from(bus) / 20_000) as u16;
        self.regs[0x01] = shunt as u16;
        self.regs[0x02] = bus;
        self.regs[0x04] = current as u16;
        self.regs[0x03] = power;
        self.regs[0x06] |= 1 << 3;
    }
}

/// Two chips on one bus.
#[derive(Debug, Default)]
struct FakeBus {
    chips: BTreeMap<u8, FakeIna226>,
}

impl ErrorType for FakeBus {
    type Error = ErrorKind;
}

impl I2c for FakeBus {
    fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), ErrorKind> {
        let chip = match self.chips.get_mut(&address) {
            Some(chip) if chip.present => chip,
            _ => return Err(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)),
        };
        for op in operations {
            match op {
                Operation::Write(bytes) => {
                    if let Some(&p) = bytes.first() {
                        chip.pointer = p;
                    }
                    if let [reg, hi, lo] = **bytes {
                        let value = u16::from_be_bytes([hi, lo]);
                        if reg == 0x00 && value & 0x8000 != 0 {
                            *chip = FakeIna226::powered_on();
                        } else {
                            chip.regs[usize::from(reg)] = value;
                            if reg == 0x00 {
                                chip.regs[0x06] &= !(1 << 3);
                            }
                        }
                    }
                }
                Operation::Read(buf) => {
                    let value = chip.regs[usize::from(chip.pointer)];
                    buf.copy_from_slice(&value.to_be_bytes()[..buf.len()]);
                    if chip.pointer == 0x06 {
                        chip.regs[0x06] &= !(1 << 3);
                    }
                }
            }
        }
        Ok(())
    }
}

fn board_bus() -> FakeBus {
    let mut bus = FakeBus::default();
    bus.chips.insert(0x40, FakeIna226::powered_on());
    bus.chips.insert(0x45, FakeIna226::powered_on());
    bus
}

/// A turn-like load: the left (inner) side regenerates for a while.
fn load(k: u64) -> Sides<f64> {
    let t = k as f64 * 0.005;
    Sides::new(2.0 * (t * 0.7).sin() - 0.3, 4.0 + 0.5 * (t * 1.3).cos())
}

/// USB: drain the link in full-speed packets.
fn drain(link: &mut Link, out: &mut Vec<u8>) {
    while !link.pending().is_empty() {
        let n = link.pending().len().min(64);
        out.extend_from_slice(&link.pending()[..n]);
        link.consume(n);
    }
}

struct Rig {
    bus: FakeBus,
    board: Board,
    link: Link,
    wire: Vec<u8>,
    t_us: u64,
    k: u64,
}

impl Rig {
    fn new() -> Self {
        let mut link = Link::new();
        link.set_connected(true);
        Self {
            bus: board_bus(),
            board: Board::new(SamplerConfig::BOARD),
            link,
            wire: Vec::new(),
            t_us: 0,
            k: 0,
        }
    }

    fn command(&mut self, id: u16, command: Command) {
        let mut buf = [0u8; wire::MAX_FRAME];
        let n = wire::encode(&HostFrame { id, command }, &mut buf).expect("fits");
        self.link.receive(&buf[..n]);
    }

    fn run(&mut self, ticks: u64) {
        for _ in 0..ticks {
            let l = load(self.k);
            for (addr, amps, volts) in [(0x40, l.left, 24.6), (0x45, l.right, 24.5)] {
                if let Some(chip) = self.bus.chips.get_mut(&addr) {
                    chip.convert(amps, volts);
                }
            }
            self.board.tick(&mut self.bus, &mut self.link, self.t_us);
            drain(&mut self.link, &mut self.wire);
            self.t_us += u64::from(self.board.sample_period_us());
            self.k += 1;
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
    // The first period only initialises the chips; every later one reads a fresh conversion.
    assert_eq!(
        samples[0].chips,
        Sides::new(
            ChipReading::Failed(ChipFault::AwaitingConversion),
            ChipReading::Failed(ChipFault::AwaitingConversion)
        )
    );
    assert!(samples
        .iter()
        .skip(1)
        .all(|s| matches!(s.chips.left, ChipReading::Fresh(_))));
    let stats = dec.stats();
    assert_eq!((stats.bad_frames, stats.lost_samples), (0, 0));

    // The board's latest model frame equals the host's recomputation at that sample, bit for bit.
    let (model, host) = dec.board_vs_host_energy().expect("model frames");
    assert_eq!(
        [
            model.snapshot.energy_lsb_us.left,
            model.snapshot.energy_lsb_us.right
        ],
        host
    );
    assert!(model.seq >= 3_980);
    // And the board's own total at the end equals the host's.
    let board_total = rig.board.sampler().measurements().total_energy_lsb_us();
    assert_eq!(dec.measurements().total_energy_lsb_us(), board_total);

    // Against physics: ∫ V·I dt of the applied load, within the registers' quantisation.
    let scale = dec.scale();
    let expected_j: f64 = (1..4_000u64)
        .map(|k| (load(k).left * 24.6 + load(k).right * 24.5) * 0.005)
        .sum();
    let got_j = scale.energy_j(board_total);
    assert!(
        (got_j - expected_j).abs() < 0.01 * expected_j.abs(),
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
    rig.bus.chips.get_mut(&0x45).expect("right").present = false; // unplugged
    rig.run(300);
    // Plugged back in: it powered up with its defaults (no calibration).
    rig.bus.chips.insert(0x45, FakeIna226::powered_on());
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
    assert_eq!(rig.board.sampler().i2c_errors(), Sides::new(0, 300));
    assert_eq!(rig.board.sampler().reinits(), Sides::new(0, 1));
    assert_eq!(dec.stats().lost_samples, 0);
}

#[test]
fn a_chip_that_resets_under_load_is_caught_and_set_up_again() {
    let mut rig = Rig::new();
    rig.run(100);
    // Brown-out: registers back to power-on defaults while current keeps flowing.
    rig.bus.chips.insert(0x40, FakeIna226::powered_on());
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
    assert_eq!(rig.board.sampler().reinits(), Sides::new(1, 0));
    // Calibration really was rewritten.
    assert_eq!(rig.bus.chips[&0x40].regs[0x05], 2048);
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
    rig.link.receive(&[1, 2, 3, 0]); // garbage frame
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
    let total = rig.board.sampler().measurements().total_energy_lsb_us();
    assert!(model_core::ina226::Scale::BOARD.energy_j(total) < 30.0 * 0.005 * 150.0);
}
