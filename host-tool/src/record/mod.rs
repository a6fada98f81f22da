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

mod clock;
mod report;
pub mod stop_signal;
mod timeline;

pub use clock::RunClock;
pub use report::{RecordStatus, RecordSummary, StopReason};
pub use timeline::CommandTimeline;

use crate::decode::{Event, Segment, StreamDecoder, StreamStats};
use crate::log::commands::CommandRow;
use crate::log::csv_sink::CsvRunSink;
use crate::log::mcap::{McapError, McapSink};
use crate::log::run_csv::RunSample;
use crate::log::run_log::{LogEvent, RunLogSink};
use crate::serial::{self, PortReader, ReadOutcome, SerialError};
use model_core::ina226::{AdcConfig, Scale};
use model_core::wire::{self, BoardFrame, ChipFault, Command, HostFrame, Sample, Status};
use model_core::{Rover, Sides};
use std::fmt;
use std::io::{self, Read, Write};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
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
            rover: Rover::HUSKY_A200,
            reconnect_timeout: Duration::from_secs(60),
            retry_every: Duration::from_millis(200),
            read_timeout: Duration::from_millis(50),
            flush_every: Duration::from_millis(200),
            status_every: Duration::from_millis(500),
            sample_period_us: None,
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
                        row.cmd_mps.left,
                        row.cmd_mps.right,
                        rates.left,
                        rates.right,
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
    #[error("commands row {row} (t_s = {t_s} s): {reason}")]
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
/// `on_status` gets the live status every [`RecordOptions::status_every`] and once at the end.
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
    on_status(&rec.status(Instant::now()));
    Ok(summary)
}

/// The recording's state between reads.
struct Recorder<'a, 'o> {
    options: &'a RecordOptions,
    open: &'a mut PortOpener<'o>,
    sink: &'a mut dyn RunLogSink,
    reader: PortReader<Box<dyn BoardPort>>,
    decoder: StreamDecoder,
    clock: RunClock,
    timeline: CommandTimeline,
    scale: Scale,
    addresses: Sides<u8>,
    start: Instant,
    connected: bool,
    samples: u64,
    rows: u64,
    incomplete: u64,
    chip_faults: Sides<Option<ChipFault>>,
    chip_failed_samples: Sides<u64>,
    last_sample_at: Option<Instant>,
    /// When the bytes being decoded were read (the arrival time of their samples).
    read_at: Instant,
    bad_frames_unlogged: u64,
    board_status: Option<Status>,
    closed_segments: Vec<Segment>,
    closed_energy_j: Sides<f64>,
    vanished: u64,
    reconnects: u64,
    last_sent_mps: Option<Sides<f64>>,
    next_id: u16,
    awaiting: Vec<u16>,
    commands_sent: u64,
    /// The id of the `Configure` sent for `--rate-hz`, until the board answers it.
    configure_id: Option<u16>,
    commands_acked: u64,
    commands_rejected: u64,
    status_at: Instant,
    status_samples: u64,
    /// When the device vanished, while it is away.
    gone_at: Option<Instant>,
}

impl<'a, 'o> Recorder<'a, 'o> {
    fn new(
        options: &'a RecordOptions,
        open: &'a mut PortOpener<'o>,
        sink: &'a mut dyn RunLogSink,
        port: Box<dyn BoardPort>,
    ) -> Self {
        let now = Instant::now();
        Self {
            options,
            open,
            sink,
            reader: PortReader::new(port),
            decoder: StreamDecoder::for_port(),
            clock: RunClock::new(),
            timeline: CommandTimeline::new(options.commands.clone()),
            scale: Scale::BOARD,
            addresses: Sides::new(0x40, 0x45),
            start: now,
            connected: true,
            samples: 0,
            rows: 0,
            incomplete: 0,
            chip_faults: Sides::new(None, None),
            chip_failed_samples: Sides::default(),
            last_sample_at: None,
            read_at: now,
            bad_frames_unlogged: 0,
            board_status: None,
            closed_segments: Vec::new(),
            closed_energy_j: Sides::new(0.0, 0.0),
            vanished: 0,
            reconnects: 0,
            last_sent_mps: None,
            next_id: 0,
            awaiting: Vec::new(),
            commands_sent: 0,
            configure_id: None,
            commands_acked: 0,
            commands_rejected: 0,
            status_at: now,
            status_samples: 0,
            gone_at: None,
        }
    }

    fn run_s(&self) -> f64 {
        RunClock::seconds(self.clock.run_us())
    }

    fn event(&mut self, event: LogEvent) -> Result<(), RecordError> {
        let t_s = self.run_s();
        self.sink.event(t_s, &event).map_err(RecordError::Sink)
    }

    /// Logs the bad frames counted since the last mark, then flushes.
    fn flush(&mut self) -> Result<(), RecordError> {
        if self.bad_frames_unlogged > 0 {
            let count = std::mem::take(&mut self.bad_frames_unlogged);
            self.event(LogEvent::BadFrames { count })?;
        }
        self.sink.flush().map_err(RecordError::Sink)
    }

    fn stop_due(&self, stop: &AtomicBool, now: Instant) -> Option<StopReason> {
        if stop.load(Ordering::Relaxed) {
            Some(StopReason::Interrupted)
        } else if self
            .options
            .duration
            .is_some_and(|d| now.duration_since(self.start) >= d)
        {
            Some(StopReason::Duration)
        } else if self.options.max_samples.is_some_and(|n| self.samples >= n) {
            Some(StopReason::Samples)
        } else {
            None
        }
    }

    fn run(
        &mut self,
        stop: &AtomicBool,
        on_status: &mut dyn FnMut(&RecordStatus),
    ) -> Result<StopReason, RecordError> {
        self.event(LogEvent::Started {
            port: self.options.port.clone(),
        })?;
        self.flush()?;
        let mut flushed_at = Instant::now();
        let mut events = Vec::new();
        let reason = loop {
            let now = Instant::now();
            if let Some(reason) = self.stop_due(stop, now) {
                break reason;
            }
            if now.duration_since(flushed_at) >= self.options.flush_every {
                self.flush()?;
                flushed_at = now;
            }
            if now.duration_since(self.status_at) >= self.options.status_every {
                let status = self.status(now);
                on_status(&status);
            }
            events.clear();
            let outcome = self.reader.poll(&mut self.decoder, |e| events.push(e));
            self.read_at = Instant::now();
            for event in events.drain(..) {
                self.on_event(event)?;
                if self.options.max_samples.is_some_and(|n| self.samples >= n) {
                    break;
                }
            }
            if let ReadOutcome::Vanished { .. } = outcome {
                if let Some(reason) = self.reconnect(stop, on_status)? {
                    break reason;
                }
            }
        };
        self.flush()?;
        self.event(LogEvent::Stopped {
            reason: reason.to_string(),
        })?;
        self.flush()?;
        Ok(reason)
    }

    /// Waits for the vanished device to come back; `Some(reason)` if the recording stops instead.
    fn reconnect(
        &mut self,
        stop: &AtomicBool,
        on_status: &mut dyn FnMut(&RecordStatus),
    ) -> Result<Option<StopReason>, RecordError> {
        let port = self.options.port.clone();
        // Close the dead port now: while a file descriptor of an unplugged CDC ACM device stays
        // open, the kernel gives the replugged device another name (ttyACM1, not ttyACM0).
        self.reader = PortReader::new(Box::new(io::empty()));
        self.vanished += 1;
        self.connected = false;
        self.event(LogEvent::DeviceVanished { port: port.clone() })?;
        self.flush()?;
        self.gone_at = Some(Instant::now());
        let gone_at = Instant::now();
        // A pseudo-terminal whose writer ended (a replay, the simulator) never comes back; its
        // number may go to an unrelated program next.
        let timeout = if is_pty(&port) {
            Duration::ZERO
        } else {
            self.options.reconnect_timeout
        };
        loop {
            let now = Instant::now();
            if let Some(reason) = self.stop_due(stop, now) {
                return Ok(Some(reason));
            }
            if now.duration_since(gone_at) >= timeout {
                return Ok(Some(StopReason::DeviceGone));
            }
            if now.duration_since(self.status_at) >= self.options.status_every {
                let status = self.status(now);
                on_status(&status);
            }
            if let Ok(new_port) = (self.open)(&port) {
                self.gone_at = None;
                self.reader = PortReader::new(new_port);
                self.decoder.new_connection();
                self.connected = true;
                self.reconnects += 1;
                self.event(LogEvent::Reconnected {
                    port,
                    offline_s: gone_at.elapsed().as_secs_f64(),
                })?;
                self.flush()?;
                return Ok(None);
            }
            // Until the next attempt, in short naps so a stop is seen at once.
            let next_try = now + self.options.retry_every;
            while let Some(left) = next_try.checked_duration_since(Instant::now()) {
                if left.is_zero() || stop.load(Ordering::Relaxed) {
                    break;
                }
                std::thread::sleep(left.min(Duration::from_millis(20)));
            }
        }
    }

    fn on_event(&mut self, event: Event) -> Result<(), RecordError> {
        match event {
            Event::Frame(frame) => {
                match &frame {
                    BoardFrame::Sample(sample) => return self.on_sample(sample, &frame),
                    BoardFrame::Hello(hello) => {
                        self.scale = hello.scale;
                        self.addresses = hello.addresses;
                        self.configure_rate(hello)?;
                    }
                    BoardFrame::Status(status) => {
                        self.board_status = Some(*status);
                        self.learn_command(status)?;
                    }
                    BoardFrame::Ack { id } => {
                        if self.configure_id == Some(*id) {
                            // The board re-announces itself: the log's board metadata gets the
                            // new period and averaging.
                            self.configure_id = None;
                            self.send_host_command(Command::GetHello);
                        }
                        let ours = self.answered(*id);
                        self.commands_acked += u64::from(ours);
                    }
                    BoardFrame::Rejected {
                        id: Some(id),
                        reason,
                    } => {
                        if self.configure_id == Some(*id) {
                            return Err(RecordError::Options(format!(
                                "the board refused sampling every {} µs: {reason:?}",
                                self.options.sample_period_us.unwrap_or(0)
                            )));
                        }
                        let ours = self.answered(*id);
                        self.commands_rejected += u64::from(ours);
                    }
                    _ => {}
                }
                let t_s = self.run_s();
                self.sink.frame(t_s, &frame).map_err(RecordError::Sink)
            }
            Event::BadFrame(_) => {
                self.bad_frames_unlogged += 1;
                Ok(())
            }
            Event::SampleGap { after_seq, missing } => {
                self.event(LogEvent::SamplesLost { after_seq, missing })
            }
            Event::BoardReset { previous } => {
                let [l, r] = previous.host_energy_lsb_us;
                self.closed_energy_j.left += self.scale.energy_j(l);
                self.closed_energy_j.right += self.scale.energy_j(r);
                self.closed_segments.push(previous);
                let gap_us = self.last_sample_at.map_or(0, |at| {
                    at.elapsed().as_micros().min(u128::from(u64::MAX)) as u64
                });
                self.clock.restart(gap_us);
                // The rebooted board has no wheel rates and will not ack what the old one got.
                self.last_sent_mps = None;
                self.awaiting.clear();
                self.event(LogEvent::BoardReset)
            }
        }
    }

    /// Without a commands file: the board's reported wheel rates, when they change, become the
    /// commanded speeds from now on.
    fn learn_command(&mut self, status: &Status) -> Result<(), RecordError> {
        if !self.options.commands.is_empty() {
            return Ok(());
        }
        let Some(rates) = status.wheel_rates_rad_s else {
            return Ok(());
        };
        let r = f64::from(self.options.rover.wheel_radius_m);
        // ω is an f32 on the wire: rounding to 1 µm/s gives back the commanded decimal speed.
        let cmd_mps = rates.map(|w| (f64::from(w) * r * 1e6).round() / 1e6);
        if self.timeline.rows().last().map(|row| row.cmd_mps) == Some(cmd_mps) {
            return Ok(());
        }
        let row = CommandRow {
            t_s: self.run_s(),
            cmd_mps,
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        };
        self.timeline.push(row);
        self.sink.command(&row).map_err(RecordError::Sink)
    }

    fn answered(&mut self, id: u16) -> bool {
        match self.awaiting.iter().position(|&a| a == id) {
            Some(at) => {
                self.awaiting.remove(at);
                true
            }
            None => false,
        }
    }

    fn on_sample(&mut self, sample: &Sample, frame: &BoardFrame) -> Result<(), RecordError> {
        let t_s = RunClock::seconds(self.clock.at(sample.t_us));
        self.samples += 1;
        if self.samples == 1 {
            // Where run time meets wall time: when the first sample's bytes were read.
            let read = std::time::SystemTime::now()
                .checked_sub(self.read_at.elapsed())
                .and_then(|at| at.duration_since(std::time::UNIX_EPOCH).ok());
            if let Some(unix) = read {
                let unix_ns = u64::try_from(unix.as_nanos()).unwrap_or(u64::MAX);
                self.sink
                    .event(t_s, &LogEvent::WallClock { unix_ns })
                    .map_err(RecordError::Sink)?;
            }
        }
        self.last_sample_at = Some(self.read_at);
        self.sink.frame(t_s, frame).map_err(RecordError::Sink)?;
        self.chip_faults = sample.chips.map(|c| match c {
            wire::ChipReading::Failed(fault) => Some(fault),
            _ => None,
        });
        if self.chip_faults.left.is_some() {
            self.chip_failed_samples.left += 1;
        }
        if self.chip_faults.right.is_some() {
            self.chip_failed_samples.right += 1;
        }
        match (
            sample.chips.left.registers(),
            sample.chips.right.registers(),
        ) {
            (Some(left), Some(right)) => {
                let scale = self.scale;
                let fix = self.timeline.fix_m(t_s);
                let row = RunSample {
                    t_s,
                    bus_v: Sides::new(scale.bus_v(left.bus), scale.bus_v(right.bus)),
                    current_a: Sides::new(
                        scale.current_a(left.current),
                        scale.current_a(right.current),
                    ),
                    cmd_mps: self.timeline.cmd_mps(t_s),
                    yaw_rad: self.timeline.yaw_rad(t_s),
                    pitch_deg: self.timeline.pitch_deg(t_s),
                    x_m: fix.map(|p| p.0),
                    y_m: fix.map(|p| p.1),
                };
                self.sink.sample(&row).map_err(RecordError::Sink)?;
                self.rows += 1;
            }
            _ => self.incomplete += 1,
        }
        self.forward(t_s)
    }

    /// `--rate-hz`: configures a board whose hello announces another period or averaging.
    fn configure_rate(&mut self, hello: &wire::Hello) -> Result<(), RecordError> {
        let Some(command) = self.options.configure_command()? else {
            return Ok(());
        };
        let Command::Configure {
            adc,
            sample_period_us,
        } = command
        else {
            return Ok(());
        };
        if hello.sample_period_us == sample_period_us && hello.adc == adc {
            return Ok(());
        }
        // A device going away gets the command again at its next hello.
        if let Some(id) = self.send_host_command(command) {
            self.configure_id = Some(id);
        }
        Ok(())
    }

    /// Sends a command of the recorder's own (not a commands-file row); its id, if it went out.
    fn send_host_command(&mut self, command: Command) -> Option<u16> {
        self.next_id = self.next_id.wrapping_add(1);
        let frame = HostFrame {
            id: self.next_id,
            command,
        };
        let mut buf = [0u8; wire::MAX_FRAME];
        // Every HostFrame fits (model-core tests it).
        let n = wire::encode(&frame, &mut buf).ok()?;
        self.reader.port_mut().write_all(&buf[..n]).ok()?;
        self.decoder.expect_ack(frame);
        Some(frame.id)
    }

    /// Sends the side speeds in force at `t_s` when they differ from the last ones sent.
    fn forward(&mut self, t_s: f64) -> Result<(), RecordError> {
        if self.options.commands.is_empty() {
            return Ok(()); // the timeline holds what the board reported, not ours to send
        }
        let Some((_, row)) = self.timeline.active(t_s) else {
            return Ok(());
        };
        let row = *row;
        if self.last_sent_mps == Some(row.cmd_mps) {
            return Ok(());
        }
        self.next_id = self.next_id.wrapping_add(1);
        let frame = HostFrame {
            id: self.next_id,
            command: Command::SetWheelRates(self.options.wheel_rates(row.cmd_mps)),
        };
        let mut buf = [0u8; wire::MAX_FRAME];
        let Ok(n) = wire::encode(&frame, &mut buf) else {
            return Ok(()); // every HostFrame fits (model-core tests it)
        };
        // No flush: on a tty it waits for the far end to drain, which a dead device never does.
        if self.reader.port_mut().write_all(&buf[..n]).is_err() {
            // The device is going away; the speeds are sent again once it is back.
            return Ok(());
        }
        self.decoder.expect_ack(frame);
        self.awaiting.push(frame.id);
        if self.awaiting.len() > 64 {
            self.awaiting.remove(0);
        }
        self.last_sent_mps = Some(row.cmd_mps);
        self.commands_sent += 1;
        self.sink.command(&row).map_err(RecordError::Sink)
    }

    fn energy_j(&self) -> Sides<f64> {
        let [l, r] = self.decoder.current_segment().host_energy_lsb_us;
        Sides::new(
            self.closed_energy_j.left + self.scale.energy_j(l),
            self.closed_energy_j.right + self.scale.energy_j(r),
        )
    }

    fn status(&mut self, now: Instant) -> RecordStatus {
        let interval_s = now.duration_since(self.status_at).as_secs_f64();
        let rate_hz = if interval_s > 0.0 {
            (self.samples - self.status_samples) as f64 / interval_s
        } else {
            0.0
        };
        self.status_at = now;
        self.status_samples = self.samples;
        let power = self.decoder.measurements().snapshot().power_lsb;
        RecordStatus {
            elapsed: now.duration_since(self.start),
            run_s: self.run_s(),
            connected: self.connected,
            reconnect_left: self.gone_at.map(|at| {
                self.options
                    .reconnect_timeout
                    .saturating_sub(now.duration_since(at))
            }),
            samples: self.samples,
            rate_hz,
            stream: self.decoder.stats(),
            board_queue_drops: self.board_status.map_or(0, |s| s.queue_drops),
            power_w: power.map(|p| p.map(|p| self.scale.power_w(p))),
            energy_j: self.energy_j(),
            addresses: self.addresses,
            chip_faults: self.chip_faults,
            chip_failed_samples: self.chip_failed_samples,
            commands_sent: self.commands_sent,
            commands_acked: self.commands_acked,
        }
    }

    fn summary(&self, stop: StopReason) -> RecordSummary {
        let mut segments = self.closed_segments.clone();
        if self.decoder.stats().samples > 0 || segments.is_empty() {
            segments.push(self.decoder.current_segment());
        }
        RecordSummary {
            stop,
            samples: self.samples,
            rows: self.rows,
            incomplete_samples: self.incomplete,
            stream: self.decoder.stats(),
            vanished: self.vanished,
            reconnects: self.reconnects,
            commands_sent: self.commands_sent,
            commands_acked: self.commands_acked,
            commands_rejected: self.commands_rejected,
            segments,
            run_s: self.run_s(),
            scale: self.scale,
        }
    }
}

/// Whether `port` is a pseudo-terminal's slave (`/dev/pts/N`): a hang-up there is final.
fn is_pty(port: &str) -> bool {
    port.starts_with("/dev/pts/")
}

#[cfg(test)]
mod tests;
