//! Heading, the four wheel positions (Eq 5.5–5.9) and the wheels' actual speeds and
//! directions (Eq 5.10–5.13) with the moving-average filter.

use super::circle::Circle;
use super::{all_finite, check_period, TrackingError};
use crate::geometry::Rover;
use core::f64::consts::FRAC_PI_2;

/// Eq 5.4: θ_H^f, the angle of the Husky frame in the total-station frame at the end of the turn,
/// from the final prism position and the fitted circle's centre. The prism lies on the rover's
/// lateral (X) axis, which for a left turn points away from the turn centre, so θ_H is the
/// direction from the centre to the prism. Computed with `atan2` (the seed's tan⁻¹ of a ratio,
/// resolved to the full circle).
pub fn final_heading_rad(circle: &Circle, final_prism_m: (f64, f64)) -> Result<f64, TrackingError> {
    let dx = final_prism_m.0 - circle.centre_x_m;
    let dy = final_prism_m.1 - circle.centre_y_m;
    if !(dx.is_finite() && dy.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    if dx == 0.0 && dy == 0.0 {
        return Err(TrackingError::Degenerate);
    }
    Ok(libm::atan2(dy, dx))
}

/// Eq 5.5: θ_H = (θ_H^f − ψ^f) + ψ for every sample: the IMU yaw ψ shifted so that its last value
/// matches the circle-fit heading θ_H^f of the last prism position (Eq 5.4).
///
/// `yaw_rad` must be sampled at the prism positions' times (one per position, same length; the
/// caller resamples the IMU onto the corrected 5 Hz time base). Writes θ_H into `out` and returns
/// the count. The yaw is not unwrapped: θ_H only enters through sin and cos (Eq 5.3).
pub fn corrected_headings_rad(
    circle: &Circle,
    prism_m: &[(f64, f64)],
    yaw_rad: &[f64],
    out: &mut [f64],
) -> Result<usize, TrackingError> {
    if prism_m.len() != yaw_rad.len() {
        return Err(TrackingError::LengthMismatch);
    }
    let (Some(&final_prism), Some(&final_yaw)) = (prism_m.last(), yaw_rad.last()) else {
        return Err(TrackingError::TooFewPoints);
    };
    if out.len() < yaw_rad.len() {
        return Err(TrackingError::OutputTooSmall);
    }
    if yaw_rad.iter().any(|v| !v.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    let offset = final_heading_rad(circle, final_prism)? - final_yaw;
    for (o, &psi) in out.iter_mut().zip(yaw_rad) {
        *o = offset + psi;
    }
    Ok(yaw_rad.len())
}

/// The four wheel-contact positions in the total-station frame [m] (Eq 5.6–5.9). Inner and outer
/// refer to a left turn: the inner wheels are on the rover's left.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelPositions {
    /// Eq 5.6: inner (left) front wheel.
    pub inner_front_m: (f64, f64),
    /// Eq 5.7: inner (left) back wheel.
    pub inner_back_m: (f64, f64),
    /// Eq 5.8: outer (right) front wheel.
    pub outer_front_m: (f64, f64),
    /// Eq 5.9: outer (right) back wheel.
    pub outer_back_m: (f64, f64),
}

/// Eq 5.3 and 5.6–5.9: wheel positions from the prism position (x_lp, y_lp) and heading θ_H, with
/// the rover's B and L and the prism's offset δx_lp: inner front at (−δx_lp − B/2, L/2), inner
/// back (−δx_lp − B/2, −L/2), outer front (−δx_lp + B/2, L/2), outer back (−δx_lp + B/2, −L/2) in
/// the prism frame, rotated by θ_H and shifted to the prism.
pub fn wheel_positions(
    prism_m: (f64, f64),
    theta_h_rad: f64,
    rover: &Rover,
    prism_offset_m: f64,
) -> WheelPositions {
    let half_b = f64::from(rover.track_width_m) / 2.0;
    let half_l = f64::from(rover.length_m) / 2.0;
    let (s, c) = libm::sincos(theta_h_rad);
    let to_ts = |(bx, by): (f64, f64)| (c * bx - s * by + prism_m.0, s * bx + c * by + prism_m.1);
    WheelPositions {
        inner_front_m: to_ts((-prism_offset_m - half_b, half_l)),
        inner_back_m: to_ts((-prism_offset_m - half_b, -half_l)),
        outer_front_m: to_ts((-prism_offset_m + half_b, half_l)),
        outer_back_m: to_ts((-prism_offset_m + half_b, -half_l)),
    }
}

// ---------------------------------------------------------------------------------------------
// Wheel velocities
// ---------------------------------------------------------------------------------------------

/// Eq 5.10: a wheel's speed ‖v(t)‖ = ‖p(t) − p(t − 1)‖ / δt [m/s].
pub fn speed_mps(from_m: (f64, f64), to_m: (f64, f64), dt_s: f64) -> f64 {
    libm::hypot(to_m.0 - from_m.0, to_m.1 - from_m.1) / dt_s
}

/// Eq 5.11: direction of a wheel's velocity in the total-station frame, 90° + the direction from
/// the circle centre to the wheel (`atan2`), i.e. the tangent of counter-clockwise motion about
/// the centre (left turns) [rad], in (−π/2, 3π/2] (not wrapped).
pub fn velocity_direction_rad(wheel_m: (f64, f64), circle: &Circle) -> f64 {
    FRAC_PI_2 + libm::atan2(wheel_m.1 - circle.centre_y_m, wheel_m.0 - circle.centre_x_m)
}

/// Eq 5.10 and 5.12–5.13: the inner and outer wheels' actual speeds ‖v_i^ACT‖ and ‖v_o^ACT‖ (mean
/// of front and back) from the prism track and the heading θ_H (Eq 5.5), wheel positions by
/// Eq 5.6–5.9.
///
/// Speed k is over the interval from sample k to sample k + 1 (the seed's time t = k + 1), so n
/// positions give n − 1 speeds, written to `inner_mps_out` and `outer_mps_out`; returns n − 1 (0
/// for fewer than 2 positions).
pub fn inner_outer_speeds(
    prism_m: &[(f64, f64)],
    theta_h_rad: &[f64],
    rover: &Rover,
    prism_offset_m: f64,
    dt_s: f64,
    inner_mps_out: &mut [f64],
    outer_mps_out: &mut [f64],
) -> Result<usize, TrackingError> {
    check_period(dt_s)?;
    if prism_m.len() != theta_h_rad.len() {
        return Err(TrackingError::LengthMismatch);
    }
    if !(prism_offset_m.is_finite() && prism_offset_m >= 0.0) {
        return Err(TrackingError::InvalidParameter);
    }
    if !all_finite(prism_m) || theta_h_rad.iter().any(|v| !v.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    let count = prism_m.len().saturating_sub(1);
    if inner_mps_out.len() < count || outer_mps_out.len() < count {
        return Err(TrackingError::OutputTooSmall);
    }
    let wheels = |k: usize| {
        let p = prism_m.get(k).copied().unwrap_or((f64::NAN, f64::NAN));
        let th = theta_h_rad.get(k).copied().unwrap_or(f64::NAN);
        wheel_positions(p, th, rover, prism_offset_m)
    };
    let outputs = inner_mps_out.iter_mut().zip(outer_mps_out.iter_mut());
    for (k, (inner, outer)) in outputs.enumerate().take(count) {
        let (a, b) = (wheels(k), wheels(k + 1));
        let v = |from, to| speed_mps(from, to, dt_s);
        *inner = (v(a.inner_front_m, b.inner_front_m) + v(a.inner_back_m, b.inner_back_m)) / 2.0;
        *outer = (v(a.outer_front_m, b.outer_front_m) + v(a.outer_back_m, b.outer_back_m)) / 2.0;
    }
    let finite = |out: &[f64]| out.iter().take(count).all(|v| v.is_finite());
    if finite(inner_mps_out) && finite(outer_mps_out) {
        Ok(count)
    } else {
        Err(TrackingError::NonFinite)
    }
}

/// The moving-average filter applied to the wheel speeds (Section 5.1, window
/// [`MOVING_AVERAGE_WINDOW`] = 3, "starting at the third sample of the set"): a trailing mean,
/// out[j] = mean(input[j ..= j + window − 1]), aligned with input sample j + window − 1. So the
/// first output belongs to the third input sample, and n inputs give n − window + 1 outputs (0 if
/// n < window). Returns the count.
pub fn moving_average(
    input: &[f64],
    window: usize,
    out: &mut [f64],
) -> Result<usize, TrackingError> {
    if window == 0 {
        return Err(TrackingError::InvalidParameter);
    }
    if input.iter().any(|v| !v.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    let count = (input.len() + 1).saturating_sub(window);
    if out.len() < count {
        return Err(TrackingError::OutputTooSmall);
    }
    for (o, w) in out.iter_mut().zip(input.windows(window)) {
        *o = w.iter().sum::<f64>() / window as f64;
    }
    Ok(count)
}
