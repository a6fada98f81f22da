//! The "sim" of the diagnosis: the hard-ground ICR model (paper Eq 20–22) fitted on the
//! calibration manoeuvres, with its per-side split, and its residuals per turn and side.
//!
//! Eq 21, P = F|ω_z| + G(|V_r| + |V_l|) with ω_z = (V_r − V_l)/B_s, is linear in
//! a = F/B_s [N] and G [N]: P = a|V_r − V_l| + G(|V_r| + |V_l|). Per side the skid term is
//! carried by equal and opposite tread forces ±a (their couple over B_s is the skid moment F;
//! the same split as the simulator's world), so
//! P_outer = a V_o + G|V_o| and P_inner = −a V_i + G|V_i| (V signed, forward positive; the inner
//! side regenerates for R > R'), and on a straight P_side = G|V| (Lemma 1).
//!
//! The fit is ordinary least squares of both sides' **average** power (a power model on the
//! commanded speeds, as the paper fitted μ and G) over the calibration rows; the diagnosis then
//! compares its prediction with the **effective** power E/T_expected (see [`features`]), so a
//! rover that turns slower than commanded shows a gap even on calibration manoeuvres.
//!
//! [`features`]: super::features

use super::features::{SideRole, TurnRow};
use super::observe::{self, Residuals};
use model_core::fit::LinearFit;
use model_core::power::{IcrHardGround, GRAVITY_M_S2};
use model_core::Rover;
use serde::Serialize;

/// Why the baseline could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BaselineError {
    /// Fewer than 3 calibration side observations, or no straight/turn mix to separate a and G.
    #[error("hard-ground baseline: {reason} ({rows} calibration manoeuvres)")]
    Fit {
        /// The fit's complaint.
        reason: String,
        /// Calibration manoeuvres available.
        rows: usize,
    },
}

/// The fitted hard-ground model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Baseline {
    /// a = F/B_s: the tread force of the skid couple [N].
    pub skid_force_n: f64,
    /// 95 % half-width of `skid_force_n` [N].
    pub skid_force_ci_n: f64,
    /// G [N].
    pub rolling_resistance_n: f64,
    /// 95 % half-width of G [N].
    pub rolling_resistance_ci_n: f64,
    /// B_s the model is expressed with (the rover's) [m].
    pub slip_track_m: f64,
    /// μ implied by a with this B_s (Eq 22: F = 2μp√(L² + (W − B_s)²)).
    pub mu: f64,
    /// Residual standard error of the fit, per side [W].
    pub residual_std_w: f64,
    /// Side observations in the fit.
    pub n: usize,
}

/// The skid feature of a side: −V_i for the inner, V_o for the outer side, 0 on a straight [m/s].
pub fn skid_feature_mps(row: &TurnRow, side: usize) -> f64 {
    if row.is_straight() {
        return 0.0;
    }
    let s = &row.sides[side];
    match s.role {
        SideRole::Inner => -s.cmd_mps,
        SideRole::Outer => s.cmd_mps,
    }
}

impl Baseline {
    /// Fits a and G on the `calibration` rows' average power per side (a total-only row is one
    /// observation: its total on the sum of both sides' features).
    pub fn fit(rover: &Rover, calibration: &[&TurnRow]) -> Result<Baseline, BaselineError> {
        let mut fit = LinearFit::<2>::new();
        let err = |reason: String| BaselineError::Fit {
            reason,
            rows: calibration.len(),
        };
        for row in calibration {
            for sides in observe::observations(row) {
                let x = observe::sum_sides(sides, |side| {
                    [skid_feature_mps(row, side), row.sides[side].cmd_mps.abs()]
                });
                fit.add(x, observe::measured_avg_w(row, sides))
                    .map_err(|e| err(e.to_string()))?;
            }
        }
        let solved = fit.solve().map_err(|e| err(e.to_string()))?;
        let [a, g] = solved.estimates;
        let slip_track_m = f64::from(rover.slip_track_m);
        let p = f64::from(rover.mass_kg) * GRAVITY_M_S2 / 4.0;
        let lateral = f64::from(rover.track_width_m) - slip_track_m;
        let lever = (f64::from(rover.length_m).powi(2) + lateral * lateral).sqrt();
        Ok(Baseline {
            skid_force_n: a.value,
            skid_force_ci_n: a.half_width(),
            rolling_resistance_n: g.value,
            rolling_resistance_ci_n: g.half_width(),
            slip_track_m,
            mu: a.value * slip_track_m / (2.0 * p * lever),
            residual_std_w: solved.residual_standard_error,
            n: solved.n,
        })
    }

    /// The model's power of one side of `row` [W].
    pub fn side_power_w(&self, row: &TurnRow, side: usize) -> f64 {
        self.skid_force_n * skid_feature_mps(row, side)
            + self.rolling_resistance_n * row.sides[side].cmd_mps.abs()
    }

    /// Both sides' model power [W].
    pub fn power_w(&self, row: &TurnRow) -> f64 {
        self.side_power_w(row, 0) + self.side_power_w(row, 1)
    }

    /// Measured effective minus model power, per side (inner/outer order of the row) [W]; NaN
    /// for a total-only row (see [`Baseline::observed_residuals_w`]).
    pub fn residual_w(&self, row: &TurnRow) -> [f64; 2] {
        [0, 1].map(|s| row.sides[s].effective_power_w - self.side_power_w(row, s))
    }

    /// Measured effective minus model power of each observation of `row`: per side, or the
    /// total of a total-only row [W].
    pub fn observed_residuals_w(&self, row: &TurnRow) -> Residuals {
        if row.is_total_only() {
            Residuals::total(row.effective_power_w() - self.power_w(row))
        } else {
            Residuals::sides(self.residual_w(row))
        }
    }

    /// As the paper's model (for the model file of `plan --model`), with the rover's geometry.
    pub fn as_icr(&self, rover: &Rover) -> IcrHardGround {
        IcrHardGround {
            mu: self.mu,
            rolling_resistance_n: self.rolling_resistance_n,
            length_m: f64::from(rover.length_m),
            width_m: f64::from(rover.track_width_m),
            mass_kg: f64::from(rover.mass_kg),
            slip_track_m: self.slip_track_m,
        }
    }
}
