//! Run logs read for analysis, the sequence `validate`, `plot` and `diagnose` share: load each
//! file (.mcap or .csv, with a progress bar), then validate them together.

use crate::figures::RunSamples;
use crate::log::load::{
    load_salvaging, refuse_duplicate_digests, refuse_duplicate_runs, stream_salvaging, LoadError,
    RunDigest, RunFormat, StreamFound,
};
use crate::log::mcap::{Loss, Truncation};
use crate::log::run_csv::{read_own_run_csv, DroppedRow, RunCsvFileError, RunSample};
use crate::log::run_log::{RunLog, RunLogSink};
use crate::progress;
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
    /// Reads `paths` in order; with `salvage` damaged run CSV rows are left out instead of
    /// refused (damaged MCAP stretches are always skipped and listed). The same run given twice
    /// is refused: it would count as two independent repeats.
    pub fn load(paths: &[PathBuf], salvage: bool) -> Result<Runs, LoadError> {
        let bar = progress::bar(paths.len() as u64, "reading runs");
        let mut runs = Runs::default();
        for path in paths {
            let loaded = load_salvaging(path, salvage)?;
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

/// How much of this tool's own run CSVs [`StreamedRuns`] holds in memory rather than reading
/// them twice, all runs together [bytes]: about two hours at 200 Hz; the samples take ~1.4×
/// the files in the layout with a tracked point (120 B a row), at most 3× in the shortest.
pub const HELD_CSV_MAX_BYTES: u64 = 128 << 20;

/// Run logs validated as streams, for `validate`: memory stays bounded whatever the logs'
/// length (each file is read twice, see [`validate::stream`]; this tool's own run CSVs, up to
/// [`HELD_CSV_MAX_BYTES`] of them in all, are read once, on every core, and validated from
/// memory), and
/// the report is the one [`Runs::validate`] gives, to the bit.
#[derive(Debug, Default)]
pub struct StreamedRuns {
    /// Each run's name (its path as given).
    pub names: Vec<String>,
    paths: Vec<PathBuf>,
    salvage: bool,
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
    /// The first pass over `paths` in order (with a progress bar): what each run's validation
    /// needs, its damage and truncation, its content digest. Errors as [`Runs::load`]'s, the
    /// same run given twice too.
    pub fn scan(paths: &[PathBuf], salvage: bool) -> Result<StreamedRuns, LoadError> {
        Self::scan_holding(paths, salvage, HELD_CSV_MAX_BYTES)
    }

    /// [`Self::scan`], holding this tool's run CSVs up to `held_max_bytes` in all (in order:
    /// a file that would pass it streams, as do the rest once it is spent).
    fn scan_holding(
        paths: &[PathBuf],
        salvage: bool,
        held_max_bytes: u64,
    ) -> Result<StreamedRuns, LoadError> {
        let bar = progress::bar(paths.len() as u64, "reading runs");
        let mut runs = StreamedRuns {
            salvage,
            ..StreamedRuns::default()
        };
        let mut held_bytes = 0;
        for path in paths {
            // The digest is taken as the samples are read (in file order, on the core that
            // parsed them); it is dropped if the file is not held.
            let mut digest = RunDigest::default();
            let mut hash = |rows: &[RunSample]| rows.iter().for_each(|s| digest.push(s));
            let budget = held_max_bytes - held_bytes;
            let read = match read_held(path, budget, &mut hash)? {
                Some((samples, bytes)) => {
                    held_bytes += bytes;
                    FirstRead::Held { samples, digest }
                }
                None => {
                    let mut scan = RunScan::default();
                    let found = stream_salvaging(path, salvage, &mut scan)?;
                    if let Some(t) = found.truncated {
                        runs.truncated.push((path.clone(), t));
                    }
                    runs.damage
                        .extend(damage_warnings(path, &found.losses, &found.dropped_rows));
                    runs.lost_data |= found.lost_data();
                    FirstRead::Scanned(scan)
                }
            };
            runs.names.push(path.display().to_string());
            runs.paths.push(path.clone());
            runs.reads.push(read);
            bar.inc(1);
        }
        bar.finish_and_clear();
        let digests: Vec<_> = runs.reads.iter().map(FirstRead::digest).collect();
        refuse_duplicate_digests(&runs.names, &digests)?;
        Ok(runs)
    }

    /// Reads run `index` again into `sink` (e.g. a third pass, for what the report does not
    /// hold); `None` for an index past the runs.
    pub fn read_again(
        &self,
        index: usize,
        sink: &mut dyn RunLogSink,
    ) -> Option<Result<StreamFound, LoadError>> {
        let path = self.paths.get(index)?;
        match self.reads.get(index)? {
            FirstRead::Held { samples, .. } => Some(replay_held(path, samples, sink)),
            FirstRead::Scanned(_) => Some(stream_salvaging(path, self.salvage, sink)),
        }
    }

    /// The second pass: validates the runs together, as [`Runs::validate`] does.
    pub fn validate(
        &self,
        rover: &Rover,
        options: &ValidateOptions,
    ) -> Result<ValidationReport, StreamedRunsError> {
        validate::stream::begin(self.reads.len(), options)?;
        let bar = progress::bar(self.reads.len() as u64, "validating runs");
        let mut runs = Vec::with_capacity(self.reads.len());
        for ((name, path), read) in self.names.iter().zip(&self.paths).zip(&self.reads) {
            let scan = match read {
                FirstRead::Held { samples, .. } => {
                    let run = RunInput::from_samples(name, samples);
                    runs.push(validate::validate_run(rover, &run, options)?);
                    bar.inc(1);
                    continue;
                }
                FirstRead::Scanned(scan) => scan,
            };
            let mut pass = RunPass::new(name, scan, rover, options)?;
            stream_salvaging(path, self.salvage, &mut pass)?;
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
enum FirstRead {
    /// Read whole ([`read_held`]): validated from memory, not read again.
    Held {
        samples: Vec<RunSample>,
        digest: RunDigest,
    },
    /// Scanned as a stream: read again to validate.
    Scanned(RunScan),
}

impl FirstRead {
    fn digest(&self) -> &RunDigest {
        match self {
            FirstRead::Held { digest, .. } => digest,
            FirstRead::Scanned(scan) => scan.digest(),
        }
    }
}

/// The samples of `path` and its size if it is one of this tool's own run CSVs (valid
/// throughout) of at most `max_bytes`; `None` for any other log (streamed: read twice).
/// `visit` as [`read_own_run_csv`]'s.
fn read_held(
    path: &Path,
    max_bytes: u64,
    visit: &mut (dyn FnMut(&[RunSample]) + Send),
) -> Result<Option<(Vec<RunSample>, u64)>, LoadError> {
    if RunFormat::of(path)? != RunFormat::Csv {
        return Ok(None);
    }
    let Some(samples) = read_own_run_csv(path, max_bytes, visit)? else {
        return Ok(None);
    };
    // Its size as read (the reader refused a larger file).
    let bytes = std::fs::metadata(path).map_or(max_bytes, |m| m.len().min(max_bytes));
    Ok(Some((samples, bytes)))
}

/// A held run's samples handed to `sink` again, as [`stream_salvaging`] would read them from
/// its file (a valid run CSV: nothing cut, damaged or dropped).
fn replay_held(
    path: &Path,
    samples: &[RunSample],
    sink: &mut dyn RunLogSink,
) -> Result<StreamFound, LoadError> {
    for s in samples {
        sink.sample(s).map_err(|e| RunCsvFileError {
            path: path.to_owned(),
            source: e.into(),
        })?;
    }
    Ok(StreamFound {
        run: (),
        format: RunFormat::Csv,
        truncated: None,
        losses: Vec::new(),
        dropped_rows: Vec::new(),
    })
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

/// One warning per damaged stretch of an MCAP file and per dropped run CSV row.
pub fn damage_warnings(path: &Path, losses: &[Loss], dropped_rows: &[DroppedRow]) -> Vec<String> {
    let losses = losses
        .iter()
        .map(|loss| format!("warning: {}: damaged, skipped {loss}", path.display()));
    let rows = dropped_rows.iter().map(|row| {
        let why = if row.cut {
            "the file ends inside it (cut by a kill or a full disk)"
        } else {
            "damaged"
        };
        format!(
            "warning: {}: line {} dropped, {why}: {}",
            path.display(),
            row.line,
            row.reason
        )
    });
    losses.chain(rows).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::demo::{self, DemoOptions};
    use crate::log::tests_support::TempDir;

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

    #[test]
    fn streamed_validation_gives_the_in_memory_report_to_the_bit() {
        let dir = TempDir::new("streamed-runs");
        let mut options = DemoOptions::new(dir.path().join("demo"));
        options.runs = 2;
        options.speed = 50.0;
        let outcome = demo::run(&options, &mut |_, _, _| {}).expect("demo");
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
        let validate_options = ValidateOptions {
            tracker_offset_m: options.world.tracker.offset_m,
            ..ValidateOptions::for_rover(&options.world.rover)
        };
        let rover = options.world.rover;
        for paths in [
            vec![a.mcap.clone(), b.mcap.clone()],
            vec![a.csv.clone(), b.mcap.clone()],
            vec![b.csv.clone(), a.csv.clone()],
            vec![damaged.clone(), cut.clone()],
        ] {
            let in_memory = Runs::load(&paths, false).expect("loads");
            let want = in_memory
                .validate(&rover, &validate_options)
                .expect("valid");
            // This tool's run CSVs held in memory (as `validate` reads them) and streamed.
            for held_max_bytes in [HELD_CSV_MAX_BYTES, 0] {
                let streamed =
                    StreamedRuns::scan_holding(&paths, false, held_max_bytes).expect("scans");
                let got = streamed.validate(&rover, &validate_options).expect("valid");
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
            }
            let held = StreamedRuns::scan(&paths, false).expect("scans");
            // The budget is for all runs together: room for the first CSV only.
            let first_only = paths
                .iter()
                .find(|p| **p == a.csv || **p == b.csv)
                .and_then(|p| std::fs::metadata(p).ok())
                .map_or(0, |m| m.len());
            let partly = StreamedRuns::scan_holding(&paths, false, first_only).expect("scans");
            let held_count = |runs: &StreamedRuns| {
                runs.reads
                    .iter()
                    .filter(|r| matches!(r, FirstRead::Held { .. }))
                    .count()
            };
            assert_eq!(
                held_count(&partly),
                usize::from(first_only > 0),
                "{paths:?}"
            );
            let got = partly.validate(&rover, &validate_options).expect("valid");
            assert_eq!(outputs(&got), outputs(&want), "{paths:?}");
            let kinds: Vec<bool> = held
                .reads
                .iter()
                .map(|r| matches!(r, FirstRead::Held { .. }))
                .collect();
            let own_csv: Vec<bool> = paths.iter().map(|p| *p == a.csv || *p == b.csv).collect();
            assert_eq!(kinds, own_csv, "{paths:?}");
        }
        // The damage was seen (so the last case compared salvaged reads).
        let streamed = StreamedRuns::scan(&[damaged, cut], false).expect("scans");
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
            let want = Runs::load(&paths, false)
                .expect_err("duplicate")
                .to_string();
            let got = StreamedRuns::scan(&paths, false)
                .expect_err("duplicate")
                .to_string();
            assert_eq!(got, want);
        }
    }
}
