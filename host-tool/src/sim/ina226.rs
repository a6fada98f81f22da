//! Register-level model of one TI INA226 (datasheet SBOS547): the register file with its
//! power-on defaults and write rules, the register pointer, and the ADC's conversion timing,
//! averaging and quantisation, fed with the true shunt current and bus voltage over time.
//!
//! Modelled:
//! - Register map (Table 2): configuration (00h), shunt (01h), bus (02h), power (03h), current
//!   (04h), calibration (05h), mask/enable (06h), alert limit (07h), manufacturer/die ID
//!   (FEh/FFh). Only 00h, 05h, 06h and 07h take writes; the others ignore them. Calibration bit
//!   15 is not implemented in the chip (reads 0). Configuration bits 14–12 always read 100b.
//!   Mask/enable takes writes to its alert-function bits (15–10) and APOL/LEN (1–0) only.
//! - Pointer semantics: a write frame's first byte sets the pointer, the next two bytes (MSB,
//!   LSB) write the pointed register; a read frame returns the pointed register big-endian.
//! - Software reset (configuration bit 15): every register back to its power-on value.
//! - Conversions by MODE (bits 2–0): bit 0 measures shunt, bit 1 bus, bit 2 continuous. Each
//!   conversion is VSHCT (shunt) followed by VBUSCT (bus); AVG conversions make one result. When a
//!   result completes: shunt = round(mean V_shunt / 2.5 µV) clamped to i16; bus =
//!   round(mean V_bus / 1.25 mV) clamped to 0..=0x7FFF; current = shunt × CAL / 2048 (Eq 3; Rust
//!   integer division, i.e. truncation toward zero, so −1 × 2047 / 2048 = 0); power =
//!   |current| × bus / 20000 (Eq 4, truncated); CVRF (mask/enable bit 3) set. Reading mask/enable
//!   clears CVRF; writing the configuration register restarts the conversion cycle and clears CVRF.
//!   A current that does not fit i16 is clamped and sets OVF (bit 2).
//! - MODE 000/100 (power-down) stops conversions. Triggered modes (001–011) run one result and
//!   stop until the configuration is written again; shunt-only and bus-only modes update only their
//!   own register (current and power are recomputed from the registers as they stand).
//! - Each conversion samples the held input at the middle of its own conversion window (the ADC
//!   integrates over the window), plus optional Gaussian noise and offset in LSB.
//!
//! Not modelled: the alert pin and its flags (AFF, alert functions are stored but never fire),
//! conversion-time tolerance, and what the real chip does on reads longer than two bytes (the model
//! repeats the register) or pointers to unimplemented addresses (the model reads 0 and ignores
//! writes).

use model_core::rng::{box_muller, XorShift64Star};

/// Power-on value of the configuration register: AVG 1, 1.1 ms + 1.1 ms, continuous shunt+bus.
pub const CONFIG_DEFAULT: u16 = 0x4127;
/// Manufacturer ID register value ("TI").
pub const MANUFACTURER_ID: u16 = 0x5449;
/// Die ID register value of the INA226.
pub const DIE_ID: u16 = 0x2260;
/// Mask/enable: conversion ready flag.
pub const MASK_CVRF: u16 = 1 << 3;
/// Mask/enable: math overflow flag.
pub const MASK_OVF: u16 = 1 << 2;

/// Shunt voltage LSB [V].
const SHUNT_LSB_V: f64 = 2.5e-6;
/// Bus voltage LSB [V].
const BUS_LSB_V: f64 = 1.25e-3;
/// Configuration: software reset bit.
const CONFIG_RESET: u16 = 1 << 15;
/// Configuration bits 14–12 read back as 100b whatever is written.
const CONFIG_FIXED: u16 = 0b100 << 12;
/// Mask/enable bits the host may write (alert functions, APOL, LEN).
const MASK_WRITABLE: u16 = 0xFC03;
/// Conversion times of the VBUSCT/VSHCT field values [µs] (datasheet Table 7/8).
const CONVERSION_US: [u64; 8] = [140, 204, 332, 588, 1100, 2116, 4156, 8244];
/// Averages of the AVG field values.
const AVERAGES: [u64; 8] = [1, 4, 16, 64, 128, 256, 512, 1024];

/// Register addresses (datasheet Table 2).
pub mod reg {
    /// Configuration.
    pub const CONFIG: u8 = 0x00;
    /// Shunt voltage.
    pub const SHUNT: u8 = 0x01;
    /// Bus voltage.
    pub const BUS: u8 = 0x02;
    /// Power.
    pub const POWER: u8 = 0x03;
    /// Current.
    pub const CURRENT: u8 = 0x04;
    /// Calibration.
    pub const CALIBRATION: u8 = 0x05;
    /// Mask/enable.
    pub const MASK_ENABLE: u8 = 0x06;
    /// Alert limit.
    pub const ALERT_LIMIT: u8 = 0x07;
    /// Manufacturer ID.
    pub const MANUFACTURER_ID: u8 = 0xFE;
    /// Die ID.
    pub const DIE_ID: u8 = 0xFF;
}

/// The analog front end of one chip: shunt resistor and measurement imperfections.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Analog {
    /// Shunt resistance [Ω] (the board's 5 mΩ by default).
    pub shunt_ohm: f64,
    /// Standard deviation of the Gaussian noise added to each shunt conversion [shunt LSB].
    pub shunt_noise_lsb: f64,
    /// Standard deviation of the Gaussian noise added to each bus conversion [bus LSB].
    pub bus_noise_lsb: f64,
    /// Constant offset added to each shunt conversion [shunt LSB].
    pub shunt_offset_lsb: f64,
    /// Constant offset added to each bus conversion [bus LSB].
    pub bus_offset_lsb: f64,
    /// Seed of the chip's noise generator (runs are reproducible for a given seed and access
    /// pattern).
    pub seed: u64,
}

impl Analog {
    /// Noise-free, offset-free chip on the board's 5 mΩ shunt.
    pub const IDEAL: Analog = Analog {
        shunt_ohm: 0.005,
        shunt_noise_lsb: 0.0,
        bus_noise_lsb: 0.0,
        shunt_offset_lsb: 0.0,
        bus_offset_lsb: 0.0,
        seed: 1,
    };
}

impl Default for Analog {
    fn default() -> Self {
        Self::IDEAL
    }
}

/// A standard normal draw for the chip's noise: Box–Muller on xorshift64* uniforms in (0, 1]
/// (53 bits plus one step, so the logarithm stays finite).
fn gaussian(rng: &mut XorShift64Star) -> f64 {
    let mut uniform = || ((rng.next_u64() >> 11) + 1) as f64 / (1u64 << 53) as f64;
    let u1 = uniform();
    let u2 = uniform();
    box_muller(u1, u2)
}

/// One input change: from `t_us` on, this current flows and the bus sits at this voltage.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Input {
    t_us: u64,
    current_a: f64,
    bus_v: f64,
}

/// The register file and ADC state of one INA226.
#[derive(Debug, Clone)]
pub struct SimIna226 {
    config: u16,
    shunt: i16,
    bus: u16,
    power: u16,
    current: i16,
    calibration: u16,
    mask_enable: u16,
    alert_limit: u16,
    pointer: u8,
    analog: Analog,
    rng: XorShift64Star,
    /// Input changes, oldest first; the first one is the last change at or before the earliest
    /// time a future conversion can sample.
    inputs: Vec<Input>,
    /// Time the chip has been advanced to [µs].
    now_us: u64,
    /// Start of the current conversion cycle (power-up, reset or configuration write) [µs].
    cycle_start_us: u64,
    /// Index (since `cycle_start_us`) of the next conversion to carry out.
    next_conversion: u64,
    shunt_sum_lsb: f64,
    bus_sum_lsb: f64,
    /// A triggered mode has delivered its result.
    triggered_done: bool,
    /// What the die ID register reads ([`DIE_ID`] unless another part is simulated).
    die_id: u16,
}

impl SimIna226 {
    /// A chip just powered up at t = 0 with the given analog front end.
    pub fn new(analog: Analog) -> Self {
        let mut chip = Self {
            config: CONFIG_DEFAULT,
            shunt: 0,
            bus: 0,
            power: 0,
            current: 0,
            calibration: 0,
            mask_enable: 0,
            alert_limit: 0,
            pointer: 0,
            analog,
            rng: XorShift64Star::new(analog.seed),
            inputs: Vec::new(),
            now_us: 0,
            cycle_start_us: 0,
            next_conversion: 0,
            shunt_sum_lsb: 0.0,
            bus_sum_lsb: 0.0,
            triggered_done: false,
            die_id: DIE_ID,
        };
        chip.power_on(0);
        chip
    }

    /// The same chip reading `die_id` from its die ID register: another part at the address
    /// (the bring-up check's wrong-ID fault; an INA260 reads 0x2270).
    pub fn with_die_id(mut self, die_id: u16) -> Self {
        self.die_id = die_id;
        self
    }

    /// The analog front end.
    pub fn analog(&self) -> Analog {
        self.analog
    }

    /// Time the chip has been advanced to [µs].
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    /// Power-on (or brown-out recovery) at `t_us`: every register to its default, pointer 0, a
    /// new conversion cycle. The analog input and the noise generator carry on.
    pub fn power_on(&mut self, t_us: u64) {
        self.now_us = self.now_us.max(t_us);
        self.pointer = 0;
        self.reset_registers();
        self.prune_inputs(self.now_us);
    }

    /// Sets the true shunt current [A] and bus voltage [V] from `t_us` on (held until the next
    /// call). Inputs must be given before the chip is advanced past their time; a change dated
    /// before an earlier change replaces every change after it.
    pub fn set_input(&mut self, t_us: u64, current_a: f64, bus_v: f64) {
        while self.inputs.last().is_some_and(|i| i.t_us >= t_us) {
            self.inputs.pop();
        }
        self.inputs.push(Input {
            t_us,
            current_a,
            bus_v,
        });
    }

    /// Reads a register without side effects (CVRF stays set), at the time the chip was last
    /// advanced to; 0 for unimplemented addresses.
    pub fn peek(&self, register: u8) -> u16 {
        match register {
            reg::CONFIG => self.config,
            reg::SHUNT => self.shunt as u16,
            reg::BUS => self.bus,
            reg::POWER => self.power,
            reg::CURRENT => self.current as u16,
            reg::CALIBRATION => self.calibration,
            reg::MASK_ENABLE => self.mask_enable,
            reg::ALERT_LIMIT => self.alert_limit,
            reg::MANUFACTURER_ID => MANUFACTURER_ID,
            reg::DIE_ID => self.die_id,
            _ => 0,
        }
    }

    /// The register pointer.
    pub fn pointer(&self) -> u8 {
        self.pointer
    }

    /// One I²C write frame addressed to the chip (after advancing it to `t_us`): the first byte
    /// sets the pointer, two more write the register (where writable). Further bytes are ignored.
    pub fn write_frame(&mut self, t_us: u64, bytes: &[u8]) {
        self.advance_to(t_us);
        let Some(&pointer) = bytes.first() else {
            return;
        };
        self.pointer = pointer;
        if let [_, hi, lo, ..] = *bytes {
            self.write_register(pointer, u16::from_be_bytes([hi, lo]));
        }
    }

    /// One I²C read frame (after advancing to `t_us`): the pointed register, MSB first, repeated
    /// for reads longer than two bytes. Reading mask/enable clears CVRF.
    pub fn read_frame(&mut self, t_us: u64, buf: &mut [u8]) {
        self.advance_to(t_us);
        let bytes = self.peek(self.pointer).to_be_bytes();
        for (i, b) in buf.iter_mut().enumerate() {
            *b = bytes[i % 2];
        }
        if self.pointer == reg::MASK_ENABLE && !buf.is_empty() {
            self.mask_enable &= !MASK_CVRF;
        }
    }

    /// Writes a register as the chip does: read-only registers ignore the write.
    fn write_register(&mut self, register: u8, value: u16) {
        match register {
            reg::CONFIG => {
                if value & CONFIG_RESET != 0 {
                    self.reset_registers();
                } else {
                    self.config = (value & 0x0FFF) | CONFIG_FIXED;
                    self.mask_enable &= !MASK_CVRF;
                    self.restart_cycle();
                }
            }
            reg::CALIBRATION => self.calibration = value & 0x7FFF,
            reg::MASK_ENABLE => {
                self.mask_enable = (self.mask_enable & !MASK_WRITABLE) | (value & MASK_WRITABLE)
            }
            reg::ALERT_LIMIT => self.alert_limit = value,
            _ => {}
        }
    }

    fn reset_registers(&mut self) {
        self.config = CONFIG_DEFAULT;
        self.shunt = 0;
        self.bus = 0;
        self.power = 0;
        self.current = 0;
        self.calibration = 0;
        self.mask_enable = 0;
        self.alert_limit = 0;
        self.restart_cycle();
    }

    fn restart_cycle(&mut self) {
        self.cycle_start_us = self.now_us;
        self.next_conversion = 0;
        self.shunt_sum_lsb = 0.0;
        self.bus_sum_lsb = 0.0;
        self.triggered_done = false;
    }

    /// (measures shunt, measures bus, continuous) from MODE; `None` in power-down.
    fn mode(&self) -> Option<(bool, bool, bool)> {
        let mode = self.config & 0b111;
        let shunt = mode & 0b001 != 0;
        let bus = mode & 0b010 != 0;
        (shunt || bus).then_some((shunt, bus, mode & 0b100 != 0))
    }

    fn field(&self, shift: u16) -> usize {
        usize::from((self.config >> shift) & 0b111)
    }

    /// Carries out every conversion that completes by `t_us` (time never goes backwards).
    ///
    /// After a long gap only the last complete result (and the partial one after it) is
    /// converted: earlier results would be overwritten unseen. This keeps the work per call
    /// bounded (at most 2 × AVG conversions) whatever the gap.
    pub fn advance_to(&mut self, t_us: u64) {
        self.now_us = self.now_us.max(t_us);
        let Some((shunt_on, bus_on, continuous)) = self.mode() else {
            return;
        };
        if self.triggered_done {
            return;
        }
        let vshct = if shunt_on {
            CONVERSION_US[self.field(3)]
        } else {
            0
        };
        let vbusct = if bus_on {
            CONVERSION_US[self.field(6)]
        } else {
            0
        };
        let conversion_us = vshct + vbusct;
        let avg = AVERAGES[self.field(9)];
        let elapsed = self.now_us.saturating_sub(self.cycle_start_us);
        let mut done = elapsed / conversion_us;
        if !continuous {
            done = done.min(avg);
        }
        let complete_results = done / avg;
        if complete_results >= 1 && self.next_conversion < (complete_results - 1) * avg {
            self.next_conversion = (complete_results - 1) * avg;
            self.shunt_sum_lsb = 0.0;
            self.bus_sum_lsb = 0.0;
        }
        while self.next_conversion < done {
            let start = self.cycle_start_us + self.next_conversion * conversion_us;
            if shunt_on {
                let current = self.input_at(start + vshct / 2).current_a;
                let v = current * self.analog.shunt_ohm;
                self.shunt_sum_lsb += v / SHUNT_LSB_V
                    + self.analog.shunt_offset_lsb
                    + self.noise(self.analog.shunt_noise_lsb);
            }
            if bus_on {
                let bus_v = self.input_at(start + vshct + vbusct / 2).bus_v;
                self.bus_sum_lsb += bus_v / BUS_LSB_V
                    + self.analog.bus_offset_lsb
                    + self.noise(self.analog.bus_noise_lsb);
            }
            self.next_conversion += 1;
            self.prune_inputs(start + conversion_us);
            if self.next_conversion.is_multiple_of(avg) {
                self.complete_result(shunt_on, bus_on, avg as f64);
                if !continuous {
                    self.triggered_done = true;
                    break;
                }
            }
        }
    }

    fn noise(&mut self, sigma_lsb: f64) -> f64 {
        if sigma_lsb == 0.0 {
            0.0
        } else {
            sigma_lsb * gaussian(&mut self.rng)
        }
    }

    fn complete_result(&mut self, shunt_on: bool, bus_on: bool, avg: f64) {
        if shunt_on {
            // `as` saturates (and maps NaN to 0): the clamp to the register's range.
            self.shunt = (self.shunt_sum_lsb / avg).round() as i16;
        }
        if bus_on {
            self.bus = ((self.bus_sum_lsb / avg).round() as i32).clamp(0, 0x7FFF) as u16;
        }
        self.shunt_sum_lsb = 0.0;
        self.bus_sum_lsb = 0.0;
        // Eq 3: truncation toward zero (Rust integer division).
        let current = i32::from(self.shunt) * i32::from(self.calibration) / 2048;
        let clamped = current.clamp(i32::from(i16::MIN), i32::from(i16::MAX));
        if clamped != current {
            self.mask_enable |= MASK_OVF;
        } else {
            self.mask_enable &= !MASK_OVF;
        }
        self.current = clamped as i16;
        // Eq 4: |current| × bus / 20000 ≤ 32768 × 32767 / 20000, which fits u16.
        self.power = (clamped.unsigned_abs() * u32::from(self.bus) / 20_000) as u16;
        self.mask_enable |= MASK_CVRF;
    }

    /// The input held at `t_us` (nothing flows before the first input).
    fn input_at(&self, t_us: u64) -> Input {
        self.inputs
            .iter()
            .rev()
            .find(|i| i.t_us <= t_us)
            .copied()
            .unwrap_or(Input {
                t_us: 0,
                current_a: 0.0,
                bus_v: 0.0,
            })
    }

    /// Drops input changes no conversion after `t_us` can see (used for a chip without power,
    /// whose next conversion can only come after it is powered up again).
    pub(crate) fn prune_inputs(&mut self, t_us: u64) {
        let later = self.inputs.iter().filter(|i| i.t_us > t_us).count();
        let keep_from = self.inputs.len().saturating_sub(later + 1);
        if keep_from > 0 {
            self.inputs.drain(..keep_from);
        }
    }
}

impl Default for SimIna226 {
    fn default() -> Self {
        Self::new(Analog::IDEAL)
    }
}

#[cfg(test)]
mod tests;
