//! Walking an MCAP file's top-level records in order from any `Read + Seek`, with bounded memory
//! (one record at a time), and salvaging damaged files: a chunk whose CRC or compression does
//! not check out is skipped, and bytes that hold no record header are skipped up to the next
//! place where a plausible record header stands and is followed by another one (resync; from
//! inside a chunk that failed, as inserted or deleted bytes move its end). Each skipped
//! stretch is reported as a [`Skipped`] for the reader to turn into a loss report.

use super::lz4_frame;
use ::mcap::records::op;
use std::io::{self, BufReader, Read, Seek, SeekFrom};

/// Bytes of a record header: opcode (1) + length (8).
const HEADER_BYTES: u64 = 9;

/// A chunk claiming more than this uncompressed is treated as damaged (the writer's chunks are
/// 256 KiB; Foxglove's a few MiB), so a damaged size cannot make the reader allocate the disk.
const MAX_CHUNK_BYTES: u64 = 1 << 30;

/// Opcodes a resync may land on: the records that stand at the top level of a chunked file.
/// Schema, channel and message records are left out on purpose: inside an uncompressed chunk
/// they look exactly like top-level records, and a resync must not read a damaged chunk's
/// unverified insides.
fn resync_opcode(opcode: u8) -> bool {
    matches!(
        opcode,
        op::HEADER
            | op::FOOTER
            | op::CHUNK
            | op::MESSAGE_INDEX
            | op::CHUNK_INDEX
            | op::ATTACHMENT
            | op::ATTACHMENT_INDEX
            | op::STATISTICS
            | op::METADATA
            | op::METADATA_INDEX
            | op::SUMMARY_OFFSET
            | op::DATA_END
    )
}

/// Body of the spec's data end record: the data section's CRC-32 [bytes].
const DATA_END_BODY_BYTES: u64 = 4;

/// Opcodes a well-formed file may hold at the top level: the spec's (0x01–0x0F) and the
/// private range (0x80–0xFF, skipped unread).
fn valid_opcode(opcode: u8) -> bool {
    (0x01..=0x0F).contains(&opcode) || opcode >= 0x80
}

/// Bytes of a chunk body up to its records' length: start and end time, uncompressed size,
/// CRC, the compression string (at most `zstd`'s 4 bytes) and the records' length.
const CHUNK_PREFIX_BYTES: u64 = 8 + 8 + 8 + 4 + 4 + 4 + 8;

/// Whether a record body of `body_len` bytes starting with `prefix` has a chunk's exact layout:
/// a known compression name and a records length that ends exactly at the body's end. No other
/// record of a well-formed file matches by chance, so a chunk whose opcode byte was flipped into
/// another valid opcode is still read as a chunk (and then checked by its CRC like any other).
fn looks_like_chunk(prefix: &[u8], body_len: u64) -> bool {
    let u32_at = |i: usize| -> Option<u64> {
        Some(u64::from(u32::from_le_bytes(
            prefix.get(i..i + 4)?.try_into().ok()?,
        )))
    };
    let u64_at = |i: usize| -> Option<u64> {
        Some(u64::from_le_bytes(prefix.get(i..i + 8)?.try_into().ok()?))
    };
    let Some(name_len) = u32_at(28) else {
        return false;
    };
    if name_len > 4 {
        return false;
    }
    let name_end = 32 + name_len as usize;
    let known = matches!(prefix.get(32..name_end), Some(b"" | b"zstd" | b"lz4"));
    known
        && u64_at(name_end)
            .is_some_and(|records| (name_end as u64 + 8).checked_add(records) == Some(body_len))
}

/// Whether a record body of `body_len` bytes starting with `prefix` is exactly a message index:
/// channel id (2), the entries' byte length (4), then that many bytes of (log time, offset)
/// pairs of 16 bytes.
fn is_message_index(prefix: &[u8], body_len: u64) -> bool {
    prefix
        .get(2..6)
        .and_then(|b| b.try_into().ok())
        .map(|b: [u8; 4]| u64::from(u32::from_le_bytes(b)))
        .is_some_and(|n| n % 16 == 0 && 6 + n == body_len)
}

/// Bytes from a record's start that [`plausible_header`] looks at: its header and the start of
/// its body (a chunk's fields up to its records).
const LOOKAHEAD: usize = (HEADER_BYTES + CHUNK_PREFIX_BYTES) as usize;

/// Whether `bytes` (a record's first [`LOOKAHEAD`] bytes, fewer where the file ends) start a
/// record a resync may land on, with `room` bytes of the file after its header: an opcode of
/// the top level, a length that fits, and for a chunk or a message index (the records a resync
/// usually lands on) a body whose first fields agree with that length. Bytes inserted into or
/// deleted from a chunk make the resync scan its compressed bytes, where only such a check
/// keeps a false start unlikely.
fn plausible_header(bytes: &[u8], room: u64) -> bool {
    let Some((&opcode, rest)) = bytes.split_first() else {
        return false;
    };
    let Some((len, prefix)) = rest.split_first_chunk::<8>() else {
        return false;
    };
    let len = u64::from_le_bytes(*len);
    if !resync_opcode(opcode) || len > room {
        return false;
    }
    match opcode {
        op::CHUNK => looks_like_chunk(prefix, len),
        op::MESSAGE_INDEX => is_message_index(prefix, len),
        _ => true,
    }
}

/// The data end record's header (opcode, length 4): the summary section starts after its body.
const DATA_END_HEADER: [u8; HEADER_BYTES as usize] = [op::DATA_END, 4, 0, 0, 0, 0, 0, 0, 0];

/// How far before the footer a summary section is looked for when the footer's offset to it
/// does not hold (bytes inserted or deleted before it) [bytes]: an hour's log has ~100 KiB.
const SUMMARY_SCAN_BYTES: u64 = 64 << 20;

/// A stretch of the file the walker could not trust.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Skipped {
    /// First byte skipped.
    pub start_byte: u64,
    /// One past the last byte skipped.
    pub end_byte: u64,
    /// Why.
    pub detail: String,
}

/// What [`Walker::next`] found.
#[derive(Debug)]
pub(super) enum Step<'a> {
    /// A record (a chunk comes as its decompressed, CRC-checked records; see [`Walker::chunk`]).
    Record {
        opcode: u8,
        /// Where its header starts.
        offset: u64,
        body: &'a [u8],
    },
    /// A damaged stretch was skipped; the walk goes on after it.
    Skipped(Skipped),
    /// The footer: the file is complete.
    Footer,
    /// The file ends without a footer: everything from `complete_bytes` on is a torn record
    /// (or bytes in which no further record was found).
    Truncated { complete_bytes: u64 },
}

/// The top-level records of an MCAP file, one at a time.
pub(super) struct Walker<R> {
    input: BufReader<R>,
    /// The file's length.
    len: u64,
    /// Where the next record header starts (`input` is positioned there between steps).
    pos: u64,
    body: Vec<u8>,
    done: bool,
    /// Where the last record other than a chunk started: its length is checked by nothing, so a
    /// damaged length may have swallowed the records after it. When the next header is bad the
    /// resync starts inside that record instead.
    last_unchecked: Option<u64>,
}

impl<R: Read + Seek> Walker<R> {
    /// Starts after the magic at `start` (8, or where a resync found the first record of a file
    /// whose start is damaged).
    pub(super) fn new(mut input: R, len: u64, start: u64) -> io::Result<Self> {
        input.seek(SeekFrom::Start(start))?;
        Ok(Self {
            // Large reads: the file is read front to back at the disk's pace.
            input: BufReader::with_capacity(1 << 20, input),
            len,
            pos: start,
            body: Vec::new(),
            done: false,
            last_unchecked: None,
        })
    }

    /// The next step of the walk; `None` after [`Step::Footer`] or [`Step::Truncated`].
    pub(super) fn next(&mut self) -> io::Result<Option<Step<'_>>> {
        if self.done {
            return Ok(None);
        }
        let offset = self.pos;
        let rest = self.len - offset;
        if rest < HEADER_BYTES {
            self.done = true;
            return Ok(Some(Step::Truncated {
                complete_bytes: offset,
            }));
        }
        let mut header = [0u8; HEADER_BYTES as usize];
        self.input.read_exact(&mut header)?;
        let opcode = header[0];
        let body_len = u64::from_le_bytes(header[1..].try_into().unwrap_or_default());
        if !valid_opcode(opcode) || body_len > rest - HEADER_BYTES {
            return match self.last_unchecked.take() {
                // The previous record's length, not this header, may be what is damaged.
                Some(previous) => self.after_bad_header(previous, opcode, body_len),
                None => self.after_bad_header(offset, opcode, body_len),
            };
        }
        self.last_unchecked = (opcode != op::CHUNK).then_some(offset);
        self.pos = offset + HEADER_BYTES + body_len;
        match opcode {
            op::FOOTER => {
                self.done = true;
                // Complete only with the closing magic after it: a file cut inside the magic
                // lost nothing but was still cut (say so).
                let magic = ::mcap::MAGIC.len() as u64;
                let mut tail = [0u8; 8];
                let whole = self.len - self.pos >= magic
                    && self.seek(self.pos).is_ok()
                    && self.input.read_exact(&mut tail[..magic as usize]).is_ok()
                    && tail[..magic as usize] == ::mcap::MAGIC[..];
                Ok(Some(if whole {
                    Step::Footer
                } else {
                    Step::Truncated {
                        complete_bytes: self.pos,
                    }
                }))
            }
            op::CHUNK | op::CHANNEL | op::MESSAGE | op::MESSAGE_INDEX => {
                let n = usize::try_from(body_len).map_err(io::Error::other)?;
                self.body.clear();
                self.body.reserve(n);
                (&mut self.input)
                    .take(body_len)
                    .read_to_end(&mut self.body)?;
                // A chunk whose opcode byte was damaged into another valid one would otherwise
                // be read as that record and its messages lost without a word.
                let opcode = if looks_like_chunk(&self.body, body_len) {
                    op::CHUNK
                } else {
                    opcode
                };
                // A message index's length is checked by nothing else: one whose body does not
                // hold exactly its entries has a damaged header (a damaged length would swallow
                // the chunks after it).
                if opcode == op::MESSAGE_INDEX && !is_message_index(&self.body, body_len) {
                    self.last_unchecked = None;
                    let detail = format!(
                        "message index of {body_len} bytes does not hold its entries (damaged \
                         length)"
                    );
                    return self.resync_after(offset, detail);
                }
                Ok(Some(Step::Record {
                    opcode,
                    offset,
                    body: &self.body,
                }))
            }
            // The spec's data end holds only the data section's CRC-32. Any other length is a
            // damaged opcode (a message index's 0x07 with one bit flipped reads 0x0F): taken as
            // the end of the data, it would drop every chunk after it without a word.
            op::DATA_END if body_len != DATA_END_BODY_BYTES => {
                self.last_unchecked = None;
                let detail = format!(
                    "data end record of {body_len} bytes (the spec's holds a {DATA_END_BODY_BYTES}-byte \
                     CRC): a damaged opcode"
                );
                self.resync_after(offset, detail)
            }
            _ => {
                // Not needed by the reader (schemas, indexes, statistics, attachments, private
                // records): skipped unread, unless it is a chunk with a damaged opcode byte
                // (its first fields tell, without reading the rest).
                let peek = body_len.min(CHUNK_PREFIX_BYTES);
                self.body.clear();
                (&mut self.input).take(peek).read_to_end(&mut self.body)?;
                if looks_like_chunk(&self.body, body_len) {
                    (&mut self.input)
                        .take(body_len - peek)
                        .read_to_end(&mut self.body)?;
                    return Ok(Some(Step::Record {
                        opcode: op::CHUNK,
                        offset,
                        body: &self.body,
                    }));
                }
                self.input
                    .seek_relative(i64::try_from(body_len - peek).map_err(io::Error::other)?)?;
                Ok(Some(Step::Record {
                    opcode,
                    offset,
                    body: &[],
                }))
            }
        }
    }

    /// A header that cannot be a record's: resync after it, or the file ends here.
    fn after_bad_header(
        &mut self,
        offset: u64,
        opcode: u8,
        body_len: u64,
    ) -> io::Result<Option<Step<'_>>> {
        let detail = if valid_opcode(opcode) {
            format!("record {opcode:#04x} claims {body_len} bytes, more than the file holds")
        } else {
            format!("no record header (opcode {opcode:#04x})")
        };
        self.resync_after(offset, detail)
    }

    /// Resyncs after the damaged record at `offset` (`detail`: how it is damaged), or the file
    /// ends there.
    fn resync_after(&mut self, offset: u64, detail: String) -> io::Result<Option<Step<'_>>> {
        match self.resync(offset + 1)? {
            Some(next) => {
                self.seek(next)?;
                Ok(Some(Step::Skipped(Skipped {
                    start_byte: offset,
                    end_byte: next,
                    detail: format!("{detail}; resynchronised at byte {next}"),
                })))
            }
            None => {
                self.done = true;
                Ok(Some(Step::Truncated {
                    complete_bytes: offset,
                }))
            }
        }
    }

    /// The chunk at `offset` did not decode: its length is checked by nothing either, so a bad
    /// header after it resyncs from inside it (bytes inserted into or deleted from a chunk move
    /// its end, and its length then points into the middle of a record).
    pub(super) fn chunk_failed(&mut self, offset: u64) {
        self.last_unchecked = Some(offset);
    }

    pub(super) fn seek(&mut self, to: u64) -> io::Result<()> {
        self.goto(to)?;
        self.pos = to;
        Ok(())
    }

    /// Positions the input at `to`, within the buffer when it holds `to` (a resync steps back
    /// and forth by a few bytes; a plain seek would read the buffer's MiB again each time).
    fn goto(&mut self, to: u64) -> io::Result<()> {
        let here = self.input.stream_position()?;
        match i64::try_from(i128::from(to) - i128::from(here)) {
            Ok(by) => self.input.seek_relative(by),
            Err(_) => self.input.seek(SeekFrom::Start(to)).map(drop),
        }
    }

    /// The first offset ≥ `from` where a [`plausible_header`] stands, followed by another one
    /// (or by the end of the file: the footer and its magic). Checking two records in a row
    /// makes a false sync in damaged bytes unlikely (a length's high bytes must all be zero,
    /// twice). Each byte is looked at once, plus one header read per candidate that passes.
    pub(super) fn resync(&mut self, from: u64) -> io::Result<Option<u64>> {
        const WINDOW: usize = 1 << 16;
        let mut window = vec![0u8; WINDOW + LOOKAHEAD];
        let mut at = from;
        while at + HEADER_BYTES <= self.len {
            self.goto(at)?;
            let want = usize::try_from((self.len - at).min(window.len() as u64))
                .map_err(io::Error::other)?;
            self.input.read_exact(&mut window[..want])?;
            // Up to the last header that fits, where the window ends with the file.
            let scan = want.saturating_sub(HEADER_BYTES as usize - 1).min(WINDOW);
            for i in 0..scan {
                let candidate = at + i as u64;
                let room = self.len - candidate - HEADER_BYTES;
                let bytes = &window[i..want.min(i + LOOKAHEAD)];
                if !plausible_header(bytes, room) {
                    continue;
                }
                let len = u64::from_le_bytes(bytes[1..9].try_into().unwrap_or_default());
                let opcode = bytes[0];
                if self.followed_by_a_record(opcode, candidate + HEADER_BYTES + len)? {
                    return Ok(Some(candidate));
                }
            }
            at += scan.max(1) as u64;
        }
        Ok(None)
    }

    /// Whether a record of `opcode` ending at `end` is followed by a [`plausible_header`] (or,
    /// for the footer, by the closing magic at the end of the file).
    fn followed_by_a_record(&mut self, opcode: u8, end: u64) -> io::Result<bool> {
        if opcode == op::FOOTER {
            return Ok(end + ::mcap::MAGIC.len() as u64 == self.len);
        }
        if end == self.len {
            // A record that ends the file: only a truncated file ends without its footer.
            return Ok(opcode == op::CHUNK);
        }
        if end + HEADER_BYTES > self.len {
            return Ok(false);
        }
        self.goto(end)?;
        let mut next = [0u8; LOOKAHEAD];
        let n =
            usize::try_from((self.len - end).min(LOOKAHEAD as u64)).map_err(io::Error::other)?;
        self.input.read_exact(&mut next[..n])?;
        Ok(plausible_header(&next[..n], self.len - end - HEADER_BYTES))
    }

    /// Channel records of the summary section, found through the footer (empty when the footer
    /// or summary is missing or damaged). They stand in for channel records lost in a damaged
    /// chunk. Restores the walk position.
    pub(super) fn summary_channels(&mut self) -> Vec<::mcap::records::Channel> {
        let mut found = Vec::new();
        let back = self.pos;
        let _ = self.read_summary_channels(&mut found);
        if self.seek(back).is_err() {
            self.done = true;
        }
        found
    }

    fn read_summary_channels(
        &mut self,
        found: &mut Vec<::mcap::records::Channel>,
    ) -> io::Result<()> {
        // Footer: opcode, length 20, summary start, summary offset start, CRC; then the magic.
        const FOOTER: u64 = HEADER_BYTES + 20 + 8;
        if self.len < FOOTER + 8 {
            return Ok(());
        }
        self.seek(self.len - FOOTER)?;
        let mut footer = [0u8; FOOTER as usize];
        self.input.read_exact(&mut footer)?;
        if footer[0] != op::FOOTER
            || footer[1..9] != 20u64.to_le_bytes()
            || &footer[29..] != ::mcap::MAGIC
        {
            return Ok(());
        }
        let stated = u64::from_le_bytes(footer[9..17].try_into().unwrap_or_default());
        if stated == 0 {
            // The file has no summary section.
            return Ok(());
        }
        let summary_end = self.len - FOOTER;
        let start = self.summary_start(stated, summary_end)?.unwrap_or(stated);
        if start < 8 || start >= summary_end {
            return Ok(());
        }
        self.seek(start)?;
        let mut at = start;
        while at + HEADER_BYTES <= summary_end {
            let mut header = [0u8; HEADER_BYTES as usize];
            self.input.read_exact(&mut header)?;
            let len = u64::from_le_bytes(header[1..].try_into().unwrap_or_default());
            if len > summary_end - at - HEADER_BYTES {
                break;
            }
            if header[0] == op::CHANNEL {
                let mut body = vec![0u8; usize::try_from(len).map_err(io::Error::other)?];
                self.input.read_exact(&mut body)?;
                if let Ok(::mcap::records::Record::Channel(c)) = parse_record(op::CHANNEL, &body) {
                    found.push(c);
                }
            } else {
                self.input
                    .seek_relative(i64::try_from(len).map_err(io::Error::other)?)?;
            }
            at += HEADER_BYTES + len;
        }
        Ok(())
    }

    /// Where the summary section ending at `summary_end` starts: at `stated` (the footer's
    /// word) if its records end exactly there, else after the last data end record before it
    /// whose following records do (bytes inserted or deleted before the summary moved it off
    /// the footer's offset). `None` if neither.
    fn summary_start(&mut self, stated: u64, summary_end: u64) -> io::Result<Option<u64>> {
        if self.records_end_at(stated, summary_end)? {
            return Ok(Some(stated));
        }
        const WINDOW: u64 = 1 << 16;
        const DATA_END_BYTES: u64 = HEADER_BYTES + DATA_END_BODY_BYTES;
        let floor = summary_end.saturating_sub(SUMMARY_SCAN_BYTES).max(8);
        // Backwards, window by window; each window overlaps the next by a data end record less
        // one byte, so one across their border is seen whole.
        let mut window = Vec::new();
        let mut hi = summary_end;
        while hi >= floor + DATA_END_BYTES {
            let lo = hi.saturating_sub(WINDOW).max(floor);
            window.resize(usize::try_from(hi - lo).map_err(io::Error::other)?, 0);
            self.goto(lo)?;
            self.input.read_exact(&mut window)?;
            let last = window.len() - DATA_END_BYTES as usize;
            for i in (0..=last).rev() {
                if window[i..i + HEADER_BYTES as usize] == DATA_END_HEADER {
                    let start = lo + i as u64 + DATA_END_BYTES;
                    if self.records_end_at(start, summary_end)? {
                        return Ok(Some(start));
                    }
                }
            }
            if lo == floor {
                break;
            }
            hi = lo + DATA_END_BYTES - 1;
        }
        Ok(None)
    }

    /// Whether the records from `from` on, each a valid opcode with a length that fits, end
    /// exactly at `end`.
    fn records_end_at(&mut self, from: u64, end: u64) -> io::Result<bool> {
        if from < 8 || from >= end {
            return Ok(false);
        }
        self.goto(from)?;
        let mut at = from;
        while at < end {
            if end - at < HEADER_BYTES {
                return Ok(false);
            }
            let mut header = [0u8; HEADER_BYTES as usize];
            self.input.read_exact(&mut header)?;
            let len = u64::from_le_bytes(header[1..].try_into().unwrap_or_default());
            if !valid_opcode(header[0]) || len > end - at - HEADER_BYTES {
                return Ok(false);
            }
            self.input
                .seek_relative(i64::try_from(len).map_err(io::Error::other)?)?;
            at += HEADER_BYTES + len;
        }
        Ok(true)
    }
}

/// `mcap::parse_record`, once every string length in `body` is known to fit in it: the parser
/// allocates a string's claimed length before reading it, so one damaged length (0xffffffff)
/// asked for 4 GiB and aborted the process where memory is bounded.
pub(crate) fn parse_record(opcode: u8, body: &[u8]) -> Result<::mcap::records::Record<'_>, String> {
    if let Some((record, field)) = overrun_field(opcode, body) {
        return Err(format!(
            "record {opcode:#04x}: the {record} record's field `{field}`: the record ends before \
             this field does (a damaged length)"
        ));
    }
    if !strings_fit(opcode, body) {
        return Err(format!(
            "record {opcode:#04x}: a string's length exceeds the record's {} bytes",
            body.len()
        ));
    }
    ::mcap::parse_record(opcode, body).map_err(|e| {
        // `mcap`'s own text of this error is "Record parse failed", its cause a backtrace.
        format!("record {opcode:#04x}: {}", crate::mcap_damage::describe(&e))
    })
}

/// The record and field of the first length-prefixed string in a header or schema record (which
/// the ROS 2 bag reader parses) that does not fit in `body`, in the words `mcap_damage` uses.
fn overrun_field(opcode: u8, body: &[u8]) -> Option<(&'static str, &'static str)> {
    // The end of the string (or bytes) at `at`, if it fits.
    let string = |at: usize| {
        let len = u32::from_le_bytes(body.get(at..at.checked_add(4)?)?.try_into().ok()?);
        let end = at.checked_add(4)?.checked_add(len as usize)?;
        (end <= body.len()).then_some(end)
    };
    let (record, start, fields): (_, _, &[&'static str]) = match opcode {
        op::HEADER => ("Header", 0, &["profile", "library"]),
        // After the schema id (2 bytes); the data has a u32 length as the strings do.
        op::SCHEMA => ("Schema", 2, &["name", "encoding", "data"]),
        _ => return None,
    };
    let mut at = start;
    for field in fields {
        at = match string(at) {
            Some(end) => end,
            None => return Some((record, field)),
        };
    }
    None
}

/// Whether each length-prefixed string of the record types this reader parses (chunk: its
/// compression; channel: topic, encoding and the metadata's keys and values) fits in `body`.
fn strings_fit(opcode: u8, body: &[u8]) -> bool {
    let u32_at = |at: usize| {
        body.get(at..at + 4)
            .map(|b| u32::from_le_bytes(b.try_into().unwrap_or_default()) as usize)
    };
    // The end of the string at `at`, if it fits.
    let string = |at: usize| {
        let end = at.checked_add(4)?.checked_add(u32_at(at)?)?;
        (end <= body.len()).then_some(end)
    };
    match opcode {
        // Start time, end time, uncompressed size (8 each), CRC (4), then the compression.
        op::CHUNK => string(28).is_some(),
        // Channel id, schema id (2 each), topic, encoding, metadata (byte length, string pairs).
        op::CHANNEL => {
            let Some(mut at) = string(4).and_then(string) else {
                return false;
            };
            let Some(map_end) = u32_at(at).and_then(|n| (at + 4).checked_add(n)) else {
                return false;
            };
            at += 4;
            while at < map_end.min(body.len()) {
                match string(at) {
                    Some(end) => at = end,
                    None => return false,
                }
            }
            true
        }
        _ => true,
    }
}

/// Why a chunk's records were not read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum ChunkProblem {
    /// CRC mismatch, decompression failure, inconsistent sizes: the chunk is skipped.
    Damaged(String),
    /// A compression this tool does not read.
    Unsupported(String),
}

/// Decodes chunk records, reusing its buffers from one chunk to the next.
#[derive(Default)]
pub(crate) struct ChunkDecoder {
    chunk: Vec<u8>,
    zstd: Option<zstd::bulk::Decompressor<'static>>,
}

impl ChunkDecoder {
    /// A chunk record's records, decompressed and CRC-checked; `Err` with why the chunk cannot
    /// be trusted. An unknown compression is `Ok(Err)` too (the caller decides).
    pub(crate) fn decode(&mut self, body: &[u8]) -> Result<&[u8], ChunkProblem> {
        let (header, data) = match parse_record(op::CHUNK, body) {
            Ok(::mcap::records::Record::Chunk { header, data }) => (header, data),
            Ok(_) => return Err(ChunkProblem::Damaged("chunk record did not parse".into())),
            Err(e) => return Err(ChunkProblem::Damaged(e)),
        };
        // The fields must fill the record exactly: a zeroed chunk header otherwise reads as a
        // valid empty chunk, and its messages would vanish unreported.
        let fields = 8 + 8 + 8 + 4 + 4 + header.compression.len() + 8 + data.len();
        if fields != body.len() {
            return Err(ChunkProblem::Damaged(format!(
                "chunk record of {} bytes, its fields account for {fields}",
                body.len()
            )));
        }
        if header.uncompressed_size > MAX_CHUNK_BYTES {
            return Err(ChunkProblem::Damaged(format!(
                "chunk claims {} bytes uncompressed",
                header.uncompressed_size
            )));
        }
        let size = header.uncompressed_size as usize;
        match header.compression.as_str() {
            "" => {
                if data.len() != size {
                    return Err(ChunkProblem::Damaged(format!(
                        "uncompressed chunk of {} bytes claims {size} bytes uncompressed",
                        data.len()
                    )));
                }
                self.chunk.clear();
                self.chunk.extend_from_slice(&data);
            }
            "zstd" => {
                self.chunk.clear();
                self.chunk.reserve(size);
                let zstd = match &mut self.zstd {
                    Some(z) => z,
                    None => self.zstd.insert(
                        zstd::bulk::Decompressor::new()
                            .map_err(|e| ChunkProblem::Damaged(format!("zstd: {e}")))?,
                    ),
                };
                let n = zstd
                    .decompress_to_buffer(&data[..], &mut self.chunk)
                    .map_err(|e| ChunkProblem::Damaged(format!("zstd chunk: {e}")))?;
                if n != size {
                    return Err(ChunkProblem::Damaged(format!(
                        "zstd chunk holds {n} bytes, its header claims {size}"
                    )));
                }
            }
            "lz4" => {
                // Block by block, the CRC below standing for the frame's content hash; a
                // chunk without a CRC, or a frame that reader does not take, through liblz4.
                let decoded = header.uncompressed_crc != 0
                    && lz4_frame::decode(&data, size, &mut self.chunk).is_some();
                if !decoded {
                    self.chunk.clear();
                    self.chunk.reserve(size);
                    let mut decoder = lz4::Decoder::new(&data[..])
                        .map_err(|e| ChunkProblem::Damaged(format!("lz4 chunk: {e}")))?;
                    let n = (&mut decoder)
                        .take(header.uncompressed_size + 1)
                        .read_to_end(&mut self.chunk)
                        .map_err(|e| ChunkProblem::Damaged(format!("lz4 chunk: {e}")))?;
                    if n != size {
                        return Err(ChunkProblem::Damaged(format!(
                            "lz4 chunk holds {n} bytes, its header claims {size}"
                        )));
                    }
                }
            }
            other => return Err(ChunkProblem::Unsupported(other.to_owned())),
        }
        if header.uncompressed_crc != 0 {
            let crc = crc32fast::hash(&self.chunk);
            if crc != header.uncompressed_crc {
                return Err(ChunkProblem::Damaged(format!(
                    "chunk CRC mismatch (stored {:#010x}, computed {crc:#010x})",
                    header.uncompressed_crc
                )));
            }
        }
        Ok(&self.chunk)
    }

    /// The records the last [`ChunkDecoder::decode`] gave, kept whole (a reader on another
    /// thread takes them); `spare`, emptied, is the next chunk's buffer.
    pub(crate) fn take_records(&mut self, spare: Vec<u8>) -> Vec<u8> {
        std::mem::replace(&mut self.chunk, spare)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A loss's detail says which field of which record is damaged.
    #[test]
    fn a_record_that_does_not_parse_says_which_field() {
        // A Schema record: id 1, then a name claiming 200 bytes of the 1 left.
        let e = parse_record(op::SCHEMA, &[1, 0, 200, 0, 0, 0, b'a']).err();
        assert_eq!(
            e.as_deref(),
            Some(
                "record 0x03: the Schema record's field `name`: the record ends before this \
                 field does (a damaged length)"
            )
        );
    }
}
