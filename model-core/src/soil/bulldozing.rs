//! Soil strength (Table 3.3) and sand bulldozing: Ishigami's side force (Eq 1.31–1.35) and the
//! simplified Skonieczny model of Section 5.4 (Eq 5.29–5.39).

use super::sinkage::simpson;
use super::slip_sinkage_2d::entry_angle_rad;
use super::{check, finite_result, input, param, unbounded, SoilError};
use crate::power::GRAVITY_M_S2;
use core::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// Strength and weight parameters of a granular soil (Table 3.3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Soil {
    /// ρ: dry bulk density [kg/m³].
    pub density_kg_m3: f64,
    /// φ_i: internal friction angle [rad], in (0, π/2).
    pub internal_friction_rad: f64,
    /// δ: external (wheel–soil) friction angle [rad], ≥ 0, φ_i + δ < π/2.
    pub external_friction_rad: f64,
    /// φ_r: angle of repose [rad], in (0, π/2).
    pub repose_angle_rad: f64,
    /// c: cohesion [Pa], ≥ 0.
    pub cohesion_pa: f64,
}

const DEG: f64 = PI / 180.0;

impl Soil {
    /// Table 3.3: GRC-1 in the laboratory sandbox (D_R ≈ 65 %): φ_i = 42°, δ = 0°,
    /// ρ = 1.7885 g/cm³, φ_r = 42°, c = 0.
    pub const GRC1_SANDBOX: Soil = Soil {
        density_kg_m3: 1788.5,
        internal_friction_rad: 42.0 * DEG,
        external_friction_rad: 0.0,
        repose_angle_rad: 42.0 * DEG,
        cohesion_pa: 0.0,
    };

    /// Checks the domains documented on each field.
    pub fn validate(&self) -> Result<(), SoilError> {
        param(self.density_kg_m3, "density_kg_m3", |r| r > 0.0)?;
        let phi = param(self.internal_friction_rad, "internal_friction_rad", |a| {
            a > 0.0 && a < FRAC_PI_2
        })?;
        param(self.external_friction_rad, "external_friction_rad", |a| {
            a >= 0.0 && phi + a < FRAC_PI_2
        })?;
        param(self.repose_angle_rad, "repose_angle_rad", |a| {
            a > 0.0 && a < FRAC_PI_2
        })?;
        param(self.cohesion_pa, "cohesion_pa", |c| c >= 0.0)?;
        Ok(())
    }

    /// ρ g: unit weight [N/m³].
    pub fn unit_weight_n_m3(&self) -> f64 {
        self.density_kg_m3 * GRAVITY_M_S2
    }
}

/// Eq 1.35: Bekker's approximation of the failure (destructive) angle, X_C = 45° − φ_i/2 [rad].
pub fn bekker_failure_angle_rad(internal_friction_rad: f64) -> f64 {
    FRAC_PI_4 - internal_friction_rad / 2.0
}

/// Eq 1.33: D_1 = cot X_C + tan(X_C + φ_i).
pub fn bulldozing_d1(failure_angle_rad: f64, internal_friction_rad: f64) -> f64 {
    1.0 / libm::tan(failure_angle_rad) + libm::tan(failure_angle_rad + internal_friction_rad)
}

/// Eq 1.34: D_2 = cot X_C + cot² X_C / cot φ_i.
pub fn bulldozing_d2(failure_angle_rad: f64, internal_friction_rad: f64) -> f64 {
    let cot_x = 1.0 / libm::tan(failure_angle_rad);
    cot_x + cot_x * cot_x * libm::tan(internal_friction_rad)
}

/// Ishigami et al.'s side bulldozing force on a wheel (Eq 1.31–1.35).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IshigamiBulldozing {
    soil: Soil,
    d1: f64,
    d2: f64,
}

impl IshigamiBulldozing {
    /// The model for a soil, with X_C from Eq 1.35 and D_1, D_2 from Eq 1.33–1.34. `Err` for an
    /// invalid soil.
    pub fn new(soil: Soil) -> Result<Self, SoilError> {
        soil.validate()?;
        let phi = soil.internal_friction_rad;
        let x_c = bekker_failure_angle_rad(phi);
        Ok(Self {
            soil,
            d1: bulldozing_d1(x_c, phi),
            d2: bulldozing_d2(x_c, phi),
        })
    }

    /// (D_1, D_2) of Eq 1.33–1.34.
    pub fn coefficients(&self) -> (f64, f64) {
        (self.d1, self.d2)
    }

    /// Eq 1.32: bulldozing resistance per unit length of the wheel side at depth h [m],
    /// R_b = D_1 (c h + D_2 ρ g h² / 2) [N/m].
    ///
    /// Choice: the seed writes ρ (a density); the term must be a unit weight for R_b to be a
    /// force per length, so ρ g is used (as in Bekker's and Hegedus's blade formulas). Negative
    /// depths count as 0.
    pub fn resistance_n_per_m(&self, depth_m: f64) -> f64 {
        let h = depth_m.max(0.0);
        self.d1 * (self.soil.cohesion_pa * h + self.d2 * self.soil.unit_weight_n_m3() * h * h / 2.0)
    }

    /// Eq 1.31: F_s = ∫ R_b(d(θ)) (r − d(θ) cos θ) dθ over the contact arc, θ from −θ_r (rear)
    /// to θ_f (front), integrated with Simpson's rule ([`SIMPSON_PANELS`] panels) [N].
    ///
    /// Choices (the seed leaves d(θ) and the angle signs implicit): θ_f and θ_r are magnitudes
    /// as in Eq 5.15–5.16, so the seed's limits θ_r…θ_f are −θ_r…θ_f here; the depth at θ is
    /// measured from the front soil surface, d(θ) = r (cos θ − cos θ_f), clipped at 0 (rim above
    /// the surface, possible at the rear when θ_r > θ_f).
    pub fn side_force_n(
        &self,
        radius_m: f64,
        front_angle_rad: f64,
        rear_angle_rad: f64,
    ) -> Result<f64, SoilError> {
        let r = param(radius_m, "radius_m", |r| r > 0.0)?;
        let tf = input(front_angle_rad, "front_angle_rad", |t| {
            (0.0..=PI).contains(&t)
        })?;
        let tr = input(rear_angle_rad, "rear_angle_rad", |t| {
            (0.0..=PI).contains(&t)
        })?;
        let cos_f = libm::cos(tf);
        let force = simpson(-tr, tf, |t| {
            let c = libm::cos(t);
            let depth = (r * (c - cos_f)).max(0.0);
            self.resistance_n_per_m(depth) * (r - depth * c)
        });
        finite_result(force)
    }

    /// Eq 1.31 for a wheel at front sinkage d and rear-to-front ratio λ: θ_f and θ_r from
    /// Eq 5.15–5.16 [N].
    pub fn side_force_for_sinkage_n(
        &self,
        radius_m: f64,
        sinkage_m: f64,
        sinkage_ratio: f64,
    ) -> Result<f64, SoilError> {
        let r = param(radius_m, "radius_m", |r| r > 0.0)?;
        let d = input(sinkage_m, "sinkage_m", |d| (0.0..=2.0 * r).contains(&d))?;
        let lambda = param(sinkage_ratio, "sinkage_ratio", |l| l >= 0.0)?;
        self.side_force_n(r, entry_angle_rad(d, r), entry_angle_rad(lambda * d, r))
    }
}

/// Eq 5.31: w = w_g |sin β|, the wheel's width projected across its direction of travel [m].
pub fn projected_width_m(ground_width_m: f64, slip_angle_rad: f64) -> f64 {
    ground_width_m * libm::fabs(libm::sin(slip_angle_rad))
}

/// Golden-section steps minimising Eq 5.35 over X_C: the bracket shrinks to 0.618⁴⁰ ≈ 4.3e-9 of
/// its width (< 4e-9 rad for GRC-1), far below what moves the force (flat at the minimum).
pub const FAILURE_ANGLE_ITERATIONS: u32 = 40;

/// Distance kept from the ends of the X_C search interval, where the force is infinite [rad].
const FAILURE_ANGLE_MARGIN_RAD: f64 = 1e-9;

/// The sand bulldozing force on one wheel and its geometry (Eq 5.29–5.36).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BulldozingForce {
    /// F^SB [N], ≥ 0.
    pub force_n: f64,
    /// The failure angle X_C minimising F^SB [rad]; `None` when nothing is pushed (w = 0 or
    /// d_avg = 0: no failure wedge, F^SB = 0).
    pub failure_angle_rad: Option<f64>,
    /// r_q: pile base (Eq 5.33), after the repose limit (Eq 5.36) [m].
    pub pile_base_m: f64,
    /// h_q = r_q tan φ_i: pile height [m].
    pub pile_height_m: f64,
    /// r_α = d_avg cot X_C (Eq 5.32) [m]; 0 when `failure_angle_rad` is `None`.
    pub failure_base_m: f64,
    /// Whether the pile has reached its maximum height (Eq 5.36) and stopped growing.
    pub pile_saturated: bool,
}

/// The simplified Skonieczny sand bulldozing model of Section 5.4 for one soil.
///
/// Geometry (Fig 5.15): the wheel, as a vertical plate of width w (Eq 5.31) cutting at depth
/// d_avg, pushes a triangular pile of base r_q and height h_q. Conserving the swept area,
/// r_q h_q / 2 = x_w d_avg, with the pile's face at φ_i (h_q = r_q tan φ_i), gives Eq 5.33,
/// r_q² = 2 x_w d_avg cot φ_i.
///
/// Force: Eq 5.29 for c = 0, rake angle α_1 = 90° and I_{X_C} = 0,
/// F^SB = w (ρ g / 2) (d_avg r_α + r_q² tan φ_i) / (−sin δ + cos δ cot(X_C + φ_i)),
/// which for δ = 0 and r_q² tan φ_i = 2 x_w d_avg is Eq 5.35. δ is kept (the denominator equals
/// cos(X_C + φ_i + δ) / sin(X_C + φ_i)).
///
/// Notes on the seed: the I_{X_C} term of Eq 5.29 carries a stray ρ g and 2 (dimensionally it
/// must be (r_q − d_avg cot X_C)² / (cot φ_i + cot X_C) inside the bracket); it is dropped as
/// the seed does. The seed justifies I_{X_C} = 0 by "r_q < r_α for cohesionless soil", which is
/// not true for every X_C (r_q grows without bound with x_w), but it does hold at the minimising
/// X_C when δ = 0: there 2x_w sin² X_C = d_avg sin φ_i cos(2X_C + φ_i), and
/// r_q < r_α ⇔ cos(2X_C + 2φ_i) < 1. [`BulldozingForce`] reports r_q and r_α so it can be checked.
///
/// Repose limit (Eq 5.36): h_q^MAX = w_g^MAX tan φ_r. Reading: the pile's slope can rise over at
/// most the wheel's length along the sand, w_g^MAX; sand added beyond that height slides off
/// at the repose angle. With h_q = r_q tan φ_i the pile stops growing at
/// r_q^MAX = h_q^MAX cot φ_i, that is at the travel x_w^MAX = (h_q^MAX)² cot φ_i / (2 d_avg)
/// ([`SandBulldozing::pile_limit_travel_m`]); past it the force stays at its value there (for
/// the same d_avg and w). For GRC-1 (φ_r = φ_i) r_q^MAX = w_g^MAX.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SandBulldozing {
    soil: Soil,
    tan_phi: f64,
    /// (sin φ_i, cos φ_i) and (sin(φ_i + δ), cos(φ_i + δ)): with them each evaluation of
    /// Eq 5.29 needs one sincos.
    sin_cos_phi: (f64, f64),
    sin_cos_phi_delta: (f64, f64),
    max_failure_angle_rad: f64,
}

impl SandBulldozing {
    /// The model for a soil. `Err` for an invalid soil or one with cohesion (Eq 5.29 is the
    /// c = 0 form; its cohesion term needs Skonieczny's h_f, which the seed does not give).
    pub fn new(soil: Soil) -> Result<Self, SoilError> {
        soil.validate()?;
        check(
            soil.cohesion_pa == 0.0,
            SoilError::InvalidParameter("cohesion_pa (Eq 5.29 is cohesionless)"),
        )?;
        Ok(Self {
            soil,
            tan_phi: libm::tan(soil.internal_friction_rad),
            sin_cos_phi: libm::sincos(soil.internal_friction_rad),
            sin_cos_phi_delta: libm::sincos(
                soil.internal_friction_rad + soil.external_friction_rad,
            ),
            max_failure_angle_rad: FRAC_PI_2
                - soil.internal_friction_rad
                - soil.external_friction_rad,
        })
    }

    /// The soil.
    pub fn soil(&self) -> &Soil {
        &self.soil
    }

    /// The X_C search interval [rad]: (0, π/2 − φ_i − δ), where Eq 5.29's denominator is
    /// positive. F^SB → ∞ at both ends (cot X_C → ∞ at 0, the denominator → 0 at the top), so
    /// for d_avg > 0 the minimum is interior. The search keeps 1e-9 rad from each end.
    pub fn failure_angle_interval_rad(&self) -> (f64, f64) {
        (0.0, self.max_failure_angle_rad)
    }

    /// Eq 5.36: h_q^MAX = w_g^MAX tan φ_r [m].
    pub fn max_pile_height_m(&self, max_ground_width_m: f64) -> f64 {
        max_ground_width_m * libm::tan(self.soil.repose_angle_rad)
    }

    /// Eq 5.33: r_q = √(2 x_w d_avg cot φ_i) [m], before the repose limit.
    pub fn pile_base_m(&self, average_sinkage_m: f64, travel_m: f64) -> f64 {
        libm::sqrt((2.0 * travel_m * average_sinkage_m / self.tan_phi).max(0.0))
    }

    /// Eq 5.33 and 5.36: the travel x_w at which the pile reaches h_q^MAX and stops growing,
    /// x_w^MAX = (h_q^MAX)² cot φ_i / (2 d_avg) [m] (infinite for d_avg ≤ 0: nothing is
    /// displaced, the pile never grows).
    pub fn pile_limit_travel_m(&self, max_ground_width_m: f64, average_sinkage_m: f64) -> f64 {
        if average_sinkage_m <= 0.0 {
            return f64::INFINITY;
        }
        let h = self.max_pile_height_m(max_ground_width_m);
        h * h / (self.tan_phi * 2.0 * average_sinkage_m)
    }

    /// Eq 5.29 (c = 0, α_1 = 90°, I_{X_C} = 0; Eq 5.34–5.35 when δ = 0) at a given failure
    /// angle X_C [rad]: F^SB for projected width w, average sinkage d_avg and pile base r_q [m].
    /// Unchecked: X_C must lie inside [`failure_angle_interval_rad`](Self::failure_angle_interval_rad).
    pub fn force_at_angle_n(
        &self,
        width_m: f64,
        average_sinkage_m: f64,
        pile_base_m: f64,
        failure_angle_rad: f64,
    ) -> f64 {
        width_m
            * self.soil.unit_weight_n_m3()
            * 0.5
            * self.shape_m2(
                average_sinkage_m,
                pile_base_m * pile_base_m * self.tan_phi,
                failure_angle_rad,
            )
    }

    /// (d_avg r_α + r_q² tan φ_i) / (−sin δ + cos δ cot(X_C + φ_i)), with
    /// `pile_area2_m2` = r_q² tan φ_i (= 2 × the pile's cross-section area). The denominator is
    /// evaluated as cos(X_C + φ_i + δ) / sin(X_C + φ_i), both by angle addition.
    fn shape_m2(&self, average_sinkage_m: f64, pile_area2_m2: f64, failure_angle_rad: f64) -> f64 {
        let (sin_x, cos_x) = libm::sincos(failure_angle_rad);
        let (sin_p, cos_p) = self.sin_cos_phi;
        let (sin_pd, cos_pd) = self.sin_cos_phi_delta;
        let numerator = average_sinkage_m * average_sinkage_m * cos_x / sin_x + pile_area2_m2;
        // sin(X + φ) and cos(X + φ + δ).
        numerator * (sin_x * cos_p + cos_x * sin_p) / (cos_x * cos_pd - sin_x * sin_pd)
    }

    /// The failure angle minimising Eq 5.35 for d_avg > 0 and pile term r_q² tan φ_i, by
    /// golden-section search over the interval ([`FAILURE_ANGLE_ITERATIONS`] steps, one
    /// evaluation each).
    fn minimising_angle_rad(&self, average_sinkage_m: f64, pile_area2_m2: f64) -> f64 {
        let f = |x: f64| self.shape_m2(average_sinkage_m, pile_area2_m2, x);
        let (angle, _) = crate::search::golden_section_min(
            f,
            FAILURE_ANGLE_MARGIN_RAD,
            self.max_failure_angle_rad - FAILURE_ANGLE_MARGIN_RAD,
            0.0,
            FAILURE_ANGLE_ITERATIONS as usize,
        );
        angle
    }

    /// Eq 5.29–5.36: the sand bulldozing force on a wheel of projected width w (Eq 5.31) at
    /// average sinkage d_avg, after a travel x_w along v_ACT, with the pile capped by the wheel's
    /// largest length along the sand w_g^MAX (Eq 5.36) [m]: r_q from Eq 5.33 (capped at
    /// r_q^MAX = w_g^MAX tan φ_r cot φ_i), then Eq 5.35 minimised over X_C (see
    /// [`failure_angle_interval_rad`](Self::failure_angle_interval_rad)).
    ///
    /// `Err` for non-finite or negative inputs.
    pub fn force(
        &self,
        width_m: f64,
        average_sinkage_m: f64,
        travel_m: f64,
        max_ground_width_m: f64,
    ) -> Result<BulldozingForce, SoilError> {
        let w = input(width_m, "width_m", |w| w >= 0.0)?;
        let d = input(average_sinkage_m, "average_sinkage_m", |d| d >= 0.0)?;
        let x = input(travel_m, "travel_m", |x| x >= 0.0)?;
        let wg_max = input(max_ground_width_m, "max_ground_width_m", |w| w >= 0.0)?;
        let free_base_m = self.pile_base_m(d, x);
        let max_base_m = self.max_pile_height_m(wg_max) / self.tan_phi;
        let pile_saturated = free_base_m >= max_base_m;
        let pile_base_m = free_base_m.min(max_base_m);
        let pile_height_m = pile_base_m * self.tan_phi;
        if w == 0.0 || d == 0.0 {
            return Ok(BulldozingForce {
                force_n: 0.0,
                failure_angle_rad: None,
                pile_base_m,
                pile_height_m,
                failure_base_m: 0.0,
                pile_saturated,
            });
        }
        let pile_area2_m2 = pile_base_m * pile_base_m * self.tan_phi;
        let x_c = self.minimising_angle_rad(d, pile_area2_m2);
        let force_n = finite_result(self.force_at_angle_n(w, d, pile_base_m, x_c))?;
        Ok(BulldozingForce {
            force_n,
            failure_angle_rad: Some(x_c),
            pile_base_m,
            pile_height_m,
            failure_base_m: d / libm::tan(x_c),
            pile_saturated,
        })
    }
}

/// Which w_g^MAX caps the pile (Eq 5.36).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PileLimit {
    /// The seed's choice: w_g at the steady-state sinkage, known in advance [m].
    SteadyStateGroundWidth(f64),
    /// Causal: the largest w_g seen so far in this manoeuvre.
    RunningMax,
}

/// One sample of [`SandBulldozer`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BulldozingSample {
    /// F^SB and its geometry.
    pub force: BulldozingForce,
    /// P^AS = F^SB v_ACT (Eq 5.37) [W].
    pub power_w: f64,
    /// x_w: travel along v_ACT since the start (or last reset) [m].
    pub travel_m: f64,
    /// w = w_g |sin β| (Eq 5.31) [m].
    pub projected_width_m: f64,
}

/// Eq 5.37: P^AS = F^SB v_ACT [W] (speed as a magnitude).
pub fn bulldozing_power_w(force_n: f64, v_act_mps: f64) -> f64 {
    force_n * libm::fabs(v_act_mps)
}

/// Eq 5.38 (and 5.39 with powers): four-wheel total 2 X_i + 2 X_o from one inner and one outer
/// wheel's force [N] or power [W].
pub fn four_wheel_total(inner: f64, outer: f64) -> f64 {
    2.0 * inner + 2.0 * outer
}

/// The sand bulldozing of one wheel through a manoeuvre, one sample at a time (Section 5.4,
/// Fig 5.17): integrates the travel x_w, tracks w_g^MAX and evaluates F^SB and P^AS.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SandBulldozer {
    model: SandBulldozing,
    limit: PileLimit,
    travel_m: f64,
    last_speed_mps: Option<f64>,
    max_ground_width_m: f64,
}

impl SandBulldozer {
    /// A wheel at the start of a manoeuvre (x_w = 0). `Err` for an invalid soil or a steady-state
    /// width that is negative or not finite.
    pub fn new(soil: Soil, limit: PileLimit) -> Result<Self, SoilError> {
        let model = SandBulldozing::new(soil)?;
        let max_ground_width_m = match limit {
            PileLimit::SteadyStateGroundWidth(w) => {
                param(w, "steady_state_ground_width_m", |w| w >= 0.0)?
            }
            PileLimit::RunningMax => 0.0,
        };
        Ok(Self {
            model,
            limit,
            travel_m: 0.0,
            last_speed_mps: None,
            max_ground_width_m,
        })
    }

    /// The force model.
    pub fn model(&self) -> &SandBulldozing {
        &self.model
    }

    /// x_w so far [m].
    pub fn travel_m(&self) -> f64 {
        self.travel_m
    }

    /// w_g^MAX in use [m].
    pub fn max_ground_width_m(&self) -> f64 {
        self.max_ground_width_m
    }

    /// Starts a new manoeuvre: no pile, x_w = 0.
    pub fn reset(&mut self) {
        if self.limit == PileLimit::RunningMax {
            self.max_ground_width_m = 0.0;
        }
        self.travel_m = 0.0;
        self.last_speed_mps = None;
    }

    /// One sample: the wheel's average sinkage d_avg and length along the sand w_g (Eq 5.25–5.26,
    /// e.g. from [`SlipSinkage2d`]), slip angle β, actual speed ‖v_ACT‖ [m/s] and the interval
    /// since the previous sample δt [s].
    ///
    /// x_w advances by the mean of the previous and current speed times δt (the seed: "the
    /// average of the actual velocity and the time interval"; the first sample uses its own
    /// speed). Then w = w_g |sin β| (Eq 5.31), F^SB from [`SandBulldozing::force`] and
    /// P^AS = F^SB ‖v_ACT‖ (Eq 5.37).
    ///
    /// `Err` for non-finite inputs, negative d_avg or w_g, or δt ≤ 0; the state is then
    /// unchanged.
    pub fn step(
        &mut self,
        average_sinkage_m: f64,
        ground_width_m: f64,
        slip_angle_rad: f64,
        v_act_mps: f64,
        dt_s: f64,
    ) -> Result<BulldozingSample, SoilError> {
        let d = input(average_sinkage_m, "average_sinkage_m", |d| d >= 0.0)?;
        let wg = input(ground_width_m, "ground_width_m", |w| w >= 0.0)?;
        let beta = input(slip_angle_rad, "slip_angle_rad", unbounded)?;
        let v = libm::fabs(input(v_act_mps, "v_act_mps", unbounded)?);
        let dt = input(dt_s, "dt_s", |t| t > 0.0)?;
        let previous = self.last_speed_mps.unwrap_or(v);
        let travel_m = finite_result(self.travel_m + 0.5 * (previous + v) * dt)?;
        let max_ground_width_m = match self.limit {
            PileLimit::SteadyStateGroundWidth(_) => self.max_ground_width_m,
            PileLimit::RunningMax => self.max_ground_width_m.max(wg),
        };
        let width_m = projected_width_m(wg, beta);
        let force = self.model.force(width_m, d, travel_m, max_ground_width_m)?;
        let power_w = finite_result(bulldozing_power_w(force.force_n, v))?;
        self.travel_m = travel_m;
        self.last_speed_mps = Some(v);
        self.max_ground_width_m = max_ground_width_m;
        Ok(BulldozingSample {
            force,
            power_w,
            travel_m,
            projected_width_m: width_m,
        })
    }
}
