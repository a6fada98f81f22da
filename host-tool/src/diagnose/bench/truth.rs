//! The ground truth of a dataset ([`truth_of`]): from the world's [`ManoeuvreTruth`] of every
//! test run, per regime, the mean over its manoeuvres of the effect's extra effective power
//! |E_effect| / T_expected [W, both sides] (the diagnosis' metric; `angular-slip` and
//! `slip-track` count the energy of the extra time). The true regime is the regime with the
//! largest mean when that peak is distinct — at least [`DISTINCT_PEAK`] × every other regime's
//! mean — and `all` when the effect is spread evenly over several regimes. `slope` and
//! `motor-heating` are `all` by definition: their extra power follows the pitch along the path
//! and the winding temperature over run time, not the turn radius.

use crate::effect_id::EffectId;
use crate::sim::world::ManoeuvreTruth;
use model_core::kinematics::Regime;
use serde::Serialize;

/// The regime with the largest mean extra power is the true regime only when its mean is at
/// least this factor above every other regime's; else the truth is `all`.
pub const DISTINCT_PEAK: f64 = 1.1;

/// The ground truth of one dataset.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Truth {
    /// The effect id, or `none` for a control.
    pub effect: String,
    /// The regime carrying most of it, `all`, or `none` for a control (see the module docs).
    pub regime: String,
    /// Mean extra effective power per regime id [W, both sides], in `Regime::ALL` order (the
    /// regimes the dataset has).
    pub extra_power_w: Vec<(String, f64)>,
    /// The largest of them [W].
    pub peak_extra_power_w: f64,
}

/// The truth of `effect` (None: control) over the manoeuvres of every run.
pub fn truth_of<'a>(
    effect: Option<EffectId>,
    manoeuvres: impl IntoIterator<Item = &'a ManoeuvreTruth>,
) -> Truth {
    let Some(effect) = effect else {
        return Truth {
            effect: "none".into(),
            regime: "none".into(),
            extra_power_w: Vec::new(),
            peak_extra_power_w: 0.0,
        };
    };
    let mut sums = [(0.0f64, 0usize); Regime::ALL.len()];
    for m in manoeuvres {
        let Some(regime) = m.regime else { continue };
        if m.expected_duration_s <= 0.0 {
            continue;
        }
        let Some(k) = Regime::ALL.iter().position(|r| *r == regime) else {
            continue;
        };
        let extra_w = m.effect_energy(effect).unwrap_or(0.0).abs() / m.expected_duration_s;
        sums[k].0 += extra_w;
        sums[k].1 += 1;
    }
    let extra_power_w: Vec<(Regime, f64)> = Regime::ALL
        .iter()
        .zip(sums)
        .filter(|(_, (_, n))| *n > 0)
        .map(|(r, (s, n))| (*r, s / n as f64))
        .collect();
    let peak = extra_power_w
        .iter()
        .copied()
        .max_by(|a, b| a.1.total_cmp(&b.1));
    let runner_up = |of: Regime| {
        extra_power_w
            .iter()
            .filter(|(r, _)| *r != of)
            .map(|(_, w)| *w)
            .fold(0.0, f64::max)
    };
    let regime = match peak {
        _ if matches!(effect, EffectId::Slope | EffectId::MotorHeating) => "all",
        Some((r, w)) if w > 0.0 && w >= DISTINCT_PEAK * runner_up(r) => r.id(),
        _ => "all",
    };
    Truth {
        effect: effect.id().into(),
        regime: regime.into(),
        extra_power_w: extra_power_w
            .iter()
            .map(|(r, w)| (r.id().to_owned(), *w))
            .collect(),
        peak_extra_power_w: peak.map_or(0.0, |p| p.1),
    }
}
