//! The simulated board: the firmware's own [`Board`] and [`Link`] on a [`SimBus`] with the two
//! INA226 models, driven by simulated time. The bytes it produces are exactly what the board
//! would send over USB; [`PtyBoard`] writes them into a pseudo-terminal that the host reads like
//! `/dev/ttyACM0`.

use super::SimBus;
use crate::serial::PtyTask;
use firmware::board::{Board, Watchdog};
use firmware::link::Link;
use firmware::sampler::SamplerConfig;
use model_core::wire::{Command, HostFrame};
use model_core::Sides;
use std::fmt;
use std::io::{self, Write};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// USB full-speed bulk packet size [bytes].
pub const USB_PACKET: usize = 64;

/// What flows through one side's motor driver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SideLoad {
    /// Current into the driver [A], positive when it draws from the battery.
    pub current_a: f64,
    /// Bus voltage at the driver [V].
    pub bus_v: f64,
}

impl SideLoad {
    /// A driver at rest on a 24 V battery.
    pub const IDLE: SideLoad = SideLoad {
        current_a: 0.0,
        bus_v: 24.0,
    };
}

/// The load on both sides as a function of simulated time [µs].
pub trait LoadSource: Send {
    /// Left and right load at `t_us`; it flows until the next call.
    fn load(&mut self, t_us: u64) -> Sides<SideLoad>;
}

impl<F: FnMut(u64) -> Sides<SideLoad> + Send> LoadSource for F {
    fn load(&mut self, t_us: u64) -> Sides<SideLoad> {
        self(t_us)
    }
}

/// The simulated board's watchdog: counts the feeds (one per completed tick).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FeedCounter(pub u64);

impl Watchdog for FeedCounter {
    fn feed(&mut self) {
        self.0 += 1;
    }
}

/// The firmware's `Board` + `Link` on a simulated bus, in simulated time.
pub struct SimBoard {
    board: Board,
    link: Link,
    watchdog: FeedCounter,
    bus: SimBus,
    addresses: Sides<u8>,
    load: Box<dyn LoadSource>,
    now_us: u64,
}

impl fmt::Debug for SimBoard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SimBoard")
            .field("board", &self.board)
            .field("link", &self.link)
            .field("bus", &self.bus)
            .field("now_us", &self.now_us)
            .finish_non_exhaustive()
    }
}

impl SimBoard {
    /// A board at t = 0 with ideal chips at `config.addresses` (0x40/0x45 for
    /// [`SamplerConfig::BOARD`]), idle load ([`SideLoad::IDLE`]), no host connected.
    pub fn new(config: SamplerConfig) -> Self {
        let mut bus = SimBus::board();
        for (board_address, address) in [
            (0x40, config.addresses.left),
            (0x45, config.addresses.right),
        ] {
            if board_address != address {
                if let Some(chip) = bus.chip(board_address).cloned() {
                    bus.insert(address, chip);
                }
            }
        }
        Self {
            board: Board::new(config),
            link: Link::new(),
            watchdog: FeedCounter::default(),
            bus,
            addresses: config.addresses,
            load: Box::new(|_| Sides::new(SideLoad::IDLE, SideLoad::IDLE)),
            now_us: 0,
        }
    }

    /// The host's DTR: the board transmits only while it is held, and greets on its rising edge.
    pub fn set_host_connected(&mut self, connected: bool) {
        self.link.set_connected(connected);
    }

    /// Watchdog feeds so far (one per completed [`SimBoard::step`]).
    pub fn watchdog_feeds(&self) -> u64 {
        self.watchdog.0
    }

    /// Sets the load the chips measure from now on.
    pub fn set_load(&mut self, load: impl LoadSource + 'static) {
        self.load = Box::new(load);
    }

    /// One sample period: the chips' inputs are set to the load at the current time, the bus
    /// advances to it, the firmware's `Board::tick` runs, and the time moves on by the board's
    /// (host-configurable) period. Returns the bytes now waiting to go out.
    pub fn step(&mut self) -> usize {
        let t = self.now_us;
        let load = self.load.load(t);
        self.bus
            .set_input(self.addresses.left, t, load.left.current_a, load.left.bus_v);
        self.bus.set_input(
            self.addresses.right,
            t,
            load.right.current_a,
            load.right.bus_v,
        );
        self.bus.set_time_us(t);
        self.board
            .tick(&mut self.bus, &mut self.link, &mut self.watchdog, t);
        self.now_us = t.saturating_add(u64::from(self.board.sample_period_us().max(1)));
        self.link.queued()
    }

    /// Writes the pending bytes to `out` in packets of at most [`USB_PACKET`] bytes, like USB;
    /// returns how many were written. A byte leaves the board's queue only once `out` took it,
    /// so on an error (a timeout of a full pty) nothing is lost or repeated.
    pub fn drain_into<W: Write + ?Sized>(&mut self, out: &mut W) -> io::Result<usize> {
        let mut written = 0;
        loop {
            let pending = self.link.pending();
            if pending.is_empty() {
                return Ok(written);
            }
            let n = pending.len().min(USB_PACKET);
            match out.write(&pending[..n]) {
                Ok(0) => return Err(io::Error::from(io::ErrorKind::WriteZero)),
                Ok(k) => {
                    let k = k.min(n);
                    self.link.consume(k);
                    written += k;
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }

    /// Bytes from the host (commands), as the USB interrupt hands them to the link.
    pub fn receive(&mut self, bytes: &[u8]) {
        self.link.receive(bytes);
    }

    /// The simulated time of the next step [µs].
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    /// The firmware's board (sampler, counters, energy).
    pub fn board(&self) -> &Board {
        &self.board
    }

    /// The firmware's link.
    pub fn link(&self) -> &Link {
        &self.link
    }

    /// The simulated bus.
    pub fn bus(&self) -> &SimBus {
        &self.bus
    }

    /// The simulated bus, for fault injection (unplug, NACK, brown-out).
    pub fn bus_mut(&mut self) -> &mut SimBus {
        &mut self.bus
    }
}

/// How a [`PtyBoard`] paces its stream.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pacing {
    /// As fast as the reader takes the bytes: the pty's buffer holds the writer back when the
    /// reader lags (the simulated time runs ahead of the wall clock).
    AsFastAsPossible,
    /// Step `k` is written no earlier than its simulated time after the start, like the board.
    RealTime,
    /// Simulated time runs at most `k` times as fast as the wall clock (`k` finite and > 0):
    /// a demo at 20× still answers commands within a few simulated periods.
    Scaled(f64),
}

impl Pacing {
    /// The wall time after the start before which a step at simulated `t_us` must not run.
    fn due(self, t_us: u64) -> Option<Duration> {
        match self {
            Pacing::AsFastAsPossible => None,
            Pacing::RealTime => Some(Duration::from_micros(t_us)),
            Pacing::Scaled(k) => Duration::try_from_secs_f64(t_us as f64 * 1e-6 / k).ok(),
        }
    }
}

/// Called before each step of a [`PtyBoard`] with the step's index and the board: fault
/// injection at a given time (unplug a chip, make it NACK, brown it out).
pub type BeforeStep = Box<dyn FnMut(u64, &mut SimBoard) + Send>;

/// Called with each step's bytes (whole frames) before they enter the pty: the line between
/// board and host, to corrupt, drop or insert bytes.
pub type Line = Box<dyn FnMut(u64, &mut Vec<u8>) + Send>;

/// Optional hooks of a [`PtyBoard`] (see [`PtyBoard::spawn_with`]).
#[derive(Default)]
pub struct PtyHooks {
    /// Runs before each step.
    pub before_step: Option<BeforeStep>,
    /// Transforms each step's bytes; with it, a step's bytes leave the board's queue at once
    /// (they are the line's), then go into the pty whole.
    pub line: Option<Line>,
    /// The host's wheel-rate commands the board waits for: the run time [µs] since its first
    /// step at which the host sends each (a recorder forwarding a commands CSV sends a row's
    /// speeds once it has read the sample at the row's time). The board steps no further than
    /// [`COMMAND_SLACK_US`] past a command's time until that command has arrived, at most for
    /// [`COMMAND_WAIT`] (a host that is gone does not hang it): on a loaded machine the run
    /// slows down instead of running ahead of its host's commands.
    pub commands_due_us: Vec<u64>,
    /// The host is this process's own recorder (the demo's): wait for its commands and reads
    /// as long as it takes, until the board is stopped, not for [`COMMAND_WAIT`] or
    /// [`WRITER_STALL`] ([`PtyWriter::wait_for_host`](crate::serial::PtyWriter::wait_for_host)):
    /// a recorder stalled for seconds on a busy machine slows the run, it does not cut it.
    pub wait_for_host: bool,
}

/// Run time a [`PtyBoard`] may run past a command's time before it waits for the command: the
/// host needs the sample at that time (written after its step) before it sends the command.
pub const COMMAND_SLACK_US: u64 = 20_000;

/// Longest wall time a [`PtyBoard`] waits for a command that is due.
pub const COMMAND_WAIT: Duration = Duration::from_secs(5);

impl fmt::Debug for PtyHooks {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("PtyHooks")
            .field("before_step", &self.before_step.is_some())
            .field("line", &self.line.is_some())
            .field("commands_due_us", &self.commands_due_us.len())
            .field("wait_for_host", &self.wait_for_host)
            .finish()
    }
}

pub use crate::serial::{HANG_UP_QUIET, WRITER_STALL};

/// Counts the wheel-rate commands among the bytes a host wrote (the board decodes them itself;
/// this is the [`PtyBoard`]'s own count, for [`PtyHooks::commands_due_us`]).
#[derive(Default)]
struct HostCommands {
    decoder: model_core::wire::FrameDecoder,
    wheel_rates: usize,
}

impl HostCommands {
    fn feed(&mut self, bytes: &[u8]) {
        let count = &mut self.wheel_rates;
        self.decoder.feed(bytes, |frame: Result<HostFrame, _>| {
            if let Ok(HostFrame {
                command: Command::SetWheelRates(_),
                ..
            }) = frame
            {
                *count += 1;
            }
        });
    }
}

/// What a finished [`PtyBoard`] writer hands back.
#[derive(Debug)]
pub struct PtyRun {
    /// The board after its last step (its own energy totals, counters).
    pub board: SimBoard,
    /// Steps run.
    pub steps: u64,
    /// Bytes written into the pty.
    pub bytes: u64,
}

impl PtyRun {
    /// The board's own energy per side at its last sample [power LSB × µs]: what the host's
    /// recomputation must equal.
    pub fn board_energy_lsb_us(&self) -> [i64; 2] {
        let e = self
            .board
            .board()
            .sampler()
            .measurements()
            .snapshot()
            .energy_lsb_us;
        [e.left, e.right]
    }
}

/// A simulated board writing into a pseudo-terminal from its own thread. The host opens
/// [`PtyBoard::path`] with [`crate::serial::open`] — the same code as for `/dev/ttyACM0`.
///
/// The board counts as connected (DTR held) from the start: a pty has no DTR line. Its bytes
/// wait in the pty until the host opens the path and reads. After its last step the writer waits
/// until the host has read everything (the slave's queue empty for [`HANG_UP_QUIET`], at most
/// [`WRITER_STALL`]) and then closes the pty: the host sees the device vanish, as on an unplug
/// (Linux: `BrokenPipe` from the poll's hang-up), with nothing left unread. Linux discards bytes
/// the host has not read when the master side closes, hence the wait.
///
/// Bytes the host writes into the pty (commands) reach the board's link between steps, as the
/// USB interrupt would hand them over: the board applies them at its next step and acks.
///
/// [`PtyTask::stop`] ends it after the current step: that step's frames are written whole and
/// read by the host before the pty closes.
pub type PtyBoard = PtyTask<PtyRun>;

impl PtyTask<PtyRun> {
    /// Starts `board` for `steps` sample periods into a new pty pair.
    pub fn spawn(board: SimBoard, steps: u64, pacing: Pacing) -> io::Result<PtyBoard> {
        Self::spawn_with(board, steps, pacing, PtyHooks::default())
    }

    /// Like [`PtyBoard::spawn`], with fault-injection hooks.
    pub fn spawn_with(
        mut board: SimBoard,
        steps: u64,
        pacing: Pacing,
        mut hooks: PtyHooks,
    ) -> io::Result<PtyBoard> {
        if let Pacing::Scaled(k) = pacing {
            if !(k.is_finite() && k > 0.0) {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!("pacing factor {k} must be finite and > 0"),
                ));
            }
        }
        board.set_host_connected(true);
        PtyTask::run("simulated board", move |mut pty, stop_flag| {
            if hooks.wait_for_host {
                pty.wait_for_host();
            }
            let start = Instant::now();
            let mut bytes = 0u64;
            let mut done = 0u64;
            let mut from_host = vec![0u8; 256];
            let mut line_bytes = Vec::new();
            let t0_us = board.now_us();
            let mut host = HostCommands::default();
            while done < steps && !stop_flag.load(Ordering::Relaxed) {
                if let Some(due) = pacing.due(board.now_us()) {
                    if let Some(wait) = (start + due).checked_duration_since(Instant::now()) {
                        std::thread::sleep(wait);
                    }
                }
                // Commands the host wrote reach the board's link before this step, as the
                // USB interrupt would hand them over; a command that is due is waited for.
                let run_us = board.now_us() - t0_us;
                let due = hooks
                    .commands_due_us
                    .iter()
                    .take_while(|&&t| t.saturating_add(COMMAND_SLACK_US) <= run_us)
                    .count();
                let waiting_since = Instant::now();
                loop {
                    let n = pty.read_from_host(&mut from_host)?;
                    if n > 0 {
                        host.feed(&from_host[..n]);
                        board.receive(&from_host[..n]);
                    } else if host.wheel_rates >= due
                        || stop_flag.load(Ordering::Relaxed)
                        || (!hooks.wait_for_host && waiting_since.elapsed() > COMMAND_WAIT)
                    {
                        break;
                    } else {
                        std::thread::sleep(Duration::from_micros(200));
                    }
                }
                if let Some(before_step) = hooks.before_step.as_mut() {
                    before_step(done, &mut board);
                }
                board.step();
                // Whole frames only (the pty waits while full): a stop takes effect
                // between steps.
                bytes += match hooks.line.as_mut() {
                    None => board.drain_into(&mut pty)? as u64,
                    Some(line) => {
                        line_bytes.clear();
                        board.drain_into(&mut line_bytes)?;
                        line(done, &mut line_bytes);
                        pty.write_all(&line_bytes)?;
                        line_bytes.len() as u64
                    }
                };
                done += 1;
            }
            pty.hang_up()?;
            Ok(PtyRun {
                board,
                steps: done,
                bytes,
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decode::{Event, StreamDecoder};
    use model_core::wire::BoardFrame;

    /// A writer that takes at most 10 bytes per call and fails every third call.
    struct Flaky {
        out: Vec<u8>,
        calls: u32,
    }

    impl Write for Flaky {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            self.calls += 1;
            if self.calls.is_multiple_of(3) {
                return Err(io::Error::from(io::ErrorKind::TimedOut));
            }
            let n = buf.len().min(10);
            self.out.extend_from_slice(&buf[..n]);
            Ok(n)
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    /// Records each write as one USB packet.
    struct Packets(Vec<Vec<u8>>);

    impl Write for Packets {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            self.0.push(buf.to_vec());
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    /// The bench a user tries first: no load, a chip with a few LSB of offset and noise, read
    /// every 5 ms while results land every 4.48 ms. A conversion landing between the shunt and
    /// the current reads must not be taken for a chip reset.
    #[test]
    fn an_idle_bench_has_no_false_resets() {
        let mut sim = SimBoard::new(SamplerConfig::BOARD);
        for (address, seed) in [(0x40, 7), (0x45, 11)] {
            let analog = super::super::Analog {
                shunt_noise_lsb: 2.0,
                shunt_offset_lsb: 1.0,
                seed,
                ..super::super::Analog::IDEAL
            };
            sim.bus_mut()
                .insert(address, super::super::SimIna226::new(analog));
        }
        for _ in 0..12_000 {
            sim.step();
        }
        let sampler = sim.board().sampler();
        assert_eq!(sampler.reinits(), Sides::new(0, 0));
        assert_eq!(sampler.i2c_errors(), Sides::new(0, 0));
        assert_eq!(sim.watchdog_feeds(), 12_000, "one feed per completed tick");
        // A real reset is still caught at idle (by the periodic calibration read-back).
        sim.bus_mut().brown_out(0x40);
        for _ in 0..600 {
            sim.step();
        }
        assert_eq!(sim.board().sampler().reinits(), Sides::new(1, 0));
    }

    #[test]
    fn silent_until_the_host_connects_then_hello_and_samples() {
        let mut sim = SimBoard::new(SamplerConfig::BOARD);
        assert_eq!(sim.step(), 0, "no DTR, nothing queued");
        sim.set_host_connected(true);
        sim.set_load(|_| {
            Sides::new(
                SideLoad {
                    current_a: 2.0,
                    bus_v: 24.5,
                },
                SideLoad {
                    current_a: 3.0,
                    bus_v: 24.4,
                },
            )
        });
        let mut usb = Packets(Vec::new());
        for _ in 0..50 {
            sim.step();
            sim.drain_into(&mut usb).expect("memory");
            assert_eq!(sim.link().queued(), 0);
        }
        assert!(usb.0.iter().all(|p| !p.is_empty() && p.len() <= USB_PACKET));
        let packets: Vec<u8> = usb.0.concat();
        let mut dec = StreamDecoder::new();
        let mut events = Vec::new();
        dec.feed(&packets, |e| events.push(e));
        assert!(matches!(
            events.first(),
            Some(Event::Frame(BoardFrame::Hello(_)))
        ));
        assert_eq!(dec.stats().samples, 50);
        assert_eq!(dec.stats().bad_frames, 0);
        assert_eq!(sim.now_us(), 51 * 5_000);
    }

    #[test]
    fn drain_loses_nothing_when_the_writer_fails_or_takes_part() {
        let mut a = SimBoard::new(SamplerConfig::BOARD);
        let mut b = SimBoard::new(SamplerConfig::BOARD);
        a.set_host_connected(true);
        b.set_host_connected(true);
        let mut clean = Vec::new();
        let mut flaky = Flaky {
            out: Vec::new(),
            calls: 0,
        };
        for _ in 0..200 {
            a.step();
            b.step();
            a.drain_into(&mut clean).expect("vec");
            while b.link().queued() > 0 {
                let _ = b.drain_into(&mut flaky);
            }
        }
        assert!(clean.len() > 1_000);
        assert_eq!(clean, flaky.out);
    }

    #[test]
    fn a_command_written_into_the_pty_is_acked_and_changes_the_wheel_rates() {
        use crate::serial::{self, PortReader, ReadOutcome};
        use model_core::wire::{self, Command, HostFrame};
        let pty = PtyBoard::spawn(
            SimBoard::new(SamplerConfig::BOARD),
            1_000_000,
            Pacing::Scaled(20.0),
        )
        .expect("pty");
        let port = serial::open(pty.path(), Duration::from_millis(20)).expect("open");
        let mut reader = PortReader::new(port);
        let mut dec = StreamDecoder::new();
        let rates = Sides::new(4.5f32, -1.25);
        let mut frame = [0u8; wire::MAX_FRAME];
        let n = wire::encode(
            &HostFrame {
                id: 77,
                command: Command::SetWheelRates(rates),
            },
            &mut frame,
        )
        .expect("fits");
        reader.port_mut().write_all(&frame[..n]).expect("write");
        let start = Instant::now();
        let mut acked = false;
        while !acked {
            assert!(start.elapsed() < Duration::from_secs(20), "no ack");
            let outcome = reader.poll(&mut dec, |e| {
                acked |= e == Event::Frame(BoardFrame::Ack { id: 77 });
            });
            assert!(!matches!(outcome, ReadOutcome::Vanished { .. }));
        }
        pty.stop();
        while !matches!(reader.poll(&mut dec, |_| {}), ReadOutcome::Vanished { .. }) {
            assert!(start.elapsed() < Duration::from_secs(20), "never hung up");
        }
        let run = pty.join().expect("writer");
        assert_eq!(
            run.board.board().sampler().measurements().wheel_rates(),
            Some(rates)
        );
        // 20× real time at most: the run took at least its simulated time / 20.
        assert!(
            start.elapsed()
                >= Duration::from_micros((run.board.now_us() / 20).saturating_sub(5_000))
        );
    }

    /// A board with a command due at run time 0 waits for it: a host that sends it late (here
    /// after 300 ms, while the board runs as fast as the pty takes its bytes) finds it acked
    /// within [`COMMAND_SLACK_US`] of run time, not hundreds of samples later.
    #[test]
    fn a_due_command_is_waited_for() {
        use crate::serial::{self, PortReader};
        use model_core::wire::{self, Command, HostFrame};
        let hooks = PtyHooks {
            commands_due_us: vec![0],
            ..PtyHooks::default()
        };
        let board = SimBoard::new(SamplerConfig::BOARD);
        let period_us = u64::from(SamplerConfig::BOARD.sample_period_us);
        let pty = PtyBoard::spawn_with(board, 1_000, Pacing::AsFastAsPossible, hooks).expect("pty");
        let port = serial::open(pty.path(), Duration::from_millis(20)).expect("open");
        let mut reader = PortReader::new(port);
        std::thread::sleep(Duration::from_millis(300));
        let mut frame = [0u8; wire::MAX_FRAME];
        let command = HostFrame {
            id: 5,
            command: Command::SetWheelRates(Sides::new(1.0, 1.0)),
        };
        let n = wire::encode(&command, &mut frame).expect("fits");
        reader.port_mut().write_all(&frame[..n]).expect("write");
        let mut dec = StreamDecoder::new();
        let (mut last_seq, mut acked_after) = (None, None);
        let start = Instant::now();
        while !reader.vanished() {
            assert!(start.elapsed() < Duration::from_secs(20), "never hung up");
            reader.poll(&mut dec, |e| match e {
                Event::Frame(BoardFrame::Sample(s)) => last_seq = Some(s.seq),
                Event::Frame(BoardFrame::Ack { id: 5 }) => acked_after = Some(last_seq),
                _ => {}
            });
        }
        pty.join().expect("writer");
        let acked_after = acked_after.expect("acked").expect("after a sample");
        assert!(
            u64::from(acked_after) <= COMMAND_SLACK_US / period_us + 1,
            "acked after sample {acked_after}"
        );
    }

    #[test]
    fn a_bad_pacing_factor_is_refused() {
        for k in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = PtyBoard::spawn(SimBoard::new(SamplerConfig::BOARD), 1, Pacing::Scaled(k))
                .expect_err("refused");
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        }
    }

    #[test]
    fn the_line_hook_sees_every_step_and_before_step_reaches_the_board() {
        use std::sync::{Arc, Mutex};
        let seen = Arc::new(Mutex::new(Vec::new()));
        let seen_in_line = Arc::clone(&seen);
        let hooks = PtyHooks {
            before_step: Some(Box::new(|k, board: &mut SimBoard| {
                if k == 3 {
                    board.bus_mut().unplug(0x45);
                }
            })),
            line: Some(Box::new(move |k, bytes: &mut Vec<u8>| {
                if let Ok(mut seen) = seen_in_line.lock() {
                    seen.push((k, bytes.len()));
                }
            })),
            ..PtyHooks::default()
        };
        let pty = PtyBoard::spawn_with(
            SimBoard::new(SamplerConfig::BOARD),
            10,
            Pacing::AsFastAsPossible,
            hooks,
        )
        .expect("pty");
        let port = crate::serial::open(pty.path(), Duration::from_millis(20)).expect("open");
        let mut reader = crate::serial::PortReader::new(port);
        let mut dec = StreamDecoder::new();
        let mut right = Vec::new();
        let start = Instant::now();
        while !reader.vanished() {
            assert!(start.elapsed() < Duration::from_secs(20));
            reader.poll(&mut dec, |e| {
                if let Event::Frame(BoardFrame::Sample(s)) = e {
                    right.push(s.chips.right);
                }
            });
        }
        let run = pty.join().expect("writer");
        let seen = seen.lock().expect("lock").clone();
        assert_eq!(
            seen.iter().map(|(k, _)| *k).collect::<Vec<_>>(),
            (0..10).collect::<Vec<_>>()
        );
        assert_eq!(seen.iter().map(|(_, n)| *n as u64).sum::<u64>(), run.bytes);
        assert_eq!(right.len(), 10);
        assert!(right[3..].iter().all(|c| *c
            == model_core::wire::ChipReading::Failed(model_core::wire::ChipFault::AddressNack)));
    }
}
