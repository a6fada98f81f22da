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
use std::io::Read;
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
