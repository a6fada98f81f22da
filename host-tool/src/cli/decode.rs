//! `host-tool decode`: summary of a raw capture of the board's serial stream.

use super::output::{self, JsonOut};
use anyhow::{bail, Context, Result};
use host_tool::decode::{foreign_format, Summary};
use std::io::Read;
use std::path::PathBuf;

/// `decode CAPTURE [--json FILE|-]`.
#[derive(clap::Args, Debug)]
pub struct DecodeArgs {
    /// Capture file (raw bytes as read from the board's serial port; `-` for stdin). A run log
    /// (.mcap, .csv) is recognised and refused with a hint.
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
        let bytes = if self.capture.as_os_str() == "-" {
            let mut bytes = Vec::new();
            std::io::stdin()
                .read_to_end(&mut bytes)
                .context("reading stdin")?;
            bytes
        } else {
            std::fs::read(&self.capture)
                .with_context(|| format!("reading {}", self.capture.display()))?
        };
        if let Some(hint) = foreign_format(&bytes) {
            bail!("{}: {hint}", self.capture.display());
        }
        let summary = Summary::of(&bytes);
        if !self.json.emit(&summary, "summary", self.force)? {
            output::print(format_args!("{}: {summary}", self.capture.display()))?;
        }
        Ok(())
    }
}
