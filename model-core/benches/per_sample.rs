//! What the board does with model-core for every sample, timed on the host:
//! `cargo bench -p model-core --bench per_sample`.
//! (On-target instruction counts come from `firmware/qemu-model-core.sh`.)

use divan::{black_box, Bencher};
use model_core::energy::RunningMeasurements;
use model_core::ina226::{BusVoltageRaw, CurrentRaw, PowerRaw, Registers, Scale, ShuntVoltageRaw};
use model_core::wire::{self, BoardFrame, ChipReading, FrameDecoder, Sample, MAX_FRAME};
use model_core::Sides;

fn main() {
    divan::main();
}

/// 1024 distinct register sets so the branch predictor cannot learn one value.
fn readings() -> Vec<Sides<Registers>> {
    (0..1024i32)
        .map(|k| {
            let regs = |i: i32| Registers {
                shunt: ShuntVoltageRaw(i as i16),
                bus: BusVoltageRaw(19_000 + (k % 300) as u16),
                current: CurrentRaw(i as i16),
                power: PowerRaw((i.unsigned_abs() * 19_000 / 20_000) as u16),
            };
            Sides::new(regs(k * 7 - 3000), regs(4000 - k * 3))
        })
        .collect()
}

fn sample_frame(k: usize, r: Sides<Registers>) -> BoardFrame {
    BoardFrame::Sample(Sample {
        t_us: 600_000_000 + k as u64 * 5_000,
        seq: k as u32,
        chips: Sides::new(ChipReading::Fresh(r.left), ChipReading::Fresh(r.right)),
    })
}

/// A turn in progress: running measurements with commanded wheel rates (so τ is computed), fed
/// the k-th of 1024 distinct readings at 200 Hz.
struct Board {
    readings: Vec<Sides<Registers>>,
    measurements: RunningMeasurements,
    k: usize,
}

impl Board {
    fn new() -> Self {
        let mut measurements = RunningMeasurements::new(Scale::BOARD);
        measurements.set_wheel_rates(Some(Sides::new(-1.2, 3.6)));
        Self {
            readings: readings(),
            measurements,
            k: 0,
        }
    }

    /// One sample's update; returns its registers.
    fn update(&mut self) -> Sides<Registers> {
        self.k = self.k.wrapping_add(1);
        let r = self.readings[self.k & 1023];
        self.measurements.update(
            black_box(self.k as u64 * 5_000),
            black_box(Sides::new(Some(r.left), Some(r.right))),
        );
        r
    }
}

/// Running power and exact energy update for one sample (both sides).
#[divan::bench]
fn update(bencher: Bencher) {
    let mut board = Board::new();
    bencher.bench_local(|| board.update());
}

/// Update plus the model snapshot (power, energy, τ ∝ P/ω per side) sent in model frames.
#[divan::bench]
fn update_and_snapshot(bencher: Bencher) {
    let mut board = Board::new();
    bencher.bench_local(|| {
        board.update();
        black_box(board.measurements.snapshot())
    });
}

/// The board's full per-sample model-core work: update + encode the sample frame for USB.
#[divan::bench]
fn update_and_encode(bencher: Bencher) {
    let mut board = Board::new();
    let mut buf = [0u8; MAX_FRAME];
    bencher.bench_local(|| {
        let r = board.update();
        wire::encode(black_box(&sample_frame(board.k, r)), &mut buf)
            .map(black_box)
            .ok();
    });
}

/// Host side: decoding one sample frame from the byte stream.
#[divan::bench]
fn decode_sample_frame(bencher: Bencher) {
    let stream: Vec<u8> = readings()
        .into_iter()
        .enumerate()
        .flat_map(|(k, r)| {
            let mut buf = [0u8; MAX_FRAME];
            let n = wire::encode(&sample_frame(k, r), &mut buf).unwrap_or(0);
            buf[..n].to_vec()
        })
        .collect();
    let frames: Vec<&[u8]> = stream.split_inclusive(|&b| b == 0).collect();
    let mut dec = FrameDecoder::new();
    let mut k = 0usize;
    bencher.bench_local(|| {
        k = k.wrapping_add(1);
        let mut last = None;
        dec.feed::<BoardFrame>(black_box(frames[k & 1023]), |f| last = Some(f));
        black_box(last)
    });
}
