//! `host-tool decode`: summary of a raw capture of the board's serial stream.

use super::output::{self, JsonOut};
use anyhow::{Context, Result};
use host_tool::decode::{read_capture, CaptureEnd, CaptureError};
use host_tool::progress::StatusLine;
use host_tool::record::stop_signal;
use std::io::Read;
use std::path::PathBuf;
use std::time::Duration;

/// Interval between running summaries on stderr while a capture is read (a capture read
/// faster prints none).
const REPORT_EVERY: Duration = Duration::from_secs(1);

/// `decode CAPTURE [--json FILE|-]`.
#[derive(clap::Args, Debug)]
pub struct DecodeArgs {
    /// Capture file (raw bytes as read from the board's serial port; `-` for stdin), read as it
    /// comes: an endless one (a FIFO) prints a running summary on stderr (every second on a
    /// terminal, every 10 s into a file) and its summary at Ctrl-C. A run log (.mcap, .csv) is
    /// recognised and refused with a hint.
    capture: PathBuf,
    #[command(flatten)]
    json: JsonOut,
    /// Overwrite an existing --json file.
    #[arg(long)]
    force: bool,
}

impl DecodeArgs {
    /// Decodes the capture and prints (or writes) its summary.
    pub fn run(self) -> Result<()> {
        self.json.check(self.force)?;
        let name = self.capture.display();
        let input: Box<dyn Read + Send> = if self.capture.as_os_str() == "-" {
            Box::new(std::io::stdin())
        } else {
            // Opened before the stop handler: Ctrl-C while a FIFO waits for its writer quits.
            Box::new(std::fs::File::open(&self.capture).with_context(|| format!("reading {name}"))?)
        };
        // Ctrl-C, SIGTERM and SIGHUP end an endless capture with its summary.
        let stop = stop_signal::install().context("installing the stop-signal handler")?;
        let mut status = StatusLine::stderr();
        let read = read_capture(input, &stop, REPORT_EVERY, &mut |summary| {
            status.show(&summary.running_line(), false);
        });
        let (summary, end) = match read {
            Ok(read) => read,
            Err(CaptureError::Foreign(hint)) => {
                status.finish(None);
                anyhow::bail!("{name}: {hint}");
            }
            Err(CaptureError::Io(e)) => {
                status.finish(None);
                return Err(e).with_context(|| format!("reading {name}"));
            }
        };
        status.finish(
            match end {
                CaptureEnd::Eof => None,
                CaptureEnd::Stopped => Some(format!(
                    "stopped: the summary is of the first {} bytes",
                    summary.bytes
                )),
            }
            .as_deref(),
        );
        if !self.json.emit(&summary, "summary", self.force)? {
            output::print(format_args!("{name}: {summary}"))?;
        }
        Ok(())
    }
}
