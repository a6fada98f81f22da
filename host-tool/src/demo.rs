//! `demo`: the whole pipeline with no hardware. A simulated Husky A200 drives the seed's turn set
//! in loose sand ([`crate::sim::world`]); the firmware's own `Board` and `Link` sample it through
//! two simulated INA226 chips and write the board's byte stream into a pseudo-terminal
//! ([`crate::sim::board::PtyBoard`]); the recorder reads that pty exactly as it reads
//! `/dev/ttyACM0`, forwarding the commanded wheel speeds to the board ([`crate::record`]); the
//! runs are validated against the seed's power models ([`crate::validate`]) and plotted
//! ([`crate::figures`]). Every run is checked end to end: the energy the host recomputed from the
//! received samples must equal the board's own total, bit for bit. Then the runs are diagnosed
//! against the hard-ground model ([`crate::diagnose`]: where it departs, which unmodelled effect,
//! how much of the held-out gap it closes), and the diagnosed model plans a CLC path against the
//! hard-ground model fitted to the same runs ([`crate::plan`]).

use crate::diagnose::calibration::Calibration;
use crate::diagnose::features::TurnRow;
use crate::diagnose::report::{self as diagnosis_report, ReportError, MODEL_FILE};
use crate::diagnose::{self, DiagnoseError, Diagnosis};
use crate::effect_id::EffectId;
use crate::figures::{write_figures, RunSamples};
use crate::live::{LiveServer, LiveTee};
use crate::log::commands::write_commands_csv_atomically;
use crate::log::convert::{convert, ConvertError};
use crate::log::load::{load_run, LoadError};
use crate::log::run_csv::RunCsvFileError;
use crate::log::run_log::RunLog;
use crate::log::{write_atomically, AtomicWriteError, Existing};
use crate::plan::sweep::{SweepGrid, SweepReport, TABLE_6_1_PATH};
use crate::plan::{self, ModelFileError, ModelSource, PlanError, PlanReport};
use crate::plot::{Format, PlotError};
use crate::record::{
    self, CommandTimeline, RecordError, RecordOptions, RecordStatus, RecordSummary, SinkError,
};
use crate::sim::board::{Pacing, PtyBoard, PtyHooks, SimBoard, COMMAND_WAIT};
use crate::sim::world::{Ground, ManoeuvreTruth, Scenario, WorldConfig, WorldError};
use crate::validate::{self, RunInput, ValidateError, ValidateOptions, ValidationReport};
use firmware::sampler::SamplerConfig;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

/// The path the demo plans (path frame, paper Fig. 5): 90° → 90° over 10 m, the thesis' sand
/// CLC experiment of Fig. C.3 (start heading, end heading [deg], distance [m]).
pub const PLAN_PATH: (f64, f64, f64) = (90.0, 90.0, 10.0);

/// Tracker rate of the simulated pose in the commands file [Hz].
pub const TRACKER_HZ: f64 = 20.0;
/// The pause between two runs on the logs' timeline [ns] (the runs themselves are driven
/// without one; at real time the next run's own start is later anyway).
const PAUSE_NS: u64 = 1_000_000_000;

/// What the demo runs.
#[derive(Debug, Clone)]
pub struct DemoOptions {
    /// Where logs, reports and figures go (created if missing).
    pub out_dir: PathBuf,
    /// The simulated world (terrain, effects, rover).
    pub world: WorldConfig,
    /// What the rover drives in each run.
    pub scenario: Scenario,
    /// Number of runs (each a separate recording, with its own noise seed).
    pub runs: u32,
    /// Seed of the first run; run k uses `seed + k`.
    pub seed: u64,
    /// Simulated seconds per wall-clock second: the board's stream is paced like the real
    /// board, only faster, so forwarded commands stay close to live.
    pub speed: f64,
    /// The simulated board's sampling (`--rate-hz`: [`SamplerConfig::with_period`]); the
    /// recorder asks for the same period, as `record --rate-hz` does.
    pub sampler: SamplerConfig,
    /// The live view the recordings are also served to (`demo --serve`).
    pub live: Option<Arc<LiveServer>>,
    /// `demo --robot-bag`: also write each run's robot bag (`run-N-robot/`, the commanded twist,
    /// IMU and tracker pose), its clock this many seconds ahead of the board log's.
    pub robot_bag_clock_offset_s: Option<f64>,
}

impl DemoOptions {
    /// The seed's sand experiment: the Husky on loose sand with the default effects
    /// ([`WorldConfig::sand`]), the turn set of Section 4.4 at v_c = 0.3 m/s once per run, three
    /// runs, 25× real time.
    pub fn new(out_dir: impl Into<PathBuf>) -> Self {
        Self {
            out_dir: out_dir.into(),
            world: WorldConfig::sand(),
            scenario: Scenario::seed_turns(0.3, 1),
            runs: 3,
            seed: 1,
            speed: 25.0,
            sampler: SamplerConfig::BOARD,
            live: None,
            robot_bag_clock_offset_s: None,
        }
    }
}

/// Why the demo stopped.
#[derive(Debug, thiserror::Error)]
pub enum DemoError {
    /// Bad options.
    #[error("{0}")]
    Options(String),
    /// The world could not be simulated.
    #[error(transparent)]
    World(#[from] WorldError),
    /// A file or the pty could not be made.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// Why it failed.
        #[source]
        source: io::Error,
    },
    /// The commands file could not be written.
    #[error(transparent)]
    Commands(#[from] RunCsvFileError),
    /// The log could not be created.
    #[error(transparent)]
    Sink(#[from] SinkError),
    /// Recording failed.
    #[error(transparent)]
    Record(#[from] RecordError),
    /// The end-to-end check failed: the recording is not what the board sent.
    #[error("{run}: {what}")]
    Check {
        /// The run.
        run: String,
        /// What differs.
        what: String,
    },
    /// Converting the log to a run CSV failed.
    #[error(transparent)]
    Convert(#[from] ConvertError),
    /// Reading a log back failed.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// Validation failed.
    #[error(transparent)]
    Validate(#[from] ValidateError),
    /// A figure could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// A report file could not be written.
    #[error(transparent)]
    Report(#[from] AtomicWriteError<io::Error>),
    /// The diagnosis failed.
    #[error("diagnosis: {0}")]
    Diagnose(#[from] DiagnoseError),
    /// The diagnosis' report, figures or model file could not be written.
    #[error("diagnosis report: {0}")]
    DiagnosisReport(#[from] ReportError),
    /// The diagnosed model file could not be read back.
    #[error(transparent)]
    ModelFile(#[from] ModelFileError),
    /// The diagnosis wrote no model file (its model is not a valid plan model).
    #[error("the diagnosis wrote no model file to plan with ({}/diagnosis.md says why)", dir.display())]
    NoModelFile {
        /// The diagnosis' output directory.
        dir: PathBuf,
    },
    /// The plan failed.
    #[error("plan: {0}")]
    Plan(#[from] PlanError),
}

/// One recorded run.
#[derive(Debug, Clone)]
pub struct DemoRun {
    /// Its name (the MCAP file's name, e.g. `run-1.mcap`).
    pub name: String,
    /// The MCAP recording (frames, samples, commands, events).
    pub mcap: PathBuf,
    /// The same run as a run CSV.
    pub csv: PathBuf,
    /// The commands (and tracker pose) forwarded during the run.
    pub commands: PathBuf,
    /// What the recorder got.
    pub summary: RecordSummary,
    /// The simulated world's ground truth per manoeuvre.
    pub truth: Vec<ManoeuvreTruth>,
}

/// Everything the demo made.
#[derive(Debug, Clone)]
pub struct DemoOutcome {
    /// The runs, in order.
    pub runs: Vec<DemoRun>,
    /// The validation of all runs.
    pub report: ValidationReport,
    /// The diagnosis and the plans with its model, or why the runs alone cannot be diagnosed
    /// (e.g. a scenario of `diagnose --next-runs`, which adds to runs driven before and has
    /// no calibration manoeuvres of its own).
    pub diagnosed: Result<Diagnosed, DiagnoseError>,
    /// Every file written (logs, reports, figures).
    pub files: Vec<PathBuf>,
}

/// The diagnosis of the demo's runs and the plans with the diagnosed model.
#[derive(Debug, Clone)]
pub struct Diagnosed {
    /// The diagnosis of all runs.
    pub diagnosis: Diagnosis,
    /// [`PLAN_PATH`] under the hard-ground model fitted to the runs (no effects).
    pub plan_hard_ground: PlanReport,
    /// [`PLAN_PATH`] under the diagnosed model (the model file `diagnose` wrote).
    pub plan_diagnosed: PlanReport,
    /// The diagnosed model's ΔE against R/R' on thesis Table 6.1's path, with the table's
    /// measured slices beside its own.
    pub sweep_diagnosed: SweepReport,
}

/// The world in a few words: terrain and the effects switched on.
pub fn describe_world(world: &WorldConfig) -> String {
    let ground = match world.ground {
        Ground::Hard => "hard ground",
        Ground::Sand => "loose sand",
    };
    let effects: Vec<&str> = EffectId::ALL
        .iter()
        .filter(|&&id| world.effects.is_enabled(id))
        .map(|id| id.id())
        .collect();
    if effects.is_empty() {
        format!("on {ground}, no extra effects")
    } else {
        format!("on {ground} with {}", effects.join(", "))
    }
}

/// Runs the demo; `on_status` gets the recorder's live status of the run being recorded
/// (run index from 0, the run's simulated duration [s], status).
pub fn run(
    options: &DemoOptions,
    on_status: &mut dyn FnMut(u32, f64, &RecordStatus),
) -> Result<DemoOutcome, DemoError> {
    if options.runs == 0 {
        return Err(DemoError::Options("at least one run is needed".into()));
    }
    if !(options.speed.is_finite() && options.speed > 0.0) {
        return Err(DemoError::Options(format!(
            "speed {} must be a finite number > 0",
            options.speed
        )));
    }
    std::fs::create_dir_all(&options.out_dir).map_err(|source| DemoError::Io {
        what: format!("creating {}", options.out_dir.display()),
        source,
    })?;
    let mut runs = Vec::new();
    let mut files = Vec::new();
    // The runs may be driven faster than real time; their logs lay them end to end in real
    // time, so that Foxglove shows each on its own timeline.
    let mut start_unix_ns = 0;
    for k in 0..options.runs {
        let run = record_run(options, k, &mut start_unix_ns, &mut |duration_s, status| {
            on_status(k, duration_s, status)
        })?;
        files.extend([run.mcap.clone(), run.csv.clone(), run.commands.clone()]);
        runs.push(run);
    }

    let logs = runs
        .iter()
        .map(|r| load_run(&r.mcap))
        .collect::<Result<Vec<RunLog>, _>>()?;
    if let Some(offset_s) = options.robot_bag_clock_offset_s {
        for (run, log) in runs.iter().zip(&logs) {
            files.push(write_robot_bag(run, log, &options.world.rover, offset_s)?);
        }
    }
    let inputs: Vec<RunInput<'_>> = runs
        .iter()
        .zip(&logs)
        .map(|(r, log)| RunInput::from_log(&r.name, log))
        .collect();
    let rover = options.world.rover;
    // The world's tracker follows its prism; validate corrects for where it sits.
    let validate_options = ValidateOptions {
        tracker_offset_m: options.world.tracker.offset_m,
        ..ValidateOptions::for_rover(&rover)
    };
    let report = validate::validate(&rover, &inputs, &validate_options)?;

    let out = &options.out_dir;
    let text = report.to_string();
    files.push(write_file(&out.join("report.txt"), text.as_bytes())?);
    let json = serde_json::to_vec_pretty(&report).map_err(|e| DemoError::Io {
        what: "serialising the report".into(),
        source: e.into(),
    })?;
    files.push(write_file(&out.join("report.json"), &json)?);
    let turns = out.join("turns.csv");
    write_atomically(&turns, Existing::Replace, |w| report.write_csv(w))?;
    files.push(turns);
    let samples: Vec<RunSamples<'_>> = runs
        .iter()
        .zip(&logs)
        .map(|(r, log)| RunSamples {
            name: &r.name,
            samples: &log.samples,
        })
        .collect();
    files.extend(write_figures(
        &report,
        &samples,
        out,
        &[Format::Png, Format::Svg],
    )?);

    let slices: Vec<&[crate::log::run_csv::RunSample]> =
        logs.iter().map(|l| l.samples.as_slice()).collect();
    let rows = diagnose::features::rows(&report, &slices);
    let diagnosed = match diagnose::diagnose(&rover, &rows) {
        Ok(diagnosis) => Ok(diagnose_and_plan(
            &rover, &rows, diagnosis, out, &mut files,
        )?),
        Err(e) => Err(e),
    };
    Ok(DemoOutcome {
        runs,
        report,
        diagnosed,
        files,
    })
}

/// Writes `diagnosis`' report, figures and model file under `out`/diagnosis and plans with its
/// model; the files written go to `files`.
fn diagnose_and_plan(
    rover: &model_core::Rover,
    rows: &[TurnRow],
    diagnosis: Diagnosis,
    out: &Path,
    files: &mut Vec<PathBuf>,
) -> Result<Diagnosed, DemoError> {
    let dir = out.join("diagnosis");
    files.extend(diagnosis_report::write_out_dir(
        &dir,
        rover,
        &diagnosis,
        rows,
        Calibration::FROM_RUNS,
    )?);
    let json = dir.join("diagnosis.json");
    diagnosis_report::write_json(&json, &diagnosis)?;
    files.push(json);

    // The model file as `plan --model` reads it, and the same file without its effect terms:
    // the hard-ground model fitted to these runs.
    let model_path = dir.join(MODEL_FILE);
    if !model_path.exists() {
        return Err(DemoError::NoModelFile { dir });
    }
    let diagnosed = plan::load_model(&model_path)?;
    let mut hard_ground = diagnosed.clone();
    hard_ground.effects.clear();
    hard_ground.description = Some("the diagnosed model without its effect terms".into());
    let (start_deg, end_deg, distance_m) = PLAN_PATH;
    let source = ModelSource::File(model_path);
    let plan_diagnosed = plan::plan(&diagnosed, &source, start_deg, end_deg, distance_m)?;
    let plan_hard_ground = plan::plan(&hard_ground, &source, start_deg, end_deg, distance_m)?;
    let (a, c, d) = TABLE_6_1_PATH;
    let sweep_diagnosed = plan::sweep::sweep(&diagnosed, &source, a, c, d, SweepGrid::default())?;
    Ok(Diagnosed {
        diagnosis,
        plan_hard_ground,
        plan_diagnosed,
        sweep_diagnosed,
    })
}

/// Simulates run `k`, streams it through a pty into the recorder, checks the recording against
/// the board's own totals, and writes its MCAP, run CSV and commands files. Its first sample is
/// at Unix time `start_unix_ns` or now, whichever is later; `start_unix_ns` moves on past the
/// run and a pause, for the next one.
fn record_run(
    options: &DemoOptions,
    k: u32,
    start_unix_ns: &mut u64,
    on_status: &mut dyn FnMut(f64, &RecordStatus),
) -> Result<DemoRun, DemoError> {
    let out = &options.out_dir;
    let stem = format!("run-{}", k + 1);
    let mcap = out.join(format!("{stem}.mcap"));
    let csv = out.join(format!("{stem}.csv"));
    let commands_path = out.join(format!("{stem}.commands.csv"));
    // Named by file, not path: the output directory may be a staging one (written whole).
    let name = format!("{stem}.mcap");

    let timeline = Arc::new(
        options
            .world
            .simulate(&options.scenario, options.seed.wrapping_add(u64::from(k)))?,
    );
    let commands = timeline.commands(TRACKER_HZ);
    write_commands_csv_atomically(&commands_path, Existing::Replace, &commands)?;

    let config = options.sampler;
    let steps = timeline.duration_us() / u64::from(config.sample_period_us) + 1;
    let mut board = SimBoard::new(config);
    board.set_load(timeline.load_source());
    // The board waits for each command the recorder will send, and for the recorder to read,
    // as long as the recorder runs: a loaded machine slows the run down, it neither lets the
    // board run ahead of its commands nor closes the pty on bytes the recorder has not read.
    let period_us = u64::from(config.sample_period_us);
    let hooks = PtyHooks {
        commands_due_us: CommandTimeline::new(commands.clone())
            .sends_us((0..steps).map(|k| k * period_us)),
        wait_for_host: true,
        ..PtyHooks::default()
    };
    let pacing = Pacing::Scaled(options.speed);
    let pty =
        PtyBoard::spawn_with(board, steps, pacing, hooks).map_err(|source| DemoError::Io {
            what: "starting the simulated board's pty".into(),
            source,
        })?;

    let mut record_options = RecordOptions::new(pty.path());
    record_options.commands = commands;
    record_options.rover = options.world.rover;
    record_options.max_samples = Some(steps);
    record_options.sample_period_us = Some(config.sample_period_us);
    let start = (*start_unix_ns).max(crate::live::unix_now_ns());
    record_options.first_sample_not_before_unix_ns = Some(start);
    *start_unix_ns = start.saturating_add((timeline.duration_s() * 1e9) as u64 + PAUSE_NS);
    // The board hangs up after its last step; anything longer than a few periods is a fault.
    record_options.reconnect_timeout = Duration::from_secs(2);
    let mut open = record::serial_opener(record_options.read_timeout);
    let mut file = record::create_sink(&mcap, true)?;
    let live = options.live.as_ref().map(|server| server.recording_sink());
    let mut sink = LiveTee::new(file.as_mut(), live);
    let stop = AtomicBool::new(false);
    let duration_s = timeline.duration_s();
    let summary = record::record(
        &record_options,
        &mut open,
        &mut sink,
        &stop,
        &mut |status| on_status(duration_s, status),
    )?;
    drop(file);
    // The recorder is done: the board waits for it no longer (on an error, dropping `pty`
    // stops it too).
    pty.stop();
    let board_run = pty.join().map_err(|source| DemoError::Io {
        what: "running the simulated board".into(),
        source,
    })?;

    // End to end: every sample arrived, in order, and the host's energy is the board's.
    let check = |what: String| DemoError::Check {
        run: name.clone(),
        what,
    };
    if summary.stream.lost_samples != 0 || summary.stream.bad_frames != 0 {
        return Err(check(format!(
            "{} of {steps} samples arrived: {} lost on the way, {} bad frames",
            summary.samples, summary.stream.lost_samples, summary.stream.bad_frames
        )));
    }
    if summary.samples != steps {
        let what = if board_run.steps < steps {
            format!(
                "the simulated board stopped after {} of {steps} steps",
                board_run.steps
            )
        } else {
            format!(
                "the recorder read {} of the board's {steps} samples before the pty closed \
                 (none lost on the way)",
                summary.samples
            )
        };
        return Err(check(what));
    }
    // The board waits for each command, but not for a recorder that stopped sending (at most
    // `COMMAND_WAIT` per command): then it answers commands late or never. Fail, do not report.
    if summary.unanswered_commands() > 0 {
        return Err(check(format!(
            "{} of {} commands answered by the board before the run ended: the recorder sent \
             them more than {} s late",
            summary.commands_acked + summary.commands_rejected,
            summary.commands_sent,
            COMMAND_WAIT.as_secs()
        )));
    }
    let board_energy = board_run.board_energy_lsb_us();
    let host_energy = summary
        .segments
        .last()
        .map(|s| s.host_energy_lsb_us)
        .unwrap_or_default();
    if host_energy != board_energy {
        return Err(check(format!(
            "host energy {host_energy:?} LSB·µs differs from the board's {board_energy:?}"
        )));
    }
    convert(&mcap, &csv)?;
    Ok(DemoRun {
        name,
        mcap,
        csv,
        commands: commands_path,
        summary,
        truth: timeline.manoeuvres().to_vec(),
    })
}

/// Writes `run`'s robot bag beside its logs, `run-N-robot/`: what the robot computer sent and
/// measured (its commands file), stamped with its own clock.
fn write_robot_bag(
    run: &DemoRun,
    log: &RunLog,
    rover: &model_core::Rover,
    clock_offset_s: f64,
) -> Result<PathBuf, DemoError> {
    // Not `.bag`: readers take that for a ROS 1 bag file.
    let dir = run.mcap.with_file_name(format!(
        "{}-robot",
        run.mcap.file_stem().unwrap_or_default().to_string_lossy()
    ));
    let Some((t_anchor, unix_anchor)) = log.wall_clock() else {
        return Err(DemoError::Check {
            run: run.name.clone(),
            what: "the recording has no wall-clock anchor for its robot bag".into(),
        });
    };
    let unix_ns_at =
        |t_s: f64| unix_anchor.saturating_add_signed(((t_s - t_anchor) * 1e9).round() as i64);
    // The robot's side of the run: every row of its commands file (the tracker's rate).
    let rows =
        crate::log::commands::read_commands_csv(&run.commands).map_err(|e| DemoError::Io {
            what: format!("reading {}", run.commands.display()),
            source: io::Error::other(e.to_string()),
        })?;
    crate::ros2::robot_bag::write_robot_bag(&dir, true, &rows, rover, unix_ns_at, clock_offset_s)
        .map_err(|e| DemoError::Io {
        what: format!("writing {}", dir.display()),
        source: io::Error::other(e.to_string()),
    })?;
    Ok(dir)
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<PathBuf, DemoError> {
    write_atomically(path, Existing::Replace, |w| w.write_all(bytes))?;
    Ok(path.to_owned())
}
