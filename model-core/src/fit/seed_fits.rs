//! The seed's two linear power fits: pitch and roll (Section 4.1, Eq 4.1, Tables 4.1–4.2) and
//! turning radius and pitch (Section 4.2, Table 4.3).

use super::linear::{Estimate, LinearFit};
use super::FitError;
use crate::kinematics::{self, SideSpeeds};

/// Eq 4.1: P(θ, φ) = ξθ + ηφ + ζ, the power of a manoeuvre against the rover's pitch θ and roll φ
/// (Section 4.1; Table 4.1 gives ξ, η, ζ per turning radius, Table 4.2 their 95 % bounds and r²).
///
/// Units follow the seed: angles in degrees (ξ ≈ 22.5–27 W/deg for R ≥ 1 m), power in W. The seed
/// fits "pitch and absolute roll value", so the regressor φ is |roll|: [`add`](Self::add) takes
/// the signed IMU roll and uses its magnitude.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PitchRollFit {
    pub(super) fit: LinearFit<3>,
}

impl PitchRollFit {
    /// An empty Eq 4.1 fit.
    pub const fn new() -> Self {
        Self {
            fit: LinearFit::new(),
        }
    }

    /// Adds one power sample [W] at pitch θ and roll φ [deg] (regressors θ, |φ|, 1).
    pub fn add(&mut self, pitch_deg: f64, roll_deg: f64, power_w: f64) -> Result<(), FitError> {
        self.fit
            .add([pitch_deg, libm::fabs(roll_deg), 1.0], power_w)
    }

    /// A fit of equally long series of pitch [deg], roll [deg] and power [W].
    pub fn from_samples(
        pitch_deg: &[f64],
        roll_deg: &[f64],
        power_w: &[f64],
    ) -> Result<Self, FitError> {
        if pitch_deg.len() != roll_deg.len() || pitch_deg.len() != power_w.len() {
            return Err(FitError::LengthMismatch);
        }
        let mut fit = Self::new();
        for ((&theta, &phi), &p) in pitch_deg.iter().zip(roll_deg).zip(power_w) {
            fit.add(theta, phi, p)?;
        }
        Ok(fit)
    }

    /// Number of samples added.
    pub fn len(&self) -> usize {
        self.fit.len()
    }

    /// True before the first sample.
    pub fn is_empty(&self) -> bool {
        self.fit.is_empty()
    }

    /// ξ, η, ζ with 95 % bounds and r² (Tables 4.1, 4.2).
    pub fn solve(&self) -> Result<PitchRollModel, FitError> {
        let r = self.fit.solve()?;
        let [xi, eta, zeta] = r.estimates;
        Ok(PitchRollModel {
            xi_w_per_deg: xi,
            eta_w_per_deg: eta,
            zeta_w: zeta,
            r_squared: r.r_squared,
            residual_standard_error_w: r.residual_standard_error,
            n: r.n,
        })
    }
}

/// The fitted Eq 4.1 (one row of Tables 4.1 and 4.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PitchRollModel {
    /// ξ: sensitivity to pitch [W/deg].
    pub xi_w_per_deg: Estimate,
    /// η: sensitivity to |roll| [W/deg].
    pub eta_w_per_deg: Estimate,
    /// ζ: power on level ground [W].
    pub zeta_w: Estimate,
    /// r² (Tables 4.2, 4.3); `None` when all powers are equal.
    pub r_squared: Option<f64>,
    /// Residual standard error of the power [W].
    pub residual_standard_error_w: f64,
    /// Number of samples fitted.
    pub n: usize,
}

impl PitchRollModel {
    /// Eq 4.1 evaluated: P = ξθ + η|φ| + ζ [W].
    pub fn power_w(&self, pitch_deg: f64, roll_deg: f64) -> f64 {
        self.xi_w_per_deg.value * pitch_deg
            + self.eta_w_per_deg.value * libm::fabs(roll_deg)
            + self.zeta_w.value
    }
}

/// The seed's stand-in radius for a point turn in the Table 4.3 fit (Section 4.2: "a 0 m turning
/// radius … was set to 0.001 m"), which caps 1/R at 1000 m⁻¹. Note that with Table 4.3's
/// c₁ = 5.55 W·m this makes the fitted model predict c₁/0.001 ≈ 5.5 kW at a point turn: the model
/// is not meant to be evaluated there, and point-turn samples carry great leverage on c₁.
pub const POINT_TURN_RADIUS_M: f64 = 0.001;

/// Turning radii above this are left out of the Table 4.3 fit (Section 4.2: "turning radii larger
/// than 20 m were neglected"); straight driving (R = ∞) with them.
pub const MAX_FIT_RADIUS_M: f64 = 20.0;

/// Whether a sample went into a fit or was left out by the seed's conventions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleUse {
    /// The sample went into the fit.
    Used,
    /// R > [`MAX_FIT_RADIUS_M`] (or no motion, hence no radius).
    Dropped,
}

/// Table 4.3: P = c₁/R + c₂ + c₃θ, the R ≥ R' case of Eq 2.12 on slopes (Section 4.2), fitted
/// linearly in the regressors 1/R, 1 and θ. The seed's White Sands fit: c₁ = 5.55 W·m
/// [5.269, 5.831], c₂ = 139.4 W [138.1, 140.7], c₃ = 6.608 W/deg [6.418, 6.799], r² = 0.685.
///
/// Conventions of the seed (Section 4.2): R is the instantaneous radius of Eq 2.4 (with the
/// controller's B_s = 1.1 m, see [`add_side_speeds`](Self::add_side_speeds)); radii above
/// [`MAX_FIT_RADIUS_M`] are dropped; a point turn's R = 0 becomes [`POINT_TURN_RADIUS_M`]. Any
/// radius below 0.001 m is raised to 0.001 m (our choice: the seed names only R = 0, and a smaller
/// radius can only come from noise around a point turn). Pitch θ in degrees, power in W.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TurnPitchFit {
    pub(super) fit: LinearFit<3>,
}

impl TurnPitchFit {
    /// An empty Table 4.3 fit.
    pub const fn new() -> Self {
        Self {
            fit: LinearFit::new(),
        }
    }

    /// Adds one power sample [W] at turning radius R ≥ 0 [m] (`INFINITY` for straight) and pitch
    /// θ [deg]. Negative R is [`FitError::InvalidParameter`] (radii are magnitudes); NaN anywhere is
    /// [`FitError::NonFinite`].
    pub fn add(
        &mut self,
        radius_m: f64,
        pitch_deg: f64,
        power_w: f64,
    ) -> Result<SampleUse, FitError> {
        if radius_m.is_nan() || !pitch_deg.is_finite() || !power_w.is_finite() {
            return Err(FitError::NonFinite);
        }
        if radius_m < 0.0 {
            return Err(FitError::InvalidParameter);
        }
        if radius_m > MAX_FIT_RADIUS_M {
            return Ok(SampleUse::Dropped);
        }
        let r = radius_m.max(POINT_TURN_RADIUS_M);
        self.fit.add([1.0 / r, 1.0, pitch_deg], power_w)?;
        Ok(SampleUse::Used)
    }

    /// Adds a sample whose radius comes from the side speeds by Eq 2.4 with slip track
    /// `slip_track_m` (the seed used the controller's 1.1 m). Standstill has no radius and is
    /// dropped.
    pub fn add_side_speeds(
        &mut self,
        speeds: SideSpeeds,
        slip_track_m: f32,
        pitch_deg: f64,
        power_w: f64,
    ) -> Result<SampleUse, FitError> {
        match kinematics::turning_radius_m(speeds, slip_track_m) {
            Some(r) => self.add(f64::from(r), pitch_deg, power_w),
            None if pitch_deg.is_finite() && power_w.is_finite() => Ok(SampleUse::Dropped),
            None => Err(FitError::NonFinite),
        }
    }

    /// Number of samples used (dropped ones not counted).
    pub fn len(&self) -> usize {
        self.fit.len()
    }

    /// True before the first used sample.
    pub fn is_empty(&self) -> bool {
        self.fit.is_empty()
    }

    /// c₁, c₂, c₃ with 95 % bounds and r² (Table 4.3).
    pub fn solve(&self) -> Result<TurnPitchModel, FitError> {
        let r = self.fit.solve()?;
        let [c1, c2, c3] = r.estimates;
        Ok(TurnPitchModel {
            c1_w_m: c1,
            c2_w: c2,
            c3_w_per_deg: c3,
            r_squared: r.r_squared,
            residual_standard_error_w: r.residual_standard_error,
            n: r.n,
        })
    }
}

/// The fitted Table 4.3 model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurnPitchModel {
    /// c₁ [W·m].
    pub c1_w_m: Estimate,
    /// c₂ [W].
    pub c2_w: Estimate,
    /// c₃ [W/deg].
    pub c3_w_per_deg: Estimate,
    /// r² (Tables 4.2, 4.3); `None` when all powers are equal.
    pub r_squared: Option<f64>,
    /// Residual standard error of the power [W].
    pub residual_standard_error_w: f64,
    /// Number of samples fitted.
    pub n: usize,
}

impl TurnPitchModel {
    /// P = c₁/R + c₂ + c₃θ [W], with the fit's convention R < 0.001 m → 0.001 m. Meant for
    /// 0 ≤ R ≤ 20 m, the range the model was fitted on.
    pub fn power_w(&self, radius_m: f64, pitch_deg: f64) -> f64 {
        self.c1_w_m.value / radius_m.max(POINT_TURN_RADIUS_M)
            + self.c2_w.value
            + self.c3_w_per_deg.value * pitch_deg
    }
}
