//! Power models of a skid-steer rover, each a small type with a `predict`-style method. The
//! simulator, the validation, the diagnosis and the planner all use these; no equation is copied.

/// Standard gravity used by the seed [m/s²] (paper Table 2).
pub const GRAVITY_M_S2: f64 = 9.81;

/// The ICR-based hard-ground model in the paper's simplified form (paper Eq 20–22): symmetric
/// ICRs at ±B_s/2, equal normal force p = mg/4 on the four wheels,
/// P = F |ω_z| + G (|V_r| + |V_l|) with F = 2 μ p √(L² + (W − B_s)²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IcrHardGround {
    /// μ: friction coefficient.
    pub mu: f64,
    /// G: internal and rolling resistance coefficient [W·s/m = N].
    pub rolling_resistance_n: f64,
    /// L: wheelbase [m].
    pub length_m: f64,
    /// W: track width [m].
    pub width_m: f64,
    /// m [kg].
    pub mass_kg: f64,
    /// B_s: slip track of this rover on this terrain [m].
    pub slip_track_m: f64,
}

impl IcrHardGround {
    /// Paper Table 2: Husky on hard ground (concrete), B_s from the EKF of Pentzer et al.
    pub const HUSKY_HARD_GROUND: IcrHardGround = IcrHardGround {
        mu: 0.74,
        rolling_resistance_n: 30.85,
        length_m: 0.52,
        width_m: 0.55,
        mass_kg: 63.0,
        slip_track_m: 1.29,
    };

    /// Normal force on each wheel, p = mg/4 [N].
    pub fn wheel_load_n(&self) -> f64 {
        self.mass_kg * GRAVITY_M_S2 / 4.0
    }

    /// Paper Eq 22: F = 2 μ p √(L² + (W − B_s)²) [N·m per rad].
    pub fn skid_moment_nm(&self) -> f64 {
        let lateral = self.width_m - self.slip_track_m;
        2.0 * self.mu
            * self.wheel_load_n()
            * libm::sqrt(self.length_m * self.length_m + lateral * lateral)
    }

    /// R' = B_s / 2 for this terrain's slip track [m].
    pub fn r_prime_m(&self) -> f64 {
        self.slip_track_m / 2.0
    }

    /// Paper Eq 21 (Eq 20 expanded): power for side speeds V_l, V_r [W].
    pub fn power_w(&self, left_mps: f64, right_mps: f64) -> f64 {
        let yaw_rate = (right_mps - left_mps) / self.slip_track_m;
        self.skid_moment_nm() * libm::fabs(yaw_rate)
            + self.rolling_resistance_n * (libm::fabs(right_mps) + libm::fabs(left_mps))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn husky_hard_ground_skid_moment() {
        // 2 · 0.74 · (63 · 9.81 / 4) · √(0.52² + (0.55 − 1.29)²) = 206.82 N·m.
        let f = IcrHardGround::HUSKY_HARD_GROUND.skid_moment_nm();
        assert!((f - 206.82).abs() < 0.01, "{f}");
    }

    #[test]
    fn point_turn_and_straight_line_power() {
        let m = IcrHardGround::HUSKY_HARD_GROUND;
        // Point turn at v_c = 0.3: ω = 0.6 / 1.29 rad/s.
        let p = m.power_w(-0.3, 0.3);
        assert!(
            (p - (206.82 * 0.6 / 1.29 + 30.85 * 0.6)).abs() < 0.01,
            "{p}"
        );
        // Straight at 0.3 m/s: only G (|V_r| + |V_l|).
        assert!((m.power_w(0.3, 0.3) - 30.85 * 0.6).abs() < 1e-9);
        // Mirror symmetry.
        assert_eq!(m.power_w(0.3, -0.3), p);
    }
}
