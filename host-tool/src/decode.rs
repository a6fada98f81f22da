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
use model_core::Sides;
use std::fmt;

mod capture;

pub use capture::{read_capture, CaptureEnd, CaptureError, CaptureSummary, CHUNK, MAX_BUFFERED};

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

impl ModelCheck {
    /// The one definition of a model frame that differs from the host's recomputation (used by
    /// `decode`, `record` and `validate`): the energy gained since the segment's `first` model
    /// frame, the latest power or τ ∝ P/ω per side not exactly equal (board and host run the
    /// same model-core code on the same registers, so any difference is a lost sample, a
    /// command whose rates the host did not learn, or a bug).
    pub fn differs(&self, first: &ModelCheck) -> bool {
        let gain = |now: Sides<i64>, then: Sides<i64>| {
            [
                now.left.wrapping_sub(then.left),
                now.right.wrapping_sub(then.right),
            ]
        };
        let board_gain = gain(
            self.board.snapshot.energy_lsb_us,
            first.board.snapshot.energy_lsb_us,
        );
        let host_gain = gain(self.host.energy_lsb_us, first.host.energy_lsb_us);
        board_gain != host_gain
            || self.board.snapshot.power_lsb != self.host.power_lsb
            || self.board.snapshot.torque_proportional != self.host.torque_proportional
    }
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
                Some(Ok(frame)) => self.feed_frame(&frame, &mut on_event),
            }
        }
    }

    /// Feeds a frame already decoded (a log's): what feeding its bytes does, without encoding
    /// and decoding them again (a frame decoded from the wire re-encodes to the same bytes).
    /// Outside a connection's wait for its hello, as a log's frames are.
    pub fn feed_frame(&mut self, frame: &BoardFrame, mut on_event: impl FnMut(Event)) {
        self.stats.frames += 1;
        self.account(frame, &mut on_event);
        on_event(Event::Frame(*frame));
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
            // A repeated delimiter, or the lone one the board starts each connection with: an
            // empty frame, nothing to decode and nothing left over from the last connection.
            None => {
                self.stale_pending -= self.frame_bytes;
                true
            }
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
            // The board's own report of the wheel rates it uses: exact at this point of the
            // stream (the board queues its frames in order), whoever commanded them.
            BoardFrame::Status(status) => {
                self.measurements.set_wheel_rates(status.wheel_rates_rad_s);
            }
            _ => {}
        }
    }

    /// Sets the wheel rates of the host's τ ∝ P/ω from here on (a command's effect that
    /// [`StreamDecoder::expect_ack`] cannot mirror: a log read back, not a live port).
    pub fn set_wheel_rates(&mut self, rates_rad_s: Option<Sides<f32>>) {
        self.measurements.set_wheel_rates(rates_rad_s);
    }

    fn on_model(&mut self, model: &Model) {
        self.stats.models += 1;
        let check = ModelCheck {
            board: *model,
            host: self.measurements.snapshot(),
        };
        let first = *self.segment.first_model.get_or_insert(check);
        if check.differs(&first) {
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
    pub bytes: u64,
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
    /// Decodes a whole capture held in memory ([`read_capture`] reads one in bounded chunks).
    pub fn of(bytes: &[u8]) -> Summary {
        let mut capture = CaptureSummary::new();
        capture.feed(bytes);
        capture.summary()
    }
}

/// What a file that is not a raw capture of the board's stream looks like, with a hint (`None`
/// for anything else): an MCAP log (its magic bytes) or a text file such as a run CSV (no frame
/// delimiter and printable text in its first 4 KiB; a capture has a 0x00 every few dozen bytes).
pub fn foreign_format(bytes: &[u8]) -> Option<&'static str> {
    const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";
    if bytes.starts_with(MCAP_MAGIC) {
        return Some(
            "an MCAP run log, not a raw capture of the serial stream: read it with `validate` or \
             `convert`, or write its byte stream with `replay LOG --to CAPTURE` and decode that",
        );
    }
    let head = &bytes[..bytes.len().min(4096)];
    let printable = head
        .iter()
        .filter(|&&b| {
            b == b'\n' || b == b'\r' || b == b'\t' || (0x20..0x7f).contains(&b) || b >= 0x80
        })
        .count();
    if head.len() >= 16 && !head.contains(&0) && printable * 100 >= head.len() * 95 {
        return Some(
            "a text file (a run CSV?), not a raw capture of the serial stream: read a run CSV with \
             `validate` or `convert`, or write a capture with `replay RUN.csv --to CAPTURE`",
        );
    }
    None
}

/// The board's USB serial number as `ports` shows it; `None` for a simulated or synthesised
/// stream (no unique ID).
pub fn usb_serial(identity: &BoardIdentity) -> Option<String> {
    let mut buf = [0u8; SERIAL_LEN];
    (*identity != BoardIdentity::UNKNOWN).then(|| identity.usb_serial(&mut buf).to_owned())
}

/// The board's USB serial number and crystal.
pub fn identity_line(identity: &BoardIdentity) -> String {
    match usb_serial(identity) {
        Some(serial) => format!("board serial {serial}, {} MHz crystal", identity.hse_mhz),
        None => "board identity: none (a simulated or synthesised stream)".into(),
    }
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
        writeln!(
            f,
            "model frames: {}, differing from the host's recomputation: {}",
            s.models, s.model_mismatches
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
                "last status: uptime {:.1} s, I²C errors {}/{}, re-inits {}/{}, results skipped {}/{}, queue drops {}, host-frame errors {}",
                st.uptime_us as f64 * 1e-6,
                st.i2c_errors.left,
                st.i2c_errors.right,
                st.reinits.left,
                st.reinits.right,
                st.skipped_results.left,
                st.skipped_results.right,
                st.queue_drops,
                st.rx_errors
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
