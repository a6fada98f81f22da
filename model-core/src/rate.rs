//! How fast the board samples: the I²C time of one sample, the INA226's conversion period, and
//! the shortest sampling period a configuration sustains. The board's `Configure` check, its
//! sampler and the host's `--rate-hz` all use these, so the limits have one definition.
//!
//! Per sample the board reads two registers per chip, shunt (01h) and bus (02h); current and
//! power are computed from them ([`crate::ina226::Registers::derived`]). The INA226 keeps its
//! register pointer between transactions (datasheet 7.5.3, "Reading From the INA226"), so the
//! read of the register a chip already points at needs no pointer byte: reading the two in
//! alternating order (shunt, bus; bus, shunt; …) makes one of them a short read.

use crate::ina226::{AdcConfig, Averaging, ConversionTime};

/// The board's SCL clock [Hz]: fast mode, the STM32F411 I²C peripheral's fastest.
pub const SCL_HZ: u32 = 400_000;
/// The chips on the bus.
pub const CHIPS: u32 = 2;

/// SCL periods of a register read with its pointer: START, address+W, pointer, repeated START,
/// address+R, 2 data bytes (9 periods per byte with its ACK), STOP.
pub const READ_WITH_POINTER_BITS: u32 = 1 + 9 + 9 + 1 + 9 + 2 * 9 + 1;
/// SCL periods of a read of the register the chip points at already: START, address+R,
/// 2 data bytes, STOP.
pub const READ_RETAINED_BITS: u32 = 1 + 9 + 2 * 9 + 1;
/// SCL periods of one sample's reads: per chip one retained read and one with its pointer.
pub const SAMPLE_BITS: u32 = CHIPS * (READ_RETAINED_BITS + READ_WITH_POINTER_BITS);
/// SCL periods a calibration read-back adds to the sample that carries it (one chip, one read
/// with pointer; the register order after it continues the alternation).
pub const CALIBRATION_CHECK_BITS: u32 = READ_WITH_POINTER_BITS;

/// Shortest sampling period the board accepts [µs] (2 kHz): one sample's reads take
/// `SAMPLE_BITS` = 154 SCL periods = 385 µs at 400 kHz, so 500 µs leaves 115 µs (23 %) for what
/// the bit count leaves out: a real SCL somewhat under 400 kHz (rise times), the CPU's work
/// between transactions, and the calibration read-back's 120 µs once every
/// [`CALIBRATION_CHECK_EVERY`] samples, which the next sample's slack absorbs.
pub const MIN_SAMPLE_PERIOD_US: u32 = 500;

/// Each chip's calibration register is read back once every this many samples (the two chips
/// half a cycle apart, so no sample carries two read-backs): a chip that reset is found within
/// 32 ms at 2 kHz, at 1.5 SCL periods per sample on average.
pub const CALIBRATION_CHECK_EVERY: u32 = 64;

/// Margin on the chip's conversion period [%]. The chip converts on its own oscillator: the
/// datasheet's electrical characteristics (SBOS547, t_CT) give each conversion time as typical
/// and a maximum 10 % longer (140 µs typ, 154 µs max; … 8.244 ms, 9.068 ms), so a sampling
/// period 10 % longer than the nominal conversion period sees a new result at every read even
/// from the slowest chip (a fast chip only leaves more results unread).
pub const CONVERSION_MARGIN_PERCENT: u32 = 10;

/// Bus time of `bits` SCL periods at [`SCL_HZ`] [ns].
pub const fn bits_to_ns(bits: u32) -> u64 {
    bits as u64 * 1_000_000_000 / SCL_HZ as u64
}

impl AdcConfig {
    /// The conversion period plus [`CONVERSION_MARGIN_PERCENT`], rounded up [µs]: after this long
    /// the chip has completed a result with these settings, and a read this long after the
    /// previous one sees a new result.
    pub const fn conversion_wait_us(&self) -> u32 {
        let conversion = self.update_period_us() as u64;
        // At most 1024 × 2 × 8244 µs × 1.1 ≈ 18.6 s: fits u32.
        ((conversion * (100 + CONVERSION_MARGIN_PERCENT as u64)).div_ceil(100)) as u32
    }

    /// The shortest sampling period with this averaging [µs]: the bus floor, or
    /// [`Self::conversion_wait_us`], whichever is longer.
    pub const fn min_sample_period_us(&self) -> u32 {
        let wait = self.conversion_wait_us();
        if wait > MIN_SAMPLE_PERIOD_US {
            wait
        } else {
            MIN_SAMPLE_PERIOD_US
        }
    }

    /// The most filtering a sampling period allows: the longest conversion period (equal shunt
    /// and bus conversion times, most averaging on a tie) whose results still come one per
    /// sample. `None` below [`MIN_SAMPLE_PERIOD_US`].
    pub fn smoothest_for_period(sample_period_us: u32) -> Option<AdcConfig> {
        if sample_period_us < MIN_SAMPLE_PERIOD_US {
            return None;
        }
        let mut best: Option<AdcConfig> = None;
        for averaging in Averaging::ALL {
            for conversion in ConversionTime::ALL {
                let adc = AdcConfig {
                    averaging,
                    bus_conversion: conversion,
                    shunt_conversion: conversion,
                };
                let fits = adc.min_sample_period_us() <= sample_period_us;
                let better = best.is_none_or(|b| adc.update_period_us() >= b.update_period_us());
                if fits && better {
                    best = Some(adc);
                }
            }
        }
        best
    }
}

/// Sampling period [µs] for a rate [Hz], rounded to the nearest µs (0 for a rate that is not a
/// finite positive number; above 1 MHz the period is 1 µs: both are refused by the checks).
pub fn period_for_rate_us(rate_hz: f64) -> u32 {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return 0;
    }
    let period = libm::round(1e6 / rate_hz);
    if period >= f64::from(u32::MAX) {
        u32::MAX
    } else {
        (period as u32).max(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bus_time_of_a_sample() {
        assert_eq!(READ_WITH_POINTER_BITS, 48);
        assert_eq!(
            bits_to_ns(READ_WITH_POINTER_BITS),
            120_000,
            "the issue's 120 µs"
        );
        assert_eq!(READ_RETAINED_BITS, 29);
        assert_eq!(SAMPLE_BITS, 154);
        assert_eq!(bits_to_ns(SAMPLE_BITS), 385_000);
        // The floor with two full reads per chip: 480 µs; the retained read saves 95.
        assert_eq!(bits_to_ns(CHIPS * 2 * READ_WITH_POINTER_BITS), 480_000);
        // 2 kHz leaves 23 % of the bus free.
        let slack = 1.0 - bits_to_ns(SAMPLE_BITS) as f64 / (f64::from(MIN_SAMPLE_PERIOD_US) * 1e3);
        assert!((slack - 0.23).abs() < 1e-12, "{slack}");
    }

    #[test]
    fn the_period_allows_the_averaging() {
        let fastest = AdcConfig {
            averaging: Averaging::X1,
            bus_conversion: ConversionTime::Us140,
            shunt_conversion: ConversionTime::Us140,
        };
        // 280 µs × 1.1 = 308 µs: the bus, not the chip, limits it.
        assert_eq!(fastest.min_sample_period_us(), MIN_SAMPLE_PERIOD_US);
        // Board default: 16 × 280 µs = 4480 µs → 4928 µs, under its 5 ms period.
        assert_eq!(AdcConfig::BOARD_DEFAULT.min_sample_period_us(), 4_928);
        let slowest = AdcConfig {
            averaging: Averaging::X1024,
            bus_conversion: ConversionTime::Us8244,
            shunt_conversion: ConversionTime::Us8244,
        };
        // 1024 × 16 488 µs × 1.1 = 18 572 083.2 µs, rounded up: longer than MAX_SAMPLE_PERIOD_US, so
        // the host cannot choose it (a result every 17 s is no sampling).
        assert_eq!(slowest.min_sample_period_us(), 18_572_084);
    }

    #[test]
    fn smoothest_averaging_for_a_rate() {
        assert_eq!(AdcConfig::smoothest_for_period(499), None);
        // 2 kHz: 204 + 204 µs = 408 µs (449 µs with the margin); 332 + 332 would not fit.
        let fast = AdcConfig::smoothest_for_period(500).expect("at the floor");
        assert_eq!(
            fast,
            AdcConfig {
                averaging: Averaging::X1,
                bus_conversion: ConversionTime::Us204,
                shunt_conversion: ConversionTime::Us204,
            }
        );
        // 200 Hz: the board default.
        assert_eq!(
            AdcConfig::smoothest_for_period(5_000),
            Some(AdcConfig::BOARD_DEFAULT)
        );
        for period in [500, 777, 1_000, 5_000, 100_000, 1_000_000] {
            let adc = AdcConfig::smoothest_for_period(period).expect("above the floor");
            assert!(adc.min_sample_period_us() <= period, "{period}: {adc:?}");
        }
    }

    #[test]
    fn rates_to_periods() {
        assert_eq!(period_for_rate_us(2_000.0), 500);
        assert_eq!(period_for_rate_us(200.0), 5_000);
        assert_eq!(period_for_rate_us(3.0), 333_333);
        assert_eq!(period_for_rate_us(0.0), 0);
        assert_eq!(period_for_rate_us(f64::NAN), 0);
        assert_eq!(period_for_rate_us(-5.0), 0);
        assert_eq!(period_for_rate_us(1e9), 1);
        assert_eq!(period_for_rate_us(1e-9), u32::MAX);
    }
}
