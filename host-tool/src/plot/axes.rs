//! Axis ranges, tick labels and clipping: what of a chart lands inside its panel.

use super::chart::Chart;
use super::{PlotError, MAX_ABS_COORDINATE};

/// An axis interval (lo, hi).
pub(super) type Span = (f64, f64);

/// A data point (x, y).
pub(super) type Point = (f64, f64);

/// Whether `p` can be placed on an axis.
pub(super) fn drawable(p: (f64, f64)) -> bool {
    let ok = |v: f64| v.is_finite() && v.abs() <= MAX_ABS_COORDINATE;
    ok(p.0) && ok(p.1)
}

/// An explicit range, checked.
fn checked_range(axis: &'static str, (lo, hi): (f64, f64)) -> Result<(f64, f64), PlotError> {
    let bad = |reason| PlotError::BadRange {
        axis,
        lo,
        hi,
        reason,
    };
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(bad("the ends must be finite"));
    }
    if lo.abs().max(hi.abs()) > MAX_ABS_COORDINATE {
        return Err(bad("the ends must lie within ±1e150"));
    }
    if lo >= hi {
        return Err(bad("the lower end must be below the upper end"));
    }
    if hi - lo < lo.abs().max(hi.abs()) * 1e-12 {
        return Err(bad(
            "too narrow for its magnitude (relative width under 1e-12)",
        ));
    }
    Ok((lo, hi))
}

/// An automatic axis range around `values` (finite, within ±[`MAX_ABS_COORDINATE`]): 5 %
/// padding each side; equal values get ±5 % of their magnitude (±1 around 0).
pub(super) fn auto_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values.fold(None, |acc: Option<(f64, f64)>, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })?;
    let magnitude = lo.abs().max(hi.abs());
    let span = hi - lo;
    if span <= magnitude * 1e-9 {
        let half = if magnitude > 0.0 {
            magnitude * 0.05
        } else {
            1.0
        };
        let mid = lo / 2.0 + hi / 2.0;
        return Some((mid - half, mid + half));
    }
    let pad = span * 0.05;
    Some((lo - pad, hi + pad))
}

/// The x and y ranges of `chart` (0..1 for an axis with no data and no range).
pub(super) fn ranges(chart: &Chart) -> Result<(Span, Span), PlotError> {
    let points = || {
        chart
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|&p| drawable(p))
    };
    let markers = chart
        .markers
        .iter()
        .map(|m| m.x)
        .filter(|x| x.is_finite() && x.abs() <= MAX_ABS_COORDINATE);
    let x = match chart.x_range {
        Some(r) => Some(checked_range("x", r)?),
        None => auto_range(points().map(|p| p.0).chain(markers)),
    };
    let y = match chart.y_range {
        Some(r) => Some(checked_range("y", r)?),
        None => auto_range(points().map(|p| p.1).chain(interval_ends(chart))),
    };
    Ok((x.unwrap_or((0.0, 1.0)), y.unwrap_or((0.0, 1.0))))
}

/// The finite ends of the intervals of drawable points (they widen the y range).
pub(super) fn interval_ends(chart: &Chart) -> impl Iterator<Item = f64> + '_ {
    chart
        .series
        .iter()
        .flat_map(|s| s.points.iter().zip(&s.intervals))
        .filter(|(&p, _)| drawable(p))
        .flat_map(|(_, &(lo, hi))| [lo, hi])
        .filter(|v| v.is_finite() && v.abs() <= MAX_ABS_COORDINATE)
}

/// Clips the segment a–b to the box (Liang–Barsky); `None` if it lies outside.
pub(super) fn clip_segment(
    a: (f64, f64),
    b: (f64, f64),
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - x0),
        (dx, x1 - a.0),
        (-dy, a.1 - y0),
        (dy, y1 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
            if t0 > t1 {
                return None;
            }
        }
    }
    // Clamped: rounding in t and in `a + t·d` may land outside a box that is tiny next to the
    // segment, and plotters' pixel mapping overflows far outside its range.
    let at = |t: f64| {
        let p = if t == 0.0 {
            a
        } else if t == 1.0 {
            b
        } else {
            (a.0 + t * dx, a.1 + t * dy)
        };
        (p.0.clamp(x0, x1), p.1.clamp(y0, y1))
    };
    Some((at(t0), at(t1)))
}

/// Whether `p` lies in the box (edges included).
pub(super) fn inside(p: (f64, f64), (x0, x1): Span, (y0, y1): Span) -> bool {
    (x0..=x1).contains(&p.0) && (y0..=y1).contains(&p.1)
}

/// The polylines of `points` inside the box: broken at undrawable points and where the line
/// leaves the box. Also returns the isolated points (drawable, in the box, no drawable
/// neighbour), which a line alone would not show.
pub(super) fn polylines(points: &[Point], x: Span, y: Span) -> (Vec<Vec<Point>>, Vec<Point>) {
    let mut runs = Vec::new();
    let mut isolated = Vec::new();
    let mut current: Vec<(f64, f64)> = Vec::new();
    for run in points.split(|&p| !drawable(p)) {
        if let [p] = run {
            if inside(*p, x, y) {
                isolated.push(*p);
            }
            continue;
        }
        for pair in run.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            match clip_segment(a, b, x, y) {
                None => {
                    if current.len() > 1 {
                        runs.push(std::mem::take(&mut current));
                    }
                    current.clear();
                }
                Some((ca, cb)) => {
                    if current.last() != Some(&ca) {
                        if current.len() > 1 {
                            runs.push(std::mem::take(&mut current));
                        }
                        current.clear();
                        current.push(ca);
                    }
                    current.push(cb);
                    if cb != b {
                        runs.push(std::mem::take(&mut current));
                    }
                }
            }
        }
        if current.len() > 1 {
            runs.push(std::mem::take(&mut current));
        }
        current.clear();
    }
    (runs, isolated)
}

/// A tick label: plain decimals for 1e-3 ≤ |v| < 1e5, otherwise scientific.
pub(super) fn tick_label(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        return "0".into();
    }
    if !(1e-3..1e5).contains(&a) {
        return format!("{v:.2e}");
    }
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}
