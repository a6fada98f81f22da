//! [`read_mcap_run`]: an MCAP run log back into a [`RunLog`], record by record in file order
//! (the summary section is not needed, so a file cut short by a killed recorder reads up to its
//! last complete record).

use super::sample_json::parse_sample_msg;
use super::{
    frame_encoding, CommandMsg, EventMsg, McapError, SampleMsg, TOPIC_COMMAND, TOPIC_EVENT,
    TOPIC_FRAME, TOPIC_SAMPLE,
};
use crate::log::run_log::RunLog;
use ::mcap::records::{op, Record};
use ::mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use model_core::wire::{self, BoardFrame, MAX_FRAME};
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

/// Where a file was cut short.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Truncation {
    /// Bytes up to the end of the last complete record (everything read comes from these).
    pub complete_bytes: u64,
    /// The file's size.
    pub file_bytes: u64,
}

/// What [`read_mcap_run`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct McapRun {
    /// The run, up to the last complete record.
    pub run: RunLog,
    /// `Some` if the file ends before its footer (the recorder was killed, the disk filled up,
    /// the copy was cut): a torn last record, or no summary section. `None` for a finished file.
    pub truncated: Option<Truncation>,
}

/// Reads the MCAP run log at `path`. A file cut short is not an error (see
/// [`McapRun::truncated`]); a damaged or foreign file is, with the byte offset of the problem.
pub fn read_mcap_run(path: &Path) -> Result<McapRun, McapError> {
    let bytes = std::fs::read(path).map_err(|source| McapError::Io {
        path: path.to_owned(),
        source,
    })?;
    read_mcap_bytes(&bytes, path)
}

/// Reads an MCAP run log held in memory; `path` only names it in errors.
pub fn read_mcap_bytes(bytes: &[u8], path: &Path) -> Result<McapRun, McapError> {
    if !bytes.starts_with(::mcap::MAGIC) {
        return Err(McapError::NotMcap {
            path: path.to_owned(),
        });
    }
    let file_bytes = bytes.len() as u64;
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            // Chunks come whole; their records are read below, within the chunk's bounds.
            .with_emit_chunks(true)
            .with_validate_data_section_crc(true)
            .with_validate_summary_section_crc(true),
        // No record length limit: the reader asks for a record's bytes before it allocates
        // them, and is given at most the rest of the file; a record claiming more than that
        // ends the file as truncated (a torn last record and a damaged length look the same).
    );
    let mut state = State::new(path);
    let mut fed = 0usize;
    // Start of the next top-level record: the magic, then records of opcode + length + data.
    let mut offset = ::mcap::MAGIC.len() as u64;
    let mut truncated = None;
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(wanted)) => {
                let n = wanted.min(bytes.len() - fed);
                if n > 0 {
                    reader.insert(n).copy_from_slice(&bytes[fed..fed + n]);
                    fed += n;
                }
                reader.notify_read(n);
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                state.record(opcode, data, offset)?;
                offset += 9 + data.len() as u64;
            }
            Err(::mcap::McapError::UnexpectedEof) => {
                truncated = Some(Truncation {
                    complete_bytes: offset.min(file_bytes),
                    file_bytes,
                });
                break;
            }
            Err(e) => return Err(state.corrupt(offset, e.to_string())),
        }
    }
    if truncated.is_none() && !state.ours {
        let topics: Vec<&str> = state.foreign_topics.iter().map(String::as_str).collect();
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
    Ok(McapRun {
        run: state.run,
        truncated,
    })
}

/// What a channel carries, for this reader.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Topic {
    Sample,
    Command,
    Event,
    Frame,
    /// Ours but derived (model, status), or someone else's: skipped.
    Skipped,
}

struct State {
    path: PathBuf,
    channels: HashMap<u16, (Topic, String)>,
    /// Whether any rover-power channel was seen.
    ours: bool,
    foreign_topics: BTreeSet<String>,
    run: RunLog,
}

impl State {
    fn new(path: &Path) -> Self {
        State {
            path: path.to_owned(),
            channels: HashMap::new(),
            ours: false,
            foreign_topics: BTreeSet::new(),
            run: RunLog::default(),
        }
    }

    fn corrupt(&self, offset: u64, detail: String) -> McapError {
        McapError::Corrupt {
            path: self.path.clone(),
            offset,
            detail,
        }
    }

    /// One top-level record starting at byte `offset`.
    fn record(&mut self, opcode: u8, data: &[u8], offset: u64) -> Result<(), McapError> {
        if opcode != op::CHUNK {
            return self.inner_record(opcode, data, offset);
        }
        let (header, records) = match ::mcap::parse_record(opcode, data) {
            Ok(Record::Chunk { header, data }) => (header, data),
            Ok(_) => return Err(self.corrupt(offset, "chunk record did not parse".into())),
            Err(e) => return Err(self.corrupt(offset, format!("chunk: {e}"))),
        };
        if !header.compression.is_empty() {
            return Err(self.corrupt(
                offset,
                format!(
                    "chunk compressed with {:?}: this tool reads uncompressed MCAP (decompress \
                     it first, e.g. `mcap compress --compression none`)",
                    header.compression
                ),
            ));
        }
        if header.uncompressed_size != records.len() as u64 {
            return Err(self.corrupt(
                offset,
                format!(
                    "uncompressed chunk of {} bytes claims {} bytes uncompressed",
                    records.len(),
                    header.uncompressed_size
                ),
            ));
        }
        if header.uncompressed_crc != 0 {
            let crc = crc32fast::hash(&records);
            if crc != header.uncompressed_crc {
                return Err(self.corrupt(
                    offset,
                    format!(
                        "chunk CRC mismatch (stored {:#010x}, computed {crc:#010x})",
                        header.uncompressed_crc
                    ),
                ));
            }
        }
        let mut rest: &[u8] = &records;
        while !rest.is_empty() {
            let Some((&opcode, after)) = rest.split_first() else {
                break;
            };
            let Some((len, after)) = after.split_first_chunk::<8>() else {
                return Err(self.corrupt(offset, "chunk ends inside a record header".into()));
            };
            let len = u64::from_le_bytes(*len);
            let Some(body) = usize::try_from(len).ok().and_then(|n| after.get(..n)) else {
                return Err(self.corrupt(
                    offset,
                    format!("record of {len} bytes does not fit in its chunk"),
                ));
            };
            self.inner_record(opcode, body, offset)?;
            rest = &after[body.len()..];
        }
        Ok(())
    }

    /// A record that is not a chunk (in a chunk or at the top level). Records this reader has
    /// no use for (indexes, statistics, attachments, unknown opcodes) are skipped unparsed.
    fn inner_record(&mut self, opcode: u8, data: &[u8], offset: u64) -> Result<(), McapError> {
        if opcode != op::CHANNEL && opcode != op::MESSAGE {
            return Ok(());
        }
        let record = ::mcap::parse_record(opcode, data)
            .map_err(|e| self.corrupt(offset, format!("record {opcode:#04x}: {e}")))?;
        match record {
            Record::Channel(channel) => self.channel(channel, offset),
            Record::Message { header, data } => {
                let Some(&(topic, _)) = self.channels.get(&header.channel_id) else {
                    return Err(self.corrupt(
                        offset,
                        format!(
                            "message on channel {}, which no channel record defines",
                            header.channel_id
                        ),
                    ));
                };
                self.message(topic, header.channel_id, header.log_time, &data)
            }
            _ => Ok(()),
        }
    }

    fn channel(&mut self, channel: ::mcap::records::Channel, offset: u64) -> Result<(), McapError> {
        let (topic, expected) = match channel.topic.as_str() {
            TOPIC_SAMPLE => (Topic::Sample, "json".to_owned()),
            TOPIC_COMMAND => (Topic::Command, "json".to_owned()),
            TOPIC_EVENT => (Topic::Event, "json".to_owned()),
            TOPIC_FRAME => (Topic::Frame, frame_encoding()),
            t if t.starts_with("/rover_power/") => {
                (Topic::Skipped, channel.message_encoding.clone())
            }
            t => {
                self.foreign_topics.insert(t.to_owned());
                self.channels
                    .insert(channel.id, (Topic::Skipped, channel.topic.clone()));
                return Ok(());
            }
        };
        if channel.message_encoding != expected {
            let detail = if topic == Topic::Frame {
                format!(
                    "{TOPIC_FRAME} holds {:?} frames; this tool reads {expected:?} (protocol \
                     version {})",
                    channel.message_encoding,
                    wire::PROTOCOL_VERSION
                )
            } else {
                format!(
                    "{} has message encoding {:?}, expected {expected:?}",
                    channel.topic, channel.message_encoding
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
        log_time_ns: u64,
        data: &[u8],
    ) -> Result<(), McapError> {
        // Built only on the error path (the topic's name is looked up then).
        let bad = |state: &Self, detail: String| McapError::BadMessage {
            path: state.path.clone(),
            topic: state
                .channels
                .get(&channel_id)
                .map(|(_, name)| name.clone())
                .unwrap_or_default(),
            log_time_ns,
            detail,
        };
        match topic {
            Topic::Sample => {
                let msg = match parse_sample_msg(data) {
                    Some(msg) => msg,
                    None => serde_json::from_slice::<SampleMsg>(data)
                        .map_err(|e| bad(self, e.to_string()))?,
                };
                let sample = msg.sample();
                if let Some(previous) = self.run.samples.last() {
                    if sample.t_s <= previous.t_s {
                        return Err(bad(
                            self,
                            format!(
                                "sample time {} is not after the previous sample's {}",
                                sample.t_s, previous.t_s
                            ),
                        ));
                    }
                }
                self.run.samples.push(sample);
            }
            Topic::Command => {
                let msg: CommandMsg =
                    serde_json::from_slice(data).map_err(|e| bad(self, e.to_string()))?;
                self.run.commands.push(msg.row());
            }
            Topic::Event => {
                let msg: EventMsg =
                    serde_json::from_slice(data).map_err(|e| bad(self, e.to_string()))?;
                self.run.events.push((msg.t_s, msg.event));
            }
            Topic::Frame => {
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
                self.run.frames.push((log_time_ns as f64 / 1e9, frame));
            }
            Topic::Skipped => {}
        }
        Ok(())
    }
}
