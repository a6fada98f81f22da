//! Reading a run log whatever its format, chosen by the file's extension: `.mcap` (see
//! [`super::mcap`]) or `.csv` (the run CSV, [`super::run_csv`]). A ROS 2 bag directory from
//! `convert --to ros2-bag` reads as its MCAP file.

use super::csv_sink::{events_path, read_events, EventsFileError};
use super::mcap::{read_mcap_run, stream_mcap_run, Loss, McapError, Truncation};
use super::run_csv::{
    read_run_csv_salvaging, visit_own_run_csv, DroppedRow, RigRange, RunCsvFileError, RunCsvReader,
    RunSample,
};
use super::run_log::{LogEvent, RunLog, RunLogSink};
use crate::ros2::read::{bag_file, BagReadError};
use std::borrow::Cow;
use std::fmt;
use std::path::{Path, PathBuf};

/// A run log file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunFormat {
    /// The run CSV (`.csv`): physical samples only.
    Csv,
    /// MCAP (`.mcap`): frames, samples, commands and events.
    Mcap,
}

impl RunFormat {
    /// The format of the run log at `path`: by its extension (case-insensitive), or MCAP for a
    /// ROS 2 bag directory (one holding `metadata.yaml`, as `convert --to ros2-bag` writes it).
    pub fn of(path: &Path) -> Result<RunFormat, LoadError> {
        if is_bag_dir(path) {
            return Ok(RunFormat::Mcap);
        }
        RunFormat::of_name(path)
    }

    /// The format a run log written to `path` takes: by its extension alone (an output path is
    /// never read as a bag directory).
    pub fn of_name(path: &Path) -> Result<RunFormat, LoadError> {
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match extension.as_deref() {
            Some("csv") => Ok(RunFormat::Csv),
            Some("mcap") => Ok(RunFormat::Mcap),
            _ => Err(LoadError::UnknownFormat {
                path: path.to_owned(),
            }),
        }
    }
}

impl fmt::Display for RunFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            RunFormat::Csv => "run CSV",
            RunFormat::Mcap => "MCAP",
        })
    }
}

/// Whether `path` is a rosbag2 bag directory.
fn is_bag_dir(path: &Path) -> bool {
    path.join("metadata.yaml").is_file()
}

/// The MCAP file of the run log at `path`: `path` itself, or a bag directory's file.
fn mcap_file(path: &Path) -> Result<Cow<'_, Path>, LoadError> {
    if is_bag_dir(path) {
        Ok(Cow::Owned(bag_file(path).map_err(Box::new)?))
    } else {
        Ok(Cow::Borrowed(path))
    }
}

/// Why a run log could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The extension names no format this tool reads.
    #[error("{}: unknown run log format (supported: .mcap, .csv)", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The run CSV is unreadable or invalid.
    #[error(transparent)]
    Csv(#[from] RunCsvFileError),
    /// The MCAP file is unreadable, damaged or not a rover-power run.
    #[error(transparent)]
    Mcap(#[from] McapError),
    /// A bag directory whose MCAP file cannot be found (boxed: the bag reader's errors are
    /// large, and every load returns this type).
    #[error(transparent)]
    Bag(#[from] Box<BagReadError>),
    /// The events file beside a run CSV (`RUN.events.jsonl`) is unreadable or invalid.
    #[error(transparent)]
    Events(#[from] EventsFileError),
    /// Two inputs hold the same run (the same file passed twice, or a copy or conversion of
    /// it): counted twice, it would pose as an independent repeat.
    #[error("{second} holds the same run as {first} (identical samples); pass each run once")]
    DuplicateRun {
        /// The first input.
        first: String,
        /// The input that repeats it.
        second: String,
    },
    /// A file read again is no longer what it was on its first read.
    #[error("{}: the file changed while it was being read (it read as this tool's run CSV before, not now)", path.display())]
    Changed {
        /// The file.
        path: PathBuf,
    },
}

/// Refuses inputs that hold the same run, by content: the samples' bits, so a run and its
/// conversion to the other format (same samples exactly) are one run too. `names` name the
/// runs in the error; runs without samples are not compared.
pub fn refuse_duplicate_runs(names: &[String], runs: &[RunLog]) -> Result<(), LoadError> {
    use std::collections::HashMap;
    use std::hash::{Hash, Hasher};
    let mut seen: HashMap<u64, usize> = HashMap::new();
    for (i, run) in runs.iter().enumerate() {
        if run.samples.is_empty() {
            continue;
        }
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        for s in &run.samples {
            for v in s.required_values() {
                v.to_bits().hash(&mut hasher);
            }
        }
        let key = hasher.finish();
        if let Some(&first) = seen.get(&key) {
            // A hash match is confirmed on the samples themselves.
            if runs[first].samples == run.samples {
                return Err(duplicate_run(names, first, i));
            }
        }
        seen.entry(key).or_insert(i);
    }
    Ok(())
}

/// Run `second` repeats run `first` (indices into `names`, which name them).
fn duplicate_run(names: &[String], first: usize, second: usize) -> LoadError {
    let name = |k: usize| {
        names
            .get(k)
            .cloned()
            .unwrap_or_else(|| format!("run {}", k + 1))
    };
    LoadError::DuplicateRun {
        first: name(first),
        second: name(second),
    }
}

/// What identifies a run's content without keeping it, for runs read as streams: the samples'
/// count and a 128-bit hash of their bits (the values [`refuse_duplicate_runs`] compares), so
/// two runs match only if their samples do, but for a chance of about 2⁻⁶⁴ (a difference
/// changes one of four independent 64-bit lanes). Lanes of a folded multiply (as wyhash's)
/// rather than SipHash: the digest runs on every sample of the run, on one core.
#[derive(Debug, Clone)]
pub struct RunDigest {
    samples: u64,
    lanes: [u64; 4],
}

/// Odd 64-bit constants (wyhash's), one per lane: each lane's multiplier and start.
const LANE_KEYS: [u64; 4] = [
    0xa076_1d64_78bd_642f,
    0xe703_7ed1_a0b4_28db,
    0x8ebc_6af0_9c88_c6e3,
    0x5899_65cc_7537_4cc3,
];

impl Default for RunDigest {
    fn default() -> Self {
        Self {
            samples: 0,
            lanes: LANE_KEYS.map(|k| k.rotate_left(32)),
        }
    }
}

/// The 128-bit product of `a` and `b`, its halves folded into 64 bits.
fn folded_multiply(a: u64, b: u64) -> u64 {
    let p = u128::from(a) * u128::from(b);
    (p as u64) ^ ((p >> 64) as u64)
}

impl RunDigest {
    /// The run's next sample.
    pub fn push(&mut self, s: &RunSample) {
        self.samples += 1;
        // Value i into lane i mod 4: four independent chains (the multiplies overlap).
        for (i, v) in s.required_values().into_iter().enumerate() {
            let lane = i % LANE_KEYS.len();
            let key = LANE_KEYS[lane];
            self.lanes[lane] = folded_multiply(self.lanes[lane] ^ v.to_bits(), key) ^ key;
        }
    }

    fn key(&self) -> (u64, u64, u64) {
        let [a, b, c, d] = self.lanes;
        (
            self.samples,
            folded_multiply(a ^ LANE_KEYS[2], b ^ LANE_KEYS[3]),
            folded_multiply(c ^ LANE_KEYS[0], d ^ LANE_KEYS[1]),
        )
    }
}

/// [`refuse_duplicate_runs`] for runs read as streams, by their digests.
pub fn refuse_duplicate_digests(names: &[String], digests: &[&RunDigest]) -> Result<(), LoadError> {
    use std::collections::HashMap;
    let mut seen: HashMap<(u64, u64, u64), usize> = HashMap::new();
    for (i, digest) in digests.iter().enumerate() {
        if digest.samples == 0 {
            continue;
        }
        if let Some(&first) = seen.get(&digest.key()) {
            return Err(duplicate_run(names, first, i));
        }
        seen.insert(digest.key(), i);
    }
    Ok(())
}

/// [`load_salvaging`] without keeping the run: its records go to `sink` in file order, so
/// memory stays bounded whatever the file's length (an MCAP file holds a few chunks at a time,
/// a run CSV one row). The same records, losses and dropped rows as [`load_salvaging`].
pub fn stream_salvaging(
    path: &Path,
    salvage: bool,
    range: RigRange,
    sink: &mut dyn RunLogSink,
) -> Result<StreamFound, LoadError> {
    match RunFormat::of(path)? {
        RunFormat::Csv => {
            let file_err = |e| RunCsvFileError {
                path: path.to_owned(),
                source: e,
            };
            let file = std::fs::File::open(path).map_err(|e| file_err(e.into()))?;
            let mut reader = RunCsvReader::new(std::io::BufReader::with_capacity(1 << 16, file))
                .map_err(file_err)?
                .salvaging(salvage)
                .within(range);
            let mut events = CsvEvents::of(path)?;
            for sample in reader.by_ref() {
                let sample = sample.map_err(file_err)?;
                events
                    .then_sample(&sample, sink)
                    .map_err(|e| file_err(e.into()))?;
            }
            events.finish(sink).map_err(|e| file_err(e.into()))?;
            Ok(StreamFound::csv(reader.dropped().to_vec()))
        }
        RunFormat::Mcap => {
            let found = stream_mcap_run(&mcap_file(path)?, sink)?;
            Ok(StreamFound {
                run: (),
                format: RunFormat::Mcap,
                truncated: found.truncated,
                losses: found.losses,
                dropped_rows: Vec::new(),
            })
        }
    }
}

/// [`stream_salvaging`]'s records of the run CSV at `path` through the run CSV's fast path
/// ([`visit_own_run_csv`]), if the file is one of this tool's own (valid throughout, readings
/// within `range`): every record went to `sink`, the events in time order among the samples.
/// `None` for any other file, when `sink` may have had some of its records (not all): a caller
/// that knows the file is its own (it was read so before) takes it as the file having changed.
pub fn stream_own_run_csv(
    path: &Path,
    range: RigRange,
    sink: &mut (dyn RunLogSink + Send),
) -> Result<Option<StreamFound>, LoadError> {
    let file_err = |e: std::io::Error| RunCsvFileError {
        path: path.to_owned(),
        source: e.into(),
    };
    let mut events = CsvEvents::of(path)?;
    // A sink's write error stops the records (the rest of the file is still parsed: the
    // visitor cannot stop the read) and is returned.
    let mut failed: Option<std::io::Error> = None;
    let own = visit_own_run_csv(path, range, &mut |rows| {
        for sample in rows {
            if failed.is_some() {
                return;
            }
            if let Err(e) = events.then_sample(sample, sink) {
                failed = Some(e);
            }
        }
    })?;
    if let Some(e) = failed {
        return Err(file_err(e).into());
    }
    if !own {
        return Ok(None);
    }
    events.finish(sink).map_err(file_err)?;
    Ok(Some(StreamFound::csv(Vec::new())))
}

/// A run CSV's events (its `RUN.events.jsonl`), handed to a sink in time order among its
/// samples, as an MCAP file holds them.
struct CsvEvents(std::iter::Peekable<std::vec::IntoIter<(f64, LogEvent)>>);

impl CsvEvents {
    /// The events of the run CSV at `path` ([`csv_events`]).
    fn of(path: &Path) -> Result<Self, EventsFileError> {
        Ok(Self(csv_events(path)?.into_iter().peekable()))
    }

    /// The events up to `sample`'s time into `sink`, then `sample`.
    fn then_sample(
        &mut self,
        sample: &RunSample,
        sink: &mut (impl RunLogSink + ?Sized),
    ) -> std::io::Result<()> {
        while let Some((t_s, event)) = self.0.next_if(|(t_s, _)| *t_s <= sample.t_s) {
            sink.event(t_s, &event)?;
        }
        sink.sample(sample)
    }

    /// The events after the last sample into `sink`.
    fn finish(self, sink: &mut (impl RunLogSink + ?Sized)) -> std::io::Result<()> {
        self.0
            .into_iter()
            .try_for_each(|(t_s, event)| sink.event(t_s, &event))
    }
}

/// What reading a run log gave: the run (or, read as a stream, `()`: its records went to a
/// sink), with what the caller should tell the user about it.
#[derive(Debug, Clone, PartialEq)]
pub struct Loaded<R> {
    /// The run.
    pub run: R,
    /// The file's format.
    pub format: RunFormat,
    /// For an MCAP file cut short (recorder killed): where; the run holds what came before.
    pub truncated: Option<Truncation>,
    /// For a damaged MCAP file: the stretches skipped (the run holds everything else).
    pub losses: Vec<Loss>,
    /// For a run CSV: the rows left out (a cut last row; damaged rows with salvage).
    pub dropped_rows: Vec<DroppedRow>,
}

/// A run log loaded whole.
pub type LoadedRun = Loaded<RunLog>;

/// What reading a run log as a stream found besides its records ([`stream_salvaging`]).
pub type StreamFound = Loaded<()>;

impl StreamFound {
    /// What streaming a run CSV found: the rows it left out.
    fn csv(dropped_rows: Vec<DroppedRow>) -> Self {
        Loaded {
            run: (),
            format: RunFormat::Csv,
            truncated: None,
            losses: Vec::new(),
            dropped_rows,
        }
    }
}

impl<R> Loaded<R> {
    /// Whether data inside the file was lost to damage (not counting a cut end: a truncated
    /// MCAP file or a cut last CSV row, which a killed recorder leaves).
    pub fn lost_data(&self) -> bool {
        lost_data(&self.losses, &self.dropped_rows)
    }

    /// The run, and what reading it found.
    pub fn split(self) -> (R, StreamFound) {
        let Loaded {
            run,
            format,
            truncated,
            losses,
            dropped_rows,
        } = self;
        let found = Loaded {
            run: (),
            format,
            truncated,
            losses,
            dropped_rows,
        };
        (run, found)
    }
}

/// Whether a read lost data inside the file: a skipped MCAP stretch or a damaged (not cut)
/// CSV row.
pub fn lost_data(losses: &[Loss], dropped_rows: &[DroppedRow]) -> bool {
    !losses.is_empty() || dropped_rows.iter().any(|r| !r.cut)
}

/// Loads the run log at `path` (`.mcap` or `.csv`), reporting a truncated or damaged MCAP file
/// and a cut last CSV row; a damaged CSV row is an error. A run CSV may hold any physical
/// reading.
pub fn load(path: &Path) -> Result<LoadedRun, LoadError> {
    load_salvaging(path, false, RigRange::default())
}

/// [`load`], and with `salvage` damaged CSV rows are left out (and listed) instead of refused.
/// (A damaged MCAP file is always salvaged: its losses are listed.) A run CSV's readings must
/// lie within `range` (an MCAP file's within the board's: they come from its registers).
pub fn load_salvaging(path: &Path, salvage: bool, range: RigRange) -> Result<LoadedRun, LoadError> {
    match RunFormat::of(path)? {
        RunFormat::Csv => {
            let (samples, dropped_rows) = read_run_csv_salvaging(path, salvage, range)?;
            let events = csv_events(path)?;
            Ok(LoadedRun {
                run: RunLog {
                    samples,
                    events,
                    ..RunLog::default()
                },
                format: RunFormat::Csv,
                truncated: None,
                losses: Vec::new(),
                dropped_rows,
            })
        }
        RunFormat::Mcap => {
            let mcap = read_mcap_run(&mcap_file(path)?)?;
            Ok(LoadedRun {
                run: mcap.run,
                format: RunFormat::Mcap,
                truncated: mcap.truncated,
                losses: mcap.losses,
                dropped_rows: Vec::new(),
            })
        }
    }
}

/// The events of the run CSV at `path`: the recorder's marks (device vanished, samples lost,
/// wall clock, ...) in its events file (`RUN.events.jsonl`) when there is one, so that a
/// conversion to MCAP or a live replay carries them.
fn csv_events(path: &Path) -> Result<Vec<(f64, LogEvent)>, EventsFileError> {
    let events = events_path(path);
    if events.is_file() {
        read_events(&events)
    } else {
        Ok(Vec::new())
    }
}

/// Loads the run log at `path` (`.mcap` or `.csv`). A truncated MCAP file loads up to its last
/// complete record; use [`load`] to learn whether it was.
pub fn load_run(path: &Path) -> Result<RunLog, LoadError> {
    load(path).map(|loaded| loaded.run)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::tests_support::TempDir;

    #[test]
    fn the_same_run_twice_is_refused_by_content() {
        use crate::log::run_csv::RunSample;
        use model_core::Sides;
        let run = |current: f64| RunLog {
            samples: (0..50)
                .map(|i| RunSample {
                    t_s: f64::from(i) * 0.01,
                    bus_v: Sides::new(24.0, 24.0),
                    current_a: Sides::new(current, 1.0),
                    cmd_mps: Sides::new(0.3, 0.3),
                    yaw_rad: None,
                    pitch_deg: None,
                    x_m: None,
                    y_m: None,
                })
                .collect(),
            ..RunLog::default()
        };
        let names = ["a.csv", "b.mcap", "c.csv"].map(String::from);
        assert!(refuse_duplicate_runs(&names, &[run(1.0), run(2.0), run(3.0)]).is_ok());
        let e = refuse_duplicate_runs(&names, &[run(1.0), run(2.0), run(1.0)]).expect_err("dup");
        assert_eq!(
            e.to_string(),
            "c.csv holds the same run as a.csv (identical samples); pass each run once"
        );
        assert!(
            refuse_duplicate_runs(&names[..2], &[RunLog::default(), RunLog::default()]).is_ok()
        );
    }

    #[test]
    fn digests_tell_runs_apart_by_any_value() {
        use crate::log::run_csv::RunSample;
        use model_core::Sides;
        let run: Vec<RunSample> = (0..40)
            .map(|i| {
                let x = f64::from(i);
                RunSample::new(
                    x * 0.005,
                    Sides::new(24.0 + x, 24.5),
                    Sides::new(1.0, -x),
                    Sides::new(0.3, 0.1),
                )
            })
            .collect();
        let digest = |samples: &[RunSample]| {
            let mut d = RunDigest::default();
            samples.iter().for_each(|s| d.push(s));
            d.key()
        };
        assert_eq!(digest(&run), digest(&run.clone()));
        assert_ne!(digest(&run), digest(&run[..39]));
        // One value changed, in each column and at each place: another digest.
        for at in [0, 17, 39] {
            for column in 0..7 {
                let mut changed = run.clone();
                let s = &mut changed[at];
                let v = match column {
                    0 => &mut s.t_s,
                    1 => &mut s.bus_v.left,
                    2 => &mut s.bus_v.right,
                    3 => &mut s.current_a.left,
                    4 => &mut s.current_a.right,
                    5 => &mut s.cmd_mps.left,
                    _ => &mut s.cmd_mps.right,
                };
                *v = -*v - 1e-9;
                assert_ne!(
                    digest(&run),
                    digest(&changed),
                    "sample {at}, column {column}"
                );
            }
        }
        // Two samples swapped: another digest.
        let mut swapped = run.clone();
        swapped.swap(3, 4);
        assert_ne!(digest(&run), digest(&swapped));
    }

    #[test]
    fn format_by_extension() {
        assert_eq!(
            RunFormat::of(Path::new("a/run.csv")).ok(),
            Some(RunFormat::Csv)
        );
        assert_eq!(
            RunFormat::of(Path::new("run.MCAP")).ok(),
            Some(RunFormat::Mcap)
        );
        for bad in ["run.txt", "run", "run.csv.gz", ".mcap"] {
            let e = RunFormat::of(Path::new(bad)).expect_err(bad);
            assert_eq!(
                e.to_string(),
                format!("{bad}: unknown run log format (supported: .mcap, .csv)")
            );
        }
    }

    #[test]
    fn csv_loads_samples_only_and_errors_name_the_file() {
        let dir = TempDir::new("load-csv");
        let path = dir.path().join("run.csv");
        std::fs::write(
            &path,
            "t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,cmd_left_mps,cmd_right_mps\n\
             0,24,1,24,2,0.1,0.2\n0.005,24,1.5,24,2.5,0.1,0.2\n",
        )
        .expect("write");
        let loaded = load(&path).expect("valid");
        assert_eq!(loaded.format, RunFormat::Csv);
        assert_eq!(loaded.run.samples.len(), 2);
        assert!(loaded.run.frames.is_empty() && loaded.truncated.is_none());

        std::fs::write(&path, "t_s\n").expect("write");
        let e = load_run(&path).expect_err("missing columns");
        assert!(
            e.to_string().starts_with(&path.display().to_string()),
            "{e}"
        );

        let mcap = dir.path().join("run.mcap");
        std::fs::write(&mcap, "t_s,left_bus_v\n").expect("write");
        let e = load_run(&mcap).expect_err("a CSV named .mcap");
        assert!(
            matches!(e, LoadError::Mcap(McapError::NotMcap { .. })),
            "{e}"
        );
        assert!(e.to_string().contains("not an MCAP file"), "{e}");
    }
}
