//! TI INA226 current/power monitor driver over `embedded_hal_async::i2c::I2c` (datasheet
//! SBOS547): on the board each transfer is interrupt-driven and awaited; on the host a blocking
//! bus runs it through [`crate::blocking`].
//!
//! The driver does not own the bus: both chips share I²C1, so each call borrows it.

use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_async::i2c::I2c;
use model_core::ina226::{
    AdcConfig, BusVoltageRaw, CalibrationRaw, ConfigurationRaw, CurrentRaw, DieIdRaw,
    ManufacturerIdRaw, PowerRaw, Registers, Scale, ShuntVoltageRaw,
};
use model_core::wire::{ChipFault, ChipRegistersReadBack};

/// Register pointers (datasheet Table 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Register {
    Configuration = 0x00,
    ShuntVoltage = 0x01,
    BusVoltage = 0x02,
    Power = 0x03,
    Current = 0x04,
    Calibration = 0x05,
    MaskEnable = 0x06,
    AlertLimit = 0x07,
    ManufacturerId = 0xFE,
    DieId = 0xFF,
}

/// Manufacturer ID register value ("TI").
pub const MANUFACTURER_ID: u16 = 0x5449;
/// Die ID register value of the INA226.
pub const DIE_ID: u16 = 0x2260;

/// Configuration register: bit 15 resets the chip.
const CONFIG_RESET: u16 = 1 << 15;
/// Bits 14–12 read back as 100b; written the same way.
const CONFIG_FIXED_BITS: u16 = 0b100 << 12;
/// MODE = 111b: shunt and bus, continuous.
const MODE_SHUNT_BUS_CONTINUOUS: u16 = 0b111;
/// Mask/Enable register: conversion-ready flag (cleared by reading the register).
const MASK_CVRF: u16 = 1 << 3;
/// Configuration register after a power-on or reset: AVG 1, 1.1 ms + 1.1 ms, continuous.
pub const CONFIG_POWER_ON: u16 = 0x4127;

/// Numerator of the calibration equation (datasheet Eq 1, CAL = 0.00512 / (I_LSB · R_shunt))
/// with I_LSB in nA and R in µΩ: 0.00512 / (1e-9 · 1e-6) = 5.12e12.
const CAL_NUMERATOR: u64 = 5_120_000_000_000;

/// The calibration register value for a shunt and current LSB.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Calibration {
    value: u16,
    scale: Scale,
}

/// The requested current LSB cannot be programmed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CalibrationError {
    /// Zero shunt resistance or current LSB.
    Zero,
    /// CAL would not fit the register's 15 bits (current LSB too small for the shunt).
    TooLarge(u64),
    /// CAL would round to 0 (current LSB too large for the shunt).
    TooSmall,
}

impl Calibration {
    /// Datasheet Eq 1, rounded to the nearest integer and checked against the 15-bit field.
    pub const fn new(scale: Scale) -> Result<Self, CalibrationError> {
        let denominator = scale.current_lsb_na as u64 * scale.shunt_micro_ohm as u64;
        if denominator == 0 {
            return Err(CalibrationError::Zero);
        }
        let value = (CAL_NUMERATOR + denominator / 2) / denominator;
        if value > 0x7FFF {
            Err(CalibrationError::TooLarge(value))
        } else if value == 0 {
            Err(CalibrationError::TooSmall)
        } else {
            Ok(Self {
                value: value as u16,
                scale,
            })
        }
    }

    pub const fn value(&self) -> u16 {
        self.value
    }

    pub const fn scale(&self) -> Scale {
        self.scale
    }

    /// The register value.
    pub const fn raw(&self) -> CalibrationRaw {
        CalibrationRaw(self.value)
    }
}

/// Board calibration: 5 mΩ shunt, 0.5 mA LSB → CAL 2048, power LSB 12.5 mW.
pub const BOARD_CALIBRATION: Calibration = match Calibration::new(Scale::BOARD) {
    Ok(c) => c,
    Err(_) => panic!("board calibration must fit the register"),
};

/// A driver error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error<E> {
    I2c(E),
    /// The device answered but is not an INA226.
    WrongId {
        manufacturer: u16,
        die: u16,
    },
}

impl<E: embedded_hal::i2c::Error> Error<E> {
    /// The fault as reported on the wire.
    pub fn fault(&self) -> ChipFault {
        match self {
            Error::I2c(e) => fault_of(e),
            Error::WrongId { .. } => ChipFault::WrongId,
        }
    }
}

impl<E> From<E> for Error<E> {
    fn from(e: E) -> Self {
        Error::I2c(e)
    }
}

/// Maps an embedded-hal I²C error onto the wire's fault codes.
pub fn fault_of<E: embedded_hal::i2c::Error>(e: &E) -> ChipFault {
    match e.kind() {
        ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data) => ChipFault::DataNack,
        ErrorKind::NoAcknowledge(_) => ChipFault::AddressNack,
        ErrorKind::ArbitrationLoss => ChipFault::ArbitrationLoss,
        ErrorKind::Bus => ChipFault::Bus,
        ErrorKind::Overrun => ChipFault::Overrun,
        _ => ChipFault::Other,
    }
}

/// One sample's reading of a chip ([`Ina226::read_measurement`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Measurement {
    /// Shunt and bus as read; current and power computed as the chip does. `None`: the bus
    /// voltage read had bit 15 set, not a value the chip holds ([`Registers::derived`]).
    pub registers: Option<Registers>,
    /// The calibration register, when the read-back was asked for.
    pub calibration: Option<CalibrationRaw>,
    /// The short read returned the configuration register's power-on value: a chip that reset
    /// points at register 00h, so the value may not be the register meant. The caller checks
    /// the calibration before trusting it (a genuine reading of 0x4127 is rare and costs one
    /// extra read).
    pub suspect_reset: bool,
}

/// One INA226 at a 7-bit address.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ina226 {
    address: u8,
    calibration: Calibration,
    adc: AdcConfig,
    /// The register the chip points at, as far as this driver knows (`None` after a failed
    /// transaction: the pointer byte may or may not have landed).
    pointer: Option<Register>,
}

impl Ina226 {
    pub const fn new(address: u8, calibration: Calibration, adc: AdcConfig) -> Self {
        Self {
            address,
            calibration,
            adc,
            pointer: None,
        }
    }

    pub const fn address(&self) -> u8 {
        self.address
    }

    pub const fn calibration(&self) -> Calibration {
        self.calibration
    }

    pub const fn adc(&self) -> AdcConfig {
        self.adc
    }

    /// The configuration register word for `adc` in continuous shunt-and-bus mode.
    pub const fn config_word(adc: AdcConfig) -> u16 {
        CONFIG_FIXED_BITS
            | adc.averaging.bits() << 9
            | adc.bus_conversion.bits() << 6
            | adc.shunt_conversion.bits() << 3
            | MODE_SHUNT_BUS_CONTINUOUS
    }

    /// Checks the IDs, then writes configuration and calibration.
    pub async fn init_async<I: I2c>(&mut self, i2c: &mut I) -> Result<(), Error<I::Error>> {
        let manufacturer = self.read_async(i2c, Register::ManufacturerId).await?;
        let die = self.read_async(i2c, Register::DieId).await?;
        if manufacturer != MANUFACTURER_ID || die != DIE_ID {
            return Err(Error::WrongId { manufacturer, die });
        }
        self.configure_async(i2c, self.adc).await?;
        self.write_async(i2c, Register::Calibration, self.calibration.value)
            .await?;
        Ok(())
    }

    /// Sets averaging and conversion times (continuous shunt and bus).
    pub async fn configure_async<I: I2c>(
        &mut self,
        i2c: &mut I,
        adc: AdcConfig,
    ) -> Result<(), I::Error> {
        self.adc = adc;
        self.write_async(i2c, Register::Configuration, Self::config_word(adc))
            .await
    }

    /// Software reset: all registers return to their defaults (CAL = 0).
    pub async fn reset_async<I: I2c>(&mut self, i2c: &mut I) -> Result<(), I::Error> {
        self.write_async(i2c, Register::Configuration, CONFIG_RESET)
            .await
    }

    /// Whether a new conversion finished since the last call (reading clears the flag). The
    /// sampler does not poll it (a third read per sample); bring-up and tests do.
    pub async fn conversion_ready_async<I: I2c>(&mut self, i2c: &mut I) -> Result<bool, I::Error> {
        Ok(self.read_async(i2c, Register::MaskEnable).await? & MASK_CVRF != 0)
    }

    /// Whether the chip lost its calibration (it reset: brown-out or power cycle).
    pub async fn calibration_lost_async<I: I2c>(&mut self, i2c: &mut I) -> Result<bool, I::Error> {
        Ok(self.read_async(i2c, Register::Calibration).await? == 0)
    }

    /// Reads the ID, configuration and calibration registers back (for the hello: the host's
    /// bring-up check compares them with what was written). Stops at the first failed read.
    pub async fn read_back_async<I: I2c>(
        &mut self,
        i2c: &mut I,
    ) -> Result<ChipRegistersReadBack, I::Error> {
        Ok(ChipRegistersReadBack {
            manufacturer_id: ManufacturerIdRaw(
                self.read_async(i2c, Register::ManufacturerId).await?,
            ),
            die_id: DieIdRaw(self.read_async(i2c, Register::DieId).await?),
            configuration: ConfigurationRaw(self.read_async(i2c, Register::Configuration).await?),
            calibration: CalibrationRaw(self.read_async(i2c, Register::Calibration).await?),
        })
    }

    /// Reads all four measurement registers as the chip holds them (shunt, bus, current,
    /// power): what [`Self::read_measurement_async`] computes, for checks.
    pub async fn read_registers_async<I: I2c>(
        &mut self,
        i2c: &mut I,
    ) -> Result<Registers, I::Error> {
        Ok(Registers {
            shunt: ShuntVoltageRaw(self.read_async(i2c, Register::ShuntVoltage).await? as i16),
            bus: BusVoltageRaw(self.read_async(i2c, Register::BusVoltage).await?),
            current: CurrentRaw(self.read_async(i2c, Register::Current).await? as i16),
            power: PowerRaw(self.read_async(i2c, Register::Power).await?),
        })
    }

    /// One sample: shunt and bus in two reads, the one the chip already points at first (a
    /// short read, no pointer byte), with the calibration read-back between them when asked
    /// (so the pointer ends on a measurement register and the next sample's first read is short
    /// again). Current and power are the chip's own Eq 3–4 on what was read, with this
    /// driver's CAL ([`Registers::derived`]).
    pub async fn read_measurement_async<I: I2c>(
        &mut self,
        i2c: &mut I,
        check_calibration: bool,
    ) -> Result<Measurement, I::Error> {
        let (first, second) = match self.pointer {
            Some(Register::BusVoltage) => (Register::BusVoltage, Register::ShuntVoltage),
            _ => (Register::ShuntVoltage, Register::BusVoltage),
        };
        let retained = self.pointer == Some(first);
        let first_value = self.read_async(i2c, first).await?;
        let calibration = if check_calibration {
            Some(CalibrationRaw(
                self.read_async(i2c, Register::Calibration).await?,
            ))
        } else {
            None
        };
        let second_value = self.read_async(i2c, second).await?;
        let (shunt, bus) = if first == Register::ShuntVoltage {
            (first_value, second_value)
        } else {
            (second_value, first_value)
        };
        Ok(Measurement {
            registers: Registers::derived(
                ShuntVoltageRaw(shunt as i16),
                BusVoltageRaw(bus),
                self.calibration.raw(),
            ),
            calibration,
            suspect_reset: retained && first_value == CONFIG_POWER_ON,
        })
    }

    /// Reads a register, sending the pointer only when the chip points elsewhere.
    pub async fn read_async<I: I2c>(
        &mut self,
        i2c: &mut I,
        register: Register,
    ) -> Result<u16, I::Error> {
        let mut buf = [0u8; 2];
        let result = if self.pointer == Some(register) {
            i2c.read(self.address, &mut buf).await
        } else {
            i2c.write_read(self.address, &[register as u8], &mut buf)
                .await
        };
        self.pointer = result.is_ok().then_some(register);
        result?;
        Ok(u16::from_be_bytes(buf))
    }

    pub async fn write_async<I: I2c>(
        &mut self,
        i2c: &mut I,
        register: Register,
        value: u16,
    ) -> Result<(), I::Error> {
        let [hi, lo] = value.to_be_bytes();
        let result = i2c.write(self.address, &[register as u8, hi, lo]).await;
        self.pointer = result.is_ok().then_some(register);
        result
    }

    crate::blocking::blocking_twins! {
        fn init => init_async() -> Result<(), Error<I::Error>>;
        fn configure => configure_async(adc: AdcConfig) -> Result<(), I::Error>;
        fn reset => reset_async() -> Result<(), I::Error>;
        fn conversion_ready => conversion_ready_async() -> Result<bool, I::Error>;
        fn calibration_lost => calibration_lost_async() -> Result<bool, I::Error>;
        fn read_back => read_back_async() -> Result<ChipRegistersReadBack, I::Error>;
        fn read_registers => read_registers_async() -> Result<Registers, I::Error>;
        fn read_measurement => read_measurement_async(check_calibration: bool) -> Result<Measurement, I::Error>;
        fn read => read_async(register: Register) -> Result<u16, I::Error>;
        fn write => write_async(register: Register, value: u16) -> Result<(), I::Error>;
    }

    /// Forgets where the chip points (it may have reset: its pointer is then 00h), so the next
    /// read sends its pointer.
    pub fn forget_pointer(&mut self) {
        self.pointer = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
    use model_core::ina226::{Averaging, ConversionTime};

    /// Datasheet worked example (section 7.5.1, Table 1 values): 10 A through 2 mΩ at 12 V with a
    /// 1 mA current LSB.
    const EXAMPLE: Scale = Scale {
        current_lsb_na: 1_000_000,
        shunt_micro_ohm: 2_000,
    };

    fn read(addr: u8, reg: Register, value: u16) -> T {
        T::write_read(addr, vec![reg as u8], value.to_be_bytes().to_vec())
    }

    fn write(addr: u8, reg: Register, value: u16) -> T {
        let [hi, lo] = value.to_be_bytes();
        T::write(addr, vec![reg as u8, hi, lo])
    }

    #[test]
    fn calibration_matches_the_datasheet_and_our_board() {
        assert_eq!(Calibration::new(EXAMPLE).map(|c| c.value()), Ok(0x0A00));
        assert_eq!(BOARD_CALIBRATION.value(), 2048);
        assert_eq!(BOARD_CALIBRATION.scale().power_lsb_uw(), 12_500);
        // Rounding, not truncation: 5.12e12 / (300_000 nA · 5000 µΩ) = 3413.33 → 3413;
        // 5.12e12 / (700_000 · 5000) = 1462.857 → 1463.
        let cal = |na| {
            Calibration::new(Scale {
                current_lsb_na: na,
                shunt_micro_ohm: 5_000,
            })
            .map(|c| c.value())
        };
        assert_eq!(cal(300_000), Ok(3413));
        assert_eq!(cal(700_000), Ok(1463));
        // 15-bit field: a 10 µA LSB on 5 mΩ needs CAL 102400.
        assert_eq!(cal(10_000), Err(CalibrationError::TooLarge(102_400)));
        assert_eq!(cal(0), Err(CalibrationError::Zero));
        assert_eq!(cal(u32::MAX), Err(CalibrationError::TooSmall));
    }

    #[test]
    fn init_and_read_the_datasheet_example() {
        let addr = 0x40;
        let adc = AdcConfig::BOARD_DEFAULT;
        let mut i2c = Mock::new(&[
            read(addr, Register::ManufacturerId, 0x5449),
            read(addr, Register::DieId, 0x2260),
            // 100b fixed | AVG 16 (010b) | VBUSCT 140 µs | VSHCT 140 µs | MODE 111b.
            write(addr, Register::Configuration, 0x4407),
            write(addr, Register::Calibration, 0x0A00),
            read(addr, Register::MaskEnable, 0x0008),
            read(addr, Register::ShuntVoltage, 0x1F40),
            read(addr, Register::BusVoltage, 0x2570),
            read(addr, Register::Current, 0x2710),
            read(addr, Register::Power, 0x12B8),
        ]);
        let mut chip = Ina226::new(addr, Calibration::new(EXAMPLE).expect("fits"), adc);
        chip.init(&mut i2c).expect("init");
        assert!(chip.conversion_ready(&mut i2c).expect("read"));
        let regs = chip.read_registers(&mut i2c).expect("read");
        assert!((EXAMPLE.shunt_v(regs.shunt) - 0.020).abs() < 1e-12);
        assert!((EXAMPLE.bus_v(regs.bus) - 11.98).abs() < 1e-9);
        assert!((EXAMPLE.current_a(regs.current) - 10.0).abs() < 1e-12);
        assert!((EXAMPLE.power_w(regs.signed_power_lsb()) - 119.8).abs() < 1e-9);
        // The chip's own arithmetic (datasheet Eq 3 and 4) reproduces its registers.
        assert_eq!(
            Registers::derived(regs.shunt, regs.bus, chip.calibration().raw()),
            Some(regs)
        );
        i2c.done();
    }

    #[test]
    fn a_measurement_is_two_reads_the_first_without_pointer() {
        let addr = 0x40;
        let mut i2c = Mock::new(&[
            // Pointer unknown: both reads send it.
            read(addr, Register::ShuntVoltage, 0x1F40),
            read(addr, Register::BusVoltage, 0x2570),
            // The chip points at bus: read it without a pointer, then shunt.
            T::read(addr, 0x2571u16.to_be_bytes().to_vec()),
            read(addr, Register::ShuntVoltage, 0xE0C0),
            // Points at shunt; the calibration read-back goes between the two.
            T::read(addr, 0x1F40u16.to_be_bytes().to_vec()),
            read(addr, Register::Calibration, 0x0A00),
            read(addr, Register::BusVoltage, 0x2570),
            // A failed read forgets the pointer.
            T::read(addr, vec![0, 0]).with_error(ErrorKind::Bus),
            read(addr, Register::ShuntVoltage, 0x1F40),
            read(addr, Register::BusVoltage, 0x2570),
            // A chip that reset points at its configuration register (00h).
            T::read(addr, CONFIG_POWER_ON.to_be_bytes().to_vec()),
            read(addr, Register::ShuntVoltage, 0x0100),
        ]);
        let example = Calibration::new(EXAMPLE).expect("fits");
        let mut chip = Ina226::new(addr, example, AdcConfig::BOARD_DEFAULT);
        let m = chip.read_measurement(&mut i2c, false).expect("read");
        assert_eq!(
            m.registers,
            Some(Registers {
                shunt: ShuntVoltageRaw(0x1F40),
                bus: BusVoltageRaw(0x2570),
                current: CurrentRaw(0x2710),
                power: PowerRaw(0x12B8),
            })
        );
        assert_eq!((m.calibration, m.suspect_reset), (None, false));
        let m = chip.read_measurement(&mut i2c, false).expect("read");
        let r = m.registers.expect("valid bus");
        assert_eq!(r.shunt, ShuntVoltageRaw(-8000));
        assert_eq!(r.current, CurrentRaw(-10_000), "sign of the shunt");
        assert_eq!(r.bus, BusVoltageRaw(0x2571));
        let m = chip.read_measurement(&mut i2c, true).expect("read");
        assert_eq!(m.calibration, Some(CalibrationRaw(0x0A00)));
        assert_eq!(m.registers.map(|r| r.power), Some(PowerRaw(0x12B8)));
        assert!(chip.read_measurement(&mut i2c, false).is_err());
        chip.read_measurement(&mut i2c, false).expect("read");
        let m = chip.read_measurement(&mut i2c, false).expect("read");
        assert!(m.suspect_reset);
        i2c.done();
    }

    #[test]
    fn config_word_fields() {
        assert_eq!(
            Ina226::config_word(AdcConfig {
                averaging: Averaging::X1,
                bus_conversion: ConversionTime::Us1100,
                shunt_conversion: ConversionTime::Us1100
            }),
            0x4127,
            "power-on default"
        );
        assert_eq!(
            Ina226::config_word(AdcConfig {
                averaging: Averaging::X1024,
                bus_conversion: ConversionTime::Us8244,
                shunt_conversion: ConversionTime::Us8244
            }),
            0x4FFF
        );
    }

    #[test]
    fn negative_current_and_shunt_are_signed() {
        let mut i2c = Mock::new(&[
            read(0x45, Register::ShuntVoltage, 0xE0C0), // −8000 → −20 mV
            read(0x45, Register::BusVoltage, 0x2570),
            read(0x45, Register::Current, 0xD8F0), // −10000 → −10 A
            read(0x45, Register::Power, 0x12B8),
        ]);
        let mut chip = Ina226::new(
            0x45,
            Calibration::new(EXAMPLE).expect("fits"),
            AdcConfig::BOARD_DEFAULT,
        );
        let regs = chip.read_registers(&mut i2c).expect("read");
        assert_eq!(regs.shunt.0, -8000);
        assert_eq!(regs.current.0, -10000);
        assert!((EXAMPLE.power_w(regs.signed_power_lsb()) + 119.8).abs() < 1e-9);
        i2c.done();
    }

    #[test]
    fn wrong_ids_and_bus_errors_are_reported() {
        let mut i2c = Mock::new(&[
            read(0x40, Register::ManufacturerId, 0x5449),
            read(0x40, Register::DieId, 0x2270), // an INA230-like die
            read(0x45, Register::ManufacturerId, 0)
                .with_error(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)),
            read(0x45, Register::ShuntVoltage, 0).with_error(ErrorKind::Bus),
            read(0x45, Register::ShuntVoltage, 0)
                .with_error(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data)),
        ]);
        let mut left = Ina226::new(0x40, BOARD_CALIBRATION, AdcConfig::BOARD_DEFAULT);
        let err = left.init(&mut i2c).expect_err("wrong die");
        assert_eq!(
            err,
            Error::WrongId {
                manufacturer: 0x5449,
                die: 0x2270
            }
        );
        assert_eq!(err.fault(), ChipFault::WrongId);
        let mut right = Ina226::new(0x45, BOARD_CALIBRATION, AdcConfig::BOARD_DEFAULT);
        assert_eq!(
            right.init(&mut i2c).expect_err("nack").fault(),
            ChipFault::AddressNack
        );
        assert_eq!(
            right.read_registers(&mut i2c).map_err(|e| fault_of(&e)),
            Err(ChipFault::Bus)
        );
        assert_eq!(
            right.read_registers(&mut i2c).map_err(|e| fault_of(&e)),
            Err(ChipFault::DataNack)
        );
        i2c.done();
    }

    #[test]
    fn read_back_returns_the_four_set_up_registers_or_the_first_fault() {
        let mut i2c = Mock::new(&[
            read(0x40, Register::ManufacturerId, 0x5449),
            read(0x40, Register::DieId, 0x2260),
            read(0x40, Register::Configuration, 0x4407),
            read(0x40, Register::Calibration, 2048),
            read(0x45, Register::ManufacturerId, 0)
                .with_error(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)),
        ]);
        let mut left = Ina226::new(0x40, BOARD_CALIBRATION, AdcConfig::BOARD_DEFAULT);
        assert_eq!(
            left.read_back(&mut i2c),
            Ok(ChipRegistersReadBack {
                manufacturer_id: ManufacturerIdRaw(MANUFACTURER_ID),
                die_id: DieIdRaw(DIE_ID),
                configuration: ConfigurationRaw(Ina226::config_word(AdcConfig::BOARD_DEFAULT)),
                calibration: CalibrationRaw(BOARD_CALIBRATION.value()),
            })
        );
        let mut right = Ina226::new(0x45, BOARD_CALIBRATION, AdcConfig::BOARD_DEFAULT);
        assert_eq!(
            right.read_back(&mut i2c).map_err(|e| fault_of(&e)),
            Err(ChipFault::AddressNack)
        );
        i2c.done();
    }

    #[test]
    fn reset_is_detected_from_calibration() {
        let mut i2c = Mock::new(&[
            write(0x40, Register::Configuration, 0x8000),
            read(0x40, Register::Calibration, 0x0000),
            // Pointer still on CAL: no pointer byte.
            T::read(0x40, vec![0x08, 0x00]),
        ]);
        let mut chip = Ina226::new(0x40, BOARD_CALIBRATION, AdcConfig::BOARD_DEFAULT);
        chip.reset(&mut i2c).expect("write");
        assert!(chip.calibration_lost(&mut i2c).expect("read"));
        assert!(!chip.calibration_lost(&mut i2c).expect("read"));
        i2c.done();
    }
}
