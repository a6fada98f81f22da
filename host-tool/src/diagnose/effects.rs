//! The catalogue of unmodelled effects: each a term added to the hard-ground baseline with a
//! physical shape, linear in its parameters, so that fitting it to the training rows' residuals
//! is ordinary least squares (`model_core::fit::LinearFit`, no intercept). The ids are the
//! simulator's [`EffectId`]s, but the shapes here are the seed's, not the simulator's code: the
//! diagnosis must work on data from any generator.
//!
//! Every term is extra **effective** power per side, ΔP_side [W] (see [`features`]). Terms are
//! fitted jointly ([`FittedModel::fit`]); power-type terms through their projection off the
//! baseline's calibration fit ([`is_power_type`]). `inner-drag` and `sinkage-bulldozing` also
//! predict the growth of power through the turn ([`has_growth`]).
//!
//! | id | seed | regressors per side |
//! |---|---|---|
//! | `inner-drag` | Section 5.2, Fig 5.6–5.7 | inner: q·\|V_i\| with q = \|V_i\|·v_iy/v_c², v_iy = ω(R − B/2), for B/2 < R < R' |
//! | `sinkage-bulldozing` | Eq 5.15–5.39 | \|V_side\|·\|ω_cmd\|·(L/2)/v_c · (1, T/T_ref) (sinkage grows with lateral slip and time) |
//! | `angular-slip` | Eq 6.3, Fig 6.7 | P_side·(1 − ρ, ρ) for ρ = R/R' ≤ 1, P_side·(0, 1/ρ) above; 0 on straights |
//! | `slip-track` | Eq 2.2, Table D.1 | P_side on turns (ω scales by B_s,ctrl/B_s,terrain everywhere) |
//! | `braked-inner` | Section 6.2, Fig 6.10–6.11 | at R = R' only: outer \|V_o\| |
//! | `current-offset` | Section 3.2, Fig 3.3 | V_bus (an offset current on every manoeuvre and side) |
//! | `motor-heating` | Section 1.1.3 | mean of I²·x_τ over the manoeuvre, x_τ the measured I² low-passed with τ from a grid (copper loss × a first-order winding temperature rise, [`winding_heat`](super::winding_heat)); without samples (P_side/V_bus)⁴·(1 − e^(−t/τ)) at mid-manoeuvre, a constant current since the run's start |
//! | `slope` | Eq 1.16, 2.12 | m g sin θ · v_c · \|V_side\|/(\|V_l\| + \|V_r\|) |
//!
//! [`features`]: super::features

use super::baseline::{self, Baseline};
use super::features::{SideRole, TurnRow};
use super::observe;
use crate::effect_id::EffectId;
use model_core::fit::{LinearFit, RankTest};
use model_core::power::GRAVITY_M_S2;
use model_core::Rover;
use serde::Serialize;

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
    /// τ of the `motor-heating` term [s] (one of [`HEATING_TAU_GRID_S`]).
    pub heating_tau_s: f64,
}

/// The winding's first-order temperature rise at run time `t_s` as a fraction of its final
/// value, 1 − e^(−t/τ) (a constant mean copper loss heating a first-order thermal mass).
pub fn heating_rise(t_s: f64, tau_s: f64) -> f64 {
    if tau_s > 0.0 {
        1.0 - (-t_s.max(0.0) / tau_s).exp()
    } else {
        1.0
    }
}

/// The thermal time constants the `motor-heating` term is tried with [s] (small gearmotors:
/// minutes to tens of minutes); the choice counts as one fitted parameter.
pub const HEATING_TAU_GRID_S: [f64; 6] = [60.0, 150.0, 300.0, 600.0, 1200.0, 2400.0];

/// Parameter count of `effect`'s term.
pub const fn param_count(effect: EffectId) -> usize {
    match effect {
        EffectId::AngularSlip | EffectId::SinkageBulldozing => 2,
        EffectId::InnerDrag
        | EffectId::SlipTrack
        | EffectId::BrakedInner
        | EffectId::CurrentOffset
        | EffectId::MotorHeating
        | EffectId::Slope => 1,
    }
}

/// Whether `effect` changes the **average** power (a power-type term), as opposed to the
/// time-type terms (`angular-slip`, `slip-track`) that only lengthen the turn. The baseline is
/// fitted on the calibration rows' average power, so a power-type term acting on calibration
/// rows (point turns, straights, wide turns) is partly absorbed into a and G: it appears in the
/// residuals as its regressor minus that regressor's projection on the baseline's features over
/// the calibration rows (Frisch–Waugh–Lovell), which [`FittedModel::fit`] uses.
pub const fn is_power_type(effect: EffectId) -> bool {
    match effect {
        EffectId::AngularSlip | EffectId::SlipTrack => false,
        EffectId::InnerDrag
        | EffectId::SinkageBulldozing
        | EffectId::BrakedInner
        | EffectId::CurrentOffset
        | EffectId::MotorHeating
        | EffectId::Slope => true,
    }
}

/// Parameters a candidate fits on its own: its term's, the growth coefficient where
/// [`has_growth`], τ for `motor-heating`.
pub fn fitted_params(effect: EffectId) -> usize {
    model_params(&[effect])
}

/// Parameters of a model of several effects fitted jointly (see [`FittedModel::fit`]).
pub fn model_params(effects: &[EffectId]) -> usize {
    effects
        .iter()
        .map(|&e| {
            param_count(e) + usize::from(has_growth(e)) + usize::from(e == EffectId::MotorHeating)
        })
        .sum()
}

/// Whether `effect` acts in some regimes only, so its gap may sit in a few of them. A warmer
/// winding and a sensor offset act on every manoeuvre: a gap confined to a few regimes is not
/// theirs, and they are judged on all rows.
pub const fn confined_to_regimes(effect: EffectId) -> bool {
    match effect {
        EffectId::MotorHeating | EffectId::CurrentOffset => false,
        EffectId::InnerDrag
        | EffectId::SinkageBulldozing
        | EffectId::AngularSlip
        | EffectId::SlipTrack
        | EffectId::BrakedInner
        | EffectId::Slope => true,
    }
}

/// Whether `effect` makes power rise through a turn (the seed's growing sand piles: the inner
/// wheels' excavated pile, Fig 5.7b, and the sinkage of both sides, Fig 5.11 and 5.19), and so
/// also predicts the growth target (second minus first half of the turn's average power).
pub const fn has_growth(effect: EffectId) -> bool {
    match effect {
        EffectId::InnerDrag | EffectId::SinkageBulldozing => true,
        EffectId::AngularSlip
        | EffectId::SlipTrack
        | EffectId::BrakedInner
        | EffectId::CurrentOffset
        | EffectId::MotorHeating
        | EffectId::Slope => false,
    }
}

/// The growth regressor of `effect` for side `side` of `row`: the shape of its power rise
/// through the turn (0 when the effect does not grow or `row` has no phases).
pub fn growth_regressor(effect: EffectId, row: &TurnRow, side: usize, ctx: &Context<'_>) -> f64 {
    if !has_growth(effect) {
        return 0.0;
    }
    // Both growing terms rise with the shape of their base power.
    regressors(effect, row, side, ctx).map_or(0.0, |x| x[0])
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
            let tau = HEATING_TAU_GRID_S
                .iter()
                .position(|&t| t == ctx.heating_tau_s);
            if let (Some(h), Some(k)) = (row.copper_heat_a4, tau) {
                [h[k][side], 0.0]
            } else if row.bus_v > 0.0 {
                // No samples (a per-turn table, the model file's rows): as if the model's
                // current had flowed since the run's start, x_τ = I²(1 − e^(−t/τ)).
                let i = ctx.baseline.side_power_w(row, side) / row.bus_v;
                let t_mid_s = row.t_start_s + 0.5 * row.duration_s;
                [i.powi(4) * heating_rise(t_mid_s, ctx.heating_tau_s), 0.0]
            } else {
                [0.0, 0.0]
            }
        }
        EffectId::Slope => {
            row.pitch_deg?;
            let mg = f64::from(ctx.rover.mass_kg) * GRAVITY_M_S2;
            [mg * baseline::grade_feature_mps(row, side), 0.0]
        }
    };
    Some(x)
}

/// The baseline's features of side `side` of `row`, the columns a power-type term is projected
/// off: [skid, |V|] (see [`is_power_type`]).
pub(crate) fn baseline_features(row: &TurnRow, side: usize) -> [f64; 2] {
    [
        super::baseline::skid_feature_mps(row, side),
        row.sides[side].cmd_mps.abs(),
    ]
}

/// One observation's columns of the joint fit of `effects`: each term's regressors (summed over
/// `sides`) less their projection `projections` on the baseline's features `f` (summed likewise).
fn design_row(
    effects: &[EffectId],
    projections: &[[[f64; 2]; MAX_PARAMS]],
    row: &TurnRow,
    sides: &[usize],
    f: [f64; 2],
    ctx: &Context<'_>,
) -> [f64; MAX_COLUMNS] {
    let mut x = [0.0; MAX_COLUMNS];
    let mut at = 0;
    for (&e, proj) in effects.iter().zip(projections) {
        let r = observe::sum_sides(sides, |side| {
            regressors(e, row, side, ctx).unwrap_or([0.0; MAX_PARAMS])
        });
        for p in 0..param_count(e) {
            x[at] = r[p] - proj[p][0] * f[0] - proj[p][1] * f[1];
            at += 1;
        }
    }
    x
}

/// One effect's fitted term within a [`FittedModel`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FittedEffect {
    /// Which effect.
    pub effect: EffectId,
    /// Its coefficients (the first [`param_count`] are used).
    pub params: [f64; MAX_PARAMS],
    /// Coefficient of its growth regressor (0 unless [`has_growth`]).
    pub growth: f64,
}

/// Several catalogue terms fitted jointly to the baseline's residuals, with the baseline
/// corrections the all-row terms need.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FittedModel {
    /// The terms, in the order asked for.
    pub effects: Vec<FittedEffect>,
    /// What the power-type terms moved the baseline's a = F/B_s by on the calibration rows,
    /// negated: a + this is the skid force without the terms [N].
    pub correction_a_n: f64,
    /// The same for G [N].
    pub correction_g_n: f64,
    /// τ of `motor-heating` chosen on the training rows [s] (the grid's first if absent).
    pub heating_tau_s: f64,
    /// Each term's projection of its power-type columns on the baseline's features over the rows
    /// the baseline was fitted on ([effect][param] → [on skid, on |V|]; zeros for time-type
    /// terms): what [`FittedModel::design_row`] takes off the regressors.
    #[serde(skip)]
    pub projections: Vec<[[f64; 2]; MAX_PARAMS]>,
}

/// Why an effect could not be fitted on a training set (e.g. its regressors are all zero there:
/// the training fold holds no row of the regime it acts on).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{effects:?}: {reason}")]
pub struct EffectFitError {
    /// The effects of the model.
    pub effects: Vec<EffectId>,
    /// The least-squares complaint.
    pub reason: String,
}

/// Most columns of a joint fit: every catalogue effect with its most parameters.
pub const MAX_COLUMNS: usize = EffectId::COUNT * MAX_PARAMS;

/// Least squares (`model_core::fit::LinearFit`) for a column count known at run time (at most
/// [`MAX_COLUMNS`]): the coefficients and the residual sum of squares; `None` when the columns
/// are (numerically) dependent or there are fewer rows than columns.
pub fn least_squares(rows: &[(Vec<f64>, f64)]) -> Option<(Vec<f64>, f64)> {
    let k = rows.first()?.0.len();
    if rows.iter().any(|(x, _)| x.len() != k) {
        return None;
    }
    least_squares_of(k, rows.iter().map(|(x, y)| (x.as_slice(), *y)))
}

/// [`least_squares`] of the first `k` columns of `rows`, streamed into the fit (no design
/// matrix is built); `None` also without rows.
fn least_squares_of<X: AsRef<[f64]>>(
    k: usize,
    rows: impl IntoIterator<Item = (X, f64)>,
) -> Option<(Vec<f64>, f64)> {
    let mut fit = LinearFit::<MAX_COLUMNS>::with_columns(k).ok()?;
    for (x, y) in rows {
        fit.add_row(x.as_ref().get(..k)?, y).ok()?;
    }
    if fit.is_empty() {
        return None;
    }
    // A column whose pivot is a tiny fraction of its norm is a combination of the others.
    let b = fit.coefficients_with(RankTest::RelativePivot(1e-7)).ok()?;
    Some((b[..k].to_vec(), fit.residual_sum_of_squares()))
}

impl FittedModel {
    /// The context this model's terms are evaluated in: `rover`, the `baseline` it was fitted
    /// with, and its own heating τ.
    pub fn context<'a>(&self, rover: &'a Rover, baseline: &'a Baseline) -> Context<'a> {
        Context {
            rover,
            baseline,
            heating_tau_s: self.heating_tau_s,
        }
    }

    /// No term (the baseline alone).
    pub fn empty() -> FittedModel {
        FittedModel {
            effects: Vec::new(),
            correction_a_n: 0.0,
            correction_g_n: 0.0,
            heating_tau_s: HEATING_TAU_GRID_S[0],
            projections: Vec::new(),
        }
    }

    /// Joint least squares of the baseline residual (effective power) of every side of `train`
    /// on the regressors of `effects` (no intercept). A power-type term's regressor is taken
    /// minus its projection on the baseline's features (skid, |V|) over `fitted_on`, the rows
    /// the baseline was fitted on (see [`is_power_type`]; with calibration runs their
    /// manoeuvres, not the diagnosed runs' point turns and straights, whose heating or pitch
    /// the baseline never saw): that is how the term shows in the residuals of a
    /// baseline fitted with the term present, so e.g. a constant offset per side, which at one
    /// v_c the baseline absorbs into G and a on the calibration rows, is still fitted exactly,
    /// and no free correction of the baseline is needed. The growth coefficients are a second
    /// least squares of the observed growth per side on the growth regressors.
    /// `motor-heating`'s τ is the one of [`HEATING_TAU_GRID_S`] with the smallest training
    /// residual.
    pub fn fit(
        effects: &[EffectId],
        train: &[&TurnRow],
        fitted_on: &[&TurnRow],
        ctx: &Context<'_>,
    ) -> Result<FittedModel, EffectFitError> {
        let fail = |reason: &str| EffectFitError {
            effects: effects.to_vec(),
            reason: reason.to_owned(),
        };
        if effects.is_empty() {
            return Ok(FittedModel::empty());
        }
        let taus: &[f64] = if effects.contains(&EffectId::MotorHeating) {
            &HEATING_TAU_GRID_S
        } else {
            &HEATING_TAU_GRID_S[..1]
        };
        // What does not depend on τ, once: each training observation's sides, baseline features
        // and residual (the heating term alone is tried on several τ).
        let observed: Vec<(&TurnRow, &[usize], [f64; 2], f64)> = train
            .iter()
            .flat_map(|&row| {
                let res = ctx.baseline.observed_residuals_w(row);
                observe::observations(row)
                    .iter()
                    .enumerate()
                    .map(move |(i, &sides)| {
                        let f = observe::sum_sides(sides, |side| baseline_features(row, side));
                        (row, sides, f, res[i])
                    })
            })
            .collect();
        let columns: usize = effects.iter().map(|&e| param_count(e)).sum();
        let mut best: Option<(f64, FittedModel)> = None;
        for &tau in taus {
            let ctx = Context {
                heating_tau_s: tau,
                ..*ctx
            };
            // Projection of each power-type column on the baseline's features over the
            // calibration rows: [effect][param] -> [on skid, on |V|].
            let projections: Vec<[[f64; 2]; MAX_PARAMS]> = effects
                .iter()
                .map(|&e| {
                    let mut out = [[0.0; 2]; MAX_PARAMS];
                    if !is_power_type(e) {
                        return out;
                    }
                    for (p, slot) in out.iter_mut().enumerate().take(param_count(e)) {
                        let design = fitted_on.iter().flat_map(|r| {
                            observe::observations(r).iter().map(move |sides| {
                                let [z] = observe::sum_sides(sides, |side| {
                                    [regressors(e, r, side, &ctx).unwrap_or([0.0; MAX_PARAMS])[p]]
                                });
                                let f =
                                    observe::sum_sides(sides, |side| baseline_features(r, side));
                                (f, z)
                            })
                        });
                        if let Some((b, _)) = least_squares_of(2, design) {
                            *slot = [b[0], b[1]];
                        }
                    }
                    out
                })
                .collect();
            // One observation per side, or one per total-only row on the summed regressors.
            let design = observed.iter().map(|&(row, sides, f, y)| {
                (design_row(effects, &projections, row, sides, f, &ctx), y)
            });
            let Some((b, ssr)) = least_squares_of(columns, design) else {
                continue;
            };
            if best.as_ref().is_some_and(|(s, _)| *s <= ssr) {
                continue;
            }
            let mut at = 0;
            let mut fitted = Vec::new();
            let (mut correction_a_n, mut correction_g_n) = (0.0, 0.0);
            for (&e, proj) in effects.iter().zip(&projections) {
                let mut params = [0.0; MAX_PARAMS];
                params[..param_count(e)].copy_from_slice(&b[at..at + param_count(e)]);
                at += param_count(e);
                for p in 0..param_count(e) {
                    correction_a_n -= proj[p][0] * params[p];
                    correction_g_n -= proj[p][1] * params[p];
                }
                fitted.push(FittedEffect {
                    effect: e,
                    params,
                    growth: 0.0,
                });
            }
            best = Some((
                ssr,
                FittedModel {
                    effects: fitted,
                    correction_a_n,
                    correction_g_n,
                    heating_tau_s: tau,
                    projections,
                },
            ));
        }
        let (_, mut model) = best.ok_or_else(|| fail("regressors are zero or collinear"))?;
        let growing: Vec<usize> = (0..effects.len())
            .filter(|&k| has_growth(effects[k]))
            .collect();
        if !growing.is_empty() {
            let mut design = Vec::new();
            for row in train {
                for side in 0..2 {
                    let Some(g) = row.sides[side].growth_w else {
                        continue;
                    };
                    let x = growing
                        .iter()
                        .map(|&k| growth_regressor(effects[k], row, side, ctx))
                        .collect();
                    design.push((x, g));
                }
            }
            // No phases or no row where it grows: the terms predict no growth.
            if let Some((b, _)) = least_squares(&design) {
                for (&k, g) in growing.iter().zip(b) {
                    model.effects[k].growth = g;
                }
            }
        }
        Ok(model)
    }

    /// The fitted columns of one observation of `row` (the sides `sides` summed, see
    /// [`observe::observations`]): each term's regressors less their projection on the baseline's
    /// features, in the order of the coefficients. The model's extra effective power there is
    /// their dot product with the coefficients, so where these columns lie relative to the
    /// training observations' is where the prediction lies relative to what it was fitted on.
    pub fn design_row(
        &self,
        row: &TurnRow,
        sides: &[usize],
        ctx: &Context<'_>,
    ) -> [f64; MAX_COLUMNS] {
        let effects: Vec<EffectId> = self.effects.iter().map(|t| t.effect).collect();
        let f = observe::sum_sides(sides, |side| baseline_features(row, side));
        design_row(&effects, &self.projections, row, sides, f, &self.ctx(ctx))
    }

    /// Number of fitted columns of the effective-power design ([`FittedModel::design_row`]).
    pub fn columns(&self) -> usize {
        self.effects.iter().map(|t| param_count(t.effect)).sum()
    }

    /// The context with this model's τ.
    fn ctx<'a>(&self, ctx: &Context<'a>) -> Context<'a> {
        Context {
            heating_tau_s: self.heating_tau_s,
            ..*ctx
        }
    }

    /// The model's extra effective power for side `side` of `row` [W] (corrections included).
    pub fn extra_w(&self, row: &TurnRow, side: usize, ctx: &Context<'_>) -> f64 {
        let ctx = self.ctx(ctx);
        self.correction_w(row, side)
            + self
                .effects
                .iter()
                .map(|f| f.term_w(row, side, &ctx))
                .sum::<f64>()
    }

    /// The model's extra **average** power for side `side` of `row` [W]: the corrections and
    /// the power-type terms ([`is_power_type`]); the time-type terms lengthen the turn and leave
    /// the average power as it is.
    pub fn extra_avg_power_w(&self, row: &TurnRow, side: usize, ctx: &Context<'_>) -> f64 {
        let ctx = self.ctx(ctx);
        self.correction_w(row, side)
            + self
                .effects
                .iter()
                .filter(|f| is_power_type(f.effect))
                .map(|f| f.term_w(row, side, &ctx))
                .sum::<f64>()
    }

    /// The baseline corrections' share of [`FittedModel::extra_w`] [W].
    pub fn correction_w(&self, row: &TurnRow, side: usize) -> f64 {
        self.correction_a_n * super::baseline::skid_feature_mps(row, side)
            + self.correction_g_n * row.sides[side].cmd_mps.abs()
    }

    /// The model's predicted growth through the turn for side `side` of `row` [W].
    pub fn growth_w(&self, row: &TurnRow, side: usize, ctx: &Context<'_>) -> f64 {
        let ctx = self.ctx(ctx);
        self.effects
            .iter()
            .map(|f| f.growth * growth_regressor(f.effect, row, side, &ctx))
            .sum()
    }
}

impl FittedEffect {
    /// This term's own extra power for side `side` of `row` (no baseline correction) [W];
    /// `ctx` must carry the model's τ.
    pub fn term_w(&self, row: &TurnRow, side: usize, ctx: &Context<'_>) -> f64 {
        regressors(self.effect, row, side, ctx)
            .map_or(0.0, |x| x[0] * self.params[0] + x[1] * self.params[1])
    }
}
