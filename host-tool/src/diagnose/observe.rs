//! The observations of a row that the model is compared with: each side of a run-CSV manoeuvre,
//! or the total alone for a per-turn summary row ([`Observed::Total`]). The baseline fit, the
//! residuals, the effect fits and the held-out errors all iterate over these, so a total-only
//! row counts **once**, with the sum of its sides' regressors, and never as two made-up sides.

use super::features::{Observed, SideRole, TurnRow};
use serde::Serialize;
use std::ops::{Deref, DerefMut};

/// The side indices each observation of `row` sums: `[[0], [1]]` for per-side rows, `[[0, 1]]`
/// for total-only rows.
pub fn observations(row: &TurnRow) -> &'static [&'static [usize]] {
    match row.observed {
        Observed::Sides => &[&[0], &[1]],
        Observed::Total { .. } => &[&[0, 1]],
    }
}

/// `f` summed over `sides`, element by element.
pub fn sum_sides<const N: usize>(sides: &[usize], f: impl Fn(usize) -> [f64; N]) -> [f64; N] {
    let mut out = [0.0; N];
    for &s in sides {
        for (o, x) in out.iter_mut().zip(f(s)) {
            *o += x;
        }
    }
    out
}

/// The measured average power of one observation of `row` [W].
pub fn measured_avg_w(row: &TurnRow, sides: &[usize]) -> f64 {
    match row.observed {
        Observed::Sides => sides.iter().map(|&s| row.sides[s].avg_power_w).sum(),
        Observed::Total { avg_power_w } => avg_power_w,
    }
}

/// The measured effective power E/T_expected of one observation of `row` (the average power of
/// a total-only row, which has no duration) [W].
pub fn measured_effective_w(row: &TurnRow, sides: &[usize]) -> f64 {
    match row.observed {
        Observed::Sides => sides.iter().map(|&s| row.sides[s].effective_power_w).sum(),
        Observed::Total { avg_power_w } => avg_power_w,
    }
}

/// The residuals of one row's observations [W]: inner then outer (per-side rows), or the total
/// alone (total-only rows). Dereferences to a slice of 2 or 1 values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Residuals {
    values: [f64; 2],
    len: usize,
}

impl Residuals {
    /// Per-side residuals, inner/outer order of the row.
    pub const fn sides(values: [f64; 2]) -> Self {
        Self { values, len: 2 }
    }

    /// The residual of the total of a total-only row.
    pub const fn total(value: f64) -> Self {
        Self {
            values: [value, 0.0],
            len: 1,
        }
    }

    /// Whether this is a total-only row's single residual.
    pub const fn is_total(&self) -> bool {
        self.len == 1
    }

    /// Subtracts a term's extra power, given per side as `extra_w(side)`: from each side, or
    /// summed over both sides from the total.
    pub fn subtract(&mut self, extra_w: impl Fn(usize) -> f64) {
        if self.is_total() {
            self.values[0] -= extra_w(0) + extra_w(1);
        } else {
            for (side, r) in self.values.iter_mut().enumerate() {
                *r -= extra_w(side);
            }
        }
    }
}

impl serde::Serialize for Residuals {
    /// As the list of its values.
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.iter())
    }
}

impl Deref for Residuals {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.values[..self.len]
    }
}

impl DerefMut for Residuals {
    fn deref_mut(&mut self) -> &mut [f64] {
        &mut self.values[..self.len]
    }
}

/// Held-out residuals of one row: effective power and growth per side ([inner/left,
/// outer/right], measured − predicted [W]; growth `None` without phases).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RowResidual {
    /// Index into the rows.
    pub row: usize,
    /// Effective-power residual of each observation: per side, or the total of a total-only
    /// row [W].
    pub effective_w: Residuals,
    /// Growth residual per side [W].
    pub growth_w: [Option<f64>; 2],
    /// Average-power residual per side: measured average power − baseline − the model's extra
    /// average power ([`FittedModel::extra_avg_power_w`](super::effects::FittedModel::extra_avg_power_w)) [W]; `None` for total-only rows.
    pub avg_w: [Option<f64>; 2],
}

/// Held-out residuals, in row order.
pub type HeldOut = Vec<RowResidual>;

/// Which part of a manoeuvre an observation is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Part {
    /// The side towards the turning centre (straights: by convention).
    Inner,
    /// The side away from it.
    Outer,
    /// Both sides together (total-only rows).
    Total,
}

impl Part {
    /// Stable identifier (`inner`, `outer`, `total`).
    pub const fn id(self) -> &'static str {
        match self {
            Part::Inner => "inner",
            Part::Outer => "outer",
            Part::Total => "total",
        }
    }
}

impl From<SideRole> for Part {
    fn from(role: SideRole) -> Self {
        match role {
            SideRole::Inner => Part::Inner,
            SideRole::Outer => Part::Outer,
        }
    }
}

impl PartialEq<SideRole> for Part {
    fn eq(&self, other: &SideRole) -> bool {
        *self == Part::from(*other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn total_residuals_count_once_and_subtract_both_sides() {
        let mut t = Residuals::total(10.0);
        assert_eq!(t.len(), 1);
        t.subtract(|s| [1.0, 2.0][s]);
        assert_eq!(&*t, &[7.0]);
        let mut s = Residuals::sides([3.0, 4.0]);
        s.subtract(|s| [1.0, 2.0][s]);
        assert_eq!(&*s, &[2.0, 2.0]);
        assert_eq!(sum_sides(&[0, 1], |s| [s as f64, 1.0]), [1.0, 2.0]);
    }
}
