//! `host-tool`: command line of the rover-power host tool (arguments only; the work is in the
//! library).

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use host_tool::decode::Summary;
use std::io::Read;
use std::path::PathBuf;

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
    }
    Ok(())
}
