//! `convert`: a run log from one format to another (or the same one, normalised), by the files'
//! extensions. Outputs are written whole or not at all ([`super::write_atomically`]).
//!
//! - MCAP → run CSV: the physical samples (with commanded speeds and pose); frames, commands
//!   and events have no place in a run CSV and are dropped.
//! - run CSV → MCAP: the samples exactly on `/rover_power/sample_batch`, plus the wire frames the
//!   board would have sent for them ([`crate::log::synthesis::synthesise_frames`]: a hello, sample
//!   frames with the registers quantised at `Scale::BOARD` — 1.25 mV, 0.5 mA — and model
//!   frames, and the board's status report of the commanded wheel rates wherever `cmd_*`
//!   changes, on the Husky's wheels as `record` assumes), so the file replays like a recording;
//!   and the recorder's events from the CSV's events file (`RUN.events.jsonl`) when it is there.
//! - MCAP → MCAP: a clean, finished copy (also the way to repair a file cut short by a killed
//!   recorder: everything before the cut is kept, with a summary and footer; or a damaged one:
//!   everything outside the damage is kept, and [`Converted::losses`] says what was not).
//! - run CSV → run CSV: this tool's canonical column order and number format.

use super::load::{load_salvaging, LoadError, RunFormat};
use super::mcap::{write_mcap_run, Loss, McapError, Truncation};
use super::run_csv::{write_run_csv_atomically, RunCsvFileError};
use super::run_csv::{DroppedRow, RigRange};
use super::run_log::RunLog;
use super::{write_atomically, AtomicWriteError, Existing};
use std::path::{Path, PathBuf};

/// Why a conversion produced no output.
#[derive(Debug, thiserror::Error)]
pub enum ConvertError {
    /// The output is the input file.
    #[error("{}: the output is the input file; choose another output", path.display())]
    SameFile {
        /// The file.
        path: PathBuf,
    },
    /// The input could not be loaded, or a file's extension names no known format.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// Writing the run CSV failed.
    #[error(transparent)]
    Csv(#[from] RunCsvFileError),
    /// Creating, syncing or placing the output file failed (a file that appeared there
    /// meanwhile is kept: see [`Existing::Keep`]).
    #[error("{}: {source}", path.display())]
    Io {
        /// The output file (or the temporary file beside it).
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Writing the MCAP file failed.
    #[error("{}: {source}", path.display())]
    Mcap {
        /// The output file.
        path: PathBuf,
        /// Why.
        #[source]
        source: McapError,
    },
}

/// What a conversion did.
#[derive(Debug, Clone, PartialEq)]
pub struct Converted {
    /// The input's format.
    pub from: RunFormat,
    /// The output's format.
    pub to: RunFormat,
    /// Samples written.
    pub samples: usize,
    /// Wire frames written (0 for a run CSV).
    pub frames: usize,
    /// Whether the frames were synthesised from the samples (CSV input).
    pub synthesised_frames: bool,
    /// The input MCAP file was cut short here; the output holds what came before.
    pub truncated: Option<Truncation>,
    /// Stretches of a damaged input MCAP file that were skipped; the output holds the rest.
    pub losses: Vec<Loss>,
    /// Rows of the input run CSV left out (a cut last row; damaged rows with salvage).
    pub dropped_rows: Vec<DroppedRow>,
}

/// Writes `run` to `path` in the format its extension names, all or nothing. A run CSV keeps
/// the samples only. `existing`: what to do with a file at `path` when it is written
/// ([`Existing`]).
pub fn save_run(path: &Path, existing: Existing, run: &RunLog) -> Result<RunFormat, ConvertError> {
    let format = RunFormat::of_name(path)?;
    match format {
        RunFormat::Csv => {
            write_run_csv_atomically(path, existing, &run.samples)?;
        }
        RunFormat::Mcap => {
            write_atomically(path, existing, |out| write_mcap_run(out, run).map(|_| ())).map_err(
                |e| match e {
                    AtomicWriteError::Io { source, path } => ConvertError::Io { path, source },
                    AtomicWriteError::Content { source, .. } => ConvertError::Mcap {
                        path: path.to_owned(),
                        source,
                    },
                },
            )?;
        }
    }
    Ok(format)
}

/// Converts the run log `input` into `output` (formats by extension, see the module docs).
/// Refuses to write over the input; leaves `output` untouched on any error, and fails rather
/// than replace a file that appears there meanwhile.
pub fn convert(input: &Path, output: &Path) -> Result<Converted, ConvertError> {
    convert_salvaging(input, output, false, Existing::Keep)
}

/// [`convert`]; with `salvage`, damaged rows of an input run CSV are left out instead of
/// refused (a damaged MCAP input is always salvaged). An input run CSV may hold any physical
/// reading, but only the board's range ([`RigRange::BoardStream`]) into MCAP, whose frames
/// hold the board's registers.
pub fn convert_salvaging(
    input: &Path,
    output: &Path,
    salvage: bool,
    existing: Existing,
) -> Result<Converted, ConvertError> {
    let to = RunFormat::of_name(output)?;
    if same_file(input, output) {
        return Err(ConvertError::SameFile {
            path: output.to_owned(),
        });
    }
    let range = match to {
        RunFormat::Mcap => RigRange::BoardStream,
        RunFormat::Csv => RigRange::Physical,
    };
    let loaded = load_salvaging(input, salvage, range)?;
    let mut run = loaded.run;
    let synthesised_frames =
        to == RunFormat::Mcap && loaded.format == RunFormat::Csv && run.frames.is_empty();
    if synthesised_frames {
        run.frames = crate::log::synthesis::synthesise_frames(
            &run.samples,
            Some(&model_core::Rover::HUSKY_A200),
        );
    }
    save_run(output, existing, &run)?;
    Ok(Converted {
        from: loaded.format,
        to,
        samples: run.samples.len(),
        frames: if to == RunFormat::Mcap {
            run.frames.len()
        } else {
            0
        },
        synthesised_frames,
        truncated: loaded.truncated,
        losses: loaded.losses,
        dropped_rows: loaded.dropped_rows,
    })
}

/// Whether `a` and `b` name the same existing file (same path, symlink or hard link).
pub fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        matches!(
            (a.canonicalize(), b.canonicalize()),
            (Ok(x), Ok(y)) if x == y
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::mcap::{read_mcap_run, tests::sim_run};
    use crate::log::run_csv::{read_run_csv, RunSample};
    use crate::log::tests_support::TempDir;
    use model_core::ina226::Scale;
    use model_core::wire::BoardFrame;
    use model_core::Sides;

    fn samples() -> Vec<RunSample> {
        (0..500)
            .map(|i| {
                let t = f64::from(i) * 0.005;
                RunSample {
                    t_s: 0.25 + t,
                    bus_v: Sides::new(24.613 - 0.2 * t, 24.5071),
                    current_a: Sides::new(7.0 * (t * 1.7).sin(), 3.333_333),
                    cmd_mps: Sides::new(0.2 * t, -0.3),
                    yaw_rad: (i % 2 == 0).then_some(0.123_456_789 * t),
                    pitch_deg: (i % 5 != 0).then_some(-2.5),
                    x_m: None,
                    y_m: None,
                }
            })
            .collect()
    }

    /// A recorded run CSV's events (its `RUN.events.jsonl`) reach the MCAP file, in time
    /// order among the samples, and a stream of the CSV carries them as the load does.
    #[test]
    fn a_run_csvs_events_survive_its_conversion_to_mcap() {
        use crate::log::csv_sink::CsvRunSink;
        use crate::log::load::{load, stream_salvaging};
        use crate::log::run_log::{LogEvent, RunLogSink};
        let dir = TempDir::new("convert-events");
        let csv = dir.path().join("rec.csv");
        let mcap = dir.path().join("rec.mcap");
        let events = [
            (
                0.0,
                LogEvent::Started {
                    port: "/dev/ttyACM0".into(),
                },
            ),
            (
                0.5,
                LogEvent::SamplesLost {
                    after_seq: 100,
                    missing: 3,
                },
            ),
            (
                0.9,
                LogEvent::DeviceVanished {
                    port: "/dev/ttyACM0".into(),
                },
            ),
        ];
        let mut sink = CsvRunSink::create(&csv, false).expect("sink");
        let mut next = events.iter().peekable();
        for s in samples() {
            while let Some((t, e)) = next.next_if(|(t, _)| *t <= s.t_s) {
                sink.event(*t, e).expect("event");
            }
            sink.sample(&s).expect("sample");
        }
        sink.finish().expect("finish");
        drop(sink);

        let loaded = load(&csv).expect("csv");
        assert_eq!(loaded.run.events, events);
        convert(&csv, &mcap).expect("csv -> mcap");
        let back = load(&mcap).expect("mcap");
        assert_eq!(back.run.events, events);
        assert_eq!(back.run.samples, loaded.run.samples);

        #[derive(Default)]
        struct Kinds(Vec<(f64, String)>, usize);
        impl RunLogSink for Kinds {
            fn sample(&mut self, _: &RunSample) -> std::io::Result<()> {
                self.1 += 1;
                Ok(())
            }
            fn event(&mut self, t_s: f64, e: &LogEvent) -> std::io::Result<()> {
                self.0
                    .push((t_s, format!("{e:?} after {} samples", self.1)));
                Ok(())
            }
        }
        let mut streamed = Kinds::default();
        stream_salvaging(&csv, false, RigRange::Physical, &mut streamed).expect("stream");
        assert_eq!(streamed.0.len(), 3);
        let after: Vec<usize> = samples_before(&loaded.run.samples, &events);
        for ((_, text), n) in streamed.0.iter().zip(after) {
            assert!(text.ends_with(&format!("after {n} samples")), "{text}");
        }
    }

    fn samples_before(
        samples: &[RunSample],
        events: &[(f64, crate::log::run_log::LogEvent)],
    ) -> Vec<usize> {
        events
            .iter()
            .map(|(t, _)| samples.iter().filter(|s| s.t_s < *t).count())
            .collect()
    }

    #[test]
    fn csv_to_mcap_to_csv_is_exact_and_the_frames_are_within_quantisation() {
        let dir = TempDir::new("convert-csv");
        let csv = dir.path().join("in.csv");
        let mcap = dir.path().join("run.mcap");
        let back = dir.path().join("back.csv");
        write_run_csv_atomically(&csv, Existing::Replace, &samples()).expect("csv");
        let original = read_run_csv(&csv).expect("read");

        let done = convert(&csv, &mcap).expect("csv -> mcap");
        assert_eq!((done.from, done.to), (RunFormat::Csv, RunFormat::Mcap));
        assert!(done.synthesised_frames);
        assert_eq!(done.samples, 500);
        let speeds = 1 + original
            .windows(2)
            .filter(|w| w[0].cmd_mps != w[1].cmd_mps)
            .count();
        assert_eq!(
            done.frames,
            1 + 500 + 25 + speeds,
            "hello, samples, a model frame per 100 ms, the board's report of each commanded speed"
        );

        let run = read_mcap_run(&mcap).expect("mcap").run;
        assert_eq!(run.samples, original, "the physical channel is exact");
        let scale = Scale::BOARD;
        let sample_frames: Vec<_> = run
            .frames
            .iter()
            .filter_map(|(t, f)| match f {
                BoardFrame::Sample(s) => Some((*t, *s)),
                _ => None,
            })
            .collect();
        assert_eq!(sample_frames.len(), original.len());
        for ((t_s, frame), s) in sample_frames.iter().zip(&original) {
            assert!((t_s - s.t_s).abs() < 1e-9);
            let l = frame.chips.left.registers().expect("fresh");
            assert!((scale.bus_v(l.bus) - s.bus_v.left).abs() <= 0.625e-3 + 1e-12);
            assert!((scale.current_a(l.current) - s.current_a.left).abs() <= 0.25e-3 + 1e-12);
        }

        let done = convert(&mcap, &back).expect("mcap -> csv");
        assert!(!done.synthesised_frames && done.frames == 0);
        assert_eq!(read_run_csv(&back).expect("back"), original);
        assert_eq!(
            std::fs::read(&back).expect("bytes"),
            std::fs::read(&csv).expect("bytes"),
            "byte for byte the canonical CSV"
        );
    }

    /// Another rig's run CSV converts to a run CSV as it is, but not into MCAP, whose frames
    /// hold the board's registers (they would saturate).
    #[test]
    fn a_run_csv_beyond_the_boards_range_converts_to_csv_but_not_to_mcap() {
        let dir = TempDir::new("convert-argo");
        let csv = dir.path().join("argo.csv");
        let mut rows = samples();
        rows[3].current_a.left = 27.5;
        write_run_csv_atomically(&csv, Existing::Replace, &rows).expect("csv");
        let back = dir.path().join("back.csv");
        convert(&csv, &back).expect("csv -> csv");
        assert_eq!(read_run_csv(&back).expect("back"), rows);
        let mcap = dir.path().join("argo.mcap");
        let e = convert(&csv, &mcap).expect_err("beyond the board's registers");
        let text = e.to_string();
        assert!(
            text.starts_with(&format!(
                "{}: line 5, column 3 (left_current_a): 27.5 is outside the INA226 board's range",
                csv.display()
            )),
            "{text}"
        );
        assert!(text.contains("`replay` and `convert` to MCAP"), "{text}");
        assert!(!mcap.exists());
    }

    #[test]
    fn mcap_to_mcap_finishes_a_truncated_recording() {
        let dir = TempDir::new("convert-repair");
        let (run, _) = sim_run(80);
        let whole = dir.path().join("whole.mcap");
        save_run(&whole, Existing::Replace, &run).expect("mcap");
        let bytes = std::fs::read(&whole).expect("read");
        let cut = dir.path().join("cut.mcap");
        // Cut inside the summary section: the data are all there, the footer is not.
        std::fs::write(&cut, &bytes[..bytes.len() - 40]).expect("write");
        let repaired = dir.path().join("repaired.mcap");
        let done = convert(&cut, &repaired).expect("repair");
        assert!(done.truncated.is_some());
        let got = read_mcap_run(&repaired).expect("repaired");
        assert_eq!(got.truncated, None);
        assert_eq!(got.run, run);
    }

    #[test]
    fn refuses_to_overwrite_the_input_and_unknown_formats_write_nothing() {
        let dir = TempDir::new("convert-same");
        let csv = dir.path().join("in.csv");
        write_run_csv_atomically(&csv, Existing::Replace, &samples()[..3]).expect("csv");
        let before = std::fs::read(&csv).expect("read");
        let e = convert(&csv, &csv).expect_err("same file");
        assert!(matches!(e, ConvertError::SameFile { .. }), "{e}");
        let dotted = dir.path().join(".").join("in.csv");
        assert!(matches!(
            convert(&csv, &dotted),
            Err(ConvertError::SameFile { .. })
        ));
        #[cfg(unix)]
        {
            let link = dir.path().join("link.csv");
            std::os::unix::fs::symlink(&csv, &link).expect("symlink");
            assert!(matches!(
                convert(&link, &csv),
                Err(ConvertError::SameFile { .. })
            ));
        }
        assert_eq!(std::fs::read(&csv).expect("read"), before);

        let e = convert(&csv, &dir.path().join("out.parquet")).expect_err("format");
        assert!(
            e.to_string()
                .ends_with("unknown run log format (supported: .mcap, .csv)"),
            "{e}"
        );
        let e = convert(&dir.path().join("missing.csv"), &dir.path().join("o.mcap"))
            .expect_err("missing input");
        assert!(e.to_string().contains("missing.csv"), "{e}");
        assert!(!dir.path().join("o.mcap").exists());
    }

    #[test]
    fn a_csv_with_negative_times_cannot_become_mcap_and_leaves_nothing() {
        let dir = TempDir::new("convert-negative");
        let csv = dir.path().join("in.csv");
        let mut s = samples();
        s[0].t_s = -0.5;
        write_run_csv_atomically(&csv, Existing::Replace, &s).expect("csv");
        let out = dir.path().join("out.mcap");
        let e = convert(&csv, &out).expect_err("negative time");
        assert!(e.to_string().contains("run time -0.5 s"), "{e}");
        assert_eq!(dir.entries(), ["in.csv"]);
    }
}
