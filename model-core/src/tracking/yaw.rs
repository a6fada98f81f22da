//! Measured yaw rate, the angular slip behind Eq 6.3 and the time to complete a turn (Fig. 6.7).

use super::circle::Circle;
use super::{all_finite, check_period, wrap_angle_rad, TrackingError};
use crate::kinematics;

/// The angle the prism sweeps about the fitted circle's centre over the track, unwrapped,
/// positive counter-clockwise [rad]. For a rigid turn about a fixed centre this is the heading
/// change. Successive positions must be less than π apart as seen from the centre.
pub fn swept_angle_rad(circle: &Circle, prism_m: &[(f64, f64)]) -> Result<f64, TrackingError> {
    if prism_m.len() < 2 {
        return Err(TrackingError::TooFewPoints);
    }
    if !all_finite(prism_m) {
        return Err(TrackingError::NonFinite);
    }
    let angle = |p: &(f64, f64)| libm::atan2(p.1 - circle.centre_y_m, p.0 - circle.centre_x_m);
    let swept: f64 = prism_m
        .windows(2)
        .map(|w| match w {
            [a, b] => wrap_angle_rad(angle(b) - angle(a)),
            _ => 0.0,
        })
        .sum();
    if swept.is_finite() {
        Ok(swept)
    } else {
        Err(TrackingError::NonFinite)
    }
}

/// The mean actual yaw rate ω_z^ACT of a turn from its prism track: [`swept_angle_rad`] over the
/// elapsed time (n − 1) δt [rad/s] (Eq 6.3's ω_z^ACT, Fig. 6.8's "average actual angular
/// velocity").
pub fn yaw_rate_from_track_rad_s(
    circle: &Circle,
    prism_m: &[(f64, f64)],
    dt_s: f64,
) -> Result<f64, TrackingError> {
    check_period(dt_s)?;
    let swept = swept_angle_rad(circle, prism_m)?;
    Ok(swept / ((prism_m.len() - 1) as f64 * dt_s))
}

/// The net heading change of a yaw series, unwrapped sample to sample (each step taken in
/// [−π, π]) [rad].
pub fn heading_change_rad(yaw_rad: &[f64]) -> Result<f64, TrackingError> {
    if yaw_rad.len() < 2 {
        return Err(TrackingError::TooFewPoints);
    }
    if yaw_rad.iter().any(|v| !v.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    Ok(yaw_rad
        .windows(2)
        .map(|w| match w {
            [a, b] => wrap_angle_rad(b - a),
            _ => 0.0,
        })
        .sum())
}

/// The mean actual yaw rate from a yaw series sampled every `dt_s`: [`heading_change_rad`] over
/// (n − 1) δt [rad/s].
pub fn yaw_rate_from_headings_rad_s(yaw_rad: &[f64], dt_s: f64) -> Result<f64, TrackingError> {
    check_period(dt_s)?;
    let change = heading_change_rad(yaw_rad)?;
    Ok(change / ((yaw_rad.len() - 1) as f64 * dt_s))
}

/// Eq 6.3 for a measured turn: s_ω = (ω_cmd − ω_act)/ω_cmd with ω_act from the prism track
/// ([`yaw_rate_from_track_rad_s`]), through [`kinematics::angular_slip`]. `Ok(None)` when nothing
/// was commanded. Left turns: both rates positive.
pub fn angular_slip_from_track(
    yaw_rate_cmd_rad_s: f32,
    circle: &Circle,
    prism_m: &[(f64, f64)],
    dt_s: f64,
) -> Result<Option<f32>, TrackingError> {
    if !yaw_rate_cmd_rad_s.is_finite() {
        return Err(TrackingError::NonFinite);
    }
    let actual = yaw_rate_from_track_rad_s(circle, prism_m, dt_s)?;
    Ok(kinematics::angular_slip(yaw_rate_cmd_rad_s, actual as f32))
}

/// Time to complete a heading change (Fig. 6.7: the time to complete a 90° turn) [s]: the first
/// time the unwrapped yaw has moved `heading_change_rad` (> 0, either direction) from its first
/// sample, interpolated linearly between samples `dt_s` apart. `Ok(None)` if the series never gets
/// there.
pub fn time_to_heading_change_s(
    yaw_rad: &[f64],
    dt_s: f64,
    heading_change_rad: f64,
) -> Result<Option<f64>, TrackingError> {
    check_period(dt_s)?;
    if !(heading_change_rad.is_finite() && heading_change_rad > 0.0) {
        return Err(TrackingError::InvalidParameter);
    }
    if yaw_rad.len() < 2 {
        return Err(TrackingError::TooFewPoints);
    }
    if yaw_rad.iter().any(|v| !v.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    let mut turned = 0.0_f64;
    for (k, w) in yaw_rad.windows(2).enumerate() {
        let [a, b] = w else { continue };
        let next = turned + wrap_angle_rad(b - a);
        if libm::fabs(next) >= heading_change_rad {
            let (from, to) = (libm::fabs(turned), libm::fabs(next));
            let frac = ((heading_change_rad - from) / (to - from)).clamp(0.0, 1.0);
            return Ok(Some((k as f64 + frac) * dt_s));
        }
        turned = next;
    }
    Ok(None)
}
