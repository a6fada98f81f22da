//! A behavioural model of the STM32F4 I²C master (RM0383 §18.3.3) and the bus behind it, for
//! the transfer state machine's tests. The hardware moves one bus event per [`Fake::step`] and
//! stretches SCL wherever the real one does (SB, ADDR, BTF, TXE with nothing to send), so a
//! test can let it run ahead of the handler (interrupt latency) and see that the bytes on the
//! wire stay right. Slaves are register files (as the INA226): a write sets the pointer and
//! optionally a 16-bit register; a read returns the pointed register big-endian, then 0xFF.
//!
//! What the model checks: CR1 written while STOP or START is pending (forbidden by RM0383), DR
//! read empty or written full. ACK: without POS a received byte is ACKed if CR1.ACK is set when it
//! completes; with POS, if ACK was set when the byte before it completed (the 2-byte
//! procedure's "ACK controls the next byte").
//!
//! What it assumes, like the handler it tests (read against RM0383 and ST's interrupt driver,
//! not checked on silicon): the bus stands still while the handler runs (on the chip it moves
//! on, which matters only for steps RM0383 wants done before the current byte ends: STOP after
//! ADDR for 1 byte, ACK cleared at N−2, DR read after STOP; the handler takes ~1.5 µs of a
//! 22.5 µs byte at the top priority); TxE is set the moment ADDR is cleared (EV8_1), so the
//! first byte may go into DR at once; with POS, the byte right after ADDR is ACKed whatever
//! ACK is (ST's `I2C_Master_ADDR` clears ACK and sets POS before clearing ADDR); a BERR
//! changes nothing (ES0287).

use super::{Registers, Sr1};
use std::collections::BTreeMap;

/// What happened on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wire {
    Start,
    Address {
        byte: u8,
        acked: bool,
    },
    /// A data byte and whether its receiver acknowledged it.
    Byte {
        byte: u8,
        acked: bool,
    },
    Stop,
}

/// A register-file slave.
#[derive(Debug, Clone, Default)]
pub struct Slave {
    pub pointer: u8,
    pub registers: BTreeMap<u8, u16>,
    /// NACKs the data byte with this index (0: the pointer) of every write.
    pub nack_data_byte: Option<usize>,
    written: Vec<u8>,
    to_send: Vec<u8>,
}

impl Slave {
    pub fn with(registers: &[(u8, u16)]) -> Self {
        Self {
            registers: registers.iter().copied().collect(),
            ..Self::default()
        }
    }

    fn addressed(&mut self, read: bool) {
        self.written.clear();
        let value = self.registers.get(&self.pointer).copied().unwrap_or(0);
        self.to_send = if read {
            value.to_be_bytes().to_vec()
        } else {
            Vec::new()
        };
        self.to_send.reverse();
    }

    fn receive(&mut self, byte: u8) -> bool {
        if self.nack_data_byte == Some(self.written.len()) {
            return false;
        }
        self.written.push(byte);
        match self.written[..] {
            [pointer] => self.pointer = pointer,
            [pointer, hi, lo] => {
                self.registers.insert(pointer, u16::from_be_bytes([hi, lo]));
            }
            _ => {}
        }
        true
    }

    fn send(&mut self) -> u8 {
        self.to_send.pop().unwrap_or(0xFF)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Bus {
    Idle,
    /// START on the wire, SB set: the address goes into DR.
    Started,
    /// The address byte is in DR and goes out at the next step.
    AddressSent(u8),
    /// ADDR set, SCL stretched until it is cleared.
    Addressed {
        read: bool,
    },
    Transmit,
    Receive,
    /// A NACK was seen: only STOP or START now.
    Nacked,
    /// Arbitration lost: the peripheral is a slave and does nothing more here.
    Released,
}

#[derive(Debug)]
pub struct Fake {
    // CR1 / CR2.
    start: bool,
    stop: bool,
    ack: bool,
    pos: bool,
    events: bool,
    buffer: bool,
    sr1: u16,
    sr1_read: bool,
    dr: Option<u8>,
    shift: Option<u8>,
    bus: Bus,
    slave: Option<u8>,
    /// With POS: whether the byte now being received is ACKed (latched at the byte before).
    next_ack: bool,
    /// The last received byte was NACKed: the slave sends no more.
    rx_ended: bool,
    pub slaves: BTreeMap<u8, Slave>,
    pub wire: Vec<Wire>,
    steps: u32,
    /// From this step on nothing moves (a slave holds SCL or SDA low).
    pub stall_at: Option<u32>,
    /// At this step another master wins arbitration.
    pub arlo_at: Option<u32>,
    /// At this step BERR is raised (spuriously: the transfer goes on).
    pub berr_at: Option<u32>,
    /// CR1.STOP never clears.
    pub stop_stuck: bool,
    /// Bus events a repeated START takes after it is asked for (the rest of SCL's low period,
    /// the set-up time), BTF staying set meanwhile.
    pub restart_delay: u32,
    restart_waited: u32,
    /// Rule breaks: CR1 written with STOP or START pending, DR read empty or written full.
    pub violations: Vec<&'static str>,
}

impl Fake {
    pub fn new(slaves: &[(u8, Slave)]) -> Self {
        Self {
            start: false,
            stop: false,
            ack: false,
            pos: false,
            events: false,
            buffer: false,
            sr1: 0,
            sr1_read: false,
            dr: None,
            shift: None,
            bus: Bus::Idle,
            slave: None,
            next_ack: true,
            rx_ended: false,
            slaves: slaves.iter().cloned().collect(),
            wire: Vec::new(),
            steps: 0,
            stall_at: None,
            arlo_at: None,
            berr_at: None,
            stop_stuck: false,
            restart_delay: 0,
            restart_waited: 0,
            violations: Vec::new(),
        }
    }

    /// Whether the peripheral requests an interrupt (RM0383 Table 92: ITEVTEN for SB, ADDR,
    /// BTF; ITBUFEN on top for TXE, RXNE; ITERREN, set with ITEVTEN here, for the errors).
    pub fn interrupt_pending(&self) -> bool {
        let events = Sr1::SB | Sr1::ADDR | Sr1::BTF | Sr1::BERR | Sr1::ARLO | Sr1::AF | Sr1::OVR;
        let buffer = Sr1::TXE | Sr1::RXNE;
        self.events && (self.sr1 & events != 0 || (self.buffer && self.sr1 & buffer != 0))
    }

    pub fn interrupts_enabled(&self) -> bool {
        self.events
    }

    /// A bus reset: the slave clocked free and the peripheral reset (registers cleared, idle).
    /// The wire log and the slaves stay.
    pub fn reset(&mut self) {
        let slaves = core::mem::take(&mut self.slaves);
        let wire = core::mem::take(&mut self.wire);
        let steps = self.steps;
        *self = Fake::new(&[]);
        self.slaves = slaves;
        self.wire = wire;
        self.steps = steps;
    }

    fn set(&mut self, flag: u16) {
        self.sr1 |= flag;
    }

    fn clear(&mut self, flag: u16) {
        self.sr1 &= !flag;
    }

    fn cr1_write(&mut self) {
        if self.stop {
            self.violations.push("CR1 written while STOP pending");
        }
        if self.start {
            self.violations.push("CR1 written while START pending");
        }
    }

    /// One bus event, unless SCL is stretched.
    pub fn step(&mut self) {
        self.steps += 1;
        if self.stall_at.is_some_and(|at| self.steps >= at) {
            return;
        }
        if self.arlo_at == Some(self.steps) {
            self.set(Sr1::ARLO);
            self.bus = Bus::Released;
            self.start = false;
            return;
        }
        if self.berr_at == Some(self.steps) {
            self.set(Sr1::BERR);
        }
        match self.bus {
            Bus::Idle | Bus::Nacked => self.idle_step(),
            Bus::AddressSent(byte) => self.address_step(byte),
            Bus::Transmit => self.transmit_step(),
            Bus::Receive => self.receive_step(),
            Bus::Started | Bus::Addressed { .. } | Bus::Released => {}
        }
    }

    fn idle_step(&mut self) {
        if self.stop {
            self.send_stop();
        } else if self.start {
            self.send_start();
        }
    }

    fn send_start(&mut self) {
        self.start = false;
        self.restart_waited = 0;
        self.wire.push(Wire::Start);
        self.clear(Sr1::BTF | Sr1::TXE);
        self.set(Sr1::SB);
        self.bus = Bus::Started;
    }

    fn send_stop(&mut self) {
        if !self.stop_stuck {
            self.stop = false;
        }
        self.wire.push(Wire::Stop);
        self.clear(Sr1::BTF | Sr1::TXE);
        self.bus = Bus::Idle;
        self.slave = None;
    }

    fn address_step(&mut self, byte: u8) {
        let address = byte >> 1;
        let read = byte & 1 == 1;
        let acked = match self.slaves.get_mut(&address) {
            Some(slave) => {
                slave.addressed(read);
                true
            }
            None => false,
        };
        self.wire.push(Wire::Address { byte, acked });
        if acked {
            self.slave = Some(address);
            self.set(Sr1::ADDR);
            self.bus = Bus::Addressed { read };
        } else {
            self.set(Sr1::AF);
            self.bus = Bus::Nacked;
        }
    }

    fn transmit_step(&mut self) {
        if let Some(byte) = self.shift.take() {
            let acked = self.slave_mut().receive(byte);
            self.wire.push(Wire::Byte { byte, acked });
            if !acked {
                self.set(Sr1::AF);
                self.bus = Bus::Nacked;
                return;
            }
            match self.dr.take() {
                Some(next) => {
                    self.shift = Some(next);
                    self.set(Sr1::TXE);
                }
                None => self.set(Sr1::BTF | Sr1::TXE),
            }
        } else if let Some(byte) = self.dr.take() {
            self.shift = Some(byte);
            self.set(Sr1::TXE);
        } else if self.start && !self.stop && self.restart_waited < self.restart_delay {
            self.restart_waited += 1;
        } else {
            // Everything sent and acknowledged (or nothing to send): STOP or repeated START,
            // if asked.
            self.idle_step();
        }
    }

    fn receive_step(&mut self) {
        if self.shift.is_some() {
            return; // DR and shift register full: SCL stretched (BTF).
        }
        if self.rx_ended {
            if self.stop {
                self.send_stop();
            }
            return;
        }
        let byte = self.slave_mut().send();
        let acked = if self.pos { self.next_ack } else { self.ack };
        self.next_ack = self.ack;
        self.wire.push(Wire::Byte { byte, acked });
        self.rx_ended = !acked;
        if self.dr.is_none() {
            self.dr = Some(byte);
            self.set(Sr1::RXNE);
        } else {
            self.shift = Some(byte);
            self.set(Sr1::BTF);
        }
    }

    fn slave_mut(&mut self) -> &mut Slave {
        let address = self.slave.expect("a slave is addressed");
        self.slaves
            .get_mut(&address)
            .expect("addressed slaves exist")
    }
}

impl Registers for Fake {
    fn sr1(&mut self) -> Sr1 {
        self.sr1_read = true;
        Sr1(self.sr1)
    }

    fn read_sr2(&mut self) {
        if self.sr1_read && self.sr1 & Sr1::ADDR != 0 {
            self.clear(Sr1::ADDR);
            if let Bus::Addressed { read } = self.bus {
                if read {
                    self.bus = Bus::Receive;
                    self.next_ack = true;
                    self.rx_ended = false;
                } else {
                    self.bus = Bus::Transmit;
                    self.set(Sr1::TXE);
                }
            }
        }
        self.sr1_read = false;
    }

    fn clear_sr1(&mut self, flags: u16) {
        self.clear(flags);
    }

    fn write_dr(&mut self, byte: u8) {
        if self.sr1 & Sr1::SB != 0 && self.sr1_read {
            // The address goes out through DR: whatever a NACK left there is overwritten.
            self.clear(Sr1::SB);
            self.dr = None;
            self.bus = Bus::AddressSent(byte);
        } else if self.dr.is_some() {
            self.violations.push("DR written while full");
        } else {
            self.dr = Some(byte);
            self.clear(Sr1::TXE);
            if self.sr1_read {
                self.clear(Sr1::BTF);
            }
        }
        self.sr1_read = false;
    }

    fn read_dr(&mut self) -> u8 {
        let Some(byte) = self.dr.take() else {
            self.violations.push("DR read while empty");
            return 0;
        };
        self.clear(Sr1::RXNE);
        if self.sr1_read {
            self.clear(Sr1::BTF);
        }
        if let Some(next) = self.shift.take() {
            self.dr = Some(next);
            self.set(Sr1::RXNE);
        }
        self.sr1_read = false;
        byte
    }

    fn start(&mut self) {
        self.cr1_write();
        self.start = true;
    }

    fn stop(&mut self) {
        self.cr1_write();
        self.stop = true;
    }

    fn stop_pending(&mut self) -> bool {
        self.stop
    }

    fn set_ack_pos(&mut self, ack: bool, pos: bool) {
        self.cr1_write();
        self.ack = ack;
        self.pos = pos;
    }

    fn set_interrupts(&mut self, on: bool, buffer: bool) {
        self.events = on;
        self.buffer = on && buffer;
    }
}
