//! Total-station data-loss correction (Section 5.1): lost samples found from the step distances
//! and re-inserted by quadratic gap filling.

use super::hampel::{hampel_at, HampelConfig};
use super::{all_finite, TrackingError};
use crate::fit::LinearFit;

/// Parameters of the total-station data-loss correction (Section 5.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GapFillConfig {
    /// The Hampel identifier run on the distances between consecutive positions.
    pub hampel: HampelConfig,
    /// Measured positions used on each side of a gap for the quadratic fit (at least 1; with 1,
    /// only two points exist and the gap is filled linearly).
    pub neighbours_per_side: usize,
    /// A gap that would need more points than this is left as it is (and counted as skipped): such
    /// a distance is more likely a wild measurement than lost samples.
    pub max_inserted_per_gap: usize,
}

impl Default for GapFillConfig {
    fn default() -> Self {
        Self {
            hampel: HampelConfig::default(),
            neighbours_per_side: 3,
            max_inserted_per_gap: 10,
        }
    }
}

/// What [`fill_gaps`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GapFill {
    /// Positions written to the output (measured + inserted).
    pub len: usize,
    /// Positions inserted.
    pub inserted: usize,
    /// Outlying distances left unfilled: more than `max_inserted_per_gap` points needed, or a
    /// window median of 0 (rover at rest) that leaves r_dist undefined.
    pub skipped_gaps: usize,
}

/// What to do with the step between positions g and g + 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Gap {
    None,
    Fill(usize),
    Skip,
}

impl Gap {
    fn inserted(self) -> usize {
        match self {
            Gap::Fill(m) => m,
            Gap::None | Gap::Skip => 0,
        }
    }
}

fn step_distance_m(points: &[(f64, f64)], j: usize) -> f64 {
    match (points.get(j), points.get(j.wrapping_add(1))) {
        (Some(a), Some(b)) => libm::hypot(b.0 - a.0, b.1 - a.1),
        _ => f64::NAN,
    }
}

/// Section 5.1's rule for the step after position `g`: flagged by the Hampel filter on the step
/// distances, r_dist = distance / window median, 1 point for 1.5 < r_dist ≤ 2.5, 2 for
/// 2.5 < r_dist ≤ 3.5, … i.e. ⌈r_dist − 1.5⌉.
fn gap_at(points: &[(f64, f64)], g: usize, config: &GapFillConfig) -> Gap {
    let steps = points.len().saturating_sub(1);
    if g >= steps {
        return Gap::None;
    }
    let h = hampel_at(steps, |j| step_distance_m(points, j), g, &config.hampel);
    if !h.outlier {
        return Gap::None;
    }
    let r_dist = step_distance_m(points, g) / h.median;
    if !(h.median > 0.0 && r_dist.is_finite()) {
        return Gap::Skip;
    }
    if r_dist <= 1.5 {
        return Gap::None;
    }
    let m = libm::ceil(r_dist - 1.5);
    if m > config.max_inserted_per_gap as f64 {
        Gap::Skip
    } else {
        Gap::Fill(m as usize)
    }
}

/// Writes the `m` points missing after position `g`: a quadratic least-squares fit of x and of y
/// against the sample index through up to `neighbours_per_side` measured positions on each side.
/// Indices count the points inserted in neighbouring gaps too, so the 0.2 s spacing holds.
fn fill_one_gap(
    points: &[(f64, f64)],
    config: &GapFillConfig,
    g: usize,
    m: usize,
    out: &mut [(f64, f64)],
) {
    let k = config.neighbours_per_side;
    // Index relative to position g; centred on the gap for conditioning.
    let centre = (m as f64 + 1.0) / 2.0;
    let mut fit_x = LinearFit::<3>::new();
    let mut fit_y = LinearFit::<3>::new();
    let mut add = |t: f64, p: (f64, f64)| {
        let u = t - centre;
        // Positions were checked finite; a refused row could only leave the fit short, and then
        // the linear fallback below applies.
        let _ = fit_x.add([1.0, u, u * u], p.0);
        let _ = fit_y.add([1.0, u, u * u], p.1);
    };
    let mut t = 0.0;
    for (step, p) in (0..=g).rev().take(k).enumerate() {
        if step > 0 {
            t -= 1.0 + gap_at(points, p, config).inserted() as f64;
        }
        if let Some(&pt) = points.get(p) {
            add(t, pt);
        }
    }
    let mut t = m as f64 + 1.0;
    for (step, p) in ((g + 1)..points.len()).take(k).enumerate() {
        if step > 0 {
            t += 1.0 + gap_at(points, p - 1, config).inserted() as f64;
        }
        if let Some(&pt) = points.get(p) {
            add(t, pt);
        }
    }
    let quadratic = fit_x.coefficients().ok().zip(fit_y.coefficients().ok());
    let (start, end) = match (points.get(g), points.get(g + 1)) {
        (Some(&a), Some(&b)) => (a, b),
        _ => return,
    };
    for (q, slot) in out.iter_mut().enumerate().take(m) {
        let tq = (q + 1) as f64;
        *slot = match quadratic {
            Some((cx, cy)) => {
                let u = tq - centre;
                (
                    cx[0] + cx[1] * u + cx[2] * u * u,
                    cy[0] + cy[1] * u + cy[2] * u * u,
                )
            }
            None => {
                let frac = tq / (m as f64 + 1.0);
                (
                    start.0 + frac * (end.0 - start.0),
                    start.1 + frac * (end.1 - start.1),
                )
            }
        };
    }
}

/// Total-station data-loss correction (Section 5.1, Fig. 5.2).
///
/// The distances between consecutive positions (sampled at 5 Hz, the still start and end already
/// trimmed as the seed does by hand) go through the Hampel filter ([`hampel`], default k = 3,
/// 3 σ). For each outlying distance, r_dist = distance / window median decides how many positions
/// were lost: 1 for 1.5 < r_dist ≤ 2.5, 2 for 2.5 < r_dist ≤ 3.5, and so on (outliers with
/// r_dist ≤ 1.5 are not gaps). The lost positions are placed by quadratic least-squares fits of x
/// and y against the sample index through the measured neighbours on both sides (our reading of
/// the seed's "quadratic polynomial fit with the neighbor points"; x and y are fitted separately,
/// so turns of any direction work).
///
/// Writes the measured and inserted positions, in order, into `out` (`OutputTooSmall` if it cannot
/// hold them all; nothing is written then) and reports the counts. A track without gaps is copied
/// unchanged.
pub fn fill_gaps(
    positions_m: &[(f64, f64)],
    config: &GapFillConfig,
    out: &mut [(f64, f64)],
) -> Result<GapFill, TrackingError> {
    config.hampel.validate()?;
    if config.neighbours_per_side == 0 {
        return Err(TrackingError::InvalidParameter);
    }
    if !all_finite(positions_m) {
        return Err(TrackingError::NonFinite);
    }
    let n = positions_m.len();
    let mut report = GapFill::default();
    for g in 0..n.saturating_sub(1) {
        match gap_at(positions_m, g, config) {
            Gap::Fill(m) => report.inserted += m,
            Gap::Skip => report.skipped_gaps += 1,
            Gap::None => {}
        }
    }
    report.len = n + report.inserted;
    if out.len() < report.len {
        return Err(TrackingError::OutputTooSmall);
    }
    let mut w = 0;
    for (g, &p) in positions_m.iter().enumerate() {
        if let Some(slot) = out.get_mut(w) {
            *slot = p;
        }
        w += 1;
        if let Gap::Fill(m) = gap_at(positions_m, g, config) {
            if let Some(dst) = out.get_mut(w..w + m) {
                fill_one_gap(positions_m, config, g, m, dst);
            }
            w += m;
        }
    }
    Ok(report)
}
