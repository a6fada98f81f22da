//! `host-tool`: command line of the rover-power host tool (arguments only; the work is in the
//! library).

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use host_tool::decode::Summary;
use host_tool::log::commands::read_commands_csv;
use host_tool::record::{self, RecordOptions, RecordStatus};
use host_tool::rover::load_rover;
use host_tool::serial::list_ports;
use std::io::{IsTerminal, Read, Write};
use std::path::PathBuf;
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
    let rows: Vec<[String; 5]> = ports
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
            ]
        })
        .collect();
    let header = ["PORT", "VID:PID", "PRODUCT", "MANUFACTURER", "SERIAL"];
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
        Command::Ports { json } => ports(json)?,
        Command::Record(args) => record_cmd(args)?,
    }
    Ok(())
}
