//! The residual metrics of the "where" analysis and the per-turn residuals of every observation
//! against the baseline (see the table in [the `gaps` module](super)).

use crate::diagnose::baseline::Baseline;
use crate::diagnose::features::TurnRow;
use crate::diagnose::observe::Part;
use model_core::kinematics::Regime;
use serde::Serialize;

/// A residual metric of the "where" analysis (see the table of [the `gaps` module](super)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Metric {
    /// Average power over the steady part [W].
    AvgPower,
    /// Largest one-sample power of the steady part, over the steady model [W].
    MaxPower,
    /// Energy over the manoeuvre against model power × expected duration [J].
    Energy,
    /// E / T_expected [W].
    EffectivePower,
}

impl Metric {
    /// Every metric, in report order.
    pub const ALL: [Metric; 4] = [
        Metric::AvgPower,
        Metric::MaxPower,
        Metric::Energy,
        Metric::EffectivePower,
    ];

    /// Stable identifier.
    pub const fn id(self) -> &'static str {
        match self {
            Metric::AvgPower => "avg-power",
            Metric::MaxPower => "max-power",
            Metric::Energy => "energy",
            Metric::EffectivePower => "effective-power",
        }
    }

    /// Unit of the residual.
    pub const fn unit(self) -> &'static str {
        match self {
            Metric::Energy => "J",
            _ => "W",
        }
    }

    /// What the residual measures (measured minus model).
    pub const fn what(self) -> &'static str {
        match self {
            Metric::AvgPower => "steady-part average power minus Eq 21 power",
            Metric::MaxPower => {
                "peak one-sample power minus Eq 21 (steady) power, less the same peak excess \
                 on the run's calibration manoeuvres"
            }
            Metric::Energy => "manoeuvre energy minus Eq 21 power x expected duration",
            Metric::EffectivePower => "energy / expected duration minus Eq 21 power",
        }
    }
}

/// The residuals of one observation (a side, or a total-only row's total) of one manoeuvre.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TurnResidual {
    /// Index of the row in the diagnosis' input.
    pub row: usize,
    /// The run's index.
    pub run_index: usize,
    /// Regime.
    pub regime: Regime,
    /// R/R' (∞ for straights).
    pub r_over_r_prime: f64,
    /// Which side.
    pub part: Part,
    /// Whether the row is a calibration manoeuvre.
    pub calibration_kind: bool,
    /// The baseline's power of this observation [W] (the relative practical floor's base for
    /// the average and peak power).
    pub model_w: f64,
    /// The baseline's effective power of this observation [W] (the floor's base for the
    /// effective power and the energy, as in [`effective_gaps`](super::effective_gaps)).
    pub model_effective_w: f64,
    /// Standard error of the baseline's effective power here [W].
    pub model_se_w: f64,
    /// Run time at the middle of the manoeuvre [s]; `None` for total-only rows.
    pub t_mid_s: Option<f64>,
    /// Average power minus model [W].
    pub avg_power_w: f64,
    /// Peak minus steady model power [W] (raw, see [the `gaps` module](super)); `None` for
    /// total-only rows.
    pub peak_over_model_w: Option<f64>,
    /// Energy minus model power × expected duration [J]; `None` for total-only rows.
    pub energy_j: Option<f64>,
    /// Effective power minus model [W].
    pub effective_power_w: f64,
    /// Second minus first half of the steady part [W]; `None` if too short or total-only.
    pub growth_w: Option<f64>,
}

/// Per-turn residuals of every observation of `rows`.
pub fn turn_residuals(baseline: &Baseline, rows: &[TurnRow]) -> Vec<TurnResidual> {
    let mut out = Vec::new();
    for (i, row) in rows.iter().enumerate() {
        let base = |part: Part| TurnResidual {
            row: i,
            run_index: row.run_index,
            regime: row.regime,
            r_over_r_prime: row.r_over_r_prime,
            part,
            calibration_kind: row.calibration_kind,
            model_w: 0.0,
            model_effective_w: 0.0,
            model_se_w: 0.0,
            t_mid_s: None,
            avg_power_w: 0.0,
            peak_over_model_w: None,
            energy_j: None,
            effective_power_w: 0.0,
            growth_w: None,
        };
        if row.is_total_only() {
            let model_w = baseline.power_w(row);
            let r = row.effective_power_w() - model_w;
            out.push(TurnResidual {
                model_w,
                model_effective_w: model_w,
                model_se_w: baseline.effective_power_se_w(row),
                avg_power_w: r,
                effective_power_w: r,
                ..base(Part::Total)
            });
            continue;
        }
        for (k, s) in row.sides.iter().enumerate() {
            let model_w = baseline.side_power_w(row, k);
            let model_effective_w = baseline.effective_side_power_w(row, k);
            out.push(TurnResidual {
                model_w,
                model_effective_w,
                model_se_w: baseline.effective_side_power_se_w(row, k),
                t_mid_s: Some(row.t_start_s + 0.5 * row.duration_s),
                avg_power_w: s.avg_power_w - model_w,
                peak_over_model_w: Some(s.max_power_w - model_w),
                energy_j: Some(s.energy_j - model_effective_w * row.expected_duration_s),
                effective_power_w: s.effective_power_w - model_effective_w,
                growth_w: s.growth_w,
                ..base(Part::from(s.role))
            });
        }
    }
    out
}
