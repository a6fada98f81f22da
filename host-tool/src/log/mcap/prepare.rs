//! A chunk's sample batches decoded and checked on the walk's thread ([`super::ahead`]), so
//! that the reader's thread, which hands every batch to its sink, does not decode them too:
//! decoding was a third of its time, the walk's thread had room. A batch's samples and its
//! frames lie in two vectors ([`Decoded`]), so a sink takes the samples as one slice
//! ([`crate::log::run_log::RunLogSink::samples`]).
//!
//! Only an optimisation: the reader takes a prepared batch only for the very record it was
//! made from, on a channel it reads as sample batches itself; any other batch (a channel
//! record the walk did not see, a message outside a chunk) it decodes itself with the same
//! function ([`Columns::decode`]), so the result is the same either way.

use super::read::message_fields;
use super::sample_batch::Columns;
use super::{proto, TOPIC_SAMPLE_BATCH};
use crate::log::run_csv::RunSample;
use ::mcap::records::{op, Record};
use model_core::wire::Sample;
use std::ops::Range;

/// Samples decoded from sample batches and checked, one batch after the other, with the board
/// frames rebuilt for the batches that carry them.
#[derive(Debug, Default)]
pub(super) struct Decoded {
    pub(super) samples: Vec<RunSample>,
    pub(super) frames: Vec<Sample>,
}

/// Where one batch lies in a [`Decoded`]: its samples, and its frames (one a sample, or none).
#[derive(Debug, Clone, Default)]
pub(super) struct Span {
    samples: Range<usize>,
    frames: Range<usize>,
}

impl Decoded {
    pub(super) fn clear(&mut self) {
        self.samples.clear();
        self.frames.clear();
    }

    /// An empty span at the end, to be [`Decoded::grown`] or [`Decoded::cut`] back to.
    pub(super) fn end(&self) -> Span {
        let (samples, frames) = (self.samples.len(), self.frames.len());
        Span {
            samples: samples..samples,
            frames: frames..frames,
        }
    }

    /// `start` ([`Decoded::end`] then) with what was added since.
    pub(super) fn grown(&self, start: Span) -> Span {
        Span {
            samples: start.samples.start..self.samples.len(),
            frames: start.frames.start..self.frames.len(),
        }
    }

    /// Drops what was added since `start` ([`Decoded::end`] then).
    pub(super) fn cut(&mut self, start: Span) {
        self.samples.truncate(start.samples.start);
        self.frames.truncate(start.frames.start);
    }

    /// The samples and frames of `span`.
    pub(super) fn get(&self, span: Span) -> (&[RunSample], &[Sample]) {
        (&self.samples[span.samples], &self.frames[span.frames])
    }
}

/// The sample batches of one chunk, decoded and checked.
#[derive(Debug, Default)]
pub(super) struct Prepared {
    /// Every batch's samples and frames.
    decoded: Decoded,
    /// Each batch message: where its record starts in the chunk's records, and its part of
    /// `decoded` (or why the message does not hold what it should).
    batches: Vec<(usize, Result<Span, String>)>,
    /// The first of `batches` not taken yet.
    next: usize,
    columns: Columns,
}

impl Prepared {
    /// Decodes the sample batches in `records` (a chunk's records) if `decode`, else leaves
    /// them to the reader; either way learns the batch channels from the channel records among
    /// them.
    pub(super) fn chunk(&mut self, records: &[u8], channels: &mut Vec<u16>, decode: bool) {
        self.decoded.clear();
        self.batches.clear();
        self.next = 0;
        let mut at = 0;
        while let Some(body) = record_body(&records[at..]) {
            let opcode = records[at];
            if opcode == op::MESSAGE && decode {
                if let Some((channel, _, _, data)) = message_fields(body) {
                    if channels.contains(&channel) {
                        let result = self.columns.decode(data, &mut self.decoded);
                        self.batches.push((at, result));
                    }
                }
            } else if opcode == op::CHANNEL {
                if let Ok(Record::Channel(c)) = super::parse_record(opcode, body) {
                    if c.topic == TOPIC_SAMPLE_BATCH && c.message_encoding == proto::ENCODING {
                        channels.push(c.id);
                    }
                }
            }
            at += 9 + body.len();
        }
    }

    /// The batch prepared from the message record at `at` in the chunk's records, if any
    /// (records are asked for in order).
    pub(super) fn take(&mut self, at: usize) -> Option<Result<Span, String>> {
        while self.batches.get(self.next).is_some_and(|b| b.0 < at) {
            self.next += 1;
        }
        let (start, _) = self.batches.get(self.next)?;
        if *start != at {
            return None;
        }
        self.next += 1;
        Some(std::mem::replace(
            &mut self.batches[self.next - 1].1,
            Ok(Span::default()),
        ))
    }

    /// The samples and frames of a batch [`Prepared::take`] gave.
    pub(super) fn get(&self, span: Span) -> (&[RunSample], &[Sample]) {
        self.decoded.get(span)
    }
}

/// The body of the record that starts `records` (opcode, u64 length, body), if it fits.
pub(super) fn record_body(records: &[u8]) -> Option<&[u8]> {
    let (_opcode, after) = records.split_first()?;
    let (len, after) = after.split_first_chunk::<8>()?;
    after.get(..usize::try_from(u64::from_le_bytes(*len)).ok()?)
}
