//! Power models of a skid-steer rover, each a small type with a `predict`-style method. The
//! simulator, the validation, the diagnosis and the planner all use these; no equation is copied.

/// Standard gravity used by the seed [m/s²] (paper Table 2).
pub const GRAVITY_M_S2: f64 = 9.81;

/// The ICR-based hard-ground model in the paper's simplified form (paper Eq 20–22): symmetric
/// ICRs at ±B_s/2, equal normal force p = mg/4 on the four wheels,
/// P = F |ω_z| + G (|V_r| + |V_l|) with F = 2 μ p √(L² + (W − B_s)²).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
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

/// Wheel positions relative to the geometric centre, with the normal force on each wheel
/// (front left, front right, rear left, rear right).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelLoads {
    /// p_1 … p_4 [N] in the order FL, FR, RL, RR.
    pub normal_force_n: [f64; 4],
}

impl WheelLoads {
    /// Equal loads p = mg/4 (centre of mass at the geometric centre, Eq 2.11).
    pub fn equal(mass_kg: f64) -> Self {
        Self {
            normal_force_n: [mass_kg * GRAVITY_M_S2 / 4.0; 4],
        }
    }
}

/// The general ICR-based model (Eq 1.16; paper Eq 18–19):
/// P = μ|ω_z| Σ p_n ‖a_n − C_n‖ + G(|V_r| + |V_l|) + Φ m g v_y sin θ,
/// where C_n is the ICR on the wheel's own side (paper Fig. 4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IcrGeneral {
    pub mu: f64,
    /// G [N].
    pub rolling_resistance_n: f64,
    /// Φ: scaling of the elevation-change term.
    pub phi: f64,
    pub mass_kg: f64,
    /// L [m].
    pub length_m: f64,
    /// W (= B) [m].
    pub width_m: f64,
    pub loads: WheelLoads,
}

impl IcrGeneral {
    /// Eq 1.16 for side speeds, ICR positions (`kinematics::IcrPositions`, [m]) and pitch θ [rad].
    pub fn power_w(
        &self,
        left_mps: f64,
        right_mps: f64,
        icr: crate::kinematics::IcrPositions,
        pitch_rad: f64,
    ) -> f64 {
        let (x_l, x_r, y) = (
            f64::from(icr.left_x_m),
            f64::from(icr.right_x_m),
            f64::from(icr.y_m),
        );
        let bs = x_r - x_l;
        // Eq 1.5 and 1.7 in the general (asymmetric ICR) form.
        let yaw_rate = (right_mps - left_mps) / bs;
        let forward = (left_mps * x_r - right_mps * x_l) / bs;
        let (hl, hw) = (self.length_m / 2.0, self.width_m / 2.0);
        // FL, FR, RL, RR wheel centres and the ICR on each wheel's side.
        let wheels = [
            (-hw, hl, x_l),
            (hw, hl, x_r),
            (-hw, -hl, x_l),
            (hw, -hl, x_r),
        ];
        let skid: f64 = wheels
            .iter()
            .zip(self.loads.normal_force_n)
            .map(|(&(wx, wy, icr_x), p)| p * libm::hypot(wx - icr_x, wy - y))
            .sum();
        self.mu * libm::fabs(yaw_rate) * skid
            + self.rolling_resistance_n * (libm::fabs(right_mps) + libm::fabs(left_mps))
            + self.phi * self.mass_kg * GRAVITY_M_S2 * forward * libm::sin(pitch_rad)
    }
}

/// The thesis' simplified model (Eq 2.12; flat ground Eq 2.16) under constant v_c:
/// P = 2c₁/B_s + c₂ + c₃θ for R ≤ R', c₁/R + c₂ + c₃θ above.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimplifiedIcr {
    /// c₁ = μ v_c m g d_ICR (Eq 2.13) [W·m].
    pub c1_w_m: f64,
    /// c₂ = 2 G v_c (Eq 2.14) [W].
    pub c2_w: f64,
    /// c₃ [W per degree of pitch]: the seed fits pitch in degrees (Table 4.3); physically
    /// Φ m g v_y (Eq 2.15) per radian.
    pub c3_w_per_deg: f64,
    /// B_s [m].
    pub slip_track_m: f64,
}

impl SimplifiedIcr {
    /// Eq 2.13–2.15 from physical parameters at total absolute speed v_c (v_y = v_c above R').
    pub fn from_physical(
        mu: f64,
        rolling_resistance_n: f64,
        phi: f64,
        mass_kg: f64,
        icr_distance_m: f64,
        slip_track_m: f64,
        v_c_mps: f64,
    ) -> Self {
        let weight = mass_kg * GRAVITY_M_S2;
        Self {
            c1_w_m: mu * v_c_mps * weight * icr_distance_m,
            c2_w: 2.0 * rolling_resistance_n * v_c_mps,
            c3_w_per_deg: (phi * weight * v_c_mps).to_radians(),
            slip_track_m,
        }
    }

    /// Eq 2.12 with the coefficients of a Table 4.3-form fit ([`crate::fit::TurnPitchFit`]) and
    /// the slip track B_s: the fitted c₁/R holds above R' and levels off below it, as the model
    /// says (the fit form itself, used by the seed on mixed radii, has no plateau).
    pub fn from_fit(fit: &crate::fit::TurnPitchModel, slip_track_m: f64) -> Self {
        Self {
            c1_w_m: fit.c1_w_m.value,
            c2_w: fit.c2_w.value,
            c3_w_per_deg: fit.c3_w_per_deg.value,
            slip_track_m,
        }
    }

    /// Eq 2.12 at turning radius `radius_m` (INFINITY for straight) and pitch [deg].
    pub fn power_w(&self, radius_m: f64, pitch_deg: f64) -> f64 {
        let r_prime = self.slip_track_m / 2.0;
        let skid = if radius_m <= r_prime {
            2.0 * self.c1_w_m / self.slip_track_m
        } else {
            self.c1_w_m / radius_m
        };
        skid + self.c2_w + self.c3_w_per_deg * pitch_deg
    }
}

/// A brushed DC motor driving one side through a gearbox (Eq 1.17–1.19).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DcMotor {
    /// K_T [N·m/A].
    pub torque_constant_nm_per_a: f64,
    /// Gear ratio (motor turns per wheel turn).
    pub gear_ratio: f64,
    /// η: efficiency of the drive, 0 < η ≤ 1.
    pub efficiency: f64,
    /// R_m [Ω].
    pub winding_resistance_ohm: f64,
}

impl DcMotor {
    /// Eq 1.17: P_m = ω_m τ_m + R_m I_m² for the motor's own torque [N·m] and speed [rad/s].
    pub fn motor_power_w(&self, motor_torque_nm: f64, motor_rate_rad_s: f64) -> f64 {
        let current = motor_torque_nm / self.torque_constant_nm_per_a;
        motor_rate_rad_s * motor_torque_nm + self.winding_resistance_ohm * current * current
    }

    /// Eq 1.18/1.19: electrical power of one side for wheel torque τ [N·m] at wheel rate ω
    /// [rad/s]: τω/η + (τ / (K_T g η))² R_m. Negative when the side is driven by the other one.
    pub fn side_power_w(&self, wheel_torque_nm: f64, wheel_rate_rad_s: f64) -> f64 {
        let current =
            wheel_torque_nm / (self.torque_constant_nm_per_a * self.gear_ratio * self.efficiency);
        wheel_torque_nm * wheel_rate_rad_s / self.efficiency
            + current * current * self.winding_resistance_ohm
    }

    /// Total power of both sides with the no-regeneration clamp: a side that would generate
    /// (negative power) draws nothing, since the rover cannot charge its battery (Section 1.1.3).
    pub fn total_power_w(
        &self,
        torque_nm: crate::Sides<f64>,
        rate_rad_s: crate::Sides<f64>,
    ) -> f64 {
        let side = |t, w| libm::fmax(self.side_power_w(t, w), 0.0);
        side(torque_nm.left, rate_rad_s.left) + side(torque_nm.right, rate_rad_s.right)
    }
}

/// Dogru & Marques' friction coefficient for a turn of radius R (Eq 1.20), with the centre of
/// mass displaced by (C_x, C_y) from the geometric centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DogruFriction {
    /// μ_r: rolling friction coefficient.
    pub mu_rolling: f64,
    /// μ_s: skidding friction coefficient.
    pub mu_skid: f64,
    /// L [m].
    pub length_m: f64,
    /// B [m].
    pub width_m: f64,
    /// C_x [m].
    pub com_x_m: f64,
    /// C_y [m].
    pub com_y_m: f64,
}

impl DogruFriction {
    /// Eq 1.20: μ(R).
    pub fn mu(&self, radius_m: f64) -> f64 {
        let (hl, hb) = (self.length_m / 2.0, self.width_m / 2.0);
        let fore_aft = hl - libm::fabs(self.com_x_m);
        let geometry = libm::sqrt((fore_aft * fore_aft + hb * hb) / (hl * hl + hb * hb));
        let offset = self.com_x_m / self.length_m;
        let skid = 2.0 * self.length_m * (0.25 - offset * offset);
        (radius_m + self.com_y_m) / (radius_m + hb) * geometry * self.mu_rolling
            + skid / (radius_m + hb) * self.mu_skid
    }
}

/// Whether friction opposes the gravity component along the heading (the ± of Eq 1.21).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrictionSense {
    /// "+": friction and the climbing load add up (the usual case).
    Opposing,
    /// "−".
    Aiding,
}

/// Dogru & Marques' power model (Eq 1.21) with motor constants k₁ [W/N²] and k₂ [W·s/(N·rad)].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DogruPower {
    pub k1: f64,
    pub k2: f64,
}

impl DogruPower {
    /// Eq 1.21, written as P = k₁T² + k₂ω_z T with the traction T = ±μ m g cos θ_s +
    /// m g sin θ_s sin γ — algebraically the same as the seed's expanded form (tested).
    pub fn power_w(
        &self,
        mu: f64,
        mass_kg: f64,
        slope_rad: f64,
        attack_rad: f64,
        yaw_rate_rad_s: f64,
        sense: FrictionSense,
    ) -> f64 {
        let weight = mass_kg * GRAVITY_M_S2;
        let sign = match sense {
            FrictionSense::Opposing => 1.0,
            FrictionSense::Aiding => -1.0,
        };
        let traction = sign * mu * weight * libm::cos(slope_rad)
            + weight * libm::sin(slope_rad) * libm::sin(attack_rad);
        self.k1 * traction * traction + self.k2 * yaw_rate_rad_s * traction
    }
}

/// Eq 1.13: shear stress of the exponential friction model, τ = p μ (1 − e^(−j/K)).
pub fn exponential_shear_stress_pa(
    pressure_pa: f64,
    mu: f64,
    shear_displacement_m: f64,
    shear_modulus_m: f64,
) -> f64 {
    pressure_pa * mu * (1.0 - libm::exp(-shear_displacement_m / shear_modulus_m))
}

/// The steady-turn dynamic model's torques per side (Eq 1.12 with M q̈ = 0): resistance
/// (Eq 1.14) plus gravity (Eq 1.15). Inner side first, as in the seed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DynamicTurn {
    /// F_i + F_Ri and F_o + F_Ro: friction plus rolling resistance of each side [N].
    pub resistance_n: (f64, f64),
    /// τ_i,res and τ_o,res: drivetrain friction, measured with the wheels lifted [N·m].
    pub drivetrain_friction_nm: (f64, f64),
}

impl DynamicTurn {
    /// Eq 1.14: C_d = R [F_i + F_Ri, F_o + F_Ro]ᵀ + [τ_i,res, τ_o,res]ᵀ, as printed (the
    /// factor R multiplies forces into torques).
    pub fn resistance_torques_nm(&self, radius_m: f64) -> (f64, f64) {
        (
            radius_m * self.resistance_n.0 + self.drivetrain_friction_nm.0,
            radius_m * self.resistance_n.1 + self.drivetrain_friction_nm.1,
        )
    }

    /// Eq 1.15: G_d = r m g sin θ_s sin γ / B · [B/2 − C_x, B/2 + C_x]ᵀ. The seed prints the
    /// term without g; it is needed for a torque in N·m and is included here.
    pub fn gravity_torques_nm(
        wheel_radius_m: f64,
        mass_kg: f64,
        slope_rad: f64,
        attack_rad: f64,
        width_m: f64,
        com_x_m: f64,
    ) -> (f64, f64) {
        let common =
            wheel_radius_m * mass_kg * GRAVITY_M_S2 * libm::sin(slope_rad) * libm::sin(attack_rad)
                / width_m;
        (
            common * (width_m / 2.0 - com_x_m),
            common * (width_m / 2.0 + com_x_m),
        )
    }

    /// Eq 1.12 in steady state: τ = C_d + G_d per side.
    pub fn torques_nm(&self, radius_m: f64, gravity_nm: (f64, f64)) -> (f64, f64) {
        let (ri, ro) = self.resistance_torques_nm(radius_m);
        (ri + gravity_nm.0, ro + gravity_nm.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::kinematics::{side_speeds_for, IcrPositions, TurnDirection};

    #[test]
    fn general_model_reduces_to_paper_eq_20() {
        let hg = IcrHardGround::HUSKY_HARD_GROUND;
        let general = IcrGeneral {
            mu: hg.mu,
            rolling_resistance_n: hg.rolling_resistance_n,
            phi: 0.0,
            mass_kg: hg.mass_kg,
            length_m: hg.length_m,
            width_m: hg.width_m,
            loads: WheelLoads::equal(hg.mass_kg),
        };
        let icr = IcrPositions::symmetric(hg.slip_track_m as f32);
        for (vl, vr) in [
            (-0.3, 0.3),
            (0.0, 0.6),
            (0.1, 0.5),
            (0.3, 0.3),
            (0.45, 0.15),
        ] {
            let a = general.power_w(vl, vr, icr, 0.0);
            let b = hg.power_w(vl, vr);
            assert!((a - b).abs() < 1e-3, "({vl}, {vr}): {a} vs {b}");
        }
    }

    #[test]
    fn eq_2_12_is_eq_1_16_under_constant_v_c() {
        // All four wheels at the same distance d_ICR from their ICR and equal loads, so
        // Σ p_n ‖a_n − C_n‖ = m g d_ICR (Section 2.2).
        let (mu, g, phi, m, bs, l, w) = (0.74, 30.85, 0.8, 63.0, 1.1, 0.52, 0.545);
        let d_icr = libm::hypot(l / 2.0, (bs - w) / 2.0);
        let general = IcrGeneral {
            mu,
            rolling_resistance_n: g,
            phi,
            mass_kg: m,
            length_m: l,
            width_m: w,
            loads: WheelLoads::equal(m),
        };
        let v_c = 0.3;
        let simple = SimplifiedIcr::from_physical(mu, g, phi, m, d_icr, bs, v_c);
        let r_prime = bs / 2.0;
        for k in [0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 12.0] {
            let r = k * r_prime / 3.0;
            let speeds = side_speeds_for(v_c as f32, r as f32, r_prime as f32, TurnDirection::Left);
            let (vl, vr) = (f64::from(speeds.left_mps), f64::from(speeds.right_mps));
            let pitch_deg: f64 = 4.0;
            let a = general.power_w(
                vl,
                vr,
                IcrPositions::symmetric(bs as f32),
                pitch_deg.to_radians(),
            );
            // The slope term of Eq 2.12 uses v_y = v_c (R > R') and sin θ ≈ θ.
            let forward =
                crate::kinematics::forward_speed_for(v_c as f32, r as f32, r_prime as f32) as f64;
            let b = simple.power_w(r, 0.0)
                + phi * m * GRAVITY_M_S2 * forward * libm::sin(pitch_deg.to_radians());
            assert!((a - b).abs() < 1e-3 * a.abs(), "R = {r}: {a} vs {b}");
        }
        // Constant below R' (Fig. 2.3), falling above.
        assert_eq!(simple.power_w(0.0, 0.0), simple.power_w(r_prime, 0.0));
        assert!(simple.power_w(2.0 * r_prime, 0.0) < simple.power_w(r_prime, 0.0));
        assert!((simple.power_w(f64::INFINITY, 0.0) - simple.c2_w).abs() < 1e-12);
    }

    #[test]
    fn table_4_3_form_and_pitch_units() {
        // Table 4.3 fit: c1 = 5.55, c2 = 139.4, c3 = 6.608 W/deg, B_s = 1.1 m.
        let fit = SimplifiedIcr {
            c1_w_m: 5.55,
            c2_w: 139.4,
            c3_w_per_deg: 6.608,
            slip_track_m: 1.1,
        };
        assert!((fit.power_w(2.0, 5.0) - (5.55 / 2.0 + 139.4 + 33.04)).abs() < 1e-9);
        assert!((fit.power_w(0.3, 0.0) - (2.0 * 5.55 / 1.1 + 139.4)).abs() < 1e-9);
        // from_physical: c3 per degree is Φ m g v_c · π/180.
        let s = SimplifiedIcr::from_physical(0.5, 30.0, 1.0, 63.0, 0.5, 1.1, 0.3);
        assert!((s.c3_w_per_deg - 63.0 * 9.81 * 0.3 * core::f64::consts::PI / 180.0).abs() < 1e-9);
        assert!((s.c2_w - 18.0).abs() < 1e-12);
    }

    #[test]
    fn a_table_4_3_fit_becomes_eq_2_12() {
        // Noiseless samples of the Table 4.3 law above R' = 0.55 m, fitted, then used as Eq 2.12.
        let truth = SimplifiedIcr {
            c1_w_m: 5.55,
            c2_w: 139.4,
            c3_w_per_deg: 6.608,
            slip_track_m: 1.1,
        };
        let mut fit = crate::fit::TurnPitchFit::new();
        for (r, pitch) in [
            (0.6, -3.0),
            (0.8, 0.0),
            (1.2, 2.0),
            (2.0, 5.0),
            (4.0, -1.0),
            (9.0, 4.0),
        ] {
            fit.add(r, pitch, truth.power_w(r, pitch))
                .expect("finite sample");
        }
        let model = SimplifiedIcr::from_fit(&fit.solve().expect("well posed"), 1.1);
        for (r, pitch) in [(0.0, 0.0), (0.3, 1.0), (0.55, 0.0), (3.0, -2.0)] {
            assert!(
                (model.power_w(r, pitch) - truth.power_w(r, pitch)).abs() < 1e-6,
                "R = {r}"
            );
        }
    }

    #[test]
    fn dc_motor_side_power_and_no_regeneration() {
        let motor = DcMotor {
            torque_constant_nm_per_a: 0.044,
            gear_ratio: 78.71,
            efficiency: 0.8,
            winding_resistance_ohm: 0.46,
        };
        // Eq 1.18 by hand: τ = 5 N·m at 3 rad/s.
        let i = 5.0 / (0.044 * 78.71 * 0.8);
        assert!((motor.side_power_w(5.0, 3.0) - (15.0 / 0.8 + i * i * 0.46)).abs() < 1e-9);
        // Eq 1.17 agrees with Eq 1.18 for an ideal gearbox (η = 1): motor τ_m = τ/g, ω_m = g ω.
        let ideal = DcMotor {
            efficiency: 1.0,
            ..motor
        };
        assert!(
            (ideal.side_power_w(5.0, 3.0) - ideal.motor_power_w(5.0 / 78.71, 3.0 * 78.71)).abs()
                < 1e-9
        );
        // An inner side dragged forward against its torque generates: clamped to zero in the total.
        let dragged = motor.side_power_w(-8.0, 1.0);
        assert!(dragged < 0.0);
        let total = motor.total_power_w(crate::Sides::new(-8.0, 12.0), crate::Sides::new(1.0, 4.0));
        assert!((total - motor.side_power_w(12.0, 4.0)).abs() < 1e-12);
        // Mirror symmetry.
        let mirrored =
            motor.total_power_w(crate::Sides::new(12.0, -8.0), crate::Sides::new(4.0, 1.0));
        assert_eq!(total, mirrored);
    }

    #[test]
    fn dogru_friction_limits() {
        let f = DogruFriction {
            mu_rolling: 0.05,
            mu_skid: 0.6,
            length_m: 0.52,
            width_m: 0.545,
            com_x_m: 0.0,
            com_y_m: 0.0,
        };
        // Straight line: only rolling friction; point turn: (L/B) μ_s.
        assert!((f.mu(1.0e9) - 0.05).abs() < 1e-6);
        assert!((f.mu(0.0) - 0.52 / 0.545 * 0.6).abs() < 1e-12);
        // Skid friction falls as the centre of mass moves fore or aft (the seed's conclusion).
        let shifted = DogruFriction { com_x_m: 0.1, ..f };
        assert!(shifted.mu(0.5) < f.mu(0.5));
    }

    #[test]
    fn dogru_power_matches_the_expanded_eq_1_21() {
        let model = DogruPower { k1: 0.002, k2: 1.7 };
        let (mu, m, slope, attack, w) = (0.6, 63.0, 0.15, 0.7, 0.5);
        let g = GRAVITY_M_S2;
        for (sense, sign) in [
            (FrictionSense::Opposing, 1.0),
            (FrictionSense::Aiding, -1.0),
        ] {
            let (c, s) = (libm::cos(slope), libm::sin(slope) * libm::sin(attack));
            // The seed's expanded form, term by term.
            let expanded = mu * mu * model.k1 * m * m * g * g * c * c
                + sign * mu * (2.0 * m * g * model.k1 * s + w * model.k2) * m * g * c
                + m * g * s * (m * g * model.k1 * s + w * model.k2);
            let got = model.power_w(mu, m, slope, attack, w, sense);
            assert!(
                (got - expanded).abs() < 1e-9 * expanded.abs(),
                "{sense:?}: {got} vs {expanded}"
            );
        }
    }

    #[test]
    fn dynamic_model_terms() {
        assert!((exponential_shear_stress_pa(1000.0, 0.5, 0.0, 0.01)).abs() < 1e-12);
        assert!((exponential_shear_stress_pa(1000.0, 0.5, 1.0, 0.01) - 500.0).abs() < 1e-6);
        let (gi, go) = DynamicTurn::gravity_torques_nm(0.165, 63.0, 0.2, 0.5, 0.545, 0.0);
        assert!(
            (gi - go).abs() < 1e-12,
            "centred mass shares the slope load equally"
        );
        let total = 0.165 * 63.0 * GRAVITY_M_S2 * libm::sin(0.2) * libm::sin(0.5);
        assert!((gi + go - total).abs() < 1e-9);
        let turn = DynamicTurn {
            resistance_n: (40.0, 60.0),
            drivetrain_friction_nm: (0.5, 0.7),
        };
        assert_eq!(turn.resistance_torques_nm(0.5), (20.5, 30.7));
        assert_eq!(turn.torques_nm(0.5, (1.0, 2.0)), (21.5, 32.7));
    }

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
