//! The simulated board's hardware: INA226 register models on an I²C bus that implements
//! `embedded_hal::i2c::I2c`, so the firmware's driver and sampler run against it unchanged.
//!
//! The bus holds the simulation time ([`SimBus::set_time_us`]); every chip with power processes
//! the conversions that completed by then, each sampling its held analog input at that
//! conversion's time. Set a chip's inputs before moving the time past them.
//!
//! The bus also accounts the time its transactions would hold a real bus ([`I2cTiming`],
//! [`SimBus::bus_time_ns`]); that time is counted, not added to the simulation clock.

pub mod board;
pub mod ina226;
pub mod throughput;
pub mod world;

pub use ina226::{Analog, SimIna226};

use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use std::collections::BTreeMap;

/// How long transactions hold the bus, for [`SimBus::bus_time_ns`].
///
/// Model: every byte takes 9 SCL periods (8 bits and the ACK/NACK bit); the START, each
/// repeated START and the STOP take one SCL period each (in fast mode their setup and hold
/// times are 0.6 µs each and the bus-free time after a STOP is 1.3 µs, all within one 2.5 µs
/// period); no clock stretching (the INA226 does not stretch SCL). Adjacent operations of the
/// same direction form one frame (one address byte). A failed transaction costs its address
/// phase: START, address byte, STOP.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct I2cTiming {
    /// SCL clock [Hz].
    pub scl_hz: u32,
}

impl I2cTiming {
    /// Fast mode, 400 kHz: the fastest the STM32F411's I²C peripheral runs.
    pub const FAST_MODE: I2cTiming = I2cTiming { scl_hz: 400_000 };

    /// SCL periods a failed transaction holds the bus: START, address byte, STOP.
    pub const FAILED_TRANSACTION_BITS: u64 = 1 + 9 + 1;

    /// SCL periods a successful transaction of `operations` holds the bus (0 for none).
    pub fn transaction_bits(operations: &[Operation<'_>]) -> u64 {
        if operations.is_empty() {
            return 0;
        }
        let mut bits = 1; // STOP
        let mut previous_read = None;
        for op in operations {
            let (read, len) = match op {
                Operation::Read(buf) => (true, buf.len()),
                Operation::Write(bytes) => (false, bytes.len()),
            };
            if previous_read != Some(read) {
                bits += 1 + 9; // (repeated) START and the address byte
            }
            bits += 9 * len as u64;
            previous_read = Some(read);
        }
        bits
    }

    /// The duration of `bits` SCL periods [ns].
    pub fn bits_to_ns(&self, bits: u64) -> u64 {
        let ns = u128::from(bits) * 1_000_000_000 / u128::from(self.scl_hz.max(1));
        u64::try_from(ns).unwrap_or(u64::MAX)
    }
}

impl Default for I2cTiming {
    fn default() -> Self {
        Self::FAST_MODE
    }
}

/// Transaction counters of one address.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TransactionCounts {
    /// Transactions addressed to it (successful or not).
    pub transactions: u64,
    /// Of those, the ones that failed (NACK, injected fault).
    pub failed: u64,
}

/// One chip on the bus, with its power state and pending injected faults.
#[derive(Debug, Clone)]
struct Slot {
    chip: SimIna226,
    plugged: bool,
    /// Fail this many more transactions with this error.
    fault: Option<(u32, ErrorKind)>,
}

/// An I²C bus with INA226 models by 7-bit address, fault injection and counters.
#[derive(Debug, Clone, Default)]
pub struct SimBus {
    now_us: u64,
    chips: BTreeMap<u8, Slot>,
    counts: BTreeMap<u8, TransactionCounts>,
    timing: I2cTiming,
    /// SCL periods all transactions so far held the bus.
    bus_bits: u64,
}

impl SimBus {
    /// An empty bus at t = 0.
    pub fn new() -> Self {
        Self::default()
    }

    /// The board's bus: ideal chips at 0x40 (left) and 0x45 (right) on 5 mΩ shunts.
    pub fn board() -> Self {
        let mut bus = Self::new();
        bus.insert(0x40, SimIna226::new(Analog::IDEAL));
        bus.insert(0x45, SimIna226::new(Analog::IDEAL));
        bus
    }

    /// Puts `chip` at `address`, powered up now (power-on defaults; its analog front end and
    /// inputs are kept). Returns the chip it replaces.
    pub fn insert(&mut self, address: u8, mut chip: SimIna226) -> Option<SimIna226> {
        chip.power_on(self.now_us);
        self.chips
            .insert(
                address,
                Slot {
                    chip,
                    plugged: true,
                    fault: None,
                },
            )
            .map(|s| s.chip)
    }

    /// The simulation time [µs].
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    /// Moves the simulation time to `t_us` (never backwards) and lets every powered chip carry
    /// out the conversions that completed by then.
    pub fn set_time_us(&mut self, t_us: u64) {
        self.now_us = self.now_us.max(t_us);
        for slot in self.chips.values_mut() {
            if slot.plugged {
                slot.chip.advance_to(self.now_us);
            } else {
                slot.chip.prune_inputs(self.now_us);
            }
        }
    }

    /// Sets the true current [A] and bus voltage [V] of the chip at `address` from `t_us` on;
    /// false if there is no chip there.
    pub fn set_input(&mut self, address: u8, t_us: u64, current_a: f64, bus_v: f64) -> bool {
        match self.chips.get_mut(&address) {
            Some(slot) => {
                slot.chip.set_input(t_us, current_a, bus_v);
                true
            }
            None => false,
        }
    }

    /// The chip at `address` (plugged or not).
    pub fn chip(&self, address: u8) -> Option<&SimIna226> {
        self.chips.get(&address).map(|s| &s.chip)
    }

    /// The chip at `address`, mutably (plugged or not).
    pub fn chip_mut(&mut self, address: u8) -> Option<&mut SimIna226> {
        self.chips.get_mut(&address).map(|s| &mut s.chip)
    }

    /// A register of the chip at `address` as it stands at the bus time, without bus traffic or
    /// side effects; `None` if there is no powered chip there.
    pub fn peek(&mut self, address: u8, register: u8) -> Option<u16> {
        let now = self.now_us;
        let slot = self.chips.get_mut(&address).filter(|s| s.plugged)?;
        slot.chip.advance_to(now);
        Some(slot.chip.peek(register))
    }

    /// Disconnects the chip at `address` (it loses power and NACKs); false if there is none.
    pub fn unplug(&mut self, address: u8) -> bool {
        match self.chips.get_mut(&address) {
            Some(slot) => {
                slot.chip.advance_to(self.now_us);
                slot.plugged = false;
                true
            }
            None => false,
        }
    }

    /// Reconnects the chip at `address`: it powers up now with its defaults (a chip already
    /// plugged is left alone). False if there is none.
    pub fn plug(&mut self, address: u8) -> bool {
        match self.chips.get_mut(&address) {
            Some(slot) => {
                if !slot.plugged {
                    slot.plugged = true;
                    slot.chip.power_on(self.now_us);
                }
                true
            }
            None => false,
        }
    }

    /// Whether a powered chip answers at `address`.
    pub fn is_plugged(&self, address: u8) -> bool {
        self.chips.get(&address).is_some_and(|s| s.plugged)
    }

    /// Brown-out of the chip at `address`: its registers return to their power-on defaults now
    /// while its analog input keeps flowing. False if there is no powered chip there.
    pub fn brown_out(&mut self, address: u8) -> bool {
        match self.chips.get_mut(&address).filter(|s| s.plugged) {
            Some(slot) => {
                slot.chip.advance_to(self.now_us);
                slot.chip.power_on(self.now_us);
                true
            }
            None => false,
        }
    }

    /// Makes the next `count` transactions to `address` fail with `kind` without reaching the
    /// chip (e.g. `NoAcknowledge(Data)`, `Bus`, `ArbitrationLoss`); replaces any pending fault.
    /// A count of 0 cancels. An address without a chip NACKs every transaction anyway, so
    /// nothing is stored for it.
    pub fn fail_next(&mut self, address: u8, count: u32, kind: ErrorKind) {
        if let Some(slot) = self.chips.get_mut(&address) {
            slot.fault = (count > 0).then_some((count, kind));
        }
    }

    /// The bus timing model (400 kHz fast mode unless set).
    pub fn timing(&self) -> I2cTiming {
        self.timing
    }

    /// Sets the SCL clock the bus time is accounted at (kept for the transactions so far).
    pub fn set_timing(&mut self, timing: I2cTiming) {
        self.timing = timing;
    }

    /// SCL periods that all transactions so far held the bus ([`I2cTiming`]'s model).
    pub fn bus_bits(&self) -> u64 {
        self.bus_bits
    }

    /// Time all transactions so far held the bus at the current SCL clock [ns].
    pub fn bus_time_ns(&self) -> u64 {
        self.timing.bits_to_ns(self.bus_bits)
    }

    /// Transaction counters of `address` (zero if never addressed).
    pub fn counts(&self, address: u8) -> TransactionCounts {
        self.counts.get(&address).copied().unwrap_or_default()
    }

    /// Runs one transaction on the addressed slot.
    fn run(&mut self, address: u8, operations: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        let now = self.now_us;
        let Some(slot) = self.chips.get_mut(&address) else {
            return Err(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address));
        };
        if let Some((left, kind)) = slot.fault {
            slot.fault = (left > 1).then_some((left - 1, kind));
            return Err(kind);
        }
        if !slot.plugged {
            return Err(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address));
        }
        // Adjacent operations of the same kind form one frame (no repeated start between them).
        let mut write: Vec<u8> = Vec::new();
        let mut i = 0;
        while i < operations.len() {
            match &mut operations[i] {
                Operation::Write(bytes) => {
                    write.extend_from_slice(bytes);
                    if !matches!(operations.get(i + 1), Some(Operation::Write(_))) {
                        slot.chip.write_frame(now, &write);
                        write.clear();
                    }
                    i += 1;
                }
                Operation::Read(_) => {
                    // One read frame: the pointed register streamed across the adjacent buffers.
                    let mut j = i;
                    let mut total = 0;
                    while let Some(Operation::Read(buf)) = operations.get(j) {
                        total += buf.len();
                        j += 1;
                    }
                    let mut frame = vec![0u8; total];
                    slot.chip.read_frame(now, &mut frame);
                    let mut pos = 0;
                    for op in &mut operations[i..j] {
                        if let Operation::Read(buf) = op {
                            let n = buf.len();
                            buf.copy_from_slice(&frame[pos..pos + n]);
                            pos += n;
                        }
                    }
                    i = j;
                }
            }
        }
        Ok(())
    }
}

impl ErrorType for SimBus {
    type Error = ErrorKind;
}

impl I2c for SimBus {
    fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), Self::Error> {
        let result = self.run(address, operations);
        let bits = match result {
            Ok(()) => I2cTiming::transaction_bits(operations),
            Err(_) => I2cTiming::FAILED_TRANSACTION_BITS,
        };
        self.bus_bits = self.bus_bits.saturating_add(bits);
        let counts = self.counts.entry(address).or_default();
        counts.transactions = counts.transactions.saturating_add(1);
        if result.is_err() {
            counts.failed = counts.failed.saturating_add(1);
        }
        result
    }
}

#[cfg(test)]
mod tests;
