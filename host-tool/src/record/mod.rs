//! Live recording from the board's serial port into a run log ([`RunLogSink`]): decode, convert
//! to physical samples on one run time base, forward commanded wheel speeds, survive unplugs,
//! report a live status, and stop on request.
//!
//! - Time: [`RunClock`] — the board's µs stamps relative to the first sample, continuing across
//!   counter wraps, board resets (after the wall-clock gap) and reconnections, so `t_s` strictly
//!   increases over the whole run.
//! - Units: raw registers scaled with the board's hello ([`model_core::ina226::Scale`]).
//! - A sample where a chip gave no reading (`Failed`: NACK, reset, awaiting its first conversion)
//!   has no row in the run log's samples — a run CSV needs both sides — and is counted
//!   ([`RecordSummary::incomplete_samples`]); its wire frame is still logged
//!   ([`RunLogSink::frame`]) and the live status names the failing chip. `Stale` readings (the
//!   same averaged result read again) are rows: they are the chip's current measurement.
//! - Commands ([`RecordOptions::commands`]): when the stream's run time reaches a row, its side
//!   speeds go to the board as `SetWheelRates` (ω = v / r, one command per change); when the
//!   board's ack arrives the host mirrors the rates ([`StreamDecoder::expect_ack`]), so the host's
//!   τ ∝ P/ω (Eq 5.14) equals the board's in every model frame. After a board reset the rates in
//!   force are sent again (the rebooted board forgot them).
//! - Without commands (no `--commands`) the commanded speeds are the board's own: each `Status`
//!   frame reports the wheel rates the board uses for τ, and a change becomes a command row
//!   (v = ω · wheel radius, rounded to 1 µm/s) in the log and the samples' `cmd_*` columns. A
//!   replay reports every command it carries that way (`crate::replay`), so a recording of a
//!   replay holds the original's commands.
//! - Merged, not forwarded ([`RecordOptions::forward_commands`] off, `--merge-commands`): the
//!   rows fill the samples' `cmd_*` and pose columns and the log's command rows as with
//!   `--commands`, but nothing goes to the board, whose stream reports the speeds in force (a
//!   replay's). The robot's side of a run, which the board's stream cannot carry (its tracker's
//!   yaw, pitch and position fixes), comes back this way: `replay --commands-out` writes it.
//! - Unplug: on a vanished device the log gets [`LogEvent::DeviceVanished`] and is flushed; the
//!   same path is re-opened every [`RecordOptions::retry_every`] until it works
//!   ([`LogEvent::Reconnected`]) or [`RecordOptions::reconnect_timeout`] passes.
//! - Rate ([`RecordOptions::sample_period_us`], `--rate-hz`): at each hello whose period differs
//!   the board gets `Configure` with that period and the smoothest averaging it allows
//!   ([`AdcConfig::smoothest_for_period`]); a refusal ends the recording with an error.
//! - Crash safety: the sink is flushed every [`RecordOptions::flush_every`].
//! - Wall time: at the first sample the log gets [`LogEvent::WallClock`], the host's Unix time
//!   when its bytes were read; run time continues across resets and reconnections by the
//!   wall-clock gap, so run time + that offset is wall time (to the crystal's drift).
//!
//! [`StreamDecoder::expect_ack`]: crate::decode::StreamDecoder::expect_ack
//! [`LogEvent::DeviceVanished`]: crate::log::run_log::LogEvent::DeviceVanished
//! [`LogEvent::Reconnected`]: crate::log::run_log::LogEvent::Reconnected
//! [`LogEvent::WallClock`]: crate::log::run_log::LogEvent::WallClock

mod clock;
mod rate;
mod recorder;
mod report;
pub mod stop_signal;
mod timeline;

pub use clock::RunClock;
pub use report::{RecordStatus, RecordSummary, StopReason};
pub use timeline::CommandTimeline;

use recorder::Recorder;

use crate::decode::{Segment, StreamStats};
use crate::excerpt::Number;
use crate::log::commands::CommandRow;
use crate::log::csv_sink::CsvRunSink;
use crate::log::mcap::{McapError, McapSink};
use crate::log::run_log::RunLogSink;
use crate::serial::{self, SerialError};
use model_core::ina226::{AdcConfig, Scale};
use model_core::wire::{self, ChipFault, Command};
use model_core::{Rover, Sides};
use std::fmt;
use std::io::{self, Read, Write};
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// What the recorder reads and writes: a serial port, a pty, or a test's scripted stream.
pub trait BoardPort: Read + Write + Send {}

impl<T: Read + Write + Send + ?Sized> BoardPort for T {}

/// Opens the board's port by path (called again on every reconnection attempt).
pub type PortOpener<'a> = dyn FnMut(&str) -> Result<Box<dyn BoardPort>, SerialError> + 'a;

/// Opens real serial ports (and ptys) with [`serial::open`].
pub fn serial_opener(
    read_timeout: Duration,
) -> impl FnMut(&str) -> Result<Box<dyn BoardPort>, SerialError> {
    move |path| serial::open(path, read_timeout).map(|p| Box::new(p) as Box<dyn BoardPort>)
}

/// Why a log could not be created.
#[derive(Debug, thiserror::Error)]
pub enum SinkError {
    /// The extension names no log format this tool writes.
    #[error("{}: unknown log format (the output must end in .mcap or .csv)", path.display())]
    UnknownFormat {
        /// The output path.
        path: std::path::PathBuf,
    },
    /// The file could not be created.
    #[error(transparent)]
    Io(#[from] io::Error),
    /// The MCAP file could not be started.
    #[error(transparent)]
    Mcap(#[from] McapError),
}

/// The log for `path`, chosen by its extension (`.mcap`: [`McapSink`], `.csv`: [`CsvRunSink`]). An existing file is an
/// error unless `overwrite`.
pub fn create_sink(path: &Path, overwrite: bool) -> Result<Box<dyn RunLogSink>, SinkError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("csv") => Ok(Box::new(CsvRunSink::create(path, overwrite)?)),
        Some("mcap") => Ok(Box::new(McapSink::create(path, overwrite)?)),
        _ => Err(SinkError::UnknownFormat {
            path: path.to_owned(),
        }),
    }
}

/// What to record and when to stop.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordOptions {
    /// The port's path (`/dev/ttyACM0`, a `/dev/serial/by-id/…` link, a pty).
    pub port: String,
    /// Stop after this much wall-clock time.
    pub duration: Option<Duration>,
    /// Stop after this many samples received.
    pub max_samples: Option<u64>,
    /// Commands to forward and to copy into the samples' `cmd_*`/pose columns (empty: none).
    pub commands: Vec<CommandRow>,
    /// Whether [`Self::commands`] go to the board (`record --commands`), or are only copied into
    /// the log because the board's stream already reports their speeds (`record
    /// --merge-commands`: a replay's pty, which takes no commands and whose acks answer the
    /// original recorder's).
    pub forward_commands: bool,
    /// The rover whose wheel radius turns side speeds into wheel rates.
    pub rover: Rover,
    /// How long a vanished device may stay away before the recording stops.
    pub reconnect_timeout: Duration,
    /// Interval between attempts to re-open a vanished device.
    pub retry_every: Duration,
    /// Longest wait of one read (and so the loop's reaction time).
    pub read_timeout: Duration,
    /// Interval between flushes of the log.
    pub flush_every: Duration,
    /// Interval between live status reports.
    pub status_every: Duration,
    /// The sampling period to configure the board to [µs] (`--rate-hz`); `None`: the board's.
    pub sample_period_us: Option<u32>,
    /// The earliest Unix time [ns] the first sample is anchored at (the host's clock when its
    /// bytes were read, if later): the demo lays its faster-than-real-time runs end to end,
    /// each on its own real-time timeline, so that Foxglove shows them one after another.
    pub first_sample_not_before_unix_ns: Option<u64>,
}

impl RecordOptions {
    /// Recording from `port` until stopped, no commands, the Husky A200, reconnecting for up to
    /// 60 s, flushing every 200 ms, status twice a second.
    pub fn new(port: impl Into<String>) -> Self {
        Self {
            port: port.into(),
            duration: None,
            max_samples: None,
            commands: Vec::new(),
            forward_commands: true,
            rover: Rover::HUSKY_A200,
            reconnect_timeout: Duration::from_secs(60),
            retry_every: Duration::from_millis(200),
            read_timeout: Duration::from_millis(50),
            flush_every: Duration::from_millis(200),
            status_every: Duration::from_millis(500),
            sample_period_us: None,
            first_sample_not_before_unix_ns: None,
        }
    }

    /// The `Configure` command for [`Self::sample_period_us`] (`None` without one), or why the
    /// board would refuse it.
    pub fn configure_command(&self) -> Result<Option<Command>, RecordError> {
        let Some(sample_period_us) = self.sample_period_us else {
            return Ok(None);
        };
        let refused = || {
            RecordError::Options(format!(
                "a sampling period of {sample_period_us} µs ({:.1} Hz) is outside what the board sustains: {} µs ({:.0} Hz, the I²C bus's limit) to {} µs",
                1e6 / f64::from(sample_period_us.max(1)),
                wire::MIN_SAMPLE_PERIOD_US,
                1e6 / f64::from(wire::MIN_SAMPLE_PERIOD_US),
                wire::MAX_SAMPLE_PERIOD_US
            ))
        };
        let adc = AdcConfig::smoothest_for_period(sample_period_us).ok_or_else(refused)?;
        let command = Command::Configure {
            adc,
            sample_period_us,
        };
        command.validate().map_err(|_| refused())?;
        Ok(Some(command))
    }

    /// The wheel rates [rad/s] for side speeds `v_mps` on this rover.
    pub fn wheel_rates(&self, v_mps: Sides<f64>) -> Sides<f32> {
        let r = f64::from(self.rover.wheel_radius_m);
        v_mps.map(|v| (v / r) as f32)
    }

    /// Checks that every command row turns into wheel rates the board accepts.
    pub fn validate(&self) -> Result<(), RecordError> {
        self.configure_command()?;
        if !(self.rover.wheel_radius_m.is_finite() && self.rover.wheel_radius_m > 0.0) {
            return Err(RecordError::Options(format!(
                "wheel radius {} m must be finite and > 0",
                self.rover.wheel_radius_m
            )));
        }
        for (i, row) in self.commands.iter().enumerate() {
            let rates = self.wheel_rates(row.cmd_mps);
            if Command::SetWheelRates(rates).validate().is_err() {
                return Err(RecordError::Command {
                    row: i + 1,
                    t_s: row.t_s,
                    reason: format!(
                        "side speeds {} / {} m/s are wheel rates {} / {} rad/s; the board accepts |ω| ≤ {} rad/s",
                        Number(row.cmd_mps.left),
                        Number(row.cmd_mps.right),
                        Number(rates.left),
                        Number(rates.right),
                        wire::MAX_WHEEL_RATE_RAD_S
                    ),
                });
            }
        }
        Ok(())
    }
}

/// Why a recording failed (a recording that merely stopped returns a [`RecordSummary`]).
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The port could not be opened at the start.
    #[error(transparent)]
    Open(#[from] SerialError),
    /// Writing the log failed (disk full, file removed); the log holds what was flushed.
    #[error("writing the log: {0}")]
    Sink(#[source] io::Error),
    /// A command row the board would refuse.
    #[error("commands row {row} (t_s = {} s): {reason}", Number(*t_s))]
    Command {
        /// 1-based row (not counting the header).
        row: usize,
        /// Its time.
        t_s: f64,
        /// What is wrong.
        reason: String,
    },
    /// Inconsistent options.
    #[error("{0}")]
    Options(String),
}

/// Records from `options.port` into `sink` until stopped: `stop` raised (Ctrl-C), the duration
/// or sample count reached, or the device gone for longer than the reconnect timeout.
/// `on_status` gets the live status every [`RecordOptions::status_every`] and once at the end
/// ([`RecordStatus::stopped`] set).
///
/// The port is opened with `open` (normally [`serial_opener`]). Failing to open it at the start
/// is an error; later, a vanished device is waited for. The sink is finished before returning,
/// also on a sink error (as far as it goes).
pub fn record(
    options: &RecordOptions,
    open: &mut PortOpener<'_>,
    sink: &mut dyn RunLogSink,
    stop: &AtomicBool,
    on_status: &mut dyn FnMut(&RecordStatus),
) -> Result<RecordSummary, RecordError> {
    options.validate()?;
    let port = open(&options.port)?;
    record_on(options, port, open, sink, stop, on_status)
}

/// Like [`record`] on a port already opened (so a caller can check the port before it creates
/// the log file); `open` is used for reconnections.
pub fn record_on(
    options: &RecordOptions,
    port: Box<dyn BoardPort>,
    open: &mut PortOpener<'_>,
    sink: &mut dyn RunLogSink,
    stop: &AtomicBool,
    on_status: &mut dyn FnMut(&RecordStatus),
) -> Result<RecordSummary, RecordError> {
    options.validate()?;
    let mut rec = Recorder::new(options, open, sink, port);
    let outcome = rec.run(stop, on_status);
    let finished = rec.sink.finish().map_err(RecordError::Sink);
    let stop_reason = outcome?;
    finished?;
    let summary = rec.summary(stop_reason);
    let mut last = rec.status(Instant::now());
    last.stopped = Some(stop_reason);
    last.reconnect_left = None; // nothing is waited for any more
    on_status(&last);
    Ok(summary)
}

#[cfg(test)]
mod tests;
