//! The walk of an MCAP file read ahead on a second core: reading the file, decompressing and
//! checking its chunks (and decoding their sample batches while the reader is the slower) on
//! one thread while the reader's state turns the previous chunk's records into the run on the
//! caller's. The steps come in file order, as [`Walker`] gives them; memory holds at most
//! [`AHEAD`] chunks beyond the one being read.

use super::prepare::Prepared;
use super::walk::{ChunkDecoder, ChunkProblem, Skipped, Step, Walker};
use ::mcap::records::op;
use std::io::{self, Read, Seek};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender};

/// A step of the walk, owned, as the reader's state takes it.
#[derive(Debug)]
pub(super) enum Walked {
    /// A chunk's records, decompressed and checked, with its sample batches decoded;
    /// `offset..end`: the chunk record's bytes.
    Chunk {
        records: Vec<u8>,
        prepared: Box<Prepared>,
        offset: u64,
        end: u64,
    },
    /// A chunk that could not be trusted, skipped whole.
    ChunkFailed(Skipped),
    /// A message index record after a failed chunk: it counts what the chunk held.
    IndexOfFailed(Vec<u8>),
    /// Any other record before the data end (the summary section's are not needed: its
    /// channels were read before the walk).
    Record {
        opcode: u8,
        offset: u64,
        body: Vec<u8>,
    },
    /// A damaged stretch skipped.
    Skipped(Skipped),
    /// The file ends without a footer: from `complete_bytes` on nothing could be read.
    Truncated { complete_bytes: u64 },
}

/// Chunks decoded ahead of the reader, at most.
const AHEAD: usize = 4;

/// The walk's steps as they are read ahead, with the way back for a chunk's buffers.
pub(super) struct Ahead<'q> {
    steps: Receiver<io::Result<Walked>>,
    spare: Sender<(Vec<u8>, Box<Prepared>)>,
    /// Steps sent and not yet taken.
    queued: &'q AtomicUsize,
}

impl Ahead<'_> {
    /// The next step; `None` after the last (the footer, a cut end, or a read error given
    /// before).
    pub(super) fn next(&mut self) -> Option<io::Result<Walked>> {
        let step = self.steps.recv().ok();
        self.queued
            .fetch_sub(usize::from(step.is_some()), Ordering::Relaxed);
        step
    }

    /// Hands a chunk's buffers back to the walk, for a chunk to come.
    pub(super) fn recycle(&self, records: Vec<u8>, prepared: Box<Prepared>) {
        // The walk may have ended: the buffers are then simply dropped.
        let _ = self.spare.send((records, prepared));
    }
}

/// Runs `read` on the steps of `walker`, which walks on another thread meanwhile. When `read`
/// returns (done, or stopped by an error of its own) the walk stops too. An error if the
/// thread cannot be started (`read` is not run).
pub(super) fn walk_ahead<R: Read + Seek + Send, T>(
    walker: Walker<R>,
    read: impl FnOnce(&mut Ahead) -> T,
) -> io::Result<T> {
    let queued = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        let (steps_tx, steps) = mpsc::sync_channel(AHEAD);
        let (spare, spare_rx) = mpsc::channel();
        let queue = &queued;
        std::thread::Builder::new()
            .name("mcap-walk".into())
            .spawn_scoped(scope, move || walk(walker, &steps_tx, &spare_rx, queue))?;
        let mut ahead = Ahead {
            steps,
            spare,
            queued: &queued,
        };
        Ok(read(&mut ahead))
        // `ahead` is dropped here: the walk's next send fails and it ends; the scope joins it.
    })
}

/// The walk: each step of `walker`, owned, into `steps`, until the end, a read error (sent
/// too) or a reader that hung up.
fn walk<R: Read + Seek>(
    mut walker: Walker<R>,
    steps: &SyncSender<io::Result<Walked>>,
    spare: &Receiver<(Vec<u8>, Box<Prepared>)>,
    queued: &AtomicUsize,
) {
    let mut decoder = ChunkDecoder::default();
    // The sample batch channels seen so far.
    let mut batch_channels = Vec::new();
    // A chunk just failed: the message indexes that follow count what it held.
    let mut after_failed = false;
    // After the data end record: the summary section.
    let mut in_summary = false;
    loop {
        let step = match walker.next() {
            Ok(Some(step)) => step,
            Ok(None) => return,
            Err(e) => {
                queued.fetch_add(1, Ordering::Relaxed);
                let _ = steps.send(Err(e));
                return;
            }
        };
        let walked = match step {
            Step::Record { .. } if in_summary => continue,
            Step::Record {
                opcode: op::DATA_END,
                ..
            } => {
                in_summary = true;
                continue;
            }
            Step::Record {
                opcode: op::CHUNK,
                offset,
                body,
            } => {
                let end = offset + 9 + body.len() as u64;
                match decoder.decode(body) {
                    Ok(_) => {
                        after_failed = false;
                        let (records, mut prepared) = spare.try_recv().unwrap_or_default();
                        let records = decoder.take_records(records);
                        // A reader with steps still to take is the slower one: it gets this
                        // chunk's batches decoded. One waiting for this chunk decodes them
                        // itself, meanwhile the walk reads on.
                        let reader_busy = queued.load(Ordering::Relaxed) > 0;
                        prepared.chunk(&records, &mut batch_channels, reader_busy);
                        Walked::Chunk {
                            records,
                            prepared,
                            offset,
                            end,
                        }
                    }
                    Err(problem) => {
                        let detail = match problem {
                            ChunkProblem::Damaged(detail) => detail,
                            // Not in the MCAP spec (zstd, lz4): most likely a damaged name.
                            ChunkProblem::Unsupported(c) => format!(
                                "chunk compressed with {c:?}; this tool reads uncompressed, \
                                 zstd and lz4 chunks"
                            ),
                        };
                        after_failed = true;
                        walker.chunk_failed(offset);
                        Walked::ChunkFailed(Skipped {
                            start_byte: offset,
                            end_byte: end,
                            detail,
                        })
                    }
                }
            }
            Step::Record {
                opcode: op::MESSAGE_INDEX,
                body,
                ..
            } => match after_failed {
                true => Walked::IndexOfFailed(body.to_vec()),
                false => continue,
            },
            Step::Record {
                opcode,
                offset,
                body,
            } => Walked::Record {
                opcode,
                offset,
                body: body.to_vec(),
            },
            Step::Skipped(s) => {
                after_failed = false;
                Walked::Skipped(s)
            }
            Step::Footer => continue,
            Step::Truncated { complete_bytes } => Walked::Truncated { complete_bytes },
        };
        queued.fetch_add(1, Ordering::Relaxed);
        if steps.send(Ok(walked)).is_err() {
            return; // the reader stopped
        }
    }
}
