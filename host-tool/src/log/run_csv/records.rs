//! The CSV layer of the run and commands CSVs: records of cells from the bytes, RFC 4180
//! quoting, physical line numbers.

use super::*;

/// The CSV layer: splits the input into records of cells, tracking physical line numbers.
///
/// A line without a quote (every row this tool writes) is split where it lies: its cells are
/// spans of the line, checked for UTF-8 once per line. Lines with quotes take the general path
/// (unquoting into `data`, possibly over several lines). Both give the same cells.
#[derive(Debug)]
pub(super) struct Records<R> {
    input: R,
    /// Physical lines read so far (= the 1-based number of the line in `line`).
    line_no: u64,
    /// The current physical line without its LF / CRLF.
    line: Vec<u8>,
    /// The unquoted cells of a record with quotes, concatenated.
    data: Vec<u8>,
    /// The current record's text when it is UTF-8 (the line, or `data`, moved here).
    text: String,
    /// Which buffer the current record's cells are spans of.
    cells_in: CellsIn,
    /// Where each cell of the current record starts and ends.
    spans: Vec<(usize, usize)>,
    /// Whether the last physical line read had no line end: the input ends inside it (a row
    /// cut by a kill or a full disk, or a file without a final newline).
    pub(super) unterminated: bool,
}

/// Where the current record's cells are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CellsIn {
    /// `text` (UTF-8, checked once for the whole record).
    Text,
    /// `line` (no quotes, not UTF-8).
    Line,
    /// `data` (quoted, not UTF-8).
    Data,
}

const UTF8_BOM: &[u8] = b"\xEF\xBB\xBF";

fn is_blank(b: u8) -> bool {
    b == b' ' || b == b'\t'
}

/// `start..end` of `bytes` without leading and trailing blanks.
fn trim_blanks(bytes: &[u8], mut start: usize, mut end: usize) -> (usize, usize) {
    while start < end && is_blank(bytes[start]) {
        start += 1;
    }
    while end > start && is_blank(bytes[end - 1]) {
        end -= 1;
    }
    (start, end)
}

impl<R: BufRead> Records<R> {
    pub(super) fn new(input: R) -> Self {
        Self {
            input,
            line_no: 0,
            line: Vec::new(),
            data: Vec::new(),
            text: String::new(),
            cells_in: CellsIn::Text,
            spans: Vec::new(),
            unterminated: false,
        }
    }

    /// Cells in the current record.
    pub(super) fn len(&self) -> usize {
        self.spans.len()
    }

    fn text(&self) -> &[u8] {
        match self.cells_in {
            CellsIn::Text => self.text.as_bytes(),
            CellsIn::Line => &self.line,
            CellsIn::Data => &self.data,
        }
    }

    /// Cell `i` of the current record (empty if there is no such cell).
    pub(super) fn cell(&self, i: usize) -> &[u8] {
        self.spans
            .get(i)
            .and_then(|&(start, end)| self.text().get(start..end))
            .unwrap_or_default()
    }

    /// Cell `i` as text; `None` if it is not UTF-8.
    pub(super) fn cell_str(&self, i: usize) -> Option<&str> {
        match self.cells_in {
            // Cells start and end at ASCII delimiters or blanks: always char boundaries.
            CellsIn::Text => {
                let &(start, end) = self.spans.get(i)?;
                self.text.get(start..end)
            }
            CellsIn::Line | CellsIn::Data => std::str::from_utf8(self.cell(i)).ok(),
        }
    }

    /// Moves the current record's bytes (`line` or `data`) into `text` if they are UTF-8.
    fn settle(&mut self, quoted: bool) {
        let buffer = if quoted {
            &mut self.data
        } else {
            &mut self.line
        };
        let bytes = std::mem::take(buffer);
        match String::from_utf8(bytes) {
            Ok(text) => {
                // The old text's allocation becomes the emptied buffer.
                *buffer = std::mem::replace(&mut self.text, text).into_bytes();
                self.cells_in = CellsIn::Text;
            }
            Err(e) => {
                *buffer = e.into_bytes();
                self.cells_in = if quoted { CellsIn::Data } else { CellsIn::Line };
            }
        }
    }

    /// Reads the next physical line into `line`; false at the end of the input.
    fn read_line(&mut self) -> io::Result<bool> {
        self.line.clear();
        if self.input.read_until(b'\n', &mut self.line)? == 0 {
            return Ok(false);
        }
        self.line_no += 1;
        self.unterminated = self.line.last() != Some(&b'\n');
        if self.line.last() == Some(&b'\n') {
            self.line.pop();
            if self.line.last() == Some(&b'\r') {
                self.line.pop();
            }
        }
        if self.line_no == 1 && self.line.starts_with(UTF8_BOM) {
            self.line.drain(..UTF8_BOM.len());
        }
        Ok(true)
    }

    /// Reads the next record (skipping blank lines); returns the line it starts on.
    pub(super) fn next_record(&mut self) -> Result<Option<u64>, RunCsvError> {
        loop {
            if !self.read_line()? {
                return Ok(None);
            }
            if !self.line.is_empty() {
                break;
            }
        }
        let start_line = self.line_no;
        self.spans.clear();
        if memchr::memchr(b'"', &self.line).is_none() {
            let mut start = 0;
            for i in memchr::memchr_iter(b',', &self.line) {
                self.spans.push(trim_blanks(&self.line, start, i));
                start = i + 1;
            }
            self.spans
                .push(trim_blanks(&self.line, start, self.line.len()));
            self.settle(false);
            return Ok(Some(start_line));
        }
        self.data.clear();
        let mut pos = 0;
        loop {
            while self.line.get(pos).copied().is_some_and(is_blank) {
                pos += 1;
            }
            let column = self.spans.len() + 1;
            let cell_start = self.data.len();
            if self.line.get(pos) == Some(&b'"') {
                // Quoted cell: `""` is a quote; it may span lines.
                let open_line = self.line_no;
                pos += 1;
                loop {
                    let rest = self.line.get(pos..).unwrap_or_default();
                    match rest.iter().position(|&b| b == b'"') {
                        Some(q) => {
                            self.data.extend_from_slice(&rest[..q]);
                            if rest.get(q + 1) == Some(&b'"') {
                                self.data.push(b'"');
                                pos += q + 2;
                            } else {
                                pos += q + 1;
                                break;
                            }
                        }
                        None => {
                            self.data.extend_from_slice(rest);
                            self.data.push(b'\n');
                            if !self.read_line()? {
                                return Err(RunCsvError::Syntax {
                                    line: open_line,
                                    column,
                                    problem: "quoted cell is never closed",
                                });
                            }
                            pos = 0;
                        }
                    }
                }
                while self.line.get(pos).copied().is_some_and(is_blank) {
                    pos += 1;
                }
                self.spans.push((cell_start, self.data.len()));
                match self.line.get(pos) {
                    None => break,
                    Some(b',') => pos += 1,
                    Some(_) => {
                        return Err(RunCsvError::Syntax {
                            line: self.line_no,
                            column,
                            problem: "text after the closing quote of a cell",
                        })
                    }
                }
            } else {
                let rest = self.line.get(pos..).unwrap_or_default();
                let end = rest.iter().position(|&b| b == b',');
                let (_, cell_end) = trim_blanks(rest, 0, end.unwrap_or(rest.len()));
                self.data.extend_from_slice(&rest[..cell_end]);
                self.spans.push((cell_start, self.data.len()));
                match end {
                    None => break,
                    Some(e) => pos += e + 1,
                }
            }
        }
        self.settle(true);
        Ok(Some(start_line))
    }
}
