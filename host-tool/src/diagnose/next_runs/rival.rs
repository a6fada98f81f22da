//! The rivals: the baseline alone, copper loss and each catalogue effect, fitted to the runs as
//! the diagnosis fits them, and the extra effective power each predicts.

use super::super::baseline::{self, Baseline};
use super::super::effect::Context;
use super::super::effects::{self, FittedModel, HEATING_TAU_GRID_S};
use super::super::features::TurnRow;
use super::super::observe;
use crate::effect_id::EffectId;
use model_core::Rover;
use serde::{Serialize, Serializer};

/// A hypothesis the next runs should tell apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rival {
    /// The baseline alone.
    None,
    /// The baseline with copper loss (the baseline family's escalation member).
    CopperLoss,
    /// The baseline with a catalogue effect.
    Effect(EffectId),
}

impl Rival {
    /// `none`, `copper-loss` or the effect id.
    pub const fn label(self) -> &'static str {
        match self {
            Rival::None => "none",
            Rival::CopperLoss => "copper-loss",
            Rival::Effect(e) => e.id(),
        }
    }
}

impl Serialize for Rival {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.label())
    }
}

/// A rival that cannot be fitted on the runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Unfitted {
    /// The rival.
    pub rival: Rival,
    /// Why.
    pub why: String,
}

/// A rival fitted to the runs.
pub(super) struct Fitted {
    pub(super) rival: Rival,
    pub(super) prediction: Prediction,
}

/// How a fitted rival predicts extra effective power.
pub(super) enum Prediction {
    /// The baseline alone: none.
    Nothing,
    /// Copper loss with the baseline's features refitted: coefficients on [F², skid, |V|].
    Copper([f64; 3]),
    /// A catalogue term.
    Effect(FittedModel),
}

impl Prediction {
    /// How many regressors of its own the rival has (the baseline's two come after them).
    pub(super) fn own_columns(&self) -> usize {
        match self {
            Prediction::Nothing => 0,
            Prediction::Copper(_) => 1,
            Prediction::Effect(m) => effects::param_count(m.effects[0].effect),
        }
    }
}

/// Columns of a mimicking fit: a rival's own regressors (≤ 2) and the baseline's two.
pub(super) const MIMIC_COLUMNS: usize = effects::MAX_PARAMS + 2;

/// What the rivals are evaluated with.
pub(super) struct Setting<'a> {
    pub(super) rover: &'a Rover,
    pub(super) baseline: &'a Baseline,
}

impl Setting<'_> {
    fn ctx(&self, tau_s: f64) -> Context<'_> {
        Context {
            rover: self.rover,
            baseline: self.baseline,
            heating_tau_s: tau_s,
        }
    }

    /// The predicted extra effective power of `f` on side `side` of `row` [W].
    pub(super) fn eta(&self, f: &Fitted, row: &TurnRow, side: usize) -> f64 {
        match &f.prediction {
            Prediction::Nothing => 0.0,
            Prediction::Copper(c) => {
                let x = copper_columns(self.baseline, row, side);
                c[0] * x[0] + c[1] * x[1] + c[2] * x[2]
            }
            Prediction::Effect(m) => m.extra_w(row, side, &self.ctx(m.heating_tau_s)),
        }
    }

    /// `f`'s own regressors on side `side` of `row`, then the baseline's features.
    pub(super) fn columns(
        &self,
        f: &Fitted,
        row: &TurnRow,
        side: usize,
    ) -> ([f64; MIMIC_COLUMNS], usize) {
        let mut x = [0.0; MIMIC_COLUMNS];
        let own = f.prediction.own_columns();
        match &f.prediction {
            Prediction::Nothing => {}
            Prediction::Copper(_) => x[0] = baseline::copper_regressor(self.baseline, row, side),
            Prediction::Effect(m) => {
                let r =
                    effects::regressors(m.effects[0].effect, row, side, &self.ctx(m.heating_tau_s))
                        .unwrap_or([0.0; effects::MAX_PARAMS]);
                x[..own].copy_from_slice(&r[..own]);
            }
        }
        x[own..own + 2].copy_from_slice(&effects::baseline_features(row, side));
        (x, own + 2)
    }
}

/// [F², skid, |V|] of side `side` of `row`.
fn copper_columns(b: &Baseline, row: &TurnRow, side: usize) -> [f64; 3] {
    let [skid, v] = effects::baseline_features(row, side);
    [baseline::copper_regressor(b, row, side), skid, v]
}

/// Fits every rival on the training rows: the baseline alone, copper loss (unless the
/// baseline has it), each catalogue effect. Those that cannot be fitted are returned apart.
pub(super) fn fit_rivals(
    s: &Setting<'_>,
    train: &[&TurnRow],
    fitted_on: &[&TurnRow],
) -> (Vec<Fitted>, Vec<Unfitted>) {
    let mut fitted = vec![Fitted {
        rival: Rival::None,
        prediction: Prediction::Nothing,
    }];
    let mut not_fitted = Vec::new();
    if s.baseline.copper_w_per_n2 == 0.0 {
        let obs: Vec<(Vec<f64>, f64)> = train
            .iter()
            .flat_map(|&row| {
                let res = s.baseline.observed_residuals_w(row);
                observe::observations(row)
                    .iter()
                    .zip(res.to_vec())
                    .map(move |(&sides, y)| {
                        let x =
                            observe::sum_sides(sides, |side| copper_columns(s.baseline, row, side));
                        (x.to_vec(), y)
                    })
            })
            .filter(|(x, y)| y.is_finite() && x.iter().all(|v| v.is_finite()))
            .collect();
        match effects::least_squares(&obs) {
            Some((c, _)) => fitted.push(Fitted {
                rival: Rival::CopperLoss,
                prediction: Prediction::Copper([c[0], c[1], c[2]]),
            }),
            None => not_fitted.push(Unfitted {
                rival: Rival::CopperLoss,
                why: "its force² regressor is a combination of the baseline's features here".into(),
            }),
        }
    }
    for e in EffectId::ALL {
        match FittedModel::fit(&[e], train, fitted_on, &s.ctx(HEATING_TAU_GRID_S[0])) {
            Ok(m) => fitted.push(Fitted {
                rival: Rival::Effect(e),
                prediction: Prediction::Effect(m),
            }),
            Err(err) => not_fitted.push(Unfitted {
                rival: Rival::Effect(e),
                why: err.reason,
            }),
        }
    }
    (fitted, not_fitted)
}
