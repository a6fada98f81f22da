//! [`read_mcap_run`]: an MCAP run log back into a [`RunLog`], record by record in file order,
//! streamed from the disk (memory holds a few chunks, not the file: [`super::ahead`]);
//! [`stream_mcap_run`] hands the records to any [`RunLogSink`] instead, so a reader that keeps
//! nothing (`validate`'s passes) runs in memory bounded whatever the log's length. The summary
//! section is not needed, so a file cut short by a killed recorder reads up to its last
//! complete record; a damaged file is salvaged ([`walk`](super::walk)): every chunk that checks
//! out is read, and what could not be is reported as [`Loss`]es (byte range, run time range,
//! samples).

use super::ahead::{walk_ahead, Walked};
use super::board_sample::BoardSample;
use super::prepare::{record_body, Decoded, Prepared, Span};
use super::sample_batch::Columns;
use super::sample_json::parse_sample_msg;
use super::walk::{parse_record, Skipped, Walker};
use super::{
    frame_encoding, frame_proto, proto, CommandMsg, EventMsg, McapError, SampleMsg, TOPIC_COMMAND,
    TOPIC_EVENT, TOPIC_FRAME, TOPIC_SAMPLE, TOPIC_SAMPLE_BATCH,
};
use crate::log::run_csv::RigRange;
use crate::log::run_csv::RunSample;
use crate::log::run_log::{RunLog, RunLogSink};
use crate::ros2::from_log::{decode_sample, SAMPLE_TYPE};
use ::mcap::records::{op, Record};
use model_core::wire::{self, BoardFrame, Sample, MAX_FRAME};
use std::collections::{BTreeSet, HashMap};
use std::fmt;
use std::io::{self, Read, Seek};
use std::path::{Path, PathBuf};

/// Where a file was cut short.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Truncation {
    /// Bytes up to the end of the last complete record (everything read comes from these).
    pub complete_bytes: u64,
    /// The file's size.
    pub file_bytes: u64,
}

/// How many samples a [`Loss`] took.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LostSamples {
    /// Counted from the damaged chunk's message index, which survived it.
    Exact(u64),
    /// Estimated from the time gap between the surviving samples around the loss and their
    /// sample period.
    About(u64),
    /// At the very start or end of the run: no sample on one side to measure the gap.
    Unknown,
}

/// A stretch of a damaged MCAP file that could not be trusted and was skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct Loss {
    /// First byte skipped.
    pub start_byte: u64,
    /// One past the last byte skipped.
    pub end_byte: u64,
    /// Why it was skipped (chunk CRC mismatch, no record header, ...).
    pub detail: String,
    /// Samples lost.
    pub samples: LostSamples,
    /// Run time of the last sample read before the loss [s] (`None`: the loss starts the run).
    pub after_t_s: Option<f64>,
    /// Run time of the first sample read after the loss [s] (`None`: the loss ends the run).
    pub before_t_s: Option<f64>,
}

impl fmt::Display for Loss {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "bytes {}..{}: ", self.start_byte, self.end_byte)?;
        match self.samples {
            LostSamples::Exact(n) => write!(f, "{n} samples lost")?,
            LostSamples::About(n) => write!(f, "about {n} samples lost")?,
            LostSamples::Unknown => write!(f, "samples lost")?,
        }
        match (self.after_t_s, self.before_t_s) {
            (Some(a), Some(b)) => write!(f, " between t = {a:.3} s and {b:.3} s")?,
            (Some(a), None) => write!(f, " after t = {a:.3} s")?,
            (None, Some(b)) => write!(f, " before t = {b:.3} s")?,
            (None, None) => {}
        }
        write!(f, " ({})", self.detail)
    }
}

/// What [`read_mcap_run`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct McapRun {
    /// The run: every record that could be trusted, up to the last complete one.
    pub run: RunLog,
    /// `Some` if the file ends before its footer (the recorder was killed, the disk filled up,
    /// the copy was cut): a torn last record, or no summary section. `None` for a finished file.
    pub truncated: Option<Truncation>,
    /// Damaged stretches skipped inside the file, in file order (empty for an intact file).
    pub losses: Vec<Loss>,
}

/// Reads the MCAP run log at `path`, streaming it (memory stays bounded by a few chunks plus the
/// run itself). A file cut short is not an error (see [`McapRun::truncated`]), nor is a damaged
/// one (see [`McapRun::losses`]: a damaged chunk, a record that does not parse, a message
/// that does not hold what its channel promises); a foreign file is.
pub fn read_mcap_run(path: &Path) -> Result<McapRun, McapError> {
    let mut run = RunLog::default();
    let found = stream_mcap_run(path, &mut run)?;
    Ok(found.with_run(run))
}

/// Reads an MCAP run log held in memory; `path` only names it in errors.
pub fn read_mcap_bytes(bytes: &[u8], path: &Path) -> Result<McapRun, McapError> {
    let mut run = RunLog::default();
    let found = read_mcap(io::Cursor::new(bytes), bytes.len() as u64, path, &mut run)?;
    Ok(found.with_run(run))
}

/// What a read found besides the records it handed on: a cut end, damaged stretches.
#[derive(Debug, Clone, PartialEq)]
pub struct McapFound {
    /// See [`McapRun::truncated`].
    pub truncated: Option<Truncation>,
    /// See [`McapRun::losses`].
    pub losses: Vec<Loss>,
}

impl McapFound {
    fn with_run(self, run: RunLog) -> McapRun {
        McapRun {
            run,
            truncated: self.truncated,
            losses: self.losses,
        }
    }
}

/// [`read_mcap_run`] without keeping the run: every record that can be trusted goes to `sink`
/// in file order (frames, samples, commands, events), as the recorder handed them to its sink.
/// An error `sink` returns stops the read and comes back as [`McapError::Io`] (a sink that
/// needs its own error type keeps it and returns any `io::Error`).
pub fn stream_mcap_run(path: &Path, sink: &mut dyn RunLogSink) -> Result<McapFound, McapError> {
    let io_err = |source| McapError::Io {
        path: path.to_owned(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io_err)?;
    let len = file.metadata().map_err(io_err)?.len();
    read_mcap(file, len, path, sink)
}

/// The reader behind [`stream_mcap_run`] and [`read_mcap_bytes`].
fn read_mcap<R: Read + Seek + Send>(
    mut input: R,
    len: u64,
    path: &Path,
    sink: &mut dyn RunLogSink,
) -> Result<McapFound, McapError> {
    let io_err = |source| McapError::Io {
        path: path.to_owned(),
        source,
    };
    let magic = ::mcap::MAGIC.len() as u64;
    let mut head = [0u8; 8];
    let has_magic = len >= magic
        && input
            .read_exact(&mut head)
            .map(|()| head == ::mcap::MAGIC)
            .map_err(io_err)?;
    let mut walker = Walker::new(input, len, magic.min(len)).map_err(io_err)?;
    let mut state = State::new(path, sink);
    if !has_magic {
        // A damaged start (a zeroed first block): salvage from the first record found.
        let Some(at) = walker.resync(0).map_err(io_err)? else {
            return Err(McapError::NotMcap {
                path: path.to_owned(),
            });
        };
        walker.seek(at).map_err(io_err)?;
        state.skip(Skipped {
            start_byte: 0,
            end_byte: at,
            detail: format!("no MCAP magic; resynchronised at byte {at}"),
        });
    }
    let mut summary_is_ours = false;
    for channel in walker.summary_channels() {
        summary_is_ours |= channel.topic.starts_with("/rover_power/");
        state.fallback.insert(channel.id, channel);
    }
    let truncated = walk_ahead(walker, |ahead| -> Result<_, McapError> {
        let mut truncated = None;
        // The damaged chunk whose message indexes (which follow it) count what it held.
        let mut pending: Option<usize> = None;
        while let Some(walked) = ahead.next() {
            match walked.map_err(io_err)? {
                Walked::Chunk {
                    records,
                    prepared,
                    offset,
                    end,
                } => {
                    state.chunk_records(&records, prepared, offset, end)?;
                    pending = None;
                    ahead.recycle(records, state.take_prepared());
                }
                Walked::ChunkFailed(skipped) => {
                    state.skip(skipped);
                    if let Some(skip) = state.skipped.last_mut() {
                        skip.indexed = Some(Indexed::default());
                    }
                    pending = Some(state.skipped.len() - 1);
                }
                Walked::IndexOfFailed(body) => {
                    if let Some(i) = pending {
                        state.count_index(&body, i);
                    }
                }
                Walked::Record {
                    opcode,
                    offset,
                    body,
                } => state.record_or_skip(opcode, &body, offset, offset + 9 + body.len() as u64)?,
                Walked::Skipped(s) => {
                    state.skip(s);
                    pending = None;
                }
                Walked::Truncated { complete_bytes } => {
                    truncated = Some(Truncation {
                        complete_bytes,
                        file_bytes: len,
                    });
                }
            }
        }
        Ok(truncated)
    })
    .map_err(io_err)??;
    if truncated.is_none() && !state.ours && !summary_is_ours {
        let topics: Vec<&str> = state.foreign_topics.iter().map(String::as_str).collect();
        if let (true, Some(first)) = (topics.is_empty(), state.skipped.first()) {
            // No channel record at all in a damaged file: damage took them, the file may well
            // be ours.
            let orphans = match state.orphan_channels.len() {
                0 => String::new(),
                n => format!(
                    " (messages on {n} channels remain, with no channel record to say what they \
                     hold)"
                ),
            };
            return Err(McapError::Corrupt {
                path: path.to_owned(),
                offset: first.skipped.start_byte,
                detail: format!("the file's channel records were lost to damage{orphans}"),
            });
        }
        return Err(McapError::Foreign {
            path: path.to_owned(),
            detail: if topics.is_empty() {
                "an MCAP file without rover-power channels (no channels at all)".into()
            } else {
                format!(
                    "an MCAP file without rover-power channels (its topics: {})",
                    topics.join(", ")
                )
            },
        });
    }
    let mut skipped = std::mem::take(&mut state.skipped);
    state.times.close(&mut skipped);
    Ok(McapFound {
        truncated,
        losses: losses(merge(skipped)),
    })
}

/// Samples of a damaged chunk, from the message index records that follow it.
#[derive(Debug, Clone, Copy, Default)]
struct Indexed {
    /// Whether any message index record followed the chunk (then `samples` is exact unless
    /// `batches`).
    seen: bool,
    samples: u64,
    /// Whether it indexed sample batches, whose count is not the samples'.
    batches: bool,
}

/// A skipped stretch and where it falls in the run.
#[derive(Debug, Clone)]
struct Skip {
    skipped: Skipped,
    /// Samples read before it.
    at_sample: usize,
    /// For one damaged chunk: what its message indexes say it held.
    indexed: Option<Indexed>,
    /// Samples lost before the next sample batch read, from its sequence (the samples written
    /// before it) and the previous batch's end.
    sequence_gap: Option<u64>,
    /// The sample times around it.
    times: SkipTimes,
}

/// Up to [`AROUND`] sample times on each side of a skipped stretch: enough to date the loss and
/// estimate what it held, without keeping the run.
#[derive(Debug, Clone, Default)]
struct SkipTimes {
    /// The last times read before the stretch, oldest first.
    before: Vec<f64>,
    /// The first times read after it.
    after: Vec<f64>,
}

/// Sample times kept on each side of a loss (32 intervals).
const AROUND: usize = 33;

/// The recent sample times, and the skips still collecting times after them.
#[derive(Debug, Default)]
struct RecentTimes {
    /// The last [`AROUND`] times (fewer at first), a ring whose oldest is at `next` once full.
    recent: Vec<f64>,
    next: usize,
    /// Every skip opened (by its place in the reader's list), in order.
    open: Vec<usize>,
    /// Times after each open skip, by its place in `open`.
    collecting: Vec<Vec<f64>>,
    /// Skips before this place in `open` have all their times (skips open in order and each
    /// takes the next [`AROUND`], so the full ones come first).
    first_open: usize,
}

impl RecentTimes {
    /// The times for a skip pushed now at place `at` of the reader's list (its `after` is filled
    /// in by [`RecentTimes::close`]).
    fn open(&mut self, at: usize) -> SkipTimes {
        self.open.push(at);
        self.collecting.push(Vec::new());
        SkipTimes {
            before: self.recent[self.next..]
                .iter()
                .chain(&self.recent[..self.next])
                .copied()
                .collect(),
            after: Vec::new(),
        }
    }

    fn recent(&mut self, t_s: f64) {
        match self.recent.get_mut(self.next) {
            Some(oldest) => *oldest = t_s,
            None => self.recent.push(t_s),
        }
        self.next = if self.next + 1 == AROUND {
            0
        } else {
            self.next + 1
        };
    }

    fn sample(&mut self, t_s: f64) {
        self.recent(t_s);
        for after in &mut self.collecting[self.first_open..] {
            after.push(t_s);
        }
        while self
            .collecting
            .get(self.first_open)
            .is_some_and(|after| after.len() == AROUND)
        {
            self.first_open += 1;
        }
    }

    /// [`RecentTimes::sample`] for each of `samples` (a batch's).
    fn samples(&mut self, samples: &[RunSample]) {
        if self.first_open < self.collecting.len() {
            return samples.iter().for_each(|s| self.sample(s.t_s));
        }
        // No skip is collecting times: only the recent ones change.
        let keep = samples.len().min(AROUND);
        for s in &samples[samples.len() - keep..] {
            self.recent(s.t_s);
        }
    }

    /// Hands each skip the times read after it.
    fn close(&mut self, skips: &mut [Skip]) {
        for (&at, after) in self.open.iter().zip(&mut self.collecting) {
            if let Some(skip) = skips.get_mut(at) {
                skip.times.after = std::mem::take(after);
            }
        }
    }
}

/// Joins stretches that touch or overlap (a damaged chunk and the bad headers after it, or the
/// resync from inside it that found its true end) into one loss.
fn merge(skips: Vec<Skip>) -> Vec<Skip> {
    let mut out: Vec<Skip> = Vec::with_capacity(skips.len());
    for s in skips {
        match out.last_mut() {
            Some(last)
                if (last.skipped.start_byte..=last.skipped.end_byte)
                    .contains(&s.skipped.start_byte)
                    && last.at_sample == s.at_sample =>
            {
                last.skipped.end_byte = last.skipped.end_byte.max(s.skipped.end_byte);
                last.skipped.detail = format!("{}; {}", last.skipped.detail, s.skipped.detail);
                last.indexed = None;
                last.sequence_gap = last.sequence_gap.or(s.sequence_gap);
            }
            _ => out.push(s),
        }
    }
    out
}

/// The losses of a salvaged run, with their run times and sample counts.
fn losses(skips: Vec<Skip>) -> Vec<Loss> {
    skips
        .into_iter()
        .map(|s| {
            let after_t_s = s.times.before.last().copied();
            let before_t_s = s.times.after.first().copied();
            let samples_lost = match (s.sequence_gap, s.indexed, after_t_s, before_t_s) {
                (Some(gap), ..) => LostSamples::Exact(gap),
                (_, Some(ix), _, _) if ix.seen && !ix.batches => LostSamples::Exact(ix.samples),
                (_, _, Some(a), Some(b)) => match typical_period_s(&s.times) {
                    Some(period) => {
                        LostSamples::About((((b - a) / period).round() - 1.0).max(0.0) as u64)
                    }
                    None => LostSamples::Unknown,
                },
                _ => LostSamples::Unknown,
            };
            Loss {
                start_byte: s.skipped.start_byte,
                end_byte: s.skipped.end_byte,
                detail: s.skipped.detail,
                samples: samples_lost,
                after_t_s,
                before_t_s,
            }
        })
        .collect()
}

/// The median sample period around a loss (up to 32 intervals on each side of it, the gap
/// itself left out).
fn typical_period_s(times: &SkipTimes) -> Option<f64> {
    let mut dts: Vec<f64> = times
        .before
        .windows(2)
        .chain(times.after.windows(2))
        .map(|w| w[1] - w[0])
        .filter(|dt| *dt > 0.0)
        .collect();
    if dts.is_empty() {
        return None;
    }
    dts.sort_by(f64::total_cmp);
    Some(dts[dts.len() / 2])
}

/// What a channel carries, for this reader.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Topic {
    /// `rover_power.Sample` protobuf messages.
    Sample,
    /// `rover_power.SampleBatch` protobuf messages.
    SampleBatch,
    /// JSON samples (files written before the protobuf channels).
    JsonSample,
    /// Samples of a ROS 2 bag (`convert --to ros2-bag`): CDR `rover_power/msg/Sample`.
    BagSample,
    Command,
    Event,
    /// Wire frames wrapped in `rover_power.Frame` protobuf messages.
    Frame,
    /// Bare wire frames (files written before the protobuf wrapping).
    BareFrame,
    /// Ours but derived (model, status), or someone else's: skipped.
    Skipped,
}

/// The channels read so far, by id: what each carries and its topic. A table rather than a
/// hash map: it is looked up for every record, and ids are small.
#[derive(Debug, Default)]
struct Channels(Vec<Option<(Topic, String)>>);

impl Channels {
    fn get(&self, id: u16) -> Option<&(Topic, String)> {
        self.0.get(usize::from(id))?.as_ref()
    }

    fn insert(&mut self, id: u16, channel: (Topic, String)) {
        let at = usize::from(id);
        if self.0.len() <= at {
            self.0.resize(at + 1, None);
        }
        self.0[at] = Some(channel);
    }
}

struct State<'s> {
    path: PathBuf,
    channels: Channels,
    /// Schema names by id, to tell our bag's sample type from another type on its topic.
    schema_names: HashMap<u16, String>,
    /// Whether any rover-power channel was seen.
    ours: bool,
    foreign_topics: BTreeSet<String>,
    /// Channel ids of messages that no channel record defines (it was lost to damage).
    orphan_channels: BTreeSet<u16>,
    /// Channels of the summary section, for messages whose channel record was lost.
    fallback: HashMap<u16, ::mcap::records::Channel>,
    /// Where the records go.
    sink: &'s mut dyn RunLogSink,
    /// Samples handed on so far.
    samples: usize,
    /// The last sample's time.
    last_t_s: Option<f64>,
    /// Sample times around skipped stretches.
    times: RecentTimes,
    /// The stretches skipped so far, in file order.
    skipped: Vec<Skip>,
    /// The sequence the next sample batch has when none was lost (0 before the first).
    next_batch_sequence: u32,
    /// The sample batches of the chunk being read, decoded on the walk's thread.
    prepared: Box<Prepared>,
    /// The prepared batch of the message record being read.
    prepared_batch: Option<Result<Span, String>>,
    /// For a batch decoded here: its columns and samples, kept to be reused.
    columns: Columns,
    own_batch: Decoded,
}

impl<'s> State<'s> {
    fn new(path: &Path, sink: &'s mut dyn RunLogSink) -> Self {
        State {
            path: path.to_owned(),
            channels: Channels::default(),
            schema_names: HashMap::new(),
            ours: false,
            foreign_topics: BTreeSet::new(),
            orphan_channels: BTreeSet::new(),
            fallback: HashMap::new(),
            sink,
            samples: 0,
            last_t_s: None,
            times: RecentTimes::default(),
            skipped: Vec::new(),
            next_batch_sequence: 0,
            prepared: Box::default(),
            prepared_batch: None,
            columns: Columns::default(),
            own_batch: Decoded::default(),
        }
    }

    /// Skips `stretch` as damaged: what was read before it stays, reading goes on after it.
    fn skip(&mut self, stretch: Skipped) {
        let times = self.times.open(self.skipped.len());
        self.skipped.push(Skip {
            skipped: stretch,
            at_sample: self.samples,
            indexed: None,
            sequence_gap: None,
            times,
        });
    }

    /// [`State::inner_record`] for the record of `opcode` whose bytes in the file are
    /// `start..end` (its chunk's, for a record inside one); a record that does not parse or a
    /// message that does not hold what its channel promises is damage: skipped as a loss, and
    /// reading goes on (one flipped byte costs one record, not the file).
    fn record_or_skip(
        &mut self,
        opcode: u8,
        data: &[u8],
        start: u64,
        end: u64,
    ) -> Result<(), McapError> {
        match self.inner_record(opcode, data, start) {
            Err(McapError::Corrupt { detail, .. }) => {
                self.skip(Skipped {
                    start_byte: start,
                    end_byte: end,
                    detail,
                });
                Ok(())
            }
            Err(McapError::BadMessage {
                topic,
                run_time_ns,
                detail,
                ..
            }) => {
                self.skip(Skipped {
                    start_byte: start,
                    end_byte: end,
                    detail: format!("{topic} message at run time {run_time_ns} ns: {detail}"),
                });
                Ok(())
            }
            other => other,
        }
    }

    /// An error of the sink, as the reader reports it.
    fn sink_err(&self, source: io::Error) -> McapError {
        McapError::Io {
            path: self.path.clone(),
            source,
        }
    }

    fn corrupt(&self, offset: u64, detail: String) -> McapError {
        McapError::Corrupt {
            path: self.path.clone(),
            offset,
            detail,
        }
    }

    /// The records of a decoded chunk at bytes `offset..end` of the file, with its sample
    /// batches `prepared` on the walk's thread. A record that does not fit ends the chunk (the
    /// rest is skipped as damage); one that does not parse is skipped alone
    /// ([`State::record_or_skip`]).
    fn chunk_records(
        &mut self,
        records: &[u8],
        prepared: Box<Prepared>,
        offset: u64,
        end: u64,
    ) -> Result<(), McapError> {
        self.prepared = prepared;
        let mut at = 0;
        while at < records.len() {
            let Some(body) = record_body(&records[at..]) else {
                self.skip(Skipped {
                    start_byte: offset,
                    end_byte: end,
                    detail: format!("the chunk's record at its byte {at} does not fit in it"),
                });
                return Ok(());
            };
            let opcode = records[at];
            if opcode == op::MESSAGE {
                self.prepared_batch = self.prepared.take(at);
            }
            let read = self.record_or_skip(opcode, body, offset, end);
            self.prepared_batch = None;
            read?;
            at += 9 + body.len();
        }
        Ok(())
    }

    /// The chunk's prepared batches, handed back for the walk to reuse.
    fn take_prepared(&mut self) -> Box<Prepared> {
        std::mem::take(&mut self.prepared)
    }

    /// Adds what a message index record after a damaged chunk says it held on the sample
    /// channel.
    fn count_index(&mut self, body: &[u8], skip: usize) {
        let Ok(Record::MessageIndex(index)) = parse_record(op::MESSAGE_INDEX, body) else {
            return;
        };
        let topic = self.channels.get(index.channel_id).map(|(topic, _)| *topic);
        let is_sample = matches!(
            topic,
            Some(Topic::Sample | Topic::JsonSample | Topic::BagSample)
        );
        let Some(indexed) = self.skipped.get_mut(skip).and_then(|s| s.indexed.as_mut()) else {
            return;
        };
        indexed.seen = true;
        indexed.batches |= topic == Some(Topic::SampleBatch);
        if !is_sample {
            return;
        }
        indexed.samples += index.records.len() as u64;
    }

    /// A record that is not a chunk (in a chunk or at the top level). Records this reader has
    /// no use for (indexes, statistics, attachments, unknown opcodes) are skipped unparsed.
    fn inner_record(&mut self, opcode: u8, data: &[u8], offset: u64) -> Result<(), McapError> {
        if opcode == op::SCHEMA {
            // Only its id and name are needed; a schema too damaged to name is left out, and
            // its channel taken on its topic and encoding.
            if let Some((id, name)) = schema_name(data) {
                self.schema_names.insert(id, name.to_owned());
            }
            return Ok(());
        }
        if opcode == op::MESSAGE {
            let Some((channel_id, sequence, publish_time, payload)) = message_fields(data) else {
                // Shorter than its fixed fields: the parser's words for the damage.
                let detail = parse_record(opcode, data)
                    .err()
                    .unwrap_or_else(|| "message record shorter than its header".into());
                return Err(self.corrupt(offset, detail));
            };
            return self.message_record(channel_id, sequence, publish_time, payload, offset);
        }
        if opcode != op::CHANNEL {
            return Ok(());
        }
        match parse_record(opcode, data).map_err(|e| self.corrupt(offset, e))? {
            Record::Channel(channel) => self.channel(channel, offset),
            _ => Ok(()),
        }
    }

    /// A message record on `channel_id` at run time `publish_time` [ns] holding `data`.
    fn message_record(
        &mut self,
        channel_id: u16,
        sequence: u32,
        publish_time: u64,
        data: &[u8],
        offset: u64,
    ) -> Result<(), McapError> {
        let topic = match self.channels.get(channel_id) {
            Some(&(topic, _)) => topic,
            None => {
                // Its channel record was in a damaged chunk: the summary's copy stands in.
                if let Some(channel) = self.fallback.remove(&channel_id) {
                    self.channel(channel, offset)?;
                }
                let Some(&(topic, _)) = self.channels.get(channel_id) else {
                    self.orphan_channels.insert(channel_id);
                    return Err(self.corrupt(
                        offset,
                        format!("message on channel {channel_id}, which no channel record defines"),
                    ));
                };
                topic
            }
        };
        // Run time is `publish_time`: `log_time` is Unix time in files since the wall-clock
        // anchor, and the same as `publish_time` in older ones.
        self.message(topic, channel_id, sequence, publish_time, data)
    }

    fn channel(&mut self, channel: ::mcap::records::Channel, offset: u64) -> Result<(), McapError> {
        let (topic, expected, found) = match channel.topic.as_str() {
            TOPIC_SAMPLE if channel.message_encoding == "cdr" => {
                let schema = self.schema_names.get(&channel.schema_id);
                if let Some(name) = schema.filter(|name| *name != SAMPLE_TYPE) {
                    return Err(McapError::Foreign {
                        path: self.path.clone(),
                        detail: format!(
                            "byte {offset}: {TOPIC_SAMPLE} holds `{name}` messages; this tool \
                             reads `{SAMPLE_TYPE}` (convert --to ros2-bag)"
                        ),
                    });
                }
                (
                    Topic::BagSample,
                    "cdr".to_owned(),
                    &channel.message_encoding,
                )
            }
            TOPIC_SAMPLE if channel.message_encoding == proto::ENCODING => (
                Topic::Sample,
                proto::ENCODING.to_owned(),
                &channel.message_encoding,
            ),
            TOPIC_SAMPLE_BATCH => (
                Topic::SampleBatch,
                proto::ENCODING.to_owned(),
                &channel.message_encoding,
            ),
            TOPIC_SAMPLE => (
                Topic::JsonSample,
                "json".to_owned(),
                &channel.message_encoding,
            ),
            TOPIC_COMMAND => (Topic::Command, "json".to_owned(), &channel.message_encoding),
            TOPIC_EVENT => (Topic::Event, "json".to_owned(), &channel.message_encoding),
            // The frames' wire format is the channel's `wire_encoding` under protobuf, else the
            // message encoding itself.
            TOPIC_FRAME if channel.message_encoding == proto::ENCODING => {
                let wire = channel.metadata.get("wire_encoding");
                (
                    Topic::Frame,
                    frame_encoding(),
                    wire.unwrap_or(&channel.message_encoding),
                )
            }
            TOPIC_FRAME => (
                Topic::BareFrame,
                frame_encoding(),
                &channel.message_encoding,
            ),
            t if t.starts_with("/rover_power/") => (
                Topic::Skipped,
                channel.message_encoding.clone(),
                &channel.message_encoding,
            ),
            t => {
                self.foreign_topics.insert(t.to_owned());
                self.channels
                    .insert(channel.id, (Topic::Skipped, channel.topic.clone()));
                return Ok(());
            }
        };
        if *found != expected {
            let detail = if matches!(topic, Topic::Frame | Topic::BareFrame) {
                format!(
                    "{TOPIC_FRAME} holds {found:?} frames; this tool reads {expected:?} (protocol \
                     version {})",
                    wire::PROTOCOL_VERSION
                )
            } else {
                format!(
                    "{} has message encoding {found:?}, expected {expected:?}",
                    channel.topic
                )
            };
            return Err(McapError::Foreign {
                path: self.path.clone(),
                detail: format!("byte {offset}: {detail}"),
            });
        }
        self.ours = true;
        self.channels.insert(channel.id, (topic, channel.topic));
        Ok(())
    }

    fn message(
        &mut self,
        topic: Topic,
        channel_id: u16,
        sequence: u32,
        run_time_ns: u64,
        data: &[u8],
    ) -> Result<(), McapError> {
        // Built only on the error path (the topic's name is looked up then).
        let bad = |state: &Self, detail: String| McapError::BadMessage {
            path: state.path.clone(),
            topic: state
                .channels
                .get(channel_id)
                .map(|(_, name)| name.clone())
                .unwrap_or_default(),
            run_time_ns,
            detail,
        };
        match topic {
            Topic::Sample | Topic::JsonSample | Topic::BagSample => {
                let (sample, board) = match topic {
                    Topic::Sample => SampleMsg::from_protobuf(data).map_err(|e| bad(self, e))?,
                    Topic::BagSample => (
                        decode_sample(data).map_err(|e| bad(self, e.to_string()))?,
                        None,
                    ),
                    _ => (
                        match parse_sample_msg(data) {
                            Some(msg) => msg,
                            None => serde_json::from_slice::<SampleMsg>(data)
                                .map_err(|e| bad(self, e.to_string()))?,
                        }
                        .sample(),
                        None,
                    ),
                };
                // The board's registers: its range, not a foreign rig's. A bag may hold any
                // rig's run CSV (`convert run.csv bag --to ros2-bag`): any physical reading.
                let range = match topic {
                    Topic::BagSample => RigRange::Physical,
                    _ => RigRange::Board,
                };
                let frame =
                    check_sample(&sample, board, range, self.last_t_s).map_err(|e| bad(self, e))?;
                self.hand_on(std::slice::from_ref(&sample), frame.as_slice())?;
            }
            Topic::SampleBatch => {
                // Decoded on the walk's thread when it could, else here.
                let prepared = std::mem::take(&mut self.prepared);
                let mut own = std::mem::take(&mut self.own_batch);
                own.clear();
                let samples = match self.prepared_batch.take() {
                    Some(result) => result.map(|span| prepared.get(span)),
                    None => self
                        .columns
                        .decode(data, &mut own)
                        .map(|span| own.get(span)),
                };
                let result = self.sample_batch(sequence, samples, &bad);
                self.prepared = prepared;
                self.own_batch = own;
                result?;
            }
            Topic::Command => {
                let msg: CommandMsg =
                    serde_json::from_slice(data).map_err(|e| bad(self, e.to_string()))?;
                self.sink
                    .command(&msg.row())
                    .map_err(|e| self.sink_err(e))?;
            }
            Topic::Event => {
                let msg: EventMsg =
                    serde_json::from_slice(data).map_err(|e| bad(self, e.to_string()))?;
                self.sink
                    .event(msg.t_s, &msg.event)
                    .map_err(|e| self.sink_err(e))?;
            }
            Topic::Frame | Topic::BareFrame => {
                let data = match topic {
                    Topic::Frame => frame_proto::decode(data).map_err(|e| bad(self, e))?,
                    _ => data,
                };
                let Some((&0, body)) = data.split_last() else {
                    return Err(bad(
                        self,
                        "frame does not end with its 0x00 delimiter".into(),
                    ));
                };
                if body.contains(&0) {
                    return Err(bad(self, "frame holds more than one frame".into()));
                }
                // Decoded in place in a copy, on the stack for any frame the board can send
                // (no allocation per frame); a longer one gets the decoder's own error.
                let mut stack = [0u8; MAX_FRAME];
                let mut heap = Vec::new();
                let copy: &mut [u8] = match stack.get_mut(..body.len()) {
                    Some(copy) => copy,
                    None => {
                        heap.extend_from_slice(body);
                        &mut heap
                    }
                };
                copy.copy_from_slice(body);
                let frame: BoardFrame = wire::decode_frame(copy)
                    .map_err(|e| bad(self, format!("frame does not decode: {e}")))?;
                // Division is correctly rounded: a time of whole nanoseconds comes back exactly.
                self.sink
                    .frame(run_time_ns as f64 / 1e9, &frame)
                    .map_err(|e| self.sink_err(e))?;
            }
            Topic::Skipped => {}
        }
        Ok(())
    }
}

/// `sample`'s board frame rebuilt from its part, once the sample is checked: within `range`
/// (a log's samples are the board's; a bag may hold any rig's run CSV) and after `last_t_s`.
/// The error says what is wrong with the message.
pub(super) fn check_sample(
    sample: &RunSample,
    board: Option<BoardSample>,
    range: RigRange,
    last_t_s: Option<f64>,
) -> Result<Option<Sample>, String> {
    // Before the range check: a frame that does not rebuild is the message's fault.
    let frame = match board {
        Some(board) => Some(board.frame(sample).ok_or_else(no_frame)?),
        None => None,
    };
    check_reading(sample, range, last_t_s)?;
    Ok(frame)
}

/// Why a sample's board part is refused.
pub(super) fn no_frame() -> String {
    "its board part does not rebuild a sample frame (bus voltage off the register's steps or \
     range)"
        .into()
}

/// Whether `sample` is within `range` and after `last_t_s`; the error says what is wrong.
pub(super) fn check_reading(
    sample: &RunSample,
    range: RigRange,
    last_t_s: Option<f64>,
) -> Result<(), String> {
    if let Some((column, value)) = sample.out_of_range(range) {
        let (bus_v_max, current_a_max) = range.limits();
        let which = match range {
            RigRange::Board => "the board's measuring",
            _ => "physical",
        };
        return Err(format!(
            "{column} = {value} is outside {which} range (bus 0 to {bus_v_max} V, current \
             ±{current_a_max} A, all finite)"
        ));
    }
    match last_t_s {
        Some(previous) if sample.t_s <= previous => Err(format!(
            "sample time {} is not after the previous sample's {previous}",
            sample.t_s
        )),
        _ => Ok(()),
    }
}

impl State<'_> {
    /// Hands on a batch's samples (checked but for their order after the previous batch), or
    /// the error that says why its message does not hold them.
    fn sample_batch(
        &mut self,
        sequence: u32,
        batch: Result<(&[RunSample], &[Sample]), String>,
        bad: &dyn Fn(&Self, String) -> McapError,
    ) -> Result<(), McapError> {
        let (samples, frames) = batch.map_err(|e| bad(self, e))?;
        if let Some(first) = samples.first() {
            check_reading(first, RigRange::Board, self.last_t_s).map_err(|e| bad(self, e))?;
        }
        // Samples lost since the previous batch (the sequence counts samples written).
        let read = self.samples;
        if let Some(skip) = self.skipped.last_mut().filter(|s| s.at_sample == read) {
            skip.sequence_gap = Some(u64::from(sequence.wrapping_sub(self.next_batch_sequence)));
        }
        self.next_batch_sequence = sequence.wrapping_add(samples.len() as u32);
        self.hand_on(samples, frames)
    }

    /// Hands checked samples on, each after its board frame when `frames` holds one a sample.
    fn hand_on(&mut self, samples: &[RunSample], frames: &[Sample]) -> Result<(), McapError> {
        self.last_t_s = samples.last().map_or(self.last_t_s, |s| Some(s.t_s));
        self.samples += samples.len();
        self.times.samples(samples);
        self.sink
            .samples(samples, frames)
            .map_err(|e| self.sink_err(e))
    }
}

/// A message record's channel id, sequence, publish time [ns] and data, read in place from its fixed
/// fields (channel id u16, sequence u32, log time u64, publish time u64, then the data; the
/// `mcap` crate's parser took a tenth of a read); `None` for a body shorter than them.
pub(super) fn message_fields(body: &[u8]) -> Option<(u16, u32, u64, &[u8])> {
    let (channel_id, rest) = body.split_first_chunk::<2>()?;
    let (sequence, rest) = rest.split_first_chunk::<4>()?;
    let (_log_time, rest) = rest.split_first_chunk::<8>()?;
    let (publish_time, data) = rest.split_first_chunk::<8>()?;
    Some((
        u16::from_le_bytes(*channel_id),
        u32::from_le_bytes(*sequence),
        u64::from_le_bytes(*publish_time),
        data,
    ))
}

/// The id and name of a schema record (id u16, then the name as a u32 length and its bytes),
/// read without the `mcap` crate's parser, which trusts the length.
fn schema_name(body: &[u8]) -> Option<(u16, &str)> {
    let (id, rest) = body.split_first_chunk::<2>()?;
    let (len, rest) = rest.split_first_chunk::<4>()?;
    let name = rest.get(..usize::try_from(u32::from_le_bytes(*len)).ok()?)?;
    Some((u16::from_le_bytes(*id), std::str::from_utf8(name).ok()?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The message header read in place gives what the `mcap` crate's parser gives, for any
        /// bytes: the same fields, or nothing where it refuses the record.
        #[test]
        fn message_fields_read_as_the_mcap_parser(body in proptest::collection::vec(any::<u8>(), 0..40)) {
            let ours = message_fields(&body);
            match ::mcap::parse_record(op::MESSAGE, &body) {
                Ok(Record::Message { header, data }) => {
                    prop_assert_eq!(
                        ours,
                        Some((header.channel_id, header.sequence, header.publish_time, &data[..]))
                    );
                }
                _ => prop_assert_eq!(ours, None),
            }
        }
    }
}
