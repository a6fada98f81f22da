//! One wheel's per-sample soil work in the host's simulator, timed:
//! `cargo bench -p model-core --bench soil_step`.
//!
//! `sinkage_and_bulldozing` is the figure that matters: one step of the 2D slip-sinkage model
//! (Eq 5.15–5.28) feeding one step of the sand bulldozing model (Eq 5.29–5.37, including the
//! golden-section minimisation over X_C). The other two split it.

use divan::{black_box, Bencher};
use model_core::soil::{
    PileLimit, SandBulldozer, SandBulldozing, SlipSinkage2d, SlipSinkageParams, Soil,
};

fn main() {
    divan::main();
}

/// 1024 distinct (v_ACT, β, v_CMD) samples around the seed's test-bed cases, so the branch
/// predictor cannot learn one value. β stays in 20°–160° so the wheel always bulldozes (w > 0)
/// and the X_C search always runs.
fn inputs() -> Vec<(f64, f64, f64)> {
    (0..1024)
        .map(|k| {
            let u = k as f64 / 1024.0;
            let v_act = 0.01 + 0.08 * u;
            let beta = (20.0 + 140.0 * ((k * 37) % 1024) as f64 / 1024.0).to_radians();
            let v_cmd = -0.2 + 0.4 * ((k * 101) % 1024) as f64 / 1024.0;
            (v_act, beta, v_cmd)
        })
        .collect()
}

const DT_S: f64 = 0.05;

struct Wheel {
    inputs: Vec<(f64, f64, f64)>,
    sinkage: SlipSinkage2d,
    bulldozer: SandBulldozer,
    k: usize,
}

impl Wheel {
    fn new() -> Self {
        Self {
            inputs: inputs(),
            sinkage: SlipSinkage2d::new(SlipSinkageParams::HUSKY_GRC1).expect("Table 5.1"),
            bulldozer: SandBulldozer::new(Soil::GRC1_SANDBOX, PileLimit::RunningMax)
                .expect("Table 3.3"),
            k: 0,
        }
    }

    fn next_input(&mut self) -> (f64, f64, f64) {
        self.k = self.k.wrapping_add(1);
        black_box(self.inputs[self.k & 1023])
    }
}

/// 2D slip-sinkage step alone (Eq 5.15–5.28).
#[divan::bench]
fn sinkage(bencher: Bencher) {
    let mut w = Wheel::new();
    bencher.bench_local(|| {
        let (v_act, beta, v_cmd) = w.next_input();
        black_box(w.sinkage.step(v_act, beta, v_cmd, DT_S)).ok();
    });
}

/// Bulldozing force alone: Eq 5.33–5.36 and the X_C minimisation of Eq 5.35.
#[divan::bench]
fn bulldozing_force(bencher: Bencher) {
    let model = SandBulldozing::new(Soil::GRC1_SANDBOX).expect("Table 3.3");
    let mut k = 0usize;
    bencher.bench_local(|| {
        k = k.wrapping_add(1);
        let u = (k & 1023) as f64 / 1024.0;
        black_box(model.force(
            black_box(0.05 + 0.15 * u),
            black_box(0.0085 + 0.05 * u),
            black_box(0.6 * u),
            black_box(0.24),
        ))
        .ok();
    });
}

/// One wheel, one sample: sinkage step, then bulldozing step (force and P^AS) from its d_avg, w_g.
#[divan::bench]
fn sinkage_and_bulldozing(bencher: Bencher) {
    let mut w = Wheel::new();
    bencher.bench_local(|| {
        let (v_act, beta, v_cmd) = w.next_input();
        w.sinkage.step(v_act, beta, v_cmd, DT_S).ok();
        let d_avg = w.sinkage.average_sinkage_m();
        let w_g = w.sinkage.ground_width_m();
        black_box(w.bulldozer.step(d_avg, w_g, beta, v_act, DT_S)).ok();
    });
}
