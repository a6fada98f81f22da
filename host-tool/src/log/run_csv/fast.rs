//! The fast path of [`super::read_run_csv_salvaging`] and of `validate` for files in this
//! tool's own layout (the header [`RunCsvWriter`](super::RunCsvWriter) writes, no quotes, LF
//! line ends, the last line ended): the file is cut at line ends into jobs, read and parsed on
//! every core in blocks (a block's bytes are parsed while they are in the cache, and no buffer
//! of the whole file is allocated) straight from the bytes: no per-row allocation, one pass
//! over the bytes, numbers by `fast_float2` (correctly rounded, as `str::parse`), a cell it
//! does not take whole by `str::parse`. The rows go to a visitor in file order, a job at a
//! time, so memory holds a few jobs whatever the file's length (the caller keeps what it
//! needs: all the samples, or a run's statistics).
//! It gives the same samples as the general reader or gives up: on the first cell, row or
//! layout it does not accept it returns `false`, and the general reader reads the file and
//! words the error (or drops the cut row) exactly as before.

use super::{Column, RigRange, RunSample};
use model_core::Sides;
use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom};
use std::path::Path;
use std::sync::{Condvar, Mutex};

/// Smallest file worth a second thread [bytes].
const PARALLEL_BYTES: u64 = 1 << 20;

/// Bytes each thread reads at a time (fits in a core's L2 with room to spare).
pub(super) const BLOCK_BYTES: usize = 256 << 10;

/// Columns up to `pitch_deg` (the layout before the tracked point's `x_m,y_m`).
const WITH_POSE_ANGLES: usize = 9;

/// A header this tool writes: its number of columns (every column, without the tracked
/// point's, the required).
fn layout(header_line: &[u8]) -> Option<usize> {
    [Column::ALL.len(), WITH_POSE_ANGLES, Column::REQUIRED.len()]
        .into_iter()
        .find(|&n| header_line == header(&Column::ALL[..n]).as_bytes())
}

/// A function handed the samples in file order, a stretch at a time, as they are read.
pub type Visit<'a> = &'a mut (dyn FnMut(&[RunSample]) + Send);

/// Hands `visit` the samples of the run CSV at `path`, in file order, read in blocks of
/// `block` bytes, and returns true if the file is valid (its readings within `range`) and in
/// this tool's layout; false otherwise (see the module docs), when `visit` may have had some
/// of its samples (not all). `visit` gets a job's rows on the core that parsed them, while
/// they are in its cache.
pub(super) fn read_file(
    path: &Path,
    block: usize,
    range: RigRange,
    visit: Visit<'_>,
) -> io::Result<bool> {
    let mut file = File::open(path)?;
    let metadata = file.metadata()?;
    if !metadata.is_file() {
        // A pipe or a device: read once, by the general reader.
        return Ok(false);
    }
    let len = metadata.len();
    let mut head = Vec::new();
    (&mut file).take(4096).read_to_end(&mut head)?;
    let Some(header_end) = memchr::memchr(b'\n', &head) else {
        return Ok(false);
    };
    let Some(columns) = layout(&head[..header_end]) else {
        return Ok(false);
    };
    let data_start = header_end as u64 + 1;
    let Some(data_len) = len.checked_sub(data_start) else {
        // The file shrank under us: the general reader reads what is there.
        return Ok(false);
    };
    if data_len > 0 {
        // The last line must be ended (a cut one is the general reader's to drop).
        let mut last = [0u8];
        file.seek(SeekFrom::Start(len - 1))?;
        file.read_exact(&mut last)?;
        if last[0] != b'\n' {
            return Ok(false);
        }
    }
    let mut reader = PartReader {
        columns,
        block,
        range,
        previous_t_s: f64::NEG_INFINITY,
        buf: Vec::with_capacity(2 * block),
    };
    if data_len < PARALLEL_BYTES {
        let mut samples = Vec::new();
        let ok = reader.read(&mut file, data_start, len, false, &mut samples)?;
        if ok {
            visit(&samples);
        }
        return Ok(ok);
    }
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get().min(8));
    let job = 4 * block as u64;
    let jobs = data_len.div_ceil(job);
    let bounds = |j: u64| data_start + (j * job).min(data_len);
    let assembly = Assembly::new(visit);
    std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads as u64)
            .map(|first| {
                let (assembly, mut reader) = (&assembly, reader.clone());
                s.spawn(move || -> io::Result<()> {
                    // The others wait for this thread's turns: a panic must not leave them
                    // waiting.
                    let _guard = FailOnPanic(assembly);
                    let mut file = File::open(path)?;
                    let mut rows = Vec::new();
                    for j in (first..jobs).step_by(threads) {
                        rows.clear();
                        reader.previous_t_s = f64::NEG_INFINITY;
                        let read =
                            reader.read(&mut file, bounds(j), bounds(j + 1), j > 0, &mut rows);
                        // Whatever happened, the job's turn passes (the others wait for it).
                        let ok = matches!(read, Ok(true));
                        if !assembly.append(j, ok.then_some(&rows[..])) {
                            read?;
                            break;
                        }
                    }
                    Ok(())
                })
            })
            .collect();
        workers
            .into_iter()
            .try_for_each(|worker| worker.join().unwrap_or(Ok(())))
    })?;
    Ok(assembly.finish())
}

/// The parallel reader's jobs handed to the visitor in file order, by the thread that read
/// each job as soon as its turn comes (so a job's rows are visited while they are in that
/// core's cache, and the next job is read meanwhile on the other core).
struct Assembly<'a> {
    state: Mutex<Assembled<'a>>,
    turn: Condvar,
}

struct Assembled<'a> {
    visit: Visit<'a>,
    /// The time of the last row visited.
    last_t_s: Option<f64>,
    /// The job whose rows come next.
    next: u64,
    /// A job was not in this tool's layout (or could not be read): the result is `false`.
    failed: bool,
}

impl<'a> Assembly<'a> {
    fn new(visit: Visit<'a>) -> Self {
        Self {
            state: Mutex::new(Assembled {
                visit,
                last_t_s: None,
                next: 0,
                failed: false,
            }),
            turn: Condvar::new(),
        }
    }

    /// Appends job `j`'s rows (`None`: the job failed) when its turn comes; false once the
    /// read has failed (the caller stops).
    fn append(&self, j: u64, rows: Option<&[RunSample]>) -> bool {
        let Ok(state) = self.state.lock() else {
            return false;
        };
        let Ok(mut state) = self.turn.wait_while(state, |s| s.next != j && !s.failed) else {
            return false;
        };
        let seamless = |rows: &[RunSample]| {
            // Time must increase across the jobs' seam too.
            match (state.last_t_s, rows.first()) {
                (Some(last_t_s), Some(first)) => first.t_s > last_t_s,
                _ => true,
            }
        };
        match rows {
            Some(rows) if !state.failed && seamless(rows) => {
                (state.visit)(rows);
                if let Some(last) = rows.last() {
                    state.last_t_s = Some(last.t_s);
                }
            }
            _ => state.failed = true,
        }
        state.next += 1;
        self.turn.notify_all();
        !state.failed
    }

    /// Ends the read with `None` (a worker panicked).
    fn fail(&self) {
        if let Ok(mut state) = self.state.lock() {
            state.failed = true;
        }
        self.turn.notify_all();
    }

    /// Whether every job was read and visited.
    fn finish(self) -> bool {
        self.state.into_inner().is_ok_and(|state| !state.failed)
    }
}

/// Fails the [`Assembly`] if its thread unwinds.
struct FailOnPanic<'a, 'b>(&'a Assembly<'b>);

impl Drop for FailOnPanic<'_, '_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.fail();
        }
    }
}

/// Reads rows of one layout from byte ranges of the file, block by block.
#[derive(Clone)]
struct PartReader {
    columns: usize,
    block: usize,
    /// The readings accepted.
    range: RigRange,
    /// The time of the last row read.
    previous_t_s: f64,
    /// The bytes read and not yet parsed.
    buf: Vec<u8>,
}

impl PartReader {
    /// Appends to `out` the rows of `file` that start at a byte in `begin..end`; false on
    /// anything the general reader must judge. `mid_line`: `begin` may fall inside a row
    /// (whose owner is the range before), so reading starts at the byte before it and the first
    /// row is the one after the next line end.
    fn read(
        &mut self,
        file: &mut File,
        begin: u64,
        end: u64,
        mid_line: bool,
        out: &mut Vec<RunSample>,
    ) -> io::Result<bool> {
        // File offset of `buf[0]`.
        let mut offset = if mid_line { begin - 1 } else { begin };
        file.seek(SeekFrom::Start(offset))?;
        let buf = &mut self.buf;
        buf.clear();
        let mut skip_to_line_end = mid_line;
        loop {
            let read = (&mut *file).take(self.block as u64).read_to_end(buf)?;
            let eof = read < self.block;
            let mut from = 0;
            if skip_to_line_end {
                match memchr::memchr(b'\n', buf) {
                    Some(i) => {
                        from = i + 1;
                        skip_to_line_end = false;
                    }
                    None if eof => return Ok(true),
                    None => {
                        offset += buf.len() as u64;
                        buf.clear();
                        continue;
                    }
                }
            }
            // Rows of this range start before `limit` in `buf`.
            let limit = usize::try_from(end.saturating_sub(offset)).unwrap_or(usize::MAX);
            let complete = memchr::memrchr(b'\n', &buf[from..]).map_or(from, |i| from + i + 1);
            let last = limit <= from || limit < complete || eof;
            let stop = if limit <= from {
                from
            } else if limit < complete {
                // The row holding byte `limit - 1` is the last of this range.
                memchr::memchr(b'\n', &buf[limit - 1..]).map_or(complete, |i| limit + i)
            } else {
                complete
            };
            let (columns, range) = (self.columns, self.range);
            if parse_lines(
                &buf[from..stop],
                columns,
                range,
                &mut self.previous_t_s,
                out,
            )
            .is_none()
            {
                return Ok(false);
            }
            if last {
                return Ok(true);
            }
            offset += complete as u64;
            buf.drain(..complete);
        }
    }
}

fn header(columns: &[Column]) -> String {
    columns
        .iter()
        .map(|c| c.name())
        .collect::<Vec<_>>()
        .join(",")
}

/// Whole lines of `columns` cells each into samples appended to `out`, their readings within
/// `range`, their times after `previous_t_s` and increasing (which is updated); `None` on
/// anything the general reader would refuse or treat specially. One pass over the bytes: each
/// cell is parsed where it starts and its number's end is its delimiter (no line or cell split
/// before parsing).
fn parse_lines(
    part: &[u8],
    columns: usize,
    range: RigRange,
    previous_t_s: &mut f64,
    out: &mut Vec<RunSample>,
) -> Option<()> {
    let mut cells = [None::<f64>; Column::ALL.len()];
    let mut pos = 0;
    while pos < part.len() {
        if part[pos] == b'\n' {
            // An empty line: the general reader skips blank lines too.
            pos += 1;
            continue;
        }
        for (n, cell) in cells.iter_mut().enumerate().take(columns) {
            let (value, end) = parse_cell(part, pos)?;
            *cell = value;
            let last = n + 1 == columns;
            match part.get(end) {
                Some(b',') if !last => {}
                Some(b'\n') if last => {}
                _ => return None,
            }
            pos = end + 1;
        }
        let sample = row_sample(&cells, columns, range)?;
        if sample.t_s <= *previous_t_s {
            return None;
        }
        *previous_t_s = sample.t_s;
        out.push(sample);
    }
    Some(())
}

/// The sample of one row's cells, checked as the general reader checks them.
fn row_sample(
    cells: &[Option<f64>; Column::ALL.len()],
    columns: usize,
    range: RigRange,
) -> Option<RunSample> {
    let value = |column: Column| -> Option<f64> {
        let v = cells[column as usize]?;
        range.admits(column, v).then_some(v)
    };
    let optional = |column: Column| -> Result<Option<f64>, ()> {
        if column as usize >= columns {
            return Ok(None);
        }
        match cells[column as usize] {
            None => Ok(None),
            Some(v) if v.is_finite() => Ok(Some(v)),
            // A tracker's dropout.
            Some(v) if v.is_nan() && Column::NAN_IS_EMPTY.contains(&column) => Ok(None),
            Some(_) => Err(()),
        }
    };
    Some(RunSample {
        t_s: value(Column::TimeS)?,
        bus_v: Sides::new(value(Column::LeftBusV)?, value(Column::RightBusV)?),
        current_a: Sides::new(value(Column::LeftCurrentA)?, value(Column::RightCurrentA)?),
        cmd_mps: Sides::new(value(Column::CmdLeftMps)?, value(Column::CmdRightMps)?),
        yaw_rad: optional(Column::YawRad).ok()?,
        pitch_deg: optional(Column::PitchDeg).ok()?,
        x_m: optional(Column::XM).ok()?,
        y_m: optional(Column::YM).ok()?,
    })
}

/// The cell starting at `start` of `bytes`: its number (`None`: empty) and the index of the
/// byte after it (its delimiter, or the end), as `str::parse::<f64>` reads the cell; `None`
/// overall for a cell that is not a number. The number is read straight from the bytes by
/// `fast_float2` (Clinger's fast path, else Eisel–Lemire, else exact big-decimal arithmetic:
/// correctly rounded, as `str::parse`, without its UTF-8 check and split); where it stops
/// before a delimiter (a stray byte, an exponent cut short) `str::parse` judges the cell.
fn parse_cell(bytes: &[u8], start: usize) -> Option<(Option<f64>, usize)> {
    let rest = bytes.get(start..)?;
    if matches!(rest.first(), None | Some(b',' | b'\n')) {
        return Some((None, start));
    }
    if let Ok((value, n)) = fast_float2::parse_partial::<f64, _>(rest) {
        if matches!(rest.get(n), None | Some(b',' | b'\n')) {
            return Some((Some(value), start + n));
        }
    }
    slow_cell(bytes, start)
}

/// A cell the fast path does not read: up to its delimiter, by `str::parse`.
fn slow_cell(bytes: &[u8], start: usize) -> Option<(Option<f64>, usize)> {
    let rest = &bytes[start..];
    let end = start + memchr::memchr2(b',', b'\n', rest).unwrap_or(rest.len());
    Some((Some(slow(&bytes[start..end])?), end))
}

/// A cell's number as [`parse_cell`] reads it, for the tests.
#[cfg(test)]
fn parse_number(cell: &[u8]) -> Option<f64> {
    match parse_cell(cell, 0)? {
        (value, end) if end == cell.len() => value,
        _ => None,
    }
}

fn slow(cell: &[u8]) -> Option<f64> {
    std::str::from_utf8(cell).ok()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn numbers_read_as_str_parse_reads_them() {
        for text in [
            "0",
            "-0",
            "1",
            "-1",
            "24.61375",
            "0.0005",
            "-16.384",
            "40.96",
            "123456789012345",
            "1234567890123456789",
            "0.1",
            "3.0000000000000004e-9",
            "1e308",
            ".5",
            "5.",
            "+1",
            "1.7976931348623157e308",
            "0.30000000000000004",
            "inf",
            "NaN",
            // Negative zero, 2⁵³ ± 1 and halfway between doubles, 19 and 20+ digits, the
            // smallest normal and subnormal, overflow and underflow, exponents of every form.
            "-0.0",
            "-0e5",
            "0.000",
            "9007199254740991",
            "9007199254740993",
            "9007199254740992.5",
            "9007199254740993.0000000000000001",
            "4503599627370496.5",
            "4503599627370497.5",
            "9999999999999999999",
            "18446744073709551615",
            "18446744073709551616",
            "99999999999999999999.5",
            "0.10000000000000000555111512312578270211815834045410156250",
            "2.2250738585072011e-308",
            "2.2250738585072014e-308",
            "4.9406564584124654e-324",
            "2.4703282292062327e-324",
            "2.4703282292062328e-324",
            "1e-400",
            "1e309",
            "-1e309",
            "1E5",
            "1e+5",
            "1.5e-3",
            "-103.50905522591594",
            "0.0013172703733747985",
            "infinity",
            "-inf",
            "+inf",
            "nan",
            "-NaN",
        ] {
            let want: Option<f64> = text.parse().ok();
            let got = parse_number(text.as_bytes());
            assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "{text}");
        }
        for bad in [
            "", "-", ".", "1..2", "1,2", "1 ", " 1", "abc", "--1", "1e", "1e+", "1.5e-", "e5",
            "0x10", "1_000", "infin", "nana", "+-1", "1-", "١",
        ] {
            assert_eq!(
                parse_number(bad.as_bytes()),
                bad.parse::<f64>().ok(),
                "{bad:?}"
            );
        }
    }

    proptest! {
        /// Random cells of every shape a run CSV may hold: signs, 1 to 25 digits with the
        /// point anywhere (or none), an optional exponent of either case and sign.
        #[test]
        fn any_numeric_cell_reads_as_str_parse_reads_it(
            sign in prop::sample::select(vec!["", "-", "+"]),
            digits in "[0-9]{1,25}",
            point in 0usize..27,
            exponent in prop::option::of((prop::sample::select(vec!["e", "E"]), prop::sample::select(vec!["", "-", "+"]), 0u32..400)),
        ) {
            let mut text = format!("{sign}{digits}");
            if point <= digits.len() {
                text.insert(sign.len() + point, '.');
            }
            if let Some((e, esign, value)) = exponent {
                text.push_str(&format!("{e}{esign}{value}"));
            }
            let want: Option<f64> = text.parse().ok();
            prop_assert_eq!(parse_number(text.as_bytes()).map(f64::to_bits), want.map(f64::to_bits), "{}", text);
        }

        /// Decimals at and next to the exact halfway point between two adjacent doubles (the
        /// hardest to round): x = m·2^(p−52) with a 53-bit m; the midpoint (2m+1)·2^(p−53) is
        /// (2m+1)·5^k / 10^k with k = 53 − p, written out exactly (k ≤ 31 keeps it in 128
        /// bits), then as is (a tie: to even), cut in its last place (below) or with a digit
        /// added (above).
        #[test]
        fn halfway_decimals_read_as_str_parse_reads_them(m in (1u64 << 52)..(1u64 << 53), p in 22u32..=52, how in 0u8..3) {
            let k = 53 - p;
            let n = u128::from(2 * m + 1) * 5u128.pow(k);
            let digits = n.to_string();
            let (int, frac) = digits.split_at(digits.len() - k as usize);
            let exact = format!("{int}.{frac}");
            let text = match how {
                0 => exact,
                1 => exact[..exact.len() - 1].to_owned(),
                _ => format!("{exact}1"),
            };
            let want: Option<f64> = text.parse().ok();
            prop_assert_eq!(parse_number(text.as_bytes()).map(f64::to_bits), want.map(f64::to_bits), "{}", text);
        }

        #[test]
        fn long_decimals_read_bit_for_bit(int in 0u64..1000, frac in 0u64..u64::MAX, neg: bool, digits in 14usize..20) {
            let frac = frac % 10u64.pow(u32::try_from(digits).unwrap_or(19).min(19));
            let text = format!("{}{int}.{frac:0digits$}", if neg { "-" } else { "" });
            let want: Option<f64> = text.parse().ok();
            prop_assert_eq!(parse_number(text.as_bytes()).map(f64::to_bits), want.map(f64::to_bits), "{}", text);
        }

        #[test]
        fn any_decimal_reads_bit_for_bit(int in 0u64..10_000_000, frac in 0u64..100_000_000, neg: bool, digits in 0usize..12) {
            let text = format!("{}{int}.{frac:0digits$}", if neg { "-" } else { "" });
            let want: f64 = text.parse().expect("decimal");
            prop_assert_eq!(parse_number(text.as_bytes()).map(f64::to_bits), Some(want.to_bits()), "{}", text);
        }

        #[test]
        fn any_f64_reads_bit_for_bit(x in any::<f64>().prop_filter("finite", |x| x.is_finite())) {
            let text = x.to_string();
            prop_assert_eq!(parse_number(text.as_bytes()).map(f64::to_bits), Some(x.to_bits()));
        }
    }
}
