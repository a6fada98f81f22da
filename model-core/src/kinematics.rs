//! Skid-steer kinematics under the seed's assumptions (Section 2.3): centre of mass at the
//! geometric centre (symmetric ICRs), no lateral slip (v_x = 0), constant total absolute speed v_c.
//!
//! Turning radii are magnitudes (`f32::INFINITY` for a straight line); the side of the turn is a
//! separate [`TurnDirection`], so a right turn is the mirror image of a left turn.

use crate::geometry::Rover;
use serde::{Deserialize, Serialize};

/// Commanded (or measured) linear speeds of the left and right wheel sets [m/s]:
/// wheel angular speed × wheel radius.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct SideSpeeds {
    pub left_mps: f32,
    pub right_mps: f32,
}

impl SideSpeeds {
    pub const fn new(left_mps: f32, right_mps: f32) -> Self {
        Self {
            left_mps,
            right_mps,
        }
    }

    /// The mirror-image manoeuvre (a left turn becomes the same right turn).
    pub fn mirrored(self) -> Self {
        Self {
            left_mps: self.right_mps,
            right_mps: self.left_mps,
        }
    }

    /// Wheel angular speeds [rad/s] for wheels of radius `wheel_radius_m`.
    pub fn wheel_rates_rad_s(self, wheel_radius_m: f32) -> crate::Sides<f32> {
        crate::Sides::new(
            self.left_mps / wheel_radius_m,
            self.right_mps / wheel_radius_m,
        )
    }
}

/// Which way the rover turns. A left turn is counter-clockwise seen from above (V_r > V_l).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum TurnDirection {
    Left,
    Right,
}

/// Velocity of the rover body in its own frame (Fig. 1.3: Y forward, X to the right).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BodyVelocity {
    /// v_x: lateral speed [m/s].
    pub lateral_mps: f32,
    /// v_y: forward speed [m/s].
    pub forward_mps: f32,
    /// ω_z: yaw rate, positive counter-clockwise [rad/s].
    pub yaw_rate_rad_s: f32,
}

/// ICR positions in the body frame (Eq 1.1–1.4) [m].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IcrPositions {
    /// x_ICR_l (negative: left of the centre).
    pub left_x_m: f32,
    /// x_ICR_r (positive).
    pub right_x_m: f32,
    /// y_ICR_v, shared by the vehicle and both side ICRs (Eq 1.1).
    pub y_m: f32,
}

impl IcrPositions {
    /// Symmetric ICRs on the lateral axis (Section 2.1): x = ±B_s/2, y = 0.
    pub fn symmetric(slip_track_m: f32) -> Self {
        Self {
            left_x_m: -slip_track_m / 2.0,
            right_x_m: slip_track_m / 2.0,
            y_m: 0.0,
        }
    }

    /// Eq 1.4: B_s = x_ICR_r − x_ICR_l.
    pub fn slip_track_m(&self) -> f32 {
        self.right_x_m - self.left_x_m
    }
}

/// Eq 1.5–1.7 (matrix form Eq 1.8): body velocity from side speeds and general ICR positions.
pub fn body_velocity_from_icr(speeds: SideSpeeds, icr: IcrPositions) -> BodyVelocity {
    let (vl, vr) = (speeds.left_mps, speeds.right_mps);
    let bs = icr.slip_track_m();
    BodyVelocity {
        lateral_mps: (vr - vl) * icr.y_m / bs,
        forward_mps: (vl * icr.right_x_m - vr * icr.left_x_m) / bs,
        yaw_rate_rad_s: (vr - vl) / bs,
    }
}

/// Eq 2.1–2.2: body velocity with symmetric ICRs and no lateral slip.
pub fn body_velocity(speeds: SideSpeeds, slip_track_m: f32) -> BodyVelocity {
    body_velocity_from_icr(speeds, IcrPositions::symmetric(slip_track_m))
}

/// Eq 2.4: turning radius |R| from side speeds. `INFINITY` when both sides run at the same speed,
/// `None` at standstill (no motion, no radius).
pub fn turning_radius_m(speeds: SideSpeeds, slip_track_m: f32) -> Option<f32> {
    let (vl, vr) = (speeds.left_mps, speeds.right_mps);
    if vl == 0.0 && vr == 0.0 {
        return None;
    }
    let diff = vl - vr;
    if diff == 0.0 {
        return Some(f32::INFINITY);
    }
    Some(slip_track_m / 2.0 * libm::fabsf((vl + vr) / diff))
}

/// Side of the turn: left when the right side runs faster. `None` for a straight line or standstill.
pub fn turn_direction(speeds: SideSpeeds) -> Option<TurnDirection> {
    if speeds.right_mps > speeds.left_mps {
        Some(TurnDirection::Left)
    } else if speeds.left_mps > speeds.right_mps {
        Some(TurnDirection::Right)
    } else {
        None
    }
}

/// Eq 2.6: total absolute speed v_c = (|V_r| + |V_l|) / 2.
pub fn total_absolute_speed_mps(speeds: SideSpeeds) -> f32 {
    (libm::fabsf(speeds.left_mps) + libm::fabsf(speeds.right_mps)) / 2.0
}

/// Appendix A (Eq A.13–A.14): side speeds that drive a turn of radius `radius_m` at constant total
/// absolute speed `v_c_mps`. `radius_m = INFINITY` drives straight. Below R' the inner side runs
/// backwards, at R' it stands still, above R' both sides run forwards.
///
/// A.13's fractions are used in their simplified forms: for R < R',
/// 2v_c / ((R+R')/(R−R') − 1) = v_c (R − R') / R'; for R > R', 2v_c / ((R+R')/(R−R') + 1) =
/// v_c (R − R') / R. Both stay finite at R = 0 and R → ∞.
pub fn side_speeds_for(
    v_c_mps: f32,
    radius_m: f32,
    r_prime_m: f32,
    direction: TurnDirection,
) -> SideSpeeds {
    let inner = if radius_m.is_infinite() {
        v_c_mps
    } else if radius_m < r_prime_m {
        v_c_mps * (radius_m - r_prime_m) / r_prime_m
    } else if radius_m == r_prime_m {
        0.0
    } else {
        v_c_mps * (radius_m - r_prime_m) / radius_m
    };
    // Eq A.14: the outer side makes up the rest of 2 v_c (|inner| + outer = 2 v_c).
    let outer = 2.0 * v_c_mps - libm::fabsf(inner);
    let left_turn = SideSpeeds {
        left_mps: inner,
        right_mps: outer,
    };
    match direction {
        TurnDirection::Left => left_turn,
        TurnDirection::Right => left_turn.mirrored(),
    }
}

/// Eq 2.9: yaw rate magnitude under the constant-v_c constraint; constant (2 v_c / B_s) for R ≤ R'.
pub fn yaw_rate_for(v_c_mps: f32, radius_m: f32, r_prime_m: f32) -> f32 {
    if radius_m <= r_prime_m {
        v_c_mps / r_prime_m
    } else {
        v_c_mps / radius_m
    }
}

/// Eq 2.10: forward speed under the constant-v_c constraint; constant (v_c) for R > R'.
pub fn forward_speed_for(v_c_mps: f32, radius_m: f32, r_prime_m: f32) -> f32 {
    if radius_m <= r_prime_m {
        radius_m / r_prime_m * v_c_mps
    } else {
        v_c_mps
    }
}

/// Eq 2.7: the smallest radius reachable at constant forward speed `v_const` when the outer side
/// saturates at `v_max`. `None` when `v_const ≥ v_max` (no turn is possible at all).
pub fn min_radius_at_constant_forward_speed_m(
    v_const_mps: f32,
    v_max_mps: f32,
    slip_track_m: f32,
) -> Option<f32> {
    (v_const_mps < v_max_mps)
        .then(|| slip_track_m / 2.0 * libm::fabsf(v_const_mps / (v_max_mps - v_const_mps)))
}

/// The regimes of a turn the seed distinguishes (Section 2.1.2 and Chapter 4).
/// Serialised kebab-case (`"below-half-track"`), the ids the host tool's tables and JSON use;
/// the variant names are accepted when reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Regime {
    /// R = 0: both sides at equal and opposite speeds.
    #[serde(alias = "Point")]
    Point,
    /// 0 < R ≤ B/2: the turning centre lies between the wheel tracks.
    #[serde(alias = "BelowHalfTrack")]
    BelowHalfTrack,
    /// B/2 < R < R': inner wheels counter-rotate but are dragged forward (β_i > 90°).
    #[serde(alias = "DraggedInner")]
    DraggedInner,
    /// R = R': inner wheels commanded to stand still.
    #[serde(alias = "AtRPrime")]
    AtRPrime,
    /// R' < R < straight: both sides run forwards.
    #[serde(alias = "AboveRPrime")]
    AboveRPrime,
    /// R = ∞ (or beyond the straight threshold).
    #[serde(alias = "Straight")]
    Straight,
}

impl Regime {
    pub const ALL: [Regime; 6] = [
        Regime::Point,
        Regime::BelowHalfTrack,
        Regime::DraggedInner,
        Regime::AtRPrime,
        Regime::AboveRPrime,
        Regime::Straight,
    ];

    /// Stable identifier used in reports and JSON.
    pub const fn id(self) -> &'static str {
        match self {
            Regime::Point => "point",
            Regime::BelowHalfTrack => "below-half-track",
            Regime::DraggedInner => "dragged-inner",
            Regime::AtRPrime => "at-r-prime",
            Regime::AboveRPrime => "above-r-prime",
            Regime::Straight => "straight",
        }
    }

    /// Inverse of [`Regime::id`].
    pub fn from_id(id: &str) -> Option<Regime> {
        Regime::ALL.into_iter().find(|r| r.id() == id)
    }

    /// Classifies a turning radius for `rover` (its B and its slip track's R').
    pub fn of(radius_m: f32, rover: &Rover, bounds: &RegimeBounds) -> Regime {
        let r_prime = rover.r_prime_m();
        let tolerance = bounds.r_prime_fraction * r_prime;
        if radius_m.is_nan() || radius_m >= bounds.straight_from_m {
            // NaN only arises from a degenerate input; a straight line is the conservative reading.
            Regime::Straight
        } else if radius_m <= tolerance {
            Regime::Point
        } else if libm::fabsf(radius_m - r_prime) <= tolerance {
            Regime::AtRPrime
        } else if radius_m <= rover.half_track_m() {
            Regime::BelowHalfTrack
        } else if radius_m < r_prime {
            Regime::DraggedInner
        } else {
            Regime::AboveRPrime
        }
    }
}

/// How close a radius must be to 0 or R' to count as a point turn or an R' turn, and where a wide
/// arc becomes a straight line.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RegimeBounds {
    /// Tolerance around R = 0 and R = R', as a fraction of R'.
    pub r_prime_fraction: f32,
    /// Radii at or above this are straight lines [m] (the seed drops R > 20 m, Section 4.2).
    pub straight_from_m: f32,
}

impl Default for RegimeBounds {
    fn default() -> Self {
        Self {
            r_prime_fraction: 0.05,
            straight_from_m: 20.0,
        }
    }
}

/// Slip angles of the inner and outer wheels [deg] (Eq 5.1–5.2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SlipAngles {
    pub inner_deg: f32,
    pub outer_deg: f32,
}

/// Eq 5.1–5.2: slip angles for an actual turning radius `r_act_m`, with `r_prime_act_m` the actual
/// radius driven when R' is commanded. β_i exceeds 90° only for B/2 < R < R'.
pub fn slip_angles(r_act_m: f32, r_prime_act_m: f32, rover: &Rover) -> SlipAngles {
    let (b, l) = (rover.track_width_m, rover.length_m);
    let inner_offset = libm::atanf(libm::fabsf(2.0 * r_act_m - b) / l).to_degrees();
    let dragged = r_act_m > b / 2.0 && r_act_m < r_prime_act_m;
    SlipAngles {
        inner_deg: if dragged {
            90.0 + inner_offset
        } else {
            90.0 - inner_offset
        },
        outer_deg: 90.0 - libm::atanf((2.0 * r_act_m + b) / l).to_degrees(),
    }
}

/// Eq 6.3: angular slip s_ω = (ω_cmd − ω_act) / ω_cmd. `None` when nothing was commanded.
pub fn angular_slip(yaw_rate_cmd_rad_s: f32, yaw_rate_act_rad_s: f32) -> Option<f32> {
    (yaw_rate_cmd_rad_s != 0.0)
        .then(|| (yaw_rate_cmd_rad_s - yaw_rate_act_rad_s) / yaw_rate_cmd_rad_s)
}

/// Appendix D: the terrain's slip track from the radius actually driven under commanded side
/// speeds: inverting Eq 2.4, B_s = 2 R_act |V_l − V_r| / |V_l + V_r|. At the commanded R' (inner
/// side still) this is simply 2 R_act. `None` for point turns and straight lines, which carry no
/// information about B_s.
pub fn slip_track_from_measured_radius_m(r_act_m: f32, commanded: SideSpeeds) -> Option<f32> {
    let sum = libm::fabsf(commanded.left_mps + commanded.right_mps);
    let diff = libm::fabsf(commanded.left_mps - commanded.right_mps);
    (sum > 0.0 && diff > 0.0 && r_act_m.is_finite()).then(|| 2.0 * r_act_m * diff / sum)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const HUSKY: Rover = Rover::HUSKY_A200;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    /// Appendix A written literally (Eq A.6, A.7, A.11, A.12) — an independent oracle for the
    /// simplified forms in `side_speeds_for`.
    fn appendix_a_literal(v_c: f32, r: f32, rp: f32) -> SideSpeeds {
        if r < rp {
            let vl = 2.0 * v_c / ((r + rp) / (r - rp) - 1.0);
            SideSpeeds::new(vl, 2.0 * v_c + vl)
        } else if r == rp {
            SideSpeeds::new(0.0, 2.0 * v_c)
        } else {
            let vl = 2.0 * v_c / ((r + rp) / (r - rp) + 1.0);
            SideSpeeds::new(vl, 2.0 * v_c - vl)
        }
    }

    #[test]
    fn appendix_a_special_radii() {
        let rp = HUSKY.r_prime_m();
        // Point turn: sides equal and opposite at v_c.
        let p = side_speeds_for(0.3, 0.0, rp, TurnDirection::Left);
        assert!(close(p.left_mps, -0.3, 1e-6) && close(p.right_mps, 0.3, 1e-6));
        // R': inner still, outer at 2 v_c (Fig. 2.1).
        let at = side_speeds_for(0.3, rp, rp, TurnDirection::Left);
        assert_eq!(at.left_mps, 0.0);
        assert!(close(at.right_mps, 0.6, 1e-6));
        // Straight: both at v_c.
        let s = side_speeds_for(0.3, f32::INFINITY, rp, TurnDirection::Left);
        assert_eq!((s.left_mps, s.right_mps), (0.3, 0.3));
        // Far but finite radius approaches v_c on both sides.
        let far = side_speeds_for(0.3, 1.0e6, rp, TurnDirection::Left);
        assert!(close(far.left_mps, 0.3, 1e-6) && close(far.right_mps, 0.3, 1e-6));
    }

    #[test]
    fn appendix_a_matches_literal_equations_across_the_seed_turn_set() {
        let rp = HUSKY.r_prime_m();
        for k in [1.0, 2.0, 4.0, 5.0, 6.0, 8.0, 12.0] {
            let r = k * rp / 3.0;
            let got = side_speeds_for(0.3, r, rp, TurnDirection::Left);
            let want = appendix_a_literal(0.3, r, rp);
            assert!(
                close(got.left_mps, want.left_mps, 1e-5),
                "R={r}: {got:?} vs {want:?}"
            );
            assert!(
                close(got.right_mps, want.right_mps, 1e-5),
                "R={r}: {got:?} vs {want:?}"
            );
        }
    }

    #[test]
    fn eq_2_9_and_2_10_constant_yaw_rate_below_r_prime_constant_speed_above() {
        let rp = HUSKY.r_prime_m();
        let v_c = 0.3;
        for r in [0.0, 0.1, 0.2725, 0.4, rp] {
            let speeds = side_speeds_for(v_c, r, rp, TurnDirection::Left);
            let body = body_velocity(speeds, HUSKY.slip_track_m);
            assert!(close(
                body.yaw_rate_rad_s,
                2.0 * v_c / HUSKY.slip_track_m,
                1e-5
            ));
            assert!(close(body.yaw_rate_rad_s, yaw_rate_for(v_c, r, rp), 1e-5));
            assert!(close(body.forward_mps, forward_speed_for(v_c, r, rp), 1e-5));
        }
        for r in [0.6, 0.733, 1.1, 5.0] {
            let speeds = side_speeds_for(v_c, r, rp, TurnDirection::Left);
            let body = body_velocity(speeds, HUSKY.slip_track_m);
            assert!(close(body.forward_mps, v_c, 1e-5));
            assert!(close(body.yaw_rate_rad_s, yaw_rate_for(v_c, r, rp), 1e-5));
            // Eq 2.3: v_y = ω_z R on the arc.
            assert!(close(body.forward_mps, body.yaw_rate_rad_s * r, 1e-5));
        }
    }

    #[test]
    fn eq_2_7_minimum_radius_at_constant_forward_speed() {
        // v_const = 0.3, v_max = 0.6 → R_min = B_s/2 · 0.3/0.3 = R'.
        let r = min_radius_at_constant_forward_speed_m(0.3, 0.6, 1.1).expect("finite");
        assert!(close(r, 0.55, 1e-6));
        // The outer side really saturates there: Appendix A at R_min gives V_r = v_max.
        let s = side_speeds_for(0.3, r, 0.55, TurnDirection::Left);
        assert!(close(s.right_mps, 0.6, 1e-6));
        assert_eq!(min_radius_at_constant_forward_speed_m(0.6, 0.6, 1.1), None);
    }

    #[test]
    fn radius_of_standstill_and_straight() {
        assert_eq!(turning_radius_m(SideSpeeds::new(0.0, 0.0), 1.1), None);
        assert_eq!(
            turning_radius_m(SideSpeeds::new(0.2, 0.2), 1.1),
            Some(f32::INFINITY)
        );
        assert_eq!(turning_radius_m(SideSpeeds::new(-0.3, 0.3), 1.1), Some(0.0));
        assert_eq!(turning_radius_m(SideSpeeds::new(0.0, 0.6), 1.1), Some(0.55));
        assert_eq!(
            turn_direction(SideSpeeds::new(0.0, 0.6)),
            Some(TurnDirection::Left)
        );
        assert_eq!(
            turn_direction(SideSpeeds::new(0.6, 0.0)),
            Some(TurnDirection::Right)
        );
        assert_eq!(turn_direction(SideSpeeds::new(0.3, 0.3)), None);
    }

    #[test]
    fn general_icr_form_reduces_to_symmetric_form() {
        let speeds = SideSpeeds::new(0.1, 0.5);
        let general = body_velocity_from_icr(speeds, IcrPositions::symmetric(1.29));
        assert!(close(general.forward_mps, 0.3, 1e-6));
        assert!(close(general.yaw_rate_rad_s, 0.4 / 1.29, 1e-6));
        assert_eq!(general.lateral_mps, 0.0);
        // Shifted ICR line (Eq 1.1, 1.6): v_x = ω_z y_ICR.
        let shifted = IcrPositions {
            y_m: 0.1,
            ..IcrPositions::symmetric(1.29)
        };
        let v = body_velocity_from_icr(speeds, shifted);
        assert!(close(v.lateral_mps, v.yaw_rate_rad_s * 0.1, 1e-6));
    }

    #[test]
    fn regimes_of_the_seed_turn_set() {
        let b = RegimeBounds::default();
        let rp = HUSKY.r_prime_m();
        let expect = [
            (0.0, Regime::Point),
            (rp / 3.0, Regime::BelowHalfTrack),
            (2.0 * rp / 3.0, Regime::DraggedInner),
            (rp, Regime::AtRPrime),
            (4.0 * rp / 3.0, Regime::AboveRPrime),
            (2.0 * rp, Regime::AboveRPrime),
            (f32::INFINITY, Regime::Straight),
            (25.0, Regime::Straight),
        ];
        for (r, regime) in expect {
            assert_eq!(Regime::of(r, &HUSKY, &b), regime, "R = {r}");
        }
        // Exactly B/2 still has the turning centre on the inner track: below half track.
        assert_eq!(
            Regime::of(HUSKY.half_track_m(), &HUSKY, &b),
            Regime::BelowHalfTrack
        );
        for r in Regime::ALL {
            assert_eq!(Regime::from_id(r.id()), Some(r));
        }
    }

    #[test]
    fn slip_angles_match_rigid_rotation_about_the_turn_centre() {
        // Independent oracle: a wheel at (x, y) from the rover centre, rotating about the turn
        // centre (−R, 0) for a left turn, moves perpendicular to its radius vector; its angle to
        // the commanded direction (±Y) is the slip angle.
        let (b, l) = (HUSKY.track_width_m, HUSKY.length_m);
        let rp_act = 0.605; // sandbox R'_ACT (Table D.1: B_s = 1.21 m)
        for r in [0.05, 0.15, 0.3, 0.45, 0.6, 0.8, 2.0] {
            let angles = slip_angles(r, rp_act, &HUSKY);
            // Outer front wheel at (B/2, L/2); relative to centre (R + B/2, L/2).
            let (ox, oy) = (r + b / 2.0, l / 2.0);
            let (vx, vy) = (-oy, ox); // ω × r, counter-clockwise
            let outer = libm::atan2f(vx.abs(), vy).to_degrees();
            assert!(
                close(angles.outer_deg, outer, 1e-3),
                "R={r}: {angles:?} vs {outer}"
            );
            // Inner front wheel at (−B/2, L/2); relative to centre (R − B/2, L/2).
            let (ix, iy) = (r - b / 2.0, l / 2.0);
            let (vx, vy) = (-iy, ix);
            // Commanded direction of the inner wheel: backwards below R', forwards above.
            let cmd_y = if r < rp_act { -1.0 } else { 1.0 };
            let cos = (vy * cmd_y) / (vx * vx + vy * vy).sqrt();
            let inner = cos.clamp(-1.0, 1.0).acos().to_degrees();
            // Eq 5.1 takes the smallest angle to the Y axis where the command is zero or forward.
            let inner = if r > b / 2.0 && r < rp_act {
                inner
            } else {
                inner.min(180.0 - inner)
            };
            assert!(
                close(angles.inner_deg, inner, 1e-3),
                "R={r}: {angles:?} vs {inner}"
            );
        }
    }

    #[test]
    fn table_5_2_slip_angles_exceed_90_only_in_the_dragged_inner_case() {
        // Table 5.2 reports β = 60°, 100°, 40°, 25° for R'/3, 2R'/3, R', 4R'/3: only the
        // dragged-inner turn crosses 90°, as Eq 5.1 requires for B/2 < R < R'.
        let rp = HUSKY.r_prime_m();
        let dragged = slip_angles(2.0 * rp / 3.0, rp, &HUSKY).inner_deg;
        assert!(dragged > 90.0);
        for r in [rp / 3.0, rp, 4.0 * rp / 3.0] {
            assert!(slip_angles(r, rp, &HUSKY).inner_deg < 90.0, "R = {r}");
        }
    }

    #[test]
    fn appendix_d_slip_track_from_r_prime_turns() {
        let at_r_prime = SideSpeeds::new(0.0, 0.6);
        // Hard concrete: R'_H = 0.645 m → B_s = 1.29 m (Table D.1 and paper Table 2).
        let bs = slip_track_from_measured_radius_m(0.645, at_r_prime).expect("defined");
        assert!(close(bs, 1.29, 1e-6));
        // Sandbox 1.21 m and CSA 0.65 m (Table D.1).
        assert!(close(
            slip_track_from_measured_radius_m(0.605, at_r_prime).unwrap_or(0.0),
            1.21,
            1e-6
        ));
        assert!(close(
            slip_track_from_measured_radius_m(0.325, at_r_prime).unwrap_or(0.0),
            0.65,
            1e-6
        ));
        assert_eq!(
            slip_track_from_measured_radius_m(0.0, SideSpeeds::new(-0.3, 0.3)),
            None
        );
        assert_eq!(
            slip_track_from_measured_radius_m(5.0, SideSpeeds::new(0.3, 0.3)),
            None
        );
    }

    #[test]
    fn angular_slip_eq_6_3() {
        assert_eq!(angular_slip(0.0, 0.1), None);
        assert!(close(angular_slip(0.5, 0.4).unwrap_or(0.0), 0.2, 1e-6));
        assert!(close(angular_slip(-0.5, -0.4).unwrap_or(0.0), 0.2, 1e-6));
    }

    proptest! {
        #[test]
        fn left_right_mirror_symmetry(v_c in 0.01f32..2.0, k in 0.0f32..10.0) {
            let rp = 0.55;
            let r = k * rp;
            let left = side_speeds_for(v_c, r, rp, TurnDirection::Left);
            let right = side_speeds_for(v_c, r, rp, TurnDirection::Right);
            prop_assert_eq!(left.mirrored(), right);
            let bl = body_velocity(left, 1.1);
            let br = body_velocity(right, 1.1);
            prop_assert!((bl.forward_mps - br.forward_mps).abs() < 1e-5);
            prop_assert!((bl.yaw_rate_rad_s + br.yaw_rate_rad_s).abs() < 1e-5);
            prop_assert_eq!(turn_direction(right), if r.is_finite() { Some(TurnDirection::Right) } else { None });
        }

        #[test]
        fn commanded_radius_round_trips_through_eq_2_4(v_c in 0.05f32..2.0, k in 0.0f32..20.0) {
            let rp = 0.55;
            let r = k * rp;
            let speeds = side_speeds_for(v_c, r, rp, TurnDirection::Left);
            // Eq 2.6: the constraint holds.
            prop_assert!((total_absolute_speed_mps(speeds) - v_c).abs() < 1e-5 * v_c.max(1.0));
            let back = turning_radius_m(speeds, 2.0 * rp).unwrap_or(f32::NAN);
            prop_assert!((back - r).abs() <= 1e-3 * r.max(1.0), "R {} → {}", r, back);
        }
    }
}
