//! [`McapSink`]: the MCAP writer behind [`RunLogSink`].

use super::board_sample::BoardSample;
use super::sample_batch::{registers_of, Batch};
use super::{
    frame_encoding, frame_proto, proto, CommandMsg, EventMsg, LogChannel, McapError, CHUNK_BYTES,
    COMMAND_CHANNEL, EVENT_CHANNEL, FRAME_CHANNEL, MODEL_CHANNEL, SAMPLE_BATCH_CHANNEL,
    STATUS_CHANNEL,
};
use crate::log::commands::CommandRow;
use crate::log::run_csv::RunSample;
use crate::log::run_log::{LogEvent, RunLogSink};
use ::mcap::records::{MessageHeader, Metadata};
use ::mcap::{Compression, WriteOptions, Writer};
use model_core::ina226::AdcConfig;
use model_core::ina226::Scale;
use model_core::wire::{
    self, BoardFrame, ChipFault, Hello, Model, Sample, Status, MAX_FRAME, PROTOCOL_VERSION,
};
use model_core::Sides;
use std::collections::BTreeMap;
use std::fmt;
use std::fs::{File, OpenOptions};
use std::io::{self, BufWriter, Seek, Write};
use std::path::Path;

/// Compression level of the chunks (see [`McapSink::with_compression`]).
const LEVEL: u32 = 9;

/// The channels of a run log (an index into [`McapSink::ids`]).
#[derive(Debug, Clone, Copy)]
pub(super) enum Ch {
    Sample,
    Model,
    Status,
    Command,
    Event,
    Frame,
}

/// Writes a run as MCAP while it happens (see the [module docs](super) for the layout and the
/// crash-safety guarantees). Samples must come in strictly increasing time; all times are run
/// times ≥ 0 [s].
pub struct McapSink<W: Write + Seek> {
    /// `None` once [`McapSink::finish`] took it.
    writer: Option<Writer<W>>,
    /// MCAP channel id of each [`Ch`], once its first message declared it. Declared lazily
    /// so that a channel record always shares its chunk with a message: a chunk of channel
    /// records alone has no message index and a start time of 0, and Foxglove Studio then
    /// shows nothing of the file ("Chunks without message indexes are not currently
    /// supported", a time range from 1970).
    ids: [Option<u16>; 6],
    /// Next sequence number of each [`Ch`]; for [`Ch::Sample`], samples written so far (a
    /// batch's sequence is its first sample's number: [`super::sample_batch`]).
    sequence: [u32; 6],
    /// The latest hello's scale (the board's until one arrives), for the model channel.
    scale: Scale,
    last_sample_t_s: Option<f64>,
    /// How `log_time` is stamped.
    clock: LogClock,
    /// A sample frame waiting for its physical sample (the next record), to ride in its
    /// message ([`BoardSample`]); written on the frame channel if anything else comes first.
    pending: Option<(f64, Sample)>,
    /// Samples not written yet: written as one message before any other record.
    batch: Batch,
}

/// Most messages held while no wall-clock event has come (a run's start before its first
/// sample: hello, status, start event). Past it, or at a sample without an anchor, the log has
/// no wall clock and goes on run time.
pub(crate) const HELD_MAX: usize = 4096;

/// Where a message's `log_time` comes from (`publish_time` is always run time).
#[derive(Debug)]
enum LogClock {
    /// No [`LogEvent::WallClock`] yet: messages wait, so every `log_time` in the file is on
    /// one clock (Unix time once it comes, run time if it never does).
    Waiting(Vec<Held>),
    /// Unix time of run time 0 [ns]: `log_time` = this + run time.
    Unix(i128),
    /// The log has no wall clock: `log_time` = run time.
    Run,
}

/// A message written before the wall clock was known.
#[derive(Debug)]
struct Held {
    channel: Ch,
    t_s: f64,
    data: Vec<u8>,
    /// An event's JSON holds its `log_time` (foxglove.Log `timestamp`): rebuilt on release.
    event: Option<LogEvent>,
}

impl<W: Write + Seek> fmt::Debug for McapSink<W> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("McapSink")
            .field("ids", &self.ids)
            .field("sequence", &self.sequence)
            .field("scale", &self.scale)
            .field("last_sample_t_s", &self.last_sample_t_s)
            .finish_non_exhaustive()
    }
}

impl McapSink<BufWriter<File>> {
    /// Creates (or truncates) `path` and writes the file header and the `rover_power` metadata
    /// record.
    pub fn create(path: &Path, overwrite: bool) -> Result<Self, McapError> {
        let mut options = OpenOptions::new();
        options.read(true).write(true);
        if overwrite {
            options.create(true).truncate(true);
        } else {
            options.create_new(true);
        }
        let file = options.open(path).map_err(|source| McapError::Io {
            path: path.to_owned(),
            source,
        })?;
        let mut sink = Self::new(BufWriter::new(file))?;
        // The header and the `rover_power` metadata reach the file at once: even a run killed
        // before its first flush leaves a file the reader recognises.
        sink.flush_records()?;
        Ok(sink)
    }
}

impl<W: Write + Seek> McapSink<W> {
    /// Starts an MCAP file in `out` (header, `rover_power` metadata; each channel is declared
    /// with its first message) with lz4-compressed chunks.
    pub fn new(out: W) -> Result<Self, McapError> {
        Self::with_compression(out, Some(Compression::Lz4))
    }

    /// Like [`McapSink::new`] with the chunks' compression chosen (`None`: uncompressed, as
    /// files of earlier versions).
    pub fn with_compression(out: W, compression: Option<Compression>) -> Result<Self, McapError> {
        let options = WriteOptions::new()
            .compression(compression)
            // One thread: chunks are small (256 KiB) and the recorder has its own work.
            .compression_threads(0)
            // lz4 rather than zstd: most of a chunk is the readings' noisy low bits, which
            // neither compresses, and lz4 copies them where zstd entropy-decodes them. An hour:
            // 33.9 MB against 30.3 MB, decompressed in a third of the time. Level 9 (high
            // compression): 33.9 MB against 36.7 MB at the fast level, and a converted hour in
            // 1.4 s against 0.6 s (a recorder writes 16 kB/s).
            .compression_level(LEVEL)
            .profile("")
            .library(format!(
                "rover-power host-tool {}",
                env!("CARGO_PKG_VERSION")
            ))
            .chunk_size(Some(CHUNK_BYTES))
            // Chunks are assembled in memory and written whole: the file never holds a
            // half-written chunk whose header still has placeholder lengths.
            .disable_seeking(true);
        let mut writer = Writer::with_options(out, options)?;
        writer.write_metadata(&Metadata {
            name: "rover_power".into(),
            metadata: BTreeMap::from([
                ("protocol_version".to_owned(), PROTOCOL_VERSION.to_string()),
                ("frame_encoding".to_owned(), frame_encoding()),
                (
                    "writer".to_owned(),
                    format!("host-tool {}", env!("CARGO_PKG_VERSION")),
                ),
                (
                    "time".to_owned(),
                    "publish_time = run time [ns]; log_time = Unix time [ns] (the wall-clock \
                     event's unix_ns + run time since it; see rover_power.wall_clock), or run \
                     time when the log has no wall clock"
                        .to_owned(),
                ),
            ]),
        })?;
        Ok(McapSink {
            writer: Some(writer),
            ids: [None; 6],
            sequence: [0; 6],
            scale: Scale::BOARD,
            last_sample_t_s: None,
            clock: LogClock::Waiting(Vec::new()),
            pending: None,
            batch: Batch::new(Scale::BOARD),
        })
    }

    /// The MCAP writer (taken only by [`McapSink::finish`], which consumes the sink).
    fn writer(&mut self) -> &mut Writer<W> {
        self.writer
            .as_mut()
            .expect("the writer is taken only when the sink is consumed")
    }

    /// Writes the summary section and footer and hands back the output, flushed. (Dropping the
    /// sink does the same, ignoring errors.)
    pub fn finish(mut self) -> Result<W, McapError> {
        self.write_waiting().map_err(::mcap::McapError::Io)?;
        self.release_held(LogClock::Run)
            .map_err(::mcap::McapError::Io)?;
        let mut writer = self.writer.take().expect("finish consumes the sink");
        writer.finish()?;
        let mut out = writer.into_inner();
        out.flush().map_err(::mcap::McapError::Io)?;
        Ok(out)
    }

    /// The MCAP writer, for tests that write records of their own between the sink's.
    #[cfg(test)]
    pub(super) fn raw_writer(&mut self) -> &mut Writer<W> {
        self.writer()
    }

    /// The output as a killed recorder leaves it: what was flushed, no summary, no footer.
    #[cfg(test)]
    pub(super) fn killed(mut self) -> W {
        self.writer.take().expect("not finished").into_inner()
    }

    /// Writes what waits for a next record: a sample frame, the batch.
    fn write_waiting(&mut self) -> io::Result<()> {
        self.release_pending()?;
        self.write_batch()
    }

    /// Writes a waiting sample frame on the frame channel (its sample did not follow).
    fn release_pending(&mut self) -> io::Result<()> {
        match self.pending.take() {
            Some((t_s, sample)) => self.write_frame(t_s, &BoardFrame::Sample(sample)),
            None => Ok(()),
        }
    }

    /// Writes the samples gathered so far as one message.
    fn write_batch(&mut self) -> io::Result<()> {
        let Some(t_s) = self.batch.first_t_s() else {
            return Ok(());
        };
        let count = self.batch.len() as u32;
        // Taken out first: writing may release held messages, which write the batch first.
        let data = self.batch.take_protobuf();
        self.write(Ch::Sample, t_s, &data)?;
        let written = &mut self.sequence[Ch::Sample as usize];
        *written = written.wrapping_add(count);
        Ok(())
    }

    /// Writes `frame` on the frame channel.
    fn write_frame(&mut self, t_s: f64, frame: &BoardFrame) -> io::Result<()> {
        let mut buf = [0u8; MAX_FRAME];
        let n = wire::encode(frame, &mut buf)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e.to_string()))?;
        self.write(Ch::Frame, t_s, &frame_proto::encode(&buf[..n]))
    }

    fn flush_records(&mut self) -> Result<(), McapError> {
        Ok(self.writer().flush()?)
    }

    /// Writes one message at run time `t_s` (held while the wall clock is not known yet).
    pub(super) fn write(&mut self, channel: Ch, t_s: f64, data: &[u8]) -> io::Result<()> {
        self.write_or_hold(channel, t_s, data, None)
    }

    fn write_or_hold(
        &mut self,
        channel: Ch,
        t_s: f64,
        data: &[u8],
        event: Option<&LogEvent>,
    ) -> io::Result<()> {
        if !matches!(channel, Ch::Sample) {
            // The samples gathered came before this record.
            self.write_batch()?;
        }
        let run_ns = run_time_ns(t_s)?;
        let log_time = match &mut self.clock {
            // The recorder's anchor comes with the first sample; a sample without one means
            // this log has no wall clock.
            LogClock::Waiting(held) if held.len() < HELD_MAX && !matches!(channel, Ch::Sample) => {
                held.push(Held {
                    channel,
                    t_s,
                    data: data.to_vec(),
                    event: event.cloned(),
                });
                return Ok(());
            }
            LogClock::Waiting(_) => {
                self.release_held(LogClock::Run)?;
                run_ns
            }
            LogClock::Unix(zero) => unix_log_time(*zero, run_ns),
            LogClock::Run => run_ns,
        };
        let rebuilt;
        let data = match event {
            Some(event) => {
                rebuilt = serde_json::to_vec(&EventMsg::of(t_s, log_time, event))
                    .map_err(io::Error::other)?;
                &rebuilt[..]
            }
            None => data,
        };
        let channel_id = self.channel_id(channel).map_err(into_io)?;
        let sequence = self.sequence[channel as usize];
        if !matches!(channel, Ch::Sample) {
            self.sequence[channel as usize] = sequence.wrapping_add(1);
        }
        self.writer()
            .write_to_known_channel(
                &MessageHeader {
                    channel_id,
                    sequence,
                    log_time,
                    publish_time: run_ns,
                },
                data,
            )
            .map_err(into_io)
    }

    /// The MCAP channel of `channel`, declared (schema and channel records) on first use.
    fn channel_id(&mut self, channel: Ch) -> Result<u16, ::mcap::McapError> {
        if let Some(id) = self.ids[channel as usize] {
            return Ok(id);
        }
        let declared: LogChannel = match channel {
            Ch::Sample => SAMPLE_BATCH_CHANNEL,
            Ch::Model => MODEL_CHANNEL,
            Ch::Status => STATUS_CHANNEL,
            Ch::Command => COMMAND_CHANNEL,
            Ch::Event => EVENT_CHANNEL,
            Ch::Frame => FRAME_CHANNEL,
        };
        let metadata = match channel {
            Ch::Frame => BTreeMap::from([
                (
                    "format".to_owned(),
                    "rover_power.Frame { bytes wire = 1; }: wire = COBS(version byte | \
                     postcard(BoardFrame) | CRC-32/ISO-HDLC little-endian) followed by a 0x00 \
                     delimiter; one frame per message, exactly as the board sent it \
                     (model_core::wire)"
                        .to_owned(),
                ),
                ("protocol_version".to_owned(), PROTOCOL_VERSION.to_string()),
                ("wire_encoding".to_owned(), frame_encoding()),
            ]),
            _ => BTreeMap::new(),
        };
        let schema_id = self.writer().add_schema(
            declared.schema_name,
            declared.schema_encoding(),
            &declared.schema(),
        )?;
        let id = self.writer().add_channel(
            schema_id,
            declared.topic,
            declared.message_encoding(),
            &metadata,
        )?;
        self.ids[channel as usize] = Some(id);
        Ok(id)
    }

    /// Leaves [`LogClock::Waiting`] for `clock` and writes the held messages on it.
    fn release_held(&mut self, clock: LogClock) -> io::Result<()> {
        let LogClock::Waiting(held) = std::mem::replace(&mut self.clock, clock) else {
            return Ok(());
        };
        for h in held {
            self.write_or_hold(h.channel, h.t_s, &h.data, h.event.as_ref())?;
        }
        Ok(())
    }

    /// The wall clock became known: a metadata record for tools that read no events, then
    /// every held message on Unix time.
    fn anchor(&mut self, t_s: f64, unix_ns: u64) -> io::Result<()> {
        if !matches!(self.clock, LogClock::Waiting(_)) {
            // One clock per file: a later anchor (or one after the file went on run time)
            // stays an event only.
            return Ok(());
        }
        let zero = i128::from(unix_ns) - i128::from(run_time_ns(t_s)?);
        self.writer()
            .write_metadata(&Metadata {
                name: "rover_power.wall_clock".into(),
                metadata: BTreeMap::from([
                    ("unix_ns".to_owned(), unix_ns.to_string()),
                    ("at_t_s".to_owned(), t_s.to_string()),
                    ("unix_ns_at_run_zero".to_owned(), zero.to_string()),
                ]),
            })
            .map_err(into_io)?;
        self.release_held(LogClock::Unix(zero))
    }

    fn write_json(
        &mut self,
        channel: Ch,
        t_s: f64,
        message: &impl serde::Serialize,
    ) -> io::Result<()> {
        let data = serde_json::to_vec(message).map_err(io::Error::other)?;
        self.write(channel, t_s, &data)
    }

    fn hello(&mut self, t_s: f64, hello: &Hello) -> io::Result<()> {
        self.scale = hello.scale;
        let f = hello.firmware;
        let entries = [
            ("t_s", t_s.to_string()),
            ("protocol_version", hello.protocol.to_string()),
            ("firmware", format!("{}.{}.{}", f.major, f.minor, f.patch)),
            ("current_lsb_na", hello.scale.current_lsb_na.to_string()),
            ("shunt_micro_ohm", hello.scale.shunt_micro_ohm.to_string()),
            ("power_lsb_uw", hello.power_lsb_uw.to_string()),
            ("shunt_lsb_nv", hello.shunt_lsb_nv.to_string()),
            ("bus_lsb_uv", hello.bus_lsb_uv.to_string()),
            ("address_left", format!("{:#04x}", hello.addresses.left)),
            ("address_right", format!("{:#04x}", hello.addresses.right)),
            ("adc", serde_json::to_string(&hello.adc).unwrap_or_default()),
            ("sample_period_us", hello.sample_period_us.to_string()),
            (
                "usb_serial",
                crate::decode::usb_serial(&hello.identity).unwrap_or_default(),
            ),
            ("hse_mhz", hello.identity.hse_mhz.to_string()),
        ];
        self.writer()
            .write_metadata(&Metadata {
                name: "rover_power.board".into(),
                metadata: entries
                    .into_iter()
                    .map(|(k, v)| (k.to_owned(), v))
                    .collect(),
            })
            .map_err(into_io)
    }
}

/// A `/rover_power/model` message (`rover_power.Model`).
pub(crate) struct ModelMsg {
    t_s: f64,
    board_t_us: u64,
    seq: u32,
    left: ModelSide,
    right: ModelSide,
    total_energy_j: f64,
}

/// One side of a [`ModelMsg`]; an unknown value is left out.
struct ModelSide {
    power_w: Option<f64>,
    energy_j: f64,
    tau_w_per_rad_s: Option<f32>,
}

impl ModelMsg {
    pub(crate) fn of(t_s: f64, model: &Model, scale: Scale) -> Self {
        let s = &model.snapshot;
        let side = |power: Option<i32>, energy: i64, tau: Option<f32>| ModelSide {
            power_w: power.map(|p| scale.power_w(p)),
            energy_j: scale.energy_j(energy),
            tau_w_per_rad_s: tau.filter(|t| t.is_finite()),
        };
        ModelMsg {
            t_s,
            board_t_us: model.t_us,
            seq: model.seq,
            left: side(
                s.power_lsb.left,
                s.energy_lsb_us.left,
                s.torque_proportional.left,
            ),
            right: side(
                s.power_lsb.right,
                s.energy_lsb_us.right,
                s.torque_proportional.right,
            ),
            total_energy_j: scale.energy_j(s.total_energy_lsb_us()),
        }
    }

    /// The message as `rover_power.Model` protobuf ([`proto`]).
    pub(crate) fn protobuf(&self) -> Vec<u8> {
        let side = |m: &mut proto::Writer, s: &ModelSide| {
            m.opt_double(1, s.power_w);
            m.double(2, s.energy_j);
            if let Some(tau) = s.tau_w_per_rad_s {
                m.float(3, tau);
            }
        };
        let mut w = proto::Writer::new();
        w.double(1, self.t_s);
        w.varint(2, self.board_t_us);
        w.varint(3, u64::from(self.seq));
        w.message(4, |m| side(m, &self.left));
        w.message(5, |m| side(m, &self.right));
        w.double(6, self.total_energy_j);
        w.into_bytes()
    }
}

/// A `/rover_power/status` message (`rover_power.Status`): the status frame's fields, with a
/// side's fault and the wheel rates left out while there are none.
pub(crate) struct StatusMsg<'a> {
    t_s: f64,
    uptime_us: u64,
    samples: u32,
    running: bool,
    i2c_errors: Sides<u32>,
    reinits: Sides<u32>,
    skipped_results: Sides<u32>,
    last_fault: Faults,
    queue_drops: u32,
    rx_errors: u32,
    adc: &'a AdcConfig,
    sample_period_us: u32,
    wheel_rates_rad_s: Option<Sides<f32>>,
}

/// The latest fault per side, a side without one left out.
struct Faults {
    left: Option<ChipFault>,
    right: Option<ChipFault>,
}

/// A value's name as its JSON spells it (a fault, an averaging, a conversion time).
fn serde_name(value: &impl serde::Serialize) -> String {
    match serde_json::to_value(value) {
        Ok(serde_json::Value::String(name)) => name,
        Ok(other) => other.to_string(),
        Err(e) => e.to_string(),
    }
}

impl<'a> StatusMsg<'a> {
    pub(crate) fn of(t_s: f64, status: &'a Status) -> Self {
        // Destructured so that a field added to the frame cannot be left out here unnoticed.
        let Status {
            uptime_us,
            samples,
            running,
            i2c_errors,
            reinits,
            skipped_results,
            last_fault,
            queue_drops,
            rx_errors,
            adc,
            sample_period_us,
            wheel_rates_rad_s,
        } = status;
        StatusMsg {
            t_s,
            uptime_us: *uptime_us,
            samples: *samples,
            running: *running,
            i2c_errors: *i2c_errors,
            reinits: *reinits,
            skipped_results: *skipped_results,
            last_fault: Faults {
                left: last_fault.left,
                right: last_fault.right,
            },
            queue_drops: *queue_drops,
            rx_errors: *rx_errors,
            adc,
            sample_period_us: *sample_period_us,
            wheel_rates_rad_s: *wheel_rates_rad_s,
        }
    }

    /// The message as `rover_power.Status` protobuf ([`proto`]).
    pub(crate) fn protobuf(&self) -> Vec<u8> {
        let counts = |m: &mut proto::Writer, c: Sides<u32>| {
            m.varint(1, u64::from(c.left));
            m.varint(2, u64::from(c.right));
        };
        let mut w = proto::Writer::new();
        w.double(1, self.t_s);
        w.varint(2, self.uptime_us);
        w.varint(3, u64::from(self.samples));
        w.bool(4, self.running);
        w.message(5, |m| counts(m, self.i2c_errors));
        w.message(6, |m| counts(m, self.reinits));
        w.message(7, |m| counts(m, self.skipped_results));
        w.message(8, |m| {
            for (field, fault) in [(1, self.last_fault.left), (2, self.last_fault.right)] {
                if let Some(fault) = fault {
                    m.bytes(field, serde_name(&fault).as_bytes());
                }
            }
        });
        w.varint(9, u64::from(self.queue_drops));
        w.varint(10, u64::from(self.rx_errors));
        w.message(11, |m| {
            m.bytes(1, serde_name(&self.adc.averaging).as_bytes());
            m.bytes(2, serde_name(&self.adc.bus_conversion).as_bytes());
            m.bytes(3, serde_name(&self.adc.shunt_conversion).as_bytes());
        });
        w.varint(12, u64::from(self.sample_period_us));
        if let Some(rates) = self.wheel_rates_rad_s {
            w.message(13, |m| {
                m.float(1, rates.left);
                m.float(2, rates.right);
            });
        }
        w.into_bytes()
    }
}

impl<W: Write + Seek> RunLogSink for McapSink<W> {
    fn frame(&mut self, t_s: f64, frame: &BoardFrame) -> io::Result<()> {
        self.release_pending()?;
        if let BoardFrame::Sample(sample) = frame {
            // Every sample frame encodes (model_core::wire's worst case fits MAX_FRAME), so
            // holding it back defers no refusal.
            self.pending = Some((t_s, *sample));
            return Ok(());
        }
        self.write_frame(t_s, frame)?;
        match frame {
            BoardFrame::Hello(hello) => self.hello(t_s, hello)?,
            BoardFrame::Model(model) => {
                let msg = ModelMsg::of(t_s, model, self.scale);
                self.write(Ch::Model, t_s, &msg.protobuf())?;
            }
            BoardFrame::Status(status) => {
                self.write(Ch::Status, t_s, &StatusMsg::of(t_s, status).protobuf())?;
            }
            _ => {}
        }
        Ok(())
    }

    fn sample(&mut self, sample: &RunSample) -> io::Result<()> {
        let values = [
            sample.bus_v,
            sample.current_a,
            sample.cmd_mps,
            Sides::new(
                sample.yaw_rad.unwrap_or_default(),
                sample.pitch_deg.unwrap_or_default(),
            ),
            Sides::new(
                sample.x_m.unwrap_or_default(),
                sample.y_m.unwrap_or_default(),
            ),
        ];
        if values
            .iter()
            .any(|s| !s.left.is_finite() || !s.right.is_finite())
        {
            return Err(invalid(format!(
                "sample at t_s = {} has a value that is not a finite number",
                sample.t_s
            )));
        }
        if let Some(previous) = self.last_sample_t_s {
            if sample.t_s <= previous {
                return Err(invalid(format!(
                    "sample time {} is not after the previous sample's {previous}",
                    sample.t_s
                )));
            }
        }
        let registers = registers_of(sample, self.scale);
        // Its sample frame rides along when it came just before and rebuilds exactly.
        let board = match self.pending.take() {
            Some((t_s, frame)) => {
                let board = (t_s.to_bits() == sample.t_s.to_bits())
                    .then(|| BoardSample::of(&frame, sample))
                    .flatten();
                if board.is_none() {
                    self.write_frame(t_s, &BoardFrame::Sample(frame))?;
                }
                board
            }
            None => None,
        };
        if !self.batch.push(sample, registers, board, self.scale) {
            self.write_batch()?;
            self.batch.push(sample, registers, board, self.scale);
        }
        self.last_sample_t_s = Some(sample.t_s);
        Ok(())
    }

    fn command(&mut self, row: &CommandRow) -> io::Result<()> {
        self.release_pending()?;
        let finite = [row.cmd_mps.left, row.cmd_mps.right]
            .into_iter()
            .chain(row.yaw_rad)
            .chain(row.pitch_deg)
            .chain(row.x_m)
            .chain(row.y_m)
            .all(f64::is_finite);
        if !finite {
            return Err(invalid(format!(
                "command at t_s = {} has a value that is not a finite number",
                row.t_s
            )));
        }
        self.write_json(Ch::Command, row.t_s, &CommandMsg::of(row))
    }

    fn event(&mut self, t_s: f64, event: &LogEvent) -> io::Result<()> {
        self.release_pending()?;
        if let LogEvent::Reconnected { offline_s, .. } = event {
            if !offline_s.is_finite() {
                return Err(invalid(
                    "reconnection with a non-finite offline time".into(),
                ));
            }
        }
        if let LogEvent::WallClock { unix_ns } = event {
            // Samples gathered before it settle the clock as they did when they came.
            self.write_batch()?;
            self.anchor(t_s, *unix_ns)?;
        }
        // The JSON (with its foxglove.Log time stamp) is built when the log time is known.
        self.write_or_hold(Ch::Event, t_s, &[], Some(event))
    }

    fn flush(&mut self) -> io::Result<()> {
        self.write_waiting()?;
        self.writer().flush().map_err(into_io)
    }

    /// Writes the summary section and footer (the sink takes no more records afterwards).
    fn finish(&mut self) -> io::Result<()> {
        self.write_waiting()?;
        self.release_held(LogClock::Run)?;
        self.writer().finish().map(drop).map_err(into_io)
    }
}

impl<W: Write + Seek> Drop for McapSink<W> {
    /// A sink dropped unfinished writes what it holds; the `mcap` writer then writes the summary
    /// and footer (errors are ignored: [`McapSink::finish`] reports them).
    fn drop(&mut self) {
        if self.writer.is_some() {
            let _ = self.write_waiting();
            let _ = self.release_held(LogClock::Run);
        }
    }
}

/// MCAP publish time [ns] of a run time [s]: finite, ≥ 0 and below 2^64 ns (584 years).
pub(super) fn run_time_ns(t_s: f64) -> io::Result<u64> {
    let ns = (t_s * 1e9).round();
    if t_s.is_finite() && t_s >= 0.0 && ns < u64::MAX as f64 {
        Ok(ns as u64)
    } else {
        Err(invalid(format!(
            "run time {t_s} s cannot be an MCAP log time (finite, ≥ 0)"
        )))
    }
}

/// MCAP log time [ns] on the Unix clock: Unix time of run time 0 plus the run time, within
/// the u64 range.
fn unix_log_time(zero_ns: i128, run_ns: u64) -> u64 {
    (zero_ns + i128::from(run_ns)).clamp(0, i128::from(u64::MAX)) as u64
}

fn invalid(message: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, message)
}

fn into_io(e: ::mcap::McapError) -> io::Error {
    match e {
        ::mcap::McapError::Io(e) => e,
        other => io::Error::other(other),
    }
}
