//! `host-tool decode`: summary of a raw capture of the board's serial stream.

use super::output::{self, JsonOut};
use anyhow::{Context, Result};
use host_tool::decode::{read_capture, CaptureEnd, CaptureError};
use host_tool::record::stop_signal;
use std::io::{IsTerminal, Read, Write};
use std::path::PathBuf;
use std::time::Duration;

/// Interval between running summaries on stderr while a capture is read (a capture read
/// faster prints none).
const REPORT_EVERY: Duration = Duration::from_secs(1);

/// `decode CAPTURE [--json FILE|-]`.
#[derive(clap::Args, Debug)]
pub struct DecodeArgs {
    /// Capture file (raw bytes as read from the board's serial port; `-` for stdin), read as it
    /// comes: an endless one (a FIFO) prints a running summary every second on stderr and its
    /// summary at Ctrl-C. A run log (.mcap, .csv) is recognised and refused with a hint.
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
            status.show(&summary.running_line());
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
        status.finish(match end {
            CaptureEnd::Eof => None,
            CaptureEnd::Stopped => Some(format!(
                "stopped: the summary is of the first {} bytes",
                summary.bytes
            )),
        });
        if !self.json.emit(&summary, "summary", self.force)? {
            output::print(format_args!("{name}: {summary}"))?;
        }
        Ok(())
    }
}

/// The running summary on stderr, the one place `decode` writes there: one line rewritten in
/// place on a terminal, a line per report into a file or pipe. A closed stderr is ignored.
struct StatusLine {
    stderr: std::io::Stderr,
    live: bool,
    shown: bool,
}

impl StatusLine {
    fn stderr() -> Self {
        let stderr = std::io::stderr();
        let live = stderr.is_terminal();
        Self {
            stderr,
            live,
            shown: false,
        }
    }

    fn show(&mut self, line: &str) {
        let _ = if self.live {
            write!(self.stderr, "\r\x1b[2K{line}")
        } else {
            writeln!(self.stderr, "{line}")
        };
        let _ = self.stderr.flush();
        self.shown = true;
    }

    /// Ends the running line (on a terminal) with `last`, or clears it.
    fn finish(&mut self, last: Option<String>) {
        let _ = match (&last, self.live && self.shown) {
            (Some(last), true) => writeln!(self.stderr, "\r\x1b[2K{last}"),
            (Some(last), false) => writeln!(self.stderr, "{last}"),
            (None, true) => write!(self.stderr, "\r\x1b[2K"),
            (None, false) => Ok(()),
        };
        let _ = self.stderr.flush();
    }
}
