//! Throughput of decode → samples → per-manoeuvre statistics on a large recorded log, side by
//! side with a plain numpy reader of the same file: `bench/throughput.sh` (or
//! `cargo bench -p host-tool --bench turn_stats`).
//!
//! The log is an hour of the simulated Husky on sand (the seed's turn set at 0.3 m/s, repeated)
//! measured by the simulated board — the firmware's own code on the simulated I²C bus — and
//! recorded by this tool's recorder (`record::record_on`) over a port that *is* that board: the
//! bytes it sends are the raw capture (`large-run.bin`), the commands the recorder forwards reach
//! it, and the recorder's samples become the run CSV (`large-run.csv`, with the commands file
//! `large-run.commands.csv`) while the same recording goes, as `host-tool record --out run.mcap`
//! writes it, through [`McapSink`] into the MCAP log (`large-run.mcap`: frames, samples,
//! commands, events). Generated once into `target/bench-data/` (again when a file is missing or
//! was made by another version of this generator).
//!
//! Timed, best of [`REPEATS`] in one process, each from the file on disk to the statistics
//! (on all cores, as the multi-threaded Python readers):
//! 1. Rust, run CSV: what `host-tool validate --rover rovers/husky-a200.toml --runs FILE`
//!    runs, the same library calls: [`StreamedRuns::scan`] (this tool's run CSV read once,
//!    parsed on every core, and validated as it is read: content digest, facts, segmentation,
//!    each manoeuvre's statistics and tracked turn) → [`StreamedRuns::validate`] (the ICR fit,
//!    the report); only the printing is left out.
//! 2. Rust, raw capture: the recorder over the capture bytes (decode, scale, commands from the
//!    commands file) → `segment` → `analyse`.
//! 3. Rust, MCAP: what `host-tool validate` runs on it, as 1. ([`StreamedRuns::scan`]
//!    streams the log once, its chunks decompressed on a second core, and validates it as it
//!    is read: digest, facts, segmentation, statistics, the board's frames cross-checked with
//!    the commands read so far; a second read only where that pass's guesses fail).
//!    The raw path computes the gap threshold beside `segment`, then `analyse` in shares of
//!    about equal samples, one per core.
//! 4. The page-cache floor: the run CSV's bytes read again, nothing parsed.
//! 5. Python peers on the run CSV (subprocesses; their own timing): `bench/numpy_turn_stats.py`
//!    (`numpy.loadtxt`), `bench/arrow_turn_stats.py` (`pyarrow.csv`, multi-threaded),
//!    `bench/polars_turn_stats.py` (polars, multi-threaded).
//! 6. `bench/mcap_turn_stats.py` on the MCAP log: the `mcap` package's reader with
//!    `mcap-protobuf-support`'s decoder, each sample batch's columns as numpy arrays, the same
//!    statistics as 5.
//!
//! Every ratio is printed from this one run, and each Rust path against its fastest peer.
//!
//! The Rust paths and the Python scripts must agree (same spans — each manoeuvre `validate`
//! analysed is a span of theirs, and the raw path's spans are theirs —, same per-span energies
//! within 1e-14 relative, the raw and MCAP logs' samples equal to the CSV's) or the bench
//! fails.
//! Without python3 or its packages the Rust figures are still printed, with the install line.
//! Under `cargo test --benches` (no `--bench` argument) the log is two simulated minutes and each
//! path runs once.
//!
//! `-- --seconds S` generates (or reuses) a log of S simulated seconds instead of an hour
//! (`run-<S>s.*`); `-- --generate-only` stops after generating (e.g. the 4-hour log that
//! `validate`'s memory is measured on: `-- --seconds 14400 --generate-only`); `-- --csv-only`
//! (`-- --mcap-only`) times the Rust run-CSV (MCAP) path alone, printing each run's stages (to
//! run under a profiler).

use anyhow::{bail, ensure, Context, Result};
use firmware::sampler::SamplerConfig;
use host_tool::log::commands::{read_commands_csv, write_commands_csv_atomically, CommandRow};
use host_tool::log::load::load_run;
use host_tool::log::mcap::McapSink;
use host_tool::log::run_csv::{read_run_csv, write_run_csv_atomically, RigRange, RunSample};
use host_tool::log::run_log::{LogEvent, RunLogSink};
use host_tool::log::write_atomically;
use host_tool::record::{record_on, BoardPort, RecordOptions, RecordSummary, StopReason};
use host_tool::rover::load_rover_file;
use host_tool::runs::StreamedRuns;
use host_tool::serial::SerialError;
use host_tool::sim::board::SimBoard;
use host_tool::sim::world::{Scenario, WorldConfig};
use host_tool::validate::segment::{gap_threshold_s, segment, Segment, SegmentOptions};
use host_tool::validate::turns::{analyse, ManoeuvreStats, TurnOptions, DEFAULT_SETTLE_S};
use host_tool::validate::ValidateOptions;
use model_core::wire::BoardFrame;
use model_core::Rover;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Timed repetitions of each path (the best is reported).
const REPEATS: usize = 5;
/// Seed of the world's noise.
const SEED: u64 = 4;
/// Side speed of the seed's turn set [m/s].
const V_C_MPS: f64 = 0.3;
/// Rate of the tracker rows in the commands file [Hz].
const TRACKER_HZ: f64 = 20.0;
/// Board periods run per read of the simulated port (40 ms at 200 Hz, as a host reading a
/// USB CDC port gets several frames at a time).
const STEPS_PER_READ: u64 = 8;
/// Bump when the generated files change (cached files of another version are regenerated).
const GENERATOR_VERSION: u32 = 8;
/// The goal of issue 12: each Rust path at least this many times as fast as the fastest Python
/// peer on the same file.
const GOAL_RATIO: f64 = 2.0;
/// Largest relative difference of a per-span energy between Rust and numpy.
const ENERGY_TOLERANCE: f64 = 1e-14;

fn main() -> Result<()> {
    // Like divan: without cargo bench's `--bench` (i.e. under `cargo test`), or with `--test`,
    // run briefly.
    let args: Vec<String> = std::env::args().collect();
    let test_mode = args.iter().any(|a| a == "--test") || !args.iter().any(|a| a == "--bench");
    let (name, seconds, repeats) = match option_value(&args, "--seconds")? {
        Some(s) => (format!("run-{s}s"), s, REPEATS),
        None if test_mode => ("small-run".to_owned(), 120.0, 1),
        None => ("large-run".to_owned(), 3_600.0, REPEATS),
    };
    let files = Files::new(&bench_data_dir()?, &name);
    ensure_log(&files, seconds)?;
    if args.iter().any(|a| a == "--generate-only") {
        println!("Generated {}", files.mcap.display());
        return Ok(());
    }
    let csv_bytes = std::fs::metadata(&files.csv)?.len();
    if args.iter().any(|a| a == "--csv-only") {
        return profile_alone("run CSV", &files.csv, CSV_STAGES, repeats);
    }
    if args.iter().any(|a| a == "--mcap-only") {
        return profile_alone("MCAP", &files.mcap, MCAP_STAGES, repeats);
    }
    let bin_bytes = std::fs::metadata(&files.bin)?.len();
    let mcap_bytes = std::fs::metadata(&files.mcap)?.len();

    let validate = ValidateSetup::load()?;
    let rover = validate.rover;
    // The run CSV's samples, for the other paths to be compared with (not timed).
    let csv_samples = read_run_csv(&files.csv)?;
    ensure!(
        load_run(&files.mcap)?.samples == csv_samples,
        "the MCAP log's samples differ from the run CSV's"
    );
    let mut baselines = [
        Baseline::new("numpy_turn_stats.py", &files.csv, &["numpy"]),
        Baseline::new("arrow_turn_stats.py", &files.csv, &["numpy", "pyarrow"]),
        Baseline::new("polars_turn_stats.py", &files.csv, &["numpy", "polars"]),
        Baseline::new(
            "mcap_turn_stats.py",
            &files.mcap,
            &["numpy", "mcap", "mcap_protobuf"],
        ),
    ];
    // The floor: the run CSV's bytes read again from the page cache, nothing parsed.
    let mut floor_best: Option<Duration> = None;
    // Round by round, so all paths see the same load on a shared machine.
    let (mut csv_best, mut raw_best, mut mcap_best) = (None, None, None);
    for _ in 0..repeats {
        keep_best(
            &mut csv_best,
            rust_validate(&files.csv, &validate, CSV_STAGES)?,
        );
        keep_best(&mut raw_best, rust_from_raw(&files, &rover)?);
        keep_best(
            &mut mcap_best,
            rust_validate(&files.mcap, &validate, MCAP_STAGES)?,
        );
        let t = Instant::now();
        let bytes = std::fs::read(&files.csv)?;
        let floor = t.elapsed();
        std::hint::black_box(bytes);
        floor_best = Some(floor_best.map_or(floor, |b| b.min(floor)));
        for baseline in &mut baselines {
            baseline.run()?;
        }
    }
    let (csv_time, csv_result) = csv_best.context("no run")?;
    let (raw_time, raw_result) = raw_best.context("no run")?;
    let (mcap_time, mcap_result) = mcap_best.context("no run")?;
    ensure!(
        raw_result.samples == csv_samples,
        "the raw capture's samples differ from the run CSV's"
    );
    let rows = csv_samples.len();
    let spans = raw_result.spans.len();
    println!(
        "Log: {} ({rows} rows, {:.1} MB run CSV; {:.1} MB raw capture; {:.1} MB MCAP), {spans} spans of ≥ 2 samples, {} manoeuvres analysed by validate",
        files.csv.display(),
        csv_bytes as f64 / 1e6,
        bin_bytes as f64 / 1e6,
        mcap_bytes as f64 / 1e6,
        csv_result.spans.len(),
    );
    let line = |what: &str, t: Duration, bytes: u64| {
        let s = t.as_secs_f64();
        println!(
            "  {what:<44} {:>9.1} ms  {:>7.2} M rows/s  {:>7.1} MB/s",
            s * 1e3,
            rows as f64 / s / 1e6,
            bytes as f64 / s / 1e6
        );
    };
    println!("Best of {repeats}, from the file on disk to per-manoeuvre statistics:");
    line("Rust, run CSV (validate's path)", csv_time, csv_bytes);
    println!("    ({})", csv_result.stages);
    line("Rust, raw capture", raw_time, bin_bytes);
    println!("    ({})", raw_result.stages);
    line("Rust, MCAP (validate's path)", mcap_time, mcap_bytes);
    println!("    ({})", mcap_result.stages);

    let floor_time = floor_best.context("no run")?;
    line(
        "page-cache read of the run CSV (floor)",
        floor_time,
        csv_bytes,
    );
    println!(
        "  Rust run CSV path reaches {:.1} % of the page-cache floor (goal ≥ 25 %)",
        100.0 * floor_time.as_secs_f64() / csv_time.as_secs_f64()
    );
    let mut ratios = Vec::new();
    for (baseline, rust, rust_name, bytes) in [
        (&baselines[0], &csv_result, "run CSV", csv_bytes),
        (&baselines[1], &csv_result, "run CSV", csv_bytes),
        (&baselines[2], &csv_result, "run CSV", csv_bytes),
        (&baselines[3], &mcap_result, "MCAP", mcap_bytes),
    ] {
        let label = format!("Python, {rust_name} (bench/{})", baseline.script);
        match &baseline.best {
            None => {
                println!(
                    "  {label}: skipped: {}",
                    baseline.missing.as_deref().unwrap_or("not run")
                );
                println!(
                    "    install with: python3 -m pip install {}   (or run bench/throughput.sh)",
                    baseline.packages.join(" ")
                );
            }
            Some((seconds, spans)) => {
                line(&label, Duration::from_secs_f64(*seconds), bytes);
                // validate analyses the manoeuvres (not standstill or too short): each is a
                // span of the peer's.
                let diff = cross_check(rust, spans, false)?;
                // The raw path's statistics are of every span: the peer's list.
                let raw_diff = cross_check(&raw_result, spans, true)?;
                println!(
                    "    agreement with Rust ({rust_name}): {} spans, {} of them in Rust, starts equal; largest relative energy difference {diff:.1e} (raw capture path, every span: {raw_diff:.1e})",
                    spans.len(),
                    rust.spans.len()
                );
                if rust_name == "run CSV" {
                    ratios.push(("run CSV", baseline.script, seconds / csv_time.as_secs_f64()));
                    ratios.push((
                        "raw capture",
                        baseline.script,
                        seconds / raw_time.as_secs_f64(),
                    ));
                } else {
                    ratios.push(("MCAP", baseline.script, seconds / mcap_time.as_secs_f64()));
                }
            }
        }
    }
    print_ratios(&ratios);
    Ok(())
}

/// Each Rust path's ratio to each Python peer (the peer's time over ours), then against the
/// fastest peer of each path with the goal.
fn print_ratios(ratios: &[(&str, &str, f64)]) {
    for (rust_name, script, r) in ratios {
        println!(
            "  Rust ({rust_name}) / {script}:{:>w$}{r:>6.1}×",
            "",
            w = 34usize.saturating_sub(rust_name.len() + script.len())
        );
    }
    // Against the fastest peer of each path (the ratio is the peer's time over ours).
    for rust_name in ["run CSV", "MCAP"] {
        let fastest = ratios
            .iter()
            .filter(|(name, _, _)| *name == rust_name)
            .min_by(|a, b| a.2.total_cmp(&b.2));
        if let Some((_, script, r)) = fastest {
            let mark = if *r >= GOAL_RATIO { "met" } else { "NOT met" };
            println!(
                "  Rust ({rust_name}) vs the fastest Python peer ({script}): {r:.2}× (goal ≥ {GOAL_RATIO}×: {mark})"
            );
        }
    }
}

/// `-- --csv-only`, `-- --mcap-only`: one Rust path alone, each run's stages printed (for a
/// profiler).
fn profile_alone(what: &str, path: &Path, stages: [&'static str; 2], repeats: usize) -> Result<()> {
    let validate = ValidateSetup::load()?;
    for _ in 0..repeats {
        let result = rust_validate(path, &validate, stages)?;
        println!(
            "Rust, {what}: {:.1} ms ({})",
            result.stages.total().as_secs_f64() * 1e3,
            result.stages
        );
    }
    Ok(())
}

/// The number after `option` in `args`, if given.
fn option_value(args: &[String], option: &str) -> Result<Option<f64>> {
    let Some(at) = args.iter().position(|a| a == option) else {
        return Ok(None);
    };
    let value = args
        .get(at + 1)
        .with_context(|| format!("{option} needs a value"))?;
    let v: f64 = value
        .parse()
        .with_context(|| format!("{option} {value:?}: not a number"))?;
    ensure!(v.is_finite() && v > 0.0, "{option} must be > 0");
    Ok(Some(v))
}

/// The generated files of one log.
struct Files {
    bin: PathBuf,
    csv: PathBuf,
    commands: PathBuf,
    mcap: PathBuf,
    stamp: PathBuf,
}

impl Files {
    fn new(dir: &Path, name: &str) -> Self {
        Self {
            bin: dir.join(format!("{name}.bin")),
            csv: dir.join(format!("{name}.csv")),
            commands: dir.join(format!("{name}.commands.csv")),
            mcap: dir.join(format!("{name}.mcap")),
            stamp: dir.join(format!("{name}.version")),
        }
    }
}

/// `target/bench-data` of the target directory this bench was built in.
fn bench_data_dir() -> Result<PathBuf> {
    // The bench runs as target/<profile>/deps/turn_stats-<hash>.
    let exe = std::env::current_exe().context("locating the bench executable")?;
    let target = exe
        .ancestors()
        .nth(3)
        .map(Path::to_owned)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../target"));
    let dir = target.join("bench-data");
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    Ok(dir)
}

/// What the generated files are: a change of any of these regenerates them.
fn stamp(seconds: f64) -> String {
    format!("generator {GENERATOR_VERSION}, seed {SEED}, sand, seed turns at {V_C_MPS} m/s, ≥ {seconds} s, tracker {TRACKER_HZ} Hz\n")
}

/// Generates the log unless all its files exist and were made for `seconds` by this generator.
fn ensure_log(files: &Files, seconds: f64) -> Result<()> {
    let want = stamp(seconds);
    let have = std::fs::read_to_string(&files.stamp).unwrap_or_default();
    let all_there = [&files.bin, &files.csv, &files.commands, &files.mcap]
        .iter()
        .all(|f| f.exists());
    if have == want && all_there {
        return Ok(());
    }
    let _ = std::fs::remove_file(&files.stamp);
    let started = Instant::now();
    println!(
        "Generating {} (once; ≈ {:.0} simulated minutes)...",
        files.csv.display(),
        seconds / 60.0
    );
    let world = WorldConfig::sand();
    // Duration = fixed (lead-in, lead-out) + repeats × one pass of the turn set.
    let one = world.simulate(&Scenario::seed_turns(V_C_MPS, 1), SEED)?;
    let two = world.simulate(&Scenario::seed_turns(V_C_MPS, 2), SEED)?;
    let per_repeat_s = two.duration_s() - one.duration_s();
    let fixed_s = one.duration_s() - per_repeat_s;
    let repeats = ((seconds - fixed_s) / per_repeat_s).ceil().max(1.0) as u32;
    let timeline = Arc::new(world.simulate(&Scenario::seed_turns(V_C_MPS, repeats), SEED)?);
    let commands = timeline.commands(TRACKER_HZ);

    let mut board = SimBoard::new(SamplerConfig::BOARD);
    board.set_load(timeline.load_source());
    board.set_host_connected(true);
    let period_us = u64::from(board.board().sample_period_us().max(1));
    let steps = timeline.duration_us() / period_us + 1;
    let capture = Arc::new(Mutex::new(Vec::new()));
    let port = SimPort {
        board,
        steps_left: steps,
        pending: Vec::new(),
        at: 0,
        capture: Arc::clone(&capture),
    };
    // The MCAP log is written live by the recorder, as `host-tool record --out run.mcap` does;
    // renamed into place once finished.
    let mcap_partial = files.mcap.with_extension("mcap.partial");
    let mut sink = Tee {
        samples: SampleSink::default(),
        mcap: McapSink::create(&mcap_partial, true)?,
    };
    let summary = record(Box::new(port), commands.clone(), &mut sink)?;
    let sink = sink.samples;
    std::fs::rename(&mcap_partial, &files.mcap)
        .with_context(|| format!("renaming {} into place", mcap_partial.display()))?;
    ensure!(
        summary.stream.lost_samples == 0
            && summary.stream.bad_frames == 0
            && summary.incomplete_samples <= 1,
        "the simulated recording lost data: {summary}"
    );
    let capture = std::mem::take(&mut *capture.lock().map_err(|_| anyhow::anyhow!("poisoned"))?);

    write_atomically(&files.bin, host_tool::log::Existing::Replace, |out| {
        out.write_all(&capture)
    })?;
    write_commands_csv_atomically(
        &files.commands,
        host_tool::log::Existing::Replace,
        &commands,
    )?;
    write_run_csv_atomically(&files.csv, host_tool::log::Existing::Replace, &sink.samples)?;
    std::fs::write(&files.stamp, want)?;
    println!(
        "  {} repeats of the turn set, {:.1} min, {} samples, {} commands forwarded ({} acked), {:.1} s",
        repeats,
        timeline.duration_s() / 60.0,
        sink.samples.len(),
        summary.commands_sent,
        summary.commands_acked,
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Records `port` with `commands` into `sink` until the port hangs up (the end of the capture).
fn record(
    port: Box<dyn BoardPort>,
    commands: Vec<CommandRow>,
    sink: &mut dyn RunLogSink,
) -> Result<RecordSummary> {
    let options = RecordOptions {
        commands,
        // The port hanging up is the end of the log: stop at once.
        reconnect_timeout: Duration::ZERO,
        ..RecordOptions::new("capture")
    };
    let mut no_reopen = |path: &str| -> Result<Box<dyn BoardPort>, SerialError> {
        Err(SerialError::Open {
            path: path.to_owned(),
            source: serialport::Error::new(serialport::ErrorKind::NoDevice, "end of capture"),
        })
    };
    let stop = AtomicBool::new(false);
    let summary = record_on(&options, port, &mut no_reopen, sink, &stop, &mut |_| {})?;
    ensure!(
        summary.stop == StopReason::DeviceGone,
        "recording stopped early: {}",
        summary.stop
    );
    Ok(summary)
}

/// The simulated board as a serial port: each read runs a few board periods and hands out their
/// bytes (keeping a copy: the raw capture); what the host writes reaches the board's link, as
/// the USB interrupt would hand it over. After the last period it hangs up (end of file).
struct SimPort {
    board: SimBoard,
    steps_left: u64,
    pending: Vec<u8>,
    at: usize,
    capture: Arc<Mutex<Vec<u8>>>,
}

impl Read for SimPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.at == self.pending.len() {
            self.pending.clear();
            self.at = 0;
            for _ in 0..STEPS_PER_READ.min(self.steps_left) {
                self.board.step();
                self.board.drain_into(&mut self.pending)?;
                self.steps_left -= 1;
            }
            if self.pending.is_empty() {
                return Ok(0);
            }
            self.capture
                .lock()
                .map_err(|_| io::Error::other("poisoned"))?
                .extend_from_slice(&self.pending);
        }
        let n = buf.len().min(self.pending.len() - self.at);
        buf[..n].copy_from_slice(&self.pending[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

impl Write for SimPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.board.receive(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// A recorded capture played back as a serial port (reads of up to the reader's chunk size),
/// then a hang-up; what the host writes goes nowhere (this board is a recording).
struct ReplayPort {
    bytes: Arc<Vec<u8>>,
    at: usize,
}

impl Read for ReplayPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let rest = self.bytes.get(self.at..).unwrap_or_default();
        let n = buf.len().min(rest.len());
        buf[..n].copy_from_slice(&rest[..n]);
        self.at += n;
        Ok(n)
    }
}

impl Write for ReplayPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        Ok(buf.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// A run log that keeps only the physical samples (what the statistics need).
#[derive(Default)]
struct SampleSink {
    samples: Vec<RunSample>,
}

impl RunLogSink for SampleSink {
    fn sample(&mut self, sample: &RunSample) -> io::Result<()> {
        self.samples.push(*sample);
        Ok(())
    }
}

/// The recorder's log going both to memory (the samples, for the run CSV) and to the MCAP file.
struct Tee {
    samples: SampleSink,
    mcap: McapSink<io::BufWriter<std::fs::File>>,
}

impl RunLogSink for Tee {
    fn frame(&mut self, t_s: f64, frame: &BoardFrame) -> io::Result<()> {
        self.mcap.frame(t_s, frame)
    }
    fn sample(&mut self, sample: &RunSample) -> io::Result<()> {
        self.samples.sample(sample)?;
        self.mcap.sample(sample)
    }
    fn command(&mut self, row: &CommandRow) -> io::Result<()> {
        self.mcap.command(row)
    }
    fn event(&mut self, t_s: f64, event: &LogEvent) -> io::Result<()> {
        self.mcap.event(t_s, event)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.mcap.flush()
    }
    fn finish(&mut self) -> io::Result<()> {
        RunLogSink::finish(&mut self.mcap)
    }
}

/// What one Rust path produced.
struct RustResult {
    /// The samples (raw path; `validate`'s stay inside it).
    samples: Vec<RunSample>,
    /// (start time [s], statistics) of every span of ≥ 2 samples (raw path), of every
    /// manoeuvre analysed (`validate`'s paths).
    spans: Vec<(f64, ManoeuvreStats)>,
    /// Where the time went.
    stages: Stages,
}

/// Wall time per stage of one run.
struct Stages {
    last: Instant,
    times: Vec<(&'static str, Duration)>,
}

impl Stages {
    fn start() -> Self {
        Self {
            last: Instant::now(),
            times: Vec::new(),
        }
    }

    /// Ends the stage `name`.
    fn mark(&mut self, name: &'static str) {
        let now = Instant::now();
        self.times.push((name, now - self.last));
        self.last = now;
    }

    fn total(&self) -> Duration {
        self.times.iter().map(|&(_, t)| t).sum()
    }
}

impl std::fmt::Display for Stages {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, (name, t)) in self.times.iter().enumerate() {
            let sep = if i == 0 { "" } else { ", " };
            write!(f, "{sep}{name} {:.1} ms", t.as_secs_f64() * 1e3)?;
        }
        Ok(())
    }
}

/// The statistics of every span of ≥ 2 samples (the spans the numpy script reports), on all
/// cores as the Python peers' readers use theirs: the gap threshold (a median over the run)
/// beside the segmentation, then the spans in runs of about equal samples, one per core.
fn statistics(samples: Vec<RunSample>, rover: &Rover, mut stages: Stages) -> Result<RustResult> {
    let options = SegmentOptions::default();
    let (segments, turn_options) = std::thread::scope(|s| {
        let gap = s.spawn(|| turn_options(&samples, &options));
        let segments = segment(&samples, rover, &options);
        (segments, gap.join())
    });
    let segments = segments?;
    let turn_options = turn_options.map_err(|_| anyhow::anyhow!("the gap threshold panicked"))?;
    stages.mark("segment + gap threshold");
    let spans: Vec<&Segment> = segments.iter().filter(|s| s.len() >= 2).collect();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // Span index where each core's share begins.
    let cuts: Vec<usize> = (0..=cores)
        .map(|k| spans.partition_point(|s| s.start < samples.len() * k / cores))
        .collect();
    let analyse_all = |spans: &[&Segment]| -> Vec<(f64, ManoeuvreStats)> {
        spans
            .iter()
            .map(|s| (s.t_start_s, analyse(&samples, s, rover, &turn_options)))
            .collect()
    };
    let stats = std::thread::scope(|s| {
        let shares: Vec<_> = cuts
            .windows(2)
            .map(|w| {
                let share = &spans[w[0]..w[1]];
                s.spawn(move || analyse_all(share))
            })
            .collect();
        shares
            .into_iter()
            .map(|h| h.join())
            .collect::<Result<Vec<_>, _>>()
    })
    .map_err(|_| anyhow::anyhow!("the statistics panicked"))?
    .concat();
    stages.mark("statistics");
    Ok(RustResult {
        samples,
        spans: stats,
        stages,
    })
}

fn turn_options(samples: &[RunSample], options: &SegmentOptions) -> TurnOptions {
    TurnOptions {
        settle_s: DEFAULT_SETTLE_S,
        turn_deg: 90.0,
        gap_threshold_s: gap_threshold_s(samples, options.gap_factor),
    }
}

/// The rover and options `host-tool validate --rover rovers/husky-a200.toml` uses.
struct ValidateSetup {
    rover: Rover,
    options: ValidateOptions,
}

impl ValidateSetup {
    fn load() -> Result<Self> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../rovers/husky-a200.toml");
        let file = load_rover_file(&path)?;
        // As `validate`'s arguments set them, with their defaults.
        let options = ValidateOptions {
            tracker_offset_m: file.tracker_offset_m,
            ..ValidateOptions::for_rover(&file.rover)
        };
        Ok(Self {
            rover: file.rover,
            options,
        })
    }
}

/// What the two stages of [`rust_validate`] do on the run CSV (this tool's own: read once,
/// validated as it is read) ...
const CSV_STAGES: [&str; 2] = [
    "read, digest, segment, statistics (scan)",
    "fit, report (validate)",
];
/// ... and on the MCAP log (streamed once, validated as it is read).
const MCAP_STAGES: [&str; 2] = [
    "read, digest, segment, statistics, cross-check (scan)",
    "fit, report (validate)",
];

/// `host-tool validate`'s path on one log: the library calls its command makes; `stages`
/// names the scan and the validation.
fn rust_validate(
    path: &Path,
    setup: &ValidateSetup,
    stages: [&'static str; 2],
) -> Result<RustResult> {
    let [scan_stage, validate_stage] = stages;
    let mut stages = Stages::start();
    let runs = StreamedRuns::scan(
        std::slice::from_ref(&path.to_owned()),
        false,
        RigRange::default(),
        &setup.rover,
        &setup.options,
    )?;
    stages.mark(scan_stage);
    let report = runs.validate()?;
    stages.mark(validate_stage);
    let spans = report
        .manoeuvres
        .iter()
        .map(|row| (row.t_start_s, row.stats.clone()))
        .collect();
    std::hint::black_box(report);
    Ok(RustResult {
        samples: Vec::new(),
        spans,
        stages,
    })
}

fn rust_from_raw(files: &Files, rover: &Rover) -> Result<RustResult> {
    let mut stages = Stages::start();
    let bytes = Arc::new(std::fs::read(&files.bin)?);
    let commands = read_commands_csv(&files.commands)?;
    stages.mark("read capture + commands");
    let mut sink = SampleSink::default();
    record(Box::new(ReplayPort { bytes, at: 0 }), commands, &mut sink)?;
    stages.mark("recorder: decode, scale, commands");
    statistics(sink.samples, rover, stages)
}

/// Keeps the faster of `best` and `result`.
fn keep_best(best: &mut Option<(Duration, RustResult)>, result: RustResult) {
    let time = result.stages.total();
    if best.as_ref().is_none_or(|(t, _)| time < *t) {
        *best = Some((time, std::hint::black_box(result)));
    }
}

/// One span as the numpy script reports it.
#[derive(serde::Deserialize)]
struct NumpySpan {
    start_s: f64,
    energy_j: [f64; 2],
}

#[derive(serde::Deserialize)]
struct NumpyOutput {
    seconds: f64,
    spans: Vec<NumpySpan>,
}

/// A Python script of `bench/` timed on one of the log files, and its best run.
struct Baseline {
    script: &'static str,
    input: PathBuf,
    /// Python packages the script imports.
    packages: &'static [&'static str],
    /// Why it cannot run (python3 or a package missing), or `None` if it can.
    missing: Option<String>,
    /// Best time [s] and the spans of that run.
    best: Option<(f64, Vec<NumpySpan>)>,
}

impl Baseline {
    fn new(script: &'static str, input: &Path, packages: &'static [&'static str]) -> Self {
        Baseline {
            script,
            input: input.to_owned(),
            packages,
            missing: python_probe(packages),
            best: None,
        }
    }

    /// One run of the script (if it can run), keeping the faster: its time is read + statistics
    /// as measured by the script, so the interpreter's start-up is not counted.
    fn run(&mut self) -> Result<()> {
        if self.missing.is_some() {
            return Ok(());
        }
        let script = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../bench")
            .join(self.script);
        let mut json = self.input.clone().into_os_string();
        json.push(".python.json");
        let json = PathBuf::from(json);
        let out = Command::new("python3")
            .arg(&script)
            .arg(&self.input)
            .arg("--json")
            .arg(&json)
            .arg("--repeat")
            .arg("1")
            .output()
            .with_context(|| format!("running {}", script.display()))?;
        if !out.status.success() {
            bail!(
                "{} failed: {}",
                script.display(),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        let text = std::fs::read_to_string(&json).with_context(|| json.display().to_string())?;
        let parsed: NumpyOutput = serde_json::from_str(&text)?;
        if self
            .best
            .as_ref()
            .is_none_or(|(best, _)| parsed.seconds < *best)
        {
            self.best = Some((parsed.seconds, parsed.spans));
        }
        Ok(())
    }
}

/// Why python3 cannot import `packages`, or `None` if it can.
fn python_probe(packages: &[&str]) -> Option<String> {
    let import = format!("import {}", packages.join(", "));
    match Command::new("python3").args(["-c", &import]).output() {
        Err(e) => Some(format!("python3 not found ({e})")),
        Ok(out) if !out.status.success() => Some(format!(
            "python3 cannot {import} ({})",
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or("")
                .trim()
        )),
        Ok(_) => None,
    }
}

/// Checks that Rust and numpy found the same spans with the same energies — with
/// `every_span`, the same list; without (`validate`'s manoeuvres), each Rust span one of
/// numpy's (by its start) —; returns the largest relative energy difference.
fn cross_check(rust: &RustResult, numpy: &[NumpySpan], every_span: bool) -> Result<f64> {
    if every_span {
        ensure!(
            rust.spans.len() == numpy.len(),
            "Rust found {} spans of ≥ 2 samples, numpy {}",
            rust.spans.len(),
            numpy.len()
        );
    }
    let mut largest: f64 = 0.0;
    let mut next = 0;
    for (t, stats) in &rust.spans {
        // numpy's spans are in time order, as Rust's.
        let Some(at) = numpy[next..].iter().position(|np| np.start_s == *t) else {
            bail!("span starting at {t} s in Rust has no span starting then in numpy");
        };
        ensure!(
            !every_span || at == 0,
            "span starting at {t} s in Rust starts at {} s in numpy",
            numpy[next].start_s
        );
        let np = &numpy[next + at];
        next += at + 1;
        ensure!(
            stats.gaps == 0,
            "span at {t} s has gaps (numpy integrates across them)"
        );
        for (r, n) in [
            (stats.energy_j.left, np.energy_j[0]),
            (stats.energy_j.right, np.energy_j[1]),
        ] {
            let scale = r.abs().max(n.abs());
            let rel = if scale > 0.0 {
                (r - n).abs() / scale
            } else {
                0.0
            };
            largest = largest.max(rel);
        }
    }
    ensure!(
        largest <= ENERGY_TOLERANCE,
        "per-span energies differ by up to {largest:e} (relative) between Rust and numpy"
    );
    Ok(largest)
}
