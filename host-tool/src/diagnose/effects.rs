//! Catalogue terms fitted to the hard-ground baseline's residuals. Each effect's term (its own
//! file in [`catalogue`](super::catalogue)) is extra **effective** power per side, ΔP_side [W]
//! (see [`features`]), with a physical shape linear in its parameters, so that fitting it is
//! ordinary least squares (`model_core::fit::LinearFit`, no intercept). The shapes are the
//! thesis', not the simulator's code: the diagnosis must work on data from any generator.
//!
//! Terms are fitted jointly ([`FittedModel::fit`]); power-type terms through their projection
//! off the baseline's calibration fit ([`is_power_type`]); a term that grows through the turn
//! also predicts that growth ([`growth_regressor`]).
//!
//! [`features`]: super::features

use super::baseline::Baseline;
use super::calibration::Calibration;
use super::catalogue;
pub use super::effect::{Context, MAX_PARAMS};
use super::error::{DiagnoseError, EffectFitError};
use super::features::TurnRow;
use super::observe;
pub use super::winding_heat::HEATING_TAU_GRID_S;
use crate::effect_id::EffectId;
use model_core::fit::{LinearFit, RankTest};
use model_core::Rover;
use serde::Serialize;

/// Parameter count of `effect`'s term.
pub fn param_count(effect: EffectId) -> usize {
    catalogue::of(effect).param_count()
}

/// Whether `effect` changes the **average** power (a power-type term), as opposed to the
/// time-type terms that only lengthen the turn. The baseline is fitted on the calibration rows'
/// average power, so a power-type term acting on calibration rows (point turns, straights, wide
/// turns) is partly absorbed into a and G: it appears in the residuals as its regressor minus
/// that regressor's projection on the baseline's features over the calibration rows
/// (Frisch–Waugh–Lovell), which [`FittedModel::fit`] uses.
pub fn is_power_type(effect: EffectId) -> bool {
    catalogue::of(effect).power_type()
}

/// The regressors of `effect` for side `side` of `row` (unused slots are 0); `None` when the
/// row lacks what the term needs (pitch for `slope`), which counts as 0 extra power.
pub fn regressors(
    effect: EffectId,
    row: &TurnRow,
    side: usize,
    ctx: &Context<'_>,
) -> Option<[f64; MAX_PARAMS]> {
    catalogue::of(effect).regressors(row, side, ctx)
}

/// Parameters a candidate fits on its own: its term's, the growth coefficient where it grows,
/// τ where it fits one.
pub fn fitted_params(effect: EffectId) -> usize {
    model_params(&[effect])
}

/// Parameters of a model of several effects fitted jointly (see [`FittedModel::fit`]).
pub fn model_params(effects: &[EffectId]) -> usize {
    effects
        .iter()
        .map(|&e| {
            let e = catalogue::of(e);
            e.param_count() + usize::from(e.grows()) + usize::from(e.fits_tau())
        })
        .sum()
}

/// The growth regressor of `effect` for side `side` of `row`: the shape of its power rise
/// through the turn (0 when the effect does not grow or `row` has no phases).
pub fn growth_regressor(effect: EffectId, row: &TurnRow, side: usize, ctx: &Context<'_>) -> f64 {
    if !catalogue::of(effect).grows() {
        return 0.0;
    }
    // Both growing terms rise with the shape of their base power.
    regressors(effect, row, side, ctx).map_or(0.0, |x| x[0])
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
    /// Coefficient of its growth regressor (0 unless it grows).
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

/// Each power-type column's projection on the baseline's features over the rows the baseline
/// was fitted on, `fitted_on`: [effect][param] → [on skid, on |V|] (zeros for time-type terms).
fn projections(
    effects: &[EffectId],
    fitted_on: &[&TurnRow],
    ctx: &Context<'_>,
) -> Vec<[[f64; 2]; MAX_PARAMS]> {
    effects
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
                            [regressors(e, r, side, ctx).unwrap_or([0.0; MAX_PARAMS])[p]]
                        });
                        let f = observe::sum_sides(sides, |side| baseline_features(r, side));
                        (f, z)
                    })
                });
                if let Some((b, _)) = least_squares_of(2, design) {
                    *slot = [b[0], b[1]];
                }
            }
            out
        })
        .collect()
}

/// The growth coefficients of `model`'s growing terms: least squares of the observed growth
/// per side of `train` on their growth regressors (none without phases or growing rows).
fn fit_growth(
    model: &mut FittedModel,
    effects: &[EffectId],
    train: &[&TurnRow],
    ctx: &Context<'_>,
) {
    let growing: Vec<usize> = (0..effects.len())
        .filter(|&k| catalogue::of(effects[k]).grows())
        .collect();
    if growing.is_empty() {
        return;
    }
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
        let taus: &[f64] = if effects.iter().any(|&e| catalogue::of(e).fits_tau()) {
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
            let projections = projections(effects, fitted_on, &ctx);
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
        fit_growth(&mut model, effects, train, ctx);
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

/// The baseline as `calibration` says and `effects` fitted jointly on all rows (plus the
/// calibration runs' manoeuvres): the diagnosed model, for tabulating (e.g. the model file of
/// `plan --model`, [`model_file`]) with [`extra_power_w`].
pub fn fit_model(
    rover: &Rover,
    rows: &[TurnRow],
    effects: &[EffectId],
    calibration: Calibration<'_>,
) -> Result<(Baseline, FittedModel), DiagnoseError> {
    let baseline = calibration.baseline(rover, rows)?;
    let ctx = Context {
        rover,
        baseline: &baseline,
        heating_tau_s: HEATING_TAU_GRID_S[0],
    };
    let model = FittedModel::fit(
        effects,
        &calibration.training_rows(rows),
        &calibration.manoeuvres(rows),
        &ctx,
    )?;
    Ok((baseline, model))
}

/// The extra effective power `model` predicts on top of `baseline` for each side of `row`
/// ([inner, outer] for turns) [W], baseline corrections included.
pub fn extra_power_w(
    rover: &Rover,
    baseline: &Baseline,
    model: &FittedModel,
    row: &TurnRow,
) -> [f64; 2] {
    let ctx = model.context(rover, baseline);
    [0, 1].map(|side| model.extra_w(row, side, &ctx))
}
