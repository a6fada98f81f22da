//! Cross-crate end-to-end tests live in `tests/tests/`; this library holds their shared fixtures.

use firmware::sampler::SamplerConfig;
use host_tool::sim::board::{SideLoad, SimBoard};
use model_core::Sides;

/// A turn-like load: the left (inner) side regenerates for a while.
pub fn turn_like_load(t_us: u64) -> Sides<SideLoad> {
    let t = t_us as f64 * 1e-6;
    Sides::new(
        SideLoad {
            current_a: 2.0 * (t * 0.7).sin() - 0.3,
            bus_v: 24.6,
        },
        SideLoad {
            current_a: 4.0 + 0.5 * (t * 1.3).cos(),
            bus_v: 24.5,
        },
    )
}

/// The simulated board at the real board's sampler settings, under [`turn_like_load`].
pub fn sim_board() -> SimBoard {
    let mut sim = SimBoard::new(SamplerConfig::BOARD);
    sim.set_load(turn_like_load);
    sim
}
