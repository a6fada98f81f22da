//! Circle fit of the prism track, the actual turning radius R_ACT and the measured slip
//! angles (Eq 5.3–5.4).

use super::{all_finite, TrackingError, CIRCLE_GAUSS_NEWTON_ITERATIONS};
use crate::fit::LinearFit;
use crate::geometry::Rover;
use crate::kinematics::{self, SlipAngles};

/// A circle in the total-station frame: (x − x_c)² + (y − y_c)² = R² (Section 5.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// x_c [m].
    pub centre_x_m: f64,
    /// y_c [m].
    pub centre_y_m: f64,
    /// R (R_lp for the prism track) [m].
    pub radius_m: f64,
}

/// Fits (x − x_c)² + (y − y_c)² = R_lp² to the prism track (Section 5.1, circle fit before
/// Eq 5.1): the algebraic (Kåsa) fit, then Gauss–Newton iterations on the geometric distances
/// Σ (‖p_k − c‖ − R)², which remove the Kåsa fit's bias towards small radii on partial arcs.
///
/// Coordinates are centred on the centroid and scaled before fitting, so a total station far
/// from the origin costs no precision. Errors: fewer than 3 points → `TooFewPoints`; NaN/∞ →
/// `NonFinite`; collinear or coincident points → `Degenerate`.
pub fn fit_circle(points_m: &[(f64, f64)]) -> Result<Circle, TrackingError> {
    if points_m.len() < 3 {
        return Err(TrackingError::TooFewPoints);
    }
    if !all_finite(points_m) {
        return Err(TrackingError::NonFinite);
    }
    let n = points_m.len() as f64;
    let mean_x = points_m.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = points_m.iter().map(|p| p.1).sum::<f64>() / n;
    let spread_sq = points_m
        .iter()
        .map(|p| (p.0 - mean_x) * (p.0 - mean_x) + (p.1 - mean_y) * (p.1 - mean_y))
        .sum::<f64>()
        / n;
    let scale = libm::sqrt(spread_sq);
    if !scale.is_finite() || !mean_x.is_finite() || !mean_y.is_finite() {
        return Err(TrackingError::NonFinite);
    }
    if scale == 0.0 {
        return Err(TrackingError::Degenerate);
    }
    let normalised = |p: &(f64, f64)| ((p.0 - mean_x) / scale, (p.1 - mean_y) / scale);

    // Kåsa: u² + v² + D u + E v + F = 0 is linear in (D, E, F).
    let mut kasa = LinearFit::<3>::new();
    for p in points_m {
        let (u, v) = normalised(p);
        kasa.add([u, v, 1.0], -(u * u + v * v))?;
    }
    let [d, e, f] = kasa.coefficients()?;
    let (mut a, mut b) = (-d / 2.0, -e / 2.0);
    let r_sq = a * a + b * b - f;
    if r_sq.is_nan() || r_sq <= 0.0 {
        return Err(TrackingError::Degenerate);
    }
    let mut r = libm::sqrt(r_sq);

    // Gauss–Newton on the geometric residuals ‖p − c‖ − R, with step halving.
    let cost = |a: f64, b: f64, r: f64| -> f64 {
        points_m
            .iter()
            .map(|p| {
                let (u, v) = normalised(p);
                let res = libm::hypot(u - a, v - b) - r;
                res * res
            })
            .sum()
    };
    let mut current = cost(a, b, r);
    for _ in 0..CIRCLE_GAUSS_NEWTON_ITERATIONS {
        let mut step = LinearFit::<3>::new();
        for p in points_m {
            let (u, v) = normalised(p);
            let (du, dv) = (u - a, v - b);
            let dist = libm::hypot(du, dv);
            if dist > 0.0 {
                // Only non-finite rows can be refused; such a row is simply left out.
                let _ = step.add([-du / dist, -dv / dist, -1.0], r - dist);
            }
        }
        let Ok(delta) = step.coefficients() else {
            break;
        };
        let mut lambda = 1.0;
        let mut accepted = false;
        for _ in 0..20 {
            let (na, nb, nr) = (
                a + lambda * delta[0],
                b + lambda * delta[1],
                r + lambda * delta[2],
            );
            let c = cost(na, nb, nr);
            if c <= current {
                (a, b, r, current) = (na, nb, nr, c);
                accepted = true;
                break;
            }
            lambda *= 0.5;
        }
        let step_size = lambda * libm::sqrt(delta.iter().map(|v| v * v).sum::<f64>());
        if !accepted || step_size.is_nan() || step_size <= 1e-13 {
            break;
        }
    }
    let circle = Circle {
        centre_x_m: mean_x + a * scale,
        centre_y_m: mean_y + b * scale,
        radius_m: libm::fabs(r) * scale,
    };
    if circle.centre_x_m.is_finite() && circle.centre_y_m.is_finite() && circle.radius_m.is_finite()
    {
        Ok(circle)
    } else {
        Err(TrackingError::NonFinite)
    }
}

/// R_ACT = R_lp − δx_lp (Section 5.1, before Eq 5.1): the radius driven by the rover's centre for a
/// **left** turn, whose prism sits δx_lp outboard of the centre (use [`PRISM_OFFSET_M`]).
///
/// A fitted prism circle smaller than the offset can only come from noise around a point turn; it
/// gives R_ACT = 0 rather than a negative radius (our choice). Right turns are not covered (the
/// prism would be inboard, and R_lp = |R_ACT − δx_lp| does not determine R_ACT).
pub fn actual_radius_m(circle: &Circle, prism_offset_m: f64) -> Result<f64, TrackingError> {
    if !(prism_offset_m.is_finite() && prism_offset_m >= 0.0) {
        return Err(TrackingError::InvalidParameter);
    }
    if !circle.radius_m.is_finite() {
        return Err(TrackingError::NonFinite);
    }
    Ok((circle.radius_m - prism_offset_m).max(0.0))
}

/// Eq 5.1–5.2 for a measured track: R_ACT from the fitted prism circle ([`actual_radius_m`]), then
/// [`kinematics::slip_angles`] with the actual R'_ACT of the terrain.
pub fn measured_slip_angles(
    circle: &Circle,
    prism_offset_m: f64,
    r_prime_act_m: f64,
    rover: &Rover,
) -> Result<SlipAngles, TrackingError> {
    if !r_prime_act_m.is_finite() {
        return Err(TrackingError::NonFinite);
    }
    let r_act = actual_radius_m(circle, prism_offset_m)?;
    Ok(kinematics::slip_angles(
        r_act as f32,
        r_prime_act_m as f32,
        rover,
    ))
}
