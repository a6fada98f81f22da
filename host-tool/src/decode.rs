//! The host end of the wire: bytes from the board (a serial port, a capture file, a pty) become
//! frames, with every loss accounted for — corrupted frames, sequence gaps — and the running
//! measurements recomputed from the raw samples with the same model-core code the board runs.

use model_core::energy::RunningMeasurements;
use model_core::ina226::Scale;
use model_core::wire::{BoardFrame, FrameDecoder, FrameError, Hello, Model, Sample, Status};
use std::fmt;

/// One decoded event of the stream.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    Frame(BoardFrame),
    /// A frame was discarded (corrupted, truncated, foreign protocol version).
    BadFrame(FrameError),
    /// `missing` samples were never received between the previous sample and this one.
    SampleGap {
        after_seq: u32,
        missing: u32,
    },
}

/// Counters of what arrived and what was lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StreamStats {
    pub frames: u64,
    pub samples: u64,
    pub bad_frames: u64,
    pub crc_errors: u64,
    /// Samples known lost from sequence-number gaps.
    pub lost_samples: u64,
    pub gaps: u64,
}

/// Decodes a byte stream and keeps the host's own running measurements.
#[derive(Debug)]
pub struct StreamDecoder {
    frames: FrameDecoder,
    stats: StreamStats,
    hello: Option<Hello>,
    last_seq: Option<u32>,
    measurements: RunningMeasurements,
    last_model: Option<Model>,
    /// Host recomputation at the moment of the board's latest model frame.
    host_at_last_model: Option<[i64; 2]>,
}

impl Default for StreamDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl StreamDecoder {
    /// A decoder that assumes our board's scale until a hello frame says otherwise.
    pub fn new() -> Self {
        Self {
            frames: FrameDecoder::new(),
            stats: StreamStats::default(),
            hello: None,
            last_seq: None,
            measurements: RunningMeasurements::new(Scale::BOARD),
            last_model: None,
            host_at_last_model: None,
        }
    }

    /// Feeds bytes; calls `on_event` for every frame, bad frame and sample gap, in stream order.
    pub fn feed(&mut self, bytes: &[u8], mut on_event: impl FnMut(Event)) {
        for &b in bytes {
            match self.frames.push::<BoardFrame>(b) {
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
            BoardFrame::Model(model) => {
                self.last_model = Some(*model);
                let e = self.measurements.snapshot().energy_lsb_us;
                self.host_at_last_model = Some([e.left, e.right]);
            }
            _ => {}
        }
    }

    fn on_sample(&mut self, sample: &Sample, on_event: &mut impl FnMut(Event)) {
        self.stats.samples += 1;
        if let Some(last) = self.last_seq {
            let missing = sample.seq.wrapping_sub(last).wrapping_sub(1);
            // A board reset restarts at 0: that is a new run, not 4 billion lost samples.
            if missing != 0 && sample.seq != 0 {
                self.stats.gaps += 1;
                self.stats.lost_samples += u64::from(missing);
                on_event(Event::SampleGap {
                    after_seq: last,
                    missing,
                });
            }
        }
        self.last_seq = Some(sample.seq);
        self.measurements
            .update(sample.t_us, sample.chips.map(|c| c.registers()));
    }

    pub fn stats(&self) -> StreamStats {
        self.stats
    }

    pub fn hello(&self) -> Option<&Hello> {
        self.hello.as_ref()
    }

    /// The host's running measurements, recomputed from every sample received.
    pub fn measurements(&self) -> &RunningMeasurements {
        &self.measurements
    }

    pub fn scale(&self) -> Scale {
        self.measurements.scale()
    }

    /// The board's latest model frame and the host's energy per side (power LSB × µs) at the
    /// moment it arrived: equal when no sample was lost, since both run the same model-core code.
    pub fn board_vs_host_energy(&self) -> Option<(Model, [i64; 2])> {
        Some((self.last_model?, self.host_at_last_model?))
    }
}

/// What a capture holds: the board, what arrived and what was lost, and the energy check.
#[derive(Debug, Clone, PartialEq)]
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
            )?,
            None => writeln!(f, "board: no hello frame in the capture (assuming the rover-power board's scale)")?,
        }
        let s = &self.stats;
        writeln!(
            f,
            "frames {}, samples {}, bad frames {} ({} CRC), lost samples {} in {} gaps",
            s.frames, s.samples, s.bad_frames, s.crc_errors, s.lost_samples, s.gaps
        )?;
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
