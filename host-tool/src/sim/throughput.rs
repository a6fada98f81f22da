//! The sample rate the simulated board sustains: the I²C time the firmware's sampler spends
//! per sample at 400 kHz ([`bus_time_per_sample`]), the rate that allows against the INA226's
//! own conversion limit ([`conversion_limit_hz`]), and long runs of the whole board drained into
//! the host's decoder, checked for queue drops, lost samples, bus backlog and USB bytes per
//! second ([`endurance`]).

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

/// Samples that set the chips up: sample 0 initialises them (860 µs of bus), sample 1 reads
/// both registers with their pointers (the chips point at CAL after set-up).
pub const START_UP_SAMPLES: u64 = 2;

/// Bus time of the firmware's steady-state samples (both chips).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BusTimePerSample {
    /// Samples measured.
    pub samples: u64,
    /// The most common bus time per sample [ns].
    pub typical_ns: u64,
    /// The longest (a sample with a calibration read-back) [ns].
    pub max_ns: u64,
    /// Mean over the measured samples [ns].
    pub mean_ns: f64,
}

impl BusTimePerSample {
    /// The shortest period the bus keeps up with [ns]: the mean fits it, and the longest
    /// sample's overrun is made up by the typical sample after it within that one's period
    /// (the read-backs are 32 samples apart, so overruns never pile up).
    pub fn min_period_ns(&self) -> f64 {
        let absorbed = (self.max_ns + self.typical_ns) as f64 / 2.0;
        absorbed.max(self.mean_ns).max(self.typical_ns as f64)
    }

    /// The highest sample rate the bus keeps up with ([`Self::min_period_ns`]) [Hz].
    pub fn sustained_rate_hz(&self) -> f64 {
        1e9 / self.min_period_ns().max(1.0)
    }

    /// The rate if every sample were a typical one [Hz].
    pub fn typical_rate_hz(&self) -> f64 {
        1e9 / self.typical_ns.max(1) as f64
    }

    /// [`Self::min_period_ns`] rounded up to whole µs.
    pub fn min_period_us(&self) -> u32 {
        let us = (self.min_period_ns() / 1e3).ceil();
        if us >= f64::from(u32::MAX) {
            u32::MAX
        } else {
            us as u32
        }
    }
}

/// Runs the firmware's own sampler on the simulated board with `config` and measures the I²C
/// time of `samples` steady-state samples (after the start-up samples that set the chips up).
/// `samples` ≥ 64 includes both chips' calibration read-backs.
pub fn bus_time_per_sample(config: SamplerConfig, samples: u32) -> BusTimePerSample {
    const START_UP: u32 = START_UP_SAMPLES as u32;
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
    /// The longest I²C time of one period after the [`START_UP_SAMPLES`] [ns].
    pub max_step_bus_ns: u64,
    /// After the start-up samples, the longest the bus was still busy with earlier samples
    /// when a period began [ns] (a sample's reads start that much late; a whole period would
    /// skip one).
    pub max_backlog_ns: u64,
    /// Chip results no read returned, per chip (the sampler's count).
    pub skipped_results: Sides<u32>,
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

    /// Whether the bus kept up: no period began with the bus busy for a whole period (the
    /// calibration read-back's few µs of overrun are made up by the next sample).
    pub fn bus_keeps_up(&self) -> bool {
        self.max_backlog_ns < u64::from(self.period_us) * 1_000
    }

    /// Bytes per second the board sent over USB.
    pub fn usb_bytes_per_s(&self) -> f64 {
        self.bytes as f64 * 1e6 / self.simulated_us.max(1) as f64
    }

    /// How many times the stream fits in `capacity_bytes_per_s`.
    pub fn usb_margin(&self, capacity_bytes_per_s: f64) -> f64 {
        capacity_bytes_per_s / self.usb_bytes_per_s().max(f64::MIN_POSITIVE)
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
    let (mut backlog_ns, mut max_backlog_ns) = (0u64, 0u64);
    progress.set_length(duration_us / 1_000_000);
    while board.now_us() < duration_us {
        let before = board.bus().bus_time_ns();
        let period_ns = u64::from(board.board().sample_period_us()) * 1_000;
        board.step();
        let step_ns = board.bus().bus_time_ns() - before;
        if steps >= START_UP_SAMPLES {
            max_step_bus_ns = max_step_bus_ns.max(step_ns);
            // Lindley's recursion: the bus work still queued when the next period begins.
            backlog_ns = (backlog_ns + step_ns).saturating_sub(period_ns);
            max_backlog_ns = max_backlog_ns.max(backlog_ns);
        }
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
        max_backlog_ns,
        skipped_results: board.board().sampler().skipped_results(),
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
    fn two_reads_per_chip_need_385_us_of_bus_per_sample() {
        let t = bus_time_per_sample(SamplerConfig::BOARD, 512);
        assert_eq!(t.samples, 512);
        // Per chip one short read (29 SCL periods) and one with its pointer (48): 154 periods.
        assert_eq!(t.typical_ns, 385_000);
        // A calibration read-back adds one read with pointer to one chip.
        assert_eq!(t.max_ns, 505_000);
        // 512 samples from seq 2 hold 16 read-backs (every 32nd sample, chips alternating).
        assert!((t.mean_ns - (385_000.0 + 16.0 * 120_000.0 / 512.0)).abs() < 1e-6);
        // The read-back's overrun is absorbed by the next sample: (505 + 385) / 2 = 445 µs.
        assert_eq!(t.min_period_us(), 445);
        assert!((t.sustained_rate_hz() - 2_247.19).abs() < 0.01);
        assert!((t.typical_rate_hz() - 2_597.40).abs() < 0.01);
        // The firmware's floor (500 µs) is above it, and under the chip's own limit.
        assert!(t.min_period_us() <= model_core::rate::MIN_SAMPLE_PERIOD_US);
        assert!(t.sustained_rate_hz() < conversion_limit_hz(FASTEST_ADC));
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
        assert!(run.bus_keeps_up());
        assert_eq!(run.max_backlog_ns, 0);
        assert_eq!(run.period_us, 5_000);
        // 385 µs of 5 ms, plus the read-backs (and the first samples' set-up).
        let u = run.bus_utilisation();
        assert!((0.0776..0.0779).contains(&u), "{u}");
        assert!(run.bytes > 12_000 * 20, "{} bytes", run.bytes);
        assert_eq!(run.simulated_us, 60_000_000);
        // 5 ms against 4.48 ms conversions: a result goes unread about once in 9 reads.
        let skipped = run.skipped_results.left;
        assert!((1_200..1_450).contains(&skipped), "{skipped}");
    }

    #[test]
    fn two_khz_is_sustained_without_loss() {
        let config = SamplerConfig::with_period(500).expect("the floor");
        let run = endurance(config, 5_000_000, swinging_load(), &ProgressBar::hidden());
        assert_eq!(run.steps, 10_000);
        assert!(run.lossless(), "{run:?}");
        assert!(run.bus_keeps_up());
        // The read-back sample overruns its period by 5 µs; the next one makes it up.
        assert_eq!(run.max_step_bus_ns, 505_000);
        assert_eq!(run.max_backlog_ns, 5_000);
        assert!(run.bus_utilisation() > 0.77, "{}", run.bus_utilisation());
        // 408 µs conversions read every 500 µs: about one result in 5.5 unread.
        let skipped = f64::from(run.skipped_results.left) / run.steps as f64;
        assert!((0.2..0.25).contains(&skipped), "{skipped}");
        // Sample frames of ~36 bytes 2000 times a second, plus model and status frames.
        let rate = run.usb_bytes_per_s();
        assert!((60_000.0..90_000.0).contains(&rate), "{rate} B/s");
    }
}
