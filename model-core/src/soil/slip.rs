//! Slip of a wheel on loose soil (Section 1.1.4, Eq 1.22–1.23).

use super::{check, finite_result, input, unbounded, SoilError};

/// Eq 1.22: longitudinal slip ratio s_y = (rω − v_y) / (rω), from the commanded linear speed
/// rω and the actual speed v_y along the commanded direction [m/s]. Positive when the wheel
/// spins faster than it travels, 1 at 100 % slip (v_y = 0). `Err` when rω = 0 (undefined).
pub fn longitudinal_slip(commanded_mps: f64, actual_mps: f64) -> Result<f64, SoilError> {
    let rw = input(commanded_mps, "commanded_mps", |v| v != 0.0)?;
    let vy = input(actual_mps, "actual_mps", unbounded)?;
    finite_result((rw - vy) / rw)
}

/// Eq 1.23: slip angle β = tan⁻¹(v_x / v_y) from the lateral v_x and longitudinal v_y speeds
/// [m/s], in (−π, π].
///
/// Choice: the seed writes tan⁻¹(v_x/v_y), which folds a backwards v_y onto a forwards one; this
/// uses the four-quadrant `atan2(v_x, v_y)`, equal to it whenever v_y > 0 and defined for
/// v_y ≤ 0 (β > 90° is the inner-wheel case of Section 5.3.2). `Err` at standstill.
pub fn slip_angle_rad(lateral_mps: f64, forward_mps: f64) -> Result<f64, SoilError> {
    let vx = input(lateral_mps, "lateral_mps", unbounded)?;
    let vy = input(forward_mps, "forward_mps", unbounded)?;
    check(
        vx != 0.0 || vy != 0.0,
        SoilError::InvalidInput("standstill"),
    )?;
    Ok(libm::atan2(vx, vy))
}
