//! Bounded I²C1 master for the board (target only), replacing the transfers of the
//! stm32f4xx-hal 0.23 driver, which we still use to enable, reset and time the peripheral and to
//! set up PB8/PB9.
//!
//! Why not the HAL's transfers (read in `stm32f4xx-hal-0.23.0/src/i2c.rs`):
//! - every wait (`SB`, `BUSY`/`MSL`, `ADDR`, `TXE`, `BTF`, `RXNE`, `STOP`) spins without a
//!   timeout (its `Error::Timeout` is only the SMBus flag), so a slave holding SDA low hangs the
//!   sample task until the watchdog resets the board, and the next boot meets the same bus;
//! - a 2-byte read clears `ACK` only after byte 1 is read: preempted at that moment for more
//!   than a byte time (~20 µs at 400 kHz), byte 2 is ACKed and the INA226 keeps SDA low
//!   (stm32f4xx-hal PRs #91, #736).
//!
//! Here every transaction has a cycle-counted deadline (DWT `CYCCNT`, [`TRANSACTION_BUDGET_US`]);
//! when it passes, the peripheral is reset and the bus clocked free ([`crate::bus_recovery`]),
//! and the transaction fails with `ErrorKind::Bus` (wire `ChipFault::Bus`): a reported fault,
//! not a watchdog reset. Reads follow RM0383's I²C master receiver procedures (1 byte: ACK
//! cleared before ADDR is cleared; 2 bytes: POS, STOP set while BTF stretches SCL). Each
//! transaction also runs
//! in a critical section (≈120 µs for a register read at 400 kHz, at most the budget plus a
//! recovery): nothing can split a timing-sensitive step, and the deadline measures bus time
//! only. The USB interrupt waits at most that long; the OTG core NAKs the host meanwhile.
//!
//! `BERR` is cleared and ignored, as the HAL does (its comment cites an erratum: BERR can be
//! raised spuriously); a real bus error that breaks a transfer ends in the deadline.

use crate::bus_recovery::{self, BusLines, Recovery};
use cortex_m::peripheral::DWT;
use embedded_hal::i2c::{
    ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation, SevenBitAddress,
};
use stm32f4xx_hal::{i2c::I2c as HalI2c, pac};

/// Deadline of one transaction [µs]: a register read takes 120 µs at 400 kHz (48 SCL periods);
/// 1 ms is ~8× that. At the default 5 ms period a stuck transaction costs no sample; at 2 kHz it
/// costs two periods, which the sample task skips (its sequence stays continuous, the time gap
/// shows).
pub const TRANSACTION_BUDGET_US: u32 = 1_000;

/// Why a wait ended early.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Abort {
    /// The slave did not acknowledge its address or a data byte.
    Nack(NoAcknowledgeSource),
    ArbitrationLoss,
    Overrun,
    /// The deadline passed: the bus or the peripheral is stuck.
    Timeout,
}

/// The I²C1 master with bounded transactions.
pub struct BoundedI2c {
    i2c: pac::I2C1,
    /// CR2, CCR and TRISE as the HAL computed them, restored after a software reset.
    timing: (u16, u16, u16),
    budget_cycles: u32,
    sysclk_hz: u32,
    timeouts: u32,
    last_recovery: Option<Recovery>,
}

impl core::fmt::Debug for BoundedI2c {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("BoundedI2c")
            .field("timeouts", &self.timeouts)
            .finish_non_exhaustive()
    }
}

impl BoundedI2c {
    /// Takes over an I²C1 the HAL has set up (PB8 SCL, PB9 SDA, 400 kHz) and clocks the bus
    /// free: after a reset in the middle of a read an INA226 may still hold SDA low. Needs the
    /// DWT cycle counter running (`DCB::enable_trace`, `DWT::enable_cycle_counter`).
    pub fn new(hal: HalI2c<pac::I2C1>, sysclk_hz: u32) -> Self {
        // The pins stay in their alternate-function, open-drain mode (dropping the HAL's pin
        // types changes no register).
        let (i2c, _pins) = hal.release();
        let timing = (
            i2c.cr2().read().bits(),
            i2c.ccr().read().bits(),
            i2c.trise().read().bits(),
        );
        let mut bus = Self {
            i2c,
            timing,
            budget_cycles: sysclk_hz / 1_000_000 * TRANSACTION_BUDGET_US,
            sysclk_hz,
            timeouts: 0,
            last_recovery: None,
        };
        cortex_m::interrupt::free(|_| bus.reset_bus());
        bus
    }

    /// Transactions that ran out of time (each followed by a bus reset).
    pub fn timeouts(&self) -> u32 {
        self.timeouts
    }

    /// What the latest bus reset found (at init, then after each timeout).
    pub fn last_recovery(&self) -> Option<Recovery> {
        self.last_recovery
    }

    /// Clocks the bus free on the pins as GPIO, then resets the peripheral (it may have latched
    /// BUSY from the garbage) and restores its timing.
    fn reset_bus(&mut self) {
        self.i2c.cr1().modify(|_, w| w.pe().clear_bit());
        let recovery = bus_recovery::recover(&mut Pb8Pb9::take(self.sysclk_hz));
        self.last_recovery = Some(recovery);
        self.i2c.cr1().write(|w| w.swrst().set_bit());
        self.i2c.cr1().write(|w| w.swrst().clear_bit());
        self.restore_timing();
        self.i2c.cr1().write(|w| w.pe().set_bit());
    }

    #[allow(unsafe_code)]
    fn restore_timing(&self) {
        let (cr2, ccr, trise) = self.timing;
        // SAFETY: the very values the HAL computed and wrote at init (read back from these
        // registers), written again after the software reset cleared them.
        unsafe {
            self.i2c.cr2().write(|w| w.bits(cr2));
            self.i2c.ccr().write(|w| w.bits(ccr));
            self.i2c.trise().write(|w| w.bits(trise));
        }
    }

    /// Waits until `ready(SR1)` within the transaction's deadline, reporting error flags.
    fn wait(&self, start: u32, ready: impl Fn(&pac::i2c1::sr1::R) -> bool) -> Result<(), Abort> {
        loop {
            let sr1 = self.i2c.sr1().read();
            if sr1.af().bit_is_set() {
                self.i2c.sr1().modify(|_, w| w.af().clear_bit());
                return Err(Abort::Nack(NoAcknowledgeSource::Unknown));
            }
            if sr1.arlo().bit_is_set() {
                self.i2c.sr1().modify(|_, w| w.arlo().clear_bit());
                return Err(Abort::ArbitrationLoss);
            }
            if sr1.ovr().bit_is_set() {
                self.i2c.sr1().modify(|_, w| w.ovr().clear_bit());
                return Err(Abort::Overrun);
            }
            if sr1.berr().bit_is_set() {
                self.i2c.sr1().modify(|_, w| w.berr().clear_bit());
            }
            if ready(&sr1) {
                return Ok(());
            }
            if DWT::cycle_count().wrapping_sub(start) > self.budget_cycles {
                return Err(Abort::Timeout);
            }
        }
    }

    /// START (or repeated START) and the address byte; returns with ADDR still set (SCL
    /// stretched) so the caller can program ACK/POS for a read before clearing it.
    fn address(&self, start: u32, address: u8, read: bool) -> Result<(), Abort> {
        self.i2c.cr1().modify(|_, w| w.start().set_bit());
        self.wait(start, |sr1| sr1.sb().bit_is_set())?;
        self.i2c
            .dr()
            .write(|w| w.dr().set((address << 1) | u8::from(read)));
        self.wait(start, |sr1| sr1.addr().bit_is_set())
            .map_err(|e| nack_in(e, NoAcknowledgeSource::Address))
    }

    /// Clears ADDR (read SR1 then SR2).
    fn clear_addr(&self) {
        let _ = self.i2c.sr1().read();
        let _ = self.i2c.sr2().read();
    }

    fn write_bytes(&self, start: u32, bytes: &[u8]) -> Result<(), Abort> {
        if bytes.is_empty() {
            // An address-only write (a probe): no byte, so no BTF to wait for.
            return Ok(());
        }
        let data_nack = |e| nack_in(e, NoAcknowledgeSource::Data);
        for &b in bytes {
            self.wait(start, |sr1| sr1.tx_e().bit_is_set())
                .map_err(data_nack)?;
            self.i2c.dr().write(|w| w.dr().set(b));
        }
        // Every byte on the wire (and ACKed) before a STOP or repeated START.
        self.wait(start, |sr1| sr1.btf().bit_is_set())
            .map_err(data_nack)
    }

    /// Receives `buf` after the address phase; sets STOP before the last byte completes.
    fn read_bytes(&self, start: u32, buf: &mut [u8]) -> Result<(), Abort> {
        match buf {
            [] => {
                self.clear_addr();
                self.i2c.cr1().modify(|_, w| w.stop().set_bit());
                Ok(())
            }
            [only] => {
                // NACK the only byte; ADDR still stretches SCL, so this is in time.
                self.i2c.cr1().modify(|_, w| w.ack().clear_bit());
                self.clear_addr();
                self.i2c.cr1().modify(|_, w| w.stop().set_bit());
                self.wait(start, |sr1| sr1.rx_ne().bit_is_set())?;
                *only = self.i2c.dr().read().dr().bits();
                Ok(())
            }
            [first, second] => {
                // POS: the cleared ACK applies to the byte after the one being received, i.e.
                // byte 2 is NACKed whatever the timing.
                self.i2c
                    .cr1()
                    .modify(|_, w| w.ack().clear_bit().pos().set_bit());
                self.clear_addr();
                // BTF: byte 1 in DR, byte 2 in the shift register, SCL stretched.
                self.wait(start, |sr1| sr1.btf().bit_is_set())?;
                self.i2c.cr1().modify(|_, w| w.stop().set_bit());
                *first = self.i2c.dr().read().dr().bits();
                *second = self.i2c.dr().read().dr().bits();
                self.i2c.cr1().modify(|_, w| w.pos().clear_bit());
                Ok(())
            }
            longer => {
                self.i2c.cr1().modify(|_, w| w.ack().set_bit());
                self.clear_addr();
                let n = longer.len();
                for byte in &mut longer[..n - 3] {
                    self.wait(start, |sr1| sr1.rx_ne().bit_is_set())?;
                    *byte = self.i2c.dr().read().dr().bits();
                }
                // N−2 in DR, N−1 in the shift register: NACK the last one, then STOP.
                self.wait(start, |sr1| sr1.btf().bit_is_set())?;
                self.i2c.cr1().modify(|_, w| w.ack().clear_bit());
                longer[n - 3] = self.i2c.dr().read().dr().bits();
                self.wait(start, |sr1| sr1.btf().bit_is_set())?;
                self.i2c.cr1().modify(|_, w| w.stop().set_bit());
                longer[n - 2] = self.i2c.dr().read().dr().bits();
                self.wait(start, |sr1| sr1.rx_ne().bit_is_set())?;
                longer[n - 1] = self.i2c.dr().read().dr().bits();
                Ok(())
            }
        }
    }

    /// Runs the operations: consecutive writes share one address phase, each change of
    /// direction is a repeated START, and the last operation ends with STOP.
    fn run(&self, start: u32, address: u8, ops: &mut [Operation<'_>]) -> Result<(), Abort> {
        let mut previous_read = None;
        let count = ops.len();
        for (k, op) in ops.iter_mut().enumerate() {
            let last = k + 1 == count;
            match op {
                Operation::Write(bytes) => {
                    if previous_read != Some(false) {
                        self.address(start, address, false)?;
                        self.clear_addr();
                    }
                    self.write_bytes(start, bytes)?;
                    if last {
                        self.i2c.cr1().modify(|_, w| w.stop().set_bit());
                    }
                    previous_read = Some(false);
                }
                Operation::Read(buf) => {
                    // Adjacent reads would be one transfer with the NACK at the very end; the
                    // drivers here never issue them.
                    if previous_read == Some(true) || !last {
                        return Err(Abort::Overrun);
                    }
                    self.address(start, address, true)?;
                    self.read_bytes(start, buf)?;
                    previous_read = Some(true);
                }
            }
        }
        // The STOP has gone out before the next START may be requested.
        self.wait(start, |_| self.i2c.cr1().read().stop().bit_is_clear())
    }
}

impl ErrorType for BoundedI2c {
    type Error = ErrorKind;
}

impl I2c<SevenBitAddress> for BoundedI2c {
    fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        cortex_m::interrupt::free(|_| {
            let start = DWT::cycle_count();
            self.i2c
                .cr1()
                .modify(|_, w| w.ack().clear_bit().pos().clear_bit());
            match self.run(start, address, ops) {
                Ok(()) => Ok(()),
                Err(Abort::Nack(source)) => {
                    // Release the bus; a NACKed address is an absent chip, not a stuck bus. The
                    // STOP gets its own deadline (the NACK may have come late in this one).
                    self.i2c.cr1().modify(|_, w| w.stop().set_bit());
                    let stop_start = DWT::cycle_count();
                    if self
                        .wait(stop_start, |_| self.i2c.cr1().read().stop().bit_is_clear())
                        .is_err()
                    {
                        self.timeouts = self.timeouts.saturating_add(1);
                        self.reset_bus();
                    }
                    Err(ErrorKind::NoAcknowledge(source))
                }
                Err(Abort::ArbitrationLoss) => {
                    // Single-master bus: arbitration lost means a glitch; start clean.
                    self.reset_bus();
                    Err(ErrorKind::ArbitrationLoss)
                }
                Err(Abort::Overrun) => {
                    self.reset_bus();
                    Err(ErrorKind::Overrun)
                }
                Err(Abort::Timeout) => {
                    self.timeouts = self.timeouts.saturating_add(1);
                    self.reset_bus();
                    Err(ErrorKind::Bus)
                }
            }
        })
    }
}

/// A NACK seen while waiting in the address or data phase.
fn nack_in(abort: Abort, source: NoAcknowledgeSource) -> Abort {
    match abort {
        Abort::Nack(_) => Abort::Nack(source),
        other => other,
    }
}

/// PB8 (SCL) and PB9 (SDA) as open-drain GPIO outputs for the length of a bus recovery; back
/// to their I²C alternate function when dropped.
struct Pb8Pb9 {
    gpio: &'static pac::gpiob::RegisterBlock,
    half_period_cycles: u32,
}

impl Pb8Pb9 {
    fn take(sysclk_hz: u32) -> Self {
        // SAFETY: PB8/PB9 belong to I2C1, which this driver owns; BSRR writes are atomic, and
        // MODER is read-modified-written only here, inside a critical section, after init set up
        // every GPIOB pin (nothing else changes GPIOB modes at run time). The HAL already made
        // both pins open-drain (OTYPER), with AF4 selected (AFRH), which mode changes keep.
        #[allow(unsafe_code)]
        let gpio: &'static pac::gpiob::RegisterBlock = unsafe { &*pac::GPIOB::ptr() };
        gpio.bsrr().write(|w| w.bs8().set_bit().bs9().set_bit());
        gpio.moder()
            .modify(|_, w| w.moder8().output().moder9().output());
        Self {
            gpio,
            half_period_cycles: sysclk_hz / 200_000,
        }
    }
}

impl Drop for Pb8Pb9 {
    fn drop(&mut self) {
        self.gpio
            .moder()
            .modify(|_, w| w.moder8().alternate().moder9().alternate());
    }
}

impl BusLines for Pb8Pb9 {
    fn set_scl(&mut self, high: bool) {
        self.gpio.bsrr().write(|w| {
            if high {
                w.bs8().set_bit()
            } else {
                w.br8().set_bit()
            }
        });
    }

    fn set_sda(&mut self, high: bool) {
        self.gpio.bsrr().write(|w| {
            if high {
                w.bs9().set_bit()
            } else {
                w.br9().set_bit()
            }
        });
    }

    fn sda_is_high(&mut self) -> bool {
        self.gpio.idr().read().idr9().bit_is_set()
    }

    fn half_period(&mut self) {
        cortex_m::asm::delay(self.half_period_cycles);
    }
}
