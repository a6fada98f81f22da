//! `host-tool record`: the board's stream from a serial port into a run log.

use super::output::{self, check_new_file, create_parent};
use anyhow::{bail, Context, Result};
use host_tool::eprintln_best_effort;
use host_tool::live::{LiveServer, LiveTee};
use host_tool::log::commands::read_commands_csv;
use host_tool::progress::StatusLine;
use host_tool::record::{self, RecordError, RecordOptions, RecordStatus};
use std::path::PathBuf;
use std::time::Duration;

/// `record --port P --out RUN.mcap|RUN.csv [...]`.
#[derive(clap::Args, Debug)]
pub struct RecordArgs {
    /// The board's port (`/dev/ttyACM0`, `/dev/serial/by-id/...`, a replay's pty).
    #[arg(long)]
    port: String,
    /// The log to write; its extension picks the format (.csv: run CSV + events file).
    #[arg(long)]
    out: PathBuf,
    /// Overwrite an existing log.
    #[arg(long)]
    force: bool,
    /// Stop after this many seconds of wall time.
    #[arg(long = "duration-s", alias = "duration", value_parser = parse_seconds, value_name = "S")]
    duration_s: Option<Duration>,
    /// Stop after this many samples.
    #[arg(long)]
    samples: Option<u64>,
    /// Commands CSV (t_s, cmd_left_mps, cmd_right_mps[, yaw_rad, pitch_deg]): forwarded to the
    /// board as wheel rates and copied into the log. Without it the commanded speeds are the
    /// board's own reports (a replay carries the original's that way).
    #[arg(long)]
    commands: Option<PathBuf>,
    /// Commands CSV copied into the log like --commands (speeds, tracker yaw, pitch and
    /// position) but not sent to the board, whose stream reports the speeds in force: for a
    /// replay's pty, with the file `replay --commands-out` wrote.
    #[arg(long, value_name = "FILE", conflicts_with = "commands")]
    merge_commands: Option<PathBuf>,
    /// The rover, for its wheel radius.
    #[command(flatten)]
    rover: super::RoverArg,
    /// Seconds to wait for a vanished device before stopping (a pty is not waited for).
    #[arg(
        long = "reconnect-timeout-s",
        alias = "reconnect-timeout",
        value_parser = parse_seconds,
        default_value = "60",
        value_name = "S"
    )]
    reconnect_timeout_s: Duration,
    /// Configure the board to sample at this rate [Hz] (up to 2000, the I²C bus's limit), with
    /// the smoothest averaging the rate allows; without it the board keeps its own (200 Hz).
    #[arg(long = "rate-hz", value_parser = parse_rate_hz, value_name = "HZ")]
    rate_hz: Option<u32>,
    #[command(flatten)]
    serve: super::serve::ServeArgs,
}

/// A sampling rate [Hz] as the board's period [µs].
pub fn parse_rate_hz(text: &str) -> Result<u32, String> {
    let hz: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a rate in Hz"))?;
    match model_core::rate::period_for_rate_us(hz) {
        0 => Err(format!("{text} Hz must be a finite number > 0")),
        period_us => Ok(period_us),
    }
}

/// A non-negative, finite number of seconds.
fn parse_seconds(text: &str) -> Result<Duration, String> {
    let s: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a number of seconds"))?;
    Duration::try_from_secs_f64(s).map_err(|_| format!("{text} s must be finite and >= 0"))
}

impl RecordArgs {
    /// Records until stopped; prints the summary.
    pub fn run(self) -> Result<()> {
        let mut options = RecordOptions::new(self.port);
        options.duration = self.duration_s;
        options.max_samples = self.samples;
        options.reconnect_timeout = self.reconnect_timeout_s;
        options.sample_period_us = self.rate_hz;
        if let Some(path) = &self.commands {
            options.commands = read_commands_csv(path)?;
        }
        if let Some(path) = &self.merge_commands {
            options.commands = read_commands_csv(path)?;
            options.forward_commands = false;
        }
        options.rover = self.rover.load()?.rover;
        let commands_file = self.commands.as_ref().or(self.merge_commands.as_ref());
        options.validate().map_err(|e| match (&e, commands_file) {
            (RecordError::Command { .. }, Some(path)) => output::naming(path, e),
            _ => e.into(),
        })?;
        // Ctrl-C, SIGTERM and SIGHUP stop cleanly (footer written, exit 0).
        let stop = record::stop_signal::install().context("installing the stop-signal handler")?;
        let mut open = record::serial_opener(options.read_timeout);
        // The port first: a wrong path leaves no empty log behind.
        let board = open(&options.port)?;
        check_new_file(&self.out, self.force)?;
        // Before the log: an address in use leaves no empty log behind.
        let live_server = self.serve.start()?;
        create_parent(&self.out)?;
        let mut file =
            record::create_sink(&self.out, self.force).map_err(|e| output::naming(&self.out, e))?;
        // The viewers beside the file, never ahead of it.
        let mut sink = LiveTee::new(
            file.as_mut(),
            live_server.as_ref().map(LiveServer::recording_sink),
        );
        // News for a log file: the port gone or back, the last status.
        let mut status_line = StatusLine::stderr();
        let mut connected = true;
        let mut on_status = |status: &RecordStatus| {
            let news = status.stopped.is_some() || status.connected != connected;
            connected = status.connected;
            status_line.show(&status.to_string(), news);
        };
        eprintln_best_effort!(
            "recording {} -> {} (Ctrl-C to stop)",
            options.port,
            self.out.display()
        );
        let result =
            record::record_on(&options, board, &mut open, &mut sink, &stop, &mut on_status);
        super::serve::finish(live_server, "rover-power: the recording has stopped");
        status_line.keep();
        let summary = result.map_err(|e| match e {
            RecordError::Sink(_) => output::naming(&self.out, e),
            e => e.into(),
        })?;
        output::print(format_args!("{}: {summary}", self.out.display()))?;
        if summary.samples == 0 {
            bail!("no samples were recorded");
        }
        Ok(())
    }
}
