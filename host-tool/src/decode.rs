//! The host end of the wire: bytes from the board (a serial port, a capture file, a pty) become
//! frames, with every loss accounted for — corrupted frames, sequence gaps — and the running
//! measurements recomputed from the raw samples with the same model-core code the board runs.
//!
//! A stream is cut into segments at board resets: a sample whose `seq` goes back (to 0, or to
//! anything earlier than the previous sample's) starts a new segment, and the host's running
//! measurements start over like the rebooted board's. A hello frame alone is not a reset: the
//! firmware greets again whenever the host re-opens the port (DTR), with `seq`, time and energy
//! running on.
//!
//! A live port is read with [`StreamDecoder::for_port`]: everything before the first hello of a
//! connection is ignored and counted. usbd-serial's 128-byte write buffer and the OTG FIFO
//! survive the host closing the port (only a USB reset clears them), so a re-opened port first
//! delivers up to ~190 bytes the board queued for the previous connection.

use model_core::board_id::{BoardIdentity, SERIAL_LEN};
use model_core::energy::{RunningMeasurements, Snapshot};
use model_core::ina226::Scale;
use model_core::wire::{
    BoardFrame, Command, FrameDecoder, FrameError, Hello, HostFrame, Model, Sample, Status,
};
use std::fmt;

/// One decoded event of the stream.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A frame that decoded.
    Frame(BoardFrame),
    /// A frame was discarded (corrupted, truncated, foreign protocol version).
    BadFrame(FrameError),
    /// `missing` samples were never received between the previous sample and this one.
    SampleGap {
        /// The last sample received before the gap.
        after_seq: u32,
        /// Samples lost.
        missing: u32,
    },
    /// The board restarted (the next sample's `seq` went back): `previous` is the segment that
    /// ended. Comes before that sample's [`Event::Frame`].
    BoardReset {
        /// What the ended segment held.
        previous: Segment,
    },
}

/// Counters of what arrived and what was lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct StreamStats {
    /// Frames that decoded.
    pub frames: u64,
    /// Sample frames among them.
    pub samples: u64,
    /// Frames discarded (any [`FrameError`]).
    pub bad_frames: u64,
    /// Of those, CRC mismatches.
    pub crc_errors: u64,
    /// Samples known lost from sequence-number gaps.
    pub lost_samples: u64,
    /// Sequence-number gaps.
    pub gaps: u64,
    /// Board resets (segments after the first).
    pub board_resets: u64,
    /// Bytes that arrived on a connection before its first hello: left over from the previous
    /// connection, ignored ([`StreamDecoder::for_port`]).
    pub stale_bytes: u64,
    /// Frames (good or bad) among those stale bytes.
    pub stale_frames: u64,
    /// Model frames received.
    pub models: u64,
    /// Model frames that differ from the host's recomputation at the same sample (power, τ, or
    /// the energy gained since the segment's first model frame): 0 unless samples were lost or
    /// a command's effect was not mirrored ([`StreamDecoder::expect_ack`]).
    pub model_mismatches: u64,
}

/// The board's model frame and the host's recomputation at the same sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelCheck {
    /// What the board sent.
    pub board: Model,
    /// The host's running measurements after the same sample.
    pub host: Snapshot,
}

/// One segment of the stream (one boot of the board).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Segment {
    /// Samples received in the segment.
    pub samples: u64,
    /// Host energy per side from every raw sample of the segment [power LSB × µs].
    pub host_energy_lsb_us: [i64; 2],
    /// The segment's first model frame and the host's state at it.
    pub first_model: Option<ModelCheck>,
    /// The segment's latest model frame and the host's state at it.
    pub last_model: Option<ModelCheck>,
}

impl Segment {
    /// Board energy per side gained between the segment's first and latest model frames [power
    /// LSB × µs] (a board that ran before the host connected has more on its counters).
    pub fn board_gain_lsb_us(&self) -> Option<[i64; 2]> {
        let (first, last) = (self.first_model?, self.last_model?);
        let [a, b] = [first, last].map(|m| m.board.snapshot.energy_lsb_us);
        Some([b.left.wrapping_sub(a.left), b.right.wrapping_sub(a.right)])
    }

    /// The host's energy per side gained over the same samples [power LSB × µs]: equal to
    /// [`Segment::board_gain_lsb_us`] when no sample was lost.
    pub fn host_gain_lsb_us(&self) -> Option<[i64; 2]> {
        let (first, last) = (self.first_model?, self.last_model?);
        let [a, b] = [first, last].map(|m| m.host.energy_lsb_us);
        Some([b.left.wrapping_sub(a.left), b.right.wrapping_sub(a.right)])
    }
}

/// Decodes a byte stream and keeps the host's own running measurements.
#[derive(Debug)]
pub struct StreamDecoder {
    frames: FrameDecoder,
    stats: StreamStats,
    hello: Option<Hello>,
    last_seq: Option<u32>,
    measurements: RunningMeasurements,
    segment: Segment,
    /// Commands sent to the board whose effect the host applies when their ack arrives.
    awaiting_ack: Vec<HostFrame>,
    /// Ignoring everything until the connection's first hello.
    awaiting_hello: bool,
    /// Bytes fed while awaiting the hello, and bytes since the last delimiter.
    stale_pending: u64,
    frame_bytes: u64,
}

impl Default for StreamDecoder {
    fn default() -> Self {
        Self::new()
    }
}

/// At most this many commands wait for their ack; older ones are forgotten (never acked).
const MAX_AWAITING_ACK: usize = 64;

impl StreamDecoder {
    /// A decoder that assumes our board's scale until a hello frame says otherwise.
    pub fn new() -> Self {
        Self {
            frames: FrameDecoder::new(),
            stats: StreamStats::default(),
            hello: None,
            last_seq: None,
            measurements: RunningMeasurements::new(Scale::BOARD),
            segment: Segment::default(),
            awaiting_ack: Vec::new(),
            awaiting_hello: false,
            stale_pending: 0,
            frame_bytes: 0,
        }
    }

    /// A decoder for a freshly opened port: the connection's bytes count from its first hello.
    pub fn for_port() -> Self {
        let mut decoder = Self::new();
        decoder.new_connection();
        decoder
    }

    /// Feeds bytes; calls `on_event` for every frame, bad frame, sample gap and board reset, in
    /// stream order.
    pub fn feed(&mut self, bytes: &[u8], mut on_event: impl FnMut(Event)) {
        for &b in bytes {
            let outcome = self.frames.push::<BoardFrame>(b);
            if self.awaiting_hello {
                self.stale_pending += 1;
                self.frame_bytes += 1;
                if b == 0 {
                    let stale = self.stale_frame_ends(&outcome);
                    self.frame_bytes = 0;
                    if stale {
                        continue;
                    }
                }
            }
            match outcome {
                None => {}
                Some(Err(e)) => {
                    self.stats.bad_frames += 1;
                    if e == FrameError::Crc {
                        self.stats.crc_errors += 1;
                    }
                    on_event(Event::BadFrame(e));
                }
                Some(Ok(frame)) => {
                    self.stats.frames += 1;
                    self.account(&frame, &mut on_event);
                    on_event(Event::Frame(frame));
                }
            }
        }
    }

    /// A new connection (the port was re-opened): drops the bytes of an unfinished frame, and
    /// ignores (counting them) the frames before the connection's first hello, which the board
    /// queued for the previous connection.
    pub fn new_connection(&mut self) {
        self.frames = FrameDecoder::new();
        self.awaiting_hello = true;
        self.stale_pending = 0;
        self.frame_bytes = 0;
    }

    /// At a delimiter while awaiting the hello: whether the frame that ended is stale (and is
    /// dropped). The hello ends the wait and is decoded as usual.
    fn stale_frame_ends(&mut self, outcome: &Option<Result<BoardFrame, FrameError>>) -> bool {
        match outcome {
            Some(Ok(BoardFrame::Hello(_))) => {
                self.awaiting_hello = false;
                self.stats.stale_bytes += self.stale_pending - self.frame_bytes;
                false
            }
            Some(_) => {
                self.stats.stale_frames += 1;
                true
            }
            // A repeated delimiter: nothing to decode.
            None => true,
        }
    }

    /// Registers a command just sent to the board: when the board acks `frame.id`, the host
    /// applies the command's effect on the running measurements (wheel rates, energy reset) at
    /// that point of the stream, as the board did, so power, energy and τ stay equal.
    pub fn expect_ack(&mut self, frame: HostFrame) {
        if self.awaiting_ack.len() >= MAX_AWAITING_ACK {
            self.awaiting_ack.remove(0);
        }
        self.awaiting_ack.push(frame);
    }

    fn answered(&mut self, id: u16) -> Option<HostFrame> {
        let at = self.awaiting_ack.iter().position(|f| f.id == id)?;
        Some(self.awaiting_ack.remove(at))
    }

    fn account(&mut self, frame: &BoardFrame, on_event: &mut impl FnMut(Event)) {
        match frame {
            BoardFrame::Hello(hello) => {
                if self.hello.is_none_or(|h| h.scale != hello.scale) {
                    // Energy so far was integrated at the old scale; start over at the new one.
                    let rates = self.measurements.wheel_rates();
                    self.measurements = RunningMeasurements::new(hello.scale);
                    self.measurements.set_wheel_rates(rates);
                }
                self.hello = Some(*hello);
            }
            BoardFrame::Sample(sample) => self.on_sample(sample, on_event),
            BoardFrame::Model(model) => self.on_model(model),
            BoardFrame::Ack { id } => {
                if let Some(sent) = self.answered(*id) {
                    match sent.command {
                        Command::SetWheelRates(rates) => {
                            self.measurements.set_wheel_rates(Some(rates));
                        }
                        Command::ClearWheelRates => self.measurements.set_wheel_rates(None),
                        Command::ResetEnergy => self.measurements.reset_energy(),
                        // The board pauses its energy at Stop: no samples arrive until Start, and
                        // the first one after it only re-anchors time.
                        Command::Stop => self.measurements.pause(),
                        _ => {}
                    }
                }
            }
            BoardFrame::Rejected { id: Some(id), .. } => {
                self.answered(*id);
            }
            _ => {}
        }
    }

    fn on_model(&mut self, model: &Model) {
        self.stats.models += 1;
        let check = ModelCheck {
            board: *model,
            host: self.measurements.snapshot(),
        };
        let first = *self.segment.first_model.get_or_insert(check);
        let gain = |m: &ModelCheck, f: &ModelCheck| {
            let (b, fb) = (
                m.board.snapshot.energy_lsb_us,
                f.board.snapshot.energy_lsb_us,
            );
            let (h, fh) = (m.host.energy_lsb_us, f.host.energy_lsb_us);
            (
                [b.left.wrapping_sub(fb.left), b.right.wrapping_sub(fb.right)],
                [h.left.wrapping_sub(fh.left), h.right.wrapping_sub(fh.right)],
            )
        };
        let (board_gain, host_gain) = gain(&check, &first);
        if board_gain != host_gain
            || check.board.snapshot.power_lsb != check.host.power_lsb
            || check.board.snapshot.torque_proportional != check.host.torque_proportional
        {
            self.stats.model_mismatches += 1;
        }
        self.segment.last_model = Some(check);
    }

    fn on_sample(&mut self, sample: &Sample, on_event: &mut impl FnMut(Event)) {
        self.stats.samples += 1;
        if let Some(last) = self.last_seq {
            let step = sample.seq.wrapping_sub(last);
            if step == 1 {
                // The next one (u32::MAX → 0 included).
            } else if sample.seq == 0 || step >= 1 << 31 {
                // Back to 0, or backwards: the board restarted (not 4 billion lost samples).
                self.stats.board_resets += 1;
                let previous = self.current_segment();
                self.segment = Segment::default();
                self.measurements = RunningMeasurements::new(self.measurements.scale());
                self.awaiting_ack.clear();
                on_event(Event::BoardReset { previous });
            } else {
                let missing = step - 1;
                self.stats.gaps += 1;
                self.stats.lost_samples += u64::from(missing);
                on_event(Event::SampleGap {
                    after_seq: last,
                    missing,
                });
            }
        }
        self.last_seq = Some(sample.seq);
        self.segment.samples += 1;
        self.measurements
            .update(sample.t_us, sample.chips.map(|c| c.registers()));
    }

    /// Counters so far.
    pub fn stats(&self) -> StreamStats {
        self.stats
    }

    /// The board's latest hello.
    pub fn hello(&self) -> Option<&Hello> {
        self.hello.as_ref()
    }

    /// The host's running measurements, recomputed from every sample of the current segment.
    pub fn measurements(&self) -> &RunningMeasurements {
        &self.measurements
    }

    /// The scale the raw registers are read with (the latest hello's, or our board's).
    pub fn scale(&self) -> Scale {
        self.measurements.scale()
    }

    /// The current segment so far.
    pub fn current_segment(&self) -> Segment {
        let e = self.measurements.snapshot().energy_lsb_us;
        Segment {
            host_energy_lsb_us: [e.left, e.right],
            ..self.segment
        }
    }

    /// The board's latest model frame of the current segment and the host's recomputation at
    /// the same sample.
    pub fn board_vs_host_model(&self) -> Option<ModelCheck> {
        self.segment.last_model
    }

    /// The board's latest model frame and the host's energy per side (power LSB × µs) at the
    /// moment it arrived: equal when no sample was lost, since both run the same model-core code.
    pub fn board_vs_host_energy(&self) -> Option<(Model, [i64; 2])> {
        let check = self.segment.last_model?;
        let e = check.host.energy_lsb_us;
        Some((check.board, [e.left, e.right]))
    }
}

/// What a capture holds: the board, what arrived and what was lost, and the energy check
/// (`decode --json` prints it as JSON).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Summary {
    pub bytes: usize,
    pub hello: Option<Hello>,
    pub stats: StreamStats,
    /// First and last sample time [µs].
    pub span_us: Option<(u64, u64)>,
    pub scale: Scale,
    /// Host energy per side from every raw sample [power LSB × µs].
    pub host_energy_lsb_us: [i64; 2],
    /// The board's latest model frame and the host's energy at that sample.
    pub board_vs_host: Option<(Model, [i64; 2])>,
    pub last_status: Option<Status>,
}

impl Summary {
    /// Decodes a whole capture.
    pub fn of(bytes: &[u8]) -> Summary {
        let mut dec = StreamDecoder::new();
        let mut span_us: Option<(u64, u64)> = None;
        let mut last_status = None;
        dec.feed(bytes, |event| match event {
            Event::Frame(BoardFrame::Sample(s)) => {
                span_us = Some((span_us.map_or(s.t_us, |(first, _)| first), s.t_us));
            }
            Event::Frame(BoardFrame::Status(s)) => last_status = Some(s),
            _ => {}
        });
        let host = dec.measurements().snapshot().energy_lsb_us;
        Summary {
            bytes: bytes.len(),
            hello: dec.hello().copied(),
            stats: dec.stats(),
            span_us,
            scale: dec.scale(),
            host_energy_lsb_us: [host.left, host.right],
            board_vs_host: dec.board_vs_host_energy(),
            last_status,
        }
    }
}

/// The board's USB serial number and crystal, as `ports` shows the serial.
pub fn identity_line(identity: &BoardIdentity) -> String {
    if *identity == BoardIdentity::UNKNOWN {
        return "board identity: none (a simulated or synthesised stream)".into();
    }
    let mut buf = [0u8; SERIAL_LEN];
    format!(
        "board serial {}, {} MHz crystal",
        identity.usb_serial(&mut buf),
        identity.hse_mhz
    )
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let j = |lsb_us: i64| self.scale.energy_j(lsb_us);
        writeln!(f, "{} bytes", self.bytes)?;
        match &self.hello {
            Some(h) => writeln!(
                f,
                "board: firmware {}.{}.{}, protocol {}, shunt {} µΩ, current LSB {} nA, chips {:#04x}/{:#04x}, period {} µs",
                h.firmware.major,
                h.firmware.minor,
                h.firmware.patch,
                h.protocol,
                h.scale.shunt_micro_ohm,
                h.scale.current_lsb_na,
                h.addresses.left,
                h.addresses.right,
                h.sample_period_us
            )
            .and_then(|()| writeln!(f, "{}", identity_line(&h.identity)))?,
            None => writeln!(f, "board: no hello frame in the capture (assuming the rover-power board's scale)")?,
        }
        let s = &self.stats;
        writeln!(
            f,
            "frames {}, samples {}, bad frames {} ({} CRC), lost samples {} in {} gaps",
            s.frames, s.samples, s.bad_frames, s.crc_errors, s.lost_samples, s.gaps
        )?;
        if s.board_resets > 0 {
            writeln!(
                f,
                "board resets: {} (energy below is the last segment's)",
                s.board_resets
            )?;
        }
        if let Some((first, last)) = self.span_us {
            writeln!(
                f,
                "duration {:.3} s",
                last.wrapping_sub(first) as f64 * 1e-6
            )?;
        }
        let [left, right] = self.host_energy_lsb_us;
        writeln!(
            f,
            "host energy from raw samples: left {:.3} J, right {:.3} J",
            j(left),
            j(right)
        )?;
        if let Some((model, host)) = &self.board_vs_host {
            let board = model.snapshot.energy_lsb_us;
            writeln!(
                f,
                "board energy at sample {}: left {:.3} J, right {:.3} J; host recomputation differs by {:.6} J / {:.6} J",
                model.seq,
                j(board.left),
                j(board.right),
                j(host[0] - board.left),
                j(host[1] - board.right)
            )?;
        }
        if let Some(st) = &self.last_status {
            writeln!(
                f,
                "last status: uptime {:.1} s, I²C errors {}/{}, re-inits {}/{}, queue drops {}, host-frame errors {}",
                st.uptime_us as f64 * 1e-6,
                st.i2c_errors.left,
                st.i2c_errors.right,
                st.reinits.left,
                st.reinits.right,
                st.queue_drops,
                st.rx_errors
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use model_core::energy::RunningMeasurements;
    use model_core::ina226::{BusVoltageRaw, CurrentRaw, PowerRaw, Registers, ShuntVoltageRaw};
    use model_core::wire::{encode, ChipReading, MAX_FRAME};
    use model_core::Sides;
    use proptest::prelude::*;

    fn sample(seq: u32) -> BoardFrame {
        let regs = Registers {
            shunt: ShuntVoltageRaw(1000),
            bus: BusVoltageRaw(19_200),
            current: CurrentRaw(1000),
            power: PowerRaw(960),
        };
        BoardFrame::Sample(Sample {
            t_us: u64::from(seq) * 5_000,
            seq,
            chips: Sides::new(
                ChipReading::Fresh(regs),
                ChipReading::Failed(model_core::wire::ChipFault::AddressNack),
            ),
        })
    }

    fn bytes_of(frames: impl IntoIterator<Item = BoardFrame>) -> Vec<Vec<u8>> {
        frames
            .into_iter()
            .map(|f| {
                let mut buf = [0u8; MAX_FRAME];
                let n = encode(&f, &mut buf).expect("fits");
                buf[..n].to_vec()
            })
            .collect()
    }

    #[test]
    fn gaps_are_counted_exactly() {
        let frames = bytes_of((0..10).map(sample));
        let mut stream = Vec::new();
        for (i, f) in frames.iter().enumerate() {
            if i != 3 && i != 6 && i != 7 {
                stream.extend(f);
            }
        }
        let mut dec = StreamDecoder::new();
        let mut gaps = Vec::new();
        dec.feed(&stream, |e| {
            if let Event::SampleGap { after_seq, missing } = e {
                gaps.push((after_seq, missing));
            }
        });
        assert_eq!(gaps, vec![(2, 1), (5, 2)]);
        assert_eq!(dec.stats().lost_samples, 3);
        assert_eq!(dec.stats().samples, 7);
    }

    fn sample_at(seq: u32, t_us: u64, power: u16) -> BoardFrame {
        let regs = Registers {
            shunt: ShuntVoltageRaw(1000),
            bus: BusVoltageRaw(19_200),
            current: CurrentRaw(1000),
            power: PowerRaw(power),
        };
        BoardFrame::Sample(Sample {
            t_us,
            seq,
            chips: Sides::new(ChipReading::Fresh(regs), ChipReading::Stale(regs)),
        })
    }

    fn decode_all(frames: impl IntoIterator<Item = BoardFrame>) -> (StreamDecoder, Vec<Event>) {
        let mut dec = StreamDecoder::new();
        let mut events = Vec::new();
        dec.feed(&bytes_of(frames).concat(), |e| events.push(e));
        (dec, events)
    }

    #[test]
    fn seq_going_back_is_a_board_reset_and_host_energy_starts_over() {
        let first = (0..10).map(|k| sample_at(k, u64::from(k) * 5_000, 100));
        let second = (0..4).map(|k| sample_at(k, 1_000 + u64::from(k) * 5_000, 200));
        let (dec, events) = decode_all(first.chain(second));
        let resets: Vec<&Segment> = events
            .iter()
            .filter_map(|e| match e {
                Event::BoardReset { previous } => Some(previous),
                _ => None,
            })
            .collect();
        assert_eq!(resets.len(), 1);
        assert_eq!(resets[0].samples, 10);
        assert_eq!(resets[0].host_energy_lsb_us, [100 * 45_000, 100 * 45_000]);
        // The reset comes right before the new segment's first sample.
        let at = events
            .iter()
            .position(|e| matches!(e, Event::BoardReset { .. }))
            .expect("reset");
        assert!(matches!(
            events[at + 1],
            Event::Frame(BoardFrame::Sample(Sample { seq: 0, .. }))
        ));
        let stats = dec.stats();
        assert_eq!(
            (stats.board_resets, stats.gaps, stats.lost_samples),
            (1, 0, 0)
        );
        let seg = dec.current_segment();
        assert_eq!(seg.samples, 4);
        assert_eq!(seg.host_energy_lsb_us, [200 * 15_000, 200 * 15_000]);
        // Backwards but not to 0 (the host connected late to a rebooted board) is a reset too.
        let (dec, _) = decode_all([sample_at(50, 0, 1), sample_at(7, 10, 1)]);
        assert_eq!((dec.stats().board_resets, dec.stats().gaps), (1, 0));
    }

    #[test]
    fn seq_wrapping_past_u32_max_is_neither_a_gap_nor_a_reset() {
        let (dec, _) = decode_all([
            sample_at(u32::MAX - 1, 0, 1),
            sample_at(u32::MAX, 5_000, 1),
            sample_at(0, 10_000, 1),
            sample_at(2, 20_000, 1),
        ]);
        let stats = dec.stats();
        assert_eq!(
            (stats.board_resets, stats.gaps, stats.lost_samples),
            (0, 1, 1)
        );
    }

    #[test]
    fn energy_integrates_across_the_u64_microsecond_wrap() {
        let t0 = u64::MAX - 12_000;
        let (dec, _) =
            decode_all((0..6).map(|k| sample_at(k, t0.wrapping_add(u64::from(k) * 5_000), 40)));
        assert_eq!(dec.current_segment().host_energy_lsb_us, [40 * 25_000; 2]);
    }

    #[test]
    fn an_acked_command_is_mirrored_so_the_model_matches() {
        let mut board = RunningMeasurements::new(Scale::BOARD);
        let rates = Sides::new(2.0f32, -3.0);
        let mut frames = Vec::new();
        for k in 0..20u32 {
            if k == 5 {
                board.set_wheel_rates(Some(rates));
                frames.push(BoardFrame::Ack { id: 9 });
            }
            if k == 12 {
                board.reset_energy();
                frames.push(BoardFrame::Ack { id: 10 });
            }
            let s = sample_at(k, u64::from(k) * 5_000, 100 + k as u16);
            if let BoardFrame::Sample(s) = &s {
                board.update(s.t_us, s.chips.map(|c| c.registers()));
            }
            frames.push(s);
            frames.push(BoardFrame::Model(Model {
                t_us: u64::from(k) * 5_000,
                seq: k,
                snapshot: board.snapshot(),
            }));
        }
        let mut dec = StreamDecoder::new();
        dec.expect_ack(HostFrame {
            id: 9,
            command: Command::SetWheelRates(rates),
        });
        dec.expect_ack(HostFrame {
            id: 10,
            command: Command::ResetEnergy,
        });
        dec.feed(&bytes_of(frames.clone()).concat(), |_| {});
        assert_eq!(dec.stats().models, 20);
        assert_eq!(dec.stats().model_mismatches, 0);
        let check = dec.board_vs_host_model().expect("model");
        assert_eq!(check.board.snapshot, check.host);
        assert!(check.host.torque_proportional.left.is_some());
        // Without mirroring, τ differs from the ack on.
        let mut blind = StreamDecoder::new();
        blind.feed(&bytes_of(frames).concat(), |_| {});
        assert_eq!(blind.stats().model_mismatches, 15);
    }

    #[test]
    fn a_new_connection_ignores_and_counts_everything_before_its_hello() {
        let hello = BoardFrame::Hello(crate::replay::synthetic_hello(5_000));
        // What the board's USB buffers still held from the previous connection: the tail of a
        // frame cut mid-way, then whole frames.
        let cut = &bytes_of([sample(7)])[0][5..];
        let stale_frames = bytes_of((8..11).map(sample)).concat();
        let fresh = bytes_of([hello].into_iter().chain((500..510).map(sample))).concat();
        let stale_len = (cut.len() + stale_frames.len()) as u64;
        let stream = [cut, &stale_frames, &fresh].concat();

        let mut dec = StreamDecoder::for_port();
        let mut events = Vec::new();
        // In small pieces, as USB delivers them.
        for chunk in stream.chunks(7) {
            dec.feed(chunk, |e| events.push(e));
        }
        let stats = dec.stats();
        assert_eq!((stats.stale_bytes, stats.stale_frames), (stale_len, 4));
        assert_eq!((stats.samples, stats.bad_frames, stats.gaps), (10, 0, 0));
        assert!(matches!(events[0], Event::Frame(BoardFrame::Hello(_))));
        assert_eq!(dec.current_segment().samples, 10);

        // A re-opened port: the same again, counted on top.
        dec.new_connection();
        dec.feed(&stream, |_| {});
        assert_eq!(dec.stats().stale_bytes, 2 * stale_len);
        assert_eq!(dec.stats().stale_frames, 8);

        // A capture is decoded whole: nothing is stale.
        let mut capture = StreamDecoder::new();
        capture.feed(&stream, |_| {});
        assert_eq!(capture.stats().stale_bytes, 0);
        assert_eq!(capture.stats().bad_frames, 1, "the cut frame");
    }

    #[test]
    fn a_stop_ack_pauses_the_host_energy_like_the_board() {
        // Ten samples, Stop (acked), a minute without samples, Start (acked), ten more.
        let mut board = RunningMeasurements::new(Scale::BOARD);
        let mut frames = Vec::new();
        let mut t_us = 0;
        for k in 0..20u32 {
            if k == 10 {
                board.pause();
                frames.push(BoardFrame::Ack { id: 1 });
                frames.push(BoardFrame::Ack { id: 2 });
                t_us += 60_000_000;
            }
            let s = sample_at(k, t_us, 400);
            if let BoardFrame::Sample(s) = &s {
                board.update(s.t_us, s.chips.map(|c| c.registers()));
            }
            frames.push(s);
            frames.push(BoardFrame::Model(Model {
                t_us,
                seq: k,
                snapshot: board.snapshot(),
            }));
            t_us += 5_000;
        }
        let mut dec = StreamDecoder::new();
        dec.expect_ack(HostFrame {
            id: 1,
            command: Command::Stop,
        });
        dec.expect_ack(HostFrame {
            id: 2,
            command: Command::Start,
        });
        dec.feed(&bytes_of(frames).concat(), |_| {});
        assert_eq!(dec.stats().model_mismatches, 0);
        // 18 intervals of 5 ms at 400 LSB: the minute of pause adds nothing.
        assert_eq!(dec.current_segment().host_energy_lsb_us, [400 * 90_000; 2]);
    }

    proptest! {
        /// Corrupting frames (without touching delimiters) loses exactly those frames: each is
        /// reported bad, and the sample gaps add up to the number corrupted.
        #[test]
        fn corrupted_frames_are_lost_exactly(corrupt in proptest::collection::btree_set(1usize..49, 0..12), byte in 0usize..20, flip in 1u8..=255) {
            let frames = bytes_of((0..50).map(sample));
            let mut stream = Vec::new();
            for (i, f) in frames.iter().enumerate() {
                let mut f = f.clone();
                if corrupt.contains(&i) {
                    let at = byte % (f.len() - 1);
                    // Always change the byte, never into a 0x00: delimiters stay where they are.
                    let mut corrupted = f[at] ^ flip;
                    if corrupted == 0 {
                        corrupted = if f[at] == 0xFF { 0x01 } else { 0xFF };
                    }
                    f[at] = corrupted;
                }
                stream.extend(f);
            }
            let mut dec = StreamDecoder::new();
            let mut good = 0u64;
            dec.feed(&stream, |e| if matches!(e, Event::Frame(_)) { good += 1 });
            prop_assert_eq!(dec.stats().lost_samples, corrupt.len() as u64);
            prop_assert_eq!(good, 50 - corrupt.len() as u64);
            prop_assert!(dec.stats().bad_frames >= corrupt.len() as u64);
        }
    }
}
