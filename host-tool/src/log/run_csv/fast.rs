//! The fast path of [`super::read_run_csv_salvaging`] for files in this tool's own layout (the
//! header [`RunCsvWriter`](super::RunCsvWriter) writes, no quotes, LF line ends, the last line
//! ended): the file is split at a line end into one part per core, each part parsed on its own
//! thread straight from the bytes (no per-row allocation; one pass over the bytes; decimals by Clinger's exact fast
//! path, anything else by `str::parse`). It gives the same samples as the general reader or gives up:
//! on the first cell, row or layout it does not accept it returns `None`, and the general reader
//! reads the file and words the error (or drops the cut row) exactly as before.

use super::{Column, RunSample};
use model_core::Sides;

/// Smallest file worth a second thread [bytes].
const PARALLEL_BYTES: usize = 1 << 20;

/// Columns up to `pitch_deg` (the layout before the tracked point's `x_m,y_m`).
const WITH_POSE_ANGLES: usize = 9;

/// The samples of a valid run CSV in this tool's layout, or `None` (see the module docs).
pub(super) fn read(bytes: &[u8]) -> Option<Vec<RunSample>> {
    let header_end = memchr::memchr(b'\n', bytes)?;
    // The layouts this tool writes: every column, without the tracked point's, the required.
    let columns = match &bytes[..header_end] {
        h if h == header(&Column::ALL).as_bytes() => Column::ALL.len(),
        h if h == header(&Column::ALL[..WITH_POSE_ANGLES]).as_bytes() => WITH_POSE_ANGLES,
        h if h == header(&Column::REQUIRED).as_bytes() => Column::REQUIRED.len(),
        _ => return None,
    };
    let data = &bytes[header_end + 1..];
    if data.last().is_some_and(|&b| b != b'\n') || memchr::memchr(b'"', data).is_some() {
        return None;
    }
    let threads = if data.len() < PARALLEL_BYTES {
        1
    } else {
        std::thread::available_parallelism().map_or(1, |n| n.get().min(8))
    };
    let parts = split_at_lines(data, threads);
    let mut results: Vec<Option<Vec<RunSample>>> = if parts.len() == 1 {
        vec![parse_part(parts[0], columns)]
    } else {
        std::thread::scope(|s| {
            let handles: Vec<_> = parts
                .iter()
                .map(|part| s.spawn(move || parse_part(part, columns)))
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().ok().flatten())
                .collect()
        })
    };
    let mut samples = results.first_mut()?.take()?;
    for part in results.into_iter().skip(1) {
        let part = part?;
        // Time must increase across the parts' seam too.
        if let (Some(last), Some(first)) = (samples.last(), part.first()) {
            if first.t_s <= last.t_s {
                return None;
            }
        }
        samples.extend_from_slice(&part);
    }
    Some(samples)
}

fn header(columns: &[Column]) -> String {
    columns
        .iter()
        .map(|c| c.name())
        .collect::<Vec<_>>()
        .join(",")
}

/// `data` cut into up to `n` parts of whole lines.
fn split_at_lines(data: &[u8], n: usize) -> Vec<&[u8]> {
    let mut parts = Vec::with_capacity(n);
    let mut rest = data;
    for k in (1..n).rev() {
        let target = rest.len() / (k + 1);
        match memchr::memchr(b'\n', &rest[target..]) {
            Some(i) if target + i + 1 < rest.len() => {
                let (part, tail) = rest.split_at(target + i + 1);
                parts.push(part);
                rest = tail;
            }
            _ => break,
        }
    }
    parts.push(rest);
    parts
}

/// Whole lines of `columns` cells each into samples; `None` on anything the general reader
/// would refuse or treat specially. One pass over the bytes: each cell is parsed where it
/// starts and its number's end is its delimiter (no line or cell split before parsing).
fn parse_part(part: &[u8], columns: usize) -> Option<Vec<RunSample>> {
    // A row of this tool's layout is at least 40 bytes: a close upper bound on the rows.
    let mut out = Vec::with_capacity(part.len() / 40 + 1);
    let mut cells = [None::<f64>; Column::ALL.len()];
    let mut previous_t_s = f64::NEG_INFINITY;
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
        if sample.t_s <= previous_t_s {
            return None;
        }
        previous_t_s = sample.t_s;
        out.push(sample);
    }
    Some(out)
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
/// once, so correctly rounded like `str::parse` — and everything else (more digits, exponents,
/// `NaN`) goes to `str::parse`. `None` overall for a cell that is not a number.
fn parse_cell(bytes: &[u8], start: usize) -> Option<(Option<f64>, usize)> {
    let mut i = start;
    let negative = bytes.get(i) == Some(&b'-');
    if negative {
        i += 1;
    }
    let mut mantissa: u64 = 0;
    let mut digits = 0usize;
    let mut fraction = 0usize;
    let mut point = false;
    while let Some(&b) = bytes.get(i) {
        let d = b.wrapping_sub(b'0');
        if d < 10 {
            // 19 digits never overflow; longer ones take the general parser below.
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
            digits += 1;
            fraction += usize::from(point);
        } else if b == b'.' && !point {
            point = true;
        } else {
            break;
        }
        i += 1;
    }
    match bytes.get(i) {
        None | Some(b',' | b'\n') => {}
        // An exponent, `NaN`, `inf`, a stray byte: the general parser decides.
        Some(_) => return slow_cell(bytes, start),
    }
    if i == start {
        return Some((None, i));
    }
    if digits == 0 || digits > 19 || mantissa > EXACT_INT || fraction >= POW10.len() {
        return Some((Some(slow(&bytes[start..i])?), i));
    }
    let value = mantissa as f64 / POW10[fraction];
    Some((Some(if negative { -value } else { value }), i))
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

    proptest! {
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

    #[test]
    fn lines_split_into_whole_lines() {
        let data = b"a\nbb\nccc\ndddd\n";
        for n in 1..6 {
            let parts = split_at_lines(data, n);
            assert_eq!(parts.concat(), data.to_vec());
            assert!(parts.iter().all(|p| p.ends_with(b"\n")), "{n}: {parts:?}");
        }
    }
}
