//! Run logs read for analysis, the sequence `validate`, `plot` and `diagnose` share: load each
//! file (.mcap or .csv, with a progress bar), then validate them together.

use crate::figures::RunSamples;
use crate::log::load::{
    load_salvaging, refuse_duplicate_digests, refuse_duplicate_runs, stream_own_run_csv,
    stream_salvaging, LoadError, RunFormat, StreamFound,
};
use crate::log::mcap::{Loss, Truncation};
use crate::log::run_csv::{visit_own_run_csv, DroppedRow, RigRange, RunSample};
use crate::log::run_log::{RunLog, RunLogSink};
use crate::progress;
use crate::validate::one_pass::{OnePass, RunResult};
use crate::validate::stream::{RunPass, RunScan};
use crate::validate::{self, RunInput, ValidateError, ValidateOptions, ValidationReport};
use model_core::Rover;
use std::path::{Path, PathBuf};

/// Loaded runs, named by their paths as given.
#[derive(Debug, Clone, Default)]
pub struct Runs {
    /// Each run's name (its path as given).
    pub names: Vec<String>,
    /// Each run's log.
    pub logs: Vec<RunLog>,
    /// MCAP files that ended before their footer (a killed recorder) and how much was used.
    pub truncated: Vec<(PathBuf, Truncation)>,
    /// What damage cost each file, one warning per stretch or row ([`damage_warnings`]).
    pub damage: Vec<String>,
    /// Whether data inside a file was lost to damage (not just a cut end).
    pub lost_data: bool,
}

impl Runs {
    /// Reads `paths` in order, run CSVs' readings within `range`; with `salvage` damaged run
    /// CSV rows are left out instead of refused (damaged MCAP stretches are always skipped and
    /// listed). The same run given twice is refused: it would count as two independent repeats.
    pub fn load(paths: &[PathBuf], salvage: bool, range: RigRange) -> Result<Runs, LoadError> {
        let bar = progress::bar(paths.len() as u64, "reading runs");
        let mut runs = Runs::default();
        for path in paths {
            let loaded = load_salvaging(path, salvage, range)?;
            if let Some(t) = loaded.truncated {
                runs.truncated.push((path.clone(), t));
            }
            runs.damage
                .extend(damage_warnings(path, &loaded.losses, &loaded.dropped_rows));
            runs.lost_data |= loaded.lost_data();
            runs.names.push(path.display().to_string());
            runs.logs.push(loaded.run);
            bar.inc(1);
        }
        bar.finish_and_clear();
        refuse_duplicate_runs(&runs.names, &runs.logs)?;
        Ok(runs)
    }

    /// The runs as `validate`'s input.
    pub fn inputs(&self) -> Vec<RunInput<'_>> {
        self.names
            .iter()
            .zip(&self.logs)
            .map(|(name, log)| RunInput::from_log(name, log))
            .collect()
    }

    /// Validates the runs together ([`validate::validate`]).
    pub fn validate(
        &self,
        rover: &Rover,
        options: &ValidateOptions,
    ) -> Result<ValidationReport, ValidateError> {
        validate::validate(rover, &self.inputs(), options)
    }

    /// Each run's samples, named, for the figures.
    pub fn samples(&self) -> Vec<RunSamples<'_>> {
        self.names
            .iter()
            .zip(&self.logs)
            .map(|(name, log)| RunSamples {
                name,
                samples: &log.samples,
            })
            .collect()
    }

    /// Each run's samples.
    pub fn sample_slices(&self) -> Vec<&[RunSample]> {
        self.logs.iter().map(|l| l.samples.as_slice()).collect()
    }
}

/// Run logs validated as streams, for `validate`: memory stays bounded whatever the logs'
/// length. Each file is read once and validated as it is read ([`validate::one_pass`]; this
/// tool's own run CSVs parsed on every core, any other log by its streaming reader), and read
/// a second time only where the pass's guesses fail (the gap threshold; a command logged after
/// a frame it governs) as [`validate::stream`] reads it. The report is the one
/// [`Runs::validate`] gives, to the bit.
#[derive(Debug)]
pub struct StreamedRuns {
    /// Each run's name (its path as given).
    pub names: Vec<String>,
    paths: Vec<PathBuf>,
    salvage: bool,
    range: RigRange,
    rover: Rover,
    options: ValidateOptions,
    reads: Vec<FirstRead>,
    /// MCAP files that ended before their footer (a killed recorder) and how much was used.
    pub truncated: Vec<(PathBuf, Truncation)>,
    /// What damage cost each file, one warning per stretch or row ([`damage_warnings`]).
    pub damage: Vec<String>,
    /// Whether data inside a file was lost to damage (not just a cut end).
    pub lost_data: bool,
}

/// Why runs read as streams could not be validated.
#[derive(Debug, thiserror::Error)]
pub enum StreamedRunsError {
    /// A file could not be read (the first pass's errors, or a read failing in the second).
    #[error(transparent)]
    Load(#[from] LoadError),
    /// Validation refused the runs.
    #[error(transparent)]
    Validate(#[from] ValidateError),
    /// The second read of a file did not give the samples of the first.
    #[error("{name}: the file changed while it was being validated ({first} samples on the first read, {second} on the second)")]
    Changed {
        /// The run.
        name: String,
        /// Samples on the first read.
        first: usize,
        /// Samples on the second.
        second: usize,
    },
}

impl StreamedRuns {
    /// The first pass over `paths` in order (with a progress bar), for validating them against
    /// `rover` with `options`: what each run's validation needs, its damage and truncation, its
    /// content digest (this tool's own run CSVs: validated already). Errors as [`Runs::load`]'s,
    /// the same run given twice too.
    pub fn scan(
        paths: &[PathBuf],
        salvage: bool,
        range: RigRange,
        rover: &Rover,
        options: &ValidateOptions,
    ) -> Result<StreamedRuns, LoadError> {
        Self::scan_with(paths, salvage, range, rover, options, true)
    }

    /// [`Self::scan`]; without `one_pass`, this tool's run CSVs are streamed as the others.
    fn scan_with(
        paths: &[PathBuf],
        salvage: bool,
        range: RigRange,
        rover: &Rover,
        options: &ValidateOptions,
        one_pass: bool,
    ) -> Result<StreamedRuns, LoadError> {
        let bar = progress::bar(paths.len() as u64, "reading runs");
        let mut runs = StreamedRuns {
            names: Vec::with_capacity(paths.len()),
            paths: Vec::with_capacity(paths.len()),
            salvage,
            range,
            rover: *rover,
            options: *options,
            reads: Vec::with_capacity(paths.len()),
            truncated: Vec::new(),
            damage: Vec::new(),
            lost_data: false,
        };
        for path in paths {
            let name = path.display().to_string();
            let own_csv = match one_pass {
                true => validate_own_csv(path, &name, range, rover, options)?,
                false => None,
            };
            let read = match own_csv {
                Some(read) => read,
                None => {
                    // Any other log, as a stream: validated as it is read where the options
                    // allow (else scanned, and validated from a second read).
                    let pass = one_pass
                        .then(|| OnePass::new(&name, rover, options))
                        .flatten();
                    let (read, found) = match pass {
                        Some(mut pass) => {
                            let found = stream_salvaging(path, salvage, range, &mut pass)?;
                            (FirstRead::of(pass.finish(), false), found)
                        }
                        None => {
                            let mut scan = RunScan::default();
                            let found = stream_salvaging(path, salvage, range, &mut scan)?;
                            (FirstRead::scanned(scan), found)
                        }
                    };
                    if let Some(t) = found.truncated {
                        runs.truncated.push((path.clone(), t));
                    }
                    runs.damage
                        .extend(damage_warnings(path, &found.losses, &found.dropped_rows));
                    runs.lost_data |= found.lost_data();
                    read
                }
            };
            runs.names.push(name);
            runs.paths.push(path.clone());
            runs.reads.push(read);
            bar.inc(1);
        }
        bar.finish_and_clear();
        let digests: Vec<_> = runs.reads.iter().map(|r| r.scan.digest()).collect();
        refuse_duplicate_digests(&runs.names, &digests)?;
        Ok(runs)
    }

    /// Reads run `index` again into `sink` (e.g. a third pass, for what the report does not
    /// hold), as a stream, the way it was first read (this tool's own run CSV by the fast
    /// path); `None` for an index past the runs.
    pub fn read_again(
        &self,
        index: usize,
        sink: &mut (dyn RunLogSink + Send),
    ) -> Option<Result<StreamFound, LoadError>> {
        let path = self.paths.get(index)?;
        Some(self.stream(index, path, sink))
    }

    /// Streams run `index` at `path` into `sink` as it was first read: this tool's own run
    /// CSV through the fast path (the file changed if it no longer takes it), any other log by
    /// [`stream_salvaging`].
    fn stream(
        &self,
        index: usize,
        path: &Path,
        sink: &mut (dyn RunLogSink + Send),
    ) -> Result<StreamFound, LoadError> {
        if !self.reads[index].own_csv {
            return stream_salvaging(path, self.salvage, self.range, sink);
        }
        stream_own_run_csv(path, self.range, sink)?.ok_or_else(|| LoadError::Changed {
            path: path.to_owned(),
        })
    }

    /// The second pass: validates the runs together, as [`Runs::validate`] does.
    pub fn validate(&self) -> Result<ValidationReport, StreamedRunsError> {
        let (rover, options) = (&self.rover, &self.options);
        validate::stream::begin(self.reads.len(), options)?;
        let bar = progress::bar(self.reads.len() as u64, "validating runs");
        let mut runs = Vec::with_capacity(self.reads.len());
        for (index, ((name, path), read)) in self
            .names
            .iter()
            .zip(&self.paths)
            .zip(&self.reads)
            .enumerate()
        {
            if let Some(result) = &read.result {
                runs.push(result.as_ref().clone()?);
                bar.inc(1);
                continue;
            }
            let scan = &read.scan;
            let mut pass = RunPass::new(name, scan, rover, options)?;
            self.stream(index, path, &mut pass)?;
            if pass.samples() != scan.samples() {
                return Err(StreamedRunsError::Changed {
                    name: name.clone(),
                    first: scan.samples(),
                    second: pass.samples(),
                });
            }
            runs.push(pass.finish());
            bar.inc(1);
        }
        bar.finish_and_clear();
        Ok(validate::stream::finish(rover, options, runs)?)
    }
}

/// A run's first read by [`StreamedRuns::scan`].
#[derive(Debug)]
struct FirstRead {
    scan: RunScan,
    /// The run's part of the report, when it was validated as it was read ([`OnePass`]; boxed:
    /// it is large beside the scan). `None`: a second read validates it (the one pass's guess
    /// failed, or the options kept the run from it).
    result: Option<Box<Result<RunResult, ValidateError>>>,
    /// This tool's own run CSV, read by the fast path (and read again by it).
    own_csv: bool,
}

impl FirstRead {
    /// The read of a run that [`OnePass`] went through.
    fn of(
        (scan, result): (RunScan, Option<Result<RunResult, ValidateError>>),
        own_csv: bool,
    ) -> Self {
        FirstRead {
            scan,
            result: result.map(Box::new),
            own_csv,
        }
    }

    /// The read of a run only scanned (a log read by the general readers).
    fn scanned(scan: RunScan) -> Self {
        FirstRead {
            scan,
            result: None,
            own_csv: false,
        }
    }
}

/// The first read of `path` if it is one of this tool's own run CSVs (valid throughout, its
/// readings within `range`), validated as it is read ([`OnePass`]): its scan alone when the
/// pass's guess failed (the run is validated from a second read). `None` for any other log, or
/// for options `validate` refuses (streamed: read twice).
fn validate_own_csv(
    path: &Path,
    name: &str,
    range: RigRange,
    rover: &Rover,
    options: &ValidateOptions,
) -> Result<Option<FirstRead>, LoadError> {
    if RunFormat::of(path)? != RunFormat::Csv {
        return Ok(None);
    }
    let Some(mut pass) = OnePass::new(name, rover, options) else {
        return Ok(None);
    };
    if !visit_own_run_csv(path, range, &mut |rows| pass.push(rows))? {
        return Ok(None);
    }
    Ok(Some(FirstRead::of(pass.finish(), true)))
}

/// The warning for a truncated MCAP file.
pub fn truncation_warning(path: &Path, t: &Truncation) -> String {
    format!(
        "warning: {} ends before its footer (recorder killed?): using its first {} of {} bytes",
        path.display(),
        t.complete_bytes,
        t.file_bytes
    )
}

/// Dropped run CSV rows warned about one by one; the rest are counted in one more line (a file
/// whose every row is damaged would otherwise print a line per row).
pub const DROPPED_ROWS_SHOWN: usize = 20;

/// One warning per damaged stretch of an MCAP file and per dropped run CSV row (the first
/// [`DROPPED_ROWS_SHOWN`], then a count).
pub fn damage_warnings(path: &Path, losses: &[Loss], dropped_rows: &[DroppedRow]) -> Vec<String> {
    let losses = losses
        .iter()
        .map(|loss| format!("warning: {}: damaged, skipped {loss}", path.display()));
    let rows = dropped_rows.iter().take(DROPPED_ROWS_SHOWN).map(|row| {
        let why = if row.cut {
            "the file ends inside it (cut by a kill or a full disk)"
        } else {
            "damaged"
        };
        // The reason is the error's text, which starts with the same line: said once.
        let line = format!("line {}", row.line);
        let reason = row
            .reason
            .strip_prefix(&line)
            .map_or(row.reason.as_str(), |r| {
                r.trim_start_matches([':', ',', ' '])
            });
        format!(
            "warning: {}: {line} dropped, {why}: {reason}",
            path.display()
        )
    });
    let more = match dropped_rows.get(DROPPED_ROWS_SHOWN..) {
        Some(rest @ [.., last]) => Some(format!(
            "warning: {}: {} more lines dropped, the last at line {}",
            path.display(),
            rest.len(),
            last.line
        )),
        _ => None,
    };
    losses.chain(rows).chain(more).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::demo::{self, DemoOptions};
    use crate::log::tests_support::TempDir;
    use model_core::Sides;

    /// A file whose every row is damaged: 20 warnings and a count, not a line per row (the
    /// fuzzing found 100 kB of warnings from one damaged header).
    #[test]
    fn dropped_rows_beyond_twenty_are_counted_in_one_line() {
        let rows: Vec<DroppedRow> = (2..=5001)
            .map(|line| DroppedRow {
                line,
                reason: format!("line {line}, column 2 (left_bus_v): empty cell"),
                cut: false,
            })
            .collect();
        let warnings = damage_warnings(Path::new("bad.csv"), &[], &rows);
        assert_eq!(warnings.len(), DROPPED_ROWS_SHOWN + 1);
        assert_eq!(
            warnings[0],
            "warning: bad.csv: line 2 dropped, damaged: column 2 (left_bus_v): empty cell"
        );
        assert_eq!(
            warnings[DROPPED_ROWS_SHOWN],
            "warning: bad.csv: 4980 more lines dropped, the last at line 5001"
        );
        assert_eq!(
            damage_warnings(Path::new("bad.csv"), &[], &rows[..20]).len(),
            20
        );
    }

    /// Everything `validate` prints or writes of a report.
    fn outputs(report: &ValidationReport) -> (String, String, Vec<u8>) {
        let mut csv = Vec::new();
        report.write_csv(&mut csv).expect("csv");
        (
            report.to_string(),
            serde_json::to_string_pretty(report).expect("json"),
            csv,
        )
    }

    /// `runs` demo runs in `dir` (at 50× real time), with the demo world's rover and the
    /// options `validate` reads them with.
    fn quick_demo(dir: &TempDir, runs: u32) -> (demo::DemoOutcome, Rover, ValidateOptions) {
        let mut options = DemoOptions::new(dir.path().join("demo"));
        options.runs = runs;
        options.speed = 50.0;
        let outcome = demo::run(&options, &mut |_, _, _| {}).expect("demo");
        let rover = options.world.rover;
        let validate_options = ValidateOptions {
            tracker_offset_m: options.world.tracker.offset_m,
            ..ValidateOptions::for_rover(&rover)
        };
        (outcome, rover, validate_options)
    }

    #[test]
    fn streamed_validation_gives_the_in_memory_report_to_the_bit() {
        let dir = TempDir::new("streamed-runs");
        let (outcome, rover, validate_options) = quick_demo(&dir, 2);
        let (a, b) = (&outcome.runs[0], &outcome.runs[1]);
        // Damage: 64 KiB zeroed in the middle of the first run's MCAP (several chunks: a smaller
        // block can fall on message indexes alone, which lose nothing), a cut last row in the
        // second run's CSV.
        let mut bytes = std::fs::read(&a.mcap).expect("mcap");
        let mid = bytes.len() / 2;
        bytes[mid..mid + 65_536].fill(0);
        let damaged = dir.path().join("damaged.mcap");
        std::fs::write(&damaged, &bytes).expect("write");
        let text = std::fs::read(&b.csv).expect("csv");
        let cut = dir.path().join("cut.csv");
        // Inside the third cell of the last row: too few cells.
        let last_row = text[..text.len() - 1]
            .iter()
            .rposition(|&b| b == b'\n')
            .expect("rows");
        std::fs::write(&cut, &text[..last_row + 12]).expect("write");
        for paths in [
            vec![a.mcap.clone(), b.mcap.clone()],
            vec![a.csv.clone(), b.mcap.clone()],
            vec![b.csv.clone(), a.csv.clone()],
            vec![damaged.clone(), cut.clone()],
        ] {
            let in_memory = Runs::load(&paths, false, RigRange::default()).expect("loads");
            let want = in_memory
                .validate(&rover, &validate_options)
                .expect("valid");
            // Validated in one pass (as `validate` reads them) and in two.
            for one_pass in [true, false] {
                let streamed = StreamedRuns::scan_with(
                    &paths,
                    false,
                    RigRange::default(),
                    &rover,
                    &validate_options,
                    one_pass,
                )
                .expect("scans");
                let got = streamed.validate().expect("valid");
                assert_eq!(outputs(&got), outputs(&want), "{paths:?}");
                assert_eq!(streamed.names, in_memory.names);
                assert_eq!(streamed.truncated, in_memory.truncated);
                assert_eq!(streamed.damage, in_memory.damage);
                assert_eq!(streamed.lost_data, in_memory.lost_data);
                // A third pass (diagnose's) gets the samples of the first.
                let mut again = RunLog::default();
                let found = streamed.read_again(0, &mut again).expect("a run");
                assert_eq!(found.expect("reads").dropped_rows, []);
                assert_eq!(again.samples, in_memory.logs[0].samples);
                // Every run validated as it was first read (MCAP, damaged or not, a cut CSV by
                // the general reader, this tool's CSVs by the fast path, which reads them
                // again).
                let one_read: Vec<bool> =
                    streamed.reads.iter().map(|r| r.result.is_some()).collect();
                assert_eq!(one_read, vec![one_pass; paths.len()], "{paths:?}");
                let fast: Vec<bool> = streamed.reads.iter().map(|r| r.own_csv).collect();
                let own_csv: Vec<bool> = paths
                    .iter()
                    .map(|p| one_pass && (*p == a.csv || *p == b.csv))
                    .collect();
                assert_eq!(fast, own_csv, "{paths:?}");
            }
        }
        // The damage was seen (so the last case compared salvaged reads).
        let streamed = StreamedRuns::scan(
            &[damaged, cut],
            false,
            RigRange::default(),
            &rover,
            &validate_options,
        )
        .expect("scans");
        assert!(
            streamed.lost_data && streamed.damage.len() >= 2,
            "{streamed:?}"
        );

        // The same run twice, or in both formats, is refused as the in-memory load refuses it.
        for paths in [
            vec![a.mcap.clone(), b.mcap.clone(), a.mcap.clone()],
            vec![a.mcap.clone(), a.csv.clone()],
            vec![a.csv.clone(), a.mcap.clone()],
            vec![a.csv.clone(), a.csv.clone()],
        ] {
            let want = Runs::load(&paths, false, RigRange::default())
                .expect_err("duplicate")
                .to_string();
            let got = StreamedRuns::scan(
                &paths,
                false,
                RigRange::default(),
                &rover,
                &validate_options,
            )
            .expect_err("duplicate")
            .to_string();
            assert_eq!(got, want);
        }
    }

    /// A log without acks (its commands in force from their times): read once when each
    /// command comes before the frames it governs, as a recorder writes them; logged after them,
    /// the one pass's cross-check would differ, so the run is read a second time. Both give the
    /// in-memory report to the bit.
    #[test]
    fn commands_logged_after_the_frames_they_govern_send_the_run_to_a_second_read() {
        use crate::log::mcap::{write_mcap_run, McapSink};
        use crate::log::run_log::RunLogSink;
        use crate::validate::crosscheck::acknowledges;
        let dir = TempDir::new("late-commands");
        let (outcome, rover, validate_options) = quick_demo(&dir, 1);
        let mut run = crate::log::load::load_run(&outcome.runs[0].mcap).expect("loads");
        run.frames.retain(|(_, f)| !acknowledges(f));
        assert!(run.commands.len() >= 6, "{} commands", run.commands.len());
        let in_order = dir.path().join("in-order.mcap");
        write_mcap_run(std::fs::File::create(&in_order).expect("create"), &run).expect("written");
        let late = dir.path().join("late.mcap");
        let mut sink = McapSink::new(std::fs::File::create(&late).expect("create")).expect("sink");
        let without = RunLog {
            commands: Vec::new(),
            ..run.clone()
        };
        for (t_s, record) in without.in_time_order() {
            record.write_to(t_s, &mut sink).expect("record");
        }
        for command in &run.commands {
            sink.command(command).expect("command");
        }
        sink.finish().expect("finish");

        for (path, once) in [(&in_order, true), (&late, false)] {
            let paths = [path.clone()];
            let want = Runs::load(&paths, false, RigRange::default())
                .expect("loads")
                .validate(&rover, &validate_options)
                .expect("valid");
            let streamed = StreamedRuns::scan(
                &paths,
                false,
                RigRange::default(),
                &rover,
                &validate_options,
            )
            .expect("scans");
            assert_eq!(
                streamed.reads[0].result.is_some(),
                once,
                "{}",
                path.display()
            );
            let got = streamed.validate().expect("valid");
            assert_eq!(outputs(&got), outputs(&want), "{}", path.display());
        }
    }

    /// Every record a stream gives, in order.
    #[derive(Default, PartialEq, Debug)]
    struct Records(Vec<String>);

    impl RunLogSink for Records {
        fn sample(&mut self, s: &RunSample) -> std::io::Result<()> {
            self.0.push(format!("{s:?}"));
            Ok(())
        }
        fn event(&mut self, t_s: f64, e: &crate::log::run_log::LogEvent) -> std::io::Result<()> {
            self.0.push(format!("{t_s} {e:?}"));
            Ok(())
        }
    }

    /// This tool's run CSV is read again by the fast path, with the records (its events among
    /// the samples) the general reader gives; a file that no longer takes that path is
    /// refused as changed, not read half by one reader.
    #[test]
    fn a_run_csv_read_again_gives_the_general_readers_records() {
        use crate::log::csv_sink::CsvRunSink;
        use crate::log::run_log::LogEvent;
        let dir = TempDir::new("read-again");
        let path = dir.path().join("run.csv");
        let rover = Rover::HUSKY_A200;
        let options = ValidateOptions::for_rover(&rover);
        let events = [
            (
                0.2,
                LogEvent::SamplesLost {
                    after_seq: 40,
                    missing: 2,
                },
            ),
            (
                3.0,
                LogEvent::DeviceVanished {
                    port: "/dev/ttyACM0".into(),
                },
            ),
            (
                99.0,
                LogEvent::DeviceVanished {
                    port: "/dev/ttyACM1".into(),
                },
            ),
        ];
        let mut sink = CsvRunSink::create(&path, false).expect("sink");
        let mut next = events.iter().peekable();
        for i in 0..2_000 {
            let t_s = i as f64 * 0.01;
            let (l, r) = if (i / 250) % 2 == 0 {
                (0.3, 0.3)
            } else {
                (0.3, -0.3)
            };
            let s = RunSample::new(
                t_s,
                Sides::new(24.0, 23.9),
                Sides::new(1.5 + 0.001 * (i % 7) as f64, 1.7),
                Sides::new(l, r),
            );
            while let Some((t, e)) = next.next_if(|(t, _)| *t <= t_s) {
                sink.event(*t, e).expect("event");
            }
            sink.sample(&s).expect("sample");
        }
        for (t, e) in next {
            sink.event(*t, e).expect("event");
        }
        sink.finish().expect("finish");
        drop(sink);

        let paths = [path.clone()];
        let streamed = StreamedRuns::scan(&paths, false, RigRange::default(), &rover, &options)
            .expect("scans");
        assert!(streamed.reads[0].own_csv, "the fast path read it first");
        let mut want = Records::default();
        stream_salvaging(&path, false, RigRange::default(), &mut want).expect("general");
        assert_eq!(want.0.len(), 2_000 + events.len());
        let mut got = Records::default();
        streamed
            .read_again(0, &mut got)
            .expect("a run")
            .expect("reads");
        assert_eq!(got, want);

        // CRLF line ends: a valid run CSV, but not this tool's layout.
        let text = std::fs::read_to_string(&path).expect("read");
        std::fs::write(&path, text.replace('\n', "\r\n")).expect("write");
        let e = streamed
            .read_again(0, &mut Records::default())
            .expect("a run")
            .expect_err("changed");
        assert!(matches!(e, LoadError::Changed { .. }), "{e}");
        assert!(e.to_string().contains("the file changed"), "{e}");
    }

    #[test]
    fn a_wrong_guess_of_the_gap_threshold_reads_the_run_again() {
        let dir = TempDir::new("one-pass-guess");
        let path = dir.path().join("run.csv");
        let rover = Rover::HUSKY_A200;
        let options = ValidateOptions::for_rover(&rover);
        let commands = [(0.3, 0.3), (0.3, -0.3), (0.0, 0.0), (-0.2, 0.4)];
        // Past the parallel reader's threshold; with `slow_from`, the first job's intervals
        // (5 ms) are not the run's median (40 ms), and the guessed threshold calls the 40 ms
        // intervals gaps where the run's does not.
        for (slow_from, guessed) in [(30_000, false), (usize::MAX, true)] {
            let mut t_s = 0.0;
            let samples: Vec<RunSample> = (0..90_000)
                .map(|i| {
                    t_s += if i >= slow_from { 0.04 } else { 0.005 };
                    let (l, r) = commands[(i / 500) % commands.len()];
                    let current = 1.5 + 0.001 * (i % 7) as f64;
                    RunSample::new(
                        t_s,
                        Sides::new(24.0, 23.9),
                        Sides::new(current, current + 0.25),
                        Sides::new(l, r),
                    )
                })
                .collect();
            crate::log::run_csv::write_run_csv_atomically(
                &path,
                crate::log::Existing::Replace,
                &samples,
            )
            .expect("write");
            let paths = [path.clone()];
            let want = Runs::load(&paths, false, RigRange::default())
                .expect("loads")
                .validate(&rover, &options)
                .expect("valid");
            let streamed = StreamedRuns::scan(&paths, false, RigRange::default(), &rover, &options)
                .expect("scans");
            assert_eq!(streamed.reads[0].result.is_some(), guessed);
            let got = streamed.validate().expect("valid");
            assert_eq!(outputs(&got), outputs(&want));
        }
        // A run that cannot be segmented: the in-memory path's error.
        crate::log::run_csv::write_run_csv_atomically(
            &path,
            crate::log::Existing::Replace,
            &[RunSample::new(
                0.0,
                Sides::new(24.0, 24.0),
                Sides::new(1.0, 1.0),
                Sides::new(0.0, 0.0),
            )],
        )
        .expect("write");
        let paths = [path.clone()];
        let want = Runs::load(&paths, false, RigRange::default())
            .expect("loads")
            .validate(&rover, &options)
            .expect_err("one sample")
            .to_string();
        let streamed = StreamedRuns::scan(&paths, false, RigRange::default(), &rover, &options)
            .expect("scans");
        assert!(streamed.reads[0].result.is_some());
        let got = streamed.validate().expect_err("one sample").to_string();
        assert_eq!(got, want);
    }
}
