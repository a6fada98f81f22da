//! The recorder's state machine ([`Recorder`]): reads the port, decodes, turns frames into the
//! run log's samples and events, forwards commands, waits out unplugs and reports its status.

use super::rate::BoardRate;
use super::{
    BoardPort, CommandTimeline, PortOpener, RecordError, RecordOptions, RecordStatus,
    RecordSummary, RunClock, StopReason,
};
use crate::decode::{Event, Segment, StreamDecoder};
use crate::log::commands::CommandRow;
use crate::log::run_csv::RunSample;
use crate::log::run_log::{LogEvent, RunLogSink};
use crate::serial::{PortReader, ReadOutcome};
use model_core::ina226::Scale;
use model_core::wire::{self, BoardFrame, ChipFault, Command, HostFrame, Sample, Status};
use model_core::Sides;
use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The recording's state between reads.
pub(super) struct Recorder<'a, 'o> {
    options: &'a RecordOptions,
    open: &'a mut PortOpener<'o>,
    pub(super) sink: &'a mut dyn RunLogSink,
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
    /// Without forwarding ([`RecordOptions::forward_commands`] off): the commands rows already
    /// looked at, and the speeds of the last one logged.
    copied_rows: usize,
    last_copied_mps: Option<Sides<f64>>,
    next_id: u16,
    awaiting: Vec<u16>,
    commands_sent: u64,
    /// The id of the `Configure` sent for `--rate-hz`, until the board answers it.
    configure_id: Option<u16>,
    commands_acked: u64,
    commands_rejected: u64,
    status_at: Instant,
    /// The board's sample rate since the last status.
    rate: BoardRate,
    /// While the device is away: until when it is waited for.
    reconnect_until: Option<Instant>,
}

impl<'a, 'o> Recorder<'a, 'o> {
    pub(super) fn new(
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
            copied_rows: 0,
            last_copied_mps: None,
            next_id: 0,
            awaiting: Vec::new(),
            commands_sent: 0,
            configure_id: None,
            commands_acked: 0,
            commands_rejected: 0,
            status_at: now,
            rate: BoardRate::new(),
            reconnect_until: None,
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

    pub(super) fn run(
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
        let gone_at = Instant::now();
        // A pseudo-terminal whose writer ended (a replay, the simulator) never comes back; its
        // number may go to an unrelated program next.
        let (timeout, gone) = if is_pty(&port) {
            (Duration::ZERO, StopReason::StreamEnded)
        } else {
            (self.options.reconnect_timeout, StopReason::DeviceGone)
        };
        self.reconnect_until = Some(gone_at + timeout);
        loop {
            let now = Instant::now();
            if let Some(reason) = self.stop_due(stop, now) {
                return Ok(Some(reason));
            }
            if now.duration_since(gone_at) >= timeout {
                return Ok(Some(gone));
            }
            if now.duration_since(self.status_at) >= self.options.status_every {
                let status = self.status(now);
                on_status(&status);
            }
            if let Ok(new_port) = (self.open)(&port) {
                self.reconnect_until = None;
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
                self.rate.restart();
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
        self.rate.sample(sample.seq, sample.t_us);
        self.samples += 1;
        if self.samples == 1 {
            // Where run time meets wall time: when the first sample's bytes were read (or
            // later, where the caller lays the run).
            let read = std::time::SystemTime::now()
                .checked_sub(self.read_at.elapsed())
                .and_then(|at| at.duration_since(std::time::UNIX_EPOCH).ok())
                .map(|unix| u64::try_from(unix.as_nanos()).unwrap_or(u64::MAX));
            if let Some(unix_ns) = read.max(self.options.first_sample_not_before_unix_ns) {
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
        if !self.options.forward_commands {
            return self.copy_commands(t_s);
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

    /// Commands not forwarded (their speeds are in force on the board already, e.g. a replay's,
    /// whose stream reports them): each row up to `t_s` whose speeds differ from the previous
    /// row's goes into the log as it is, as a forwarded one would have; nothing goes to the board.
    fn copy_commands(&mut self, t_s: f64) -> Result<(), RecordError> {
        let Some((active, _)) = self.timeline.active(t_s) else {
            return Ok(());
        };
        while self.copied_rows <= active {
            let Some(&row) = self.timeline.rows().get(self.copied_rows) else {
                break;
            };
            self.copied_rows += 1;
            if self.last_copied_mps != Some(row.cmd_mps) {
                self.last_copied_mps = Some(row.cmd_mps);
                self.sink.command(&row).map_err(RecordError::Sink)?;
            }
        }
        Ok(())
    }

    fn energy_j(&self) -> Sides<f64> {
        let [l, r] = self.decoder.current_segment().host_energy_lsb_us;
        Sides::new(
            self.closed_energy_j.left + self.scale.energy_j(l),
            self.closed_energy_j.right + self.scale.energy_j(r),
        )
    }

    pub(super) fn status(&mut self, now: Instant) -> RecordStatus {
        self.status_at = now;
        let power = self.decoder.measurements().snapshot().power_lsb;
        RecordStatus {
            elapsed: now.duration_since(self.start),
            run_s: self.run_s(),
            connected: self.connected,
            reconnect_left: self
                .reconnect_until
                .map(|until| until.saturating_duration_since(now)),
            samples: self.samples,
            rate_hz: self.rate.take_hz(),
            stream: self.decoder.stats(),
            board_queue_drops: self.board_status.map_or(0, |s| s.queue_drops),
            power_w: power.map(|p| p.map(|p| self.scale.power_w(p))),
            energy_j: self.energy_j(),
            addresses: self.addresses,
            chip_faults: self.chip_faults,
            chip_failed_samples: self.chip_failed_samples,
            commands_sent: self.commands_sent,
            commands_acked: self.commands_acked,
            stopped: None,
        }
    }

    pub(super) fn summary(&self, stop: StopReason) -> RecordSummary {
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
