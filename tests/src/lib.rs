//! Cross-crate end-to-end tests live in `tests/tests/`; this library holds their shared fixtures.

use firmware::sampler::SamplerConfig;
use host_tool::decode::StreamDecoder;
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

/// The host's energy is the board's, bit for bit: the board's latest model frame equals the
/// host's recomputation at that sample, and the board's own total at its last sample equals the
/// host's. Returns that model frame's `seq` and the board's total [LSB·µs].
pub fn assert_host_energy_is_the_boards(decoder: &StreamDecoder, board: &SimBoard) -> (u32, i64) {
    let (model, host) = decoder.board_vs_host_energy().expect("model frames");
    assert_eq!(
        [
            model.snapshot.energy_lsb_us.left,
            model.snapshot.energy_lsb_us.right
        ],
        host
    );
    let board_total = board.board().sampler().measurements().total_energy_lsb_us();
    assert_eq!(decoder.measurements().total_energy_lsb_us(), board_total);
    (model.seq, board_total)
}
