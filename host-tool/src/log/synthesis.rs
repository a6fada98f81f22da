//! Frame synthesis: the byte stream the board would have sent for a log of physical samples
//! (a run CSV), used by `replay` and by `convert` (CSV → MCAP): a hello, one sample frame per row
//! with the registers our INA226s would have read ([`registers_of`], quantised at
//! [`Scale::BOARD`]), model frames every [`MODEL_PERIOD_US`] from model-core's own running
//! measurements, as the firmware computes them, and the board's status report of each
//! commanded change of wheel rates ([`command_report`]). The synthesised hello reports firmware
//! 0.0.0 so a reader can tell it from a real board.

use crate::log::run_csv::RunSample;
use firmware::board::MODEL_PERIOD_US;
use firmware::sampler::{BOARD_ADDRESSES, DEFAULT_SAMPLE_PERIOD_US};
use model_core::energy::RunningMeasurements;
use model_core::ina226::{
    AdcConfig, BusVoltageRaw, CurrentRaw, PowerRaw, Registers, Scale, ShuntVoltageRaw, BUS_LSB_UV,
    SHUNT_LSB_NV,
};
use model_core::wire::{
    BoardFrame, ChipReading, FirmwareVersion, Hello, Model, Sample, Status, MAX_SAMPLE_PERIOD_US,
    MIN_SAMPLE_PERIOD_US, PROTOCOL_VERSION,
};
use model_core::{Rover, Sides};

/// Registers an INA226 on our board ([`Scale::BOARD`]: 5 mΩ shunt, 0.5 mA current LSB) reads
/// for a steady `bus_v` [V] and `current_a` [A]: shunt and current rounded to the nearest LSB
/// (so |error| ≤ 1.25 µV / 0.25 mA), clamped to i16 (±16.38 A, the shunt's 81.92 mV full
/// scale); bus rounded to the nearest 1.25 mV, clamped to 0..=40.96 V; power = |current| × bus
/// / 20000 truncated, as the chip computes it (datasheet Eq 4; ≤ 12.5 mW below |I|·V).
pub fn registers_of(bus_v: f64, current_a: f64) -> Registers {
    let scale = Scale::BOARD;
    // `as` saturates (and maps NaN to 0): the clamp to the register's range.
    let shunt_v = current_a * f64::from(scale.shunt_micro_ohm) * 1e-6;
    let shunt = (shunt_v / (f64::from(SHUNT_LSB_NV) * 1e-9)).round() as i16;
    let current = (current_a / (f64::from(scale.current_lsb_na) * 1e-9)).round() as i16;
    let bus = ((bus_v / (f64::from(BUS_LSB_UV) * 1e-6)).round() as i32).clamp(0, 0x7FFF) as u16;
    let power = (u32::from(current.unsigned_abs()) * u32::from(bus) / 20_000) as u16;
    Registers {
        shunt: ShuntVoltageRaw(shunt),
        bus: BusVoltageRaw(bus),
        current: CurrentRaw(current),
        power: PowerRaw(power),
    }
}

/// The hello of a synthesised stream: our board's scale, LSBs, chip addresses and default ADC
/// configuration, firmware 0.0.0 (no board sent it), the given sampling period.
pub fn synthetic_hello(sample_period_us: u32) -> Hello {
    let scale = Scale::BOARD;
    Hello {
        protocol: PROTOCOL_VERSION,
        firmware: FirmwareVersion {
            major: 0,
            minor: 0,
            patch: 0,
        },
        scale,
        power_lsb_uw: scale.power_lsb_uw(),
        shunt_lsb_nv: SHUNT_LSB_NV,
        bus_lsb_uv: BUS_LSB_UV,
        addresses: BOARD_ADDRESSES,
        adc: AdcConfig::BOARD_DEFAULT,
        sample_period_us,
        identity: model_core::board_id::BoardIdentity::UNKNOWN,
        chips: model_core::Sides::new(
            model_core::wire::ChipProbe::NotRead,
            model_core::wire::ChipProbe::NotRead,
        ),
    }
}

/// The frames the board would have sent for `samples`, at their run times: a hello, then per
/// sample a sample frame (board time `t_us` = µs since the first sample, `seq` = row index,
/// both chips fresh with [`registers_of`]) and, every [`MODEL_PERIOD_US`], the model frame
/// (energy integrated by model-core from those registers; τ undefined, as no wheel rates were
/// commanded to this board). The hello's period is the median sample interval (clamped to
/// the range a host may configure; 5 ms for fewer than two samples).
///
/// With `commands_for` a rover, the samples' commanded speeds are commanded to the board as
/// well: at the first sample and wherever `cmd_*` changes, the board's status report of the new
/// wheel rates (v / wheel radius, [`command_report`]) precedes the sample, and the model frames'
/// τ ∝ P/ω uses them.
pub fn synthesise_frames(
    samples: &[RunSample],
    commands_for: Option<&Rover>,
) -> Vec<(f64, BoardFrame)> {
    let Some(first) = samples.first() else {
        return Vec::new();
    };
    let t_us = |s: &RunSample| synthesised_t_us(first.t_s, s.t_s);
    let mut intervals: Vec<u64> = samples
        .windows(2)
        .map(|w| t_us(&w[1]).saturating_sub(t_us(&w[0])))
        .collect();
    intervals.sort_unstable();
    let period_us =
        intervals
            .get(intervals.len() / 2)
            .map_or(DEFAULT_SAMPLE_PERIOD_US, |&median| {
                u32::try_from(median)
                    .unwrap_or(MAX_SAMPLE_PERIOD_US)
                    .clamp(MIN_SAMPLE_PERIOD_US, MAX_SAMPLE_PERIOD_US)
            });
    let mut frames = Vec::with_capacity(samples.len() * 11 / 10 + 1);
    let hello = synthetic_hello(period_us);
    frames.push((first.t_s, BoardFrame::Hello(hello)));
    let mut measurements = RunningMeasurements::new(Scale::BOARD);
    let mut last_model_us: Option<u64> = None;
    let mut last_cmd: Option<Sides<f64>> = None;
    for (seq, s) in samples.iter().enumerate() {
        let t = t_us(s);
        let seq = seq as u32;
        if let Some(rover) = commands_for.filter(|_| last_cmd != Some(s.cmd_mps)) {
            last_cmd = Some(s.cmd_mps);
            let rates = wheel_rates(s.cmd_mps, rover);
            measurements.set_wheel_rates(Some(rates));
            let status = command_report(None, &hello, t, seq, rates);
            frames.push((s.t_s, BoardFrame::Status(status)));
        }
        let regs = Sides::new(
            registers_of(s.bus_v.left, s.current_a.left),
            registers_of(s.bus_v.right, s.current_a.right),
        );
        measurements.update(t, regs.map(Some));
        frames.push((
            s.t_s,
            BoardFrame::Sample(Sample {
                t_us: t,
                seq,
                chips: regs.map(ChipReading::Fresh),
            }),
        ));
        // The firmware's cadence (firmware::board): a model frame after the sample once
        // MODEL_PERIOD_US has passed since the previous one.
        if last_model_us.is_none_or(|last| t.wrapping_sub(last) >= MODEL_PERIOD_US) {
            last_model_us = Some(t);
            frames.push((
                s.t_s,
                BoardFrame::Model(Model {
                    t_us: t,
                    seq,
                    snapshot: measurements.snapshot(),
                }),
            ));
        }
    }
    frames
}

/// The board time [µs] a synthesised stream stamps the sample logged at `t_s` with, the first
/// sample logged at `first_t_s` (so a recording of it starts its run time there).
pub fn synthesised_t_us(first_t_s: f64, t_s: f64) -> u64 {
    ((t_s - first_t_s) * 1e6).round() as u64
}

/// Wheel rates for side speeds `cmd_mps` [m/s] on `rover`'s wheels [rad/s], as `record`
/// commands them.
pub fn wheel_rates(cmd_mps: Sides<f64>, rover: &Rover) -> Sides<f32> {
    cmd_mps.map(|v| (v / f64::from(rover.wheel_radius_m)) as f32)
}

/// The board's status report right after it applied `rates`: the latest logged status (or, in
/// a stream that has none yet, the hello's configuration, running, no faults) with uptime
/// `uptime_us`, `samples` taken and the new wheel rates.
pub fn command_report(
    latest: Option<&Status>,
    hello: &Hello,
    uptime_us: u64,
    samples: u32,
    rates: Sides<f32>,
) -> Status {
    let base = latest.copied().unwrap_or(Status {
        uptime_us,
        samples,
        running: true,
        i2c_errors: Sides::new(0, 0),
        reinits: Sides::new(0, 0),
        skipped_results: Sides::new(0, 0),
        last_fault: Sides::new(None, None),
        queue_drops: 0,
        rx_errors: 0,
        adc: hello.adc,
        sample_period_us: hello.sample_period_us,
        wheel_rates_rad_s: None,
    });
    Status {
        uptime_us,
        samples,
        wheel_rates_rad_s: Some(rates),
        ..base
    }
}
