//! Replaying a run log as the board's byte stream: into a pseudo-terminal that other tools open
//! like `/dev/ttyACM0` (`replay --to-pty`), or into a file (`replay --to`, for `decode`).
//!
//! A log with wire frames (MCAP) replays them byte for byte. A log of physical samples only (a
//! run CSV) replays a synthesised stream: a hello, one sample frame per row with the registers
//! the board's INA226s would have read ([`registers_of`], quantised at [`Scale::BOARD`]), and
//! model frames every [`MODEL_PERIOD_US`] computed by model-core's own running measurements, as
//! the firmware does. The synthesised hello reports firmware 0.0.0 so a reader can tell it from
//! a real board.
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
use crate::log::run_csv::RunSample;
use crate::log::run_log::RunLog;
use crate::serial::{PtyTask, PtyWriter};
use crate::sim::board::USB_PACKET;
use firmware::board::MODEL_PERIOD_US;
use firmware::sampler::{BOARD_ADDRESSES, DEFAULT_SAMPLE_PERIOD_US};
use model_core::energy::RunningMeasurements;
use model_core::ina226::{
    AdcConfig, BusVoltageRaw, CurrentRaw, PowerRaw, Registers, Scale, ShuntVoltageRaw, BUS_LSB_UV,
    SHUNT_LSB_NV,
};
use model_core::wire::{
    self, BoardFrame, ChipReading, FirmwareVersion, Hello, Model, Sample, Status, MAX_FRAME,
    MAX_SAMPLE_PERIOD_US, MIN_SAMPLE_PERIOD_US, PROTOCOL_VERSION,
};
use model_core::{Rover, Sides};
use std::io::{self, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Registers an INA226 on our board ([`Scale::BOARD`]: 5 mΩ shunt, 0.5 mA current LSB) reads
/// for a steady `bus_v` [V] and `current_a` [A]: shunt and current rounded to the nearest LSB
/// (so |error| ≤ 1.25 µV / 0.25 mA), clamped to i16 (±16.38 A, the shunt's 81.92 mV full
/// scale); bus rounded to the nearest 1.25 mV, clamped to 0..=40.96 V; power = |current| × bus
/// / 20000 truncated, as the chip computes it (datasheet Eq 4; ≤ 12.5 mW below |I|·V).
pub fn registers_of(bus_v: f64, current_a: f64) -> Registers {
    let scale = Scale::BOARD;
    // `as` saturates (and maps NaN to 0): the clamp to the register's range.
    let shunt_v = current_a * f64::from(scale.shunt_micro_ohm) * 1e-6;
    let shunt = (shunt_v / (f64::from(SHUNT_LSB_NV) * 1e-9)).round() as i16;
    let current = (current_a / (f64::from(scale.current_lsb_na) * 1e-9)).round() as i16;
    let bus = ((bus_v / (f64::from(BUS_LSB_UV) * 1e-6)).round() as i32).clamp(0, 0x7FFF) as u16;
    let power = (u32::from(current.unsigned_abs()) * u32::from(bus) / 20_000) as u16;
    Registers {
        shunt: ShuntVoltageRaw(shunt),
        bus: BusVoltageRaw(bus),
        current: CurrentRaw(current),
        power: PowerRaw(power),
    }
}

/// The hello of a synthesised stream: our board's scale, LSBs, chip addresses and default ADC
/// configuration, firmware 0.0.0 (no board sent it), the given sampling period.
pub fn synthetic_hello(sample_period_us: u32) -> Hello {
    let scale = Scale::BOARD;
    Hello {
        protocol: PROTOCOL_VERSION,
        firmware: FirmwareVersion {
            major: 0,
            minor: 0,
            patch: 0,
        },
        scale,
        power_lsb_uw: scale.power_lsb_uw(),
        shunt_lsb_nv: SHUNT_LSB_NV,
        bus_lsb_uv: BUS_LSB_UV,
        addresses: BOARD_ADDRESSES,
        adc: AdcConfig::BOARD_DEFAULT,
        sample_period_us,
        identity: model_core::board_id::BoardIdentity::UNKNOWN,
        chips: model_core::Sides::new(
            model_core::wire::ChipProbe::NotRead,
            model_core::wire::ChipProbe::NotRead,
        ),
    }
}

/// The frames the board would have sent for `samples`, at their run times: a hello, then per
/// sample a sample frame (board time `t_us` = µs since the first sample, `seq` = row index,
/// both chips fresh with [`registers_of`]) and, every [`MODEL_PERIOD_US`], the model frame
/// (energy integrated by model-core from those registers; τ undefined, as no wheel rates were
/// commanded to this board). The hello's period is the median sample interval (clamped to
/// the range a host may configure; 5 ms for fewer than two samples).
///
/// With `commands_for` a rover, the samples' commanded speeds are commanded to the board as
/// well: at the first sample and wherever `cmd_*` changes, the board's status report of the new
/// wheel rates (v / wheel radius, [`command_report`]) precedes the sample, and the model frames'
/// τ ∝ P/ω uses them.
pub fn synthesise_frames(
    samples: &[RunSample],
    commands_for: Option<&Rover>,
) -> Vec<(f64, BoardFrame)> {
    let Some(first) = samples.first() else {
        return Vec::new();
    };
    let t_us = |s: &RunSample| ((s.t_s - first.t_s) * 1e6).round() as u64;
    let mut intervals: Vec<u64> = samples
        .windows(2)
        .map(|w| t_us(&w[1]).saturating_sub(t_us(&w[0])))
        .collect();
    intervals.sort_unstable();
    let period_us =
        intervals
            .get(intervals.len() / 2)
            .map_or(DEFAULT_SAMPLE_PERIOD_US, |&median| {
                u32::try_from(median)
                    .unwrap_or(MAX_SAMPLE_PERIOD_US)
                    .clamp(MIN_SAMPLE_PERIOD_US, MAX_SAMPLE_PERIOD_US)
            });
    let mut frames = Vec::with_capacity(samples.len() * 11 / 10 + 1);
    let hello = synthetic_hello(period_us);
    frames.push((first.t_s, BoardFrame::Hello(hello)));
    let mut measurements = RunningMeasurements::new(Scale::BOARD);
    let mut last_model_us: Option<u64> = None;
    let mut last_cmd: Option<Sides<f64>> = None;
    for (seq, s) in samples.iter().enumerate() {
        let t = t_us(s);
        let seq = seq as u32;
        if let Some(rover) = commands_for.filter(|_| last_cmd != Some(s.cmd_mps)) {
            last_cmd = Some(s.cmd_mps);
            let rates = wheel_rates(s.cmd_mps, rover);
            measurements.set_wheel_rates(Some(rates));
            let status = command_report(None, &hello, t, seq, rates);
            frames.push((s.t_s, BoardFrame::Status(status)));
        }
        let regs = Sides::new(
            registers_of(s.bus_v.left, s.current_a.left),
            registers_of(s.bus_v.right, s.current_a.right),
        );
        measurements.update(t, regs.map(Some));
        frames.push((
            s.t_s,
            BoardFrame::Sample(Sample {
                t_us: t,
                seq,
                chips: regs.map(ChipReading::Fresh),
            }),
        ));
        // The firmware's cadence (firmware::board): a model frame after the sample once
        // MODEL_PERIOD_US has passed since the previous one.
        if last_model_us.is_none_or(|last| t.wrapping_sub(last) >= MODEL_PERIOD_US) {
            last_model_us = Some(t);
            frames.push((
                s.t_s,
                BoardFrame::Model(Model {
                    t_us: t,
                    seq,
                    snapshot: measurements.snapshot(),
                }),
            ));
        }
    }
    frames
}

/// Wheel rates for side speeds `cmd_mps` [m/s] on `rover`'s wheels [rad/s], as `record`
/// commands them.
pub fn wheel_rates(cmd_mps: Sides<f64>, rover: &Rover) -> Sides<f32> {
    cmd_mps.map(|v| (v / f64::from(rover.wheel_radius_m)) as f32)
}

/// The board's status report right after it applied `rates`: the latest logged status (or, in
/// a stream that has none yet, the hello's configuration, running, no faults) with uptime
/// `uptime_us`, `samples` taken and the new wheel rates.
pub fn command_report(
    latest: Option<&Status>,
    hello: &Hello,
    uptime_us: u64,
    samples: u32,
    rates: Sides<f32>,
) -> Status {
    let base = latest.copied().unwrap_or(Status {
        uptime_us,
        samples,
        running: true,
        i2c_errors: Sides::new(0, 0),
        reinits: Sides::new(0, 0),
        skipped_results: Sides::new(0, 0),
        last_fault: Sides::new(None, None),
        queue_drops: 0,
        rx_errors: 0,
        adc: hello.adc,
        sample_period_us: hello.sample_period_us,
        wheel_rates_rad_s: None,
    });
    Status {
        uptime_us,
        samples,
        wheel_rates_rad_s: Some(rates),
        ..base
    }
}

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
