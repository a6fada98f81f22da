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

pub mod family;

use super::adequacy;
use super::features::{SideRole, TurnRow};
use super::observe::{self, Residuals};
use model_core::fit::{FitError, LinearFit};
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
    /// The family member chosen on the calibration manoeuvres ([`family`]).
    pub structure: Structure,
    /// Copper-loss coefficient: the side draws c·F² on top of its motor power, F = P/V its
    /// traction force [W/N²]; 0 unless `structure.copper_loss`.
    pub copper_w_per_n2: f64,
    /// The terrain-wide constant angular slip of the calibration turns (thesis Fig. 6.7: a
    /// constant offset between actual and expected turn time on hard ground), the same at every
    /// calibration radius; 0 when not significant or not the same ([`family`]). Turns take
    /// 1/(1 − s₀) of their expected time, so the model's effective power of a turn is
    /// P/(1 − s₀); only a slip beyond it is an effect.
    pub turn_slip: f64,
    /// Leave-one-run-out RMS error of the chosen member on the calibration manoeuvres' average
    /// power [W]; `None` with fewer than 2 calibration runs (the plain member is used).
    pub cv_rmse_w: Option<f64>,
    /// Φ m g of the calibration's slopes [N]: fitted (as a nuisance) only when some calibration
    /// manoeuvre is off level ground ([`adequacy::is_level`]), so a calibration driven on undulating
    /// ground does not bend a and G; 0 otherwise. Not part of the model's prediction: a slope
    /// in the diagnosed runs is the `slope` effect (the paper's model is level).
    pub calibration_grade_n: f64,
    /// Covariance of (a, G) from the fit [N²]; zero when given, not fitted.
    #[serde(skip)]
    pub covariance: [[f64; 2]; 2],
    /// The copper-loss member the family tried because every copper-free member misfit the
    /// calibration, and refused because it misfits too; `None` when not tried or taken.
    pub copper_refused: Option<Refused>,
}

/// A member the baseline family tried and refused.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Refused {
    /// The member, fitted on all calibration manoeuvres.
    pub structure: Structure,
    /// Its leave-one-run-out RMS error on the calibration manoeuvres [W].
    pub cv_rmse_w: Option<f64>,
    /// Its lack of fit on them, per side when tested so, else total [W RMS].
    pub lack_of_fit_rms_w: f64,
}

/// How the skid power is split per side (the baseline family's split members).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum Split {
    /// The tread couple ±a: the inner side regenerates for R > R' (the plain model).
    Regenerating,
    /// The tread couple with each side's negative (generated) power scaled by the fraction the
    /// driver returns to the bus: 0 is the thesis' Section 1.1.3 clamp ("any negative power
    /// … put to 0", drivers that cannot regenerate); between 0 and 1 a regenerating driver
    /// with its efficiency on both conversions (P_m·η returned where P_m/η is drawn).
    Returning {
        /// Fraction of the generated power returned (0 = clamped).
        fraction: f64,
    },
}

/// A member of the baseline family: the split and whether copper loss ∝ I² is modelled.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Structure {
    /// Per-side split of the skid power.
    pub split: Split,
    /// Whether each side adds c·(P/V)² (copper loss ∝ torque², Eq 1.18–1.19).
    pub copper_loss: bool,
}

impl Structure {
    /// The paper's model as the diagnosis always had it.
    pub const PLAIN: Structure = Structure {
        split: Split::Regenerating,
        copper_loss: false,
    };

    /// Fitted parameters (a, G, the returned fraction, c): the parsimony order of the family.
    pub fn parameters(&self) -> usize {
        let grid = match self.split {
            Split::Regenerating => 0,
            Split::Returning { fraction } => usize::from(fraction > 0.0),
        };
        2 + grid + usize::from(self.copper_loss)
    }

    /// Short label (`regenerating`, `clamped+copper`, …).
    pub fn label(&self) -> String {
        let split = match self.split {
            Split::Regenerating => "regenerating",
            Split::Returning { fraction } if fraction <= 0.0 => "clamped",
            Split::Returning { .. } => "returning",
        };
        if self.copper_loss {
            format!("{split}+copper")
        } else {
            split.to_string()
        }
    }
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

/// The slope feature of a side: sin θ · V_side / 2. Each track carries half the weight, whose
/// component along the track, (m g / 2) sin θ, it pushes at its own speed (signed: a side
/// running backwards in a turn descends where the other climbs); the sides sum to Eq 1.16's
/// Φ m g v_y sin θ [m/s]; 0 without pitch.
pub fn grade_feature_mps(row: &TurnRow, side: usize) -> f64 {
    match row.pitch_deg {
        Some(pitch) => 0.5 * pitch.to_radians().sin() * row.sides[side].cmd_mps,
        None => 0.0,
    }
}

/// Whether `calibration` has a manoeuvre off level ground: its baseline then fits the slope as
/// a nuisance ([`Baseline::calibration_grade_n`]).
fn is_graded(calibration: &[&TurnRow]) -> bool {
    calibration.iter().any(|r| !adequacy::is_level(r))
}

/// F², the copper-loss regressor of a side of `b`: the square of its traction force P/V, ∝
/// torque² ∝ motor current² (Eq 1.18–1.19: I²R depends on the torque, not on the speed) [N²].
/// A side commanded (nearly) still in a turn (the inner side at R′) holds the skid couple's
/// tread force at stall: its tread still slides lengthwise, by ω(B_s − B)/2, so the motor
/// carries the force with no power, the seed's braked wheel (Section 6.2); a still wheel
/// meets no rolling resistance. A side the clamp puts to 0 has no copper loss either: its
/// power is negative only "if the applied torque is 0 and the wheel rotates due to the torque
/// applied by the other side motor" (Section 1.1.3).
pub(crate) fn copper_regressor(b: &Baseline, row: &TurnRow, side: usize) -> f64 {
    let v = row.sides[side].cmd_mps.abs();
    if v > MIN_FORCE_SPEED_MPS {
        let shaft_w = b.shaft_power_w(plain_regressors(row, side));
        let clamped = matches!(b.structure.split, Split::Returning { fraction } if fraction == 0.0);
        if clamped && shaft_w < 0.0 {
            0.0
        } else {
            (shaft_w / v).powi(2)
        }
    } else if held_at_stall(row, side) {
        b.skid_force_n.powi(2)
    } else {
        0.0
    }
}

/// Below this side speed the traction force P/V is not defined by the power [m/s].
const MIN_FORCE_SPEED_MPS: f64 = 0.02;

/// Whether a side of `row` is held at stall: commanded (nearly) still in a turn (the inner
/// side at R′). Its motor holds a force without turning, so it draws copper loss only.
pub fn held_at_stall(row: &TurnRow, side: usize) -> bool {
    !row.is_straight()
        && row.yaw_rate_cmd_rad_s != 0.0
        && row.sides[side].cmd_mps.abs() <= MIN_FORCE_SPEED_MPS
}

/// Largest standstill current per side taken as the drivers' quiescent draw [A]: the thesis'
/// Fig. 3.3 shows ≈ 0 A at rest on the INA226 board and 0.59 A on the built-in sensing, the
/// latter being the `current-offset` effect, which must stay in the residuals.
pub const QUIESCENT_MAX_A: f64 = 0.25;

/// The side's standstill draw as a fixed, measured (not fitted) offset of the baseline [W]: real
/// power the drivers draw in every manoeuvre; 0 when the run's standstill current exceeds
/// [`QUIESCENT_MAX_A`] (an offset that large is an effect) or is unknown.
pub fn quiescent_draw_w(row: &TurnRow, side: usize) -> f64 {
    let w = row.standstill_w[side];
    let current_a = if row.bus_v > 1.0 {
        w / row.bus_v
    } else {
        f64::INFINITY
    };
    if w.is_finite() && current_a.abs() <= QUIESCENT_MAX_A {
        w
    } else {
        0.0
    }
}

/// A side's regressors of a and G before the split: the skid feature and |V|.
fn plain_regressors(row: &TurnRow, side: usize) -> [f64; 2] {
    [skid_feature_mps(row, side), row.sides[side].cmd_mps.abs()]
}

/// A side's regressors [a, G, c, Φ m g] given the previous iteration's fit (`None`: the first
/// pass).
fn current_regressors(prev: Option<&Baseline>, row: &TurnRow, side: usize) -> [f64; 4] {
    let x = plain_regressors(row, side);
    let grade = grade_feature_mps(row, side);
    let Some(prev) = prev else {
        return [x[0], x[1], 0.0, grade];
    };
    let scale = prev.split_scale(x);
    [
        x[0] * scale,
        x[1] * scale,
        copper_regressor(prev, row, side),
        grade,
    ]
}

/// (estimate, 95 % half-width) of [a, G, c, Φ m g] (0 for a column not fitted), the residual
/// standard error, n and the covariance of a and G.
type Solved = ([(f64, f64); 4], f64, usize, [[f64; 2]; 2]);

/// Least squares of the calibration observations' average power (less the measured standstill
/// draw) on a, G and the columns `used` ([copper, grade]) of `x_of`'s regressors.
fn solve(
    calibration: &[&TurnRow],
    used: [bool; 2],
    x_of: impl Fn(&TurnRow, usize) -> [f64; 4],
) -> Result<Solved, FitError> {
    // The columns fitted: a and G always, then copper and grade when `used` (no allocation:
    // the family's cross-validation fits this many times per dataset).
    let mut columns = [0usize; 4];
    let mut k = 0;
    for j in 0..4 {
        if j < 2 || used[j - 2] {
            columns[k] = j;
            k += 1;
        }
    }
    let columns = &columns[..k];
    let mut fit = LinearFit::<4>::with_columns(k)?;
    for row in calibration {
        for sides in observe::observations(row) {
            let all = observe::sum_sides(sides, |side| x_of(row, side));
            let mut x = [0.0; 4];
            for (slot, &j) in x.iter_mut().zip(columns) {
                *slot = all[j];
            }
            let draw: f64 = sides.iter().map(|&side| quiescent_draw_w(row, side)).sum();
            fit.add_row(&x[..k], observe::measured_avg_w(row, sides) - draw)?;
        }
    }
    // The seed's 95 % intervals, with the quantiles the diagnosis keeps (it fits thousands of
    // baselines per dataset; each inversion is iterative).
    let solved = fit.solve_with_t(model_core::fit::SEED_CONFIDENCE, |dof| {
        Ok(super::stats::t_quantile_975(dof))
    })?;
    let mut estimates = [(0.0, 0.0); 4];
    for (k, &j) in columns.iter().enumerate() {
        let e = solved.estimates[k];
        estimates[j] = (e.value, e.half_width());
    }
    let c = &solved.covariance;
    Ok((
        estimates,
        solved.residual_standard_error,
        solved.n,
        [[c[0][0], c[0][1]], [c[1][0], c[1][1]]],
    ))
}

impl Baseline {
    /// Fits a and G of the plain member on the `calibration` rows' average power per side (a
    /// total-only row is one observation: its total on the sum of both sides' features).
    pub fn fit_plain(rover: &Rover, calibration: &[&TurnRow]) -> Result<Baseline, BaselineError> {
        Baseline::fit_member(rover, calibration, Structure::PLAIN)
    }

    /// Fits one member of the family. The clamp and copper loss are not linear in the
    /// parameters: the fit iterates, with the sides the previous fit predicts negative
    /// contributing nothing (clamp) and the previous fit's (P/V)² as the copper regressor.
    pub fn fit_member(
        rover: &Rover,
        calibration: &[&TurnRow],
        structure: Structure,
    ) -> Result<Baseline, BaselineError> {
        let err = |reason: String| BaselineError::Fit {
            reason,
            rows: calibration.len(),
        };
        let graded = is_graded(calibration);
        let mut current = Baseline::with_parameters(rover, structure, [0.0; 3]);
        // The copper regressor comes from the previous fit: a fixed point that needs more
        // passes than the clamp to settle below the repeat noise (4 left ~0.3 W of lack of fit).
        let iterations = match structure {
            Structure::PLAIN => 1,
            Structure {
                copper_loss: true, ..
            } => 12,
            _ => 4,
        };
        let mut solved = None;
        for i in 0..iterations {
            // The first pass fits the unclamped, copper-free regressors.
            let prev = (i > 0).then_some(&current);
            let x_of = |row: &TurnRow, side: usize| current_regressors(prev, row, side);
            // The first pass has no copper regressor yet (it comes from the previous fit).
            let copper = structure.copper_loss && i > 0;
            // Too few pitched manoeuvres to separate the grade from a and G: fit them alone.
            let result = solve(calibration, [copper, graded], x_of)
                .or_else(|e| match e {
                    FitError::Singular | FitError::TooFewSamples if graded => {
                        solve(calibration, [copper, false], x_of)
                    }
                    e => Err(e),
                })
                .map_err(|e| err(e.to_string()))?;
            let [(a, _), (g, _), (c, _), _] = result.0;
            current = Baseline::with_parameters(rover, structure, [a, g, c]);
            solved = Some(result);
        }
        let Some(([(a, a_hw), (g, g_hw), (c, _), (grade, _)], rse, n, covariance)) = solved else {
            return Err(err("no iteration".into()));
        };
        if structure.copper_loss && c < 0.0 {
            return Err(err(format!("copper-loss coefficient {c:.2e} W/N² < 0")));
        }
        let mut b = Baseline::with_parameters(rover, structure, [a, g, c]);
        b.skid_force_ci_n = a_hw;
        b.rolling_resistance_ci_n = g_hw;
        b.residual_std_w = rse;
        b.n = n;
        b.covariance = covariance;
        b.calibration_grade_n = grade;
        Ok(b)
    }

    /// A baseline of `structure` with a, G and c given (no uncertainty).
    fn with_parameters(rover: &Rover, structure: Structure, [a, g, c]: [f64; 3]) -> Baseline {
        let slip_track_m = f64::from(rover.slip_track_m);
        let p = f64::from(rover.mass_kg) * GRAVITY_M_S2 / 4.0;
        let lateral = f64::from(rover.track_width_m) - slip_track_m;
        let lever = (f64::from(rover.length_m).powi(2) + lateral * lateral).sqrt();
        Baseline {
            skid_force_n: a,
            skid_force_ci_n: 0.0,
            rolling_resistance_n: g,
            rolling_resistance_ci_n: 0.0,
            slip_track_m,
            mu: a * slip_track_m / (2.0 * p * lever),
            residual_std_w: f64::NAN,
            n: 0,
            structure,
            copper_w_per_n2: c,
            turn_slip: 0.0,
            cv_rmse_w: None,
            calibration_grade_n: 0.0,
            covariance: [[0.0; 2]; 2],
            copper_refused: None,
        }
    }

    /// The factor the split applies to a side whose plain regressors are `x`: a side predicted
    /// to generate returns only its fraction (clamped: nothing), any other side 1.
    fn split_scale(&self, x: [f64; 2]) -> f64 {
        let raw = self.skid_force_n * x[0] + self.rolling_resistance_n * x[1];
        match self.structure.split {
            Split::Returning { fraction } if raw < 0.0 => fraction,
            _ => 1.0,
        }
    }

    /// The wheels' power of a side with plain regressors `x`, before the split [W]: its force
    /// times its speed, negative when the side is driven by the ground.
    fn shaft_power_w(&self, x: [f64; 2]) -> f64 {
        self.skid_force_n * x[0] + self.rolling_resistance_n * x[1]
    }

    /// The motor power of one side (the split applied, before copper loss) [W].
    fn motor_power_w(&self, row: &TurnRow, side: usize) -> f64 {
        let x = plain_regressors(row, side);
        self.shaft_power_w(x) * self.split_scale(x)
    }

    /// Expected over actual duration of `row`: a turn takes 1/(1 − s₀) of its expected time
    /// with the calibration's constant slip, so its effective power is P/(1 − s₀).
    fn turn_time_factor(&self, row: &TurnRow) -> f64 {
        if row.is_straight() || !row.turned_from_yaw || self.turn_slip == 0.0 {
            1.0
        } else {
            1.0 / (1.0 - self.turn_slip)
        }
    }

    /// The model's power of one side of `row` [W]: motor power, copper loss and the side's
    /// measured standstill draw ([`quiescent_draw_w`]).
    pub fn side_power_w(&self, row: &TurnRow, side: usize) -> f64 {
        // Copper loss follows the torque, which a generating side has too, whatever the
        // driver does with the generated power.
        self.motor_power_w(row, side)
            + self.copper_w_per_n2 * copper_regressor(self, row, side)
            + quiescent_draw_w(row, side)
    }

    /// The side's power as fitted to the calibration: the model's plus the calibration's slope
    /// nuisance ([`Baseline::calibration_grade_n`]) [W]. What the family's cross-validation and
    /// lack-of-fit tests judge the fit by.
    pub fn calibration_side_power_w(&self, row: &TurnRow, side: usize) -> f64 {
        self.side_power_w(row, side) + self.calibration_grade_n * grade_feature_mps(row, side)
    }

    /// Both sides' model power [W].
    pub fn power_w(&self, row: &TurnRow) -> f64 {
        self.side_power_w(row, 0) + self.side_power_w(row, 1)
    }

    /// The model's effective power E/T_expected of one side: its power over the turn's time
    /// with the calibration's constant slip [W].
    pub fn effective_side_power_w(&self, row: &TurnRow, side: usize) -> f64 {
        self.side_power_w(row, side) * self.turn_time_factor(row)
    }

    /// Standard error of [`effective_side_power_w`](Self::effective_side_power_w) from the
    /// uncertainty of a and G (the copper coefficient's is left out) [W]: every diagnosed row
    /// shares it, so a gap must exceed it as well as the rows' own spread.
    pub fn effective_side_power_se_w(&self, row: &TurnRow, side: usize) -> f64 {
        let x = plain_regressors(row, side);
        let scale = self.split_scale(x) * self.turn_time_factor(row);
        let c = &self.covariance;
        let v = x[0] * x[0] * c[0][0] + 2.0 * x[0] * x[1] * c[0][1] + x[1] * x[1] * c[1][1];
        scale.abs() * v.max(0.0).sqrt()
    }

    /// The same for both sides together (their errors move together: the same a and G) [W].
    pub fn effective_power_se_w(&self, row: &TurnRow) -> f64 {
        self.effective_side_power_se_w(row, 0) + self.effective_side_power_se_w(row, 1)
    }

    /// Measured effective minus model effective power, per side (inner/outer order of the
    /// row) [W]; NaN for a total-only row (see [`Baseline::observed_residuals_w`]).
    pub fn residual_w(&self, row: &TurnRow) -> [f64; 2] {
        [0, 1].map(|s| row.sides[s].effective_power_w - self.effective_side_power_w(row, s))
    }

    /// Measured effective minus model power of each observation of `row`: per side, or the
    /// total of a total-only row (average power: no duration) [W].
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
