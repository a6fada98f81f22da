//! The board's USB serial port (CDC ACM, `/dev/ttyACM0`) — or a pseudo-terminal carrying the
//! simulated board's stream — read into a [`StreamDecoder`]. One code path for both.
//!
//! Built on `serialport` without its libudev feature: on Linux, [`list_ports`] reads the USB
//! vendor/product IDs and strings from sysfs.

use crate::decode::{Event, StreamDecoder};
use serialport::{SerialPort, SerialPortType, TTYPort};
use std::fmt;
use std::io::{self, Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Baud rate requested on open. CDC ACM ignores it (USB runs at its own speed); a pty accepts it.
pub const BAUD_RATE: u32 = 115_200;

/// Bytes asked for per read: several 64-byte USB packets.
pub const READ_CHUNK: usize = 4096;

/// USB VID:PID of the board (V-USB's shared CDC-ACM pair, told apart by serial number).
pub const ROVER_POWER_VID_PID: (u16, u16) = (0x16c0, 0x27dd);

/// What to do about a port the user may not open: the udev rule or the dialout group.
pub const PERMISSION_HINT: &str = "install the udev rule (sudo cp firmware/99-rover-power.rules \
/etc/udev/rules.d/ && sudo udevadm control --reload-rules && sudo udevadm trigger, then re-plug \
the board; it also adds /dev/rover-power) or join the dialout group (sudo usermod -aG dialout \
$USER, then log out and back in); docs/board.md, \"From a bare board to a first recording\"";

/// Errors of listing and opening ports.
#[derive(Debug, thiserror::Error)]
pub enum SerialError {
    /// The system's port list could not be read.
    #[error("cannot list serial ports: {0}")]
    List(#[source] serialport::Error),
    /// A zero read timeout would make every read return at once (serialport's default).
    #[error("the read timeout must be greater than zero")]
    ZeroTimeout,
    /// The port could not be opened (missing, busy, no permission).
    #[error("cannot open {path}: {source}")]
    Open {
        /// The port's path.
        path: String,
        /// Why.
        #[source]
        source: serialport::Error,
    },
    /// The user may not open the port (Linux: not in `dialout`, no udev rule).
    #[error("cannot open {path}: permission denied; {PERMISSION_HINT}")]
    PermissionDenied {
        /// The port's path.
        path: String,
    },
    /// DTR could not be asserted; the board transmits only while the host holds DTR.
    #[error("cannot assert DTR on {path}: {source}")]
    Dtr {
        /// The port's path.
        path: String,
        /// Why.
        #[source]
        source: serialport::Error,
    },
}

/// USB identity of a port.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UsbId {
    /// Vendor ID.
    pub vid: u16,
    /// Product ID.
    pub pid: u16,
}

/// One serial port of the system.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortInfo {
    /// Path to open (`/dev/ttyACM0`).
    pub name: String,
    /// USB vendor/product ID, for USB ports.
    pub usb: Option<UsbId>,
    /// USB product string, when known.
    pub product: Option<String>,
    /// USB manufacturer string, when known.
    pub manufacturer: Option<String>,
    /// USB serial number, when known.
    pub serial_number: Option<String>,
}

impl PortInfo {
    /// Whether this is a rover-power board: the shared CDC-ACM VID:PID 16c0:27dd and a serial
    /// number under the project's prefix (built from the MCU's unique ID, as in its hello).
    pub fn is_rover_power(&self) -> bool {
        self.usb
            .as_ref()
            .is_some_and(|u| (u.vid, u.pid) == ROVER_POWER_VID_PID)
            && self
                .serial_number
                .as_deref()
                .is_some_and(|s| s.starts_with(model_core::board_id::SERIAL_PREFIX))
    }

    fn from_serialport(info: serialport::SerialPortInfo) -> Self {
        let mut port = PortInfo {
            name: info.port_name,
            usb: None,
            product: None,
            manufacturer: None,
            serial_number: None,
        };
        if let SerialPortType::UsbPort(usb) = info.port_type {
            port.usb = Some(UsbId {
                vid: usb.vid,
                pid: usb.pid,
            });
            port.product = usb.product;
            port.manufacturer = usb.manufacturer;
            port.serial_number = usb.serial_number;
        }
        port
    }
}

/// The system's serial ports, sorted by name. Empty (not an error, not a panic) on a Linux
/// system without `/sys/class/tty` (some containers).
pub fn list_ports() -> Result<Vec<PortInfo>, SerialError> {
    // serialport's sysfs scan panics when the directory is missing.
    if cfg!(target_os = "linux") && !std::path::Path::new("/sys/class/tty").is_dir() {
        return Ok(Vec::new());
    }
    let mut ports: Vec<PortInfo> = serialport::available_ports()
        .map_err(SerialError::List)?
        .into_iter()
        .map(PortInfo::from_serialport)
        .collect();
    ports.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(ports)
}

/// Whether `path` is (or is a symlink to, like a `/dev/serial/by-id` name) a Unix
/// pseudo-terminal slave, which has no modem control lines.
pub fn is_pty(path: &str) -> bool {
    let pts = |p: &std::path::Path| p.starts_with("/dev/pts");
    pts(std::path::Path::new(path)) || std::fs::canonicalize(path).is_ok_and(|p| pts(&p))
}

/// Opens `path` for reading the board: raw 8N1, reads wait at most `read_timeout` (must be > 0),
/// DTR asserted so the board starts transmitting (and greets with a hello). A pseudo-terminal
/// has no DTR line; there the failure to set it is ignored (the simulated board's DTR is
/// [`crate::sim::board::SimBoard::set_host_connected`]).
pub fn open(path: &str, read_timeout: Duration) -> Result<Box<dyn SerialPort>, SerialError> {
    if read_timeout.is_zero() {
        return Err(SerialError::ZeroTimeout);
    }
    let mut port = serialport::new(path, BAUD_RATE)
        .timeout(read_timeout)
        .dtr_on_open(true)
        .open()
        .map_err(|source| open_error(path, source))?;
    if let Err(source) = port.write_data_terminal_ready(true) {
        if !is_pty(path) {
            return Err(SerialError::Dtr {
                path: path.to_owned(),
                source,
            });
        }
    }
    Ok(port)
}

/// The error of a failed open: a refused permission gets its own variant (and hint).
pub fn open_error(path: &str, source: serialport::Error) -> SerialError {
    match source.kind() {
        serialport::ErrorKind::Io(io::ErrorKind::PermissionDenied) => {
            SerialError::PermissionDenied {
                path: path.to_owned(),
            }
        }
        _ => SerialError::Open {
            path: path.to_owned(),
            source,
        },
    }
}

/// What one [`PortReader::poll`] found.
#[derive(Debug)]
pub enum ReadOutcome {
    /// This many bytes were read and decoded.
    Data(usize),
    /// Nothing arrived within the read timeout (or the read was interrupted): try again.
    NoData,
    /// The device is gone (unplugged, pty closed): end of file or an I/O error. Every byte
    /// read before it was decoded; further polls keep reporting this.
    Vanished {
        /// The error, or `None` for end of file.
        error: Option<io::Error>,
    },
}

/// Reads a port (any [`Read`]; normally `Box<dyn SerialPort>` from [`open`]) in chunks into a
/// [`StreamDecoder`].
#[derive(Debug)]
pub struct PortReader<R> {
    port: R,
    buf: Box<[u8]>,
    bytes_read: u64,
    vanished: bool,
}

impl<R: Read> PortReader<R> {
    /// A reader of `port`.
    pub fn new(port: R) -> Self {
        Self {
            port,
            buf: vec![0u8; READ_CHUNK].into_boxed_slice(),
            bytes_read: 0,
            vanished: false,
        }
    }

    /// One read (waiting at most the port's read timeout); the bytes go into `decoder`, which
    /// calls `on_event` for each event.
    pub fn poll(
        &mut self,
        decoder: &mut StreamDecoder,
        on_event: impl FnMut(Event),
    ) -> ReadOutcome {
        if self.vanished {
            return ReadOutcome::Vanished { error: None };
        }
        match self.port.read(&mut self.buf) {
            Ok(0) => {
                self.vanished = true;
                ReadOutcome::Vanished { error: None }
            }
            Ok(n) => {
                let n = n.min(self.buf.len());
                self.bytes_read = self.bytes_read.saturating_add(n as u64);
                decoder.feed(&self.buf[..n], on_event);
                ReadOutcome::Data(n)
            }
            Err(e) if is_transient(&e) => ReadOutcome::NoData,
            Err(e) => {
                self.vanished = true;
                ReadOutcome::Vanished { error: Some(e) }
            }
        }
    }

    /// Bytes read so far.
    pub fn bytes_read(&self) -> u64 {
        self.bytes_read
    }

    /// Whether the device has vanished.
    pub fn vanished(&self) -> bool {
        self.vanished
    }

    /// The port, e.g. to send commands to the board.
    pub fn port_mut(&mut self) -> &mut R {
        &mut self.port
    }

    /// Gives the port back.
    pub fn into_inner(self) -> R {
        self.port
    }
}

/// How long a [`PtyWriter`] waits for a reader that takes nothing before giving up.
pub const WRITER_STALL: Duration = Duration::from_secs(10);

/// How long the pty must stay read empty before a [`PtyWriter`] hangs up.
pub const HANG_UP_QUIET: Duration = Duration::from_millis(50);

/// The device end of a pseudo-terminal pair: whatever is written to it, a host reads from
/// [`PtyWriter::path`] with [`open`] like the board's `/dev/ttyACM0`. Used by the simulated board
/// and by `replay --to-pty`.
///
/// Writes wait while the pty is full (the reader lags) and fail with `TimedOut` only after
/// [`WRITER_STALL`] without progress. Bytes written before the host opens the path wait in the
/// pty (the slave end is held open). Linux discards what the host has not read when the master
/// closes, so [`PtyWriter::hang_up`] first waits for the host to read everything; the host then
/// sees the device vanish, as on an unplug (a hang-up: `BrokenPipe` or end of file).
pub struct PtyWriter {
    master: TTYPort,
    slave: TTYPort,
    path: String,
    /// How long a write or the hang-up waits for a host that reads nothing; `None`: as long as
    /// the host runs, until [`PtyWriter::stop`] is set ([`PtyWriter::wait_for_host`]).
    patience: Option<Duration>,
    /// Set when the writer is to stop ([`PtyTask::stop`]).
    stop: Arc<AtomicBool>,
}

impl fmt::Debug for PtyWriter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("PtyWriter")
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

impl PtyWriter {
    /// A new pty pair.
    pub fn open() -> io::Result<PtyWriter> {
        let (mut master, slave) = TTYPort::pair().map_err(io::Error::from)?;
        let path = slave
            .name()
            .ok_or_else(|| io::Error::other("the pty slave has no path"))?;
        master
            .set_timeout(Duration::from_millis(50))
            .map_err(io::Error::from)?;
        Ok(PtyWriter {
            master,
            slave,
            path,
            patience: Some(WRITER_STALL),
            stop: Arc::new(AtomicBool::new(false)),
        })
    }

    /// The host is this process's own (the demo's recorder): wait for it however slow it is
    /// (a disk that blocks its writes for seconds under load, a starved thread), until the
    /// task is stopped, never on a wall clock.
    pub fn wait_for_host(&mut self) {
        self.patience = None;
    }

    /// A writer that gives up on a silent host after `patience` instead of [`WRITER_STALL`]:
    /// tests show a stall beyond it in a fraction of a second.
    #[cfg(test)]
    fn with_patience(mut self, patience: Duration) -> Self {
        self.patience = Some(patience);
        self
    }

    /// Whether waiting for the host is over: past `patience` without progress since `since`,
    /// or, without patience, the task was stopped.
    fn given_up(&self, since: Instant) -> bool {
        match self.patience {
            Some(limit) => since.elapsed() > limit,
            None => self.stop.load(Ordering::Relaxed),
        }
    }

    /// The slave's path (`/dev/pts/N`), to open like a serial port.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// Bytes written that the host has not read yet.
    pub fn unread(&self) -> io::Result<u32> {
        self.slave.bytes_to_read().map_err(io::Error::from)
    }

    /// Waits until the host has read everything written: the slave's queue stays empty for
    /// [`HANG_UP_QUIET`] (the kernel moves written bytes to the slave asynchronously, so empty
    /// once is not enough). Gives up after `limit` without the host reading a byte (`None`:
    /// waits as long as it takes). Returns whether everything was read.
    pub fn wait_until_read(&self, limit: Option<Duration>) -> io::Result<bool> {
        let mut progress_at = Instant::now();
        let mut quiet_since = Instant::now();
        let mut unread = self.unread()?;
        loop {
            let now = self.unread()?;
            // Nothing left to read is not a stalled host.
            if now < unread || now == 0 {
                progress_at = Instant::now();
            }
            unread = now;
            if unread > 0 {
                quiet_since = Instant::now();
            } else if quiet_since.elapsed() >= HANG_UP_QUIET {
                return Ok(true);
            }
            if limit.is_some_and(|limit| progress_at.elapsed() >= limit) {
                return Ok(false);
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    /// What the host wrote into the pty (commands to the board), without waiting: reads only
    /// the bytes already there, at most `buf.len()`; 0 when there are none.
    pub fn read_from_host(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let waiting = self.master.bytes_to_read().map_err(io::Error::from)? as usize;
        if waiting == 0 || buf.is_empty() {
            return Ok(0);
        }
        let n = waiting.min(buf.len());
        match self.master.read(&mut buf[..n]) {
            Ok(k) => Ok(k.min(n)),
            Err(e) if is_transient(&e) => Ok(0),
            Err(e) => Err(e),
        }
    }

    /// Waits for the host to read everything, then closes both ends: the host sees the device
    /// vanish with nothing left unread. Gives up (and what is unread is lost) after
    /// [`WRITER_STALL`] without the host reading a byte, or, [waiting for the
    /// host](PtyWriter::wait_for_host), when the task is stopped.
    pub fn hang_up(self) -> io::Result<()> {
        let mut progress_at = Instant::now();
        let mut unread = self.unread()?;
        while !self.wait_until_read(Some(Duration::from_millis(20)))? {
            let now = self.unread()?;
            if now < unread {
                progress_at = Instant::now();
            }
            unread = now;
            if self.given_up(progress_at) {
                break;
            }
        }
        Ok(())
    }
}

/// A [`PtyWriter`] fed from its own thread (the simulated board, a replay): the pty's path to
/// open, a stop request, and the thread's result. Dropping it stops and joins the thread.
#[derive(Debug)]
pub struct PtyTask<T> {
    name: String,
    path: String,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<io::Result<T>>>,
}

impl<T: Send + 'static> PtyTask<T> {
    /// Opens a pty pair and runs `work(pty, stop)` on a thread called `name`; `work` checks
    /// `stop` between writes and hangs the pty up when it is done.
    pub fn run(
        name: &str,
        work: impl FnOnce(PtyWriter, &AtomicBool) -> io::Result<T> + Send + 'static,
    ) -> io::Result<PtyTask<T>> {
        let pty = PtyWriter::open()?;
        let path = pty.path().to_owned();
        let stop = Arc::clone(&pty.stop);
        let stop_flag = Arc::clone(&stop);
        let thread = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || work(pty, &stop_flag))?;
        Ok(PtyTask {
            name: name.into(),
            path,
            stop,
            thread: Some(thread),
        })
    }
}

impl<T> PtyTask<T> {
    /// The pty slave's path (`/dev/pts/N`), to open like a serial port.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// Asks the writer to stop after what it is writing now: it waits for the reader to read
    /// that, then hangs up (the device vanishes mid-stream).
    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }

    /// Waits for the writer to finish.
    pub fn join(mut self) -> io::Result<T> {
        match self.thread.take() {
            Some(thread) => thread
                .join()
                .map_err(|_| io::Error::other(format!("the {} thread panicked", self.name)))?,
            None => Err(io::Error::other("already joined")),
        }
    }
}

impl<T> Drop for PtyTask<T> {
    fn drop(&mut self) {
        self.stop();
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Write for PtyWriter {
    /// Writes some of `buf`, waiting while the pty is full; `TimedOut` after [`WRITER_STALL`]
    /// without progress (or, [waiting for the host](PtyWriter::wait_for_host), once stopped).
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let start = Instant::now();
        loop {
            match self.master.write(buf) {
                Ok(n) => return Ok(n),
                Err(e) if is_transient(&e) => {
                    if self.given_up(start) {
                        let why = match self.patience {
                            Some(limit) => {
                                format!("nobody read {} for {} s", self.path, limit.as_secs())
                            }
                            None => format!("stopped while the host read nothing of {}", self.path),
                        };
                        return Err(io::Error::new(io::ErrorKind::TimedOut, why));
                    }
                }
                Err(e) => return Err(e),
            }
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        self.master.flush()
    }
}

/// Whether a read or write error only means "nothing now" (a read timeout, a non-blocking port
/// with nothing to give or take, a signal): the port is still there, try again.
pub fn is_transient(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use model_core::wire::{self, BoardFrame};
    use std::collections::VecDeque;

    /// Scripted reads.
    struct Script(VecDeque<io::Result<Vec<u8>>>);

    impl Read for Script {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            match self.0.pop_front() {
                None => Ok(0),
                Some(Ok(bytes)) => {
                    buf[..bytes.len()].copy_from_slice(&bytes);
                    Ok(bytes.len())
                }
                Some(Err(e)) => Err(e),
            }
        }
    }

    #[test]
    fn timeouts_are_no_data_other_errors_vanish_and_bytes_read_before_are_kept() {
        let mut frame = [0u8; wire::MAX_FRAME];
        let n = wire::encode(&BoardFrame::Ack { id: 7 }, &mut frame).expect("fits");
        let frame = frame[..n].to_vec();
        let mut reader = PortReader::new(Script(VecDeque::from([
            Ok(frame[..2].to_vec()),
            Err(io::Error::from(io::ErrorKind::TimedOut)),
            Err(io::Error::from(io::ErrorKind::WouldBlock)),
            Err(io::Error::from(io::ErrorKind::Interrupted)),
            Ok(frame[2..].to_vec()),
            Err(io::Error::from(io::ErrorKind::BrokenPipe)),
            Ok(frame.clone()),
        ])));
        let mut dec = StreamDecoder::new();
        let mut events = Vec::new();
        let mut outcomes = Vec::new();
        for _ in 0..7 {
            outcomes.push(reader.poll(&mut dec, |e| events.push(e)));
        }
        assert!(matches!(outcomes[0], ReadOutcome::Data(2)));
        assert!(outcomes[1..4]
            .iter()
            .all(|o| matches!(o, ReadOutcome::NoData)));
        assert!(matches!(outcomes[4], ReadOutcome::Data(m) if m == n - 2));
        assert!(matches!(
            &outcomes[5],
            ReadOutcome::Vanished { error: Some(e) } if e.kind() == io::ErrorKind::BrokenPipe
        ));
        assert!(matches!(outcomes[6], ReadOutcome::Vanished { error: None }));
        assert_eq!(events, vec![Event::Frame(BoardFrame::Ack { id: 7 })]);
        assert_eq!(reader.bytes_read(), n as u64);
        assert!(reader.vanished());
    }

    #[test]
    fn end_of_file_is_vanished() {
        let mut reader = PortReader::new(Script(VecDeque::new()));
        let mut dec = StreamDecoder::new();
        assert!(matches!(
            reader.poll(&mut dec, |_| {}),
            ReadOutcome::Vanished { error: None }
        ));
    }

    #[test]
    fn a_zero_timeout_is_refused_and_a_missing_port_is_an_error() {
        assert!(matches!(
            open("/dev/null-no-such-port", Duration::ZERO),
            Err(SerialError::ZeroTimeout)
        ));
        assert!(matches!(
            open("/dev/null-no-such-port", Duration::from_millis(10)),
            Err(SerialError::Open { .. })
        ));
    }

    #[test]
    fn a_refused_permission_names_the_udev_rule_and_the_dialout_group() {
        let denied = serialport::Error::new(
            serialport::ErrorKind::Io(io::ErrorKind::PermissionDenied),
            "Permission denied",
        );
        let e = open_error("/dev/ttyACM0", denied);
        assert!(matches!(e, SerialError::PermissionDenied { .. }));
        let text = e.to_string();
        assert!(
            text.contains("99-rover-power.rules") && text.contains("dialout"),
            "{text}"
        );
        let missing = serialport::Error::new(serialport::ErrorKind::NoDevice, "gone");
        assert!(matches!(
            open_error("/dev/ttyACM0", missing),
            SerialError::Open { .. }
        ));
    }

    #[test]
    fn a_board_is_known_by_vid_pid_and_serial_prefix() {
        let mut port = PortInfo {
            name: "/dev/ttyACM0".into(),
            usb: Some(UsbId {
                vid: 0x16c0,
                pid: 0x27dd,
            }),
            product: None,
            manufacturer: None,
            serial_number: Some("rover-power.github.io:33003a0012513330363439ff".into()),
        };
        assert!(port.is_rover_power());
        // Another device on the shared pair, and the old firmware's serial.
        port.serial_number = Some("someone.example:1".into());
        assert!(!port.is_rover_power());
        port.serial_number = Some("RP-0001".into());
        assert!(!port.is_rover_power());
    }

    #[test]
    fn listing_ports_does_not_fail_here() {
        // Whatever this machine has (often nothing), listing works.
        let ports = list_ports().expect("list");
        assert!(ports.iter().all(|p| !p.name.is_empty()));
    }

    /// Once the host has read everything, the hang-up comes at once (it once waited the whole
    /// stall limit: an empty pty read as a host making no progress); bytes left unread are
    /// waited for while the host reads them.
    #[test]
    fn the_hang_up_follows_the_hosts_last_read_at_once() {
        let mut pty = PtyWriter::open().expect("pty");
        let mut host = open(pty.path(), Duration::from_millis(100)).expect("host end");
        pty.write_all(&[7u8; 4096]).expect("written");
        let reader = std::thread::spawn(move || {
            let mut got = 0;
            let mut buf = [0u8; 512];
            while got < 4096 {
                // A slow host: a read every 5 ms.
                std::thread::sleep(Duration::from_millis(5));
                got += host.read(&mut buf).unwrap_or(0);
            }
            (got, host)
        });
        let start = Instant::now();
        pty.hang_up().expect("hung up");
        let waited = start.elapsed();
        let (got, _host) = reader.join().expect("reader");
        assert_eq!(got, 4096);
        assert!(waited < Duration::from_secs(3), "{waited:?}");
    }

    /// What a host that stalls for `stall` and then reads to the end gets of 4096 bytes from a
    /// writer with 100 ms of patience, waiting for its host or not.
    fn read_after_a_stall(stall: Duration, waiting_for_host: bool) -> usize {
        let mut pty = PtyWriter::open()
            .expect("pty")
            .with_patience(Duration::from_millis(100));
        if waiting_for_host {
            pty.wait_for_host();
        }
        let mut host = open(pty.path(), Duration::from_millis(50)).expect("host end");
        pty.write_all(&[7u8; 4096]).expect("written");
        let writer = std::thread::spawn(move || pty.hang_up());
        std::thread::sleep(stall);
        let (mut got, mut buf) = (0, [0u8; 512]);
        let until = Instant::now() + Duration::from_secs(5);
        while got < 4096 && Instant::now() < until {
            match host.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => got += n,
                Err(e) if is_transient(&e) => {}
                Err(_) => break, // hung up: the rest is gone
            }
        }
        writer.join().expect("writer").expect("hung up");
        got
    }

    /// The demo's board waits for its own recorder however long it stalls: its pty once hung
    /// up after the stall limit with the last samples unread (tests/tests/e2e/demo.rs stalls
    /// the demo's recorder; this is the same at 10× a short patience, with the control).
    #[test]
    fn a_writer_waiting_for_its_host_outlasts_any_stall_and_one_that_is_not_gives_up() {
        let stall = Duration::from_secs(1);
        assert_eq!(read_after_a_stall(stall, true), 4096);
        assert!(
            read_after_a_stall(stall, false) < 4096,
            "the patience applies"
        );
    }
}
