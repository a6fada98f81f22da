//! `[tracker]`: the pose tracker of the simulated world — a total station following a prism
//! (thesis Section 5.1: 5 Hz, the prism δx_lp = 0.21 m right of the rover's centre, Fig. 5.3),
//! or with `offset_m = 0` the rover's centre itself (RTK GNSS, motion capture, odometry fusion).
//! Each fix is the tracked point's true position plus Gaussian noise per coordinate; a fix is
//! lost with probability `dropout` (the total station losing the prism, which Section 5.1's gap
//! filling repairs). Noise and dropouts are drawn from the run's seed and the fix's time.

use serde::{Deserialize, Serialize};

/// `[tracker]` of a world file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Tracker {
    /// Lateral offset of the tracked point from the rover's centre, positive to the right [m].
    pub offset_m: f64,
    /// Fix rate [Hz]; 0 for no position fixes.
    pub rate_hz: f64,
    /// Noise of each coordinate [m, std].
    pub position_std_m: f64,
    /// Probability that a fix is lost, in [0, 0.5].
    pub dropout: f64,
}

impl Default for Tracker {
    /// The thesis' total station: the prism 0.21 m right of the centre, 5 Hz; 2 mm per
    /// coordinate and 5 % lost fixes (our figures: the seed gives neither).
    fn default() -> Self {
        Self {
            offset_m: model_core::tracking::PRISM_OFFSET_M,
            rate_hz: 1.0 / model_core::tracking::TOTAL_STATION_PERIOD_S,
            position_std_m: 0.002,
            dropout: 0.05,
        }
    }
}

impl Tracker {
    /// The fix times of a run of `duration_us` [µs]: every 1/`rate_hz` from 0 (none if the rate
    /// is 0).
    pub fn fix_times_us(&self, duration_us: u64) -> Vec<u64> {
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0) {
            return Vec::new();
        }
        let period_us = 1e6 / self.rate_hz;
        (0u64..)
            .map(|k| (k as f64 * period_us).round() as u64)
            .take_while(|&t| t <= duration_us)
            .collect()
    }

    /// The tracked point of a rover whose centre is at `centre_m` heading `yaw_rad` (forward
    /// direction, counter-clockwise from +x): `offset_m` along its right axis (sin ψ, −cos ψ).
    pub fn point_m(&self, centre_m: (f64, f64), yaw_rad: f64) -> (f64, f64) {
        let (s, c) = yaw_rad.sin_cos();
        (
            centre_m.0 + self.offset_m * s,
            centre_m.1 - self.offset_m * c,
        )
    }
}
