//! Verdicts without repeats: leave-one-out prediction intervals for observations whose group
//! has no repeat to measure the noise against (a per-turn summary's one row per radius, or one
//! run driving every radius once).
//!
//! For each such observation the baseline (Eq 21, linear in a = F/B_s and G) is refitted
//! **without its row**, and the measured value is compared with the refit's prediction:
//! t = (y − ŷ₍₋ᵢ₎) / (s₍₋ᵢ₎ √(1 + x'(X'X)₍₋ᵢ₎⁻¹x)), the externally studentised residual, Student's
//! t with df = (observations in the refit) − 2 (n − p − 1 when the row was in the fit, one
//! observation per row). The reference the row is refitted on:
//! - **total-only rows** (a summary table): every other row of the table. A published table has
//!   no calibration/test split and no repeats; its question is which row the others do not
//!   predict (with only the calibration-kind rows, a 5-row table leaves 1 df);
//! - **per-side runs**: the calibration manoeuvres, as the baseline (of the runs, less the row; or
//!   of the calibration runs).
//!
//! **Multiple testing** (one test per observation, so a clean table is not flagged by chance):
//! Holm's step-down, gatekept in two families fixed before looking at the data (serial
//! gatekeeping; it controls the family-wise error at α):
//! 1. turns with R ≤ R′ (inner wheels stopped or counter-rotating), where the seed documents the
//!    loose-soil departures from the hard-ground model (Sections 2.1.2, 4.4, 5) and where every
//!    size-changing catalogue term acts;
//! 2. turns with R > R′ and straights, where the seed fits Eq 2.12 (Section 4.2) — tested only
//!    when every observation of family 1 is rejected (or there is none).
//!
//! Adjusted p: Holm's within family 1; within family 2 the larger of Holm's and family 1's
//! largest. A plain Holm over all observations is reported as well (`p_holm_all`): with a
//! 5-row table it is the stricter figure, and the report should show both.

use super::baseline::skid_feature_mps;
use super::calibration::{Calibration, Source};
use super::features::TurnRow;
use super::observe::{self, Part};
use serde::Serialize;

/// Family-wise error rate of the row verdicts.
pub const ALPHA: f64 = 0.05;

/// What value of an observation is tested.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measure {
    /// Effective power E/T_expected (a summary: its average power) [W].
    Effective,
    /// Average power over the steady part [W].
    Average,
}

/// The multiple-testing family of an observation (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Family {
    /// R ≤ R′: tested first.
    UpToRPrime,
    /// R > R′ and straights: tested when family 1 is all rejected.
    BeyondRPrime,
}

/// The leave-one-out test of one observation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LooTest {
    /// Index of the row.
    pub row: usize,
    /// Side, or the total of a total-only row.
    pub part: Part,
    /// Measured value [W].
    pub measured_w: f64,
    /// Prediction of the baseline refitted without the row [W].
    pub prediction_w: f64,
    /// Measured − prediction [W].
    pub residual_w: f64,
    /// Standard error of a new observation at this row: s₍₋ᵢ₎ √(1 + h) [W].
    pub se_w: f64,
    /// 95 % prediction interval of the measured value (unadjusted) [W].
    pub interval_w: (f64, f64),
    /// Externally studentised residual.
    pub t: f64,
    /// Its degrees of freedom.
    pub df: usize,
    /// Two-sided p of `t`.
    pub p: f64,
    /// p adjusted for multiple testing (gatekept Holm, module doc).
    pub p_adjusted: f64,
    /// p adjusted by a plain Holm over every tested observation.
    pub p_holm_all: f64,
    /// Its family.
    pub family: Family,
    /// `p_adjusted` ≤ [`ALPHA`] (the practical floor is the caller's).
    pub beyond_noise: bool,
}

impl LooTest {
    /// One line: the row, its leave-one-out residual and the significance statement.
    pub fn statement(&self, rows: &[TurnRow]) -> String {
        let what = rows.get(self.row).map_or_else(String::new, |r| {
            if r.radius_cmd_m.is_finite() {
                format!("R = {:.2} m ", r.radius_cmd_m)
            } else {
                "straight ".to_owned()
            }
        });
        format!(
            "{what}{:+.1} W against the baseline refitted without it ({:.1} W, 95 % prediction \
             interval [{:.1}, {:.1}]): t = {:.2}, df = {}, p = {:.3} (adjusted {:.3}; plain Holm \
             over all tested rows {:.3})",
            self.residual_w,
            self.prediction_w,
            self.interval_w.0,
            self.interval_w.1,
            self.t,
            self.df,
            self.p,
            self.p_adjusted,
            self.p_holm_all
        )
    }
}

/// Sums of a 2-parameter least-squares fit (no intercept).
#[derive(Debug, Clone, Copy, Default)]
struct Normal {
    xx: [[f64; 2]; 2],
    xy: [f64; 2],
    yy: f64,
    n: usize,
}

impl Normal {
    fn add(&mut self, x: [f64; 2], y: f64, sign: f64) {
        for i in 0..2 {
            for j in 0..2 {
                self.xx[i][j] += sign * x[i] * x[j];
            }
            self.xy[i] += sign * x[i] * y;
        }
        self.yy += sign * y * y;
        if sign > 0.0 {
            self.n += 1;
        } else {
            self.n -= 1;
        }
    }

    /// Prediction, standard error of a new observation and df at `x`; `None` when singular
    /// or without a residual degree of freedom.
    fn predict(&self, x: [f64; 2]) -> Option<(f64, f64, usize)> {
        let det = self.xx[0][0] * self.xx[1][1] - self.xx[0][1] * self.xx[1][0];
        let scale = self.xx[0][0].abs() * self.xx[1][1].abs();
        // NaN-safe: a NaN determinant is singular too.
        let regular = det.abs() > 1e-12 * scale.max(f64::MIN_POSITIVE);
        if self.n < 3 || !regular {
            return None;
        }
        let inv = [
            [self.xx[1][1] / det, -self.xx[0][1] / det],
            [-self.xx[1][0] / det, self.xx[0][0] / det],
        ];
        let beta = [
            inv[0][0] * self.xy[0] + inv[0][1] * self.xy[1],
            inv[1][0] * self.xy[0] + inv[1][1] * self.xy[1],
        ];
        // SSR = y'y − β'X'y.
        let ssr = (self.yy - beta[0] * self.xy[0] - beta[1] * self.xy[1]).max(0.0);
        let df = self.n - 2;
        let s2 = ssr / df as f64;
        let h = x[0] * (inv[0][0] * x[0] + inv[0][1] * x[1])
            + x[1] * (inv[1][0] * x[0] + inv[1][1] * x[1]);
        let se = (s2 * (1.0 + h)).sqrt();
        Some((beta[0] * x[0] + beta[1] * x[1], se, df))
    }
}

/// The baseline's features of one observation (sides summed).
fn features(row: &TurnRow, sides: &[usize]) -> [f64; 2] {
    observe::sum_sides(sides, |side| {
        [skid_feature_mps(row, side), row.sides[side].cmd_mps.abs()]
    })
}

fn part_of(row: &TurnRow, sides: &[usize]) -> Part {
    match sides {
        [side] => Part::from(row.sides[*side].role),
        _ => Part::Total,
    }
}

/// Leave-one-out tests of the observations `wanted(row, part)` selects, adjusted for
/// multiple testing over them (module doc).
pub fn tests(
    rows: &[TurnRow],
    calibration: Calibration<'_>,
    measure: Measure,
    wanted: impl Fn(usize, Part) -> bool,
) -> Vec<LooTest> {
    // The reference fit and, per row of `rows`, whether it is in it.
    let summary = rows.iter().any(TurnRow::is_total_only);
    let mut reference = Normal::default();
    let mut in_reference = vec![false; rows.len()];
    let reference_rows: Vec<&TurnRow> = match calibration.source {
        Source::FromRuns if summary => rows.iter().collect(),
        _ => calibration.manoeuvres(rows),
    };
    for row in &reference_rows {
        for sides in observe::observations(row) {
            reference.add(
                features(row, sides),
                observe::measured_avg_w(row, sides),
                1.0,
            );
        }
        if let Some(i) = rows.iter().position(|r| std::ptr::eq(r, *row)) {
            in_reference[i] = true;
        }
    }
    let mut out = Vec::new();
    for (i, row) in rows.iter().enumerate() {
        let mut fit = reference;
        if in_reference[i] {
            for sides in observe::observations(row) {
                fit.add(
                    features(row, sides),
                    observe::measured_avg_w(row, sides),
                    -1.0,
                );
            }
        }
        for sides in observe::observations(row) {
            let part = part_of(row, sides);
            if !wanted(i, part) {
                continue;
            }
            let x = features(row, sides);
            let Some((prediction_w, se_w, df)) = fit.predict(x) else {
                continue;
            };
            let measured_w = match measure {
                Measure::Effective => observe::measured_effective_w(row, sides),
                Measure::Average => observe::measured_avg_w(row, sides),
            };
            let residual_w = measured_w - prediction_w;
            let t = if se_w > 0.0 {
                residual_w / se_w
            } else {
                f64::INFINITY.copysign(residual_w)
            };
            let half = super::stats::t_quantile_975(df) * se_w;
            let p = t_two_sided_p(t, df);
            out.push(LooTest {
                row: i,
                part,
                measured_w,
                prediction_w,
                residual_w,
                se_w,
                interval_w: (prediction_w - half, prediction_w + half),
                t,
                df,
                p,
                p_adjusted: p,
                p_holm_all: p,
                family: if row.r_over_r_prime <= 1.0 + 1e-6 {
                    Family::UpToRPrime
                } else {
                    Family::BeyondRPrime
                },
                beyond_noise: false,
            });
        }
    }
    adjust(&mut out);
    out
}

/// Holm-adjusted p values of `p` (same order).
pub(super) fn holm(p: &[f64]) -> Vec<f64> {
    let m = p.len();
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| p[a].total_cmp(&p[b]));
    let mut out = vec![1.0; m];
    let mut running: f64 = 0.0;
    for (k, &i) in order.iter().enumerate() {
        running = running.max(((m - k) as f64 * p[i]).min(1.0));
        out[i] = running;
    }
    out
}

/// Sets `p_adjusted`, `p_holm_all` and `beyond_noise` (module doc).
fn adjust(tests: &mut [LooTest]) {
    let all: Vec<f64> = tests.iter().map(|t| t.p).collect();
    for (t, p) in tests.iter_mut().zip(holm(&all)) {
        t.p_holm_all = p;
    }
    let mut gate = 0.0f64;
    for family in [Family::UpToRPrime, Family::BeyondRPrime] {
        let idx: Vec<usize> = (0..tests.len())
            .filter(|&i| tests[i].family == family)
            .collect();
        let p: Vec<f64> = idx.iter().map(|&i| tests[i].p).collect();
        let adjusted = holm(&p);
        for (&i, a) in idx.iter().zip(&adjusted) {
            tests[i].p_adjusted = a.max(gate);
            tests[i].beyond_noise = tests[i].p_adjusted <= ALPHA;
        }
        // Serial gate: the next family inherits the largest adjusted p of this one.
        gate = adjusted.iter().fold(gate, |g, a| g.max(*a));
    }
}

/// Two-sided p of Student's t with `df` degrees of freedom (1 when there is no test: df = 0 or
/// t NaN), from model-core's t distribution.
pub fn t_two_sided_p(t: f64, df: usize) -> f64 {
    // The lower tail at −|t| is the upper tail at |t|, computed without cancellation.
    model_core::fit::student_t_cdf(-t.abs(), df).map_or(1.0, |tail| (2.0 * tail).clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t_p_values_match_tables() {
        // df = 2 has a closed form: p = 1 − t/√(t² + 2).
        for t in [0.5, 1.0, 2.0, 4.9, 10.0] {
            let exact = 1.0 - t / (t * t + 2.0f64).sqrt();
            assert!((t_two_sided_p(t, 2) - exact).abs() < 1e-10, "{t}");
        }
        // The 97.5 % quantiles give p = 0.05.
        for df in [1, 3, 10, 30, 120] {
            let q = super::super::stats::t_quantile_975(df);
            assert!((t_two_sided_p(q, df) - 0.05).abs() < 5e-4, "{df}");
        }
        assert_eq!(t_two_sided_p(0.0, 5), 1.0);
        assert_eq!(t_two_sided_p(f64::INFINITY, 5), 0.0);
    }

    #[test]
    fn holm_steps_down_and_stays_monotone() {
        let adj = holm(&[0.01, 0.04, 0.03, 0.2]);
        assert!((adj[0] - 0.04).abs() < 1e-12);
        assert!((adj[2] - 0.09).abs() < 1e-12);
        assert!((adj[1] - 0.09).abs() < 1e-12);
        assert!((adj[3] - 0.2).abs() < 1e-12);
    }

    fn test(family: Family, p: f64) -> LooTest {
        LooTest {
            row: 0,
            part: Part::Total,
            measured_w: 0.0,
            prediction_w: 0.0,
            residual_w: 0.0,
            se_w: 1.0,
            interval_w: (0.0, 0.0),
            t: 0.0,
            df: 2,
            p,
            p_adjusted: p,
            p_holm_all: p,
            family,
            beyond_noise: false,
        }
    }

    #[test]
    fn the_wide_turns_are_tested_only_past_the_gate() {
        // Family 1 all rejected: family 2 is tested with Holm within it.
        let mut t = vec![
            test(Family::UpToRPrime, 0.04),
            test(Family::BeyondRPrime, 0.01),
            test(Family::BeyondRPrime, 0.5),
        ];
        adjust(&mut t);
        assert!(t[0].beyond_noise && t[1].beyond_noise && !t[2].beyond_noise);
        assert!((t[1].p_adjusted - 0.04).abs() < 1e-12);
        // A plain Holm over all three would not reject the first.
        assert!((t[0].p_holm_all - 0.08).abs() < 1e-12);
        // Family 1 not rejected: nothing in family 2 is, however small its p.
        let mut t = vec![
            test(Family::UpToRPrime, 0.3),
            test(Family::BeyondRPrime, 0.001),
        ];
        adjust(&mut t);
        assert!(!t[0].beyond_noise && !t[1].beyond_noise);
        assert!((t[1].p_adjusted - 0.3).abs() < 1e-12);
        // No family 1: family 2 gets the whole α.
        let mut t = vec![test(Family::BeyondRPrime, 0.001)];
        adjust(&mut t);
        assert!(t[0].beyond_noise);
    }
}
