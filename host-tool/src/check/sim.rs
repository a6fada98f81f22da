//! `check --simulated`: the firmware's own board on the simulated bus behind a pseudo-terminal,
//! with a DTR line the check raises (a pty has none, so it is carried beside it), and the
//! faults a first board shows, to inject.

use super::session::{CheckPort, READ_TIMEOUT};
use crate::serial::{self, SerialError};
use crate::sim::board::{Pacing, PtyBoard, PtyHooks, PtyRun, SideLoad, SimBoard};
use crate::sim::{Analog, SimIna226};
use firmware::sampler::SamplerConfig;
use model_core::Sides;
use std::io::{self, Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A fault to inject into the simulated board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimFault {
    /// The right chip (0x45) is not on the bus.
    MissingChip,
    /// The right chip is an INA260 (die ID 0x2270).
    WrongId,
    /// The right chip browns out every 0.75 s.
    ResetChip,
    /// The port refuses DTR (a USB-UART adapter without modem lines).
    NoDtr,
    /// The board speaks the previous protocol version.
    WrongProtocol,
    /// The board never sends a byte.
    SilentPort,
    /// The right side draws 0.59 A at standstill (the seed's Fig. 3.3).
    StandstillOffset,
}

impl SimFault {
    /// Every fault.
    pub const ALL: [SimFault; 7] = [
        SimFault::MissingChip,
        SimFault::WrongId,
        SimFault::ResetChip,
        SimFault::NoDtr,
        SimFault::WrongProtocol,
        SimFault::SilentPort,
        SimFault::StandstillOffset,
    ];

    /// The fault's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SimFault::MissingChip => "missing-chip",
            SimFault::WrongId => "wrong-id",
            SimFault::ResetChip => "reset-chip",
            SimFault::NoDtr => "no-dtr",
            SimFault::WrongProtocol => "wrong-protocol",
            SimFault::SilentPort => "silent-port",
            SimFault::StandstillOffset => "standstill-offset",
        }
    }

    /// The fault named `name`.
    pub fn parse(name: &str) -> Result<SimFault, String> {
        SimFault::ALL
            .into_iter()
            .find(|f| f.name() == name)
            .ok_or_else(|| {
                let names: Vec<&str> = SimFault::ALL.iter().map(|f| f.name()).collect();
                format!("unknown fault {name:?}; one of {}", names.join(", "))
            })
    }
}

/// The right chip's address on the board.
const RIGHT: u8 = 0x45;
/// Steps between injected brown-outs (0.75 s at 200 Hz), and the first one's offset after DTR.
const RESET_EVERY: u64 = 150;
const RESET_AT: u64 = 75;
/// Die ID of an INA260.
const INA260_DIE_ID: u16 = 0x2270;

/// A simulated board running behind a pty, with its DTR line.
#[derive(Debug)]
pub struct SimulatedBoard {
    task: PtyBoard,
    dtr: Arc<AtomicBool>,
    dtr_works: bool,
}

impl SimulatedBoard {
    /// Starts the board with `fault` at the given pace, standing still on a 24 V battery (the
    /// drivers' quiescent 30–40 mA flowing), until [`SimulatedBoard::finish`].
    pub fn spawn(fault: Option<SimFault>, pacing: Pacing) -> io::Result<SimulatedBoard> {
        let mut board = SimBoard::new(SamplerConfig::BOARD);
        for (address, seed) in [(0x40, 3), (RIGHT, 5)] {
            let analog = Analog {
                shunt_noise_lsb: 2.0,
                bus_noise_lsb: 1.0,
                seed,
                ..Analog::IDEAL
            };
            let mut chip = SimIna226::new(analog);
            if fault == Some(SimFault::WrongId) && address == RIGHT {
                chip = chip.with_die_id(INA260_DIE_ID);
            }
            board.bus_mut().insert(address, chip);
        }
        let right_a = if fault == Some(SimFault::StandstillOffset) {
            0.59
        } else {
            0.04
        };
        board.set_load(move |_| {
            Sides::new(
                SideLoad {
                    current_a: 0.03,
                    bus_v: 24.0,
                },
                SideLoad {
                    current_a: right_a,
                    bus_v: 23.98,
                },
            )
        });
        let dtr = Arc::new(AtomicBool::new(false));
        let line_dtr = Arc::clone(&dtr);
        let mut connected_steps = 0u64;
        let before_step = move |k: u64, board: &mut SimBoard| {
            // The host's DTR reaches the board as the USB interrupt would hand it over.
            let dtr = line_dtr.load(Ordering::Relaxed);
            board.set_host_connected(dtr);
            connected_steps = if dtr { connected_steps + 1 } else { 0 };
            match fault {
                Some(SimFault::MissingChip) if k == 0 => {
                    board.bus_mut().unplug(RIGHT);
                }
                Some(SimFault::ResetChip) if connected_steps % RESET_EVERY == RESET_AT => {
                    board.bus_mut().brown_out(RIGHT);
                }
                _ => {}
            }
        };
        let line: Option<crate::sim::board::Line> = match fault {
            Some(SimFault::SilentPort) => Some(Box::new(|_, bytes: &mut Vec<u8>| bytes.clear())),
            Some(SimFault::WrongProtocol) => Some(Box::new(|_, bytes: &mut Vec<u8>| {
                rewrite_version(bytes, model_core::wire::PROTOCOL_VERSION - 1)
            })),
            _ => None,
        };
        let hooks = PtyHooks {
            before_step: Some(Box::new(before_step)),
            line,
            ..PtyHooks::default()
        };
        let task = PtyBoard::spawn_with(board, u64::MAX, pacing, hooks)?;
        Ok(SimulatedBoard {
            task,
            dtr,
            dtr_works: fault != Some(SimFault::NoDtr),
        })
    }

    /// The pty's path.
    pub fn path(&self) -> &str {
        self.task.path()
    }

    /// Opens the pty like the board's port, its DTR wired to the simulated board.
    pub fn opener(&self) -> impl FnMut(&str) -> Result<Box<dyn CheckPort>, SerialError> {
        let dtr = Arc::clone(&self.dtr);
        let dtr_works = self.dtr_works;
        move |path| {
            let port = serial::open(path, READ_TIMEOUT)?;
            Ok(Box::new(SimPort {
                port,
                dtr: Arc::clone(&dtr),
                dtr_works,
            }) as Box<dyn CheckPort>)
        }
    }

    /// Stops the board and hands back its final state.
    pub fn finish(self) -> io::Result<PtyRun> {
        self.task.stop();
        self.task.join()
    }
}

/// The pty with the simulated DTR line.
struct SimPort {
    port: Box<dyn serialport::SerialPort>,
    dtr: Arc<AtomicBool>,
    dtr_works: bool,
}

impl Read for SimPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.port.read(buf)
    }
}

impl Write for SimPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.port.write(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.port.flush()
    }
}

impl CheckPort for SimPort {
    fn set_dtr(&mut self, on: bool) -> io::Result<()> {
        if !self.dtr_works {
            return Err(io::Error::other("the port has no modem control lines"));
        }
        self.dtr.store(on, Ordering::Relaxed);
        Ok(())
    }
}

impl Drop for SimPort {
    /// Closing a port drops DTR: the board stops sending. What it sent before is read here, so
    /// the pty can hang up without waiting for a reader.
    fn drop(&mut self) {
        self.dtr.store(false, Ordering::Relaxed);
        let mut buf = [0u8; 4096];
        let start = Instant::now();
        let mut quiet = 0;
        while quiet < 3 && start.elapsed() < Duration::from_secs(2) {
            match self.port.read(&mut buf) {
                Ok(n) if n > 0 => quiet = 0,
                Ok(_) => break,
                Err(e) if e.kind() == io::ErrorKind::TimedOut => quiet += 1,
                Err(_) => break,
            }
        }
    }
}

/// Re-encodes every frame of `bytes` (whole frames) as protocol `version`, CRC and COBS
/// included: a board flashed with another firmware.
fn rewrite_version(bytes: &mut Vec<u8>, version: u8) {
    let mut out = Vec::with_capacity(bytes.len());
    for frame in bytes.split(|&b| b == 0).filter(|f| !f.is_empty()) {
        let mut body = frame.to_vec();
        let Ok(n) = cobs::decode_in_place(&mut body) else {
            continue;
        };
        if n < 5 {
            continue;
        }
        let body = &mut body[..n];
        body[0] = version;
        let crc = crc32fast::hash(&body[..n - 4]);
        body[n - 4..].copy_from_slice(&crc.to_le_bytes());
        let mut encoded = vec![0u8; cobs::max_encoding_length(n)];
        let m = cobs::encode(body, &mut encoded);
        out.extend_from_slice(&encoded[..m]);
        out.push(0);
    }
    *bytes = out;
}
