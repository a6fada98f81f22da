//! INA226 register values as they travel from the chip to the host, and their scale
//! (TI INA226 datasheet, SBOS547). Pure data: the I²C driver lives in the firmware crate.

use serde::{Deserialize, Serialize};

/// Shunt voltage register (01h): signed, LSB 2.5 µV.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct ShuntVoltageRaw(pub i16);

/// Bus voltage register (02h): unsigned, LSB 1.25 mV (bit 15 is always 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct BusVoltageRaw(pub u16);

impl BusVoltageRaw {
    /// Whether the chip can hold this value: bit 15 of register 02h always reads 0 (datasheet,
    /// Bus Voltage Register; full scale 40.96 V is 0x7FFF). A read with it set did not come from the register:
    /// 0xFFFF is SDA left high, as by a chip browning out mid-read.
    pub const fn is_valid(self) -> bool {
        self.0 & 0x8000 == 0
    }
}

/// Current register (04h): signed, LSB set by the calibration register.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct CurrentRaw(pub i16);

/// Power register (03h): unsigned magnitude, LSB 25 × current LSB. Its sign is the current's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct PowerRaw(pub u16);

/// Configuration register (00h): averaging, conversion times, mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct ConfigurationRaw(pub u16);

/// Calibration register (05h): CAL of datasheet Eq 1, 15 bits; 2048 on our board, 0 after a
/// reset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct CalibrationRaw(pub u16);

/// Manufacturer ID register (FEh): 0x5449 ("TI").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct ManufacturerIdRaw(pub u16);

/// Die ID register (FFh): 0x2260 on an INA226.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DieIdRaw(pub u16);

/// Shunt voltage LSB [nV] (datasheet 7.6.1.2).
pub const SHUNT_LSB_NV: u32 = 2_500;
/// Bus voltage LSB [µV] (datasheet 7.6.1.3).
pub const BUS_LSB_UV: u32 = 1_250;
/// Power LSB is this many current LSBs (datasheet Eq 4).
pub const POWER_LSB_PER_CURRENT_LSB: u32 = 25;

/// The four measurement registers of one chip, read in one sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Registers {
    pub shunt: ShuntVoltageRaw,
    pub bus: BusVoltageRaw,
    pub current: CurrentRaw,
    pub power: PowerRaw,
}

impl Registers {
    /// The current and power registers as the chip computes them from shunt and bus with
    /// `cal`, so the board reads two registers instead of four.
    ///
    /// Datasheet Eq 3: current = shunt × CAL / 2048, an integer division truncating toward zero
    /// (−1 × 2047 / 2048 = 0), clamped to the register's i16 range (the chip sets OVF there).
    /// Eq 4: power = |current| × bus / 20000, truncated; at most 32768 × 32767 / 20000, a u16.
    /// `None` for a bus voltage the chip cannot hold ([`BusVoltageRaw::is_valid`]): the reading
    /// is not the chip's, and its power would not fit the register (0xFFFF at 10 A and more
    /// wrapped to a small power).
    pub fn derived(
        shunt: ShuntVoltageRaw,
        bus: BusVoltageRaw,
        cal: CalibrationRaw,
    ) -> Option<Registers> {
        if !bus.is_valid() {
            return None;
        }
        let current = i32::from(shunt.0) * i32::from(cal.0) / 2048;
        let current = CurrentRaw(current.clamp(i32::from(i16::MIN), i32::from(i16::MAX)) as i16);
        Some(Registers {
            shunt,
            bus,
            current,
            power: Self::power_of(current, bus)?,
        })
    }

    /// Datasheet Eq 4: the power register for `current` and `bus`, |current| × bus / 20000
    /// truncated; `None` for a bus voltage the chip cannot hold (its power would not fit the
    /// register; for every valid one it does, never wrapped).
    pub fn power_of(current: CurrentRaw, bus: BusVoltageRaw) -> Option<PowerRaw> {
        if !bus.is_valid() {
            return None;
        }
        let power = u32::from(current.0.unsigned_abs()) * u32::from(bus.0) / 20_000;
        u16::try_from(power).ok().map(PowerRaw)
    }

    /// Power with its sign taken from the current register, in power LSBs (the power register
    /// holds |I|·V only).
    pub fn signed_power_lsb(&self) -> i32 {
        let magnitude = i32::from(self.power.0);
        if self.current.0 < 0 {
            -magnitude
        } else {
            magnitude
        }
    }
}

/// Scale of the calibrated registers, as announced by the board in its hello frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Scale {
    /// Current LSB [nA] (0.5 mA on our board).
    pub current_lsb_na: u32,
    /// Shunt resistance [µΩ] (5 mΩ on our board).
    pub shunt_micro_ohm: u32,
}

// The conversions divide the exact integer (count × LSB in n/µ units) by a power of ten rather
// than multiply by its inverse: the result is then the double nearest the reading's exact decimal
// value, which prints short (0.0075 A, not 0.007500000000000001) and parses fast in logs.
impl Scale {
    /// Our board: 5 mΩ shunts, 0.5 mA current LSB → CAL 2048, 12.5 mW power LSB.
    pub const BOARD: Scale = Scale {
        current_lsb_na: 500_000,
        shunt_micro_ohm: 5_000,
    };

    /// Power LSB [µW].
    pub const fn power_lsb_uw(&self) -> u32 {
        // nA → µW per LSB: × 25 / 1000, done in u64 so no LSB a u32 can hold overflows.
        (self.current_lsb_na as u64 * POWER_LSB_PER_CURRENT_LSB as u64 / 1000) as u32
    }

    pub fn shunt_v(&self, raw: ShuntVoltageRaw) -> f64 {
        f64::from(raw.0) * f64::from(SHUNT_LSB_NV) / 1e9
    }

    pub fn bus_v(&self, raw: BusVoltageRaw) -> f64 {
        f64::from(raw.0) * f64::from(BUS_LSB_UV) / 1e6
    }

    pub fn current_a(&self, raw: CurrentRaw) -> f64 {
        f64::from(raw.0) * f64::from(self.current_lsb_na) / 1e9
    }

    /// Power [W] from a signed power-LSB count.
    pub fn power_w(&self, signed_power_lsb: i32) -> f64 {
        f64::from(signed_power_lsb) * f64::from(self.power_lsb_uw()) / 1e6
    }

    /// Energy [J] from an accumulated count of power LSB × µs.
    pub fn energy_j(&self, energy_lsb_us: i64) -> f64 {
        energy_lsb_us as f64 * f64::from(self.power_lsb_uw()) / 1e12
    }
}

/// Number of samples averaged per result (AVG bits 11–9 of the configuration register).
/// Serialised as the count (`"16"`); the variant name is accepted when reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Averaging {
    #[serde(rename = "1", alias = "X1")]
    X1,
    #[serde(rename = "4", alias = "X4")]
    X4,
    #[serde(rename = "16", alias = "X16")]
    X16,
    #[serde(rename = "64", alias = "X64")]
    X64,
    #[serde(rename = "128", alias = "X128")]
    X128,
    #[serde(rename = "256", alias = "X256")]
    X256,
    #[serde(rename = "512", alias = "X512")]
    X512,
    #[serde(rename = "1024", alias = "X1024")]
    X1024,
}

impl Averaging {
    pub const ALL: [Averaging; 8] = [
        Averaging::X1,
        Averaging::X4,
        Averaging::X16,
        Averaging::X64,
        Averaging::X128,
        Averaging::X256,
        Averaging::X512,
        Averaging::X1024,
    ];

    /// The 3-bit field value.
    pub const fn bits(self) -> u16 {
        self as u16
    }

    pub const fn count(self) -> u32 {
        match self {
            Averaging::X1 => 1,
            Averaging::X4 => 4,
            Averaging::X16 => 16,
            Averaging::X64 => 64,
            Averaging::X128 => 128,
            Averaging::X256 => 256,
            Averaging::X512 => 512,
            Averaging::X1024 => 1024,
        }
    }

    pub fn from_bits(bits: u16) -> Averaging {
        Averaging::ALL[usize::from(bits & 0b111)]
    }
}

/// Conversion time of one shunt or bus measurement (VBUSCT bits 8–6, VSHCT bits 5–3).
/// Serialised as `"140-us"`; the variant name is accepted when reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ConversionTime {
    #[serde(rename = "140-us", alias = "Us140")]
    Us140,
    #[serde(rename = "204-us", alias = "Us204")]
    Us204,
    #[serde(rename = "332-us", alias = "Us332")]
    Us332,
    #[serde(rename = "588-us", alias = "Us588")]
    Us588,
    #[serde(rename = "1100-us", alias = "Us1100")]
    Us1100,
    #[serde(rename = "2116-us", alias = "Us2116")]
    Us2116,
    #[serde(rename = "4156-us", alias = "Us4156")]
    Us4156,
    #[serde(rename = "8244-us", alias = "Us8244")]
    Us8244,
}

impl ConversionTime {
    pub const ALL: [ConversionTime; 8] = [
        ConversionTime::Us140,
        ConversionTime::Us204,
        ConversionTime::Us332,
        ConversionTime::Us588,
        ConversionTime::Us1100,
        ConversionTime::Us2116,
        ConversionTime::Us4156,
        ConversionTime::Us8244,
    ];

    pub const fn bits(self) -> u16 {
        self as u16
    }

    pub const fn micros(self) -> u32 {
        match self {
            ConversionTime::Us140 => 140,
            ConversionTime::Us204 => 204,
            ConversionTime::Us332 => 332,
            ConversionTime::Us588 => 588,
            ConversionTime::Us1100 => 1100,
            ConversionTime::Us2116 => 2116,
            ConversionTime::Us4156 => 4156,
            ConversionTime::Us8244 => 8244,
        }
    }

    pub fn from_bits(bits: u16) -> ConversionTime {
        ConversionTime::ALL[usize::from(bits & 0b111)]
    }
}

/// Averaging and conversion times of both chips (continuous shunt and bus mode).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct AdcConfig {
    pub averaging: Averaging,
    pub bus_conversion: ConversionTime,
    pub shunt_conversion: ConversionTime,
}

impl AdcConfig {
    /// Board default: 16 × (140 µs + 140 µs) = 4.48 ms per result, read every 5 ms (200 Hz):
    /// smooth enough for the seed's turns of a few seconds without over-filtering.
    pub const BOARD_DEFAULT: AdcConfig = AdcConfig {
        averaging: Averaging::X16,
        bus_conversion: ConversionTime::Us140,
        shunt_conversion: ConversionTime::Us140,
    };

    /// Time between two new results in continuous shunt-and-bus mode [µs] (datasheet 7.3.1).
    pub const fn update_period_us(&self) -> u32 {
        self.averaging.count() * (self.bus_conversion.micros() + self.shunt_conversion.micros())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn readings_are_the_doubles_nearest_their_exact_decimal_values() {
        let s = Scale::BOARD;
        // 15 × 0.5 mA = 0.0075 A exactly; multiplying by 1e-9 would give 0.007500000000000001.
        assert_eq!(s.current_a(CurrentRaw(15)), 0.0075);
        assert_eq!(s.current_a(CurrentRaw(-5)), -0.0025);
        // 19204 × 1.25 mV = 24.005 V (not 24.004999999999999).
        assert_eq!(s.bus_v(BusVoltageRaw(19_204)), 24.005);
        assert_eq!(s.shunt_v(ShuntVoltageRaw(3)), 7.5e-6);
        assert_eq!(s.power_w(7), 0.0875);
    }

    #[test]
    fn board_scale() {
        assert_eq!(Scale::BOARD.power_lsb_uw(), 12_500);
        // Datasheet worked example: 1 mA current LSB → 25 mW power LSB.
        let example = Scale {
            current_lsb_na: 1_000_000,
            shunt_micro_ohm: 2_000,
        };
        assert_eq!(example.power_lsb_uw(), 25_000);
        assert!((example.power_w(0x12B8) - 119.8).abs() < 1e-9);
        assert!((example.bus_v(BusVoltageRaw(0x2570)) - 11.98).abs() < 1e-9);
        assert!((example.shunt_v(ShuntVoltageRaw(0x1F40)) - 0.020).abs() < 1e-12);
        assert!((example.current_a(CurrentRaw(0x2710)) - 10.0).abs() < 1e-12);
    }

    #[test]
    fn power_sign_comes_from_current() {
        let mut regs = Registers {
            current: CurrentRaw(-200),
            power: PowerRaw(96),
            ..Default::default()
        };
        assert_eq!(regs.signed_power_lsb(), -96);
        regs.current = CurrentRaw(200);
        assert_eq!(regs.signed_power_lsb(), 96);
        regs.power = PowerRaw(u16::MAX);
        regs.current = CurrentRaw(i16::MIN);
        assert_eq!(regs.signed_power_lsb(), -65_535);
    }

    #[test]
    fn derived_registers_follow_eq_3_and_4() {
        // Datasheet worked example (7.5.1): CAL 0x0A00, 20 mV shunt, 11.98 V bus → 10 A, 119.8 W.
        let example = Registers::derived(
            ShuntVoltageRaw(0x1F40),
            BusVoltageRaw(0x2570),
            CalibrationRaw(0x0A00),
        )
        .expect("valid bus");
        assert_eq!(example.current, CurrentRaw(0x2710));
        assert_eq!(example.power, PowerRaw(0x12B8));
        // Truncation toward zero, not flooring: −1 × 2047 / 2048 is 0, −3 × 2049 / 2048 is −3.
        let cal = |c| CalibrationRaw(c);
        let bus = BusVoltageRaw(19_200);
        let current =
            |shunt, c| Registers::derived(ShuntVoltageRaw(shunt), bus, cal(c)).map(|r| r.current);
        assert_eq!(current(-1, 2047), Some(CurrentRaw(0)));
        assert_eq!(current(-3, 2049), Some(CurrentRaw(-3)));
        // Overflow clamps; power of the clamped current, never wrapped.
        let full = Registers::derived(
            ShuntVoltageRaw(i16::MIN),
            BusVoltageRaw(0x7FFF),
            cal(0x7FFF),
        )
        .expect("valid bus");
        assert_eq!(full.current, CurrentRaw(i16::MIN));
        assert_eq!(full.power, PowerRaw((32_768u32 * 0x7FFF / 20_000) as u16));
        assert_eq!(full.signed_power_lsb(), -53_685);
        // A chip that lost its calibration (CAL 0) computes nothing.
        let lost = Registers::derived(ShuntVoltageRaw(4000), bus, cal(0)).expect("valid bus");
        assert_eq!((lost.current, lost.power), (CurrentRaw(0), PowerRaw(0)));
    }

    #[test]
    fn a_bus_voltage_with_bit_15_set_is_no_reading() {
        // 0xFFFF (SDA high through the read) at 12 A: |I| × V / 20000 = 24000 × 65535 / 20000
        // would be 78 642, which the power register cannot hold (it wrapped to 13 106).
        let (shunt, cal) = (ShuntVoltageRaw(24_000), CalibrationRaw(2048));
        for bus in [0x8000, 0xA570, 0xFFFF] {
            assert!(!BusVoltageRaw(bus).is_valid());
            assert_eq!(Registers::derived(shunt, BusVoltageRaw(bus), cal), None);
        }
        let top = Registers::derived(shunt, BusVoltageRaw(0x7FFF), cal).expect("full scale");
        assert_eq!(top.power, PowerRaw(39_320), "24000 × 32767 / 20000");
    }

    #[test]
    fn field_bits_round_trip() {
        for a in Averaging::ALL {
            assert_eq!(Averaging::from_bits(a.bits()), a);
        }
        for c in ConversionTime::ALL {
            assert_eq!(ConversionTime::from_bits(c.bits()), c);
        }
        assert_eq!(AdcConfig::BOARD_DEFAULT.update_period_us(), 4_480);
    }
}
