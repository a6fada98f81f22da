//! The pairs of rivals and how far manoeuvres separate them: the fits by which each rival of a
//! pair mimics the other's predictions, their residual sums of squares in σ.

use super::super::features::TurnRow;
use super::super::observe;
use super::rival::{Fitted, Prediction, Rival, Setting, MIMIC_COLUMNS};
use model_core::fit::LinearFit;
use serde::Serialize;

/// Separation a pair needs [σ].
pub const TARGET_SIGMA: f64 = 3.0;

/// How far the runs separate two rivals.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PairSeparation {
    /// The two rivals.
    pub rivals: [Rival; 2],
    /// Their separation over the manoeuvres driven [σ].
    pub sigma: f64,
    /// `sigma` ≥ [`TARGET_SIGMA`].
    pub separable: bool,
}

/// One ordered mimicking fit: `mimic`'s columns fitted to `target`'s predictions.
#[derive(Clone)]
struct Mimic {
    target: usize,
    mimic: usize,
    fit: LinearFit<MIMIC_COLUMNS>,
}

impl Mimic {
    fn new(target: usize, mimic: usize, columns: usize) -> Self {
        Self {
            target,
            mimic,
            fit: LinearFit::with_columns(columns).expect("2 to 4 columns"),
        }
    }

    /// Adds the observations of `row` (each side, or the total of a total-only row), each
    /// weighted by `weight`.
    fn add(&mut self, s: &Setting<'_>, fitted: &[Fitted], row: &TurnRow, weight: f64) {
        let w = weight.sqrt();
        for &sides in observe::observations(row) {
            let y: f64 = sides
                .iter()
                .map(|&side| s.eta(&fitted[self.target], row, side))
                .sum();
            let mut x = [0.0; MIMIC_COLUMNS];
            let mut k = 0;
            for &side in sides {
                let (c, n) = s.columns(&fitted[self.mimic], row, side);
                for (xi, ci) in x.iter_mut().zip(c) {
                    *xi += ci;
                }
                k = n;
            }
            for xi in &mut x {
                *xi *= w;
            }
            // A non-finite prediction (a term without its input) is no observation.
            let _ = self.fit.add_row(&x[..k], y * w);
        }
    }
}

/// A pair of rivals and the fits that separate them.
#[derive(Clone)]
pub(super) struct Pair {
    rivals: [usize; 2],
    fits: Vec<Mimic>,
}

impl Pair {
    pub(super) fn new(fitted: &[Fitted], a: usize, b: usize) -> Self {
        let columns = |i: usize| fitted[i].prediction.own_columns() + 2;
        // Every rival nests the baseline alone: only the other one must fail to mimic it.
        let fits = match (&fitted[a].prediction, &fitted[b].prediction) {
            (Prediction::Nothing, _) => vec![Mimic::new(b, a, columns(a))],
            (_, Prediction::Nothing) => vec![Mimic::new(a, b, columns(b))],
            _ => vec![Mimic::new(a, b, columns(b)), Mimic::new(b, a, columns(a))],
        };
        Self {
            rivals: [a, b],
            fits,
        }
    }

    /// Adds the drives `rows`, each weighted by `weight`.
    pub(super) fn add<'r>(
        &mut self,
        s: &Setting<'_>,
        fitted: &[Fitted],
        rows: impl IntoIterator<Item = &'r TurnRow> + Clone,
        weight: f64,
    ) {
        for f in &mut self.fits {
            for row in rows.clone() {
                f.add(s, fitted, row, weight);
            }
        }
    }

    /// The separation [σ]: the weaker direction's.
    pub(super) fn sigma(&self, noise_w: f64) -> f64 {
        self.fits
            .iter()
            .map(|f| f.fit.residual_sum_of_squares().max(0.0).sqrt() / noise_w)
            .fold(f64::INFINITY, f64::min)
    }

    /// The smallest increase of the mimicking fits' residual sum of squares one drive of `row`
    /// brings [W²].
    pub(super) fn increment(&self, s: &Setting<'_>, fitted: &[Fitted], row: &TurnRow) -> f64 {
        self.fits
            .iter()
            .map(|f| {
                let mut g = f.clone();
                g.add(s, fitted, row, 1.0);
                g.fit.residual_sum_of_squares() - f.fit.residual_sum_of_squares()
            })
            .fold(f64::INFINITY, f64::min)
    }

    pub(super) fn labels(&self, fitted: &[Fitted]) -> [Rival; 2] {
        self.rivals.map(|i| fitted[i].rival)
    }
}

/// Decides how far the manoeuvres driven (`train`) separate every pair of fitted rivals.
pub(super) fn pairs_driven(s: &Setting<'_>, fitted: &[Fitted], train: &[&TurnRow]) -> Vec<Pair> {
    // Every pair over the manoeuvres driven.
    let mut pairs: Vec<Pair> = Vec::new();
    for a in 0..fitted.len() {
        for b in a + 1..fitted.len() {
            let mut p = Pair::new(fitted, a, b);
            p.add(s, fitted, train.iter().copied(), 1.0);
            pairs.push(p);
        }
    }
    pairs
}

/// Decides whether `p` is separated, by noise σ `noise_w`.
pub(super) fn separation(p: &Pair, fitted: &[Fitted], noise_w: f64) -> PairSeparation {
    let sigma = p.sigma(noise_w);
    PairSeparation {
        rivals: p.labels(fitted),
        sigma,
        separable: sigma >= TARGET_SIGMA,
    }
}
