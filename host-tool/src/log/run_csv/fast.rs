//! The fast path of [`super::read_run_csv_salvaging`] for files in this tool's own layout (the
//! header [`RunCsvWriter`](super::RunCsvWriter) writes, no quotes, LF line ends, the last line
//! ended): the file is cut at line ends into one part per core, each part read and parsed on
//! its own thread in blocks (a block's bytes are parsed while they are in the cache, and no
//! buffer of the whole file is allocated) straight from the bytes: no per-row allocation, one
//! pass over the bytes, decimals by Clinger's exact fast path (or, past 2⁵³, an exact 128-bit
//! integer division), anything else by `str::parse`.
//! It gives the same samples as the general reader or gives up: on the first cell, row or
//! layout it does not accept it returns `None`, and the general reader reads the file and
//! words the error (or drops the cut row) exactly as before.

use super::{Column, RunSample};
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

/// The samples of the run CSV at `path` if it is valid, in this tool's layout and at most
/// `max_bytes` long, read in blocks of `block` bytes; `Ok(None)` otherwise (see the module
/// docs).
pub(super) fn read_file(
    path: &Path,
    block: usize,
    max_bytes: u64,
) -> io::Result<Option<Vec<RunSample>>> {
    let mut file = File::open(path)?;
    let metadata = file.metadata()?;
    if !metadata.is_file() {
        // A pipe or a device: read once, by the general reader.
        return Ok(None);
    }
    let len = metadata.len();
    if len > max_bytes {
        return Ok(None);
    }
    let mut head = Vec::new();
    (&mut file).take(4096).read_to_end(&mut head)?;
    let Some(header_end) = memchr::memchr(b'\n', &head) else {
        return Ok(None);
    };
    let Some(columns) = layout(&head[..header_end]) else {
        return Ok(None);
    };
    let data_start = header_end as u64 + 1;
    let Some(data_len) = len.checked_sub(data_start) else {
        // The file shrank under us: the general reader reads what is there.
        return Ok(None);
    };
    if data_len > 0 {
        // The last line must be ended (a cut one is the general reader's to drop).
        let mut last = [0u8];
        file.seek(SeekFrom::Start(len - 1))?;
        file.read_exact(&mut last)?;
        if last[0] != b'\n' {
            return Ok(None);
        }
    }
    // A row of this tool's layout is at least 40 bytes: a close upper bound on the rows, so
    // the samples are never moved while growing.
    let capacity = usize::try_from(data_len / 40 + 1).unwrap_or(0);
    let mut reader = PartReader {
        columns,
        block,
        previous_t_s: f64::NEG_INFINITY,
        buf: Vec::with_capacity(2 * block),
    };
    if data_len < PARALLEL_BYTES {
        let mut samples = Vec::with_capacity(capacity);
        let ok = reader.read(&mut file, data_start, len, false, &mut samples)?;
        return Ok(ok.then_some(samples));
    }
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get().min(8));
    let job = 4 * block as u64;
    let jobs = data_len.div_ceil(job);
    let bounds = |j: u64| data_start + (j * job).min(data_len);
    let assembly = Assembly::new(capacity);
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

/// The samples of the parallel reader's jobs, appended in file order by the thread that read
/// each job as soon as its turn comes (so a job's rows are copied while they are in that
/// core's cache, and the next job is read meanwhile on the other core).
struct Assembly {
    state: Mutex<Assembled>,
    turn: Condvar,
}

struct Assembled {
    samples: Vec<RunSample>,
    /// The job whose rows come next.
    next: u64,
    /// A job was not in this tool's layout (or could not be read): the result is `None`.
    failed: bool,
}

impl Assembly {
    fn new(capacity: usize) -> Self {
        Self {
            state: Mutex::new(Assembled {
                samples: Vec::with_capacity(capacity),
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
            match (state.samples.last(), rows.first()) {
                (Some(last), Some(first)) => first.t_s > last.t_s,
                _ => true,
            }
        };
        match rows {
            Some(rows) if !state.failed && seamless(rows) => {
                state.samples.extend_from_slice(rows);
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

    fn finish(self) -> Option<Vec<RunSample>> {
        let state = self.state.into_inner().ok()?;
        (!state.failed).then_some(state.samples)
    }
}

/// Fails the [`Assembly`] if its thread unwinds.
struct FailOnPanic<'a>(&'a Assembly);

impl Drop for FailOnPanic<'_> {
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
            if parse_lines(&buf[from..stop], self.columns, &mut self.previous_t_s, out).is_none() {
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

/// Whole lines of `columns` cells each into samples appended to `out`, their times after
/// `previous_t_s` and increasing (which is updated); `None` on anything the general reader
/// would refuse or treat specially. One pass over the bytes: each cell is parsed where it
/// starts and its number's end is its delimiter (no line or cell split before parsing).
fn parse_lines(
    part: &[u8],
    columns: usize,
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
        let sample = row_sample(&cells, columns)?;
        if sample.t_s <= *previous_t_s {
            return None;
        }
        *previous_t_s = sample.t_s;
        out.push(sample);
    }
    Some(())
}

/// The sample of one row's cells, checked as the general reader checks them.
fn row_sample(cells: &[Option<f64>; Column::ALL.len()], columns: usize) -> Option<RunSample> {
    let value = |column: Column| -> Option<f64> {
        let v = cells[column as usize]?;
        let in_range = column.range().is_none_or(|(lo, hi)| v >= lo && v <= hi);
        (v.is_finite() && in_range).then_some(v)
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

/// Exact powers of ten as `f64` (10²² is the largest one a double holds exactly).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Largest integer every smaller one of which a double holds exactly (2⁵³).
const EXACT_INT: u64 = 1 << 53;

/// The cell starting at `start` of `bytes`: its number (`None`: empty) and the index of the
/// byte after it (its delimiter, or the end), as `str::parse::<f64>` reads the cell. Plain
/// decimals (`-12.345`) whose digits make an integer below 2⁵³ with at most 22 after the point
/// take Clinger's fast path — an integer and a power of ten, both exact as doubles, divided
/// once, so correctly rounded like `str::parse` —, those of up to 19 digits above 2⁵³ take
/// [`exact_quotient`], and everything else (more digits, exponents, `NaN`) goes to
/// `str::parse`. `None` overall for a cell that is not a number.
fn parse_cell(bytes: &[u8], start: usize) -> Option<(Option<f64>, usize)> {
    let mut i = start;
    let negative = bytes.get(i) == Some(&b'-');
    if negative {
        i += 1;
    }
    // 19 digits never overflow; longer ones take the general parser below.
    let mut mantissa: u64 = 0;
    let int_start = i;
    i = digits_into(bytes, i, &mut mantissa);
    let mut digits = i - int_start;
    let mut fraction = 0;
    if bytes.get(i) == Some(&b'.') {
        i += 1;
        let fraction_start = i;
        i = digits_into(bytes, i, &mut mantissa);
        fraction = i - fraction_start;
        digits += fraction;
    }
    match bytes.get(i) {
        None | Some(b',' | b'\n') => {}
        // An exponent, `NaN`, `inf`, a stray byte: the general parser decides.
        Some(_) => return slow_cell(bytes, start),
    }
    if i == start {
        return Some((None, i));
    }
    if digits == 0 || digits > 19 || fraction >= POW10.len() {
        return Some((Some(slow(&bytes[start..i])?), i));
    }
    let value = if mantissa <= EXACT_INT {
        mantissa as f64 / POW10[fraction]
    } else {
        match exact_quotient(mantissa, fraction) {
            Some(v) => v,
            None => return Some((Some(slow(&bytes[start..i])?), i)),
        }
    };
    Some((Some(if negative { -value } else { value }), i))
}

/// The decimal digits of `bytes` from `i` on appended to `mantissa` (wrapping), eight at a
/// time while eight are there (SWAR: one 64-bit load, checked and converted with a few
/// multiplications), then one by one; returns the index after the last digit.
fn digits_into(bytes: &[u8], mut i: usize, mantissa: &mut u64) -> usize {
    while let Some(chunk) = bytes
        .get(i..i + 8)
        .and_then(|c| <[u8; 8]>::try_from(c).ok())
    {
        let v = u64::from_le_bytes(chunk);
        if !eight_digits(v) {
            break;
        }
        *mantissa = mantissa
            .wrapping_mul(100_000_000)
            .wrapping_add(eight_digits_value(v));
        i += 8;
    }
    while let Some(&b) = bytes.get(i) {
        let d = b.wrapping_sub(b'0');
        if d >= 10 {
            break;
        }
        *mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
        i += 1;
    }
    i
}

/// Whether all eight bytes of `v` (little-endian) are ASCII digits.
fn eight_digits(v: u64) -> bool {
    const HIGH: u64 = 0xF0F0_F0F0_F0F0_F0F0;
    ((v & HIGH) | ((v.wrapping_add(0x0606_0606_0606_0606) & HIGH) >> 4)) == 0x3333_3333_3333_3333
}

/// The number the eight ASCII digits of `v` (little-endian: first digit in the low byte) write.
fn eight_digits_value(v: u64) -> u64 {
    const MASK: u64 = 0x0000_00FF_0000_00FF;
    const MUL1: u64 = 100 + (1_000_000 << 32);
    const MUL2: u64 = 1 + (10_000 << 32);
    let v = v.wrapping_sub(0x3030_3030_3030_3030);
    let v = v.wrapping_mul(10).wrapping_add(v >> 8);
    (v & MASK)
        .wrapping_mul(MUL1)
        .wrapping_add(((v >> 16) & MASK).wrapping_mul(MUL2))
        >> 32
}

/// `mantissa` / 10^`fraction` correctly rounded (to nearest, ties to even) for a mantissa above
/// 2⁵³ (17 to 19 digits, where Clinger's path is not exact), by integer arithmetic: the
/// quotient to 54+ bits in 128-bit integers, its remainder as the sticky bit. `None` when
/// 10^`fraction` does not fit in 64 bits (the general parser takes those).
fn exact_quotient(mantissa: u64, fraction: usize) -> Option<f64> {
    let divisor = 10u64.checked_pow(u32::try_from(fraction).ok()?)?;
    // mantissa < 2⁶⁴ and divisor < 2⁶⁴: mantissa · 2⁶⁴ fits, and the quotient has at least
    // 54 bits (mantissa > 2⁵³, divisor ≤ 10¹⁹ < 2⁶⁴).
    let scaled = u128::from(mantissa) << 64;
    let q = scaled / u128::from(divisor);
    let sticky = scaled % u128::from(divisor) != 0;
    let bits = 128 - q.leading_zeros();
    let drop = bits.checked_sub(53).filter(|&d| d > 0)?;
    let kept = q >> drop;
    let rest = q & ((1u128 << drop) - 1);
    let half = 1u128 << (drop - 1);
    let round_up = rest > half || (rest == half && (sticky || kept & 1 == 1));
    let kept = u64::try_from(kept + u128::from(round_up)).ok()?;
    // kept ≤ 2⁵³: exact as f64; the power of two 2^(drop − 64) (drop ≤ 75) is built from its
    // bits and scales exactly (no overflow or underflow for these magnitudes).
    let scale = f64::from_bits(u64::from(1023 + drop - 64) << 52);
    Some(kept as f64 * scale)
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
        ] {
            let want: Option<f64> = text.parse().ok();
            let got = parse_number(text.as_bytes());
            assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "{text}");
        }
        for bad in ["", "-", ".", "1..2", "1,2", "1 ", "abc", "--1"] {
            assert_eq!(
                parse_number(bad.as_bytes()),
                bad.parse::<f64>().ok(),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn eight_digits_at_once() {
        for text in ["00000000", "12345678", "99999999", "40960000", "00000001"] {
            let v = u64::from_le_bytes(text.as_bytes().try_into().expect("8 bytes"));
            assert!(eight_digits(v), "{text}");
            assert_eq!(eight_digits_value(v), text.parse::<u64>().expect("digits"));
        }
        for text in [
            "1234567.", "/2345678", ":2345678", "1234567:", "-1234567", "1234 678",
        ] {
            let v = u64::from_le_bytes(text.as_bytes().try_into().expect("8 bytes"));
            assert!(!eight_digits(v), "{text}");
        }
    }

    proptest! {
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
