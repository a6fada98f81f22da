//! The model file `diagnose --out` writes for `plan --model`: the fitted hard-ground base
//! (μ via Eq 22, G, B_s of the [`Baseline`]) plus the named effect as a [`plan::EffectTerm`],
//! tabulated over R/R′ at the runs' v_c.
//!
//! The table is the effect fitted on every diagnosed row (and the calibration manoeuvres of
//! calibration runs), evaluated on synthetic manoeuvres: at each R/R′ of the grid a left turn
//! at the runs' median v_c with the constant-v_c side speeds of Appendix A (Eq A.14,
//! [`side_speeds_for`]), the yaw rate of Eq 2.9, the runs' median turned angle, bus voltage and
//! start time, and zero pitch (the planner plans on level ground). The value is the extra power
//! of both sides together.
//!
//! Units agree with the planner: the diagnosis measures **effective** power, energy over the
//! commanded duration of the heading change (E/T_expected, see [`features`](super::features)),
//! and `plan` prices an arc as (Eq 21 power + ΔP(R/R′)) × |Δθ| max(R, R′)/v_c, the commanded
//! duration (paper Eq 26 is Eq 21 power times that duration). So a time-type effect (angular
//! slip, slip track: the rover turns slower than commanded, average power unchanged) enters as
//! the extra energy it costs per commanded second, and the planned arc energy is the energy the
//! rover will actually spend on it.
//!
//! The last breakpoint is a straight line placed at R = [`RegimeBounds::straight_from_m`] (where
//! `validate` calls a manoeuvre straight); `plan` holds it for lines (R = ∞) and interpolates
//! between the widest tabulated turn and it.

use super::baseline::Baseline;
use super::calibration::Calibration;
use super::diagnosis::Diagnosis;
use super::effects::fit_model;
use super::effects::{FittedEffect, FittedModel};
use super::error::DiagnoseError;
use super::features::{Observed, SideObs, SideRole, TurnRow, CALIBRATION_MIN_R_OVER_R_PRIME};
use super::stats;
use crate::plan::{self, EffectTerm, EnergyModel, HardGroundBase, ModelError};
use crate::rover::decimal_f64;
use model_core::kinematics::{side_speeds_for, yaw_rate_for, Regime, RegimeBounds, TurnDirection};
use model_core::Rover;

/// Uniform grid step of R/R′ up to [`GRID_UNIFORM_MAX`].
pub const GRID_STEP: f64 = 0.05;
/// End of the uniform part of the grid (R/R′).
pub const GRID_UNIFORM_MAX: f64 = 4.0;
/// Wider turns tabulated beyond the uniform grid (R/R′).
pub const GRID_WIDE: [f64; 6] = [5.0, 6.0, 8.0, 10.0, 12.0, 16.0];
/// Turned angle of the synthetic turns when no run has a turn with a yaw-based angle [rad].
pub const DEFAULT_TURN_RAD: f64 = std::f64::consts::FRAC_PI_2;

/// Why no model file could be made.
#[derive(Debug, thiserror::Error)]
pub enum ModelFileError {
    /// No manoeuvre with a positive v_c.
    #[error("no manoeuvre with a positive speed to take v_c from")]
    NoSpeed,
    /// The diagnosed effects could not be fitted on all rows.
    #[error("fitting the diagnosed model on all manoeuvres: {0}")]
    Fit(#[from] DiagnoseError),
    /// The fitted values make no valid model (e.g. a negative μ or G).
    #[error("the fitted model is not a valid plan model: {0}")]
    Model(#[from] ModelError),
}

/// The median of the finite `values`.
fn median(mut values: Vec<f64>) -> Option<f64> {
    values.retain(|v| v.is_finite());
    stats::median(values)
}

/// The conditions the synthetic manoeuvres are built at (medians over the diagnosed rows).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conditions {
    /// v_c [m/s].
    pub v_c_mps: f64,
    /// Turned angle of a turn [rad].
    pub turn_rad: f64,
    /// Bus voltage [V].
    pub bus_v: f64,
    /// Run time at the start of a manoeuvre [s].
    pub t_start_s: f64,
}

impl Conditions {
    /// Medians of `rows` (v_c over moving manoeuvres; turned angle over turns with yaw).
    pub fn of(rows: &[TurnRow]) -> Result<Conditions, ModelFileError> {
        let v_c_mps = median(
            rows.iter()
                .map(|r| r.v_c_mps)
                .filter(|v| *v > 0.0)
                .collect(),
        )
        .map(micro)
        .ok_or(ModelFileError::NoSpeed)?;
        let turn_rad = median(
            rows.iter()
                .filter(|r| !r.is_straight() && r.turned_from_yaw)
                .map(|r| r.expected_duration_s * r.yaw_rate_cmd_rad_s)
                .filter(|a| *a > 0.0)
                .collect(),
        )
        .unwrap_or(DEFAULT_TURN_RAD);
        Ok(Conditions {
            v_c_mps,
            turn_rad,
            bus_v: median(rows.iter().map(|r| r.bus_v).collect()).unwrap_or(0.0),
            t_start_s: median(rows.iter().map(|r| r.t_start_s).collect()).unwrap_or(0.0),
        })
    }
}

/// A synthetic left turn at `r_over_r_prime` (∞: a straight line) under `at`, with the
/// baseline's power as its measured power.
pub fn synthetic_row(
    rover: &Rover,
    baseline: &Baseline,
    r_over_r_prime: f64,
    at: &Conditions,
) -> TurnRow {
    let r_prime = f64::from(rover.r_prime_m());
    let bounds = RegimeBounds::default();
    let straight = !r_over_r_prime.is_finite()
        || r_over_r_prime * r_prime >= f64::from(bounds.straight_from_m);
    let radius_m = if straight {
        f64::INFINITY
    } else {
        r_over_r_prime * r_prime
    };
    let (regime, inner_mps, outer_mps, yaw_rate) = if straight {
        (Regime::Straight, at.v_c_mps, at.v_c_mps, 0.0)
    } else {
        let s = side_speeds_for(
            at.v_c_mps as f32,
            radius_m as f32,
            r_prime as f32,
            TurnDirection::Left,
        );
        (
            Regime::of(radius_m as f32, rover, &bounds),
            f64::from(s.left_mps),
            f64::from(s.right_mps),
            f64::from(yaw_rate_for(
                at.v_c_mps as f32,
                radius_m as f32,
                r_prime as f32,
            )),
        )
    };
    let duration_s = if straight || yaw_rate <= 0.0 {
        1.0
    } else {
        at.turn_rad / yaw_rate
    };
    let side = |role, cmd_mps| SideObs {
        role,
        cmd_mps,
        avg_power_w: 0.0,
        max_power_w: 0.0,
        energy_j: 0.0,
        effective_power_w: 0.0,
        growth_w: None,
    };
    let mut row = TurnRow {
        run: "synthetic".into(),
        run_index: 0,
        manoeuvre: 0,
        regime,
        radius_cmd_m: radius_m,
        r_over_r_prime: if straight {
            f64::INFINITY
        } else {
            r_over_r_prime
        },
        v_c_mps: at.v_c_mps,
        yaw_rate_cmd_rad_s: yaw_rate,
        duration_s,
        expected_duration_s: duration_s,
        turned_from_yaw: true,
        angular_slip: None,
        yaw_rate_act_rad_s: None,
        t_start_s: at.t_start_s,
        pitch_deg: Some(0.0),
        standstill_current_a: None,
        standstill_w: [0.0; 2],
        bus_v: at.bus_v,
        sides: [
            side(SideRole::Inner, inner_mps),
            side(SideRole::Outer, outer_mps),
        ],
        calibration_kind: straight
            || regime == Regime::Point
            || r_over_r_prime >= CALIBRATION_MIN_R_OVER_R_PRIME - 1e-9,
        observed: Observed::Sides,
        copper_heat_a4: None,
        measured: None,
        direction: (!straight).then_some(TurnDirection::Left),
    };
    for k in 0..2 {
        let p = baseline.side_power_w(&row, k);
        let s = &mut row.sides[k];
        s.avg_power_w = p;
        s.effective_power_w = p;
        s.energy_j = p * duration_s;
    }
    row
}

/// `x` to 1e-6 (file values free of f32 → f64 noise).
fn micro(x: f64) -> f64 {
    (x * 1e6).round() / 1e6
}

/// The R/R′ breakpoints of the table: a uniform grid, the regime edges (B/2, R′ ± the at-R′
/// tolerance) with a point just outside each, wider turns, and the straight line's position;
/// turns only up to `widest` R/R′ (the widest turn diagnosed: beyond it a fitted term is an
/// extrapolation, so the table goes straight from there to the straight line's value, which
/// was measured, and `plan` interpolates between the two).
pub fn grid(rover: &Rover, widest: f64) -> Vec<f64> {
    let r_prime = f64::from(rover.r_prime_m());
    let bounds = RegimeBounds::default();
    let tol = f64::from(bounds.r_prime_fraction);
    let half = f64::from(rover.half_track_m()) / r_prime;
    let straight = f64::from(bounds.straight_from_m) / r_prime;
    let per_unit = (1.0 / GRID_STEP).round();
    let steps = (GRID_UNIFORM_MAX * per_unit).round() as usize;
    // k / per_unit rather than k · step: 0.15, not 0.15000000000000002, in the file.
    let mut out: Vec<f64> = (0..=steps).map(|k| k as f64 / per_unit).collect();
    for edge in [half, 1.0 - tol, 1.0 + tol] {
        out.extend([edge - 1e-3, edge, edge + 1e-3].map(micro));
    }
    out.extend(GRID_WIDE);
    let straight = micro(straight);
    out.retain(|x| *x >= 0.0 && *x < straight && *x <= widest + 1e-9);
    out.push(straight);
    out.sort_by(f64::total_cmp);
    out.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    out
}

/// One effect term of a fitted model, tabulated: its total extra power of both sides at each
/// R/R′ of [`grid`] up to `widest` (the last breakpoint is the straight line).
pub fn effect_term(
    rover: &Rover,
    baseline: &Baseline,
    model: &FittedModel,
    term: &FittedEffect,
    at: &Conditions,
    widest: f64,
) -> EffectTerm {
    let ctx = model.context(rover, baseline);
    let r_over_r_prime = grid(rover, widest);
    let extra_power_w = r_over_r_prime
        .iter()
        .map(|&k| {
            let row = synthetic_row(rover, baseline, k, at);
            micro(term.term_w(&row, 0, &ctx) + term.term_w(&row, 1, &ctx))
        })
        .collect();
    EffectTerm {
        name: term.effect.id().to_owned(),
        r_over_r_prime,
        extra_power_w,
    }
}

/// The plan model of `diagnosis`: its baseline as the hard-ground base and the effects of its
/// model (the named one and its stepwise secondaries, fitted jointly on every row) as effect
/// terms, at the median v_c of `rows`. The power-type effects' baseline corrections (a and G
/// refitted with them, see [`FittedModel`]) go into the base's μ and G.
pub fn energy_model(
    rover: &Rover,
    diagnosis: &Diagnosis,
    rows: &[TurnRow],
    calibration: Calibration<'_>,
) -> Result<EnergyModel, ModelFileError> {
    let at = Conditions::of(rows)?;
    let effects = diagnosis.model_effects();
    let calibration = diagnosis.fitted_with(calibration);
    let (baseline, model) = fit_model(rover, rows, &effects, calibration)?;
    // No table beyond the widest diagnosed turn (R/R′ = 0 if there is none).
    let widest = rows
        .iter()
        .map(|r| r.r_over_r_prime)
        .filter(|k| k.is_finite())
        .fold(0.0, f64::max);
    let terms: Vec<EffectTerm> = model
        .effects
        .iter()
        .map(|term| effect_term(rover, &baseline, &model, term, &at, widest))
        .collect();
    let a = baseline.skid_force_n + model.correction_a_n;
    let icr = baseline.as_icr(rover);
    let mu = if baseline.skid_force_n != 0.0 {
        icr.mu * a / baseline.skid_force_n
    } else {
        icr.mu
    };
    let what = if effects.is_empty() {
        format!("no effect term (diagnosis: {})", diagnosis.effect)
    } else {
        let ids: Vec<&str> = effects.iter().map(|e| e.id()).collect();
        format!("plus the diagnosed {}", ids.join(" + "))
    };
    let model = EnergyModel {
        version: plan::MODEL_FORMAT_VERSION,
        description: Some(format!(
            "host-tool diagnose: hard-ground model (paper Eq 21-22) fitted on {} calibration \
             manoeuvres ({}), {what}, tabulated at v_c = {:.3} m/s",
            diagnosis.calibration.manoeuvres,
            diagnosis.calibration.source.id(),
            at.v_c_mps
        )),
        v_c_mps: at.v_c_mps,
        rover: *rover,
        base: HardGroundBase {
            mu: micro(mu),
            rolling_resistance_n: micro(icr.rolling_resistance_n + model.correction_g_n),
            // The rover file's decimal (the baseline carries its f32 as f64).
            slip_track_m: decimal_f64(rover.slip_track_m),
        },
        effects: terms,
    };
    model.check()?;
    Ok(model)
}

#[cfg(test)]
mod tests;
