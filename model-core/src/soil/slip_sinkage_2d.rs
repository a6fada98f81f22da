//! The grousered wheel (Table 5.1, Eq 5.15–5.20, 5.25–5.26) and the seed's 2D slip-sinkage
//! model (Section 5.3.1, Eq 5.15–5.28).

use super::{check, finite_result, input, param, unbounded, SoilError};
use core::f64::consts::PI;

/// A grousered wheel (Fig 5.9, Table 5.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wheel {
    /// r [m].
    pub radius_m: f64,
    /// B_w: wheel thickness (width) [m].
    pub width_m: f64,
    /// n_g: number of grousers.
    pub grouser_count: u16,
    /// h: grouser height [m].
    pub grouser_height_m: f64,
    /// B_g: grouser width (across the wheel) [m].
    pub grouser_width_m: f64,
    /// l_g: grouser thickness (along the rim) [m].
    pub grouser_thickness_m: f64,
}

impl Wheel {
    /// Table 5.1: the Clearpath Husky's pneumatic wheel.
    pub const HUSKY: Wheel = Wheel {
        radius_m: 0.165,
        width_m: 0.125,
        grouser_count: 28,
        grouser_height_m: 0.015,
        grouser_width_m: 0.085,
        grouser_thickness_m: 0.011,
    };

    /// Checks that every dimension is finite, the radius and width positive and the grouser
    /// dimensions non-negative.
    pub fn validate(&self) -> Result<(), SoilError> {
        param(self.radius_m, "radius_m", |r| r > 0.0)?;
        param(self.width_m, "width_m", |b| b > 0.0)?;
        param(self.grouser_height_m, "grouser_height_m", |h| h >= 0.0)?;
        param(self.grouser_width_m, "grouser_width_m", |b| b >= 0.0)?;
        param(self.grouser_thickness_m, "grouser_thickness_m", |l| {
            l >= 0.0
        })?;
        Ok(())
    }

    /// Eq 5.18: contact-patch thickness B_c = e_cw B_w [m] (e_cw ≈ 1.05 for the Husky's
    /// pneumatic tyre, 1 for a rigid cylinder).
    pub const fn contact_width_m(&self, contact_ratio: f64) -> f64 {
        contact_ratio * self.width_m
    }

    /// Eq 5.20 without checks (for constants).
    const fn excavation_efficiency_raw(&self, contact_ratio: f64) -> f64 {
        let grouser_area_m2 =
            self.grouser_count as f64 * self.grouser_width_m * self.grouser_thickness_m;
        1.0 - grouser_area_m2 / (2.0 * PI * self.radius_m * self.contact_width_m(contact_ratio))
    }

    /// Eq 5.20: excavation efficiency k_EX = 1 − n_g B_g l_g / (2π r B_c), with
    /// B_c = e_cw B_w (Eq 5.18).
    ///
    /// Choice: the seed's denominator is the contact-patch thickness B_c, not the wheel
    /// thickness B_w. Only that reading reproduces the published Husky value: with
    /// B_c = 1.05 × 0.125 m, k_EX = 1 − 0.02618 / 0.13607 = 0.80760 (seed: 0.8076); with
    /// B_w = 0.125 m it would be 1 − 0.02618 / 0.12959 = 0.79798.
    ///
    /// `Err` for an invalid wheel, e_cw < 1 (the seed: e_cw ≥ 1), or grousers covering the
    /// whole rim (k_EX ≤ 0).
    pub fn excavation_efficiency(&self, contact_ratio: f64) -> Result<f64, SoilError> {
        self.validate()?;
        param(contact_ratio, "contact_ratio", |e| e >= 1.0)?;
        let k = self.excavation_efficiency_raw(contact_ratio);
        check(
            k > 0.0,
            SoilError::InvalidParameter("grouser area ≥ rim area"),
        )?;
        Ok(k)
    }
}

/// Eq 5.15 / 5.16 / 1.25 inverted: the angle at which the rim meets a soil surface `depth_m`
/// above the wheel's lowest point, acos(1 − depth/r) [rad]. The argument is clamped to [−1, 1].
pub(super) fn entry_angle_rad(depth_m: f64, radius_m: f64) -> f64 {
    libm::acos((1.0 - depth_m / radius_m).clamp(-1.0, 1.0))
}

/// Eq 5.26: length of the wheel along the sand at the soil level (a chord of the rim),
/// w_g = 2 √(d_avg (2r − d_avg)) [m], from the average sinkage d_avg ∈ [0, 2r] (Eq 5.25) and the
/// wheel radius r [m].
pub fn ground_width_m(average_sinkage_m: f64, radius_m: f64) -> Result<f64, SoilError> {
    let r = param(radius_m, "radius_m", |r| r > 0.0)?;
    let d = input(average_sinkage_m, "average_sinkage_m", |d| {
        (0.0..=2.0 * r).contains(&d)
    })?;
    Ok(chord_m(d, r))
}

/// Eq 5.26 without checks (d ∈ [0, 2r]).
pub(super) fn chord_m(average_sinkage_m: f64, radius_m: f64) -> f64 {
    2.0 * libm::sqrt((average_sinkage_m * (2.0 * radius_m - average_sinkage_m)).max(0.0))
}

// ---------------------------------------------------------------------------------------------
// 2D slip-sinkage model (Section 5.3.1)
// ---------------------------------------------------------------------------------------------

/// Parameters of the 2D slip-sinkage model of one wheel (Section 5.3.1, Table 5.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlipSinkageParams {
    /// The wheel (r, B_w, h are used).
    pub wheel: Wheel,
    /// d_0: static sinkage, the initial value and lower bound of d [m], > 0.
    pub static_sinkage_m: f64,
    /// h_gc: ground clearance, the upper bound of d [m].
    pub ground_clearance_m: f64,
    /// λ: rear-to-front sinkage ratio (Eq 5.16), > 0.
    pub sinkage_ratio: f64,
    /// e_cw: contact-patch to wheel thickness ratio (Eq 5.18), ≥ 1.
    pub contact_ratio: f64,
    /// k_EX: excavation efficiency (Eq 5.19–5.20), in (0, 1].
    pub excavation_efficiency: f64,
    /// k_f: front compaction parameter (Eq 5.27), ≥ 0.
    pub front_compaction: f64,
    /// k_s: side compaction parameter (Eq 5.27), ≥ 0.
    pub side_compaction: f64,
}

impl SlipSinkageParams {
    /// The Husky wheel on GRC-1 (Table 5.1; e_cw = 1.05; k_EX from Eq 5.20 = 0.8076; k_f = 0.85,
    /// k_s = 0.35 as tuned at v_ACT = 0.02 m/s, Fig 5.10). The seed notes that at
    /// v_ACT = 0.04 m/s k_f ≈ 0.6 and k_s ≈ 0.2 fit better: the parameters depend on speed.
    pub const HUSKY_GRC1: SlipSinkageParams = SlipSinkageParams {
        wheel: Wheel::HUSKY,
        static_sinkage_m: 0.01,
        ground_clearance_m: 0.13,
        sinkage_ratio: 0.7,
        contact_ratio: 1.05,
        excavation_efficiency: Wheel::HUSKY.excavation_efficiency_raw(1.05),
        front_compaction: 0.85,
        side_compaction: 0.35,
    };

    /// Checks the domains documented on each field, and that the bounds keep the geometry
    /// defined: 0 < d_0 ≤ h_gc, and h_gc and λ h_gc at most 2r (so acos in Eq 5.15–5.16 and the
    /// square root in Eq 5.26 stay real).
    pub fn validate(&self) -> Result<(), SoilError> {
        self.wheel.validate()?;
        let r = self.wheel.radius_m;
        let d0 = param(self.static_sinkage_m, "static_sinkage_m", |d| d > 0.0)?;
        let lambda = param(self.sinkage_ratio, "sinkage_ratio", |l| l > 0.0)?;
        param(self.ground_clearance_m, "ground_clearance_m", |h| {
            h >= d0 && h <= 2.0 * r && lambda * h <= 2.0 * r
        })?;
        param(self.contact_ratio, "contact_ratio", |e| e >= 1.0)?;
        param(self.excavation_efficiency, "excavation_efficiency", |k| {
            k > 0.0 && k <= 1.0
        })?;
        param(self.front_compaction, "front_compaction", |k| k >= 0.0)?;
        param(self.side_compaction, "side_compaction", |k| k >= 0.0)?;
        Ok(())
    }
}

/// What one step of [`SlipSinkage2d`] did (volumes over the step, Eq 5.19–5.28).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SinkageStep {
    /// V_REM: sand excavated from under the wheel (Eq 5.19) [m³].
    pub removed_m3: f64,
    /// V_front: sand met in front of the wheel (Eq 5.23) [m³].
    pub front_m3: f64,
    /// V_side: sand met beside the wheel (Eq 5.24) [m³].
    pub side_m3: f64,
    /// V_ADD = k_f V_front + k_s V_side (Eq 5.27) [m³].
    pub added_m3: f64,
    /// d(t) after the step, saturated to [d_0, h_gc] (Eq 5.28) [m].
    pub sinkage_m: f64,
    /// Whether Eq 5.28 left [d_0, h_gc] and was saturated.
    pub saturated: bool,
}

/// The seed's 2D slip-sinkage model of one wheel (Section 5.3.1, Eq 5.15–5.28): the sinkage d
/// (at the front of the wheel, below the undisturbed surface) starts at d_0 and each sample
/// moves it by the sand the grousers remove minus the sand the wheel runs onto, spread over the
/// contact patch, saturated to [d_0, h_gc].
///
/// The update is explicit: θ_f, θ_r, w_c, d_avg and w_g of step t all come from d(t − δt).
/// The seed writes d_avg(t) and w_g "(t)" in Eq 5.24–5.26, but d(t) is what Eq 5.28 computes,
/// so the previous sinkage is the only one available. A δt large enough to overshoot the
/// steady state just lands on a bound.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlipSinkage2d {
    params: SlipSinkageParams,
    sinkage_m: f64,
}

impl SlipSinkage2d {
    /// A wheel at rest at its static sinkage, d(0) = d_0. `Err` for invalid parameters.
    pub fn new(params: SlipSinkageParams) -> Result<Self, SoilError> {
        params.validate()?;
        Ok(Self {
            params,
            sinkage_m: params.static_sinkage_m,
        })
    }

    /// The parameters.
    pub fn params(&self) -> &SlipSinkageParams {
        &self.params
    }

    /// Back to d = d_0.
    pub fn reset(&mut self) {
        self.sinkage_m = self.params.static_sinkage_m;
    }

    /// Sets the sinkage d [m] (e.g. a measured one). `Err` outside [d_0, h_gc].
    pub fn set_sinkage_m(&mut self, sinkage_m: f64) -> Result<(), SoilError> {
        let (lo, hi) = (self.params.static_sinkage_m, self.params.ground_clearance_m);
        self.sinkage_m = input(sinkage_m, "sinkage_m", |d| d >= lo && d <= hi)?;
        Ok(())
    }

    /// d: sinkage at the front of the wheel [m], in [d_0, h_gc].
    pub fn sinkage_m(&self) -> f64 {
        self.sinkage_m
    }

    /// Eq 5.25: d_avg = (1 + λ) d / 2, the mean of the front and rear sinkage [m].
    pub fn average_sinkage_m(&self) -> f64 {
        (1.0 + self.params.sinkage_ratio) * self.sinkage_m / 2.0
    }

    /// Eq 5.26: w_g = 2 √(d_avg (2r − d_avg)), the wheel's length along the sand [m].
    pub fn ground_width_m(&self) -> f64 {
        chord_m(self.average_sinkage_m(), self.params.wheel.radius_m)
    }

    /// Eq 5.15: θ_f = acos(1 − d/r), the front entry angle [rad].
    pub fn front_angle_rad(&self) -> f64 {
        entry_angle_rad(self.sinkage_m, self.params.wheel.radius_m)
    }

    /// Eq 5.16: θ_r = acos(1 − λd/r), the rear exit angle (a magnitude) [rad].
    pub fn rear_angle_rad(&self) -> f64 {
        entry_angle_rad(
            self.params.sinkage_ratio * self.sinkage_m,
            self.params.wheel.radius_m,
        )
    }

    /// Eq 5.17: w_c = r (θ_f + θ_r), the length of the contact patch along the rim [m]. (The
    /// seed's "θ_e" in Eq 5.17 is θ_r.)
    pub fn contact_length_m(&self) -> f64 {
        self.params.wheel.radius_m * (self.front_angle_rad() + self.rear_angle_rad())
    }

    /// One sample of Eq 5.15–5.28, d(t − δt) → d(t), from the wheel's actual speed ‖v_ACT‖, the
    /// slip angle β between v_ACT and v_CMD, the commanded linear speed v_CMD = r ω_CMD [m/s] and
    /// the sample interval δt [s]:
    ///
    /// - V_REM = k_EX B_c h |v_CMD| δt (Eq 5.19, B_c = e_cw B_w by Eq 5.18);
    /// - Δy_front = |v_ACT| δt |cos β|, Δx_side = |v_ACT| δt |sin β| (Eq 5.21–5.22);
    /// - V_front = Δy_front B_w d, V_side = Δx_side w_g d (Eq 5.23–5.24, d = d(t − δt));
    /// - V_ADD = k_f V_front + k_s V_side (Eq 5.27);
    /// - d(t) = d + (V_REM − V_ADD) / (B_c w_c) (Eq 5.28), saturated to [d_0, h_gc].
    ///
    /// Speeds and β enter as magnitudes (see the module notes). `Err` for a non-finite input or
    /// δt ≤ 0 (`InvalidInput`), or when finite but huge inputs overflow (`Overflow`); the sinkage
    /// is then unchanged.
    pub fn step(
        &mut self,
        v_act_mps: f64,
        slip_angle_rad: f64,
        v_cmd_mps: f64,
        dt_s: f64,
    ) -> Result<SinkageStep, SoilError> {
        let v_act = libm::fabs(input(v_act_mps, "v_act_mps", unbounded)?);
        let beta = input(slip_angle_rad, "slip_angle_rad", unbounded)?;
        let v_cmd = libm::fabs(input(v_cmd_mps, "v_cmd_mps", unbounded)?);
        let dt = input(dt_s, "dt_s", |t| t > 0.0)?;

        let p = &self.params;
        let d = self.sinkage_m;
        let contact_width_m = p.wheel.contact_width_m(p.contact_ratio);
        // Eq 5.19.
        let removed_m3 =
            p.excavation_efficiency * contact_width_m * p.wheel.grouser_height_m * v_cmd * dt;
        // Eq 5.21–5.22.
        let (sin_b, cos_b) = libm::sincos(beta);
        let travel_m = v_act * dt;
        let front_travel_m = travel_m * libm::fabs(cos_b);
        let side_travel_m = travel_m * libm::fabs(sin_b);
        // Eq 5.23–5.27.
        let front_m3 = front_travel_m * p.wheel.width_m * d;
        let side_m3 = side_travel_m * self.ground_width_m() * d;
        let added_m3 = p.front_compaction * front_m3 + p.side_compaction * side_m3;
        // Eq 5.28. w_c > 0 because d ≥ d_0 > 0.
        let unsaturated = d + (removed_m3 - added_m3) / (contact_width_m * self.contact_length_m());
        let unsaturated = finite_result(unsaturated)?;
        let sinkage_m = unsaturated.clamp(p.static_sinkage_m, p.ground_clearance_m);
        self.sinkage_m = sinkage_m;
        Ok(SinkageStep {
            removed_m3,
            front_m3,
            side_m3,
            added_m3,
            sinkage_m,
            saturated: sinkage_m != unsaturated,
        })
    }
}
