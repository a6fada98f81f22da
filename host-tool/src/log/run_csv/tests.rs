use super::*;
use crate::log::tests_support::TempDir;
use proptest::prelude::*;

const HEADER: &str =
    "t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,cmd_left_mps,cmd_right_mps";

fn read_all(text: &[u8]) -> Result<Vec<RunSample>, RunCsvError> {
    RunCsvReader::new(text)?.collect()
}

fn error_of(text: &str) -> String {
    match read_all(text.as_bytes()) {
        Ok(samples) => panic!("accepted: {samples:?}"),
        Err(e) => e.to_string(),
    }
}

fn sample(t_s: f64) -> RunSample {
    RunSample {
        t_s,
        bus_v: Sides::new(24.1, 24.0),
        current_a: Sides::new(3.5, -0.25),
        cmd_mps: Sides::new(0.1, 0.5),
        yaw_rad: None,
        pitch_deg: None,
        x_m: None,
        y_m: None,
    }
}

fn to_csv(samples: &[RunSample]) -> Vec<u8> {
    let mut w = RunCsvWriter::new(Vec::new()).expect("header");
    for s in samples {
        w.write(s).expect("valid sample");
    }
    w.into_inner().expect("flush")
}

#[test]
fn writer_output_is_the_documented_layout() {
    let mut s = sample(0.005);
    s.yaw_rad = Some(-0.5);
    let text = String::from_utf8(to_csv(&[sample(0.0), s])).expect("utf8");
    assert_eq!(
        text,
        format!(
            "{HEADER},yaw_rad,pitch_deg,x_m,y_m\n\
             0,24.1,3.5,24,-0.25,0.1,0.5,,,,\n\
             0.005,24.1,3.5,24,-0.25,0.1,0.5,-0.5,,,\n"
        )
    );
}

#[test]
fn required_columns_only_gives_no_yaw_or_pitch() {
    let text = format!("{HEADER}\n0,24,1,24.5,2,0.1,0.2\n0.01,24,1.5,24.5,2.5,0.1,0.2\n");
    let reader = RunCsvReader::new(text.as_bytes()).expect("header");
    assert!(!reader.has_yaw() && !reader.has_pitch());
    let samples: Vec<_> = reader.collect::<Result<_, _>>().expect("valid");
    assert_eq!(samples.len(), 2);
    assert_eq!(samples[1].current_a, Sides::new(1.5, 2.5));
    assert_eq!(samples[1].bus_v, Sides::new(24.0, 24.5));
    assert_eq!(samples[1].cmd_mps, Sides::new(0.1, 0.2));
    assert!(samples
        .iter()
        .all(|s| s.yaw_rad.is_none() && s.pitch_deg.is_none()));
}

#[test]
fn optional_columns_may_be_empty_per_row() {
    let text = format!(
        "pitch_deg,{HEADER},yaw_rad\n\
         1.5,0,24,1,24,2,0.1,0.2,0.25\n\
         ,1,24,1,24,2,0.1,0.2,\n\
         -2,2,24,1,24,2,0.1,0.2,\n"
    );
    let reader = RunCsvReader::new(text.as_bytes()).expect("header");
    assert!(reader.has_yaw() && reader.has_pitch());
    let samples: Vec<_> = reader.collect::<Result<_, _>>().expect("valid");
    let got: Vec<_> = samples.iter().map(|s| (s.yaw_rad, s.pitch_deg)).collect();
    assert_eq!(
        got,
        [(Some(0.25), Some(1.5)), (None, None), (None, Some(-2.0))]
    );
}

#[test]
fn extra_columns_are_ignored_whatever_they_hold() {
    let text = "note,t_s,left_bus_v,x,left_current_a,right_bus_v,right_current_a,cmd_left_mps,cmd_right_mps,note\n\
                hello,0,24,,1,24,2,0.1,0.2,\"a, quoted\"\n";
    let samples = read_all(text.as_bytes()).expect("valid");
    assert_eq!(samples.len(), 1);
    assert_eq!(samples[0].current_a, Sides::new(1.0, 2.0));
}

#[test]
fn bom_crlf_quotes_spaces_and_trailing_blank_lines() {
    let text = format!(
        "\u{feff}{HEADER},yaw_rad\r\n\
         0, 24 ,\"1\",24,2,0.1,0.2,0.5\r\n\
         \"0.5\",24,1,24,2,0.1,0.2,\"\"\r\n\
         \r\n\r\n"
    );
    let samples = read_all(text.as_bytes()).expect("valid");
    assert_eq!(samples.len(), 2);
    assert_eq!(samples[0].bus_v.left, 24.0);
    assert_eq!(samples[0].yaw_rad, Some(0.5));
    assert_eq!(samples[1].t_s, 0.5);
    assert_eq!(samples[1].yaw_rad, None);
}

#[test]
fn bom_crlf_error_lines_are_right() {
    let text = format!("\u{feff}{HEADER}\r\n0,24,1,24,2,0.1,0.2\r\n1,24,1,24,abc,0.1,0.2\r\n");
    assert_eq!(
        error_of(&text),
        "line 3, column 5 (right_current_a): \"abc\" is not a number"
    );
}

#[test]
fn no_header() {
    for text in ["", "\u{feff}", "\n\n", "\u{feff}\r\n\r\n"] {
        let e = read_all(text.as_bytes()).expect_err("empty");
        assert!(matches!(e, RunCsvError::NoHeader), "{text:?}: {e:?}");
    }
}

#[test]
fn missing_required_column_names_it_and_the_header_line() {
    let header = HEADER.replace(",cmd_left_mps", "");
    assert_eq!(
        error_of(&format!("{header}\n")),
        "line 1: missing required column `cmd_left_mps` in the header"
    );
    // A misspelt name is an extra column, so the real one is missing.
    let header = HEADER.replace("t_s", "time_s");
    assert_eq!(
        error_of(&format!("\n{header}\n")),
        "line 2: missing required column `t_s` in the header"
    );
}

#[test]
fn duplicate_known_column() {
    assert_eq!(
        error_of(&format!("{HEADER},left_bus_v\n")),
        "line 1: column `left_bus_v` appears twice in the header (columns 2 and 8)"
    );
}

#[test]
fn unparsable_number() {
    let text = format!("{HEADER}\n0,24,1,24,2,0.1,0.2\n0.1,24,abc,24,2,0.1,0.2\n");
    assert_eq!(
        error_of(&text),
        "line 3, column 3 (left_current_a): \"abc\" is not a number"
    );
}

#[test]
fn empty_required_cell() {
    let text = format!("{HEADER}\n0,24,1,24,2,,0.2\n");
    assert_eq!(
        error_of(&text),
        "line 2, column 6 (cmd_left_mps): empty cell in a required column"
    );
}

#[test]
fn nan_and_infinities() {
    for (cell, shown) in [
        ("NaN", "\"NaN\""),
        ("inf", "\"inf\""),
        ("-infinity", "\"-infinity\""),
        ("1e999", "\"1e999\""),
    ] {
        let text = format!("{HEADER},yaw_rad\n0,24,1,24,2,0.1,0.2,{cell}\n");
        assert_eq!(
            error_of(&text),
            format!("line 2, column 8 (yaw_rad): {shown} is not a finite number")
        );
    }
}

#[test]
fn time_must_strictly_increase() {
    let text = format!("{HEADER}\n0.5,24,1,24,2,0.1,0.2\n0.25,24,1,24,2,0.1,0.2\n");
    assert_eq!(
        error_of(&text),
        "line 3, column 1 (t_s): time 0.25 is not after the previous row's 0.5"
    );
    let text = format!("{HEADER}\n0.5,24,1,24,2,0.1,0.2\n0.5,24,1,24,2,0.1,0.2\n");
    assert_eq!(
        error_of(&text),
        "line 3, column 1 (t_s): time 0.5 is not after the previous row's 0.5"
    );
}

#[test]
fn rows_with_too_few_or_too_many_cells() {
    let text = format!("{HEADER}\n0,24,1,24,2,0.1\n");
    assert_eq!(error_of(&text), "line 2: row has 6 cells, the header has 7");
    let text = format!("{HEADER}\n0,24,1,24,2,0.1,0.2,9\n");
    assert_eq!(error_of(&text), "line 2: row has 8 cells, the header has 7");
}

#[test]
fn comment_lines_are_not_allowed() {
    let text = format!("{HEADER}\n# recorded on the Husky,24,1,24,2,0.1,0.2\n");
    assert_eq!(
        error_of(&text),
        "line 2, column 1 (t_s): \"# recorded on the Husky\" is not a number"
    );
}

#[test]
fn line_numbers_count_newlines_inside_quotes_and_blank_lines() {
    let text =
        format!("{HEADER},note\n0,24,1,24,2,0.1,0.2,\"two\nlines\"\n\n1,24,1,24,2,0.1,zz,\n");
    assert_eq!(
        error_of(&text),
        "line 5, column 7 (cmd_right_mps): \"zz\" is not a number"
    );
}

#[test]
fn long_bad_cells_are_cut_in_the_message() {
    let long = "x".repeat(100);
    let text = format!("{HEADER}\n{long},24,1,24,2,0.1,0.2\n");
    let msg = error_of(&text);
    assert!(msg.len() < 100, "{msg}");
    assert!(msg.contains(&format!("\"{}…\"", "x".repeat(40))), "{msg}");
}

#[test]
fn reader_stops_after_an_error() {
    let text = format!("{HEADER}\n0,24,1,24,2,0.1,x\n1,24,1,24,2,0.1,0.2\n");
    let mut reader = RunCsvReader::new(text.as_bytes()).expect("header");
    assert!(matches!(reader.next(), Some(Err(_))));
    assert!(reader.next().is_none());
}

#[test]
fn writer_refuses_what_the_reader_would_reject() {
    let mut w = RunCsvWriter::new(Vec::new()).expect("header");
    w.write(&sample(1.0)).expect("first");
    let e = w.write(&sample(1.0)).expect_err("same time");
    assert_eq!(
        e.to_string(),
        "line 3, column 1 (t_s): time 1 is not after the previous row's 1"
    );
    let mut bad = sample(2.0);
    bad.pitch_deg = Some(f64::NAN);
    let e = w.write(&bad).expect_err("NaN");
    assert_eq!(
        e.to_string(),
        "line 3, column 9 (pitch_deg): \"NaN\" is not a finite number"
    );
    assert_eq!(w.rows(), 1);
    let text = w.into_inner().expect("flush");
    assert_eq!(read_all(&text).expect("still valid"), [sample(1.0)]);
}

/// `n` valid rows whose `bad_row` (1-based data row) has an unparsable current.
fn csv_with_bad_row(n: usize, bad_row: usize) -> String {
    let mut text = format!("{HEADER}\n");
    for i in 1..=n {
        let current = if i == bad_row { "abc" } else { "1.25" };
        text.push_str(&format!("{},24,{current},24,2,0.1,0.2\n", i as f64 * 0.005));
    }
    text
}

#[test]
fn malformed_last_row_creates_no_output() {
    let dir = TempDir::new("run-csv-bad");
    let input = dir.path().join("in.csv");
    let output = dir.path().join("out.csv");
    std::fs::write(&input, csv_with_bad_row(1000, 1000)).expect("write input");
    let e = normalize_run_csv(&input, &output, Existing::Replace).expect_err("malformed");
    assert_eq!(
        e.to_string(),
        format!(
            "{}: line 1001, column 3 (left_current_a): \"abc\" is not a number",
            input.display()
        )
    );
    assert!(!output.exists());
    assert_eq!(dir.entries(), ["in.csv"], "no temporary file left behind");

    // An existing output keeps its content.
    std::fs::write(&output, b"previous").expect("write");
    normalize_run_csv(&input, &output, Existing::Replace).expect_err("malformed");
    assert_eq!(std::fs::read(&output).expect("read"), b"previous");
    assert_eq!(dir.entries(), ["in.csv", "out.csv"]);
}

#[test]
fn normalize_reorders_and_drops_extra_columns() {
    let dir = TempDir::new("run-csv-norm");
    let input = dir.path().join("in.csv");
    let output = dir.path().join("out.csv");
    let text = "\u{feff}cmd_right_mps,extra,right_current_a,right_bus_v,cmd_left_mps,left_current_a,left_bus_v,t_s\r\n\
                0.2,x,2,24.5,0.1,1,24,0\r\n\
                0.2,y,2.5,24.5,0.1,1.5,24,0.005\r\n";
    std::fs::write(&input, text).expect("write");
    assert_eq!(
        normalize_run_csv(&input, &output, Existing::Replace).expect("valid"),
        2
    );
    assert_eq!(
        std::fs::read_to_string(&output).expect("read"),
        format!(
            "{HEADER},yaw_rad,pitch_deg,x_m,y_m\n\
             0,24,1,24.5,2,0.1,0.2,,,,\n\
             0.005,24,1.5,24.5,2.5,0.1,0.2,,,,\n"
        )
    );
    assert_eq!(
        read_run_csv(&output).expect("readable"),
        read_run_csv(&input).expect("same")
    );
}

#[test]
fn write_atomically_then_read_back() {
    let dir = TempDir::new("run-csv-write");
    let path = dir.path().join("run.csv");
    let samples: Vec<_> = (0..100).map(|i| sample(f64::from(i) * 0.005)).collect();
    assert_eq!(
        write_run_csv_atomically(&path, Existing::Replace, &samples).expect("written"),
        100
    );
    assert_eq!(read_run_csv(&path).expect("read"), samples);

    let mut bad = samples.clone();
    bad[99].t_s = 0.0;
    let e = write_run_csv_atomically(&path, Existing::Replace, &bad).expect_err("time goes back");
    assert!(e.to_string().contains("line 101, column 1 (t_s)"), "{e}");
    assert_eq!(read_run_csv(&path).expect("old file intact"), samples);
    assert_eq!(dir.entries(), ["run.csv"]);
}

#[test]
fn missing_input_names_the_file() {
    let e = read_run_csv(Path::new("/nonexistent/run.csv")).expect_err("missing");
    assert!(e.to_string().starts_with("/nonexistent/run.csv: "), "{e}");
}

fn finite() -> impl Strategy<Value = f64> {
    prop_oneof![
        any::<f64>().prop_filter("finite", |x| x.is_finite()),
        -1e3..1e3f64,
        Just(0.0),
        Just(-0.0),
    ]
}

/// Any value in a range (the range checks refuse the rest), the board's limits among them.
fn within(lo: f64, hi: f64, board: f64) -> impl Strategy<Value = f64> {
    prop_oneof![lo..=hi, Just(lo), Just(hi), Just(0.0), -board..=board]
}

/// Rows of physical readings, some beyond the board's range.
fn samples() -> impl Strategy<Value = Vec<RunSample>> {
    let (bus, current) = (
        || {
            within(0.0, PHYSICAL_BUS_V_MAX, BUS_V_MAX)
                .prop_map(f64::abs)
                .boxed()
        },
        || {
            within(
                -PHYSICAL_CURRENT_A_MAX,
                PHYSICAL_CURRENT_A_MAX,
                CURRENT_A_MAX,
            )
            .boxed()
        },
    );
    let row = (
        1e-9..10.0f64,
        [
            bus(),
            current(),
            bus(),
            current(),
            finite().boxed(),
            finite().boxed(),
        ],
        proptest::option::of(finite()),
        proptest::option::of(finite()),
    );
    (-1e6..1e6f64, proptest::collection::vec(row, 0..40)).prop_map(|(t0, rows)| {
        let mut t = t0;
        let mut out = Vec::new();
        for (dt, [lv, la, rv, ra, cl, cr], yaw_rad, pitch_deg) in rows {
            let next = t + dt;
            if next <= t {
                continue; // dt lost to rounding at this magnitude
            }
            t = next;
            out.push(RunSample {
                t_s: t,
                bus_v: Sides::new(lv, rv),
                current_a: Sides::new(la, ra),
                cmd_mps: Sides::new(cl, cr),
                yaw_rad,
                pitch_deg,
                x_m: None,
                y_m: None,
            });
        }
        out
    })
}

fn same_bits(a: &RunSample, b: &RunSample) -> bool {
    let bits = |s: &RunSample| s.required_values().map(f64::to_bits);
    bits(a) == bits(b)
        && a.yaw_rad.map(f64::to_bits) == b.yaw_rad.map(f64::to_bits)
        && a.pitch_deg.map(f64::to_bits) == b.pitch_deg.map(f64::to_bits)
}

proptest! {
    #[test]
    fn round_trip_is_exact(samples in samples()) {
        let text = to_csv(&samples);
        let back = read_all(&text).expect("own output reads back");
        prop_assert_eq!(back.len(), samples.len());
        for (a, b) in samples.iter().zip(&back) {
            prop_assert!(same_bits(a, b), "{:?} != {:?}", a, b);
        }
    }

    #[test]
    fn any_column_order_with_extras_reads_the_same(
        order in Just((0..9usize).collect::<Vec<_>>()).prop_shuffle(),
        extras in proptest::collection::vec(0..10usize, 0..3),
        samples in samples(),
    ) {
        // Canonical text → cells per row → permuted columns with extra columns spliced in.
        let canonical = String::from_utf8(to_csv(&samples)).expect("utf8");
        let mut text = String::new();
        for (n, line) in canonical.lines().enumerate() {
            let cells: Vec<&str> = line.split(',').collect();
            let mut row: Vec<String> = order.iter().map(|&i| cells[i].to_owned()).collect();
            for (k, &at) in extras.iter().enumerate() {
                let at = at.min(row.len());
                row.insert(at, if n == 0 { format!("extra{k}") } else { format!("\"junk,{k}\"") });
            }
            text.push_str(&row.join(","));
            text.push_str("\r\n");
        }
        let back = read_all(text.as_bytes()).expect("permuted reads");
        prop_assert_eq!(back, samples);
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2000)) {
        if let Ok(reader) = RunCsvReader::new(&bytes[..]) {
            for _ in reader {}
        }
    }

    #[test]
    fn arbitrary_rows_under_a_valid_header_never_panic(
        tail in proptest::collection::vec(
            prop_oneof![
                Just(b','), Just(b'\n'), Just(b'\r'), Just(b'"'), Just(b'1'), Just(b'.'),
                Just(b'e'), Just(b'-'), Just(b' '), any::<u8>(),
            ],
            0..2000,
        )
    ) {
        let mut bytes = format!("{HEADER},yaw_rad\n").into_bytes();
        bytes.extend_from_slice(&tail);
        let reader = RunCsvReader::new(&bytes[..]).expect("valid header");
        for _ in reader {}
    }
}

#[test]
fn quoting_errors_have_line_and_column() {
    let text = format!("{HEADER}\n0,24,1,24,\"2\"x,0.1,0.2\n");
    assert_eq!(
        error_of(&text),
        "line 2, column 5: text after the closing quote of a cell"
    );
    let text = format!("{HEADER}\n0,24,1,24,2,0.1,0.2\n1,24,\"1\n,24,2,0.1,0.2\n");
    assert_eq!(
        error_of(&text),
        "line 3, column 3: quoted cell is never closed"
    );
}

#[test]
fn doubled_quotes_inside_a_quoted_extra_cell() {
    let text = format!("{HEADER},note\n0,24,1,24,2,0.1,0.2,\"say \"\"hi\"\", twice\"\n");
    assert_eq!(read_all(text.as_bytes()).expect("valid").len(), 1);
}

/// The fenced block of `lang` in the guide's file-formats page.
fn readme_block(lang: &str) -> &'static str {
    let readme = include_str!("../../../../docs/formats.md");
    let start = readme
        .find(&format!("```{lang}\n"))
        .map(|i| i + lang.len() + 4)
        .expect("block in README");
    let len = readme[start..].find("```").expect("closed block");
    &readme[start..start + len]
}

#[test]
fn readme_examples_are_valid() {
    let samples = read_all(readme_block("csv").as_bytes()).expect("docs/formats.md CSV");
    assert_eq!(samples.len(), 3);
    assert_eq!(samples[2].yaw_rad, None);
    assert_eq!(samples[1].current_a, Sides::new(1.18, 5.91));
    let rover = crate::rover::parse_rover(readme_block("toml")).expect("docs/formats.md TOML");
    assert_eq!(rover, model_core::Rover::HUSKY_A200);
}

#[test]
fn unquoted_and_quoted_rows_read_the_same_also_with_non_utf8_extra_cells() {
    // Unquoted rows take the reader's line fast path, quoted ones the general path; a byte that
    // is not UTF-8 in an ignored column must not spoil the other cells on either.
    let header = b"t_s,note,left_bus_v,left_current_a,right_bus_v,right_current_a,cmd_left_mps,cmd_right_mps,yaw_rad\n";
    let plain = [
        &header[..],
        b"0.5,caf\xe9, 24.5 ,1.5,24.25,-2,0.3,0.3,\n1,ok,24,1,24,1,0,0,0.25\n",
    ]
    .concat();
    let quoted = [
        &header[..],
        b"\"0.5\",\"caf\xe9\", 24.5 ,\"1.5\",24.25,-2,0.3,0.3,\n1,\"ok\",24,1,24,1,0,0,\"0.25\"\n",
    ]
    .concat();
    let a = read_all(&plain).expect("plain");
    let b = read_all(&quoted).expect("quoted");
    assert_eq!(a, b);
    assert_eq!(a.len(), 2);
    assert_eq!(a[0].bus_v.left, 24.5);
    assert_eq!(a[0].current_a.right, -2.0);
    assert_eq!(a[0].yaw_rad, None);
    assert_eq!(a[1].yaw_rad, Some(0.25));
    // A non-UTF-8 byte in a required cell is "not a number", with its line and column.
    let bad = [&header[..], b"0.5,x,24\xe9,1,24,1,0,0,\n"].concat();
    let e = read_all(&bad).expect_err("bad cell").to_string();
    assert!(e.starts_with("line 2, column 3 (left_bus_v):"), "{e}");
}

const HEADER_LF: &str =
    "t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,cmd_left_mps,cmd_right_mps\n";

fn read_text(text: &str, salvage: bool) -> Result<(Vec<RunSample>, Vec<DroppedRow>), RunCsvError> {
    let mut reader = RunCsvReader::new(text.as_bytes())?.salvaging(salvage);
    let rows = reader.by_ref().collect::<Result<Vec<_>, _>>()?;
    Ok((rows, reader.dropped().to_vec()))
}

#[test]
fn a_cut_last_row_is_dropped_with_its_line_and_damage_elsewhere_is_an_error() {
    let rows = "0,24,1,24,1,0.1,0.1\n0.01,24,1,24,1,0.1,0.1\n";
    let (got, dropped) = read_text(&format!("{HEADER_LF}{rows}0.02,24,1"), false).expect("cut");
    assert_eq!(got.len(), 2);
    assert_eq!(dropped.len(), 1);
    assert!(dropped[0].cut && dropped[0].line == 4, "{:?}", dropped[0]);
    assert!(
        dropped[0].reason.contains("row has 3 cells"),
        "{:?}",
        dropped[0]
    );
    // A complete last row without its newline is kept.
    let (got, dropped) =
        read_text(&format!("{HEADER_LF}{rows}0.02,24,1,24,1,0.1,0.1"), false).expect("whole");
    assert_eq!((got.len(), dropped.len()), (3, 0));
    // The same short row in the middle is damage: an error, or dropped with --salvage.
    let text = format!("{HEADER_LF}0,24,1,24,1,0.1,0.1\n0.01,24,1\n0.02,24,1,24,1,0.1,0.1\n");
    let e = read_text(&text, false).expect_err("damaged");
    assert_eq!(e.to_string(), "line 3: row has 3 cells, the header has 7");
    let (got, dropped) = read_text(&text, true).expect("salvaged");
    assert_eq!(got.len(), 2);
    assert!(!dropped[0].cut && dropped[0].line == 3, "{:?}", dropped[0]);
}

#[test]
fn unphysical_readings_are_errors_naming_line_and_column() {
    for (cells, column) in [
        ("0,24,1e308,24,1,0.1,0.1", "column 3 (left_current_a)"),
        ("0,3.4e38,1,24,1,0.1,0.1", "column 2 (left_bus_v)"),
        ("0,24,1,-0.5,1,0.1,0.1", "column 4 (right_bus_v)"),
        // Milliamperes and millivolts for amperes and volts.
        ("0,24,1,24,-3500,0.1,0.1", "column 5 (right_current_a)"),
        ("0,24000,1,24,1,0.1,0.1", "column 2 (left_bus_v)"),
    ] {
        let e = read_text(&format!("{HEADER_LF}{cells}\n"), false).expect_err(cells);
        let text = e.to_string();
        assert!(text.starts_with(&format!("line 2, {column}: ")), "{text}");
        assert!(
            text.contains(
                "outside any physical reading's range (bus 0 to 1000 V, current ±1000 A)"
            ),
            "{text}"
        );
    }
}

/// Issue 34 item 6: the run CSV is the interchange format for other rigs, whose readings go
/// beyond the board's range (an Argo J5 draws ≈ 20 A, a Hall sensor reads 50 A).
#[test]
fn other_rigs_readings_beyond_the_boards_range_are_read_by_default() {
    let text = format!(
        "{HEADER_LF}0,48,20,48,-16.5,0.1,0.1\n0.01,60,50,0,-1000,0.1,0.1\n0.02,1000,1000,0,0,0,0\n"
    );
    let (got, dropped) = read_text(&text, false).expect("another rig's readings");
    assert_eq!((got.len(), dropped.len()), (3, 0));
    assert_eq!(got[1].current_a, Sides::new(50.0, -1000.0));
    // The same through the fast path (a file in this tool's layout) and the writer.
    let dir = TempDir::new("other-rig");
    let path = dir.path().join("argo.csv");
    write_run_csv_atomically(&path, Existing::Replace, &got).expect("written");
    assert!(read_own_run_csv(&path, RigRange::default())
        .expect("read")
        .is_some_and(|own| own == got));
    assert_eq!(read_run_csv(&path).expect("read"), got);
}

#[test]
fn the_board_range_refuses_another_rigs_reading_naming_file_line_column_and_the_way_out() {
    let dir = TempDir::new("board-range");
    let own = dir.path().join("own.csv");
    let rows = [sample(0.0), sample(0.01), sample(0.02)];
    let mut argo = rows;
    argo[1].current_a.left = 20.0;
    write_run_csv_atomically(&own, Existing::Replace, &argo).expect("written");
    // A foreign layout too (columns reordered, CRLF): the general reader.
    let foreign = dir.path().join("foreign.csv");
    let text = String::from_utf8(to_csv(&argo)).expect("utf8");
    let swapped: Vec<String> = text
        .lines()
        .map(|l| {
            let mut cells: Vec<&str> = l.split(',').collect();
            cells.swap(0, 1);
            cells.join(",")
        })
        .collect();
    std::fs::write(&foreign, swapped.join("\r\n")).expect("written");
    for (path, column) in [(&own, 3), (&foreign, 3)] {
        assert_eq!(
            read_run_csv(path).expect("read by default")[1]
                .current_a
                .left,
            20.0
        );
        let e = read_run_csv_salvaging(path, false, RigRange::Board).expect_err("board range");
        assert_eq!(
            e.to_string(),
            format!(
                "{}: line 3, column {column} (left_current_a): 20 is outside the INA226 board's \
                 range (bus 0 to 40.96 V, current ±16.384 A), which --rig-range board holds the \
                 file to; for another rig's file leave the option out (any physical reading) or \
                 state that rig's range: --rig-range BUS_V,CURRENT_A",
                path.display()
            )
        );
        // A stated range: the rig's own.
        let hall = RigRange::parse("60,50").expect("a range");
        assert_eq!(
            read_run_csv_salvaging(path, false, hall)
                .expect("within 50 A")
                .0,
            read_run_csv(path).expect("read")
        );
        let tight = RigRange::parse("30,15").expect("a range");
        let e = read_run_csv_salvaging(path, false, tight).expect_err("beyond 15 A");
        assert!(
            e.to_string().ends_with(
                "20 is outside the rig's range stated by --rig-range 30,15 (bus 0 to 30 V, \
                 current ±15 A); widen it, or leave the option out (any physical reading)"
            ),
            "{e}"
        );
    }
    // Full scale is the board's.
    let (got, _) = read_text(
        &format!("{HEADER_LF}0,40.96,16.384,0,-16.384,0.1,0.1\n"),
        false,
    )
    .expect("full scale");
    let board = RunCsvReader::new(to_csv(&got).as_slice())
        .expect("header")
        .within(RigRange::Board)
        .collect::<Result<Vec<_>, _>>()
        .expect("full scale is within the board's range");
    assert_eq!(board, got);
}

proptest! {
    #![proptest_config(crate::log::tests_support::fuzz_config(128))]

    /// Damage rows anywhere: with salvage the reader keeps exactly the rows it did not touch
    /// (never an invented or altered one) and names every dropped line.
    #[test]
    fn salvage_keeps_the_untouched_rows(
        rows in samples(),
        hits in proptest::collection::vec(any::<prop::sample::Index>(), 0..4),
        cut in proptest::option::of(any::<prop::sample::Index>()),
    ) {
        let mut text = Vec::new();
        let mut writer = RunCsvWriter::new(&mut text).expect("header");
        for r in &rows {
            writer.write(r).expect("row");
        }
        writer.into_inner().expect("flushed");
        let header_end = text.iter().position(|&b| b == b'\n').expect("header") + 1;
        // A byte that is no digit, sign, point, comma or line end: any row it hits fails.
        for at in &hits {
            let span = text.len() - header_end;
            if span == 0 {
                break;
            }
            text[header_end + at.index(span)] = b'x';
        }
        if let Some(cut) = cut {
            let n = header_end + cut.index(text.len() - header_end + 1);
            text.truncate(n);
        }
        let mut reader = RunCsvReader::new(&text[..]).expect("header intact").salvaging(true);
        let got = reader.by_ref().collect::<Result<Vec<_>, _>>();
        let got = got.map_err(|e| TestCaseError::fail(format!("{e}")))?;
        // A cut may shorten the last number of a row that stays whole: that row is not checked.
        let checked = if cut.is_some() { got.len().saturating_sub(1) } else { got.len() };
        for g in &got[..checked] {
            prop_assert!(rows.iter().any(|r| same_bits(r, g)), "an altered row came back: {:?}", g);
        }
        let lost = rows.len() - got.len();
        prop_assert!(reader.dropped().len() >= lost.min(1) || cut.is_some());
        if hits.is_empty() && cut.is_none() {
            prop_assert_eq!(got.len(), rows.len());
            prop_assert!(reader.dropped().is_empty());
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// The parallel fast path gives the general reader's samples, bit for bit, or gives up.
    #[test]
    fn the_fast_path_reads_what_the_general_reader_reads(rows in samples(), copies in 1usize..4) {
        let mut text = Vec::new();
        let mut writer = RunCsvWriter::new(&mut text).expect("header");
        // Repeated with shifted times: files past the parallel threshold too.
        let span = rows.last().map_or(0.0, |r| r.t_s) - rows.first().map_or(0.0, |r| r.t_s) + 1.0;
        let mut all = Vec::new();
        for k in 0..copies * 12_000 / (rows.len() + 1) + 1 {
            for r in &rows {
                let shifted = RunSample { t_s: r.t_s + span * k as f64, ..*r };
                if all.last().is_none_or(|p: &RunSample| shifted.t_s > p.t_s) {
                    all.push(shifted);
                }
            }
        }
        for r in &all {
            writer.write(r).expect("row");
        }
        writer.into_inner().expect("flushed");
        let general = RunCsvReader::new(&text[..]).expect("header").collect::<Result<Vec<_>, _>>().expect("valid");
        let dir = crate::log::tests_support::TempDir::new("fast-path");
        let path = dir.path().join("run.csv");
        std::fs::write(&path, &text).expect("write");
        // Within the board's range the fast path reads the file iff the general reader does.
        let board = RunCsvReader::new(&text[..]).expect("header").within(RigRange::Board).collect::<Result<Vec<_>, _>>();
        let mut fast = Vec::new();
        let own = super::fast::read_file(&path, 4096, RigRange::Board, &mut |rows| fast.extend_from_slice(rows)).expect("read");
        prop_assert_eq!(own, board.is_ok());
        if let Ok(board) = board {
            prop_assert_eq!(fast, board);
        }
        // Small blocks too: rows cut by the block and part seams.
        for block in [super::fast::BLOCK_BYTES, 4096, 97] {
            // The visitor is handed every sample once, in file order.
            let mut fast = Vec::new();
            let own = super::fast::read_file(&path, block, RigRange::default(), &mut |rows| fast.extend_from_slice(rows)).expect("read");
            prop_assert!(own, "this tool's layout");
            prop_assert_eq!(fast.len(), general.len());
            for (a, b) in fast.iter().zip(&general) {
                prop_assert!(same_bits(a, b), "{:?} vs {:?}", a, b);
            }
        }
    }
}

#[test]
fn positions_read_back_nan_is_a_dropout_and_the_pair_is_required() {
    let text = format!(
        "{HEADER},y_m,x_m\n0,24.1,3.5,24,-0.25,0.1,0.5,2.5,-1\n\
         0.005,24.1,3.5,24,-0.25,0.1,0.5,NaN,nan\n0.01,24.1,3.5,24,-0.25,0.1,0.5,,\n"
    );
    let samples: Vec<RunSample> = RunCsvReader::new(text.as_bytes())
        .expect("header")
        .collect::<Result<_, _>>()
        .expect("valid");
    assert_eq!(samples[0].position_m(), Some((-1.0, 2.5)));
    assert_eq!((samples[1].x_m, samples[1].y_m), (None, None));
    assert_eq!(samples[2].position_m(), None);
    let back = String::from_utf8(to_csv(&samples)).expect("utf8");
    assert!(
        back.lines().nth(1).expect("row").ends_with(",-1,2.5"),
        "{back}"
    );
    // NaN stays an error in the other columns.
    let bad = format!("{HEADER},yaw_rad\n0,24.1,3.5,24,-0.25,0.1,0.5,NaN\n");
    let e = RunCsvReader::new(bad.as_bytes())
        .expect("header")
        .next()
        .expect("row")
        .expect_err("NaN yaw");
    assert!(e.to_string().contains("yaw_rad"), "{e}");
    let alone = format!("{HEADER},x_m\n");
    let e = RunCsvReader::new(alone.as_bytes()).expect_err("x without y");
    assert_eq!(
        e.to_string(),
        "line 1: column `x_m` needs column `y_m` in the header too"
    );
}

#[test]
fn the_parallel_fast_path_leaves_damage_anywhere_to_the_general_reader() {
    // Past the parallel threshold; blocks of 97 bytes put job seams every 388 bytes, so a
    // time going back lands inside jobs and on their seams.
    let rows: Vec<String> = (0..40_000)
        .map(|i| format!("{},24.005,1.25,23.995,-0.5,0.3,-0.3", f64::from(i) * 0.005))
        .collect();
    let dir = TempDir::new("fast-damage");
    let path = dir.path().join("run.csv");
    for (at, bad) in [
        (20_000, "50,24,1,24,2,0.1,0.2"),
        (39_980, "199.9,24,1,24,abc,0.1,0.2"),
        (1, "0,24,1,24,2,0.1,0.2"),
    ] {
        for k in [at, at + 3, at + 7, at + 11] {
            let mut rows = rows.clone();
            if let Some(row) = rows.get_mut(k) {
                *row = bad.to_owned();
            }
            let text = format!("{HEADER}\n{}\n", rows.join("\n"));
            std::fs::write(&path, &text).expect("write");
            for block in [super::fast::BLOCK_BYTES, 97] {
                let fast = super::fast::read_file(&path, block, RigRange::default(), &mut |_| {})
                    .expect("read");
                assert!(!fast, "row {k} ({bad}) passed the fast path");
            }
            let general = RunCsvReader::new(text.as_bytes())
                .expect("header")
                .collect::<Result<Vec<_>, _>>();
            let e = read_run_csv(&path).expect_err("damaged");
            assert_eq!(
                e.source.to_string(),
                general.expect_err("damaged").to_string()
            );
        }
    }
    // Undamaged, the same file takes the fast path.
    std::fs::write(&path, format!("{HEADER}\n{}\n", rows.join("\n"))).expect("write");
    let mut fast = 0;
    let own = super::fast::read_file(&path, 97, RigRange::default(), &mut |rows| {
        fast += rows.len()
    })
    .expect("read");
    assert!(own, "the fast path");
    assert_eq!(fast, rows.len());
}
