//! Post-processing of the total-station track of the rover's landmark prism (Section 5.1): data-loss
//! correction (Hampel filter on the step distances and quadratic gap filling), the circle fit that
//! gives the actual turning radius R_ACT, the heading θ_H and the four wheel positions
//! (Eq 5.3–5.9), the wheels' actual speeds and directions (Eq 5.10–5.13) with a moving-average
//! filter, and the measured yaw rate behind the angular slip (Eq 6.3) and the time to complete a
//! turn (Fig. 6.7).
//!
//! Host post-processing in `f64`, `no_std` and allocation-free: functions read slices and write
//! into caller-provided output slices, returning how much they wrote.
//!
//! Frames and conventions: positions are (x, y) in the total-station frame [m]. Like every turn in
//! the seed, tracks are **left turns** (counter-clockwise seen from above) with the prism mounted
//! δx_lp = 0.21 m to the right of the rover's centre (Fig. 5.3), i.e. outboard of the turn.
//! Angles are in radians, yaw positive counter-clockwise.
#![warn(missing_docs)]

use crate::fit::{FitError, LinearFit};
use crate::geometry::Rover;
use crate::kinematics::{self, SlipAngles};
use core::f64::consts::{FRAC_PI_2, TAU};

/// The total station samples the prism at 5 Hz (Section 5.1): δt = 0.2 s.
pub const TOTAL_STATION_PERIOD_S: f64 = 0.2;

/// δx_lp: lateral offset of the landmark prism from the rover's centre, to its right (Fig. 5.3).
pub const PRISM_OFFSET_M: f64 = 0.21;

/// Window of the moving-average filter applied to the wheel speeds (Section 5.1).
pub const MOVING_AVERAGE_WINDOW: usize = 3;

/// Largest Hampel half-window supported (the window lives on the stack).
pub const MAX_HAMPEL_HALF_WINDOW: usize = 16;

/// Scales a median absolute deviation to a normal standard deviation: 1/(√2 erf⁻¹(½)) ≈ 1.4826,
/// as MATLAB's `hampel` does.
pub const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602;

/// Iterations of the geometric (Gauss–Newton) refinement of the circle fit.
const CIRCLE_GAUSS_NEWTON_ITERATIONS: usize = 50;

/// Why a track cannot be processed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackingError {
    /// Not enough points (a circle needs 3; a speed or a rate needs 2).
    TooFewPoints,
    /// NaN or infinite input, or an overflowing result.
    NonFinite,
    /// Geometry without an answer: collinear or coincident points (no circle), a prism at the
    /// circle's centre (no heading).
    Degenerate,
    /// Input slices of different lengths.
    LengthMismatch,
    /// The output slice cannot hold the result.
    OutputTooSmall,
    /// A parameter outside its domain (a non-positive period, a negative offset, a Hampel window
    /// beyond [`MAX_HAMPEL_HALF_WINDOW`]…).
    InvalidParameter,
}

impl core::fmt::Display for TrackingError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            TrackingError::TooFewPoints => "too few points",
            TrackingError::NonFinite => "non-finite input or result",
            TrackingError::Degenerate => "degenerate geometry",
            TrackingError::LengthMismatch => "input slices differ in length",
            TrackingError::OutputTooSmall => "output slice too small",
            TrackingError::InvalidParameter => "parameter outside its domain",
        })
    }
}

impl From<FitError> for TrackingError {
    fn from(e: FitError) -> Self {
        match e {
            FitError::TooFewSamples => TrackingError::TooFewPoints,
            FitError::NonFinite => TrackingError::NonFinite,
            FitError::Singular => TrackingError::Degenerate,
            FitError::LengthMismatch => TrackingError::LengthMismatch,
            FitError::InvalidParameter => TrackingError::InvalidParameter,
        }
    }
}

fn all_finite(points: &[(f64, f64)]) -> bool {
    points.iter().all(|(x, y)| x.is_finite() && y.is_finite())
}

fn check_period(dt_s: f64) -> Result<(), TrackingError> {
    if dt_s.is_finite() && dt_s > 0.0 {
        Ok(())
    } else {
        Err(TrackingError::InvalidParameter)
    }
}

/// Wraps an angle to [−π, π].
fn wrap_angle_rad(a: f64) -> f64 {
    a - TAU * libm::round(a / TAU)
}

// ---------------------------------------------------------------------------------------------
// Circle fit and actual radius
// ---------------------------------------------------------------------------------------------

/// A circle in the total-station frame: (x − x_c)² + (y − y_c)² = R² (Section 5.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// x_c [m].
    pub centre_x_m: f64,
    /// y_c [m].
    pub centre_y_m: f64,
    /// R (R_lp for the prism track) [m].
    pub radius_m: f64,
}

/// Fits (x − x_c)² + (y − y_c)² = R_lp² to the prism track (Section 5.1, circle fit before
/// Eq 5.1): the algebraic (Kåsa) fit, then Gauss–Newton iterations on the geometric distances
/// Σ (‖p_k − c‖ − R)², which remove the Kåsa fit's bias towards small radii on partial arcs.
///
/// Coordinates are centred on the centroid and scaled before fitting, so a total station far
/// from the origin costs no precision. Errors: fewer than 3 points → `TooFewPoints`; NaN/∞ →
/// `NonFinite`; collinear or coincident points → `Degenerate`.
pub fn fit_circle(points_m: &[(f64, f64)]) -> Result<Circle, TrackingError> {
    if points_m.len() < 3 {
        return Err(TrackingError::TooFewPoints);
    }
    if !all_finite(points_m) {
        return Err(TrackingError::NonFinite);
    }
    let n = points_m.len() as f64;
    let mean_x = points_m.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = points_m.iter().map(|p| p.1).sum::<f64>() / n;
    let spread_sq = points_m
        .iter()
        .map(|p| (p.0 - mean_x) * (p.0 - mean_x) + (p.1 - mean_y) * (p.1 - mean_y))
        .sum::<f64>()
        / n;
    let scale = libm::sqrt(spread_sq);
    if !scale.is_finite() || !mean_x.is_finite() || !mean_y.is_finite() {
        return Err(TrackingError::NonFinite);
    }
    if scale == 0.0 {
        return Err(TrackingError::Degenerate);
    }
    let normalised = |p: &(f64, f64)| ((p.0 - mean_x) / scale, (p.1 - mean_y) / scale);

    // Kåsa: u² + v² + D u + E v + F = 0 is linear in (D, E, F).
    let mut kasa = LinearFit::<3>::new();
    for p in points_m {
        let (u, v) = normalised(p);
        kasa.add([u, v, 1.0], -(u * u + v * v))?;
    }
    let [d, e, f] = kasa.coefficients()?;
    let (mut a, mut b) = (-d / 2.0, -e / 2.0);
    let r_sq = a * a + b * b - f;
    if r_sq.is_nan() || r_sq <= 0.0 {
        return Err(TrackingError::Degenerate);
    }
    let mut r = libm::sqrt(r_sq);

    // Gauss–Newton on the geometric residuals ‖p − c‖ − R, with step halving.
    let cost = |a: f64, b: f64, r: f64| -> f64 {
        points_m
            .iter()
            .map(|p| {
                let (u, v) = normalised(p);
                let res = libm::hypot(u - a, v - b) - r;
                res * res
            })
            .sum()
    };
    let mut current = cost(a, b, r);
    for _ in 0..CIRCLE_GAUSS_NEWTON_ITERATIONS {
        let mut step = LinearFit::<3>::new();
        for p in points_m {
            let (u, v) = normalised(p);
            let (du, dv) = (u - a, v - b);
            let dist = libm::hypot(du, dv);
            if dist > 0.0 {
                // Only non-finite rows can be refused; such a row is simply left out.
                let _ = step.add([-du / dist, -dv / dist, -1.0], r - dist);
            }
        }
        let Ok(delta) = step.coefficients() else {
            break;
        };
        let mut lambda = 1.0;
        let mut accepted = false;
        for _ in 0..20 {
            let (na, nb, nr) = (
                a + lambda * delta[0],
                b + lambda * delta[1],
                r + lambda * delta[2],
            );
            let c = cost(na, nb, nr);
            if c <= current {
                (a, b, r, current) = (na, nb, nr, c);
                accepted = true;
                break;
            }
            lambda *= 0.5;
        }
        let step_size = lambda * libm::sqrt(delta.iter().map(|v| v * v).sum::<f64>());
        if !accepted || step_size.is_nan() || step_size <= 1e-13 {
            break;
        }
    }
    let circle = Circle {
        centre_x_m: mean_x + a * scale,
        centre_y_m: mean_y + b * scale,
        radius_m: libm::fabs(r) * scale,
    };
    if circle.centre_x_m.is_finite() && circle.centre_y_m.is_finite() && circle.radius_m.is_finite()
    {
        Ok(circle)
    } else {
        Err(TrackingError::NonFinite)
    }
}

/// R_ACT = R_lp − δx_lp (Section 5.1, before Eq 5.1): the radius driven by the rover's centre for a
/// **left** turn, whose prism sits δx_lp outboard of the centre (use [`PRISM_OFFSET_M`]).
///
/// A fitted prism circle smaller than the offset can only come from noise around a point turn; it
/// gives R_ACT = 0 rather than a negative radius (our choice). Right turns are not covered (the
/// prism would be inboard, and R_lp = |R_ACT − δx_lp| does not determine R_ACT).
pub fn actual_radius_m(circle: &Circle, prism_offset_m: f64) -> Result<f64, TrackingError> {
    if !(prism_offset_m.is_finite() && prism_offset_m >= 0.0) {
        return Err(TrackingError::InvalidParameter);
    }
    if !circle.radius_m.is_finite() {
        return Err(TrackingError::NonFinite);
    }
    Ok((circle.radius_m - prism_offset_m).max(0.0))
}

/// Eq 5.1–5.2 for a measured track: R_ACT from the fitted prism circle ([`actual_radius_m`]), then
/// [`kinematics::slip_angles`] with the actual R'_ACT of the terrain.
pub fn measured_slip_angles(
    circle: &Circle,
    prism_offset_m: f64,
    r_prime_act_m: f64,
    rover: &Rover,
) -> Result<SlipAngles, TrackingError> {
    if !r_prime_act_m.is_finite() {
        return Err(TrackingError::NonFinite);
    }
    let r_act = actual_radius_m(circle, prism_offset_m)?;
    Ok(kinematics::slip_angles(
        r_act as f32,
        r_prime_act_m as f32,
        rover,
    ))
}

// ---------------------------------------------------------------------------------------------
// Hampel filter and data-loss correction
// ---------------------------------------------------------------------------------------------

/// Parameters of the Hampel identifier (Section 5.1 uses MATLAB's defaults: 3 and 3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HampelConfig {
    /// k: neighbours on each side of a sample in its window (window 2k + 1), at most
    /// [`MAX_HAMPEL_HALF_WINDOW`].
    pub half_window: usize,
    /// A sample is an outlier when it lies more than this many scaled MADs from its window median.
    pub n_sigmas: f64,
}

impl Default for HampelConfig {
    fn default() -> Self {
        Self {
            half_window: 3,
            n_sigmas: 3.0,
        }
    }
}

impl HampelConfig {
    fn validate(&self) -> Result<(), TrackingError> {
        if self.half_window <= MAX_HAMPEL_HALF_WINDOW
            && self.n_sigmas.is_finite()
            && self.n_sigmas >= 0.0
        {
            Ok(())
        } else {
            Err(TrackingError::InvalidParameter)
        }
    }
}

/// What the Hampel identifier says about one sample (MATLAB's `xmedian`, `xsigma` and `j`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HampelPoint {
    /// Median of the sample's window.
    pub median: f64,
    /// 1.4826 × the median absolute deviation of the window from that median.
    pub sigma: f64,
    /// |x − median| > n_sigmas · sigma (strictly).
    pub outlier: bool,
}

/// Median of a small window, sorted in place; the mean of the two middle values for an even count
/// (MATLAB's `median`).
fn median_in_place(w: &mut [f64]) -> f64 {
    w.sort_unstable_by(f64::total_cmp);
    let n = w.len();
    match (w.get(n.wrapping_sub(1) / 2), w.get(n / 2)) {
        (Some(lo), Some(hi)) => (lo + hi) / 2.0,
        _ => f64::NAN,
    }
}

/// The Hampel identifier at sample `i` of a series of `len` values given by `value`.
fn hampel_at(
    len: usize,
    value: impl Fn(usize) -> f64,
    i: usize,
    config: &HampelConfig,
) -> HampelPoint {
    // MATLAB semantics at the edges: the window is truncated to the samples that exist.
    let k = config.half_window.min(MAX_HAMPEL_HALF_WINDOW);
    let lo = i.saturating_sub(k);
    let hi = i.saturating_add(k).min(len.saturating_sub(1));
    let mut buf = [0.0; 2 * MAX_HAMPEL_HALF_WINDOW + 1];
    let mut count = 0;
    for (slot, j) in buf.iter_mut().zip(lo..=hi) {
        *slot = value(j);
        count += 1;
    }
    let window = &mut buf[..count];
    let median = median_in_place(window);
    for v in window.iter_mut() {
        *v = libm::fabs(*v - median);
    }
    let sigma = MAD_TO_SIGMA * median_in_place(window);
    let x = value(i);
    HampelPoint {
        median,
        sigma,
        outlier: libm::fabs(x - median) > config.n_sigmas * sigma,
    }
}

/// The Hampel identifier over a series, as MATLAB's `hampel(x, k, nsigma)` (Section 5.1): each
/// sample's window is the sample and k neighbours per side; the sample is an outlier if it differs
/// from the window median by more than `n_sigmas` × 1.4826 × MAD.
///
/// Edges follow MATLAB: near the ends the window is truncated to the samples that exist (k + 1
/// samples at the first one), and an even-sized window's median is the mean of its two middle
/// values. Unlike MATLAB, which skips NaNs, any NaN/∞ is refused (`NonFinite`). A window whose MAD
/// is 0 flags any sample that differs from the median at all. Writes one [`HampelPoint`] per
/// value into `out` and returns the number of outliers.
pub fn hampel(
    values: &[f64],
    config: &HampelConfig,
    out: &mut [HampelPoint],
) -> Result<usize, TrackingError> {
    config.validate()?;
    if out.len() < values.len() {
        return Err(TrackingError::OutputTooSmall);
    }
    if values.iter().any(|v| !v.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    let value = |j: usize| values.get(j).copied().unwrap_or(f64::NAN);
    let mut outliers = 0;
    for (i, slot) in out.iter_mut().enumerate().take(values.len()) {
        *slot = hampel_at(values.len(), value, i, config);
        outliers += usize::from(slot.outlier);
    }
    Ok(outliers)
}

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

// ---------------------------------------------------------------------------------------------
// Heading and wheel positions
// ---------------------------------------------------------------------------------------------

/// Eq 5.4: θ_H^f, the angle of the Husky frame in the total-station frame at the end of the turn,
/// from the final prism position and the fitted circle's centre. The prism lies on the rover's
/// lateral (X) axis, which for a left turn points away from the turn centre, so θ_H is the
/// direction from the centre to the prism. Computed with `atan2` (the seed's tan⁻¹ of a ratio,
/// resolved to the full circle).
pub fn final_heading_rad(circle: &Circle, final_prism_m: (f64, f64)) -> Result<f64, TrackingError> {
    let dx = final_prism_m.0 - circle.centre_x_m;
    let dy = final_prism_m.1 - circle.centre_y_m;
    if !(dx.is_finite() && dy.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    if dx == 0.0 && dy == 0.0 {
        return Err(TrackingError::Degenerate);
    }
    Ok(libm::atan2(dy, dx))
}

/// Eq 5.5: θ_H = (θ_H^f − ψ^f) + ψ for every sample: the IMU yaw ψ shifted so that its last value
/// matches the circle-fit heading θ_H^f of the last prism position (Eq 5.4).
///
/// `yaw_rad` must be sampled at the prism positions' times (one per position, same length; the
/// caller resamples the IMU onto the corrected 5 Hz time base). Writes θ_H into `out` and returns
/// the count. The yaw is not unwrapped: θ_H only enters through sin and cos (Eq 5.3).
pub fn corrected_headings_rad(
    circle: &Circle,
    prism_m: &[(f64, f64)],
    yaw_rad: &[f64],
    out: &mut [f64],
) -> Result<usize, TrackingError> {
    if prism_m.len() != yaw_rad.len() {
        return Err(TrackingError::LengthMismatch);
    }
    let (Some(&final_prism), Some(&final_yaw)) = (prism_m.last(), yaw_rad.last()) else {
        return Err(TrackingError::TooFewPoints);
    };
    if out.len() < yaw_rad.len() {
        return Err(TrackingError::OutputTooSmall);
    }
    if yaw_rad.iter().any(|v| !v.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    let offset = final_heading_rad(circle, final_prism)? - final_yaw;
    for (o, &psi) in out.iter_mut().zip(yaw_rad) {
        *o = offset + psi;
    }
    Ok(yaw_rad.len())
}

/// The four wheel-contact positions in the total-station frame [m] (Eq 5.6–5.9). Inner and outer
/// refer to a left turn: the inner wheels are on the rover's left.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelPositions {
    /// Eq 5.6: inner (left) front wheel.
    pub inner_front_m: (f64, f64),
    /// Eq 5.7: inner (left) back wheel.
    pub inner_back_m: (f64, f64),
    /// Eq 5.8: outer (right) front wheel.
    pub outer_front_m: (f64, f64),
    /// Eq 5.9: outer (right) back wheel.
    pub outer_back_m: (f64, f64),
}

/// Eq 5.3 and 5.6–5.9: wheel positions from the prism position (x_lp, y_lp) and heading θ_H, with
/// the rover's B and L and the prism's offset δx_lp: inner front at (−δx_lp − B/2, L/2), inner
/// back (−δx_lp − B/2, −L/2), outer front (−δx_lp + B/2, L/2), outer back (−δx_lp + B/2, −L/2) in
/// the prism frame, rotated by θ_H and shifted to the prism.
pub fn wheel_positions(
    prism_m: (f64, f64),
    theta_h_rad: f64,
    rover: &Rover,
    prism_offset_m: f64,
) -> WheelPositions {
    let half_b = f64::from(rover.track_width_m) / 2.0;
    let half_l = f64::from(rover.length_m) / 2.0;
    let (s, c) = libm::sincos(theta_h_rad);
    let to_ts = |(bx, by): (f64, f64)| (c * bx - s * by + prism_m.0, s * bx + c * by + prism_m.1);
    WheelPositions {
        inner_front_m: to_ts((-prism_offset_m - half_b, half_l)),
        inner_back_m: to_ts((-prism_offset_m - half_b, -half_l)),
        outer_front_m: to_ts((-prism_offset_m + half_b, half_l)),
        outer_back_m: to_ts((-prism_offset_m + half_b, -half_l)),
    }
}

// ---------------------------------------------------------------------------------------------
// Wheel velocities
// ---------------------------------------------------------------------------------------------

/// Eq 5.10: a wheel's speed ‖v(t)‖ = ‖p(t) − p(t − 1)‖ / δt [m/s].
pub fn speed_mps(from_m: (f64, f64), to_m: (f64, f64), dt_s: f64) -> f64 {
    libm::hypot(to_m.0 - from_m.0, to_m.1 - from_m.1) / dt_s
}

/// Eq 5.11: direction of a wheel's velocity in the total-station frame, 90° + the direction from
/// the circle centre to the wheel (`atan2`), i.e. the tangent of counter-clockwise motion about
/// the centre (left turns) [rad], in (−π/2, 3π/2] (not wrapped).
pub fn velocity_direction_rad(wheel_m: (f64, f64), circle: &Circle) -> f64 {
    FRAC_PI_2 + libm::atan2(wheel_m.1 - circle.centre_y_m, wheel_m.0 - circle.centre_x_m)
}

/// Eq 5.10 and 5.12–5.13: the inner and outer wheels' actual speeds ‖v_i^ACT‖ and ‖v_o^ACT‖ (mean
/// of front and back) from the prism track and the heading θ_H (Eq 5.5), wheel positions by
/// Eq 5.6–5.9.
///
/// Speed k is over the interval from sample k to sample k + 1 (the seed's time t = k + 1), so n
/// positions give n − 1 speeds, written to `inner_mps_out` and `outer_mps_out`; returns n − 1 (0
/// for fewer than 2 positions).
pub fn inner_outer_speeds(
    prism_m: &[(f64, f64)],
    theta_h_rad: &[f64],
    rover: &Rover,
    prism_offset_m: f64,
    dt_s: f64,
    inner_mps_out: &mut [f64],
    outer_mps_out: &mut [f64],
) -> Result<usize, TrackingError> {
    check_period(dt_s)?;
    if prism_m.len() != theta_h_rad.len() {
        return Err(TrackingError::LengthMismatch);
    }
    if !(prism_offset_m.is_finite() && prism_offset_m >= 0.0) {
        return Err(TrackingError::InvalidParameter);
    }
    if !all_finite(prism_m) || theta_h_rad.iter().any(|v| !v.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    let count = prism_m.len().saturating_sub(1);
    if inner_mps_out.len() < count || outer_mps_out.len() < count {
        return Err(TrackingError::OutputTooSmall);
    }
    let wheels = |k: usize| {
        let p = prism_m.get(k).copied().unwrap_or((f64::NAN, f64::NAN));
        let th = theta_h_rad.get(k).copied().unwrap_or(f64::NAN);
        wheel_positions(p, th, rover, prism_offset_m)
    };
    let outputs = inner_mps_out.iter_mut().zip(outer_mps_out.iter_mut());
    for (k, (inner, outer)) in outputs.enumerate().take(count) {
        let (a, b) = (wheels(k), wheels(k + 1));
        let v = |from, to| speed_mps(from, to, dt_s);
        *inner = (v(a.inner_front_m, b.inner_front_m) + v(a.inner_back_m, b.inner_back_m)) / 2.0;
        *outer = (v(a.outer_front_m, b.outer_front_m) + v(a.outer_back_m, b.outer_back_m)) / 2.0;
    }
    let finite = |out: &[f64]| out.iter().take(count).all(|v| v.is_finite());
    if finite(inner_mps_out) && finite(outer_mps_out) {
        Ok(count)
    } else {
        Err(TrackingError::NonFinite)
    }
}

/// The moving-average filter applied to the wheel speeds (Section 5.1, window
/// [`MOVING_AVERAGE_WINDOW`] = 3, "starting at the third sample of the set"): a trailing mean,
/// out[j] = mean(input[j ..= j + window − 1]), aligned with input sample j + window − 1. So the
/// first output belongs to the third input sample, and n inputs give n − window + 1 outputs (0 if
/// n < window). Returns the count.
pub fn moving_average(
    input: &[f64],
    window: usize,
    out: &mut [f64],
) -> Result<usize, TrackingError> {
    if window == 0 {
        return Err(TrackingError::InvalidParameter);
    }
    if input.iter().any(|v| !v.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    let count = (input.len() + 1).saturating_sub(window);
    if out.len() < count {
        return Err(TrackingError::OutputTooSmall);
    }
    for (o, w) in out.iter_mut().zip(input.windows(window)) {
        *o = w.iter().sum::<f64>() / window as f64;
    }
    Ok(count)
}

// ---------------------------------------------------------------------------------------------
// Measured yaw rate, angular slip and time to turn
// ---------------------------------------------------------------------------------------------

/// The angle the prism sweeps about the fitted circle's centre over the track, unwrapped,
/// positive counter-clockwise [rad]. For a rigid turn about a fixed centre this is the heading
/// change. Successive positions must be less than π apart as seen from the centre.
pub fn swept_angle_rad(circle: &Circle, prism_m: &[(f64, f64)]) -> Result<f64, TrackingError> {
    if prism_m.len() < 2 {
        return Err(TrackingError::TooFewPoints);
    }
    if !all_finite(prism_m) {
        return Err(TrackingError::NonFinite);
    }
    let angle = |p: &(f64, f64)| libm::atan2(p.1 - circle.centre_y_m, p.0 - circle.centre_x_m);
    let swept: f64 = prism_m
        .windows(2)
        .map(|w| match w {
            [a, b] => wrap_angle_rad(angle(b) - angle(a)),
            _ => 0.0,
        })
        .sum();
    if swept.is_finite() {
        Ok(swept)
    } else {
        Err(TrackingError::NonFinite)
    }
}

/// The mean actual yaw rate ω_z^ACT of a turn from its prism track: [`swept_angle_rad`] over the
/// elapsed time (n − 1) δt [rad/s] (Eq 6.3's ω_z^ACT, Fig. 6.8's "average actual angular
/// velocity").
pub fn yaw_rate_from_track_rad_s(
    circle: &Circle,
    prism_m: &[(f64, f64)],
    dt_s: f64,
) -> Result<f64, TrackingError> {
    check_period(dt_s)?;
    let swept = swept_angle_rad(circle, prism_m)?;
    Ok(swept / ((prism_m.len() - 1) as f64 * dt_s))
}

/// The net heading change of a yaw series, unwrapped sample to sample (each step taken in
/// [−π, π]) [rad].
pub fn heading_change_rad(yaw_rad: &[f64]) -> Result<f64, TrackingError> {
    if yaw_rad.len() < 2 {
        return Err(TrackingError::TooFewPoints);
    }
    if yaw_rad.iter().any(|v| !v.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    Ok(yaw_rad
        .windows(2)
        .map(|w| match w {
            [a, b] => wrap_angle_rad(b - a),
            _ => 0.0,
        })
        .sum())
}

/// The mean actual yaw rate from a yaw series sampled every `dt_s`: [`heading_change_rad`] over
/// (n − 1) δt [rad/s].
pub fn yaw_rate_from_headings_rad_s(yaw_rad: &[f64], dt_s: f64) -> Result<f64, TrackingError> {
    check_period(dt_s)?;
    let change = heading_change_rad(yaw_rad)?;
    Ok(change / ((yaw_rad.len() - 1) as f64 * dt_s))
}

/// Eq 6.3 for a measured turn: s_ω = (ω_cmd − ω_act)/ω_cmd with ω_act from the prism track
/// ([`yaw_rate_from_track_rad_s`]), through [`kinematics::angular_slip`]. `Ok(None)` when nothing
/// was commanded. Left turns: both rates positive.
pub fn angular_slip_from_track(
    yaw_rate_cmd_rad_s: f32,
    circle: &Circle,
    prism_m: &[(f64, f64)],
    dt_s: f64,
) -> Result<Option<f32>, TrackingError> {
    if !yaw_rate_cmd_rad_s.is_finite() {
        return Err(TrackingError::NonFinite);
    }
    let actual = yaw_rate_from_track_rad_s(circle, prism_m, dt_s)?;
    Ok(kinematics::angular_slip(yaw_rate_cmd_rad_s, actual as f32))
}

/// Time to complete a heading change (Fig. 6.7: the time to complete a 90° turn) [s]: the first
/// time the unwrapped yaw has moved `heading_change_rad` (> 0, either direction) from its first
/// sample, interpolated linearly between samples `dt_s` apart. `Ok(None)` if the series never gets
/// there.
pub fn time_to_heading_change_s(
    yaw_rad: &[f64],
    dt_s: f64,
    heading_change_rad: f64,
) -> Result<Option<f64>, TrackingError> {
    check_period(dt_s)?;
    if !(heading_change_rad.is_finite() && heading_change_rad > 0.0) {
        return Err(TrackingError::InvalidParameter);
    }
    if yaw_rad.len() < 2 {
        return Err(TrackingError::TooFewPoints);
    }
    if yaw_rad.iter().any(|v| !v.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    let mut turned = 0.0_f64;
    for (k, w) in yaw_rad.windows(2).enumerate() {
        let [a, b] = w else { continue };
        let next = turned + wrap_angle_rad(b - a);
        if libm::fabs(next) >= heading_change_rad {
            let (from, to) = (libm::fabs(turned), libm::fabs(next));
            let frac = ((heading_change_rad - from) / (to - from)).clamp(0.0, 1.0);
            return Ok(Some((k as f64 + frac) * dt_s));
        }
        turned = next;
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::Rng;
    use core::f64::consts::PI;
    use proptest::prelude::*;

    const HUSKY: Rover = Rover::HUSKY_A200;
    const DT: f64 = TOTAL_STATION_PERIOD_S;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    fn dist(a: (f64, f64), b: (f64, f64)) -> f64 {
        (a.0 - b.0).hypot(a.1 - b.1)
    }

    /// A rigid left turn: the rover's centre circles `centre` at radius `r_act_m` with yaw rate
    /// `yaw_rate_rad_s`; θ_H (the rover's X axis, Eq 5.3) points from the centre to the rover.
    #[derive(Debug, Clone, Copy)]
    struct Turn {
        centre: (f64, f64),
        r_act_m: f64,
        yaw_rate_rad_s: f64,
        theta0_rad: f64,
    }

    impl Turn {
        fn theta_h(&self, t_s: f64) -> f64 {
            self.theta0_rad + self.yaw_rate_rad_s * t_s
        }

        /// The prism, δx_lp outboard of the centre.
        fn prism(&self, t_s: f64) -> (f64, f64) {
            let r = self.r_act_m + PRISM_OFFSET_M;
            let th = self.theta_h(t_s);
            (self.centre.0 + r * th.cos(), self.centre.1 + r * th.sin())
        }

        fn track(&self, samples: usize, noise_m: f64, rng: &mut Rng) -> Vec<(f64, f64)> {
            (0..samples)
                .map(|k| {
                    let p = self.prism(k as f64 * DT);
                    (p.0 + noise_m * rng.normal(), p.1 + noise_m * rng.normal())
                })
                .collect()
        }
    }

    /// 90° at the Husky's commanded yaw rate for R ≤ R' (2 v_c / B_s = 0.545 rad/s at 0.3 m/s).
    fn r_prime_turn() -> Turn {
        Turn {
            centre: (3.2, -1.7),
            r_act_m: 0.55,
            yaw_rate_rad_s: 0.6 / 1.1,
            theta0_rad: -2.5,
        }
    }

    fn samples_for(turn: &Turn, angle_rad: f64) -> usize {
        (angle_rad / (turn.yaw_rate_rad_s * DT)).round() as usize + 1
    }

    #[test]
    fn circle_fit_is_exact_on_noiseless_points() {
        let turn = r_prime_turn();
        let track = turn.track(samples_for(&turn, 2.0 * PI) - 1, 0.0, &mut Rng::new(0));
        let c = fit_circle(&track).expect("a circle");
        assert!(close(c.centre_x_m, 3.2, 1e-12) && close(c.centre_y_m, -1.7, 1e-12));
        assert!(close(c.radius_m, 0.76, 1e-12));
        assert!(close(
            actual_radius_m(&c, PRISM_OFFSET_M).expect("valid"),
            0.55,
            1e-12
        ));
        // Three points determine the circle; far from the origin costs nothing.
        let far: Vec<(f64, f64)> = [0.1, 1.3, 2.9]
            .iter()
            .map(|a: &f64| (1.0e4 + 2.0 * a.cos(), -3.0e4 + 2.0 * a.sin()))
            .collect();
        let c = fit_circle(&far).expect("a circle");
        assert!(close(c.centre_x_m, 1.0e4, 1e-8) && close(c.centre_y_m, -3.0e4, 1e-8));
        assert!(close(c.radius_m, 2.0, 1e-9));
    }

    /// Cramér–Rao bound on the SD of the fitted radius for points at `angles_rad` on a circle with
    /// independent noise `sigma_m` in x and y: σ √[(JᵀJ)⁻¹]_rr, J rows (−cos φ, −sin φ, −1).
    fn radius_crb_m(angles_rad: &[f64], sigma_m: f64) -> f64 {
        let mut m = [[0.0f64; 3]; 3];
        for th in angles_rad {
            let j = [-th.cos(), -th.sin(), -1.0];
            for a in 0..3 {
                for b in 0..3 {
                    m[a][b] += j[a] * j[b];
                }
            }
        }
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        sigma_m * ((m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det).sqrt()
    }

    #[test]
    fn circle_fit_recovers_r_act_from_noisy_arcs() {
        // R_ACT = 0.55 m with the prism 0.21 m outboard, 2 mm noise per coordinate, 5 Hz at the
        // commanded 0.545 rad/s.
        let turn = r_prime_turn();
        for (arc_rad, tolerance_m) in [(2.0 * PI, 2e-3), (PI, 5e-3)] {
            let n = samples_for(&turn, arc_rad);
            let mut worst = 0.0_f64;
            for seed in 0..50 {
                let track = turn.track(n, 0.002, &mut Rng::new(seed));
                let c = fit_circle(&track).expect("a circle");
                let r_act = actual_radius_m(&c, PRISM_OFFSET_M).expect("valid");
                worst = worst.max((r_act - 0.55).abs());
            }
            println!(
                "arc {arc_rad:.3} rad, {n} points: worst |R_ACT − 0.55| over 50 seeds {worst:.4} m"
            );
            assert!(worst < tolerance_m, "arc {arc_rad}: {worst}");
        }
        // Partial arcs without noise are exact.
        for arc_rad in [PI / 4.0, PI / 2.0] {
            let track = turn.track(samples_for(&turn, arc_rad), 0.0, &mut Rng::new(0));
            let r_act = actual_radius_m(&fit_circle(&track).expect("a circle"), PRISM_OFFSET_M);
            assert!(close(r_act.expect("valid"), 0.55, 1e-9));
        }
        // A 90° turn is only 15 points: no estimator can promise 5 mm every time (the Cramér–Rao
        // bound on the radius' SD is 4.9 mm here). The fit is unbiased and efficient (RMS error at
        // the bound), and its median error is below 5 mm.
        for (arc_rad, rate) in [
            (PI / 2.0, 0.6 / 1.1),
            (PI / 2.0, 0.3),
            (2.0 * PI / 3.0, 0.6 / 1.1),
        ] {
            let turn = Turn {
                yaw_rate_rad_s: rate,
                ..r_prime_turn()
            };
            let n = samples_for(&turn, arc_rad);
            let angles: Vec<f64> = (0..n).map(|k| turn.theta_h(k as f64 * DT)).collect();
            let crb = radius_crb_m(&angles, 0.002);
            let mut errors: Vec<f64> = (0..2000)
                .map(|seed| {
                    let track = turn.track(n, 0.002, &mut Rng::new(seed));
                    let c = fit_circle(&track).expect("a circle");
                    actual_radius_m(&c, PRISM_OFFSET_M).expect("valid") - 0.55
                })
                .collect();
            let mean = errors.iter().sum::<f64>() / 2000.0;
            let rms = (errors.iter().map(|e| e * e).sum::<f64>() / 2000.0).sqrt();
            errors.iter_mut().for_each(|e| *e = e.abs());
            errors.sort_by(f64::total_cmp);
            let within_5mm = errors.iter().filter(|e| **e < 0.005).count() as f64 / 2000.0;
            println!(
                "arc {arc_rad:.3} rad, {n} points: mean {mean:.5} m, RMS {rms:.5} m (CRB {crb:.5}), \
                 median {:.5} m, 95th pct {:.5} m, within 5 mm {within_5mm:.3}",
                errors[1000], errors[1900]
            );
            assert!(mean.abs() < 0.1 * crb, "biased: {mean}");
            assert!(rms < 1.1 * crb, "RMS {rms} vs CRB {crb}");
            assert!(errors[1000] < 0.005);
        }
    }

    #[test]
    fn circle_fit_is_a_geometric_least_squares_minimum() {
        let turn = r_prime_turn();
        let track = turn.track(samples_for(&turn, PI / 2.0), 0.01, &mut Rng::new(5));
        let c = fit_circle(&track).expect("a circle");
        let cost = |cx: f64, cy: f64, r: f64| -> f64 {
            track.iter().map(|p| (dist(*p, (cx, cy)) - r).powi(2)).sum()
        };
        let best = cost(c.centre_x_m, c.centre_y_m, c.radius_m);
        for (dx, dy, dr) in [
            (1e-4, 0.0, 0.0),
            (0.0, 1e-4, 0.0),
            (0.0, 0.0, 1e-4),
            (1e-4, -1e-4, 1e-4),
        ] {
            for s in [-1.0, 1.0] {
                assert!(
                    cost(
                        c.centre_x_m + s * dx,
                        c.centre_y_m + s * dy,
                        c.radius_m + s * dr
                    ) > best
                );
            }
        }
    }

    #[test]
    fn circle_fit_refuses_degenerate_input() {
        assert_eq!(
            fit_circle(&[(0.0, 0.0), (1.0, 1.0)]),
            Err(TrackingError::TooFewPoints)
        );
        assert_eq!(
            fit_circle(&[(0.0, 0.0), (1.0, 1.0), (2.0, 2.0), (3.5, 3.5)]),
            Err(TrackingError::Degenerate)
        );
        assert_eq!(fit_circle(&[(1.0, 2.0); 5]), Err(TrackingError::Degenerate));
        assert_eq!(
            fit_circle(&[(0.0, 0.0), (1.0, f64::NAN), (2.0, 0.0)]),
            Err(TrackingError::NonFinite)
        );
        let c = Circle {
            centre_x_m: 0.0,
            centre_y_m: 0.0,
            radius_m: 0.2,
        };
        assert_eq!(actual_radius_m(&c, 0.21), Ok(0.0));
        assert_eq!(
            actual_radius_m(&c, -0.1),
            Err(TrackingError::InvalidParameter)
        );
    }

    /// The naive Hampel identifier of MATLAB's "Hampel filter algorithm" example, with allocation:
    /// an independent oracle for [`hampel`].
    fn hampel_oracle(x: &[f64], k: usize, nsigma: f64) -> Vec<HampelPoint> {
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            let n = v.len();
            if n % 2 == 1 {
                v[n / 2]
            } else {
                (v[n / 2 - 1] + v[n / 2]) / 2.0
            }
        };
        (0..x.len())
            .map(|j| {
                let lo = j.saturating_sub(k);
                let hi = (j + k).min(x.len() - 1);
                let mut w: Vec<f64> = x[lo..=hi].to_vec();
                let med = median(&mut w);
                let mut dev: Vec<f64> = x[lo..=hi].iter().map(|v| (v - med).abs()).collect();
                let sd = median(&mut dev) / (0.476_936_276_204_469_9 * 2f64.sqrt());
                HampelPoint {
                    median: med,
                    sigma: sd,
                    outlier: (x[j] - med).abs() > nsigma * sd,
                }
            })
            .collect()
    }

    #[test]
    fn hampel_by_hand_and_at_the_edges() {
        let x = [1.0, 2.0, 3.0, 4.0, 100.0, 5.0, 6.0, 7.0];
        let mut out = [HampelPoint::default(); 8];
        let n = hampel(&x, &HampelConfig::default(), &mut out).expect("valid");
        assert_eq!(n, 1);
        // Sample 4: window [2, 3, 4, 100, 5, 6, 7] → median 5, MAD 2.
        assert!(
            out[4].outlier
                && out[4].median == 5.0
                && close(out[4].sigma, 2.0 * MAD_TO_SIGMA, 1e-12)
        );
        // Sample 0: truncated window [1, 2, 3, 4] → median 2.5, MAD 1.
        assert!(
            !out[0].outlier && out[0].median == 2.5 && close(out[0].sigma, MAD_TO_SIGMA, 1e-12)
        );
        // The last sample's window [100, 5, 6, 7] → median 6.5.
        assert_eq!(out[7].median, 6.5);
        // A constant window (MAD 0) flags any difference at all.
        let mut out = [HampelPoint::default(); 5];
        hampel(
            &[1.0, 1.0, 1.0, 1.0, 1.0 + 1e-12],
            &HampelConfig::default(),
            &mut out,
        )
        .expect("valid");
        assert!(out[4].outlier && !out[3].outlier);
        // k = 0: every window is the sample itself; nothing is an outlier.
        let cfg = HampelConfig {
            half_window: 0,
            n_sigmas: 3.0,
        };
        assert_eq!(hampel(&x, &cfg, &mut [HampelPoint::default(); 8]), Ok(0));
    }

    #[test]
    fn hampel_matches_the_matlab_algorithm() {
        let mut rng = Rng::new(11);
        for trial in 0..50 {
            let n = 1 + trial * 3;
            let mut x: Vec<f64> = (0..n)
                .map(|i| (i as f64 * 0.3).sin() + 0.1 * rng.normal())
                .collect();
            for _ in 0..n / 8 {
                let i = (rng.uniform() * n as f64) as usize % n;
                x[i] += 5.0 * rng.normal();
            }
            for (k, nsigma) in [(3, 3.0), (1, 2.0), (5, 1.0)] {
                let cfg = HampelConfig {
                    half_window: k,
                    n_sigmas: nsigma,
                };
                let mut out = vec![HampelPoint::default(); n];
                let count = hampel(&x, &cfg, &mut out).expect("valid");
                let want = hampel_oracle(&x, k, nsigma);
                for (j, (got, want)) in out.iter().zip(&want).enumerate() {
                    assert_eq!(got.median, want.median, "n {n} k {k} sample {j}");
                    assert!(
                        close(got.sigma, want.sigma, 1e-12),
                        "n {n} k {k} sample {j}"
                    );
                    // The scale constants agree to ~1e-16; a tie at the threshold is possible in
                    // principle but not in this data.
                    assert_eq!(got.outlier, want.outlier, "n {n} k {k} sample {j}");
                }
                assert_eq!(count, want.iter().filter(|p| p.outlier).count());
            }
        }
    }

    #[test]
    fn hampel_refuses_bad_input() {
        let mut out = [HampelPoint::default(); 3];
        let cfg = HampelConfig::default();
        assert_eq!(
            hampel(&[1.0, f64::NAN, 2.0], &cfg, &mut out),
            Err(TrackingError::NonFinite)
        );
        assert_eq!(
            hampel(&[1.0; 4], &cfg, &mut out),
            Err(TrackingError::OutputTooSmall)
        );
        let wide = HampelConfig {
            half_window: MAX_HAMPEL_HALF_WINDOW + 1,
            n_sigmas: 3.0,
        };
        assert_eq!(
            hampel(&[1.0; 3], &wide, &mut out),
            Err(TrackingError::InvalidParameter)
        );
        let bad = HampelConfig {
            half_window: 3,
            n_sigmas: f64::NAN,
        };
        assert_eq!(
            hampel(&[1.0; 3], &bad, &mut out),
            Err(TrackingError::InvalidParameter)
        );
        assert_eq!(hampel(&[], &cfg, &mut []), Ok(0));
    }

    /// Removes samples `at .. at + count` from a 5 Hz track and checks that exactly `count` points
    /// come back, each within 1 cm of the removed truth. Returns the largest error of an inserted
    /// point.
    fn check_refill(
        turn: &Turn,
        n: usize,
        at: usize,
        count: usize,
        noise_m: f64,
        seed: u64,
    ) -> f64 {
        let truth: Vec<(f64, f64)> = (0..n).map(|k| turn.prism(k as f64 * DT)).collect();
        let mut rng = Rng::new(seed);
        let measured: Vec<(f64, f64)> = truth
            .iter()
            .enumerate()
            .filter(|(k, _)| *k < at || *k >= at + count)
            .map(|(_, p)| (p.0 + noise_m * rng.normal(), p.1 + noise_m * rng.normal()))
            .collect();
        let mut out = vec![(0.0, 0.0); n + 20];
        let report = fill_gaps(&measured, &GapFillConfig::default(), &mut out).expect("fits");
        assert_eq!(report.inserted, count, "gap of {count} at {at}");
        assert_eq!(report.len, n);
        assert_eq!(report.skipped_gaps, 0);
        let mut worst = 0.0_f64;
        for k in 0..n {
            let err = dist(out[k], truth[k]);
            let inserted = (at..at + count).contains(&k);
            if inserted {
                worst = worst.max(err);
            }
            let tol = if inserted {
                0.01
            } else {
                5.0 * noise_m + 1e-12
            };
            assert!(
                err < tol,
                "gap of {count} at {at}, sample {k}: off by {err} m"
            );
        }
        // Measured points are copied exactly.
        assert_eq!(out[..at], measured[..at]);
        assert_eq!(out[at + count..n], measured[at..]);
        worst
    }

    #[test]
    fn lost_samples_are_reinserted_one_two_and_three() {
        let turn = r_prime_turn();
        let n = samples_for(&turn, PI / 2.0) + 10; // a 90° turn and a bit (25 samples)
        for count in 1..=3 {
            let (mut clean, mut noisy) = (0.0_f64, 0.0_f64);
            for at in [1, 6, 12, n - count - 1] {
                clean = clean.max(check_refill(&turn, n, at, count, 0.0, 0));
                for seed in 0..10 {
                    noisy = noisy.max(check_refill(&turn, n, at, count, 0.002, seed));
                }
            }
            println!("{count} lost: worst inserted error {clean:.4} m noiseless, {noisy:.4} m with 2 mm noise");
        }
        // Two gaps in one track, within one Hampel window of each other.
        let truth: Vec<(f64, f64)> = (0..n).map(|k| turn.prism(k as f64 * DT)).collect();
        let measured: Vec<(f64, f64)> = truth
            .iter()
            .enumerate()
            .filter(|(k, _)| ![8, 11, 12].contains(k))
            .map(|(_, p)| *p)
            .collect();
        let mut out = vec![(0.0, 0.0); n];
        let report = fill_gaps(&measured, &GapFillConfig::default(), &mut out).expect("fits");
        assert_eq!((report.len, report.inserted), (n, 3));
        for (got, want) in out.iter().zip(&truth) {
            assert!(dist(*got, *want) < 0.01);
        }
    }

    #[test]
    fn point_turn_track_is_refilled_too() {
        // R_ACT = 0: the prism circles the rover's centre at δx_lp (2.3 cm per sample).
        let turn = Turn {
            r_act_m: 0.0,
            ..r_prime_turn()
        };
        let n = samples_for(&turn, PI / 2.0) + 4;
        check_refill(&turn, n, 9, 2, 0.0, 0);
        check_refill(&turn, n, 9, 3, 0.0005, 1);
    }

    #[test]
    fn clean_tracks_are_untouched() {
        let turn = r_prime_turn();
        let mut out = vec![(0.0, 0.0); 40];
        for noise in [0.0, 0.002] {
            let track = turn.track(30, noise, &mut Rng::new(9));
            let report = fill_gaps(&track, &GapFillConfig::default(), &mut out).expect("fits");
            assert_eq!(
                report,
                GapFill {
                    len: 30,
                    inserted: 0,
                    skipped_gaps: 0
                }
            );
            assert_eq!(out[..30], track[..]);
        }
        // A straight line at constant speed.
        let line: Vec<(f64, f64)> = (0..20)
            .map(|k| (0.06 * k as f64, 1.0 + 0.02 * k as f64))
            .collect();
        let report = fill_gaps(&line, &GapFillConfig::default(), &mut out).expect("fits");
        assert_eq!((report.len, report.inserted), (20, 0));
        assert_eq!(out[..20], line[..]);
        // Nothing and one point.
        assert_eq!(
            fill_gaps(&[], &GapFillConfig::default(), &mut []),
            Ok(GapFill::default())
        );
        let one = fill_gaps(&[(1.0, 2.0)], &GapFillConfig::default(), &mut out).expect("fits");
        assert_eq!((one.len, out[0]), (1, (1.0, 2.0)));
    }

    #[test]
    fn gap_filling_reports_errors_and_skips() {
        let turn = r_prime_turn();
        let mut track = turn.track(20, 0.0, &mut Rng::new(0));
        track.remove(10);
        let mut small = vec![(0.0, 0.0); 19];
        assert_eq!(
            fill_gaps(&track, &GapFillConfig::default(), &mut small),
            Err(TrackingError::OutputTooSmall)
        );
        assert_eq!(small, vec![(0.0, 0.0); 19]);
        let none = GapFillConfig {
            max_inserted_per_gap: 0,
            ..GapFillConfig::default()
        };
        let mut out = vec![(0.0, 0.0); 25];
        let report = fill_gaps(&track, &none, &mut out).expect("fits");
        assert_eq!(
            report,
            GapFill {
                len: 19,
                inserted: 0,
                skipped_gaps: 1
            }
        );
        let zero = GapFillConfig {
            neighbours_per_side: 0,
            ..GapFillConfig::default()
        };
        assert_eq!(
            fill_gaps(&track, &zero, &mut out),
            Err(TrackingError::InvalidParameter)
        );
        // One neighbour per side: linear interpolation across the gap.
        let linear = GapFillConfig {
            neighbours_per_side: 1,
            ..GapFillConfig::default()
        };
        let report = fill_gaps(&track, &linear, &mut out).expect("fits");
        assert_eq!(report.inserted, 1);
        let mid = (
            (track[9].0 + track[10].0) / 2.0,
            (track[9].1 + track[10].1) / 2.0,
        );
        assert!(dist(out[10], mid) < 1e-12);
        track[3].0 = f64::NAN;
        assert_eq!(
            fill_gaps(&track, &GapFillConfig::default(), &mut out),
            Err(TrackingError::NonFinite)
        );
    }

    /// What [`process`] computes for a synthetic turn.
    struct Processed {
        circle: Circle,
        track: Vec<(f64, f64)>,
        theta_h: Vec<f64>,
        inner: Vec<f64>,
        outer: Vec<f64>,
    }

    /// Runs Section 5.1 on a synthetic rigid turn: circle fit, Eq 5.4–5.5 headings from an IMU yaw
    /// with an unknown offset (and wrapped), wheel speeds (Eq 5.10, 5.12–5.13).
    fn process(turn: &Turn, n: usize) -> Processed {
        let track = turn.track(n, 0.0, &mut Rng::new(0));
        let yaw: Vec<f64> = (0..n)
            .map(|k| wrap_angle_rad(turn.theta_h(k as f64 * DT) + FRAC_PI_2 - 1.234))
            .collect();
        let circle = fit_circle(&track).expect("a circle");
        let mut theta_h = vec![0.0; n];
        assert_eq!(
            corrected_headings_rad(&circle, &track, &yaw, &mut theta_h),
            Ok(n)
        );
        let (mut inner, mut outer) = (vec![0.0; n - 1], vec![0.0; n - 1]);
        let count = inner_outer_speeds(
            &track,
            &theta_h,
            &HUSKY,
            PRISM_OFFSET_M,
            DT,
            &mut inner,
            &mut outer,
        )
        .expect("valid");
        assert_eq!(count, n - 1);
        Processed {
            circle,
            track,
            theta_h,
            inner,
            outer,
        }
    }

    #[test]
    fn rigid_turn_wheel_speeds_are_yaw_rate_times_distance_to_the_centre() {
        let (b, l) = (f64::from(HUSKY.track_width_m), f64::from(HUSKY.length_m));
        // Below B/2, dragged inner (B/2 < R < R'), at R' and beyond, and a point turn.
        for r_act in [0.0, 0.15, 0.4, 0.55, 0.8, 2.0] {
            let turn = Turn {
                r_act_m: r_act,
                ..r_prime_turn()
            };
            let n = samples_for(&turn, PI / 2.0);
            let Processed {
                track,
                theta_h,
                inner,
                outer,
                ..
            } = process(&turn, n);
            for k in 0..n {
                // Eq 5.5 recovers the true θ_H (mod 2π).
                let err = wrap_angle_rad(theta_h[k] - turn.theta_h(k as f64 * DT));
                assert!(err.abs() < 1e-9, "R {r_act} sample {k}: θ_H off by {err}");
                // The wheels sit where the rover's geometry puts them around its centre.
                let w = wheel_positions(track[k], theta_h[k], &HUSKY, PRISM_OFFSET_M);
                let centre_of_rover = turn.prism(k as f64 * DT);
                let (s, c) = theta_h[k].sin_cos();
                let rover_centre = (
                    centre_of_rover.0 - PRISM_OFFSET_M * c,
                    centre_of_rover.1 - PRISM_OFFSET_M * s,
                );
                let expect = |bx: f64, by: f64| {
                    (
                        rover_centre.0 + c * bx - s * by,
                        rover_centre.1 + s * bx + c * by,
                    )
                };
                assert!(dist(w.inner_front_m, expect(-b / 2.0, l / 2.0)) < 1e-12);
                assert!(dist(w.outer_back_m, expect(b / 2.0, -l / 2.0)) < 1e-12);
            }
            let rho_inner = (r_act - b / 2.0).hypot(l / 2.0);
            let rho_outer = (r_act + b / 2.0).hypot(l / 2.0);
            let omega = turn.yaw_rate_rad_s;
            // Eq 5.10 measures the chord: 2ρ sin(ω δt / 2) / δt, within (ω δt)²/24 of ω ρ.
            let chord = |rho: f64| 2.0 * rho * (omega * DT / 2.0).sin() / DT;
            for k in 0..n - 1 {
                assert!(
                    close(inner[k], chord(rho_inner), 1e-9),
                    "R {r_act}: {} vs {}",
                    inner[k],
                    chord(rho_inner)
                );
                assert!(close(outer[k], chord(rho_outer), 1e-9));
                assert!(close(inner[k], omega * rho_inner, 1e-3 * omega * rho_inner));
                assert!(close(outer[k], omega * rho_outer, 1e-3 * omega * rho_outer));
            }
        }
    }

    #[test]
    fn wheel_velocity_directions_give_the_eq_5_1_slip_angles() {
        // β = angle between a wheel's velocity (Eq 5.11) and its commanded direction: forward
        // (θ_H + 90°) for the outer wheels, and for the inner wheels backward below R'_ACT,
        // forward above (Section 2.1.2).
        let r_prime_act = 0.55;
        for r_act in [0.15, 0.4, 0.8, 2.0] {
            let turn = Turn {
                r_act_m: r_act,
                ..r_prime_turn()
            };
            let n = samples_for(&turn, PI / 2.0);
            let Processed {
                circle,
                track,
                theta_h,
                ..
            } = process(&turn, n);
            let expected =
                measured_slip_angles(&circle, PRISM_OFFSET_M, r_prime_act, &HUSKY).expect("valid");
            assert_eq!(
                expected,
                kinematics::slip_angles(r_act as f32, r_prime_act as f32, &HUSKY)
            );
            for k in 0..n {
                let w = wheel_positions(track[k], theta_h[k], &HUSKY, PRISM_OFFSET_M);
                let forward = theta_h[k] + FRAC_PI_2;
                let inner_cmd = if r_act < r_prime_act {
                    forward + PI
                } else {
                    forward
                };
                let beta = |wheel: (f64, f64), cmd: f64| {
                    wrap_angle_rad(velocity_direction_rad(wheel, &circle) - cmd)
                        .abs()
                        .to_degrees()
                };
                for wheel in [w.outer_front_m, w.outer_back_m] {
                    let got = beta(wheel, forward);
                    assert!(
                        close(got, f64::from(expected.outer_deg), 1e-3),
                        "R {r_act}: {got} vs {expected:?}"
                    );
                }
                for wheel in [w.inner_front_m, w.inner_back_m] {
                    let got = beta(wheel, inner_cmd);
                    assert!(
                        close(got, f64::from(expected.inner_deg), 1e-3),
                        "R {r_act}: {got} vs {expected:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn moving_average_starts_at_the_third_sample() {
        let x = [3.0, 6.0, 9.0, 0.0, 3.0];
        let mut out = [0.0; 3];
        assert_eq!(moving_average(&x, MOVING_AVERAGE_WINDOW, &mut out), Ok(3));
        assert_eq!(out, [6.0, 5.0, 4.0]);
        assert_eq!(moving_average(&x[..2], 3, &mut out), Ok(0));
        assert_eq!(
            moving_average(&x, 3, &mut [0.0; 2]),
            Err(TrackingError::OutputTooSmall)
        );
        assert_eq!(
            moving_average(&x, 0, &mut out),
            Err(TrackingError::InvalidParameter)
        );
        assert_eq!(
            moving_average(&[f64::NAN; 3], 3, &mut out),
            Err(TrackingError::NonFinite)
        );
        let mut same = [0.0; 5];
        assert_eq!(moving_average(&x, 1, &mut same), Ok(5));
        assert_eq!(same, x);
    }

    #[test]
    fn angular_slip_and_time_to_turn_from_a_slow_turn() {
        // Commanded 0.545 rad/s (R' at v_c = 0.3 m/s); the rover only manages 0.4 rad/s.
        let turn = Turn {
            yaw_rate_rad_s: 0.4,
            ..r_prime_turn()
        };
        let n = samples_for(&turn, PI / 2.0) + 5;
        let track = turn.track(n, 0.0, &mut Rng::new(0));
        let circle = fit_circle(&track).expect("a circle");
        let rate = yaw_rate_from_track_rad_s(&circle, &track, DT).expect("valid");
        assert!(close(rate, 0.4, 1e-12));
        let cmd = (0.6 / 1.1) as f32;
        let slip = angular_slip_from_track(cmd, &circle, &track, DT)
            .expect("valid")
            .expect("commanded");
        assert!(close(
            f64::from(slip),
            (f64::from(cmd) - 0.4) / f64::from(cmd),
            1e-6
        ));
        assert_eq!(angular_slip_from_track(0.0, &circle, &track, DT), Ok(None));
        // IMU yaw, wrapped at ±π: the 90° takes (π/2)/0.4 = 3.927 s.
        let yaw: Vec<f64> = (0..n)
            .map(|k| wrap_angle_rad(3.0 + 0.4 * k as f64 * DT))
            .collect();
        assert!(
            yaw.iter().any(|&y| y < 0.0),
            "the series must wrap for this test"
        );
        assert!(close(
            yaw_rate_from_headings_rad_s(&yaw, DT).expect("valid"),
            0.4,
            1e-12
        ));
        assert!(close(
            heading_change_rad(&yaw).expect("valid"),
            0.4 * (n - 1) as f64 * DT,
            1e-12
        ));
        let t = time_to_heading_change_s(&yaw, DT, PI / 2.0)
            .expect("valid")
            .expect("turned");
        assert!(close(t, PI / 2.0 / 0.4, 1e-9), "{t}");
        assert_eq!(time_to_heading_change_s(&yaw, DT, PI), Ok(None));
        // A right turn counts too.
        let right: Vec<f64> = yaw.iter().map(|y| -y).collect();
        let t = time_to_heading_change_s(&right, DT, PI / 2.0)
            .expect("valid")
            .expect("turned");
        assert!(close(t, PI / 2.0 / 0.4, 1e-9));
        assert_eq!(
            time_to_heading_change_s(&yaw, 0.0, 1.0),
            Err(TrackingError::InvalidParameter)
        );
        assert_eq!(
            time_to_heading_change_s(&yaw, DT, -1.0),
            Err(TrackingError::InvalidParameter)
        );
        assert_eq!(
            time_to_heading_change_s(&yaw[..1], DT, 1.0),
            Err(TrackingError::TooFewPoints)
        );
    }

    #[test]
    fn heading_inputs_are_checked() {
        let c = Circle {
            centre_x_m: 0.0,
            centre_y_m: 0.0,
            radius_m: 1.0,
        };
        assert_eq!(
            final_heading_rad(&c, (0.0, 0.0)),
            Err(TrackingError::Degenerate)
        );
        assert!(close(
            final_heading_rad(&c, (-1.0, 0.0)).expect("defined"),
            PI,
            1e-15
        ));
        let mut out = [0.0; 2];
        assert_eq!(
            corrected_headings_rad(&c, &[(1.0, 0.0)], &[0.0, 1.0], &mut out),
            Err(TrackingError::LengthMismatch)
        );
        assert_eq!(
            corrected_headings_rad(&c, &[], &[], &mut out),
            Err(TrackingError::TooFewPoints)
        );
        assert_eq!(
            corrected_headings_rad(&c, &[(1.0, 0.0); 3], &[0.0; 3], &mut out),
            Err(TrackingError::OutputTooSmall)
        );
        let (mut a, mut b) = ([0.0; 1], [0.0; 1]);
        assert_eq!(
            inner_outer_speeds(
                &[(0.0, 0.0), (1.0, 0.0)],
                &[0.0, 0.0],
                &HUSKY,
                0.21,
                0.0,
                &mut a,
                &mut b
            ),
            Err(TrackingError::InvalidParameter)
        );
        assert_eq!(
            inner_outer_speeds(
                &[(0.0, 0.0), (1.0, 0.0)],
                &[0.0, f64::NAN],
                &HUSKY,
                0.21,
                DT,
                &mut a,
                &mut b
            ),
            Err(TrackingError::NonFinite)
        );
        assert_eq!(
            inner_outer_speeds(
                &[(0.0, 0.0), (1.0, 0.0)],
                &[0.0, 0.0],
                &HUSKY,
                0.21,
                DT,
                &mut a,
                &mut b
            ),
            Ok(1)
        );
        assert!(close(a[0], 5.0, 1e-12) && close(b[0], 5.0, 1e-12));
    }

    fn any_f64() -> impl Strategy<Value = f64> {
        prop_oneof![
            6 => -10.0..10.0f64,
            1 => any::<f64>(),
            1 => Just(f64::NAN),
            1 => Just(f64::INFINITY),
            1 => Just(0.0),
        ]
    }

    fn any_points(max: usize) -> impl Strategy<Value = Vec<(f64, f64)>> {
        proptest::collection::vec((any_f64(), any_f64()), 0..max)
    }

    proptest! {
        #[test]
        fn circle_fit_never_panics(points in any_points(40)) {
            if let Ok(c) = fit_circle(&points) {
                prop_assert!(c.radius_m.is_finite() && c.radius_m >= 0.0);
                let _ = actual_radius_m(&c, PRISM_OFFSET_M);
                let _ = measured_slip_angles(&c, PRISM_OFFSET_M, 0.55, &HUSKY);
                let _ = swept_angle_rad(&c, &points);
                let _ = yaw_rate_from_track_rad_s(&c, &points, DT);
                let _ = angular_slip_from_track(0.5, &c, &points, DT);
            }
        }

        #[test]
        fn hampel_never_panics(values in proptest::collection::vec(any_f64(), 0..60), k in 0usize..20, nsigma in any_f64()) {
            let mut out = vec![HampelPoint::default(); values.len()];
            let cfg = HampelConfig { half_window: k, n_sigmas: nsigma };
            if let Ok(n) = hampel(&values, &cfg, &mut out) {
                prop_assert!(n <= values.len());
                if k == 0 { prop_assert_eq!(n, 0); }
            }
        }

        #[test]
        fn gap_filling_never_panics_and_keeps_the_measurements(
            points in any_points(50),
            k in 0usize..5,
            max in 0usize..12,
        ) {
            let cfg = GapFillConfig { neighbours_per_side: k, max_inserted_per_gap: max, ..GapFillConfig::default() };
            let mut out = vec![(0.0, 0.0); points.len() * (1 + max)];
            if let Ok(report) = fill_gaps(&points, &cfg, &mut out) {
                prop_assert_eq!(report.len, points.len() + report.inserted);
                // The measured points appear in order (a subsequence of the output).
                let mut it = out[..report.len].iter();
                for p in &points {
                    prop_assert!(it.any(|q| q == p));
                }
            }
            // A tight buffer is refused or suffices, never overrun.
            let mut tight = vec![(0.0, 0.0); points.len()];
            let _ = fill_gaps(&points, &cfg, &mut tight);
        }

        #[test]
        fn wheel_processing_never_panics(
            rows in proptest::collection::vec((any_f64(), any_f64(), any_f64()), 0..30),
            dt in any_f64(),
            offset in any_f64(),
            change in any_f64(),
        ) {
            let prism: Vec<(f64, f64)> = rows.iter().map(|r| (r.0, r.1)).collect();
            let yaw: Vec<f64> = rows.iter().map(|r| r.2).collect();
            let n = rows.len();
            let (mut inner, mut outer, mut th) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            let _ = inner_outer_speeds(&prism, &yaw, &HUSKY, offset, dt, &mut inner, &mut outer);
            let _ = moving_average(&yaw, 3, &mut inner);
            let _ = time_to_heading_change_s(&yaw, dt, change);
            let _ = yaw_rate_from_headings_rad_s(&yaw, dt);
            let c = Circle { centre_x_m: offset, centre_y_m: change, radius_m: 1.0 };
            let _ = corrected_headings_rad(&c, &prism, &yaw, &mut th);
        }
    }
}
