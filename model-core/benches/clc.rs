//! One energy-optimal CLC path (paper Eq 46) on hard ground, timed on the host:
//! `cargo bench -p model-core --bench clc`.

use divan::{black_box, Bencher};
use model_core::paths::{optimise_clc, ClcEnds, ClcPath};
use model_core::power::IcrHardGround;

fn main() {
    divan::main();
}

fn table_3_first_case() -> ClcEnds {
    ClcEnds::new(45f64.to_radians(), 45f64.to_radians(), 10.0).expect("valid Eq 50 ends")
}

/// Paper Table 3, CLC (45°, 45°, 10 m): the full optimisation, PLP energy included.
#[divan::bench]
fn optimise_45_45_10m(bencher: Bencher) {
    let ends = table_3_first_case();
    let law = IcrHardGround::HUSKY_HARD_GROUND;
    bencher.bench_local(|| optimise_clc(black_box(&law), black_box(&ends)));
}

/// One evaluation inside the optimiser: tangent line (Eq 47–49) and energy (Eq 45).
#[divan::bench]
fn path_and_energy(bencher: Bencher) {
    let ends = table_3_first_case();
    let law = IcrHardGround::HUSKY_HARD_GROUND;
    bencher.bench_local(|| {
        ClcPath::new(black_box(&ends), black_box(0.645), black_box(0.645)).map(|p| p.energy_j(&law))
    });
}
