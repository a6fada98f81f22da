//! The sample rate the simulated board sustains: the I²C time the firmware's polling design
//! spends per sample at 400 kHz ([`bus_time_per_sample`]), the rate that allows against the
//! INA226's own conversion limit ([`conversion_limit_hz`]), and long runs of the whole board
//! drained into the host's decoder, checked for queue drops and lost samples ([`endurance`]).

use super::board::{LoadSource, SideLoad, SimBoard};
use crate::decode::StreamDecoder;
use firmware::sampler::SamplerConfig;
use indicatif::ProgressBar;
use model_core::ina226::{AdcConfig, Averaging, ConversionTime};
use model_core::Sides;
use std::time::{Duration, Instant};

/// The chip's fastest continuous setting: no averaging, 140 µs shunt + 140 µs bus conversions.
pub const FASTEST_ADC: AdcConfig = AdcConfig {
    averaging: Averaging::X1,
    bus_conversion: ConversionTime::Us140,
    shunt_conversion: ConversionTime::Us140,
};

/// New results per second of one chip in continuous shunt-and-bus mode with `adc` [Hz]
/// (≈3571 Hz for [`FASTEST_ADC`]; 223 Hz for the board default).
pub fn conversion_limit_hz(adc: AdcConfig) -> f64 {
    1e6 / f64::from(adc.update_period_us().max(1))
}

/// Bus time of the firmware's steady-state samples (both chips).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BusTimePerSample {
    /// Samples measured.
    pub samples: u64,
    /// The most common bus time per sample [ns].
    pub typical_ns: u64,
    /// The longest (a sample with the periodic calibration check) [ns].
    pub max_ns: u64,
    /// Mean over the measured samples [ns].
    pub mean_ns: f64,
}

impl BusTimePerSample {
    /// The highest sample rate at which every sample's bus traffic fits in its period [Hz].
    pub fn sustained_rate_hz(&self) -> f64 {
        1e9 / self.max_ns.max(1) as f64
    }

    /// The rate if every sample were a typical one [Hz].
    pub fn typical_rate_hz(&self) -> f64 {
        1e9 / self.typical_ns.max(1) as f64
    }

    /// The shortest sample period the polling design sustains, rounded up to whole µs.
    pub fn min_period_us(&self) -> u32 {
        u32::try_from(self.max_ns.div_ceil(1_000)).unwrap_or(u32::MAX)
    }
}

/// Runs the firmware's own sampler on the simulated board with `config` and measures the I²C
/// time of `samples` steady-state samples (after the start-up samples that set the chips up).
/// `samples` ≥ 256 includes a calibration check.
pub fn bus_time_per_sample(config: SamplerConfig, samples: u32) -> BusTimePerSample {
    /// Sample 0 initialises the chips, sample 1 may still wait for their first conversion.
    const START_UP: u32 = 2;
    let mut board = SimBoard::new(config);
    let mut times = Vec::with_capacity(samples as usize);
    for k in 0..START_UP + samples {
        let before = board.bus().bus_time_ns();
        board.step();
        if k >= START_UP {
            times.push(board.bus().bus_time_ns() - before);
        }
    }
    let mut sorted = times.clone();
    sorted.sort_unstable();
    let mut typical = (0, 0); // (count, value)
    for run in sorted.chunk_by(|a, b| a == b) {
        if run.len() > typical.0 {
            typical = (run.len(), run[0]);
        }
    }
    BusTimePerSample {
        samples: times.len() as u64,
        typical_ns: typical.1,
        max_ns: sorted.last().copied().unwrap_or(0),
        mean_ns: times.iter().map(|&t| t as f64).sum::<f64>() / times.len().max(1) as f64,
    }
}

/// What a long run of the simulated board delivered to the host's decoder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Endurance {
    /// Simulated time covered [µs].
    pub simulated_us: u64,
    /// Board periods run.
    pub steps: u64,
    /// Sample frames the decoder received.
    pub samples: u64,
    /// Samples the decoder found missing from sequence gaps.
    pub lost_samples: u64,
    /// Frames the decoder discarded.
    pub bad_frames: u64,
    /// Frames the board's transmit queue dropped.
    pub queue_drops: u32,
    /// Bytes the board sent.
    pub bytes: u64,
    /// I²C time of the whole run [ns].
    pub bus_time_ns: u64,
    /// The longest I²C time of one period [ns].
    pub max_step_bus_ns: u64,
    /// The sample period [µs].
    pub period_us: u32,
    /// Wall-clock time the run took.
    pub wall: Duration,
}

impl Endurance {
    /// Fraction of the simulated time the I²C bus was busy.
    pub fn bus_utilisation(&self) -> f64 {
        self.bus_time_ns as f64 / (self.simulated_us.max(1) as f64 * 1e3)
    }

    /// Whether every period's bus traffic fit in the period.
    pub fn bus_fits(&self) -> bool {
        self.max_step_bus_ns <= u64::from(self.period_us) * 1_000
    }

    /// Wall-clock time per simulated hour.
    pub fn wall_per_simulated_hour(&self) -> Duration {
        self.wall.mul_f64(3_600e6 / self.simulated_us.max(1) as f64)
    }

    /// No sample lost anywhere: none dropped by the board, none missing at the host, none
    /// corrupted, one sample per period.
    pub fn lossless(&self) -> bool {
        self.queue_drops == 0
            && self.lost_samples == 0
            && self.bad_frames == 0
            && self.samples == self.steps
    }
}

/// A load that keeps the stream's frames changing: both sides swing through driving and
/// regenerating currents (period 7 s and 11 s) with the battery sagging under load.
pub fn swinging_load() -> impl LoadSource {
    |t_us: u64| {
        let t = t_us as f64 * 1e-6;
        let tau = std::f64::consts::TAU;
        let left = 8.0 + 12.0 * (tau * t / 7.0).sin();
        let right = -3.0 + 14.0 * (tau * t / 11.0).cos();
        let bus_v = 25.2 - 0.02 * (left.abs() + right.abs());
        Sides::new(
            SideLoad {
                current_a: left,
                bus_v,
            },
            SideLoad {
                current_a: right,
                bus_v,
            },
        )
    }
}

/// Runs the simulated board with `config` for `duration_us` of simulated time with a host
/// connected, draining its bytes into a [`StreamDecoder`] after every period (as USB does, many
/// packets per 5 ms), and reports what arrived. `progress` counts simulated seconds.
pub fn endurance(
    config: SamplerConfig,
    duration_us: u64,
    load: impl LoadSource + 'static,
    progress: &ProgressBar,
) -> Endurance {
    let start = Instant::now();
    let mut board = SimBoard::new(config);
    board.set_load(load);
    board.set_host_connected(true);
    let mut decoder = StreamDecoder::new();
    let mut buf: Vec<u8> = Vec::with_capacity(4096);
    let (mut steps, mut bytes, mut max_step_bus_ns) = (0u64, 0u64, 0u64);
    progress.set_length(duration_us / 1_000_000);
    while board.now_us() < duration_us {
        let before = board.bus().bus_time_ns();
        board.step();
        max_step_bus_ns = max_step_bus_ns.max(board.bus().bus_time_ns() - before);
        steps += 1;
        buf.clear();
        // Writing into a Vec cannot fail.
        let _ = board.drain_into(&mut buf);
        bytes += buf.len() as u64;
        decoder.feed(&buf, |_| {});
        if steps % 1_000 == 0 {
            progress.set_position(board.now_us() / 1_000_000);
        }
    }
    progress.set_position(duration_us / 1_000_000);
    let stats = decoder.stats();
    Endurance {
        simulated_us: board.now_us(),
        steps,
        samples: stats.samples,
        lost_samples: stats.lost_samples,
        bad_frames: stats.bad_frames,
        queue_drops: board.link().queue_drops(),
        bytes,
        bus_time_ns: board.bus().bus_time_ns(),
        max_step_bus_ns,
        period_us: board.board().sample_period_us(),
        wall: start.elapsed(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chip_conversion_limits() {
        assert!((conversion_limit_hz(FASTEST_ADC) - 1e6 / 280.0).abs() < 1e-9);
        assert!((conversion_limit_hz(FASTEST_ADC) - 3571.4).abs() < 0.1);
        assert!((conversion_limit_hz(AdcConfig::BOARD_DEFAULT) - 1e6 / 4480.0).abs() < 1e-9);
    }

    #[test]
    fn polling_design_needs_1_2_ms_of_bus_per_sample() {
        let t = bus_time_per_sample(SamplerConfig::BOARD, 512);
        assert_eq!(t.samples, 512);
        // 2 chips × 5 register reads × 48 SCL periods × 2.5 µs.
        assert_eq!(t.typical_ns, 1_200_000);
        // One more read per chip every 256 samples.
        assert_eq!(t.max_ns, 1_440_000);
        assert!((t.mean_ns - (1_200_000.0 + 2.0 * 240_000.0 / 512.0)).abs() < 1e-6);
        assert_eq!(t.min_period_us(), 1_440);
        assert!((t.sustained_rate_hz() - 694.44).abs() < 0.01);
        assert!((t.typical_rate_hz() - 833.33).abs() < 0.01);
        // The bus, not the chips, limits the rate: under a quarter of the chip's limit.
        assert!(t.sustained_rate_hz() < 0.25 * conversion_limit_hz(FASTEST_ADC));
    }

    #[test]
    fn a_simulated_minute_at_200_hz_loses_nothing() {
        // The simulated hour is in `benches/sim_rate.rs`; a minute covers every periodic frame.
        let run = endurance(
            SamplerConfig::BOARD,
            60_000_000,
            swinging_load(),
            &ProgressBar::hidden(),
        );
        assert_eq!(run.steps, 12_000);
        assert!(run.lossless(), "{run:?}");
        assert!(run.bus_fits());
        assert_eq!(run.period_us, 5_000);
        // 1.2 ms of 5 ms, plus the calibration checks (and the first sample's set-up).
        let u = run.bus_utilisation();
        assert!((0.240..0.2415).contains(&u), "{u}");
        assert!(run.bytes > 12_000 * 20, "{} bytes", run.bytes);
        assert_eq!(run.simulated_us, 60_000_000);
    }

    #[test]
    fn the_polling_limit_is_sustained_without_loss() {
        let limit = bus_time_per_sample(
            SamplerConfig {
                adc: FASTEST_ADC,
                ..SamplerConfig::BOARD
            },
            512,
        );
        let config = SamplerConfig {
            adc: FASTEST_ADC,
            sample_period_us: limit.min_period_us(),
            ..SamplerConfig::BOARD
        };
        let run = endurance(config, 5_000_000, swinging_load(), &ProgressBar::hidden());
        assert!(run.lossless(), "{run:?}");
        assert!(run.bus_fits());
        assert!(run.bus_utilisation() > 0.8, "{}", run.bus_utilisation());
    }
}
