//! Why there is no diagnosis.

use super::baseline::BaselineError;
use crate::effect_id::EffectId;

/// Why there is no diagnosis.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DiagnoseError {
    /// No turn or straight to diagnose.
    #[error("no manoeuvre to diagnose")]
    NoRows,
    /// The baseline cannot be fitted.
    #[error(transparent)]
    Baseline(#[from] BaselineError),
    /// One run and one radius: nothing to hold out.
    #[error("cross-validation needs at least two runs or two radii")]
    NothingToHoldOut,
    /// The effects asked for cannot be fitted on these rows.
    #[error(transparent)]
    EffectFit(#[from] EffectFitError),
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
