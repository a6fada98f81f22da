//! Post-processing of the total-station track of the rover's landmark prism (Section 5.1): data-loss
//! correction (Hampel filter on the step distances and quadratic gap filling), the circle fit that
//! gives the actual turning radius R_ACT, the heading θ_H and the four wheel positions
//! (Eq 5.3–5.9), the wheels' actual speeds and directions (Eq 5.10–5.13) with a moving-average
//! filter, and the measured yaw rate behind the angular slip (Eq 6.3) and the time to complete a
//! turn (Fig. 6.7).
//!
//! Host post-processing in `f64`, `no_std` and allocation-free: functions read slices and write
//! into caller-provided output slices, returning how much they wrote.
//!
//! Frames and conventions: positions are (x, y) in the total-station frame [m]. Like every turn in
//! the seed, tracks are **left turns** (counter-clockwise seen from above) with the prism mounted
//! δx_lp = 0.21 m to the right of the rover's centre (Fig. 5.3), i.e. outboard of the turn.
//! Angles are in radians, yaw positive counter-clockwise.
#![warn(missing_docs)]

use crate::fit::FitError;
use core::f64::consts::TAU;

mod circle;
mod gaps;
mod hampel;
mod wheels;
mod yaw;

pub use circle::*;
pub use gaps::*;
pub use hampel::*;
pub use wheels::*;
pub use yaw::*;

/// The total station samples the prism at 5 Hz (Section 5.1): δt = 0.2 s.
pub const TOTAL_STATION_PERIOD_S: f64 = 0.2;

/// δx_lp: lateral offset of the landmark prism from the rover's centre, to its right (Fig. 5.3).
pub const PRISM_OFFSET_M: f64 = 0.21;

/// Window of the moving-average filter applied to the wheel speeds (Section 5.1).
pub const MOVING_AVERAGE_WINDOW: usize = 3;

/// Largest Hampel half-window supported (the window lives on the stack).
pub const MAX_HAMPEL_HALF_WINDOW: usize = 16;

/// Scales a median absolute deviation to a normal standard deviation: 1/(√2 erf⁻¹(½)) ≈ 1.4826,
/// as MATLAB's `hampel` does.
pub const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602;

/// Iterations of the geometric (Gauss–Newton) refinement of the circle fit.
const CIRCLE_GAUSS_NEWTON_ITERATIONS: usize = 50;

/// Why a track cannot be processed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackingError {
    /// Not enough points (a circle needs 3; a speed or a rate needs 2).
    TooFewPoints,
    /// NaN or infinite input, or an overflowing result.
    NonFinite,
    /// Geometry without an answer: collinear or coincident points (no circle), a prism at the
    /// circle's centre (no heading).
    Degenerate,
    /// Input slices of different lengths.
    LengthMismatch,
    /// The output slice cannot hold the result.
    OutputTooSmall,
    /// A parameter outside its domain (a non-positive period, a negative offset, a Hampel window
    /// beyond [`MAX_HAMPEL_HALF_WINDOW`]…).
    InvalidParameter,
}

impl core::fmt::Display for TrackingError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            TrackingError::TooFewPoints => "too few points",
            TrackingError::NonFinite => "non-finite input or result",
            TrackingError::Degenerate => "degenerate geometry",
            TrackingError::LengthMismatch => "input slices differ in length",
            TrackingError::OutputTooSmall => "output slice too small",
            TrackingError::InvalidParameter => "parameter outside its domain",
        })
    }
}

impl From<FitError> for TrackingError {
    fn from(e: FitError) -> Self {
        match e {
            FitError::TooFewSamples => TrackingError::TooFewPoints,
            FitError::NonFinite => TrackingError::NonFinite,
            FitError::Singular => TrackingError::Degenerate,
            FitError::LengthMismatch => TrackingError::LengthMismatch,
            FitError::InvalidParameter => TrackingError::InvalidParameter,
        }
    }
}

fn all_finite(points: &[(f64, f64)]) -> bool {
    points.iter().all(|(x, y)| x.is_finite() && y.is_finite())
}

fn check_period(dt_s: f64) -> Result<(), TrackingError> {
    if dt_s.is_finite() && dt_s > 0.0 {
        Ok(())
    } else {
        Err(TrackingError::InvalidParameter)
    }
}

/// Wraps an angle to [−π, π].
pub fn wrap_angle_rad(a: f64) -> f64 {
    a - TAU * libm::round(a / TAU)
}

#[cfg(test)]
mod tests;
