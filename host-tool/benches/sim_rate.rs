//! The sample rate the simulated board sustains with realistic bus timing, and a simulated hour
//! at the board's default rate: `cargo bench -p host-tool --bench sim_rate`.
//!
//! Prints the figures first (I²C time per sample at 400 kHz, the rate the firmware's polling
//! design sustains against the INA226's own conversion limit, and the hour's samples, drops,
//! losses and wall time), then times one board period with divan. Under `cargo test --benches`
//! (or with `--test`) the run is one simulated minute.

use divan::{black_box, Bencher};
use embedded_hal::i2c::I2c;
use firmware::sampler::SamplerConfig;
use host_tool::decode::StreamDecoder;
use host_tool::sim::board::SimBoard;
use host_tool::sim::throughput::{
    bus_time_per_sample, conversion_limit_hz, endurance, swinging_load, FASTEST_ADC,
};
use host_tool::sim::SimBus;

fn main() {
    // Like divan: without cargo bench's `--bench` (i.e. under `cargo test`), or with `--test`,
    // run everything once, briefly.
    let args: Vec<String> = std::env::args().collect();
    let test_mode = args.iter().any(|a| a == "--test") || !args.iter().any(|a| a == "--bench");
    report(if test_mode { 60 } else { 3_600 });
    divan::main();
}

fn report(seconds: u64) {
    let board = SamplerConfig::BOARD;
    let bus = bus_time_per_sample(board, 1_024);
    let chip_hz = conversion_limit_hz(FASTEST_ADC);
    println!("I²C at {} kHz, firmware polling both chips:", 400);
    println!(
        "  bus time per sample: {:.0} µs typical, {:.0} µs with the calibration check (every 256), mean {:.1} µs",
        bus.typical_ns as f64 / 1e3,
        bus.max_ns as f64 / 1e3,
        bus.mean_ns / 1e3
    );
    println!(
        "  sustained sample rate: {:.1} Hz (period ≥ {} µs); {:.1} Hz if every sample were typical",
        bus.sustained_rate_hz(),
        bus.min_period_us(),
        bus.typical_rate_hz()
    );
    println!(
        "  chip's own limit (1 × (140 + 140) µs): {:.1} Hz per chip; polling design reaches {:.3} of it",
        chip_hz,
        bus.sustained_rate_hz() / chip_hz
    );
    println!(
        "  board default ({} µs period, {} × ({} + {}) µs averaging = {:.1} Hz fresh results): bus busy {:.1} % of the time",
        board.sample_period_us,
        board.adc.averaging.count(),
        board.adc.shunt_conversion.micros(),
        board.adc.bus_conversion.micros(),
        conversion_limit_hz(board.adc),
        100.0 * bus.mean_ns / (f64::from(board.sample_period_us) * 1e3)
    );

    let progress = host_tool::progress::bar(seconds, "simulated seconds");
    let run = endurance(board, seconds * 1_000_000, swinging_load(), &progress);
    progress.finish_and_clear();
    println!(
        "Simulated {} s at {} µs: {} periods, {} samples received, {} queue drops, {} lost, {} bad frames, {} bytes",
        run.simulated_us / 1_000_000,
        run.period_us,
        run.steps,
        run.samples,
        run.queue_drops,
        run.lost_samples,
        run.bad_frames,
        run.bytes
    );
    println!(
        "  bus utilisation {:.2} %, longest period's bus time {} µs ({}), wall {:.2} s ({:.2} s per simulated hour){}",
        100.0 * run.bus_utilisation(),
        run.max_step_bus_ns / 1_000,
        if run.bus_fits() { "fits" } else { "DOES NOT FIT" },
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
