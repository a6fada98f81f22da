//! `host-tool`: command line of the rover-power host tool (arguments only; the work is in the
//! library).

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use host_tool::decode::Summary;
use host_tool::log::convert::{convert, same_file};
use host_tool::log::load::load;
use host_tool::log::mcap::Truncation;
use host_tool::log::write_atomically;
use host_tool::replay::{frames_of, write_stream, ReplayPacing, ReplayPty};
use host_tool::validate::{self, RunInput, ValidateOptions};
use model_core::power::IcrHardGround;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

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

fn positive_speed(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(k) if k.is_finite() && k > 0.0 => Ok(k),
        _ => Err(format!(
            "{text:?} is not a speed factor (a finite number > 0)"
        )),
    }
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

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Decode { capture } => {
            let bytes = if capture.as_os_str() == "-" {
                let mut bytes = Vec::new();
                std::io::stdin()
                    .read_to_end(&mut bytes)
                    .context("reading stdin")?;
                bytes
            } else {
                std::fs::read(&capture).with_context(|| format!("reading {}", capture.display()))?
            };
            print!("{}: {}", capture.display(), Summary::of(&bytes));
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
            let rover = host_tool::rover::load_rover(&rover)?;
            let mut options = ValidateOptions::for_rover(&rover);
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
            let names: Vec<String> = runs.iter().map(|p| p.display().to_string()).collect();
            let logs = runs
                .iter()
                .map(|p| {
                    let loaded = load(p)?;
                    warn_truncated(p, loaded.truncated);
                    Ok(loaded.run)
                })
                .collect::<Result<Vec<_>>>()?;
            let inputs: Vec<RunInput<'_>> = names
                .iter()
                .zip(&logs)
                .map(|(name, log)| RunInput::from_log(name, log))
                .collect();
            let report = validate::validate(&rover, &inputs, &options)?;
            let json_to_stdout = json.as_deref().is_some_and(|p| p.as_os_str() == "-");
            if let Some(path) = &json {
                let text = serde_json::to_vec_pretty(&report).context("serialising the report")?;
                if json_to_stdout {
                    let mut out = std::io::stdout().lock();
                    out.write_all(&text)?;
                    writeln!(out)?;
                } else {
                    write_file(path, &text)?;
                }
            }
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
    }
    Ok(())
}
