//! The check against a port: open it, raise DTR, wait for the hello, watch the stream, send
//! `Configure` and read it back. Everything observed goes to the pure verdicts.

use super::verdicts::{self, ConfigureRun, Heard, Window};
use super::{CheckReport, Limits, Step, StepId};
use crate::decode::{Event, StreamDecoder};
use crate::serial::{self, PortInfo, SerialError};
use model_core::ina226::{AdcConfig, Averaging, ConversionTime};
use model_core::wire::{
    self, BoardFrame, ChipFault, ChipReading, Command, FrameDecoder, FrameError, Hello, HostFrame,
    Status, PROTOCOL_VERSION,
};
use model_core::Sides;
use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

/// A port the check can read, write and raise DTR on.
pub trait CheckPort: Read + Write + Send {
    /// Sets DTR; the board transmits only while the host holds it.
    fn set_dtr(&mut self, on: bool) -> io::Result<()>;
}

/// Opens a port by path.
pub type Opener<'a> = dyn FnMut(&str) -> Result<Box<dyn CheckPort>, SerialError> + 'a;

/// How long one read of the port waits.
pub const READ_TIMEOUT: Duration = Duration::from_millis(50);

/// A serial port (or a pseudo-terminal) opened with [`serial::open`].
struct SerialCheckPort {
    port: Box<dyn serialport::SerialPort>,
    /// A pty has no modem lines: DTR is not an error there (a replay does not need it).
    pty: bool,
}

impl Read for SerialCheckPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.port.read(buf)
    }
}

impl Write for SerialCheckPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.port.write(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.port.flush()
    }
}

impl CheckPort for SerialCheckPort {
    fn set_dtr(&mut self, on: bool) -> io::Result<()> {
        match self.port.write_data_terminal_ready(on) {
            Err(e) if !self.pty => Err(io::Error::other(e)),
            _ => Ok(()),
        }
    }
}

/// Opens real serial ports and ptys (DTR is raised by the check's own step).
pub fn serial_opener() -> impl FnMut(&str) -> Result<Box<dyn CheckPort>, SerialError> {
    |path| {
        let port = serial::open(path, READ_TIMEOUT)?;
        Ok(Box::new(SerialCheckPort {
            port,
            pty: serial::is_pty(path),
        }) as Box<dyn CheckPort>)
    }
}

/// Runs every step on the port `given`, or on the one board among `ports`.
pub fn run(
    given: Option<&str>,
    ports: &[PortInfo],
    open: &mut Opener<'_>,
    limits: &Limits,
) -> CheckReport {
    let (port_step, path) = verdicts::port(given, ports);
    let mut steps = vec![port_step];
    let Some(path) = path else {
        return CheckReport::new(None, steps);
    };
    let mut port = match open(&path) {
        Ok(port) => port,
        Err(e) => {
            steps.extend(verdicts::open_failed(&e));
            return CheckReport::new(Some(path), steps);
        }
    };
    steps.push(Step::pass(StepId::Open, "opened"));
    if let Err(e) = port.set_dtr(true) {
        steps.push(Step::fail(
            StepId::Dtr,
            format!("cannot assert DTR: {e}"),
            super::Hint::NoDtr,
        ));
        return CheckReport::new(Some(path), steps);
    }
    steps.push(Step::pass(StepId::Dtr, "asserted"));
    let mut conn = Conn::new(port);
    let hello = conn.await_hello(limits.hello_timeout);
    steps.push(verdicts::hello(
        hello.as_ref(),
        conn.heard,
        limits.hello_timeout,
    ));
    let Some(hello) = hello.filter(|h| h.protocol == PROTOCOL_VERSION) else {
        return CheckReport::new(Some(path), steps);
    };
    // The hello sent on connect does not read the chips; the one for `GetHello` does.
    let read_back = conn.fresh_hello(limits.answer_timeout);
    let Some(read_back) = read_back else {
        steps.push(Step::fail(
            StepId::Chips,
            "no answer to GetHello",
            super::Hint::NotABoard,
        ));
        return CheckReport::new(Some(path), steps);
    };
    steps.push(verdicts::chips(&read_back));
    steps.push(verdicts::averaging(&read_back));
    let window = conn.watch(&hello, limits.window);
    steps.extend(verdicts::window(&hello, &window, limits));
    let run = conn.configure_round_trip(&hello, limits.answer_timeout);
    steps.push(verdicts::configure(&run));
    CheckReport::new(Some(path), steps)
}

/// An open port with its decoders.
struct Conn {
    port: Box<dyn CheckPort>,
    decoder: StreamDecoder,
    /// Sees every frame, also those of another protocol version (the stream decoder skips
    /// everything before the connection's first hello).
    raw: FrameDecoder,
    heard: Heard,
    vanished: bool,
    next_id: u16,
}

impl Conn {
    fn new(port: Box<dyn CheckPort>) -> Self {
        Conn {
            port,
            decoder: StreamDecoder::for_port(),
            raw: FrameDecoder::new(),
            heard: Heard::default(),
            vanished: false,
            next_id: 0,
        }
    }

    /// Reads until `deadline` or until `on_event` returns true for an event; whether it did.
    fn pump(&mut self, deadline: Instant, mut on_event: impl FnMut(&Event) -> bool) -> bool {
        let mut buf = [0u8; serial::READ_CHUNK];
        let mut events = Vec::new();
        while !self.vanished && Instant::now() < deadline {
            let n = match self.port.read(&mut buf) {
                Ok(0) => {
                    self.vanished = true;
                    0
                }
                Ok(n) => n.min(buf.len()),
                Err(e) if serial::is_transient(&e) => 0,
                Err(_) => {
                    self.vanished = true;
                    0
                }
            };
            let bytes = &buf[..n];
            self.heard.bytes += n as u64;
            let heard = &mut self.heard;
            self.raw
                .feed::<BoardFrame>(
                    bytes,
                    |outcome: Result<BoardFrame, FrameError>| match outcome {
                        Ok(_) => heard.frames += 1,
                        Err(FrameError::Version(v)) => {
                            heard.frames += 1;
                            heard.foreign_version = Some(v);
                        }
                        Err(_) => {}
                    },
                );
            events.clear();
            self.decoder.feed(bytes, |e| events.push(e));
            let mut done = false;
            for event in &events {
                done |= on_event(event);
            }
            if done {
                return true;
            }
        }
        false
    }

    fn await_hello(&mut self, timeout: Duration) -> Option<Hello> {
        let mut hello = None;
        self.pump(Instant::now() + timeout, |e| match e {
            Event::Frame(BoardFrame::Hello(h)) => {
                hello = Some(*h);
                true
            }
            _ => false,
        });
        hello
    }

    /// Watches the stream for `duration`.
    fn watch(&mut self, hello: &Hello, duration: Duration) -> Window {
        let before = self.decoder.stats();
        let scale = hello.scale;
        let mut w = Window::default();
        let mut statuses: (Option<Status>, Option<Status>) = (None, None);
        self.pump(Instant::now() + duration, |e| {
            match e {
                Event::Frame(BoardFrame::Sample(s)) => {
                    w.samples += 1;
                    w.first.get_or_insert((s.seq, s.t_us));
                    w.last = Some((s.seq, s.t_us));
                    account(&mut w, true, s.chips.left, scale);
                    account(&mut w, false, s.chips.right, scale);
                }
                Event::Frame(BoardFrame::Status(status)) => {
                    statuses.0.get_or_insert(*status);
                    statuses.1 = Some(*status);
                }
                _ => {}
            }
            false
        });
        let after = self.decoder.stats();
        w.lost_samples = after.lost_samples - before.lost_samples;
        w.bad_frames = after.bad_frames - before.bad_frames;
        w.crc_errors = after.crc_errors - before.crc_errors;
        w.board_resets = after.board_resets - before.board_resets;
        if let (Some(a), Some(b)) = statuses {
            w.queue_drops = u64::from(b.queue_drops.wrapping_sub(a.queue_drops));
            let reinits = |a: u32, b: u32| u64::from(b.wrapping_sub(a));
            w.resets.left = w.resets.left.max(reinits(a.reinits.left, b.reinits.left));
            w.resets.right = w
                .resets
                .right
                .max(reinits(a.reinits.right, b.reinits.right));
        }
        w
    }

    /// Sends `command`; its ack, its rejection, or `None` without an answer in time.
    fn command(&mut self, command: Command, timeout: Duration) -> verdicts::Answer {
        self.command_and(command, timeout, |_| {})
    }

    /// Sends `command` and calls `on_frame` on every frame before its answer.
    fn command_and(
        &mut self,
        command: Command,
        timeout: Duration,
        mut on_frame: impl FnMut(&BoardFrame),
    ) -> verdicts::Answer {
        self.next_id = self.next_id.wrapping_add(1);
        let id = self.next_id;
        let frame = HostFrame { id, command };
        let mut buf = [0u8; wire::MAX_FRAME];
        let Ok(n) = wire::encode(&frame, &mut buf) else {
            return None;
        };
        if self.port.write_all(&buf[..n]).is_err() {
            return None;
        }
        self.decoder.expect_ack(frame);
        let mut answer = None;
        self.pump(Instant::now() + timeout, |e| match e {
            Event::Frame(BoardFrame::Ack { id: got }) if *got == id => {
                answer = Some(Ok(()));
                true
            }
            Event::Frame(BoardFrame::Rejected {
                id: Some(got),
                reason,
            }) if *got == id => {
                answer = Some(Err(*reason));
                true
            }
            Event::Frame(f) => {
                on_frame(f);
                false
            }
            _ => false,
        });
        answer
    }

    /// The hello the board sends for `GetHello` (its chips read back now).
    fn fresh_hello(&mut self, timeout: Duration) -> Option<Hello> {
        let mut hello = None;
        let answer = self.command_and(Command::GetHello, timeout, |f| {
            if let BoardFrame::Hello(h) = f {
                hello = Some(*h);
            }
        });
        answer.and_then(Result::ok).and(hello)
    }

    /// `Configure` another averaging, read it back; restore the original, read it back.
    fn configure_round_trip(&mut self, hello: &Hello, timeout: Duration) -> ConfigureRun {
        let original = hello.adc;
        let test = test_config(original, hello.sample_period_us);
        let configure = |adc| Command::Configure {
            adc,
            sample_period_us: hello.sample_period_us,
        };
        let answer = self.command(configure(test), timeout);
        let read_back = self.fresh_hello(timeout);
        let restore_answer = self.command(configure(original), timeout);
        let restored = self.fresh_hello(timeout);
        ConfigureRun {
            original,
            test,
            answer,
            read_back,
            restore_answer,
            restored,
        }
    }
}

/// The configuration the check sets for a while: another averaging the board's period can hold
/// (`Configure` refuses one whose conversions outlast the period), the most averaged first;
/// failing that, other conversion times.
fn test_config(original: AdcConfig, sample_period_us: u32) -> AdcConfig {
    let fits = |adc: &AdcConfig| *adc != original && adc.min_sample_period_us() <= sample_period_us;
    let other_averaging = Averaging::ALL.iter().rev().map(|&averaging| AdcConfig {
        averaging,
        ..original
    });
    let other_times = ConversionTime::ALL.iter().map(|&t| AdcConfig {
        bus_conversion: t,
        shunt_conversion: t,
        ..original
    });
    other_averaging
        .chain(other_times)
        .find(fits)
        .unwrap_or(original)
}

/// Adds one chip's reading to the window.
fn account(w: &mut Window, left: bool, reading: ChipReading, scale: model_core::ina226::Scale) {
    fn side<T>(sides: &mut Sides<T>, left: bool) -> &mut T {
        if left {
            &mut sides.left
        } else {
            &mut sides.right
        }
    }
    match reading {
        ChipReading::Fresh(r) | ChipReading::Stale(r) => {
            *side(&mut w.readings, left) += 1;
            *side(&mut w.bus_v_sum, left) += scale.bus_v(r.bus);
            *side(&mut w.current_a_sum, left) += scale.current_a(r.current);
        }
        ChipReading::Failed(ChipFault::ResetDetected) => *side(&mut w.resets, left) += 1,
        ChipReading::Failed(ChipFault::AwaitingConversion) => {}
        ChipReading::Failed(fault) => {
            *side(&mut w.failed, left) += 1;
            *side(&mut w.last_fault, left) = Some(fault);
        }
    }
}
