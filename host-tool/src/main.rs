//! `host-tool`: command line of the rover-power host tool (arguments only; the work is in the
//! library).

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use host_tool::decode::Summary;
use host_tool::demo::{self, DemoOptions};
use host_tool::diagnose::{self, calibration::Calibration, report};
use host_tool::figures::{write_figures, RunSamples};
use host_tool::log::commands::read_commands_csv;
use host_tool::log::convert::{convert, same_file};
use host_tool::log::load::load;
use host_tool::log::mcap::Truncation;
use host_tool::log::write_atomically;
use host_tool::plan::{self, ModelSource, Preset};
use host_tool::plot::Format;
use host_tool::progress;
use host_tool::record::{self, RecordOptions, RecordStatus};
use host_tool::replay::{frames_of, write_stream, ReplayPacing, ReplayPty};
use host_tool::rover::load_rover;
use host_tool::serial::list_ports;
use host_tool::sim::world::{load_scenario, load_world};
use host_tool::validate::{self, RunInput, ValidateOptions};
use model_core::power::IcrHardGround;
use std::io::{IsTerminal, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

#[derive(Parser)]
#[command(version, about = "rover-power host tool")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Decode a raw capture of the board's serial stream and summarise it: frames, losses,
    /// duration, and the board's energy against the host's recomputation from raw samples.
    Decode {
        /// Capture file (raw bytes as read from the board's serial port; `-` for stdin).
        capture: PathBuf,
        /// Print the summary as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Validate runs against the seed's power models: cut them into manoeuvres from the
    /// commanded speeds, print a per-turn table (R_cmd, R/R', regime, duration vs expected,
    /// angular slip, power, energy, τ ∝ P/ω), fit the ICR model (c1, c2, c3 with pitch) with
    /// 95 % bounds and r², flag where measured power departs from it, and cross-check the
    /// board's model frames against the host's recomputation.
    Validate {
        /// Rover TOML (e.g. rovers/husky-a200.toml).
        #[arg(long)]
        rover: PathBuf,
        /// Run logs, .csv or .mcap (each is validated as an independent run).
        #[arg(long, num_args = 1.., required = true)]
        runs: Vec<PathBuf>,
        /// Write the whole report as JSON to FILE (`-` for stdout, then no table is printed).
        #[arg(long, value_name = "FILE")]
        json: Option<PathBuf>,
        /// Write the per-manoeuvre table as CSV to FILE.
        #[arg(long, value_name = "FILE")]
        csv: Option<PathBuf>,
        /// Heading change of each turn when the runs have no yaw [deg].
        #[arg(long, default_value_t = validate::DEFAULT_TURN_DEG)]
        turn_deg: f64,
        /// Settle time cut from the start of each manoeuvre for the steady statistics [s].
        #[arg(long, default_value_t = validate::DEFAULT_SETTLE_S)]
        settle_s: f64,
        /// Shortest manoeuvre analysed [s].
        #[arg(long, default_value_t = validate::segment::DEFAULT_MIN_DURATION_S)]
        min_duration_s: f64,
        /// Tolerance on the commanded side speeds within one manoeuvre [m/s].
        #[arg(long, default_value_t = validate::segment::DEFAULT_SPEED_TOLERANCE_MPS)]
        speed_tolerance_mps: f64,
        /// Flag manoeuvres whose power departs from the fit by more than this [%] (and lies
        /// outside the 95 % prediction interval).
        #[arg(long, default_value_t = 100.0 * validate::DEFAULT_DEPARTURE_FRACTION)]
        departure_pct: f64,
        /// Hard-ground reference model as `MU,G_N,BS_M` (friction coefficient, rolling
        /// resistance [N], the terrain's slip track [m]; geometry and mass from the rover).
        /// Default: the seed's Husky values (paper Table 2) for the Husky, none otherwise.
        #[arg(long, value_name = "MU,G_N,BS_M", value_parser = parse_hard_ground, conflicts_with = "no_hard_ground")]
        hard_ground: Option<[f64; 3]>,
        /// No hard-ground reference column.
        #[arg(long)]
        no_hard_ground: bool,
    },
    /// Convert a run log between MCAP (.mcap) and the run CSV (.csv), or normalise one (same
    /// format in and out; repairs an MCAP file cut short by a killed recorder). CSV → MCAP adds
    /// the wire frames the board would have sent (registers quantised at 1.25 mV / 0.5 mA), so
    /// the result replays like a recording.
    Convert {
        /// The run log to read (.mcap or .csv).
        input: PathBuf,
        /// The file to write (.mcap or .csv); written whole or not at all.
        output: PathBuf,
    },
    /// Replay a run log (.mcap or .csv) as the board's byte stream: into a pseudo-terminal that
    /// other tools open like /dev/ttyACM0, or into a capture file for `decode`.
    #[command(group(clap::ArgGroup::new("target").required(true).args(["to_pty", "to"])))]
    Replay {
        /// The run log (.mcap: its frames byte for byte; .csv: frames synthesised from samples).
        log: PathBuf,
        /// Stream into a new pty: prints its path, waits for a reader, streams, hangs up.
        #[arg(long)]
        to_pty: bool,
        /// Write the whole byte stream to this file instead.
        #[arg(long, value_name = "FILE")]
        to: Option<PathBuf>,
        /// Playback speed (2 = twice real time).
        #[arg(long, default_value_t = 1.0, value_parser = positive_speed, value_name = "K")]
        speed: f64,
        /// Write as fast as the reader takes the bytes (ignores --speed).
        #[arg(long)]
        as_fast_as_possible: bool,
    },
    /// The main job, no hardware needed: a simulated Husky A200 drives the seed's turn set in
    /// loose sand; the firmware's own code samples it through simulated INA226 chips into a
    /// pseudo-terminal; the recorder reads it like /dev/ttyACM0; the runs are validated against
    /// the seed's power models. Tables on the terminal; logs, reports and figures in --out.
    Demo {
        /// Output directory.
        #[arg(long, default_value = "demo-out")]
        out: PathBuf,
        /// World TOML (default: the built-in sand world, as in worlds/husky-sand.toml).
        #[arg(long)]
        world: Option<PathBuf>,
        /// Scenario TOML (default: the seed's turn set once per run).
        #[arg(long)]
        scenario: Option<PathBuf>,
        /// Number of runs.
        #[arg(long, default_value_t = 3)]
        runs: u32,
        /// Noise seed of the first run (run k uses seed + k).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Simulated seconds per wall-clock second.
        #[arg(long, default_value_t = 25.0, value_parser = positive_speed)]
        speed: f64,
    },
    /// Draw the validation figures of runs: power vs time per turn, average and maximum power
    /// vs R/R' with the model curves, τ ∝ P/ω per side, residuals.
    Plot {
        /// Rover TOML (e.g. rovers/husky-a200.toml).
        #[arg(long)]
        rover: PathBuf,
        /// Run logs, .csv or .mcap.
        #[arg(long, num_args = 1.., required = true)]
        runs: Vec<PathBuf>,
        /// Output directory (created if missing).
        #[arg(long, default_value = "plots")]
        out: PathBuf,
        /// Figure format(s).
        #[arg(long, value_enum, default_value = "both")]
        format: FigureFormat,
    },
    /// List the serial ports: name, USB VID:PID, product, manufacturer, serial number.
    Ports {
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Record the board's stream from a serial port into a run log, with a live status line.
    /// Stops on Ctrl-C, --duration or --samples; waits for an unplugged board to come back.
    Record(RecordArgs),
    /// Diagnose the gap between the hard-ground model and the runs: where it departs (gaps per
    /// regime and side, significant beyond the repeat noise), which catalogued unmodelled effect
    /// explains it (grouped cross-validation, penalised), and how much of the held-out gap it
    /// closes. Table on the terminal; JSON with --json; report, figures and a `plan --model`
    /// file with --out.
    Diagnose(DiagnoseArgs),
    /// Checks `diagnose` on simulated datasets whose effect and structure it is not told, drawn
    /// from a world family (power split, constant angular slip, motor losses, standstill draw,
    /// Husky or Argo, turn direction, speed, rate, noise): each carries one catalogue effect,
    /// none (control) or only a non-default structure; prints per part (tuning, held-out) the
    /// confusion matrix, accuracy per structure, the regime hit rate and the median shrink.
    DiagnoseBench(DiagnoseBenchArgs),
    /// Energy of the optimal CLC path (arc – line – arc) against the PLP path (point turn –
    /// line – point turn) between two poses (paper Eq 23–50). Headings are in the path frame:
    /// from the start-to-end line, counter-clockwise positive, both in (0, 90] or both in
    /// [-90, 0).
    Plan(PlanArgs),
}

#[derive(clap::Args)]
struct DiagnoseArgs {
    /// Rover TOML (e.g. rovers/husky-a200.toml).
    #[arg(long)]
    rover: PathBuf,
    /// Calibration runs, .csv or .mcap: their straights, point turns and turns with R ≥ 2R′ fit
    /// the hard-ground baseline and are not scored (default: those manoeuvres of --runs).
    #[arg(long, num_args = 1..)]
    calibration: Vec<PathBuf>,
    /// Runs to diagnose: run CSVs or MCAP logs, or per-turn summary CSVs (header with
    /// radius_m,avg_power_w and optional v_c_mps, pitch_deg; e.g. a published table).
    #[arg(long, num_args = 1.., required = true)]
    runs: Vec<PathBuf>,
    /// Write the diagnosis as JSON to FILE (`-` for stdout, then no table is printed).
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Output directory: diagnosis.md, figures (PNG, SVG) and model.toml for `plan --model`.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

#[derive(clap::Args)]
struct DiagnoseBenchArgs {
    /// Datasets per part (one in ten a control, one in ten a structure without effect).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..=100_000))]
    datasets: u64,
    /// Bench seed: the same seed gives the same datasets (the held-out part uses 1000 + seed).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(0..1000))]
    seed: u64,
    /// Part of the world family: `tuning`, `held-out` (structures, geometry and seeds no
    /// tuning decision looks at) or `both`, reported separately.
    #[arg(long, value_enum, default_value = "both")]
    part: BenchPartArg,
    /// Worker threads.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u64).range(1..=256))]
    threads: u64,
    /// Write every dataset's result as JSON to FILE (`-` for stdout, then no table is printed).
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Keep the simulated tracker's position fixes (5 Hz prism): the diagnosis then places
    /// turns by their measured R_ACT and sees a measured slip track.
    #[arg(long)]
    poses: bool,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum BenchPartArg {
    Tuning,
    HeldOut,
    Both,
}

#[derive(clap::Args)]
struct PlanArgs {
    /// Start heading θ_A in the path frame [deg].
    #[arg(long, allow_negative_numbers = true)]
    start_deg: f64,
    /// End heading θ_C in the path frame [deg].
    #[arg(long, allow_negative_numbers = true)]
    end_deg: f64,
    /// Start-to-end distance d [m].
    #[arg(long, allow_negative_numbers = true)]
    distance_m: f64,
    /// Built-in energy model (husky-hard-ground: paper Table 2, reproduces Table 3).
    #[arg(
        long,
        value_enum,
        default_value = "husky-hard-ground",
        conflicts_with = "model"
    )]
    preset: PresetArg,
    /// Energy model file (TOML: rover, hard-ground base, effect terms; see the README).
    #[arg(long, value_name = "FILE")]
    model: Option<PathBuf>,
    /// Write the plan as JSON to FILE (`-` for stdout, then no table is printed).
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

/// `plan --preset` values.
#[derive(Clone, Copy, clap::ValueEnum)]
enum PresetArg {
    HuskyHardGround,
}

impl From<PresetArg> for Preset {
    fn from(p: PresetArg) -> Self {
        match p {
            PresetArg::HuskyHardGround => Preset::HuskyHardGround,
        }
    }
}

/// `MU,G_N,BS_M` → three finite positive numbers.
fn parse_hard_ground(text: &str) -> Result<[f64; 3], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>().map_err(|e| format!("{v:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match values[..] {
        [mu, g, bs] if values.iter().all(|v| v.is_finite() && *v > 0.0) => Ok([mu, g, bs]),
        _ => Err("expected three positive numbers MU,G_N,BS_M (e.g. 0.74,30.85,1.29)".into()),
    }
}

/// Writes `text` to `path` whole or not at all.
fn write_file(path: &Path, text: &[u8]) -> Result<()> {
    write_atomically(path, |w| w.write_all(text))
        .with_context(|| format!("writing {}", path.display()))
}

/// Writes `value` as pretty JSON to `path` (atomically), or to stdout when `path` is `-`.
/// Returns whether it went to stdout: the command then prints nothing else there.
fn emit_json(path: Option<&Path>, value: &impl serde::Serialize, what: &str) -> Result<bool> {
    let Some(path) = path else {
        return Ok(false);
    };
    let mut text =
        serde_json::to_vec_pretty(value).with_context(|| format!("serialising the {what}"))?;
    text.push(b'\n');
    if path.as_os_str() == "-" {
        // Written, not print!ed: a closed stdout is an error, not a panic.
        std::io::stdout().lock().write_all(&text)?;
        Ok(true)
    } else {
        write_file(path, &text)?;
        Ok(false)
    }
}

fn positive_speed(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(k) if k.is_finite() && k > 0.0 => Ok(k),
        _ => Err(format!(
            "{text:?} is not a speed factor (a finite number > 0)"
        )),
    }
}

/// Reads run logs (.mcap or .csv), with a progress bar; names are the paths as given.
fn load_runs(paths: &[PathBuf]) -> Result<(Vec<String>, Vec<host_tool::log::run_log::RunLog>)> {
    let bar = progress::bar(paths.len() as u64, "reading runs");
    let mut names = Vec::with_capacity(paths.len());
    let mut logs = Vec::with_capacity(paths.len());
    for path in paths {
        let loaded = load(path)?;
        warn_truncated(path, loaded.truncated);
        names.push(path.display().to_string());
        logs.push(loaded.run);
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok((names, logs))
}

fn warn_truncated(path: &Path, truncated: Option<Truncation>) {
    if let Some(t) = truncated {
        eprintln!(
            "warning: {} ends before its footer (recorder killed?): using its first {} of {} bytes",
            path.display(),
            t.complete_bytes,
            t.file_bytes
        );
    }
}

/// Which figure files to write.
#[derive(Clone, Copy, clap::ValueEnum)]
enum FigureFormat {
    Png,
    Svg,
    Both,
}

impl FigureFormat {
    fn formats(self) -> &'static [Format] {
        match self {
            FigureFormat::Png => &[Format::Png],
            FigureFormat::Svg => &[Format::Svg],
            FigureFormat::Both => &[Format::Png, Format::Svg],
        }
    }
}

#[derive(clap::Args)]
struct RecordArgs {
    /// The board's port (`/dev/ttyACM0`, `/dev/serial/by-id/...`).
    #[arg(long)]
    port: String,
    /// The log to write; its extension picks the format (.csv: run CSV + events file).
    #[arg(long)]
    out: PathBuf,
    /// Overwrite an existing log.
    #[arg(long)]
    force: bool,
    /// Stop after this many seconds of wall time.
    #[arg(long, value_parser = parse_seconds)]
    duration: Option<Duration>,
    /// Stop after this many samples.
    #[arg(long)]
    samples: Option<u64>,
    /// Commands CSV (t_s, cmd_left_mps, cmd_right_mps[, yaw_rad, pitch_deg]): forwarded to the
    /// board as wheel rates and copied into the log.
    #[arg(long)]
    commands: Option<PathBuf>,
    /// Rover TOML for the wheel radius (default: the Husky A200).
    #[arg(long)]
    rover: Option<PathBuf>,
    /// Seconds to wait for a vanished device before stopping.
    #[arg(long, value_parser = parse_seconds, default_value = "60")]
    reconnect_timeout: Duration,
}

/// A non-negative, finite number of seconds.
fn parse_seconds(text: &str) -> Result<Duration, String> {
    let s: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a number of seconds"))?;
    Duration::try_from_secs_f64(s).map_err(|_| format!("{text} s must be finite and >= 0"))
}

fn ports(json: bool) -> Result<()> {
    let ports = list_ports()?;
    if json {
        let list: Vec<serde_json::Value> = ports
            .iter()
            .map(|p| {
                serde_json::json!({
                    "name": p.name,
                    "vid": p.usb.as_ref().map(|u| u.vid),
                    "pid": p.usb.as_ref().map(|u| u.pid),
                    "product": p.product,
                    "manufacturer": p.manufacturer,
                    "serial_number": p.serial_number,
                    "rover_power": p.is_rover_power(),
                })
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&list)?);
        return Ok(());
    }
    if ports.is_empty() {
        println!("no serial ports found");
        return Ok(());
    }
    let rows: Vec<[String; 6]> = ports
        .iter()
        .map(|p| {
            let opt = |s: &Option<String>| s.clone().unwrap_or_else(|| "-".into());
            [
                p.name.clone(),
                p.usb
                    .as_ref()
                    .map_or("-".into(), |u| format!("{:04x}:{:04x}", u.vid, u.pid)),
                opt(&p.product),
                opt(&p.manufacturer),
                opt(&p.serial_number),
                if p.is_rover_power() { "yes" } else { "-" }.into(),
            ]
        })
        .collect();
    let header = [
        "PORT",
        "VID:PID",
        "PRODUCT",
        "MANUFACTURER",
        "SERIAL",
        "ROVER-POWER",
    ];
    let mut widths = header.map(str::len);
    for row in &rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    for row in std::iter::once(header.map(String::from)).chain(rows) {
        let cells: Vec<String> = row
            .iter()
            .zip(widths)
            .map(|(c, w)| format!("{c:<w$}"))
            .collect();
        println!("{}", cells.join("  ").trim_end());
    }
    Ok(())
}

fn record_cmd(args: RecordArgs) -> Result<()> {
    let RecordArgs {
        port,
        out,
        force,
        duration,
        samples,
        commands,
        rover,
        reconnect_timeout,
    } = args;
    let mut options = RecordOptions::new(port);
    options.duration = duration;
    options.max_samples = samples;
    options.reconnect_timeout = reconnect_timeout;
    if let Some(path) = &commands {
        options.commands = read_commands_csv(path)?;
    }
    if let Some(path) = &rover {
        options.rover = load_rover(path)?;
    }
    options.validate()?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::Relaxed) {
            // A second Ctrl-C: the user wants out now; the log holds what was flushed.
            std::process::exit(130);
        }
    })
    .context("installing the Ctrl-C handler")?;
    let mut open = record::serial_opener(options.read_timeout);
    // The port first: a wrong path leaves no empty log behind.
    let board = open(&options.port)?;
    let mut sink = record::create_sink(&out, force)?;
    let mut stderr = std::io::stderr();
    // One line rewritten in place on a terminal; a line per report into a file or pipe.
    let live = stderr.is_terminal();
    let mut on_status = |status: &RecordStatus| {
        let _ = if live {
            write!(stderr, "\r\x1b[2K{status}")
        } else {
            writeln!(stderr, "{status}")
        };
        let _ = stderr.flush();
    };
    eprintln!(
        "recording {} -> {} (Ctrl-C to stop)",
        options.port,
        out.display()
    );
    let result = record::record_on(
        &options,
        board,
        &mut open,
        sink.as_mut(),
        &stop,
        &mut on_status,
    );
    if live {
        eprintln!();
    }
    let summary = result?;
    print!("{}: {summary}", out.display());
    if summary.samples == 0 {
        bail!("no samples were recorded");
    }
    Ok(())
}

fn demo_cmd(
    out: PathBuf,
    world: Option<PathBuf>,
    scenario: Option<PathBuf>,
    runs: u32,
    seed: u64,
    speed: f64,
) -> Result<()> {
    let mut options = DemoOptions::new(out);
    if let Some(path) = &world {
        options.world = load_world(path)?;
    }
    if let Some(path) = &scenario {
        options.scenario = load_scenario(path)?;
    }
    options.runs = runs;
    options.seed = seed;
    options.speed = speed;
    let started = std::time::Instant::now();
    println!(
        "demo: a simulated rover (B = {} m, m = {} kg) {}: {runs} runs through a pty, {speed}x real time",
        options.world.rover.track_width_m,
        options.world.rover.mass_kg,
        demo::describe_world(&options.world),
    );
    let bar = progress::bar(1000, "recording");
    let outcome = demo::run(&options, &mut |k, duration_s, status| {
        let done = (f64::from(k) + (status.run_s / duration_s).clamp(0.0, 1.0)) / f64::from(runs);
        bar.set_position((1000.0 * done) as u64);
    })?;
    bar.finish_and_clear();
    for run in &outcome.runs {
        let s = &run.summary;
        let j = |e: i64| s.scale.energy_j(e);
        let energy = s
            .segments
            .last()
            .map(|g| g.host_energy_lsb_us)
            .unwrap_or_default();
        println!(
            "{}: {} samples through the pty, {} lost, {} bad frames, {} commands acked; \
             energy {:.1} J left / {:.1} J right = the board's own total, bit for bit",
            run.name,
            s.samples,
            s.stream.lost_samples,
            s.stream.bad_frames,
            s.commands_acked,
            j(energy[0]),
            j(energy[1]),
        );
    }
    println!();
    print!("{}", outcome.report);
    println!();
    println!(
        "== diagnosis: the hard-ground model (Eq 21 per side) fitted on the runs' straights, point \
         turns and 2R′ turns; every catalogued effect fitted on training runs and scored on the \
         withheld run"
    );
    print!("{}", report::table(&outcome.diagnosis));
    println!();
    let (start_deg, end_deg, distance_m) = demo::PLAN_PATH;
    println!(
        "== plan: {start_deg}° → {end_deg}° over {distance_m} m on this terrain (paper Eq 23–50; \
         model file {}/diagnosis/model.toml)",
        options.out_dir.display()
    );
    let effects = outcome.diagnosis.model_effects();
    let effects: Vec<&str> = effects.iter().map(|e| e.id()).collect();
    for (what, p) in [
        (
            "hard-ground model fitted to the runs".to_owned(),
            &outcome.plan_hard_ground,
        ),
        (
            format!("+ diagnosed {}", effects.join(" + ")),
            &outcome.plan_diagnosed,
        ),
    ] {
        println!(
            "  {what}: CLC R1 = {:.2} m ({:.2} R′), R2 = {:.2} m ({:.2} R′), {:.0} J vs PLP {:.0} J \
             ({:+.1} %)",
            p.clc.r1_m,
            p.clc.r1_m / p.r_prime_m,
            p.clc.r2_m,
            p.clc.r2_m / p.r_prime_m,
            p.clc.energy_j,
            p.plp.energy_j,
            -p.saving_pct
        );
    }
    println!();
    println!(
        "{} files in {} ({:.1} s):",
        outcome.files.len(),
        options.out_dir.display(),
        started.elapsed().as_secs_f64()
    );
    for file in &outcome.files {
        println!("  {}", file.display());
    }
    Ok(())
}

fn plot_cmd(rover: &Path, runs: &[PathBuf], out: &Path, format: FigureFormat) -> Result<()> {
    let rover = load_rover(rover)?;
    let (names, logs) = load_runs(runs)?;
    let inputs: Vec<RunInput<'_>> = names
        .iter()
        .zip(&logs)
        .map(|(name, log)| RunInput::from_log(name, log))
        .collect();
    let report = validate::validate(&rover, &inputs, &ValidateOptions::for_rover(&rover))?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let samples: Vec<RunSamples<'_>> = names
        .iter()
        .zip(&logs)
        .map(|(name, log)| RunSamples {
            name,
            samples: &log.samples,
        })
        .collect();
    for file in write_figures(&report, &samples, out, format.formats())? {
        println!("{}", file.display());
    }
    Ok(())
}

/// The diagnosis' rows of run logs (validated with the rover's default options).
/// The diagnosis rows of `paths`: run logs through `validate`, and per-turn summary CSVs
/// (header with `radius_m` and `avg_power_w`, see `diagnose::summary`) as total-only rows, each
/// file its own run; plus the summaries' caveats.
fn diagnosis_rows(
    rover: &model_core::Rover,
    tracker_offset_m: f64,
    paths: &[PathBuf],
    what: &str,
) -> Result<(Vec<diagnose::features::TurnRow>, Vec<String>)> {
    let (summaries, runs): (Vec<&PathBuf>, Vec<&PathBuf>) = paths
        .iter()
        .partition(|p| diagnose::summary::is_summary_file(p));
    let mut rows = if runs.is_empty() {
        Vec::new()
    } else {
        let runs: Vec<PathBuf> = runs.into_iter().cloned().collect();
        run_rows(rover, tracker_offset_m, &runs, what)?
    };
    let mut notes = Vec::new();
    for path in summaries {
        let summary = diagnose::summary::load_summary(path)?;
        let run_index = rows.iter().map(|r| r.run_index + 1).max().unwrap_or(0);
        let mut of = diagnose::summary::summary_rows(rover, &summary, &path.display().to_string());
        for row in &mut of {
            row.run_index = run_index;
        }
        rows.extend(of);
        notes.extend(
            diagnose::summary::summary_notes(&summary)
                .into_iter()
                .map(|n| format!("{}: {n}", path.display())),
        );
    }
    Ok((rows, notes))
}

fn run_rows(
    rover: &model_core::Rover,
    tracker_offset_m: f64,
    paths: &[PathBuf],
    what: &str,
) -> Result<Vec<diagnose::features::TurnRow>> {
    let (names, logs) = load_runs(paths)?;
    let inputs: Vec<RunInput<'_>> = names
        .iter()
        .zip(&logs)
        .map(|(name, log)| RunInput::from_log(name, log))
        .collect();
    let options = ValidateOptions {
        tracker_offset_m,
        ..ValidateOptions::for_rover(rover)
    };
    let report =
        validate::validate(rover, &inputs, &options).with_context(|| format!("{what} runs"))?;
    let samples: Vec<&[host_tool::log::run_csv::RunSample]> =
        logs.iter().map(|l| l.samples.as_slice()).collect();
    Ok(diagnose::features::rows(&report, &samples))
}

fn diagnose_cmd(args: DiagnoseArgs) -> Result<()> {
    let rover_file = host_tool::rover::load_rover_file(&args.rover)?;
    let (rover, offset) = (rover_file.rover, rover_file.tracker_offset_m);
    let (rows, notes) = diagnosis_rows(&rover, offset, &args.runs, "diagnosed")?;
    let cal_rows = if args.calibration.is_empty() {
        None
    } else {
        Some(diagnosis_rows(&rover, offset, &args.calibration, "calibration")?.0)
    };
    let calibration = match &cal_rows {
        Some(rows) => Calibration::Rows(rows),
        None => Calibration::FromRuns,
    };
    let mut diagnosis =
        diagnose::diagnose_with(&rover, &rows, calibration).context("diagnosing the runs")?;
    diagnosis.notes.extend(notes);
    // Files first: a closed stdout (`| head`) must not lose them.
    let files = match &args.out {
        Some(dir) => report::write_out_dir(dir, &rover, &diagnosis, &rows, calibration)?,
        None => Vec::new(),
    };
    if !emit_json(args.json.as_deref(), &diagnosis.to_json(), "diagnosis")? {
        // Written, not print!ed: a closed stdout is an error, not a panic.
        let mut stdout = std::io::stdout().lock();
        write!(stdout, "{}", report::table(&diagnosis))?;
        if !files.is_empty() {
            writeln!(stdout)?;
        }
        for file in files {
            writeln!(stdout, "{}", file.display())?;
        }
    }
    Ok(())
}

fn diagnose_bench_cmd(args: DiagnoseBenchArgs) -> Result<()> {
    let options = diagnose::bench::BenchOptions {
        datasets: args.datasets as usize,
        seed: args.seed,
        threads: args.threads as usize,
        part: match args.part {
            BenchPartArg::Tuning => diagnose::bench::PartChoice::Tuning,
            BenchPartArg::HeldOut => diagnose::bench::PartChoice::HeldOut,
            BenchPartArg::Both => diagnose::bench::PartChoice::Both,
        },
        poses: args.poses,
    };
    let report = diagnose::bench::run_bench(&options);
    if !emit_json(args.json.as_deref(), &report, "bench")? {
        write!(std::io::stdout().lock(), "{report}")?;
    }
    Ok(())
}

fn plan_cmd(args: PlanArgs) -> Result<()> {
    let (model, source) = match args.model {
        Some(path) => (plan::load_model(&path)?, ModelSource::File(path)),
        None => {
            let preset = Preset::from(args.preset);
            (preset.model(), ModelSource::Preset(preset))
        }
    };
    let report = plan::plan(
        &model,
        &source,
        args.start_deg,
        args.end_deg,
        args.distance_m,
    )?;
    if !emit_json(args.json.as_deref(), &report, "plan")? {
        print!("{report}");
    }
    Ok(())
}

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Decode { capture, json } => {
            let bytes = if capture.as_os_str() == "-" {
                let mut bytes = Vec::new();
                std::io::stdin()
                    .read_to_end(&mut bytes)
                    .context("reading stdin")?;
                bytes
            } else {
                std::fs::read(&capture).with_context(|| format!("reading {}", capture.display()))?
            };
            let summary = Summary::of(&bytes);
            if json {
                println!("{}", serde_json::to_string_pretty(&summary)?);
            } else {
                print!("{}: {summary}", capture.display());
            }
        }
        Command::Validate {
            rover,
            runs,
            json,
            csv,
            turn_deg,
            settle_s,
            min_duration_s,
            speed_tolerance_mps,
            departure_pct,
            hard_ground,
            no_hard_ground,
        } => {
            let rover_file = host_tool::rover::load_rover_file(&rover)?;
            let rover = rover_file.rover;
            let mut options = ValidateOptions::for_rover(&rover);
            options.tracker_offset_m = rover_file.tracker_offset_m;
            options.turn_deg = turn_deg;
            options.settle_s = settle_s;
            options.segment.min_duration_s = min_duration_s;
            options.segment.speed_tolerance_mps = speed_tolerance_mps;
            options.departure_fraction = departure_pct / 100.0;
            if no_hard_ground {
                options.hard_ground = None;
            } else if let Some([mu, g, bs]) = hard_ground {
                options.hard_ground = Some(IcrHardGround {
                    mu,
                    rolling_resistance_n: g,
                    length_m: f64::from(rover.length_m),
                    width_m: f64::from(rover.track_width_m),
                    mass_kg: f64::from(rover.mass_kg),
                    slip_track_m: bs,
                });
            }
            let (names, logs) = load_runs(&runs)?;
            let inputs: Vec<RunInput<'_>> = names
                .iter()
                .zip(&logs)
                .map(|(name, log)| RunInput::from_log(name, log))
                .collect();
            let report = validate::validate(&rover, &inputs, &options)?;
            let json_to_stdout = emit_json(json.as_deref(), &report, "report")?;
            if let Some(path) = &csv {
                let mut text = Vec::new();
                report.write_csv(&mut text)?;
                write_file(path, &text)?;
            }
            if !json_to_stdout {
                print!("{report}");
            }
        }
        Command::Convert { input, output } => {
            let done = convert(&input, &output)?;
            warn_truncated(&input, done.truncated);
            print!(
                "{} ({}) -> {} ({}): {} samples",
                input.display(),
                done.from,
                output.display(),
                done.to,
                done.samples
            );
            if done.frames > 0 {
                let how = if done.synthesised_frames {
                    " (synthesised from the samples)"
                } else {
                    ""
                };
                print!(", {} frames{how}", done.frames);
            }
            println!();
        }
        Command::Replay {
            log,
            to_pty,
            to,
            speed,
            as_fast_as_possible,
        } => {
            let loaded = load(&log)?;
            warn_truncated(&log, loaded.truncated);
            let frames =
                frames_of(&loaded.run).map_err(|e| anyhow::anyhow!("encoding frames: {e}"))?;
            if frames.is_empty() {
                bail!(
                    "{}: nothing to replay (no frames, no samples)",
                    log.display()
                );
            }
            if let Some(out) = to {
                if same_file(&log, &out) {
                    bail!("{}: the output is the input file", out.display());
                }
                let bytes = write_atomically(&out, |w| write_stream(&frames, w))?;
                println!("{}: {} frames, {bytes} bytes", out.display(), frames.len());
            } else if to_pty {
                let pacing = if as_fast_as_possible {
                    ReplayPacing::AsFastAsPossible
                } else {
                    ReplayPacing::RealTime { speed }
                };
                let replay = ReplayPty::spawn(frames, pacing, None)?;
                println!("{}", replay.path());
                let stats = replay.join().context("replaying into the pty")?;
                eprintln!("replayed {} frames, {} bytes", stats.frames, stats.bytes);
            }
        }
        Command::Ports { json } => ports(json)?,
        Command::Demo {
            out,
            world,
            scenario,
            runs,
            seed,
            speed,
        } => demo_cmd(out, world, scenario, runs, seed, speed)?,
        Command::Plot {
            rover,
            runs,
            out,
            format,
        } => plot_cmd(&rover, &runs, &out, format)?,
        Command::Record(args) => record_cmd(args)?,
        Command::Plan(args) => plan_cmd(args)?,
        Command::Diagnose(args) => diagnose_cmd(args)?,
        Command::DiagnoseBench(args) => diagnose_bench_cmd(args)?,
    }
    Ok(())
}
