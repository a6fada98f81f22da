//! `host-tool`: command line of the rover-power host tool.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use host_tool::decode::{Event, StreamDecoder};
use model_core::wire::BoardFrame;
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
        Command::Decode { capture } => decode(&capture),
    }
}

fn decode(path: &PathBuf) -> Result<()> {
    let mut bytes = Vec::new();
    if path.as_os_str() == "-" {
        std::io::stdin()
            .read_to_end(&mut bytes)
            .context("reading stdin")?;
    } else {
        bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    }
    let mut dec = StreamDecoder::new();
    let (mut first_t, mut last_t) = (None, None);
    let mut status = None;
    dec.feed(&bytes, |event| match event {
        Event::Frame(BoardFrame::Sample(s)) => {
            first_t.get_or_insert(s.t_us);
            last_t = Some(s.t_us);
        }
        Event::Frame(BoardFrame::Status(s)) => status = Some(s),
        _ => {}
    });
    let stats = dec.stats();
    let scale = dec.scale();
    println!("{}: {} bytes", path.display(), bytes.len());
    match dec.hello() {
        Some(h) => println!(
            "board: firmware {}.{}.{}, protocol {}, shunt {} µΩ, current LSB {} nA, chips {:#04x}/{:#04x}, period {} µs",
            h.firmware.major, h.firmware.minor, h.firmware.patch, h.protocol,
            h.scale.shunt_micro_ohm, h.scale.current_lsb_na, h.addresses.left, h.addresses.right, h.sample_period_us
        ),
        None => println!("board: no hello frame in the capture (assuming the rover-power board's scale)"),
    }
    println!(
        "frames {}, samples {}, bad frames {} ({} CRC), lost samples {} in {} gaps",
        stats.frames,
        stats.samples,
        stats.bad_frames,
        stats.crc_errors,
        stats.lost_samples,
        stats.gaps
    );
    if let (Some(a), Some(b)) = (first_t, last_t) {
        println!("duration {:.3} s", b.wrapping_sub(a) as f64 * 1e-6);
    }
    let host = dec.measurements().snapshot().energy_lsb_us;
    println!(
        "host energy from raw samples: left {:.3} J, right {:.3} J",
        scale.energy_j(host.left),
        scale.energy_j(host.right)
    );
    if let Some((model, at)) = dec.board_vs_host_energy() {
        let board = model.snapshot.energy_lsb_us;
        println!(
            "board energy at sample {}: left {:.3} J, right {:.3} J; host at that point differs by {:.6} J / {:.6} J",
            model.seq,
            scale.energy_j(board.left),
            scale.energy_j(board.right),
            scale.energy_j(at[0] - board.left),
            scale.energy_j(at[1] - board.right)
        );
    }
    if let Some(s) = status {
        println!(
            "last status: uptime {:.1} s, I²C errors {}/{}, re-inits {}/{}, queue drops {}, host-frame errors {}",
            s.uptime_us as f64 * 1e-6, s.i2c_errors.left, s.i2c_errors.right, s.reinits.left, s.reinits.right,
            s.queue_drops, s.rx_errors
        );
    }
    Ok(())
}
