//! One I²C master transfer on the STM32F4's I²C peripheral (RM0383 §18.3.3 "I2C master mode"),
//! driven by its interrupts: what the handler does at each event. It is independent of the
//! chip, so it is tested on the host against a fake peripheral; the board's glue (`stm32_i2c`)
//! maps [`Registers`] onto I2C1 and calls [`Master::on_interrupt`] from the I2C1_EV and I2C1_ER
//! handlers.
//!
//! A transfer is what our drivers issue: an optional write (register pointer, or pointer and
//! value) and an optional read, joined by a repeated START, ended by STOP. The handler keeps
//! SCL stretched wherever the reference manual's sequences need a decision (SB, ADDR, BTF), so
//! its latency only slows the bus, never corrupts a byte; it runs above every task that touches
//! the bus, so its steps cannot be split. [`AwaitedBus`] is the task's side: an
//! `embedded_hal_async` bus that starts a transfer, awaits its end under a deadline, and has the
//! bus reset after a failure that needs it; the board supplies the lock, the clock and the reset
//! ([`Port`], [`Clock`]). Reads follow RM0383's master receiver procedures:
//! - 1 byte: ACK cleared before ADDR is cleared, STOP right after (EV6_3);
//! - 2 bytes: ACK cleared and POS set before ADDR is cleared, so the NACK falls on byte 2
//!   whatever the latency; at BTF (byte 1 in DR, byte 2 in the shift register, NACKed) STOP,
//!   then DR twice;
//! - N > 2: RXNE per byte until three remain; at BTF (N−2 in DR, N−1 in the shift register)
//!   ACK cleared and N−2 read, so byte N is NACKed; at the next BTF STOP, then DR twice.
//!
//! Errors: AF (no acknowledge: of the address, or of a data byte) ends the transfer with STOP;
//! ARLO (arbitration lost; the peripheral has dropped to slave mode) and OVR end it and ask for a
//! bus reset. BERR is cleared and counted, and the transfer goes on: the STM32F411 errata sheet
//! (ES0287, I2C "spurious bus error detection in master mode") says a master's BERR can be
//! raised wrongly and has no effect on the transfer, so the workaround is to clear it and go on
//! (as the HAL does); a real bus error that breaks the transfer ends in the caller's deadline
//! ([`Master::abort`], then a bus reset), and BERR raised again and again in
//! [`Failure::Stalled`].

use core::future::{poll_fn, Future};
use core::task::{Poll, Waker};
use embedded_hal::i2c::{ErrorKind, ErrorType, NoAcknowledgeSource, Operation};

/// Longest write of one transfer [bytes] (our drivers write at most a pointer and a register).
pub const MAX_WRITE: usize = 8;
/// Longest read of one transfer [bytes].
pub const MAX_READ: usize = 8;
/// Interrupts in a row that find nothing to do (or only a BERR to clear) before the transfer
/// is given up as stalled (a flag the handler cannot clear would otherwise hold the CPU in the
/// handler). A few are
/// normal: BTF stays set for the microseconds until a repeated START goes out.
pub const MAX_IDLE_INTERRUPTS: u8 = 64;

/// The status register 1 (RM0383 §18.6.6), as read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Sr1(pub u16);

impl Sr1 {
    /// START generated.
    pub const SB: u16 = 1 << 0;
    /// Address sent and acknowledged (SCL stretched until cleared).
    pub const ADDR: u16 = 1 << 1;
    /// Byte transfer finished (DR and shift register both full or both empty; SCL stretched).
    pub const BTF: u16 = 1 << 2;
    pub const RXNE: u16 = 1 << 6;
    pub const TXE: u16 = 1 << 7;
    /// Misplaced START or STOP.
    pub const BERR: u16 = 1 << 8;
    /// Arbitration lost.
    pub const ARLO: u16 = 1 << 9;
    /// Acknowledge failure.
    pub const AF: u16 = 1 << 10;
    /// Overrun/underrun.
    pub const OVR: u16 = 1 << 11;

    pub fn has(self, flag: u16) -> bool {
        self.0 & flag != 0
    }
}

/// The register operations the handler needs (on the board: I2C1's CR1, CR2, SR1, SR2, DR).
pub trait Registers {
    /// Reads SR1 (the first half of clearing SB, ADDR and BTF).
    fn sr1(&mut self) -> Sr1;
    /// Reads SR2: after an SR1 read, clears ADDR.
    fn read_sr2(&mut self);
    /// Clears these error flags of SR1 (they are cleared by writing 0).
    fn clear_sr1(&mut self, flags: u16);
    fn write_dr(&mut self, byte: u8);
    fn read_dr(&mut self) -> u8;
    /// Sets CR1.START: a START, or a repeated START after the current byte.
    fn start(&mut self);
    /// Sets CR1.STOP: a STOP after the current byte.
    fn stop(&mut self);
    /// CR1.STOP is still set: the STOP has not gone out, and CR1 must not be written yet.
    fn stop_pending(&mut self) -> bool;
    /// CR1.ACK and CR1.POS.
    fn set_ack_pos(&mut self, ack: bool, pos: bool);
    /// CR2: event and error interrupts (`on`), and buffer interrupts (TXE/RXNE) on top.
    fn set_interrupts(&mut self, on: bool, buffer: bool);
}

/// The previous STOP is still going out, or the previous transfer is still under way (its
/// awaiting future was dropped): retry in a few microseconds; the deadline bounds the wait.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Busy;

/// Why a transfer failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failure {
    /// Not acknowledged: the address (no such chip) or a data byte.
    Nack(NoAcknowledgeSource),
    ArbitrationLoss,
    Overrun,
    /// Interrupts kept coming with nothing to do ([`MAX_IDLE_INTERRUPTS`]).
    Stalled,
    /// The caller's deadline passed ([`Master::abort`]).
    Timeout,
    /// Operations this master does not carry out ([`Transfer::new`]); nothing was sent.
    Unsupported,
}

impl Failure {
    /// The embedded-hal error (the sampler maps it onto the wire's `ChipFault`).
    pub fn kind(self) -> ErrorKind {
        match self {
            Failure::Nack(source) => ErrorKind::NoAcknowledge(source),
            Failure::ArbitrationLoss => ErrorKind::ArbitrationLoss,
            Failure::Overrun => ErrorKind::Overrun,
            Failure::Stalled | Failure::Timeout => ErrorKind::Bus,
            Failure::Unsupported => ErrorKind::Other,
        }
    }

    /// Whether the peripheral must be reset and the bus clocked free before the next transfer:
    /// everything but a NACK, after which the handler has already sent a STOP (and a request
    /// that never reached the bus).
    pub fn needs_bus_reset(self) -> bool {
        !matches!(self, Failure::Nack(_) | Failure::Unsupported)
    }
}

/// What a transfer is asked to do, copied out of the caller's operations (the interrupt handler
/// cannot borrow them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Transfer {
    address: u8,
    write: [u8; MAX_WRITE],
    write_len: usize,
    read_len: usize,
}

impl Transfer {
    /// The transfer for embedded-hal operations: writes (sent as one), then at most one read,
    /// last. Other shapes, or more than [`MAX_WRITE`]/[`MAX_READ`] bytes, are
    /// [`Failure::Unsupported`] (no driver here issues them). No operation at all, or only empty
    /// ones, is an address probe.
    pub fn new(address: u8, ops: &[Operation<'_>]) -> Result<Self, Failure> {
        let mut transfer = Transfer {
            address,
            write: [0; MAX_WRITE],
            write_len: 0,
            read_len: 0,
        };
        for op in ops {
            match op {
                Operation::Write(bytes) => {
                    let end = transfer.write_len + bytes.len();
                    if transfer.read_len > 0 || end > MAX_WRITE {
                        return Err(Failure::Unsupported);
                    }
                    transfer.write[transfer.write_len..end].copy_from_slice(bytes);
                    transfer.write_len = end;
                }
                Operation::Read(buf) => {
                    if transfer.read_len > 0 || buf.len() > MAX_READ {
                        return Err(Failure::Unsupported);
                    }
                    transfer.read_len = buf.len();
                }
            }
        }
        Ok(transfer)
    }

    /// Copies the bytes read into the operations' read buffer.
    pub fn copy_out(&self, received: &Received, ops: &mut [Operation<'_>]) {
        for op in ops {
            if let Operation::Read(buf) = op {
                buf.copy_from_slice(&received.bytes[..buf.len()]);
            }
        }
    }

    fn writes(&self) -> bool {
        self.write_len > 0 || self.read_len == 0
    }
}

/// The bytes a finished transfer read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Received {
    bytes: [u8; MAX_READ],
    len: usize,
}

impl Received {
    pub fn bytes(&self) -> &[u8] {
        &self.bytes[..self.len]
    }
}

/// Where the transfer is: the event each phase waits for is in its doc.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Idle,
    /// START requested: SB.
    Start {
        read: bool,
    },
    /// Address byte in DR: ADDR (or AF).
    Address {
        read: bool,
    },
    /// Byte `next` goes into DR at the next TXE.
    Writing {
        next: usize,
    },
    /// Every byte is in DR: BTF once the last one is acknowledged, then STOP or repeated START.
    WriteDone,
    /// N > 2: byte `next` is read at the next RXNE, until three remain.
    Receiving {
        next: usize,
    },
    /// Three remain: BTF (N−2 in DR, N−1 in the shift register).
    ThirdLast,
    /// Two remain: BTF (N−1 in DR, N in the shift register, NACKed).
    LastTwo,
    /// One byte, NACKed, STOP requested: RXNE.
    LastByte,
    Done(Result<Received, Failure>),
}

/// The transfer state shared by the interrupt handler and the task awaiting it.
#[derive(Debug)]
pub struct Master {
    transfer: Transfer,
    phase: Phase,
    received: Received,
    waker: Option<Waker>,
    idle_interrupts: u8,
    bus_errors: u32,
}

impl Default for Master {
    fn default() -> Self {
        Self::new()
    }
}

impl Master {
    pub const fn new() -> Self {
        Self {
            transfer: Transfer {
                address: 0,
                write: [0; MAX_WRITE],
                write_len: 0,
                read_len: 0,
            },
            phase: Phase::Idle,
            received: Received {
                bytes: [0; MAX_READ],
                len: 0,
            },
            waker: None,
            idle_interrupts: 0,
            bus_errors: 0,
        }
    }

    /// BERR flags cleared and ignored so far (see the module doc).
    pub fn bus_errors(&self) -> u32 {
        self.bus_errors
    }

    /// Whether a transfer is under way (started, not yet taken by [`Self::poll`]).
    pub fn busy(&self) -> bool {
        !matches!(self.phase, Phase::Idle)
    }

    /// Starts `transfer` with a START; its end comes through [`Self::poll`]. [`Busy`] while the
    /// previous transfer's STOP is still going out (CR1 must not be written until it has), or
    /// while a transfer nobody awaits any more is still running: a START then would cut it off
    /// mid-byte and the handler would take its events for the new one's.
    pub fn begin<R: Registers>(&mut self, regs: &mut R, transfer: Transfer) -> Result<(), Busy> {
        if self.in_flight() || regs.stop_pending() {
            return Err(Busy);
        }
        self.transfer = transfer;
        self.received = Received {
            bytes: [0; MAX_READ],
            len: transfer.read_len,
        };
        self.idle_interrupts = 0;
        self.phase = Phase::Start {
            read: !transfer.writes(),
        };
        regs.set_ack_pos(false, false);
        regs.set_interrupts(true, false);
        regs.start();
        Ok(())
    }

    /// Started and not yet ended by the handler (a finished transfer's result may still wait).
    fn in_flight(&self) -> bool {
        !matches!(self.phase, Phase::Idle | Phase::Done(_))
    }

    /// The transfer's end, once the handler has reached it; until then `waker` is woken at the
    /// end.
    pub fn poll(&mut self, waker: &Waker) -> Poll<Result<Received, Failure>> {
        match self.phase {
            Phase::Done(result) => {
                self.phase = Phase::Idle;
                self.waker = None;
                Poll::Ready(result)
            }
            // Nothing started (or it was aborted): nothing will end.
            Phase::Idle => Poll::Ready(Err(Failure::Stalled)),
            _ => {
                if !self.waker.as_ref().is_some_and(|w| w.will_wake(waker)) {
                    self.waker = Some(waker.clone());
                }
                Poll::Pending
            }
        }
    }

    /// The deadline passed: interrupts off, the transfer forgotten. The caller resets the bus.
    pub fn abort<R: Registers>(&mut self, regs: &mut R) {
        regs.set_interrupts(false, false);
        self.phase = Phase::Idle;
        self.waker = None;
    }

    /// The I2C event and error interrupt handler.
    pub fn on_interrupt<R: Registers>(&mut self, regs: &mut R) {
        let sr1 = regs.sr1();
        if sr1.has(Sr1::BERR) {
            regs.clear_sr1(Sr1::BERR);
            self.bus_errors = self.bus_errors.saturating_add(1);
        }
        if let Some(failure) = self.error_in(sr1) {
            regs.clear_sr1(sr1.0 & (Sr1::AF | Sr1::ARLO | Sr1::OVR));
            // After ARLO the peripheral is a slave and has let go of the bus: no STOP.
            if failure != Failure::ArbitrationLoss {
                regs.stop();
            }
            self.finish(regs, Err(failure));
            return;
        }
        // A BERR alone is no progress either: BERR raised again and again (noise making
        // START/STOP conditions on the lines) must end in `Stalled`, not hold the CPU here.
        if self.step(regs, sr1) {
            self.idle_interrupts = 0;
        } else if !self.in_flight() {
            // A leftover request after the end: nothing is waiting for it.
            regs.set_interrupts(false, false);
        } else {
            self.idle_interrupts = self.idle_interrupts.saturating_add(1);
            if self.idle_interrupts >= MAX_IDLE_INTERRUPTS {
                // No CR1.STOP: stalled waiting for SB, START is still pending, and RM0383
                // forbids writing CR1 then (a second START or STOP may follow). The bus reset
                // every stall gets sends the STOP from the pins.
                self.finish(regs, Err(Failure::Stalled));
            }
        }
    }

    /// An error flag that ends the transfer.
    fn error_in(&self, sr1: Sr1) -> Option<Failure> {
        if !self.in_flight() {
            return None;
        }
        if sr1.has(Sr1::ARLO) {
            Some(Failure::ArbitrationLoss)
        } else if sr1.has(Sr1::AF) {
            Some(Failure::Nack(match self.phase {
                Phase::Address { .. } => NoAcknowledgeSource::Address,
                Phase::Writing { .. } | Phase::WriteDone => NoAcknowledgeSource::Data,
                _ => NoAcknowledgeSource::Unknown,
            }))
        } else if sr1.has(Sr1::OVR) {
            Some(Failure::Overrun)
        } else {
            None
        }
    }

    /// Takes the step the phase waits for, if `sr1` shows its event; whether it did.
    fn step<R: Registers>(&mut self, regs: &mut R, sr1: Sr1) -> bool {
        let t = self.transfer;
        let n = t.read_len;
        self.phase = match self.phase {
            Phase::Start { read } if sr1.has(Sr1::SB) => {
                // SR1 was read: writing DR clears SB.
                regs.write_dr((t.address << 1) | u8::from(read));
                Phase::Address { read }
            }
            Phase::Address { read: false } if sr1.has(Sr1::ADDR) => {
                regs.read_sr2();
                match t.write_len {
                    0 => return self.stop_and_finish(regs),
                    1 => {
                        regs.write_dr(t.write[0]);
                        Phase::WriteDone
                    }
                    _ => {
                        // DR and shift register are empty (EV8_1): the first byte goes now,
                        // the rest at each TXE.
                        regs.write_dr(t.write[0]);
                        regs.set_interrupts(true, true);
                        Phase::Writing { next: 1 }
                    }
                }
            }
            Phase::Writing { next } if sr1.has(Sr1::TXE) => {
                regs.write_dr(t.write[next]);
                if next + 1 == t.write_len {
                    regs.set_interrupts(true, false);
                    Phase::WriteDone
                } else {
                    Phase::Writing { next: next + 1 }
                }
            }
            Phase::WriteDone if sr1.has(Sr1::BTF) => {
                if n == 0 {
                    return self.stop_and_finish(regs);
                }
                regs.start();
                Phase::Start { read: true }
            }
            Phase::Address { read: true } if sr1.has(Sr1::ADDR) => self.address_read(regs),
            Phase::Receiving { next } if sr1.has(Sr1::RXNE) => {
                self.received.bytes[next] = regs.read_dr();
                if n - (next + 1) == 3 {
                    regs.set_interrupts(true, false);
                    Phase::ThirdLast
                } else {
                    Phase::Receiving { next: next + 1 }
                }
            }
            Phase::ThirdLast if sr1.has(Sr1::BTF) => {
                // Byte N−1 waits in the shift register with SCL stretched: clearing ACK now
                // NACKs byte N, which reading N−2 lets in.
                regs.set_ack_pos(false, false);
                self.received.bytes[n - 3] = regs.read_dr();
                Phase::LastTwo
            }
            Phase::LastTwo if sr1.has(Sr1::BTF) => {
                regs.stop();
                self.received.bytes[n - 2] = regs.read_dr();
                self.received.bytes[n - 1] = regs.read_dr();
                Phase::Done(Ok(self.received))
            }
            Phase::LastByte if sr1.has(Sr1::RXNE) => {
                self.received.bytes[0] = regs.read_dr();
                Phase::Done(Ok(self.received))
            }
            _ => return false,
        };
        if let Phase::Done(result) = self.phase {
            self.finish(regs, result);
        }
        true
    }

    /// ADDR of the read phase: program ACK/POS for the length while SCL is stretched, then
    /// clear ADDR.
    fn address_read<R: Registers>(&mut self, regs: &mut R) -> Phase {
        match self.transfer.read_len {
            1 => {
                regs.set_ack_pos(false, false);
                regs.read_sr2();
                regs.stop();
                regs.set_interrupts(true, true);
                Phase::LastByte
            }
            2 => {
                regs.set_ack_pos(false, true);
                regs.read_sr2();
                Phase::LastTwo
            }
            3 => {
                regs.set_ack_pos(true, false);
                regs.read_sr2();
                Phase::ThirdLast
            }
            _ => {
                regs.set_ack_pos(true, false);
                regs.read_sr2();
                regs.set_interrupts(true, true);
                Phase::Receiving { next: 0 }
            }
        }
    }

    fn stop_and_finish<R: Registers>(&mut self, regs: &mut R) -> bool {
        regs.stop();
        self.finish(regs, Ok(self.received));
        true
    }

    fn finish<R: Registers>(&mut self, regs: &mut R, result: Result<Received, Failure>) {
        regs.set_interrupts(false, false);
        self.phase = Phase::Done(result);
        if let Some(waker) = self.waker.take() {
            waker.wake();
        }
    }
}

/// The board's side of [`AwaitedBus`]: the state the interrupt handlers share, and the bus reset.
pub trait Port {
    type Regs: Registers;
    /// Runs `f` with the interrupt handlers held off.
    fn lock<R>(&mut self, f: impl FnOnce(&mut Master, &mut Self::Regs) -> R) -> R;
    /// Resets the peripheral and clocks the bus free after `failure` (the handlers are held off
    /// only for the register writes).
    fn reset_bus(&mut self, failure: Failure) -> impl Future<Output = ()>;
}

/// Time for [`AwaitedBus`]: each transfer's deadline.
pub trait Clock {
    type Deadline: Copy;
    /// The deadline of a transfer starting now.
    fn deadline(&self) -> Self::Deadline;
    fn passed(&self, deadline: Self::Deadline) -> bool;
    /// Waits a few microseconds (a STOP going out).
    fn pause(&self) -> impl Future<Output = ()>;
    /// `end`'s output, or `None` when the deadline comes first.
    fn until<F: Future>(
        &self,
        deadline: Self::Deadline,
        end: F,
    ) -> impl Future<Output = Option<F::Output>>;
}

/// The interrupt-driven master as an `embedded_hal_async` bus: each transaction starts the
/// transfer, awaits the handler's end of it, or the deadline, then the transfer is aborted; a
/// failure that needs it resets the bus before the error is returned.
#[derive(Debug)]
pub struct AwaitedBus<P, C> {
    pub port: P,
    pub clock: C,
}

impl<P: Port, C: Clock> AwaitedBus<P, C> {
    async fn run(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), Failure> {
        let transfer = Transfer::new(address, ops)?;
        let Self { port, clock } = self;
        let deadline = clock.deadline();
        // The previous STOP goes out within microseconds; CR1 must not be written before.
        while port
            .lock(|master, regs| master.begin(regs, transfer))
            .is_err()
        {
            if clock.passed(deadline) {
                return Err(Failure::Timeout);
            }
            clock.pause().await;
        }
        let end = poll_fn(|cx| port.lock(|master, _| master.poll(cx.waker())));
        match clock.until(deadline, end).await {
            Some(Ok(received)) => {
                transfer.copy_out(&received, ops);
                Ok(())
            }
            Some(Err(failure)) => Err(failure),
            None => {
                port.lock(|master, regs| master.abort(regs));
                Err(Failure::Timeout)
            }
        }
    }
}

impl<P, C> ErrorType for AwaitedBus<P, C> {
    type Error = ErrorKind;
}

impl<P: Port, C: Clock> embedded_hal_async::i2c::I2c for AwaitedBus<P, C> {
    async fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), ErrorKind> {
        let result = self.run(address, operations).await;
        if let Err(failure) = result {
            if failure.needs_bus_reset() {
                self.port.reset_bus(failure).await;
            }
        }
        result.map_err(Failure::kind)
    }
}

#[cfg(test)]
mod fake;
#[cfg(test)]
mod tests;
