//! Is the baseline adequate on its own calibration manoeuvres? A classic lack-of-fit F test:
//! the calibration manoeuvres repeat (the same radius and v_c across runs, or within a run), so
//! the scatter of their repeats is the pure error, and what the model leaves beyond it is lack
//! of fit. An effect is named only against a baseline that passes (see [`super::diagnose_with`]);
//! a model that misfits the manoeuvres it is trusted on would turn its own structural error
//! into a confident effect name.
//!
//! The observation is the **average** power, the quantity the baseline is fitted on. Total
//! power (both sides; paper Eq 21 is a total-power model) is judged first; the per-side split
//! is judged separately, so a report can say "the total fits, the split does not".
//!
//! A misfit needs both statistics and size: p < [`ALPHA`] **and** an RMS of the manoeuvres' mean
//! residuals beyond the practical floor (max([`PRACTICAL_FLOOR_W`], [`RELATIVE_FLOOR`] × the RMS
//! model power)): with hundreds of samples per turn the pure error can be a fraction of a watt,
//! and a two-parameter steady model is not expected to hold the power to better than a few %
//! (the same tolerance the gaps use). The groups beyond their own floor are what the report
//! names.

use super::features::{Observed, SideRole, TurnRow};
use super::stats::{PRACTICAL_FLOOR_W, RELATIVE_FLOOR};
use serde::Serialize;
use std::collections::BTreeMap;

/// Calibration manoeuvres steeper than this mean pitch are left out of the test: the baseline is
/// a level-ground model, and a slope's Φ m g v sin θ is an effect, not a misfit [deg].
pub const LEVEL_PITCH_DEG: f64 = 1.0;

/// Whether `row` was driven on level ground: its mean pitch within [`LEVEL_PITCH_DEG`], or not
/// measured.
pub fn is_level(row: &TurnRow) -> bool {
    row.pitch_deg.is_none_or(|p| p.abs() <= LEVEL_PITCH_DEG)
}

/// Significance level of the lack-of-fit test.
pub const ALPHA: f64 = 0.01;

/// The share of the baseline's calibration lack of fit an effect must remove to be named
/// against a misfitting baseline (see [`explained_fraction`]).
pub const EXPLAINED_BY_EFFECT: f64 = 0.5;

/// The share of `base`'s lack of fit (mean square of the groups' mean residuals, per side when
/// tested per side, else total) that `with` (the same test with an effect added) removes.
pub fn explained_fraction(base: &Adequacy, with: &Adequacy) -> f64 {
    let pick = |a: &Adequacy| {
        a.per_side
            .as_ref()
            .map_or(a.total.lack_of_fit_rms_w, |t| t.lack_of_fit_rms_w)
    };
    let (b, w) = (pick(base), pick(with));
    if b > 0.0 {
        1.0 - (w / b).powi(2)
    } else {
        0.0
    }
}

/// What a lack-of-fit test compared.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Observation {
    /// Both sides' sum.
    Total,
    /// Each side (inner/outer; straights: the sides by convention).
    PerSide,
}

/// One calibration manoeuvre (and side) in the test: its repeats' mean residual.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GroupFit {
    /// `point turn`, `R = 2.00 R′` or `straight`, at v_c.
    pub manoeuvre: String,
    /// The side (per-side test only).
    pub side: Option<SideRole>,
    /// Repeats.
    pub n: usize,
    /// Mean of measured minus model average power [W].
    pub mean_residual_w: f64,
    /// Mean measured average power [W].
    pub mean_measured_w: f64,
    /// Mean model average power [W].
    pub model_w: f64,
    /// The practical floor of this group [W].
    pub floor_w: f64,
}

impl GroupFit {
    /// Whether the mean residual is beyond the practical floor.
    pub fn beyond_floor(&self) -> bool {
        self.mean_residual_w.abs() > self.floor_w
    }
}

/// The lack-of-fit F test of one observation kind.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LackOfFit {
    /// Total or per side.
    pub observation: Observation,
    /// Observations.
    pub n: usize,
    /// Distinct manoeuvres (replicate groups).
    pub groups: usize,
    /// Model parameters fitted.
    pub params: usize,
    /// Lack-of-fit degrees of freedom (groups − params).
    pub df_lack_of_fit: usize,
    /// Pure-error degrees of freedom (n − groups).
    pub df_pure_error: usize,
    /// Repeat noise σ = √(SS_pure / df_pure) [W].
    pub repeat_sigma_w: f64,
    /// RMS of the groups' mean residuals [W].
    pub lack_of_fit_rms_w: f64,
    /// F = (SS_lof / df_lof) / (SS_pure / df_pure); `None` when not testable.
    pub f: Option<f64>,
    /// P(F > f) under an adequate model.
    pub p_value: Option<f64>,
    /// Every group, largest |mean residual| first.
    pub groups_fit: Vec<GroupFit>,
}

impl LackOfFit {
    /// `Some(false)` when the model misfits (p < [`ALPHA`] and a group beyond its floor),
    /// `Some(true)` when it passes, `None` when there are no repeats or no spare groups.
    pub fn adequate(&self) -> Option<bool> {
        let p = self.p_value?;
        Some(!(p < ALPHA && self.lack_of_fit_rms_w > self.floor_w()))
    }

    /// The practical floor of the RMS lack of fit: max([`PRACTICAL_FLOOR_W`],
    /// [`RELATIVE_FLOOR`] × the RMS model power over the groups) [W].
    pub fn floor_w(&self) -> f64 {
        let n = self.groups_fit.len().max(1) as f64;
        let rms_model = (self
            .groups_fit
            .iter()
            .map(|g| g.model_w.powi(2))
            .sum::<f64>()
            / n)
            .sqrt();
        PRACTICAL_FLOOR_W.max(RELATIVE_FLOOR * rms_model)
    }
}

/// The adequacy of a model on the calibration manoeuvres.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Adequacy {
    /// The total-power test (first-class).
    pub total: LackOfFit,
    /// The per-side test (absent with total-only rows).
    pub per_side: Option<LackOfFit>,
    /// `false` when the total or the per-side split misfits; `None` when untestable.
    pub adequate: Option<bool>,
    /// What the data suggest about a misfit.
    pub suggestions: Vec<String>,
}

impl Adequacy {
    /// Whether the per-side split may be leaned on (it passed, or could not be tested).
    pub fn split_fits(&self) -> bool {
        self.per_side
            .as_ref()
            .is_none_or(|t| t.adequate() != Some(false))
    }
}

/// The replicate key and label of a calibration manoeuvre: radius and v_c, to 0.01.
fn manoeuvre_key(row: &TurnRow) -> (i64, i64, String) {
    let v = (row.v_c_mps * 100.0).round() as i64;
    if row.is_straight() {
        return (i64::MAX, v, format!("straight at {:.2} m/s", row.v_c_mps));
    }
    let r = (row.r_over_r_prime * 100.0).round() as i64;
    let label = if r == 0 {
        format!("point turn at {:.2} m/s", row.v_c_mps)
    } else {
        format!("R = {:.2} R′ at {:.2} m/s", row.r_over_r_prime, row.v_c_mps)
    };
    (r, v, label)
}

/// One observation of the test: group key, side, measured and model values.
struct Obs {
    key: (i64, i64, String, Option<SideRole>),
    measured: f64,
    model: f64,
}

/// Tests `model_w(row, side)` (a side's model average power) on the calibration `rows`, which
/// fitted `params` parameters.
pub fn test(
    rows: &[&TurnRow],
    params: usize,
    model_w: impl Fn(&TurnRow, usize) -> f64,
) -> Adequacy {
    let mut total = Vec::new();
    let mut sides = Vec::new();
    let level = rows.iter().filter(|r| is_level(r));
    for row in level {
        let (r, v, label) = manoeuvre_key(row);
        let model = [model_w(row, 0), model_w(row, 1)];
        let measured_total = match row.observed {
            Observed::Sides => row.sides[0].avg_power_w + row.sides[1].avg_power_w,
            Observed::Total { avg_power_w } => avg_power_w,
        };
        total.push(Obs {
            key: (r, v, label.clone(), None),
            measured: measured_total,
            model: model[0] + model[1],
        });
        if row.observed == Observed::Sides {
            for (obs, model) in row.sides.iter().zip(model) {
                sides.push(Obs {
                    key: (r, v, label.clone(), Some(obs.role)),
                    measured: obs.avg_power_w,
                    model,
                });
            }
        }
    }
    let total = lack_of_fit(Observation::Total, &total, params);
    let per_side = (!sides.is_empty()).then(|| lack_of_fit(Observation::PerSide, &sides, params));
    let verdicts = [Some(&total), per_side.as_ref()]
        .into_iter()
        .flatten()
        .map(LackOfFit::adequate);
    let adequate = verdicts.fold(None, |acc: Option<bool>, v| match (acc, v) {
        (Some(false), _) | (_, Some(false)) => Some(false),
        (Some(true), _) | (_, Some(true)) => Some(true),
        (None, None) => None,
    });
    let mut out = Adequacy {
        total,
        per_side,
        adequate,
        suggestions: Vec::new(),
    };
    out.suggestions = suggestions(&out, rows);
    out
}

fn lack_of_fit(observation: Observation, obs: &[Obs], params: usize) -> LackOfFit {
    let mut groups: BTreeMap<&(i64, i64, String, Option<SideRole>), Vec<&Obs>> = BTreeMap::new();
    for o in obs {
        groups.entry(&o.key).or_default().push(o);
    }
    let mut ss_pure = 0.0;
    let mut ss_lof = 0.0;
    let mut groups_fit = Vec::new();
    for (key, of) in &groups {
        let n = of.len() as f64;
        let mean = |f: fn(&&Obs) -> f64| of.iter().map(f).sum::<f64>() / n;
        let measured = mean(|o| o.measured);
        let model = mean(|o| o.model);
        ss_pure += of
            .iter()
            .map(|o| (o.measured - measured).powi(2))
            .sum::<f64>();
        // The model is the same on every repeat (commanded speeds), up to v_c rounding.
        ss_lof += of.iter().map(|o| (measured - o.model).powi(2)).sum::<f64>();
        groups_fit.push(GroupFit {
            manoeuvre: key.2.clone(),
            side: key.3,
            n: of.len(),
            mean_residual_w: measured - model,
            mean_measured_w: measured,
            model_w: model,
            floor_w: PRACTICAL_FLOOR_W.max(RELATIVE_FLOOR * model.abs()),
        });
    }
    groups_fit.sort_by(|a, b| b.mean_residual_w.abs().total_cmp(&a.mean_residual_w.abs()));
    let n = obs.len();
    let g = groups.len();
    let df_lof = g.saturating_sub(params);
    let df_pure = n.saturating_sub(g);
    let repeat_sigma_w = if df_pure > 0 {
        (ss_pure / df_pure as f64).sqrt()
    } else {
        f64::NAN
    };
    let lof_rms = if groups_fit.is_empty() {
        0.0
    } else {
        (groups_fit
            .iter()
            .map(|gf| gf.mean_residual_w.powi(2))
            .sum::<f64>()
            / groups_fit.len() as f64)
            .sqrt()
    };
    let (f, p_value) = if df_lof > 0 && df_pure > 0 {
        // A pure error of exactly 0 (noise-free repeats) makes any misfit infinitely significant.
        let f = (ss_lof / df_lof as f64) / (ss_pure / df_pure as f64).max(f64::MIN_POSITIVE);
        let p = model_core::fit::f_upper_tail(f, df_lof, df_pure).ok();
        (Some(f), p)
    } else {
        (None, None)
    };
    LackOfFit {
        observation,
        n,
        groups: g,
        params,
        df_lack_of_fit: df_lof,
        df_pure_error: df_pure,
        repeat_sigma_w,
        lack_of_fit_rms_w: lof_rms,
        f,
        p_value,
        groups_fit,
    }
}

/// Plain-words hints from the misfit's pattern (only when the model misfits).
fn suggestions(a: &Adequacy, rows: &[&TurnRow]) -> Vec<String> {
    let mut out = Vec::new();
    if a.adequate != Some(false) {
        return out;
    }
    if let Some(sides) = &a.per_side {
        // The seed's no-regeneration rule (thesis 1.1.3): the inner side of wide turns never
        // draws below 0 W while the model has it regenerate.
        let clamp = sides.groups_fit.iter().filter(|g| {
            g.side == Some(SideRole::Inner) && g.model_w < -PRACTICAL_FLOOR_W && g.beyond_floor()
        });
        let clamp: Vec<&GroupFit> = clamp.collect();
        if !clamp.is_empty() && clamp.iter().all(|g| g.mean_measured_w > -PRACTICAL_FLOOR_W) {
            out.push(format!(
                "inner side never below 0 W where the model regenerates ({}): the \
                 no-regeneration clamp (thesis Section 1.1.3)",
                names(&clamp)
            ));
        } else if clamp.iter().any(|g| g.mean_measured_w > PRACTICAL_FLOOR_W) {
            out.push(format!(
                "inner side draws positive power where the model regenerates ({}): the inner \
                 power turns positive again past a threshold radius R_T (paper Fig 11)",
                names(&clamp)
            ));
        }
        if a.total.adequate() != Some(false) && sides.adequate() == Some(false) {
            out.push(
                "the total fits but the per-side split does not: the sides share the power \
                 differently from a tread couple"
                    .to_owned(),
            );
        }
    }
    // Straights below the model while turns sit above it: a no-intercept model linear in the
    // drive force overprices the low-force manoeuvres when the loss grows faster than linearly
    // (copper loss ∝ I², thesis Eq 1.17–1.19), or when the inner side does not regenerate.
    let straight = a
        .total
        .groups_fit
        .iter()
        .find(|g| g.manoeuvre.starts_with("straight"));
    let turns_above = a
        .total
        .groups_fit
        .iter()
        .filter(|g| !g.manoeuvre.starts_with("straight"))
        .any(|g| g.mean_residual_w > g.floor_w);
    if let Some(g) = straight.filter(|g| g.mean_residual_w < -g.floor_w && turns_above) {
        out.push(format!(
            "straights draw {:.1} W less than the model ({:.0} %) while turns draw more: power \
             grows faster than linearly with the drive force (copper loss ∝ I², thesis Eq \
             1.17–1.19) or the inner side does not regenerate",
            -g.mean_residual_w,
            -100.0 * g.mean_residual_w / g.model_w.abs().max(f64::MIN_POSITIVE)
        ));
    }
    // A constant angular slip on the calibration turns (thesis Fig 6.7 on hard ground).
    let slips: Vec<f64> = rows.iter().filter_map(|r| r.angular_slip).collect();
    if let Some((mean, lo, hi)) = super::stats::t_interval(&slips) {
        if lo > 0.0 && mean > 0.02 {
            out.push(format!(
                "calibration turns take {:.0} % longer than commanded (95 % CI {:.0}–{:.0} %): a \
                 terrain-wide angular slip",
                100.0 * mean / (1.0 - mean),
                100.0 * lo / (1.0 - lo),
                100.0 * hi / (1.0 - hi)
            ));
        }
    }
    let worst = &a.total.groups_fit;
    if let Some(g) = worst.first().filter(|g| g.beyond_floor()) {
        out.push(format!(
            "largest total misfit: {} by {:+.1} W (repeat σ {:.1} W)",
            g.manoeuvre, g.mean_residual_w, a.total.repeat_sigma_w
        ));
    }
    out
}

fn names(groups: &[&GroupFit]) -> String {
    groups
        .iter()
        .map(|g| format!("{} {:+.1} W", g.manoeuvre, g.mean_residual_w))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests;
