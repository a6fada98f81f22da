//! The catalogue of unmodelled effects: each a term added to the hard-ground baseline with a
//! physical shape, linear in its parameters, so that fitting it to the training rows' residuals
//! is ordinary least squares (`model_core::fit::LinearFit`, no intercept). The ids are the
//! simulator's [`EffectId`]s, but the shapes here are the seed's, not the simulator's code: the
//! diagnosis must work on data from any generator.
//!
//! Every term is extra **effective** power per side, ΔP_side [W] (see [`features`]).
//!
//! | id | seed | regressors per side |
//! |---|---|---|
//! | `inner-drag` | Section 5.2, Fig 5.6–5.7 | inner: q·\|V_i\| with q = \|V_i\|·v_iy/v_c², v_iy = ω(R − B/2), for B/2 < R < R' |
//! | `sinkage-bulldozing` | Eq 5.15–5.39 | \|V_side\|·\|ω_cmd\|·(L/2)/v_c · (1, T/T_ref) (sinkage grows with lateral slip and time) |
//! | `angular-slip` | Eq 6.3, Fig 6.7 | P_side·(1 − ρ, ρ) for ρ = R/R' ≤ 1, P_side·(0, 1/ρ) above; 0 on straights |
//! | `slip-track` | Eq 2.2, Table D.1 | P_side on turns (ω scales by B_s,ctrl/B_s,terrain everywhere) |
//! | `braked-inner` | Section 6.2, Fig 6.10–6.11 | at R = R' only: outer \|V_o\| |
//! | `current-offset` | Section 3.2, Fig 3.3 | V_bus (an offset current on every manoeuvre and side) |
//! | `motor-heating` | Section 1.1.3 | (P_side/V_bus)²·t_run (copper loss × the early, linear part of the winding's heating) |
//! | `slope` | Eq 1.16, 2.12 | m g sin θ · v_c · \|V_side\|/(\|V_l\| + \|V_r\|) |
//!
//! [`features`]: super::features

use super::baseline::Baseline;
use super::features::{SideRole, TurnRow};
use crate::sim::world::EffectId;
use model_core::fit::LinearFit;
use model_core::power::GRAVITY_M_S2;
use model_core::Rover;

/// Most parameters any effect has.
pub const MAX_PARAMS: usize = 2;

/// Reference turn time of the sinkage term's growth [s] (a 90° point turn at 0.3 m/s on the
/// Husky).
pub const SINKAGE_REF_TIME_S: f64 = 3.0;

/// What an effect's regressors need besides the row.
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    /// The rover (B, L, m, R').
    pub rover: &'a Rover,
    /// The fitted baseline (for P_side of the multiplicative terms).
    pub baseline: &'a Baseline,
}

/// Parameter count of `effect`'s term.
pub const fn param_count(effect: EffectId) -> usize {
    match effect {
        EffectId::AngularSlip | EffectId::SinkageBulldozing => 2,
        _ => 1,
    }
}

/// Whether `effect` acts on every manoeuvre (and so is fitted with a correction of G, one
/// more parameter).
pub const fn corrects_g(effect: EffectId) -> bool {
    matches!(
        effect,
        EffectId::CurrentOffset | EffectId::Slope | EffectId::MotorHeating
    )
}

/// Parameters a candidate fits: its own plus the G correction where [`corrects_g`].
pub const fn fitted_params(effect: EffectId) -> usize {
    param_count(effect) + if corrects_g(effect) { 1 } else { 0 }
}

/// The regressors of `effect` for side `side` of `row` (unused slots are 0); `None` when the
/// row lacks what the term needs (pitch for `slope`), which counts as 0 extra power.
pub fn regressors(
    effect: EffectId,
    row: &TurnRow,
    side: usize,
    ctx: &Context<'_>,
) -> Option<[f64; MAX_PARAMS]> {
    let s = &row.sides[side];
    let v = s.cmd_mps.abs();
    let r_prime = f64::from(ctx.rover.r_prime_m());
    let half_track = f64::from(ctx.rover.track_width_m) / 2.0;
    let turn = !row.is_straight();
    let x = match effect {
        EffectId::InnerDrag => {
            let r = row.radius_cmd_m;
            if turn
                && s.role == SideRole::Inner
                && r > half_track
                && r < r_prime
                && row.v_c_mps > 0.0
            {
                let v_iy = row.yaw_rate_cmd_rad_s * (r - half_track);
                let q = v * v_iy / (row.v_c_mps * row.v_c_mps);
                [q * v, 0.0]
            } else {
                [0.0, 0.0]
            }
        }
        EffectId::SinkageBulldozing => {
            if turn && row.v_c_mps > 0.0 {
                let lateral = row.yaw_rate_cmd_rad_s * f64::from(ctx.rover.length_m) / 2.0;
                let base = v * lateral / row.v_c_mps;
                [base, base * row.expected_duration_s / SINKAGE_REF_TIME_S]
            } else {
                [0.0, 0.0]
            }
        }
        EffectId::AngularSlip => {
            if turn {
                let p = ctx.baseline.side_power_w(row, side);
                let rho = row.r_over_r_prime;
                if rho <= 1.0 {
                    [p * (1.0 - rho), p * rho]
                } else {
                    [0.0, p / rho]
                }
            } else {
                [0.0, 0.0]
            }
        }
        EffectId::SlipTrack => {
            if turn {
                [ctx.baseline.side_power_w(row, side), 0.0]
            } else {
                [0.0, 0.0]
            }
        }
        EffectId::BrakedInner => {
            let at_r_prime = row.regime == model_core::kinematics::Regime::AtRPrime;
            if at_r_prime && s.role == SideRole::Outer {
                [v, 0.0]
            } else {
                [0.0, 0.0]
            }
        }
        EffectId::CurrentOffset => [row.bus_v, 0.0],
        EffectId::MotorHeating => {
            if row.bus_v > 0.0 {
                let i = ctx.baseline.side_power_w(row, side) / row.bus_v;
                [i * i * row.t_start_s, 0.0]
            } else {
                [0.0, 0.0]
            }
        }
        EffectId::Slope => {
            let pitch = row.pitch_deg?;
            let (vl, vr) = (row.sides[0].cmd_mps.abs(), row.sides[1].cmd_mps.abs());
            if vl + vr > 0.0 {
                let mg = f64::from(ctx.rover.mass_kg) * GRAVITY_M_S2;
                let v_y = 0.5 * (row.sides[0].cmd_mps + row.sides[1].cmd_mps);
                [mg * pitch.to_radians().sin() * v_y * v / (vl + vr), 0.0]
            } else {
                [0.0, 0.0]
            }
        }
    };
    Some(x)
}

/// An effect's term fitted to training residuals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FittedEffect {
    /// Which effect.
    pub effect: EffectId,
    /// Its coefficients (the first `param_count` are used).
    pub params: [f64; MAX_PARAMS],
    /// Correction to the baseline's G fitted with it (0 unless [`corrects_g`]) [N].
    pub correction: f64,
}

/// Why an effect could not be fitted on a training set (e.g. its regressors are all zero there:
/// the training fold holds no row of the regime it acts on).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{effect}: {reason}")]
pub struct EffectFitError {
    /// The effect.
    pub effect: EffectId,
    /// The least-squares complaint.
    pub reason: String,
}

impl FittedEffect {
    /// Least squares of the baseline residual of every side of `train` on `effect`'s regressors.
    pub fn fit(
        effect: EffectId,
        train: &[&TurnRow],
        ctx: &Context<'_>,
    ) -> Result<FittedEffect, EffectFitError> {
        let err = |e: model_core::fit::FitError| EffectFitError {
            effect,
            reason: e.to_string(),
        };
        // Terms acting on every row (offset, slope, heating) are fitted jointly with a
        // correction of the baseline's G: at one v_c an offset per side is indistinguishable
        // from G on the calibration rows, so they are absorbed unless G may move with them.
        // Terms acting on some rows only are fitted alone (a G correction would move the rows
        // they do not act on, e.g. the straights).
        let mut alone1 = LinearFit::<1>::new();
        let mut alone2 = LinearFit::<2>::new();
        let mut with_g = LinearFit::<2>::new();
        for row in train {
            // One observation per side, or one per total-only row on the summed regressors.
            let res = ctx.baseline.observed_residuals_w(row);
            for (sides, &r) in super::observe::observations(row).iter().zip(res.iter()) {
                let x = super::observe::sum_sides(sides, |side| {
                    regressors(effect, row, side, ctx).unwrap_or([0.0; MAX_PARAMS])
                });
                let [v] = super::observe::sum_sides(sides, |side| [row.sides[side].cmd_mps.abs()]);
                match (corrects_g(effect), param_count(effect)) {
                    (true, _) => with_g.add([x[0], v], r),
                    (false, 1) => alone1.add([x[0]], r),
                    (false, _) => alone2.add(x, r),
                }
                .map_err(err)?;
            }
        }
        let (params, correction) = match (corrects_g(effect), param_count(effect)) {
            (true, _) => {
                let c = with_g.coefficients().map_err(err)?;
                ([c[0], 0.0], c[1])
            }
            (false, 1) => ([alone1.coefficients().map_err(err)?[0], 0.0], 0.0),
            (false, _) => (alone2.coefficients().map_err(err)?, 0.0),
        };
        Ok(FittedEffect {
            effect,
            params,
            correction,
        })
    }

    /// The term's extra power for side `side` of `row` [W].
    pub fn extra_w(&self, row: &TurnRow, side: usize, ctx: &Context<'_>) -> f64 {
        let base = self.correction * row.sides[side].cmd_mps.abs();
        base + regressors(self.effect, row, side, ctx)
            .map_or(0.0, |x| x[0] * self.params[0] + x[1] * self.params[1])
    }
}
