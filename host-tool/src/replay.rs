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

use crate::log::commands::CommandRow;
use crate::log::run_log::RunLog;
use crate::serial::{PtyTask, PtyWriter};
use crate::sim::board::USB_PACKET;
use firmware::sampler::DEFAULT_SAMPLE_PERIOD_US;
use model_core::wire::{self, BoardFrame, Status, MAX_FRAME};
use model_core::Rover;
use std::io::{self, Write};
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
    let acked = frames.iter().any(|(_, f)| {
        matches!(
            f,
            BoardFrame::Ack { .. } | BoardFrame::Rejected { id: Some(_), .. }
        )
    });
    let mut pending = commands.iter().peekable();
    let mut out = Vec::with_capacity(frames.len() + commands.len());
    let mut hello = synthetic_hello(DEFAULT_SAMPLE_PERIOD_US);
    let mut latest: Option<Status> = None;
    let (mut uptime_us, mut next_seq) = (0u64, 0u32);
    for &(t_s, frame) in frames {
        let report = |c: &CommandRow, latest: &Option<Status>| {
            let status = command_report(
                latest.as_ref(),
                &hello,
                uptime_us,
                next_seq,
                wheel_rates(c.cmd_mps, rover),
            );
            (t_s, BoardFrame::Status(status))
        };
        if !acked {
            while let Some(c) = pending.next_if(|c| c.t_s <= t_s) {
                out.push(report(c, &latest));
            }
        }
        let answer = match frame {
            BoardFrame::Ack { .. } if acked => pending.next().map(|c| report(c, &latest)),
            BoardFrame::Rejected { id: Some(_), .. } if acked => {
                pending.next();
                None
            }
            _ => None,
        };
        match frame {
            BoardFrame::Hello(h) => hello = h,
            BoardFrame::Status(st) => latest = Some(st),
            BoardFrame::Sample(sample) => {
                uptime_us = sample.t_us;
                next_seq = sample.seq.wrapping_add(1);
            }
            _ => {}
        }
        out.push((t_s, frame));
        out.extend(answer);
    }
    out
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
            let Some((t0_s, first)) = frames.first() else {
                pty.hang_up()?;
                return Ok(stats);
            };
            send(&mut pty, first, &mut stats)?;
            if !pty.wait_until_read(wait_for_reader)? {
                return Err(io::Error::new(
                    io::ErrorKind::TimedOut,
                    format!("nobody read {} in time", pty.path()),
                ));
            }
            let start = Instant::now();
            for (t_s, frame) in &frames[1..] {
                if stop_flag.load(Ordering::Relaxed) {
                    break;
                }
                if let ReplayPacing::RealTime { speed } = pacing {
                    let after_s = ((t_s - t0_s) / speed).max(0.0);
                    let after = Duration::try_from_secs_f64(after_s).unwrap_or(Duration::MAX);
                    let wait = start.checked_add(after).map_or(Duration::MAX, |due| {
                        due.saturating_duration_since(Instant::now())
                    });
                    sleep_unless_stopped(wait, stop_flag);
                }
                send(&mut pty, frame, &mut stats)?;
            }
            pty.hang_up()?;
            Ok(stats)
        })
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
