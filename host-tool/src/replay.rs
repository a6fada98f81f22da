//! Replaying a run log as the board's byte stream: into a pseudo-terminal that other tools open
//! like `/dev/ttyACM0` (`replay --to-pty`), or into a file (`replay --to`, for `decode`).
//!
//! A log with wire frames (MCAP) replays them byte for byte. A log of physical samples only (a
//! run CSV) replays a synthesised stream ([`crate::log::synthesis`]: a hello, sample frames with
//! the registers the board's INA226s would have read, model frames as the firmware computes
//! them).
//!
//! Commanded speeds travel with the stream: a recording's forwarded commands (the MCAP
//! `/command` topic, or a run CSV's `cmd_*` columns) were host → board bytes, which a replay
//! cannot send back to the recorder. So after each command takes effect (its ack in a
//! recording, the change of `cmd_*` in a run CSV) the replay inserts the board's own report of
//! the wheel rates it now uses, a `Status` frame ([`command_report`]); a recorder without a
//! commands file takes its commanded speeds from those reports (`crate::record`), so
//! `replay → record → validate` finds the same manoeuvres as the original log. Wheel rates are
//! side speed / wheel radius of the replay's rover (default the Husky A200, as `record`'s).
//!
//! What the board does not measure, its stream cannot carry: the tracker's yaw, pitch and
//! position fixes come from the robot, as on a real run (`record --commands`). So the replay
//! writes the robot's side of the run beside the stream ([`robot_side`], `replay
//! --commands-out`): a commands CSV with each sample's commanded speeds and pose (and a
//! recording's own command rows) on the run time a recording of the replay will have, which
//! `record --merge-commands` copies into the recording without sending anything to the board.
//! Replay → record then gives back every column of the log: the readings within the registers'
//! quantisation, the rest exactly.

use crate::log::commands::{CommandRow, CommandsCsvWriter};
use crate::log::load::{
    load_salvaging, stream_salvaging, LoadError, LoadedRun, RunFormat, StreamFound,
};
use crate::log::mcap::McapError;
use crate::log::run_csv::RigRange;
use crate::log::run_csv::RunSample;
use crate::log::run_log::{RunLog, RunLogSink};
use crate::log::synthesis::synthesised_t_us;
use crate::record::RunClock;
use crate::serial::{PtyTask, PtyWriter};
use crate::sim::board::USB_PACKET;
use crate::validate::crosscheck::acknowledges;
use firmware::sampler::DEFAULT_SAMPLE_PERIOD_US;
use model_core::wire::{self, BoardFrame, Hello, Status, MAX_FRAME};
use model_core::Rover;
use std::convert::Infallible;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

pub use crate::log::synthesis::{
    command_report, registers_of, synthesise_frames, synthetic_hello, wheel_rates,
};

/// A recording's frames with the board's report of each forwarded command's wheel rates
/// inserted where the board applied it: right after its ack (commands and acks pair up in
/// order, a rejected command has no report), or, in a log without acks, at the command's time.
pub fn with_command_reports(
    frames: &[(f64, BoardFrame)],
    commands: &[CommandRow],
    rover: &Rover,
) -> Vec<(f64, BoardFrame)> {
    let acked = frames.iter().any(|(_, f)| acknowledges(f));
    let mut reports = CommandReports::new(commands, acked, rover);
    let mut out = Vec::with_capacity(frames.len() + commands.len());
    for &(t_s, frame) in frames {
        let pushed: Result<(), Infallible> = reports.push(t_s, frame, &mut |t_s, frame| {
            out.push((t_s, frame));
            Ok(())
        });
        let Ok(()) = pushed;
    }
    out
}

/// [`with_command_reports`] frame by frame, for a recording read as a stream: the commands
/// and whether the log holds acks (any [`acknowledges`] frame) come from a first pass.
#[derive(Debug)]
pub struct CommandReports<'a> {
    rover: &'a Rover,
    acked: bool,
    pending: std::iter::Peekable<std::slice::Iter<'a, CommandRow>>,
    hello: Hello,
    latest: Option<Status>,
    uptime_us: u64,
    next_seq: u32,
}

impl<'a> CommandReports<'a> {
    /// Reports of `commands` on `rover`'s wheels; `acked`: the log holds acks.
    pub fn new(commands: &'a [CommandRow], acked: bool, rover: &'a Rover) -> Self {
        Self {
            rover,
            acked,
            pending: commands.iter().peekable(),
            hello: synthetic_hello(DEFAULT_SAMPLE_PERIOD_US),
            latest: None,
            uptime_us: 0,
            next_seq: 0,
        }
    }

    /// The recording's next frame: hands `out` the reports due before it, the frame, and the
    /// report its ack answers.
    pub fn push<E>(
        &mut self,
        t_s: f64,
        frame: BoardFrame,
        out: &mut impl FnMut(f64, BoardFrame) -> Result<(), E>,
    ) -> Result<(), E> {
        let report = |c: &CommandRow, this: &Self| {
            let status = command_report(
                this.latest.as_ref(),
                &this.hello,
                this.uptime_us,
                this.next_seq,
                wheel_rates(c.cmd_mps, this.rover),
            );
            BoardFrame::Status(status)
        };
        if !self.acked {
            while let Some(c) = self.pending.next_if(|c| c.t_s <= t_s) {
                out(t_s, report(c, self))?;
            }
        }
        let answer = match frame {
            BoardFrame::Ack { .. } if self.acked => self.pending.next().map(|c| report(c, self)),
            BoardFrame::Rejected { id: Some(_), .. } if self.acked => {
                self.pending.next();
                None
            }
            _ => None,
        };
        match frame {
            BoardFrame::Hello(h) => self.hello = h,
            BoardFrame::Status(st) => self.latest = Some(st),
            BoardFrame::Sample(sample) => {
                self.uptime_us = sample.t_us;
                self.next_seq = sample.seq.wrapping_add(1);
            }
            _ => {}
        }
        out(t_s, frame)?;
        match answer {
            Some(answer) => out(t_s, answer),
            None => Ok(()),
        }
    }
}

/// One frame in the wire format, delimiter included.
pub fn encode_frame(frame: &BoardFrame) -> Result<Vec<u8>, wire::EncodeError> {
    let mut buf = [0u8; MAX_FRAME];
    let n = wire::encode(frame, &mut buf)?;
    Ok(buf[..n].to_vec())
}

/// The timed byte stream of a run: its logged frames re-encoded (byte for byte what the board
/// sent: the encoding is deterministic) with the board's reports of the forwarded commands
/// ([`with_command_reports`]), or, for a log without frames, the frames synthesised from its
/// samples with their commanded speeds ([`synthesise_frames`]). Wheel rates are on `rover`'s
/// wheels. Times are run times [s].
pub fn frames_of(run: &RunLog, rover: &Rover) -> Result<Vec<(f64, Vec<u8>)>, wire::EncodeError> {
    let frames = if run.frames.is_empty() {
        synthesise_frames(&run.samples, Some(rover))
    } else {
        with_command_reports(&run.frames, &run.commands, rover)
    };
    frames
        .iter()
        .map(|(t_s, frame)| Ok((*t_s, encode_frame(frame)?)))
        .collect()
}

/// The robot's side of `run`, which the board's stream does not carry (see the module docs):
/// one commands row per sample with its commanded speeds, yaw, pitch and position fix, and the
/// log's own command rows (a recording's forwarded commands, with the tracker's pose at their
/// time) where they fall between samples, on the run time a recording of [`frames_of`]'s
/// stream will have. Fed to a recorder as commands that are not forwarded
/// ([`crate::record::RecordOptions::forward_commands`] off), each sample gets its own row's
/// values back (a row at a sample's time is not interpolated) and the log its command rows.
pub fn robot_side(run: &RunLog) -> Vec<CommandRow> {
    let mut rows = RobotSide::new(&run.commands, run.frames.is_empty());
    let mut out = Vec::with_capacity(run.samples.len() + run.commands.len());
    let mut push = |row: CommandRow| -> Result<(), Infallible> {
        out.push(row);
        Ok(())
    };
    for sample in &run.samples {
        let Ok(()) = rows.sample(sample, &mut push);
    }
    let Ok(()) = rows.finish(&mut push);
    out
}

/// [`robot_side`] sample by sample, for a log read as a stream.
#[derive(Debug)]
struct RobotSide {
    /// The log's command rows by time, one per time, and the next one due.
    commands: Vec<CommandRow>,
    next: usize,
    /// Frames synthesised from the samples: their board time counts from the first sample
    /// ([`synthesised_t_us`]), and a recorder's run time from that ([`RunClock`]).
    synthesised: Option<(Option<f64>, RunClock)>,
    last_t_s: Option<f64>,
}

impl RobotSide {
    fn new(commands: &[CommandRow], synthesised: bool) -> Self {
        let mut commands = commands.to_vec();
        commands.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
        // At equal times the later row is the one that was in force.
        commands.reverse();
        commands.dedup_by(|later, earlier| later.t_s == earlier.t_s);
        commands.reverse();
        Self {
            commands,
            next: 0,
            synthesised: synthesised.then(|| (None, RunClock::new())),
            last_t_s: None,
        }
    }

    /// Where `t_s` of the log falls on the recording's time base: the same in a replay of a
    /// recording's frames; counted from the first sample when the frames are synthesised.
    fn recorded_t_s(&mut self, t_s: f64) -> f64 {
        match &mut self.synthesised {
            None => t_s,
            Some((first, clock)) => {
                let first = *first.get_or_insert(t_s);
                RunClock::seconds(clock.at(synthesised_t_us(first, t_s)))
            }
        }
    }

    /// Hands `out` the command rows before `sample`, then the sample's own row.
    fn sample<E>(
        &mut self,
        sample: &RunSample,
        out: &mut (impl FnMut(CommandRow) -> Result<(), E> + ?Sized),
    ) -> Result<(), E> {
        let t_s = self.recorded_t_s(sample.t_s);
        // Command rows on the log's time base, moved as the samples are.
        let shift = sample.t_s - t_s;
        while let Some(&c) = self.commands.get(self.next) {
            let at = c.t_s - shift;
            if at > t_s {
                break;
            }
            self.next += 1;
            // A command row at the sample's time: the sample's row stands for it.
            if at < t_s && self.last_t_s.is_none_or(|last| at > last) {
                out(CommandRow { t_s: at, ..c })?;
                self.last_t_s = Some(at);
            }
        }
        if self.last_t_s.is_some_and(|last| t_s <= last) {
            return Ok(());
        }
        self.last_t_s = Some(t_s);
        out(CommandRow {
            t_s,
            cmd_mps: sample.cmd_mps,
            yaw_rad: sample.yaw_rad,
            pitch_deg: sample.pitch_deg,
            x_m: sample.x_m,
            y_m: sample.y_m,
        })
    }

    /// Hands `out` the command rows after the last sample (of a recording: synthesised frames
    /// place rows by the samples' times, and there is none after the last).
    fn finish<E>(
        &mut self,
        out: &mut (impl FnMut(CommandRow) -> Result<(), E> + ?Sized),
    ) -> Result<(), E> {
        if self.synthesised.is_some() {
            return Ok(());
        }
        while let Some(&c) = self.commands.get(self.next) {
            self.next += 1;
            if self.last_t_s.is_none_or(|last| c.t_s > last) {
                out(c)?;
                self.last_t_s = Some(c.t_s);
            }
        }
        Ok(())
    }
}

/// Writes the frames back to back into `out` (a capture file for `decode`); returns the bytes
/// written.
pub fn write_stream<W: Write + ?Sized>(frames: &[(f64, Vec<u8>)], out: &mut W) -> io::Result<u64> {
    let mut bytes = 0u64;
    for (_, frame) in frames {
        out.write_all(frame)?;
        bytes += frame.len() as u64;
    }
    Ok(bytes)
}

/// How a replay is paced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ReplayPacing {
    /// Each frame at its logged time after the first, divided by `speed` (1 = real time, 2 =
    /// twice as fast). `speed` must be finite and > 0.
    RealTime {
        /// Playback speed factor.
        speed: f64,
    },
    /// As fast as the reader takes the bytes.
    AsFastAsPossible,
}

/// What a finished replay wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReplayStats {
    /// Frames written.
    pub frames: u64,
    /// Bytes written.
    pub bytes: u64,
}

/// A log replayed into a pseudo-terminal from its own thread, as the board would send it.
///
/// The first frame is written at once and the replay clock starts only when a reader has taken
/// it (someone opened [`ReplayPty::path`] and reads), so starting the other tool late loses
/// nothing. Frames go out in USB-sized packets ([`USB_PACKET`]). After the last frame the writer
/// waits for the reader to read everything, then hangs up (the device vanishes), as
/// [`crate::sim::board::PtyBoard`] does — both write through [`PtyWriter`].
///
/// [`PtyTask::stop`] ends it after the current frame; the reader gets what was written.
pub type ReplayPty = PtyTask<ReplayStats>;

impl PtyTask<ReplayStats> {
    /// Starts replaying `frames` (from [`frames_of`]) into a new pty. `wait_for_reader` bounds
    /// the wait for someone to read the first frame (`None`: as long as it takes); past it the
    /// replay ends with a `TimedOut` error.
    pub fn spawn(
        frames: Vec<(f64, Vec<u8>)>,
        pacing: ReplayPacing,
        wait_for_reader: Option<Duration>,
    ) -> io::Result<ReplayPty> {
        Self::spawn_streaming(
            move |emit| frames.iter().try_for_each(|(t_s, frame)| emit(*t_s, frame)),
            pacing,
            wait_for_reader,
        )
    }

    /// [`Self::spawn`] for frames produced while they are replayed: `produce` hands each
    /// timed frame, in order, to the callback it gets (which paces and writes it, and returns
    /// an error once the replay is stopped), e.g. [`ReplaySource::emit`].
    pub fn spawn_streaming(
        produce: impl FnOnce(&mut dyn FnMut(f64, &[u8]) -> io::Result<()>) -> io::Result<()>
            + Send
            + 'static,
        pacing: ReplayPacing,
        wait_for_reader: Option<Duration>,
    ) -> io::Result<ReplayPty> {
        if let ReplayPacing::RealTime { speed } = pacing {
            if !(speed.is_finite() && speed > 0.0) {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!("replay speed {speed} must be a finite number > 0"),
                ));
            }
        }
        PtyTask::run("replay", move |mut pty, stop_flag| {
            let mut stats = ReplayStats {
                frames: 0,
                bytes: 0,
            };
            // The first frame's time and when a reader took it.
            let mut started: Option<(f64, Instant)> = None;
            let mut stopped = false;
            let produced = produce(&mut |t_s, frame| {
                let Some((t0_s, start)) = started else {
                    // As the board starts every connection: a lone delimiter first.
                    pty.write_all(&[0])?;
                    stats.bytes += 1;
                    send(&mut pty, frame, &mut stats)?;
                    if !pty.wait_until_read(wait_for_reader)? {
                        return Err(io::Error::new(
                            io::ErrorKind::TimedOut,
                            format!("nobody read {} in time", pty.path()),
                        ));
                    }
                    started = Some((t_s, Instant::now()));
                    return Ok(());
                };
                if stop_flag.load(Ordering::Relaxed) {
                    stopped = true;
                    return Err(io::ErrorKind::Interrupted.into());
                }
                if let ReplayPacing::RealTime { speed } = pacing {
                    let after_s = ((t_s - t0_s) / speed).max(0.0);
                    let after = Duration::try_from_secs_f64(after_s).unwrap_or(Duration::MAX);
                    let wait = start.checked_add(after).map_or(Duration::MAX, |due| {
                        due.saturating_duration_since(Instant::now())
                    });
                    sleep_unless_stopped(wait, stop_flag);
                }
                send(&mut pty, frame, &mut stats)
            });
            match produced {
                Err(_) if stopped => {}
                other => other?,
            }
            pty.hang_up()?;
            Ok(stats)
        })
    }
}

/// A run log opened for a replay whose frames are produced while the file is read again, so
/// memory holds a few chunks of an MCAP recording, not the run (a run CSV's frames are synthesised
/// from its samples, which are read whole). The same frames, in the same order, as
/// [`frames_of`] gives for the loaded run.
#[derive(Debug)]
pub struct ReplaySource {
    path: PathBuf,
    salvage: bool,
    rover: Rover,
    content: Content,
    /// The robot's side of a log whose frames are synthesised ([`robot_side`]); a recording's
    /// is read again when asked for.
    robot_side: Vec<CommandRow>,
}

#[derive(Debug)]
enum Content {
    /// A recording with frames, read again at replay: its forwarded commands and whether it
    /// holds acks, from the first pass.
    Recording {
        commands: Vec<CommandRow>,
        acked: bool,
    },
    /// Frames synthesised from a log of samples only.
    Synthesised(Vec<(f64, BoardFrame)>),
}

impl ReplaySource {
    /// Opens the run log at `path` (as [`load_salvaging`] reads it, with `salvage`; a run CSV's
    /// readings within the board's range, [`RigRange::BoardStream`], as they become its
    /// registers): one pass over the file learns what the replay needs, and what reading it
    /// found (truncation, losses, dropped rows: for the user, before the replay starts).
    pub fn open(
        path: &Path,
        salvage: bool,
        rover: &Rover,
    ) -> Result<(ReplaySource, StreamFound), LoadError> {
        let mut robot = Vec::new();
        let mut synthesised = |loaded: LoadedRun| {
            let (run, found) = loaded.split();
            let frames = synthesise_frames(&run.samples, Some(rover));
            robot = robot_side(&RunLog {
                frames: Vec::new(),
                ..run
            });
            (Content::Synthesised(frames), found)
        };
        let (content, found) = match RunFormat::of(path)? {
            RunFormat::Csv => synthesised(load_salvaging(path, salvage, RigRange::BoardStream)?),
            RunFormat::Mcap => {
                let mut scan = Scan::default();
                let found = stream_salvaging(path, salvage, RigRange::BoardStream, &mut scan)?;
                if scan.frames {
                    let content = Content::Recording {
                        commands: scan.commands,
                        acked: scan.acked,
                    };
                    (content, found)
                } else {
                    // Samples only (no recorder writes this): synthesised as from a run CSV.
                    synthesised(load_salvaging(path, salvage, RigRange::BoardStream)?)
                }
            }
        };
        let source = ReplaySource {
            path: path.to_owned(),
            salvage,
            rover: *rover,
            content,
            robot_side: robot,
        };
        Ok((source, found))
    }

    /// Whether the log holds nothing to replay (no frames, no samples).
    pub fn is_empty(&self) -> bool {
        match &self.content {
            Content::Recording { .. } => false,
            Content::Synthesised(frames) => frames.is_empty(),
        }
    }

    /// Hands `emit` each frame of the replay in order, encoded, with its run time [s]; stops
    /// at the first error `emit` returns (or reading the file again fails).
    pub fn emit(&self, emit: &mut dyn FnMut(f64, &[u8]) -> io::Result<()>) -> io::Result<()> {
        let mut buf = [0u8; MAX_FRAME];
        let mut encoded = |t_s: f64, frame: BoardFrame| -> io::Result<()> {
            let n = wire::encode(&frame, &mut buf)
                .map_err(|e| io::Error::other(format!("encoding frames: {e}")))?;
            emit(t_s, &buf[..n])
        };
        match &self.content {
            Content::Synthesised(frames) => frames
                .iter()
                .try_for_each(|&(t_s, frame)| encoded(t_s, frame)),
            Content::Recording { commands, acked } => {
                let mut replay = Replay {
                    reports: CommandReports::new(commands, *acked, &self.rover),
                    emit: &mut encoded,
                };
                let range = RigRange::BoardStream;
                stream_salvaging(&self.path, self.salvage, range, &mut replay).map_err(
                    |e| match e {
                        // The sink's own error (the reader's, or the replay stopped) as it was.
                        LoadError::Mcap(McapError::Io { source, .. }) => source,
                        other => io::Error::other(other.to_string()),
                    },
                )?;
                Ok(())
            }
        }
    }

    /// Hands `out` the robot's side of the replayed run ([`robot_side`]) row by row; a
    /// recording is read again for it (its samples are not kept).
    pub fn robot_side(&self, out: &mut dyn FnMut(CommandRow) -> io::Result<()>) -> io::Result<()> {
        let Content::Recording { commands, .. } = &self.content else {
            return self.robot_side.iter().try_for_each(|&row| out(row));
        };
        struct Rows<'o> {
            rows: RobotSide,
            out: &'o mut dyn FnMut(CommandRow) -> io::Result<()>,
        }
        impl RunLogSink for Rows<'_> {
            fn sample(&mut self, sample: &RunSample) -> io::Result<()> {
                self.rows.sample(sample, &mut *self.out)
            }
        }
        let mut rows = Rows {
            rows: RobotSide::new(commands, false),
            out,
        };
        let range = RigRange::BoardStream;
        stream_salvaging(&self.path, self.salvage, range, &mut rows).map_err(|e| match e {
            LoadError::Mcap(McapError::Io { source, .. }) => source,
            other => io::Error::other(other.to_string()),
        })?;
        rows.rows.finish(&mut *rows.out)
    }

    /// Writes the robot's side of the replayed run ([`ReplaySource::robot_side`]) as a commands
    /// CSV into `out`; returns the rows written.
    pub fn write_robot_side<W: Write>(&self, out: W) -> io::Result<u64> {
        let mut writer = CommandsCsvWriter::new(out).map_err(io::Error::other)?;
        let mut rows = 0u64;
        self.robot_side(&mut |row| {
            rows += 1;
            writer.write(&row).map_err(io::Error::other)
        })?;
        writer.into_inner().map_err(io::Error::other)?;
        Ok(rows)
    }

    /// Writes the replay's frames back to back into `out` (a capture file for `decode`);
    /// returns the frames and bytes written.
    pub fn write_stream<W: Write + ?Sized>(&self, out: &mut W) -> io::Result<ReplayStats> {
        let mut stats = ReplayStats {
            frames: 0,
            bytes: 0,
        };
        self.emit(&mut |_, frame| {
            out.write_all(frame)?;
            stats.frames += 1;
            stats.bytes += frame.len() as u64;
            Ok(())
        })?;
        Ok(stats)
    }
}

/// The first pass of [`ReplaySource::open`] over a recording.
#[derive(Debug, Default)]
struct Scan {
    frames: bool,
    acked: bool,
    commands: Vec<CommandRow>,
}

impl RunLogSink for Scan {
    fn frame(&mut self, _t_s: f64, frame: &BoardFrame) -> io::Result<()> {
        self.frames = true;
        self.acked |= acknowledges(frame);
        Ok(())
    }

    fn command(&mut self, row: &CommandRow) -> io::Result<()> {
        self.commands.push(*row);
        Ok(())
    }
}

/// The second pass: the recording's frames with the command reports, out as they come.
struct Replay<'a, 'e> {
    reports: CommandReports<'a>,
    emit: &'e mut dyn FnMut(f64, BoardFrame) -> io::Result<()>,
}

impl RunLogSink for Replay<'_, '_> {
    fn frame(&mut self, t_s: f64, frame: &BoardFrame) -> io::Result<()> {
        let emit = &mut *self.emit;
        self.reports
            .push(t_s, *frame, &mut |t_s, frame| emit(t_s, frame))
    }
}

/// Writes one frame in USB-sized packets.
fn send(pty: &mut PtyWriter, frame: &[u8], stats: &mut ReplayStats) -> io::Result<()> {
    for packet in frame.chunks(USB_PACKET) {
        pty.write_all(packet)?;
    }
    stats.frames += 1;
    stats.bytes += frame.len() as u64;
    Ok(())
}

/// Sleeps `wait`, waking early if `stop` is set.
fn sleep_unless_stopped(wait: Duration, stop: &AtomicBool) {
    let start = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        let Some(left) = wait.checked_sub(start.elapsed()).filter(|d| !d.is_zero()) else {
            return;
        };
        std::thread::sleep(left.min(Duration::from_millis(100)));
    }
}

#[cfg(test)]
mod tests;
