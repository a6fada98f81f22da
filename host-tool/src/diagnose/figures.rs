//! The diagnosis' figures (drawn with [`crate::plot`]): the held-out residual of every turn
//! against R/R′ before and after adding the effect, one panel per side, and the growth of power
//! through each turn (second minus first half) against R/R′ per side, measured against the
//! models (Eq 21 and every catalogue term predict a constant power through a steady turn).

use super::features::{SideRole, TurnRow};
use super::gaps::{regime_side_label, Gap, GroupStat, Part};
use super::observe::HeldOut;
use crate::plot::{Chart, Figure, Marker, Series, SeriesStyle};
use model_core::kinematics::Regime;
use model_core::Rover;

/// Horizontal offset of the before/after points of one turn in the residual figure (R/R′).
pub const DODGE: f64 = 0.025;

/// The panel of one side against R/R′, titled by the side.
fn side_chart(role: SideRole, y_label: &str) -> Chart {
    Chart::new(format!("{} side", role.id()), "R / R′", y_label)
}

/// Markers at R = B/2 and R = R′ (R/R′ axis).
fn regime_markers(rover: &Rover) -> Vec<Marker> {
    let r_prime = f64::from(rover.r_prime_m());
    let mut out = Vec::new();
    if r_prime > 0.0 {
        out.push(Marker::new(
            f64::from(rover.half_track_m()) / r_prime,
            "B/2",
        ));
    }
    out.push(Marker::new(1.0, "R′"));
    out
}

/// A horizontal line at 0 over the turns' R/R′ range (none without turns).
fn zero_line(rows: &[TurnRow], name: &str) -> Series {
    let xs = rows
        .iter()
        .map(|r| r.r_over_r_prime)
        .filter(|x| x.is_finite());
    let (lo, hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    let points = if lo <= hi {
        vec![(lo.min(0.0), 0.0), (hi, 0.0)]
    } else {
        Vec::new()
    };
    Series::new(name, points, SeriesStyle::Line, 6)
}

/// The side index of `role` in `row` (turns: 0 inner, 1 outer).
fn side_of(row: &TurnRow, role: SideRole) -> usize {
    if row.sides[0].role == role {
        0
    } else {
        1
    }
}

/// The part of `role`.
fn part_of(role: SideRole) -> Part {
    match role {
        SideRole::Inner => Part::Inner,
        SideRole::Outer => Part::Outer,
    }
}

/// Group means with their 95 % intervals, one per regime, at the mean R/R′ of the regime's turns
/// plus `dx` (straights, with no place on the R/R′ axis, are left out); points coloured `colour`.
fn regime_means(
    rows: &[TurnRow],
    name: &str,
    groups: impl Iterator<Item = (Regime, f64, (f64, f64))>,
    colour: usize,
    dx: f64,
) -> Series {
    let (points, intervals) = groups
        .filter_map(|(regime, mean, ci)| {
            let xs: Vec<f64> = rows
                .iter()
                .filter(|r| r.regime == regime && !r.is_straight())
                .map(|r| r.r_over_r_prime)
                .collect();
            let x = xs.iter().sum::<f64>() / xs.len() as f64;
            (!xs.is_empty()).then_some(((x + dx, mean), ci))
        })
        .unzip();
    Series::new(name, points, SeriesStyle::Points, colour).with_intervals(intervals)
}

/// The gaps of one side (the mean effective-power residual per regime of the `baseline` so
/// named, with its 95 % interval).
fn gap_series(rows: &[TurnRow], gaps: &[Gap], role: SideRole, baseline: &str) -> Series {
    let part = part_of(role);
    let groups = gaps
        .iter()
        .filter(|g| g.side == part)
        .map(|g| (g.regime, g.mean_w, g.ci_w));
    // Between the before (−DODGE) and after (+DODGE) points.
    regime_means(
        rows,
        &format!("regime mean gap, 95 % CI ({baseline})"),
        groups,
        2,
        0.0,
    )
}

/// Held-out effective-power residual of every turn against R/R′, before (the baseline, named
/// `baseline` in the legend) and after adding `effect`, inner and outer side in two panels;
/// before and after are drawn [`DODGE`] left and right of the turn's R/R′, and the `gaps` (per
/// regime and side, the diagnosis' bootstrap 95 % intervals) as bars at their regime's mean
/// R/R′. Straights (R/R′ = ∞) are not drawn.
pub fn residuals_vs_radius(
    rover: &Rover,
    rows: &[TurnRow],
    before: &HeldOut,
    after: &HeldOut,
    baseline: &str,
    effect: &str,
    gaps: &[Gap],
) -> Figure {
    let charts = [SideRole::Inner, SideRole::Outer]
        .into_iter()
        .map(|role| {
            let mut chart = side_chart(role, "held-out residual, measured − model [W]");
            // Before and after are dodged by ∓DODGE in R/R′ so that equal residuals (where the
            // effect adds nothing) stay visible.
            let points = |res: &HeldOut, dx: f64| {
                res.iter()
                    .filter_map(|r| {
                        let row = rows.get(r.row)?;
                        // A total-only row (a per-turn table) has no side to draw.
                        if row.is_straight() || row.is_total_only() {
                            return None;
                        }
                        let w = *r.effective_w.get(side_of(row, role))?;
                        Some((row.r_over_r_prime + dx, w))
                    })
                    .collect::<Vec<_>>()
            };
            chart.series.push(Series::new(
                baseline,
                points(before, -DODGE),
                SeriesStyle::Points,
                1,
            ));
            chart.series.push(Series::new(
                format!("+ {effect}"),
                points(after, DODGE),
                SeriesStyle::Points,
                0,
            ));
            chart.series.push(gap_series(rows, gaps, role, baseline));
            chart.series.push(zero_line(rows, ""));
            chart.markers = regime_markers(rover);
            chart
        })
        .collect();
    Figure::new(
        format!("Held-out residual before and after adding {effect}"),
        charts,
        2,
    )
    .share_y()
}

/// Growth of average power through each turn (second half minus first half of its steady part)
/// against R/R′, inner and outer side, with the models' growth (none).
///
/// `phases` are the diagnosis' growth groups per regime and side
/// ([`super::WhereAnalysis::phase_by_regime_side`]): their means with 95 % bootstrap intervals
/// are drawn as bars.
pub fn growth_vs_radius(rover: &Rover, rows: &[TurnRow], phases: &[GroupStat]) -> Figure {
    let charts = [SideRole::Inner, SideRole::Outer]
        .into_iter()
        .map(|role| {
            let mut chart = side_chart(role, "growth through the turn [W]");
            let measured = rows
                .iter()
                .filter(|r| !r.is_straight())
                .filter_map(|r| {
                    r.sides[side_of(r, role)]
                        .growth_w
                        .map(|g| (r.r_over_r_prime, g))
                })
                .collect();
            chart
                .series
                .push(Series::new("measured", measured, SeriesStyle::Points, 0));
            let part = part_of(role);
            let groups = Regime::ALL.into_iter().filter_map(|regime| {
                let label = regime_side_label(regime, part);
                let g = phases.iter().find(|g| g.group == label)?;
                Some((regime, g.mean, g.ci))
            });
            chart
                .series
                // Beside the turns (a regime of one radius would hide them).
                .push(regime_means(rows, "regime mean, 95 % CI", groups, 2, DODGE));
            chart
                .series
                .push(zero_line(rows, "models (constant power)"));
            chart.markers = regime_markers(rover);
            chart
        })
        .collect();
    Figure::new("Power growth through the turn", charts, 2).share_y()
}
