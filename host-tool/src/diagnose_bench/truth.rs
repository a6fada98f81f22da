//! The ground truth of a dataset ([`truth_of`]): from the world's [`ManoeuvreTruth`] of every
//! test run, per regime, the mean over its manoeuvres of the effect's extra effective power
//! |E_effect| / T_expected [W, both sides] (the diagnosis' metric; `angular-slip` and
//! `slip-track` count the energy of the extra time). The true regime is the regime with the
//! largest mean when that peak is distinct — at least [`DISTINCT_PEAK`] × every other regime's
//! mean — and `all` when the effect is spread evenly over several regimes. `slope` and
//! `motor-heating` are `all` by definition: their extra power follows the pitch along the path
//! and the winding temperature over run time, not the turn radius.

use crate::diagnose::effects::{is_power_type, least_squares};
use crate::diagnose::stats::{PRACTICAL_FLOOR_W, RELATIVE_FLOOR};
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
    /// Mean per regime id of the extra effective power left once its calibration-run part is
    /// absorbed (see the module docs) [W, both sides, signed].
    pub unabsorbed_w: Vec<(String, f64)>,
    /// The largest of them in magnitude [W].
    pub unabsorbed_peak_w: f64,
    /// Whether that unabsorbed mean reaches the diagnosis' practical floor in some regime:
    /// max([`PRACTICAL_FLOOR_W`], [`RELATIVE_FLOOR`] × the regime's mean true side power).
    pub visible_after_calibration: bool,
}

/// The truth of `effect` (None: control) over the manoeuvres of every run.
pub fn truth_of(
    effect: Option<EffectId>,
    manoeuvres: &[ManoeuvreTruth],
    calibration: &[ManoeuvreTruth],
) -> Truth {
    let Some(effect) = effect else {
        return Truth {
            effect: "none".into(),
            regime: "none".into(),
            extra_power_w: Vec::new(),
            peak_extra_power_w: 0.0,
            unabsorbed_w: Vec::new(),
            unabsorbed_peak_w: 0.0,
            visible_after_calibration: false,
        };
    };
    let unabsorbed_w = unabsorbed(effect, manoeuvres, calibration);
    let unabsorbed_peak_w = unabsorbed_w
        .iter()
        .fold(0.0f64, |m, u| m.max(u.mean_w.abs()));
    let visible_after_calibration = unabsorbed_w.iter().any(|u| u.mean_w.abs() >= u.floor_w);
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
        unabsorbed_w: unabsorbed_w
            .iter()
            .map(|u| (u.regime.id().to_owned(), u.mean_w))
            .collect(),
        unabsorbed_peak_w,
        visible_after_calibration,
    }
}

/// One regime's unabsorbed extra power and the practical floor there.
struct Unabsorbed {
    regime: Regime,
    /// Mean over the regime's manoeuvres [W, both sides, signed].
    mean_w: f64,
    /// max([`PRACTICAL_FLOOR_W`], [`RELATIVE_FLOOR`] × the regime's mean true side power) [W].
    floor_w: f64,
}

/// The regressors by which a baseline calibrated on these runs absorbs an effect's extra
/// effective power of `m` (both sides); `None` for pauses. A power-type effect: the skid term
/// |ω_cmd| and the rolling term Σ|V| (a and G are fitted on the calibration manoeuvres' average
/// power). A time-type effect leaves the average power as it is, so a and G take none of it;
/// when it makes the calibration turns slower (`slows_turns`) the terrain's constant angular
/// slip takes it in proportion to the turn's power, else nothing does (the diagnosis takes no
/// negative constant slip: turning faster than commanded is not a slip).
fn absorbing_features(effect: EffectId, m: &ManoeuvreTruth, slows_turns: bool) -> Option<Vec<f64>> {
    m.regime?;
    if m.expected_duration_s <= 0.0 {
        return None;
    }
    if is_power_type(effect) {
        return Some(vec![
            m.commanded_yaw_rate_rad_s.abs(),
            m.cmd_mps.left.abs() + m.cmd_mps.right.abs(),
        ]);
    }
    let turn_power_w = if m.commanded_yaw_rate_rad_s != 0.0 {
        m.avg_power_w.left + m.avg_power_w.right
    } else {
        0.0
    };
    Some(if slows_turns {
        vec![turn_power_w]
    } else {
        Vec::new()
    })
}

/// The effect's extra effective power of `m` [W, both sides, signed].
fn extra_effective_w(effect: EffectId, m: &ManoeuvreTruth) -> f64 {
    m.effect_energy(effect).unwrap_or(0.0) / m.expected_duration_s
}

/// Per regime, the mean extra power the calibration does not absorb and the floor there.
fn unabsorbed(
    effect: EffectId,
    manoeuvres: &[ManoeuvreTruth],
    calibration: &[ManoeuvreTruth],
) -> Vec<Unabsorbed> {
    let slows_turns = calibration
        .iter()
        .filter(|m| m.regime.is_some() && m.commanded_yaw_rate_rad_s != 0.0)
        .map(|m| extra_effective_w(effect, m))
        .sum::<f64>()
        > 0.0;
    let design: Vec<(Vec<f64>, f64)> = calibration
        .iter()
        .filter_map(|m| {
            Some((
                absorbing_features(effect, m, slows_turns)?,
                extra_effective_w(effect, m),
            ))
        })
        .collect();
    // Too few calibration manoeuvres to fit: nothing is absorbed.
    let beta = least_squares(&design).map(|(b, _)| b);
    let mut sums = [(0.0f64, 0.0f64, 0usize); Regime::ALL.len()];
    for m in manoeuvres {
        let (Some(regime), Some(x)) = (m.regime, absorbing_features(effect, m, slows_turns)) else {
            continue;
        };
        let Some(k) = Regime::ALL.iter().position(|r| *r == regime) else {
            continue;
        };
        let absorbed: f64 = beta
            .as_ref()
            .map_or(0.0, |b| b.iter().zip(&x).map(|(b, x)| b * x).sum());
        sums[k].0 += extra_effective_w(effect, m) - absorbed;
        sums[k].1 += 0.5 * (m.avg_power_w.left.abs() + m.avg_power_w.right.abs());
        sums[k].2 += 1;
    }
    Regime::ALL
        .iter()
        .zip(sums)
        .filter(|(_, (_, _, n))| *n > 0)
        .map(|(&regime, (s, p, n))| Unabsorbed {
            regime,
            mean_w: s / n as f64,
            floor_w: PRACTICAL_FLOOR_W.max(RELATIVE_FLOOR * p / n as f64),
        })
        .collect()
}
