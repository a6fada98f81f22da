//! The commands CSV: what the rover's controller commanded, over time, and optionally the pose a
//! tracker measured. `record --commands FILE` forwards the speeds to the board (so its τ ∝ P/ω
//! estimates are live) and copies speeds and pose into the run log; the simulated world writes
//! one for each scenario it runs.

use model_core::Sides;

/// One row of a commands CSV: from `t_s` on (until the next row) the controller commands these
/// side speeds; `yaw_rad`/`pitch_deg` are the pose a tracker measured at `t_s`, if any.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CommandRow {
    /// Time since the start of the run [s], strictly increasing.
    pub t_s: f64,
    /// Commanded linear speed of each side [m/s], positive forward.
    pub cmd_mps: Sides<f64>,
    /// Yaw [rad], counter-clockwise positive, if tracked.
    pub yaw_rad: Option<f64>,
    /// Pitch [deg], nose-up positive, if tracked.
    pub pitch_deg: Option<f64>,
}
