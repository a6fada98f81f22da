//! MCAP run logs (<https://mcap.dev>): one file per run, readable by Foxglove Studio and the `mcap`
//! tools, written as the run happens by [`McapSink`] and read back by
//! [`read_mcap_run`].
//!
//! # Layout
//!
//! Channels (the high-rate ones in protobuf, their schema in the file: [`proto`]; commands and
//! events in JSON with `jsonschema` schemas in the subset Foxglove Studio reads):
//!
//! | topic | schema | what |
//! |---|---|---|
//! | `/rover_power/sample_batch` | `rover_power.SampleBatch` (protobuf) | the physical samples in batches of about 20 (one model period), one packed column per value ([`sample_batch`]): `t_s`; per side (`left`, `right`) `power_w` (`float`, bus × current, for viewers), the bus and current registers `bus_raw`, `current_raw` at the batch's `current_lsb_na` (the exact doubles rebuilt from them; `bus_v`, `current_a` as doubles in a batch whose readings are not registers), `cmd_mps`; `yaw_rad`, `pitch_deg` when measured and `x_m`, `y_m` when a tracker fix landed on the sample (NaN for a sample without); `board`: each sample frame's part beyond these ([`board_sample`]), when the frames came just before their samples and rebuild from them exactly. Files written before held one `rover_power.Sample` a message on `/rover_power/sample` (as the live view still sends them), and before that JSON samples; all read |
//! | `/rover_power/model` | `rover_power.Model` (protobuf) | the board's on-device model frame: per side `power_w`, `energy_j`, `tau_w_per_rad_s` (τ ∝ P/ω, Eq 5.14), in SI units at the board's scale |
//! | `/rover_power/status` | `rover_power.Status` (protobuf) | the board's status frame (health counters) |
//! | `/rover_power/command` | `rover_power.Command` (JSON) | commanded side speeds and tracked pose |
//! | `/rover_power/event` | `foxglove.Log` (JSON) | stream events (device vanished, samples lost, ...) as Foxglove log lines, with the structured event in `event` |
//! | `/rover_power/frame` | `rover_power.Frame` (protobuf) | every other wire frame exactly as the board encoded it, in `bytes wire = 1`; the bytes are `rover-power-wire-v<PROTOCOL_VERSION>` (channel metadata `wire_encoding`), now v3: `COBS(version ‖ postcard(BoardFrame) ‖ CRC-32) ‖ 0x00`, see `model_core::wire`. Files written before held every frame here, and before that the bare frame under that message encoding; all read |
//!
//! Logs written before the protobuf channels (samples, model and status in JSON) read the same.
//!
//! `publish_time` is the run time in ns; `log_time` is Unix time in ns, the host's clock: the
//! [`LogEvent::WallClock`] anchor (when the first sample's bytes were read) plus the run time
//! since it. Messages before the anchor are held by the sink until it comes, so one file has one
//! clock; a log without a wall-clock event (a converted CSV without its events) keeps
//! `log_time` = run time, as files written before this did. The reader takes run time from
//! `publish_time`, so it reads both. Frames are stored as bytes, so their run time is kept to
//! the nanosecond; samples, commands and events carry their exact `t_s` as well. Metadata records:
//! `rover_power` (protocol version, frame encoding, writer) at the start,
//! `rover_power.wall_clock` (`unix_ns`, `at_t_s`, `unix_ns_at_run_zero`) when the wall clock is
//! known, and `rover_power.board` at each hello frame (firmware, scale, LSBs, chip addresses, period).
//!
//! The model and status channels are views of the frames for plotting; the reader rebuilds a
//! [`RunLog`] from the frame, sample, command and event channels. Other topics in the file
//! (a recording merged with a ROS bag) are ignored.
//!
//! # Crash safety
//!
//! Records are grouped in lz4-compressed chunks of at most [`CHUNK_BYTES`] (uncompressed and
//! zstd chunks, as other tools and our earlier versions write them, read too); each
//! [`RunLogSink::flush`] closes the current chunk and writes it whole, so a killed process
//! leaves a file that holds every chunk flushed before it died. The summary section (indexes,
//! statistics) and the footer are written by [`McapSink::finish`] or on drop. The reader does
//! not need them: it reads the records in order and reports a file cut short (no footer, or a
//! torn last record) as [`McapRun::truncated`] with everything before the cut.
//!
//! # Salvage
//!
//! A damaged file (a flipped bit, a zeroed block, bytes inserted or deleted) is read around the
//! damage: a chunk whose CRC, compression or sizes do not check out is skipped whole, and bytes
//! holding no record header are skipped up to the next plausible record header that is followed
//! by another (searched from inside a chunk that failed, whose length may be what moved). The
//! summary's channel records stand in for ones lost with a chunk, found after the data end
//! record when bytes inserted or deleted before it moved it off the footer's offset.
//! Each skipped stretch is a [`Loss`] in [`McapRun::losses`]: bytes, the run times around it and
//! the samples lost (counted from the chunk's message index when it survived, else estimated).

mod ahead;
mod board_sample;
mod frame_proto;
mod lz4_frame;
mod prepare;
pub(crate) mod proto;
mod read;
#[cfg(test)]
mod salvage_tests;
mod sample_batch;
mod sample_json;
mod sink;
pub mod studio;
#[cfg(test)]
pub(crate) mod tests;
mod walk;
// The ROS 2 bag reader parses records and decodes chunks with the same guards.
pub(crate) use walk::{parse_record, ChunkDecoder, ChunkProblem};

pub use read::{
    read_mcap_bytes, read_mcap_run, stream_mcap_run, Loss, LostSamples, McapFound, McapRun,
    Truncation,
};
pub use sink::McapSink;
pub(crate) use sink::{ModelMsg, StatusMsg, HELD_MAX};

use super::commands::CommandRow;
use super::run_csv::RunSample;
use super::run_log::{LogEvent, RunLog};
use model_core::wire::PROTOCOL_VERSION;
use model_core::Sides;
use std::io;
use std::path::PathBuf;

/// Topic of the physical samples one by one (the live view; log files before batches).
pub const TOPIC_SAMPLE: &str = "/rover_power/sample";
/// Topic of the physical samples in batches (log files).
pub const TOPIC_SAMPLE_BATCH: &str = "/rover_power/sample_batch";
/// Topic of the board's model frames in SI units.
pub const TOPIC_MODEL: &str = "/rover_power/model";
/// Topic of the board's status frames.
pub const TOPIC_STATUS: &str = "/rover_power/status";
/// Topic of the commanded speeds and tracked pose.
pub const TOPIC_COMMAND: &str = "/rover_power/command";
/// Topic of the stream events.
pub const TOPIC_EVENT: &str = "/rover_power/event";
/// Topic of the raw wire frames.
pub const TOPIC_FRAME: &str = "/rover_power/frame";

/// How a channel's messages are encoded, with the schema that says so.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// `protobuf` messages; the schema is [`proto::descriptor_set`] of the schema's name (schema
    /// encoding `protobuf`).
    Protobuf,
    /// `json` messages with this JSON schema (schema encoding `jsonschema`, in the subset Foxglove
    /// Studio reads).
    Json(&'static str),
}

/// A channel of a run log: the MCAP file declares these and the live server (`crate::live`)
/// advertises the same, so one Foxglove layout reads both.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LogChannel {
    /// The topic.
    pub topic: &'static str,
    /// The schema's name (for protobuf, the message's fully qualified name).
    pub schema_name: &'static str,
    /// How its messages are encoded.
    pub encoding: Encoding,
}

impl LogChannel {
    /// The message encoding (`protobuf` or `json`).
    pub fn message_encoding(&self) -> &'static str {
        match self.encoding {
            Encoding::Protobuf => proto::ENCODING,
            Encoding::Json(_) => "json",
        }
    }

    /// The schema encoding (`protobuf` or `jsonschema`).
    pub fn schema_encoding(&self) -> &'static str {
        match self.encoding {
            Encoding::Protobuf => proto::ENCODING,
            Encoding::Json(_) => "jsonschema",
        }
    }

    /// The schema's bytes as the MCAP schema record holds them.
    pub fn schema(&self) -> Vec<u8> {
        match self.encoding {
            Encoding::Protobuf => proto::descriptor_set(self.schema_name),
            Encoding::Json(schema) => schema.as_bytes().to_vec(),
        }
    }
}

/// [`TOPIC_SAMPLE`]'s channel.
pub const SAMPLE_CHANNEL: LogChannel = LogChannel {
    topic: TOPIC_SAMPLE,
    schema_name: proto::SAMPLE,
    encoding: Encoding::Protobuf,
};
/// [`TOPIC_SAMPLE_BATCH`]'s channel.
pub const SAMPLE_BATCH_CHANNEL: LogChannel = LogChannel {
    topic: TOPIC_SAMPLE_BATCH,
    schema_name: proto::SAMPLE_BATCH,
    encoding: Encoding::Protobuf,
};
/// [`TOPIC_MODEL`]'s channel.
pub const MODEL_CHANNEL: LogChannel = LogChannel {
    topic: TOPIC_MODEL,
    schema_name: proto::MODEL,
    encoding: Encoding::Protobuf,
};
/// [`TOPIC_STATUS`]'s channel.
pub const STATUS_CHANNEL: LogChannel = LogChannel {
    topic: TOPIC_STATUS,
    schema_name: proto::STATUS,
    encoding: Encoding::Protobuf,
};
/// [`TOPIC_COMMAND`]'s channel.
pub const COMMAND_CHANNEL: LogChannel = LogChannel {
    topic: TOPIC_COMMAND,
    schema_name: "rover_power.Command",
    encoding: Encoding::Json(schema::COMMAND),
};
/// [`TOPIC_EVENT`]'s channel.
pub const EVENT_CHANNEL: LogChannel = LogChannel {
    topic: TOPIC_EVENT,
    schema_name: "foxglove.Log",
    encoding: Encoding::Json(schema::EVENT),
};
/// [`TOPIC_FRAME`]'s channel.
pub const FRAME_CHANNEL: LogChannel = LogChannel {
    topic: TOPIC_FRAME,
    schema_name: proto::FRAME,
    encoding: Encoding::Protobuf,
};

/// Target size of a chunk before it is written even without a flush [bytes].
pub const CHUNK_BYTES: u64 = 256 * 1024;

/// The wire format of this protocol version: what the frame channel's messages hold (its
/// `wire_encoding`; the message encoding itself in files written before the protobuf wrapping).
pub fn frame_encoding() -> String {
    format!("rover-power-wire-v{PROTOCOL_VERSION}")
}

/// Why an MCAP run log could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum McapError {
    /// Opening, reading or writing the file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// The file does not start with the MCAP magic bytes.
    #[error("{}: not an MCAP file (it does not start with the MCAP magic bytes)", path.display())]
    NotMcap {
        /// The file.
        path: PathBuf,
    },
    /// The MCAP structure is damaged (bad record, CRC mismatch, unsupported compression).
    #[error("{}: byte {offset}: {detail}", path.display())]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// Where the damaged record starts.
        offset: u64,
        /// What is wrong.
        detail: String,
    },
    /// A rover-power message does not hold what its channel promises.
    #[error("{}: {topic} message at run time {run_time_ns} ns: {detail}", path.display())]
    BadMessage {
        /// The file.
        path: PathBuf,
        /// The message's topic.
        topic: String,
        /// The message's run time (its `publish_time`).
        run_time_ns: u64,
        /// What is wrong.
        detail: String,
    },
    /// A valid MCAP file that is not a rover-power run, or of another protocol version.
    #[error("{}: {detail}", path.display())]
    Foreign {
        /// The file.
        path: PathBuf,
        /// What was found instead.
        detail: String,
    },
    /// The writer refused a record (a non-finite value, a sample time not after the previous
    /// one, a negative run time).
    #[error("{0}")]
    Refused(String),
    /// The MCAP writer failed.
    #[error("writing MCAP: {0}")]
    Write(#[from] ::mcap::McapError),
}

/// Writes a whole [`RunLog`] as MCAP into `out`, records in time order (events, then frames,
/// then samples at equal times); returns the finished writer.
pub fn write_mcap_run<W: io::Write + io::Seek>(out: W, run: &RunLog) -> Result<W, McapError> {
    write_mcap_run_with(out, run, Some(::mcap::Compression::Lz4))
}

/// [`write_mcap_run`] with the chunks' compression chosen (`None`: uncompressed).
pub fn write_mcap_run_with<W: io::Write + io::Seek>(
    out: W,
    run: &RunLog,
    compression: Option<::mcap::Compression>,
) -> Result<W, McapError> {
    let mut sink = McapSink::with_compression(out, compression)?;
    for (t_s, record) in run.in_time_order() {
        record
            .write_to(t_s, &mut sink)
            .map_err(|e| match e.kind() {
                io::ErrorKind::InvalidInput => McapError::Refused(e.to_string()),
                _ => McapError::Write(::mcap::McapError::Io(e)),
            })?;
    }
    sink.finish()
}

/// One side of a [`SampleMsg`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
struct SampleSide {
    bus_v: f64,
    current_a: f64,
    power_w: f64,
    cmd_mps: f64,
}

/// A `/rover_power/sample` message.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct SampleMsg {
    t_s: f64,
    left: SampleSide,
    right: SampleSide,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    yaw_rad: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pitch_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    x_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    y_m: Option<f64>,
}

impl SampleMsg {
    pub(crate) fn of(s: &RunSample) -> Self {
        let side = |bus_v: f64, current_a: f64, cmd_mps: f64| SampleSide {
            bus_v,
            current_a,
            power_w: bus_v * current_a,
            cmd_mps,
        };
        SampleMsg {
            t_s: s.t_s,
            left: side(s.bus_v.left, s.current_a.left, s.cmd_mps.left),
            right: side(s.bus_v.right, s.current_a.right, s.cmd_mps.right),
            yaw_rad: s.yaw_rad,
            pitch_deg: s.pitch_deg,
            x_m: s.x_m,
            y_m: s.y_m,
        }
    }

    /// The message as `rover_power.Sample` protobuf ([`proto`]), with the board's sample frame
    /// folded in when given.
    pub(crate) fn protobuf(&self, board: Option<&board_sample::BoardSample>) -> Vec<u8> {
        let side = |m: &mut proto::Writer, s: &SampleSide| {
            m.double(1, s.bus_v);
            m.double(2, s.current_a);
            m.double(3, s.power_w);
            m.double(4, s.cmd_mps);
        };
        let mut w = proto::Writer::new();
        w.double(1, self.t_s);
        w.message(2, |m| side(m, &self.left));
        w.message(3, |m| side(m, &self.right));
        w.opt_double(4, self.yaw_rad);
        w.opt_double(5, self.pitch_deg);
        w.opt_double(6, self.x_m);
        w.opt_double(7, self.y_m);
        if let Some(board) = board {
            w.message(8, |m| board.write(m));
        }
        w.into_bytes()
    }

    /// The sample a `rover_power.Sample` protobuf message holds, and its board frame's part if
    /// folded in. Its time and both sides are required (a writer of ours wrote them); unknown
    /// fields are skipped, as protobuf readers do, so a later writer may add some.
    pub(crate) fn from_protobuf(
        data: &[u8],
    ) -> Result<(RunSample, Option<board_sample::BoardSample>), String> {
        Self::from_own_protobuf(data).unwrap_or_else(|| Self::from_protobuf_fields(data))
    }

    /// [`Self::from_protobuf`] field by field, for any layout.
    fn from_protobuf_fields(
        data: &[u8],
    ) -> Result<(RunSample, Option<board_sample::BoardSample>), String> {
        fn side(data: &[u8]) -> Result<[Option<f64>; 3], String> {
            let mut out = [None; 3];
            for item in proto::Fields::of(data) {
                let (field, value) = item?;
                match field {
                    1 => out[0] = Some(value.double()?),
                    2 => out[1] = Some(value.double()?),
                    4 => out[2] = Some(value.double()?),
                    _ => {}
                }
            }
            Ok(out)
        }
        let mut t_s = None;
        let (mut left, mut right) = ([None; 3], [None; 3]);
        let mut optional = [None; 4];
        let mut board = None;
        for item in proto::Fields::of(data) {
            let (field, value) = item?;
            match (field, value) {
                (1, v) => t_s = Some(v.double()?),
                (2, proto::Value::Len(m)) => left = side(m)?,
                (3, proto::Value::Len(m)) => right = side(m)?,
                (4..=7, v) => optional[field as usize - 4] = Some(v.double()?),
                (8, proto::Value::Len(m)) => board = Some(board_sample::BoardSample::read(m)?),
                (2 | 3 | 8, other) => {
                    return Err(format!(
                        "field {field}: expected a message, found {other:?}"
                    ))
                }
                _ => {}
            }
        }
        let need = |v: Option<f64>, name: &str| v.ok_or_else(|| format!("no {name}"));
        let [bus_l, cur_l, cmd_l] = left;
        let [bus_r, cur_r, cmd_r] = right;
        let sample = RunSample {
            t_s: need(t_s, "t_s")?,
            bus_v: Sides::new(need(bus_l, "left.bus_v")?, need(bus_r, "right.bus_v")?),
            current_a: Sides::new(
                need(cur_l, "left.current_a")?,
                need(cur_r, "right.current_a")?,
            ),
            cmd_mps: Sides::new(need(cmd_l, "left.cmd_mps")?, need(cmd_r, "right.cmd_mps")?),
            yaw_rad: optional[0],
            pitch_deg: optional[1],
            x_m: optional[2],
            y_m: optional[3],
        };
        Ok((sample, board))
    }

    /// [`Self::from_protobuf`] for a message laid out exactly as [`Self::protobuf`] writes it
    /// (fields in order, every side value present): read at fixed offsets, as the sample channel
    /// is most of a log. `None` for any other layout, which the general reader takes.
    fn from_own_protobuf(
        data: &[u8],
    ) -> Option<Result<(RunSample, Option<board_sample::BoardSample>), String>> {
        /// Key and length of a side: field 2 or 3, 36 bytes of four doubles (keys 1 to 4).
        const SIDE: usize = 2 + 36;
        fn double(bytes: &[u8], key: u8) -> Option<f64> {
            let (&k, rest) = bytes.split_first()?;
            if k != key {
                return None;
            }
            Some(f64::from_le_bytes(*rest.first_chunk::<8>()?))
        }
        fn side(bytes: &[u8], field: u8) -> Option<[f64; 4]> {
            if bytes.get(..2)? != [field << 3 | 2, 36] {
                return None;
            }
            let mut out = [0.0; 4];
            for (i, v) in out.iter_mut().enumerate() {
                *v = double(bytes.get(2 + 9 * i..)?, (i as u8 + 1) << 3 | 1)?;
            }
            Some(out)
        }
        let t_s = double(data, 1 << 3 | 1)?;
        let left = side(data.get(9..)?, 2)?;
        let right = side(data.get(9 + SIDE..)?, 3)?;
        let mut rest = data.get(9 + 2 * SIDE..)?;
        let mut optional = [None; 4];
        for (i, v) in optional.iter_mut().enumerate() {
            if let Some(x) = double(rest, (i as u8 + 4) << 3 | 1) {
                *v = Some(x);
                rest = &rest[9..];
            }
        }
        let board = match rest.split_first() {
            None => None,
            Some((&0x42, tail)) => {
                let (len, tail) = proto::varint(tail)?;
                if u64::try_from(tail.len()).ok()? != len {
                    return None;
                }
                Some(match board_sample::BoardSample::read(tail) {
                    Ok(board) => board,
                    Err(e) => return Some(Err(e)),
                })
            }
            Some(_) => return None,
        };
        let sample = RunSample {
            t_s,
            bus_v: Sides::new(left[0], right[0]),
            current_a: Sides::new(left[1], right[1]),
            cmd_mps: Sides::new(left[3], right[3]),
            yaw_rad: optional[0],
            pitch_deg: optional[1],
            x_m: optional[2],
            y_m: optional[3],
        };
        Some(Ok((sample, board)))
    }

    fn sample(&self) -> RunSample {
        RunSample {
            t_s: self.t_s,
            bus_v: Sides::new(self.left.bus_v, self.right.bus_v),
            current_a: Sides::new(self.left.current_a, self.right.current_a),
            cmd_mps: Sides::new(self.left.cmd_mps, self.right.cmd_mps),
            yaw_rad: self.yaw_rad,
            pitch_deg: self.pitch_deg,
            x_m: self.x_m,
            y_m: self.y_m,
        }
    }
}

/// A `/rover_power/command` message.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct CommandMsg {
    t_s: f64,
    cmd_mps: Sides<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    yaw_rad: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pitch_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    x_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    y_m: Option<f64>,
}

impl CommandMsg {
    pub(crate) fn of(c: &CommandRow) -> Self {
        CommandMsg {
            t_s: c.t_s,
            cmd_mps: c.cmd_mps,
            yaw_rad: c.yaw_rad,
            pitch_deg: c.pitch_deg,
            x_m: c.x_m,
            y_m: c.y_m,
        }
    }

    fn row(&self) -> CommandRow {
        CommandRow {
            t_s: self.t_s,
            cmd_mps: self.cmd_mps,
            yaw_rad: self.yaw_rad,
            pitch_deg: self.pitch_deg,
            x_m: self.x_m,
            y_m: self.y_m,
        }
    }
}

/// Foxglove's `foxglove.Log` time stamp.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
struct FoxgloveTime {
    sec: u64,
    nsec: u32,
}

/// A `/rover_power/event` message: a `foxglove.Log` line (Foxglove's Log panel shows it) plus
/// the structured event and its exact run time.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct EventMsg {
    t_s: f64,
    event: LogEvent,
    #[serde(default)]
    timestamp: Option<FoxgloveTime>,
    /// foxglove.Log level: 2 info, 3 warning.
    #[serde(default)]
    level: u8,
    #[serde(default)]
    message: String,
    #[serde(default)]
    name: String,
    #[serde(default)]
    file: String,
    #[serde(default)]
    line: u32,
}

impl EventMsg {
    pub(crate) fn of(t_s: f64, log_time_ns: u64, event: &LogEvent) -> Self {
        let (level, message) = describe_event(event);
        EventMsg {
            t_s,
            event: event.clone(),
            timestamp: Some(FoxgloveTime {
                sec: log_time_ns / 1_000_000_000,
                nsec: (log_time_ns % 1_000_000_000) as u32,
            }),
            level,
            message,
            name: "rover-power".into(),
            file: String::new(),
            line: 0,
        }
    }
}

/// foxglove.Log level and text of an event.
pub(crate) fn describe_event(event: &LogEvent) -> (u8, String) {
    const INFO: u8 = 2;
    const WARNING: u8 = 3;
    match event {
        LogEvent::Started { port } => (INFO, format!("recording started on {port}")),
        LogEvent::DeviceVanished { port } => (WARNING, format!("device on {port} vanished")),
        LogEvent::Reconnected { port, offline_s } => (
            INFO,
            format!("device back on {port} after {offline_s:.3} s offline"),
        ),
        LogEvent::SamplesLost { after_seq, missing } => (
            WARNING,
            format!("{missing} samples lost after sample {after_seq}"),
        ),
        LogEvent::BadFrames { count } => (WARNING, format!("{count} frames failed to decode")),
        LogEvent::BoardReset => (
            WARNING,
            "the board restarted (time and energy start over)".into(),
        ),
        LogEvent::Stopped { reason } => (INFO, format!("recording stopped: {reason}")),
        LogEvent::WallClock { unix_ns } => (
            INFO,
            format!("wall clock: this sample is at Unix time {unix_ns} ns"),
        ),
    }
}

/// JSON schemas of the channels, in the subset Foxglove Studio's reader (`parseJsonSchema`)
/// takes: every field has one `"type"` string, nested objects are written inline (no `$ref`),
/// and a value that is not known is an absent field, never `null` (no type arrays).
/// [`super::studio`] holds every schema and message to these rules (tests).
mod schema {
    pub(super) const COMMAND: &str = r##"{
  "title": "rover_power.Command",
  "description": "Commanded side speeds and the tracked pose",
  "type": "object",
  "properties": {
    "t_s": {"type": "number", "description": "run time [s]"},
    "cmd_mps": {
      "type": "object",
      "properties": {"left": {"type": "number"}, "right": {"type": "number"}},
      "description": "commanded side speeds [m/s], positive forward"
    },
    "yaw_rad": {"type": "number"},
    "pitch_deg": {"type": "number"},
    "x_m": {"type": "number"},
    "y_m": {"type": "number"}
  },
  "required": ["t_s", "cmd_mps"]
}"##;

    pub(super) const EVENT: &str = r##"{
  "title": "foxglove.Log",
  "description": "A stream event as a log line; the structured event is in `event`",
  "type": "object",
  "properties": {
    "timestamp": {
      "type": "object",
      "properties": {"sec": {"type": "integer", "minimum": 0}, "nsec": {"type": "integer", "minimum": 0}}
    },
    "level": {"type": "integer", "description": "1 debug, 2 info, 3 warning, 4 error, 5 fatal"},
    "message": {"type": "string"},
    "name": {"type": "string"},
    "file": {"type": "string"},
    "line": {"type": "integer", "minimum": 0},
    "t_s": {"type": "number", "description": "run time [s]"},
    "event": {
      "type": "object",
      "description": "the structured event; which fields it has depends on its kind",
      "properties": {
        "kind": {"type": "string", "description": "started, device-vanished, reconnected, samples-lost, bad-frames, board-reset, stopped or wall-clock"},
        "port": {"type": "string", "description": "the serial port (started, device-vanished, reconnected)"},
        "offline_s": {"type": "number", "description": "time the device was gone [s] (reconnected)"},
        "after_seq": {"type": "integer", "description": "the last sample before the gap (samples-lost)"},
        "missing": {"type": "integer", "description": "samples lost (samples-lost)"},
        "count": {"type": "integer", "description": "frames that failed to decode (bad-frames)"},
        "reason": {"type": "string", "description": "why the recording stopped (stopped)"},
        "unix_ns": {"type": "integer", "description": "host clock when the first sample arrived [Unix ns] (wall-clock)"}
      },
      "required": ["kind"]
    }
  },
  "required": ["timestamp", "level", "message", "name", "file", "line", "t_s", "event"]
}"##;
}
