//! The sample rate the simulated board sustains with realistic bus timing, and a simulated hour
//! at 2 kHz (the bus's floor) and at the default 200 Hz: `cargo bench -p host-tool --bench
//! sim_rate`.
//!
//! Prints the figures first (I²C time per sample at 400 kHz, the rate the firmware's two-read
//! sampler sustains against the INA226's own conversion limit, each hour's samples, drops,
//! losses, bus backlog, skipped chip results, USB bytes per second and their margin, and wall
//! time), then times one board period with divan. Under `cargo test --benches` (or with
//! `--test`) each run is one simulated minute.

use divan::{black_box, Bencher};
use embedded_hal::i2c::I2c;
use firmware::sampler::SamplerConfig;
use host_tool::decode::StreamDecoder;
use host_tool::sim::board::SimBoard;
use host_tool::sim::throughput::{
    bus_time_per_sample, conversion_limit_hz, endurance, swinging_load, FASTEST_ADC,
};
use host_tool::sim::SimBus;
use model_core::rate::MIN_SAMPLE_PERIOD_US;

/// USB 2.0 full-speed bulk ceiling [B/s]: 19 packets of 64 bytes per 1 ms frame (USB 2.0
/// specification, Table 5-9).
const USB_FS_BULK_CEILING_B_S: f64 = 19.0 * 64.0 * 1_000.0;
/// What CDC-ACM full speed delivered from an STM32 to a PC reading the port continuously:
/// ~1.15 MB/s (9.2 Mbit/s, ST community, "USB CDC packet loss at high data rates", 2025:
/// <https://community.st.com/t5/stm32-mcus-embedded-software/usb-cdc-packet-loss-at-high-data-rates/td-p/866027>).
const CDC_ACM_MEASURED_B_S: f64 = 1_150_000.0;
/// A host that services the port less eagerly (a hub, a busy laptop): plan for a quarter of it.
const CDC_ACM_PLANNING_B_S: f64 = CDC_ACM_MEASURED_B_S / 4.0;

fn main() {
    // Like divan: without cargo bench's `--bench` (i.e. under `cargo test`), or with `--test`,
    // run everything once, briefly.
    let args: Vec<String> = std::env::args().collect();
    let test_mode = args.iter().any(|a| a == "--test") || !args.iter().any(|a| a == "--bench");
    let seconds = if test_mode { 60 } else { 3_600 };
    bus_report();
    match SamplerConfig::with_period(MIN_SAMPLE_PERIOD_US) {
        Some(fast) => hour(fast, seconds),
        None => println!("no configuration at {MIN_SAMPLE_PERIOD_US} µs (a bug)"),
    }
    hour(SamplerConfig::BOARD, seconds);
    divan::main();
}

fn bus_report() {
    let fast = SamplerConfig {
        adc: FASTEST_ADC,
        sample_period_us: MIN_SAMPLE_PERIOD_US,
        ..SamplerConfig::BOARD
    };
    let bus = bus_time_per_sample(fast, 1_024);
    let chip_hz = conversion_limit_hz(FASTEST_ADC);
    println!(
        "I²C at {} kHz, firmware reading shunt and bus of both chips (current and power derived):",
        model_core::rate::SCL_HZ / 1_000
    );
    println!(
        "  bus time per sample: {:.0} µs typical, {:.0} µs with a calibration read-back (one chip, every 32nd sample), mean {:.1} µs",
        bus.typical_ns as f64 / 1e3,
        bus.max_ns as f64 / 1e3,
        bus.mean_ns / 1e3
    );
    println!(
        "  sustained sample rate: {:.1} Hz (period ≥ {} µs, the read-back's overrun made up by the next sample); {:.1} Hz if every sample were typical",
        bus.sustained_rate_hz(),
        bus.min_period_us(),
        bus.typical_rate_hz()
    );
    println!(
        "  firmware floor: {} µs ({:.0} Hz), bus busy {:.1} % of it; chip's own limit (1 × (140 + 140) µs): {:.1} Hz per chip",
        MIN_SAMPLE_PERIOD_US,
        1e6 / f64::from(MIN_SAMPLE_PERIOD_US),
        100.0 * bus.mean_ns / (f64::from(MIN_SAMPLE_PERIOD_US) * 1e3),
        chip_hz,
    );
}

/// A simulated hour (or minute) of `config`, drained into the host's decoder.
fn hour(config: SamplerConfig, seconds: u64) {
    let progress = host_tool::progress::bar(seconds, "simulated seconds");
    let run = endurance(config, seconds * 1_000_000, swinging_load(), &progress);
    progress.finish_and_clear();
    println!(
        "Simulated {} s at {} µs ({:.0} Hz; {} × ({} + {}) µs averaging): {} periods, {} samples received, {} queue drops, {} lost, {} bad frames",
        run.simulated_us / 1_000_000,
        run.period_us,
        1e6 / f64::from(run.period_us),
        config.adc.averaging.count(),
        config.adc.shunt_conversion.micros(),
        config.adc.bus_conversion.micros(),
        run.steps,
        run.samples,
        run.queue_drops,
        run.lost_samples,
        run.bad_frames,
    );
    println!(
        "  bus utilisation {:.2} %, longest period's bus time {} µs, largest backlog {} µs ({}); chip results unread: {} left, {} right ({:.3} per sample)",
        100.0 * run.bus_utilisation(),
        run.max_step_bus_ns / 1_000,
        run.max_backlog_ns / 1_000,
        if run.bus_keeps_up() { "keeps up" } else { "FALLS BEHIND" },
        run.skipped_results.left,
        run.skipped_results.right,
        f64::from(run.skipped_results.left) / run.steps.max(1) as f64,
    );
    println!(
        "  USB: {} bytes, {:.0} B/s; margin {:.1}× the full-speed bulk ceiling ({:.0} B/s), {:.1}× measured CDC-ACM ({:.0} B/s), {:.1}× a quarter of it",
        run.bytes,
        run.usb_bytes_per_s(),
        run.usb_margin(USB_FS_BULK_CEILING_B_S),
        USB_FS_BULK_CEILING_B_S,
        run.usb_margin(CDC_ACM_MEASURED_B_S),
        CDC_ACM_MEASURED_B_S,
        run.usb_margin(CDC_ACM_PLANNING_B_S),
    );
    println!(
        "  wall {:.2} s ({:.2} s per simulated hour){}",
        run.wall.as_secs_f64(),
        run.wall_per_simulated_hour().as_secs_f64(),
        if run.lossless() { "" } else { "  LOSSES" }
    );
    println!();
}

/// One board period with a host attached: step (sample both chips, queue frames), drain and
/// decode — the host's cost per simulated sample.
#[divan::bench]
fn board_period_with_host(bencher: Bencher) {
    let mut board = SimBoard::new(SamplerConfig::BOARD);
    board.set_load(swinging_load());
    board.set_host_connected(true);
    let mut decoder = StreamDecoder::new();
    let mut buf = Vec::with_capacity(4096);
    bencher.bench_local(move || {
        board.step();
        buf.clear();
        let _ = board.drain_into(&mut buf);
        decoder.feed(&buf, |e| {
            black_box(e);
        });
    });
}

/// One board period without a host (the link discards frames).
#[divan::bench]
fn board_period_no_host(bencher: Bencher) {
    let mut board = SimBoard::new(SamplerConfig::BOARD);
    board.set_load(swinging_load());
    bencher.bench_local(move || black_box(board.step()));
}

/// One simulated register read (pointer write, repeated start, 2-byte read).
#[divan::bench]
fn sim_bus_register_read(bencher: Bencher) {
    let mut bus = SimBus::board();
    let mut buf = [0u8; 2];
    bencher.bench_local(move || {
        let _ = bus.write_read(0x40, black_box(&[0x01]), &mut buf);
        black_box(buf)
    });
}
