//! A capture decoded as it is read, in bounded chunks: `decode` keeps the summary's counters,
//! never the bytes, so a capture of any length — a long recording, `/dev/zero`, a FIFO a logger
//! keeps writing — decodes in constant memory, with a running summary while it lasts.
//!
//! The reads happen on a thread of their own, a few chunks ahead of the decoder: a stop request
//! (Ctrl-C) is seen within [`WAIT`] even while a FIFO's read waits for its writer.

use super::{foreign_format, Event, StreamDecoder, Summary};
use model_core::wire::{BoardFrame, Status};
use std::io::{self, Read};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

/// Bytes asked for by one read.
pub const CHUNK: usize = 64 * 1024;

/// Chunks queued between the reading thread and the decoder.
const QUEUED: usize = 1;

/// Bytes of the input held at once, at most: the chunks queued, the one being read (or waiting
/// for room in the queue) and the one being decoded.
pub const MAX_BUFFERED: usize = (QUEUED + 2) * CHUNK;

/// Longest wait for the next chunk before the stop request and the running summary are looked at.
pub const WAIT: Duration = Duration::from_millis(100);

/// The bytes [`foreign_format`] looks at: the start of the input.
const HEAD: usize = 4096;

/// The summary of a capture so far, fed chunk by chunk.
#[derive(Debug, Default)]
pub struct CaptureSummary {
    decoder: StreamDecoder,
    bytes: u64,
    span_us: Option<(u64, u64)>,
    last_status: Option<Status>,
}

impl CaptureSummary {
    /// Nothing read yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Decodes the next bytes of the capture.
    pub fn feed(&mut self, bytes: &[u8]) {
        self.bytes = self.bytes.saturating_add(bytes.len() as u64);
        let (span_us, last_status) = (&mut self.span_us, &mut self.last_status);
        self.decoder.feed(bytes, |event| match event {
            Event::Frame(BoardFrame::Sample(s)) => {
                *span_us = Some((span_us.map_or(s.t_us, |(first, _)| first), s.t_us));
            }
            Event::Frame(BoardFrame::Status(s)) => *last_status = Some(s),
            _ => {}
        });
    }

    /// The summary of everything fed so far.
    pub fn summary(&self) -> Summary {
        let dec = &self.decoder;
        let host = dec.measurements().snapshot().energy_lsb_us;
        Summary {
            bytes: self.bytes,
            hello: dec.hello().copied(),
            stats: dec.stats(),
            span_us: self.span_us,
            scale: dec.scale(),
            host_energy_lsb_us: [host.left, host.right],
            board_vs_host: dec.board_vs_host_energy(),
            last_status: self.last_status,
        }
    }
}

impl Summary {
    /// The summary so far in one line (an endless capture's running report).
    pub fn running_line(&self) -> String {
        let s = &self.stats;
        let duration_s = self
            .span_us
            .map_or(0.0, |(first, last)| last.wrapping_sub(first) as f64 * 1e-6);
        format!(
            "{} bytes: frames {}, samples {} over {duration_s:.1} s, bad frames {} ({} CRC), lost samples {} in {} gaps",
            self.bytes, s.frames, s.samples, s.bad_frames, s.crc_errors, s.lost_samples, s.gaps
        )
    }
}

/// How a read capture ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CaptureEnd {
    /// The input's end.
    Eof,
    /// The stop flag was raised first (Ctrl-C): the summary is of the bytes read until then.
    Stopped,
}

/// Why a capture could not be read.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// The input is a run log or a text file, not a raw capture ([`foreign_format`]'s hint).
    #[error("{0}")]
    Foreign(&'static str),
    /// Reading the input failed.
    #[error(transparent)]
    Io(#[from] io::Error),
}

/// One message of the reading thread: a chunk, the end (an empty chunk) or a read error.
type Chunk = io::Result<Vec<u8>>;

/// Reads `input` to its end, or until `stop` is raised, in chunks of at most [`CHUNK`] bytes
/// and never more than [`MAX_BUFFERED`] of them held, and returns its summary. `on_progress`
/// gets the summary so far every `report_every` (an endless input's running summary). An
/// input that starts like a run log or a text file is refused ([`CaptureError::Foreign`]).
pub fn read_capture(
    input: impl Read + Send + 'static,
    stop: &AtomicBool,
    report_every: Duration,
    on_progress: &mut dyn FnMut(&Summary),
) -> Result<(Summary, CaptureEnd), CaptureError> {
    let chunks = spawn_reader(input)?;
    let mut capture = CaptureSummary::new();
    let mut head = Vec::with_capacity(HEAD);
    let mut head_checked = false;
    let mut reported_at = Instant::now();
    let end = loop {
        if stop.load(Ordering::Relaxed) {
            break CaptureEnd::Stopped;
        }
        match chunks.recv_timeout(WAIT) {
            Ok(Ok(chunk)) if chunk.is_empty() => break CaptureEnd::Eof,
            Ok(Ok(chunk)) => {
                if !head_checked {
                    let take = chunk.len().min(HEAD - head.len());
                    head.extend_from_slice(&chunk[..take]);
                    if head.len() == HEAD {
                        refuse_foreign(&head)?;
                        head_checked = true;
                    }
                }
                capture.feed(&chunk);
            }
            Ok(Err(e)) => return Err(e.into()),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => {
                return Err(io::Error::other("the reading thread ended without a word").into())
            }
        }
        if reported_at.elapsed() >= report_every {
            on_progress(&capture.summary());
            reported_at = Instant::now();
        }
    };
    if !head_checked {
        refuse_foreign(&head)?;
    }
    Ok((capture.summary(), end))
}

fn refuse_foreign(head: &[u8]) -> Result<(), CaptureError> {
    foreign_format(head).map_or(Ok(()), |hint| Err(CaptureError::Foreign(hint)))
}

/// Reads `input` on a thread of its own into a queue of [`QUEUED`] chunks. The thread
/// ends at the input's end, at a read error, or when the queue's reader is gone; a read that
/// never returns (a FIFO without a writer) keeps it until the process exits.
fn spawn_reader(mut input: impl Read + Send + 'static) -> io::Result<Receiver<Chunk>> {
    let (tx, rx) = mpsc::sync_channel::<Chunk>(QUEUED);
    std::thread::Builder::new()
        .name("capture-reader".into())
        .spawn(move || loop {
            let mut chunk = vec![0u8; CHUNK];
            let message = match input.read(&mut chunk) {
                Ok(n) => {
                    chunk.truncate(n.min(CHUNK));
                    Ok(chunk)
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => Err(e),
            };
            let last = message.as_ref().map_or(true, Vec::is_empty);
            if tx.send(message).is_err() || last {
                return;
            }
        })?;
    Ok(rx)
}
