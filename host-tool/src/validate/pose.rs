//! What a turn's pose track says (thesis Section 5.1): the tracked point's fixes go through the
//! total-station data-loss correction (Hampel filter on the step distances, quadratic gap
//! filling), a circle is fitted to them, and the tracked point's lateral offset turns the
//! fitted circle into the radius the rover's centre drove, R_ACT. From the same circle: the
//! swept angle and so the measured yaw rate and angular slip (Eq 6.3), the wheels' speeds
//! (Eq 5.6–5.13, with the heading from the circle, Eq 5.4), and, per run, the measured slip
//! track (Appendix D) that makes R′_ACT and the R_ACT/R′_ACT axis of Table 6.1.
//!
//! Every step is `model_core::tracking`'s; this module picks the fixes out of a run, handles
//! both turn directions and offsets on either side, and turns a track that cannot be used into
//! a typed note for that turn ([`TrackNote`]) instead of an error for the run.
//!
//! Frames: a right turn is mirrored (x → −x) into a left turn, so the tracked point's offset
//! changes side. In the left-turn frame the point sits at a along the rover's lateral axis
//! (right positive), so it circles the turn centre at R_lp = |R_ACT + a|; R_ACT = R_lp − a when
//! the point is on the far side of the centre from the rover (a ≥ 0: always, as the thesis'
//! outboard prism), R_ACT = −R_lp − a when the point is between (a < 0 and R_ACT < −a). When both
//! are possible the one nearer the commanded radius is taken, and the turn says so.

use crate::log::run_csv::RunSample;
use model_core::kinematics::{self, SideSpeeds, SlipAngles, TurnDirection};
use model_core::tracking::{self, Circle, GapFillConfig, TrackingError};
use model_core::{Rover, Sides};
use serde::Serialize;
use std::fmt;

/// The samples without their pose fixes: the run as a recorder without a tracker logs it.
pub fn without_positions(samples: &[RunSample]) -> Vec<RunSample> {
    samples
        .iter()
        .map(|s| RunSample {
            x_m: None,
            y_m: None,
            ..*s
        })
        .collect()
}

/// A turn must sweep at least this much about its fitted centre for R_ACT [deg] (a shorter arc
/// pins no circle down).
pub const MIN_SWEPT_DEG: f64 = 15.0;

/// A tracked point that stays within this distance of its mean [m] did not circle anything: the
/// rover turned about that point (R_ACT = |offset|).
pub const STATIONARY_SPREAD_M: f64 = 0.02;

/// Why a turn's track gives no R_ACT, or what to know about the one it gives.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case", tag = "note")]
pub enum TrackNote {
    /// The run has positions, but none in this turn.
    NoFixes,
    /// Fewer fixes than a circle needs (3).
    TooFewFixes {
        /// Fixes in the turn.
        fixes: usize,
    },
    /// The fixes lie on a line (or on one point): no circle.
    Collinear,
    /// The fitted arc sweeps less than [`MIN_SWEPT_DEG`].
    TooShortTurn {
        /// Angle swept about the fitted centre [deg].
        swept_deg: f64,
    },
    /// The tracked point did not move (within [`STATIONARY_SPREAD_M`]): the rover turned about
    /// it; R_ACT is the offset, and the track gives no yaw rate or wheel speeds.
    TurnedAboutTrackedPoint,
    /// The tracked point is inboard and the circle fits two radii (R_lp − a and −R_lp − a);
    /// the one nearer the commanded radius was taken.
    AmbiguousRadius {
        /// The radius not taken [m].
        other_m: f64,
    },
    /// Some position cells held NaN or infinities (skipped, as lost fixes).
    NonFiniteFixes {
        /// How many.
        count: usize,
    },
    /// `model_core::tracking` refused the track (a numerical corner case).
    Refused {
        /// Its reason.
        #[serde(serialize_with = "tracking_error")]
        reason: TrackingError,
    },
}

fn tracking_error<S: serde::Serializer>(e: &TrackingError, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(e)
}

impl fmt::Display for TrackNote {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TrackNote::NoFixes => write!(f, "no position fix in this turn"),
            TrackNote::TooFewFixes { fixes } => {
                write!(f, "{fixes} position fix(es): a circle needs 3")
            }
            TrackNote::Collinear => write!(f, "the fixes lie on a line: no circle"),
            TrackNote::TooShortTurn { swept_deg } => write!(
                f,
                "the track sweeps {swept_deg:.1}° (< {MIN_SWEPT_DEG}°): too short for a radius"
            ),
            TrackNote::TurnedAboutTrackedPoint => {
                write!(f, "the tracked point stood still: R_ACT = |offset|")
            }
            TrackNote::AmbiguousRadius { other_m } => write!(
                f,
                "tracked point inboard: {other_m:.3} m fits too; took the one nearer the command"
            ),
            TrackNote::NonFiniteFixes { count } => {
                write!(f, "{count} non-finite position(s) skipped")
            }
            TrackNote::Refused { reason } => write!(f, "track not usable: {reason}"),
        }
    }
}

/// What one turn's pose track measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrackStats {
    /// Fixes in the turn's steady part.
    pub fixes: usize,
    /// Positions inserted by the gap filling (Section 5.1).
    pub filled: usize,
    /// Outlying steps left unfilled (too long a gap, or a wild fix).
    pub unfilled_gaps: usize,
    /// Radius of the tracked point's fitted circle, R_lp [m].
    pub tracked_radius_m: Option<f64>,
    /// RMS distance of the fixes from the fitted circle [m].
    pub fit_rms_m: Option<f64>,
    /// R_ACT: the radius the rover's centre drove [m].
    pub r_act_m: Option<f64>,
    /// Angle swept about the fitted centre, counter-clockwise positive [deg].
    pub swept_deg: Option<f64>,
    /// Mean yaw rate from the track, counter-clockwise positive [rad/s].
    pub yaw_rate_act_rad_s: Option<f64>,
    /// Eq 6.3 with the track's yaw rate.
    pub angular_slip: Option<f64>,
    /// Eq 5.10–5.13: mean actual speed of the inner and outer wheels (front and back averaged,
    /// moving average of 3) [m/s].
    pub wheel_speed_mps: Option<InnerOuter>,
    /// Appendix D for this turn: 2 R_ACT |V_l − V_r| / |V_l + V_r| [m]; `None` for point turns.
    pub slip_track_m: Option<f64>,
    /// Eq 5.1–5.2 with R_ACT and the run's R′_ACT [deg] (set with the run's slip track).
    pub slip_angles_deg: Option<SlipAngles>,
    /// What to know, or why there is no R_ACT.
    pub notes: Vec<TrackNote>,
}

/// A quantity of the inner and the outer side of a turn.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct InnerOuter {
    /// The side towards the turn centre.
    pub inner: f64,
    /// The side away from it.
    pub outer: f64,
}

impl TrackStats {
    fn empty(fixes: usize, notes: Vec<TrackNote>) -> Self {
        Self {
            fixes,
            filled: 0,
            unfilled_gaps: 0,
            tracked_radius_m: None,
            fit_rms_m: None,
            r_act_m: None,
            swept_deg: None,
            yaw_rate_act_rad_s: None,
            angular_slip: None,
            wheel_speed_mps: None,
            slip_track_m: None,
            slip_angles_deg: None,
            notes,
        }
    }
}

/// The turn being measured.
#[derive(Debug, Clone, Copy)]
pub struct TurnContext<'a> {
    /// The rover (B, L for the wheel positions).
    pub rover: &'a Rover,
    /// Commanded side speeds [m/s].
    pub cmd_mps: Sides<f64>,
    /// Side of the turn.
    pub direction: Option<TurnDirection>,
    /// Commanded radius [m] (to choose between two radii the track allows).
    pub radius_cmd_m: Option<f64>,
    /// Commanded yaw rate, counter-clockwise positive [rad/s].
    pub yaw_rate_cmd_rad_s: f64,
    /// Lateral offset of the tracked point from the centre, right positive [m].
    pub tracker_offset_m: f64,
}

/// Whether any sample of `samples` carries a position (finite or not).
pub fn has_positions(samples: &[RunSample]) -> bool {
    samples.iter().any(|s| s.x_m.is_some() && s.y_m.is_some())
}

/// Measures the turn whose samples are `span` (its steady part) from the fixes in it.
pub fn analyse_track(span: &[RunSample], turn: &TurnContext<'_>) -> TrackStats {
    let mut notes = Vec::new();
    let mut times = Vec::new();
    let mut points = Vec::new();
    let mut non_finite = 0;
    for s in span {
        match (s.x_m, s.y_m, s.position_m()) {
            (_, _, Some(p)) => {
                times.push(s.t_s);
                points.push(p);
            }
            (Some(_), Some(_), None) => non_finite += 1,
            _ => {}
        }
    }
    if non_finite > 0 {
        notes.push(TrackNote::NonFiniteFixes { count: non_finite });
    }
    let fixes = points.len();
    if fixes == 0 {
        notes.push(TrackNote::NoFixes);
        return TrackStats::empty(0, notes);
    }
    if fixes < 3 {
        notes.push(TrackNote::TooFewFixes { fixes });
        return TrackStats::empty(fixes, notes);
    }
    // Mirror a right turn into a left one: the offset changes side with it.
    let right = turn.direction == Some(TurnDirection::Right);
    let (sign, offset) = if right {
        (-1.0, -turn.tracker_offset_m)
    } else {
        (1.0, turn.tracker_offset_m)
    };
    for p in &mut points {
        p.0 *= sign;
    }
    let mut stats = TrackStats::empty(fixes, notes);
    if spread_m(&points) < STATIONARY_SPREAD_M {
        stats.r_act_m = Some(offset.abs());
        stats.notes.push(TrackNote::TurnedAboutTrackedPoint);
        return stats;
    }
    let refused = |stats: &mut TrackStats, e: TrackingError| {
        stats.notes.push(match e {
            TrackingError::Degenerate => TrackNote::Collinear,
            reason => TrackNote::Refused { reason },
        });
    };
    let config = GapFillConfig::default();
    let mut filled = vec![(0.0, 0.0); fixes * (config.max_inserted_per_gap + 1)];
    let gap = match tracking::fill_gaps(&points, &config, &mut filled) {
        Ok(g) => g,
        Err(e) => {
            refused(&mut stats, e);
            return stats;
        }
    };
    filled.truncate(gap.len);
    stats.filled = gap.inserted;
    stats.unfilled_gaps = gap.skipped_gaps;
    let circle = match tracking::fit_circle(&filled) {
        Ok(c) => c,
        Err(e) => {
            refused(&mut stats, e);
            return stats;
        }
    };
    stats.tracked_radius_m = Some(circle.radius_m);
    stats.fit_rms_m = Some(rms_distance_m(&circle, &points));
    let swept = match tracking::swept_angle_rad(&circle, &filled) {
        Ok(a) => a,
        Err(e) => {
            refused(&mut stats, e);
            return stats;
        }
    };
    stats.swept_deg = Some(sign * swept.to_degrees());
    if swept.abs().to_degrees() < MIN_SWEPT_DEG {
        stats.notes.push(TrackNote::TooShortTurn {
            swept_deg: swept.abs().to_degrees(),
        });
        return stats;
    }
    let (r_act, far_side) = match centre_radius_m(&circle, offset, turn.radius_cmd_m) {
        Ok((r, far, other)) => {
            if let Some(other_m) = other {
                stats.notes.push(TrackNote::AmbiguousRadius { other_m });
            }
            (r, far)
        }
        Err(e) => {
            refused(&mut stats, e);
            return stats;
        }
    };
    stats.r_act_m = Some(r_act);
    let (first, last) = (times[0], times[times.len() - 1]);
    // The filled track is evenly spaced when the gap filling restored every lost fix.
    let dt_s = (last - first) / (filled.len() - 1) as f64;
    if let Ok(rate) = tracking::yaw_rate_from_track_rad_s(&circle, &filled, dt_s) {
        stats.yaw_rate_act_rad_s = Some(sign * rate);
        let cmd = (sign * turn.yaw_rate_cmd_rad_s) as f32;
        stats.angular_slip = tracking::angular_slip_from_track(cmd, &circle, &filled, dt_s)
            .ok()
            .flatten()
            .map(f64::from);
    }
    stats.wheel_speed_mps = wheel_speeds(&circle, &filled, offset, far_side, turn.rover, dt_s);
    let speeds = SideSpeeds::new(turn.cmd_mps.left as f32, turn.cmd_mps.right as f32);
    stats.slip_track_m =
        kinematics::slip_track_from_measured_radius_m(r_act as f32, speeds).map(f64::from);
    stats
}

/// RMS distance of the points from their centroid [m].
fn spread_m(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(x, y), p| (x + p.0 / n, y + p.1 / n));
    (points
        .iter()
        .map(|p| (p.0 - mx).powi(2) + (p.1 - my).powi(2))
        .sum::<f64>()
        / n)
        .sqrt()
}

/// RMS of ‖p − c‖ − R over `points` [m].
fn rms_distance_m(circle: &Circle, points: &[(f64, f64)]) -> f64 {
    let sum: f64 = points
        .iter()
        .map(|p| {
            let d = (p.0 - circle.centre_x_m).hypot(p.1 - circle.centre_y_m) - circle.radius_m;
            d * d
        })
        .sum();
    (sum / points.len() as f64).sqrt()
}

/// R_ACT from the tracked point's circle in the left-turn frame, with the point `offset_m` along
/// the rover's lateral axis (right positive); whether the point is on the far side of the centre
/// from the rover (the usual case); and the other admissible radius, if any.
fn centre_radius_m(
    circle: &Circle,
    offset_m: f64,
    radius_cmd_m: Option<f64>,
) -> Result<(f64, bool, Option<f64>), TrackingError> {
    if offset_m >= 0.0 {
        // The thesis' case (prism outboard): Section 5.1's R_ACT = R_lp − δx_lp.
        return Ok((tracking::actual_radius_m(circle, offset_m)?, true, None));
    }
    let far = circle.radius_m - offset_m;
    let near = -circle.radius_m - offset_m;
    if near < 0.0 {
        return Ok((far, true, None));
    }
    let cmd = radius_cmd_m.unwrap_or(far);
    Ok(if (far - cmd).abs() <= (near - cmd).abs() {
        (far, true, Some(near))
    } else {
        (near, false, Some(far))
    })
}

/// Eq 5.4–5.13 on the rover's centre: the heading from the circle (the tracked point lies on the
/// lateral axis, so the direction from the centre of the circle to it is θ_H, or θ_H + π when it
/// is between the rover and the turn centre), the centre's track, then the wheels' speeds with a
/// moving average of 3; their means.
fn wheel_speeds(
    circle: &Circle,
    track: &[(f64, f64)],
    offset_m: f64,
    far_side: bool,
    rover: &Rover,
    dt_s: f64,
) -> Option<InnerOuter> {
    let flip = if far_side { 0.0 } else { std::f64::consts::PI };
    let mut headings = Vec::with_capacity(track.len());
    let mut centres = Vec::with_capacity(track.len());
    for &p in track {
        let theta = tracking::final_heading_rad(circle, p).ok()? + flip;
        let (s, c) = theta.sin_cos();
        headings.push(theta);
        centres.push((p.0 - offset_m * c, p.1 - offset_m * s));
    }
    let n = track.len().saturating_sub(1);
    let (mut inner, mut outer) = (vec![0.0; n], vec![0.0; n]);
    tracking::inner_outer_speeds(
        &centres, &headings, rover, 0.0, dt_s, &mut inner, &mut outer,
    )
    .ok()?;
    let mean_filtered = |v: &[f64]| -> Option<f64> {
        let mut out = vec![0.0; v.len()];
        let k = tracking::moving_average(v, tracking::MOVING_AVERAGE_WINDOW, &mut out).ok()?;
        (k > 0).then(|| out[..k].iter().sum::<f64>() / k as f64)
    };
    Some(InnerOuter {
        inner: mean_filtered(&inner)?,
        outer: mean_filtered(&outer)?,
    })
}

/// The run's measured slip track (Appendix D): the median of its turns' values, with their
/// spread.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MeasuredSlipTrack {
    /// Median over the turns [m].
    pub slip_track_m: f64,
    /// Sample standard deviation over the turns [m]; 0 with one turn.
    pub spread_m: f64,
    /// Turns it comes from.
    pub turns: usize,
}

/// The median and spread of per-turn slip tracks; `None` without any.
pub fn measured_slip_track(per_turn_m: &[f64]) -> Option<MeasuredSlipTrack> {
    let mut v: Vec<f64> = per_turn_m
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let median = if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    };
    let mean = v.iter().sum::<f64>() / n as f64;
    let spread = if n > 1 {
        (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    } else {
        0.0
    };
    Some(MeasuredSlipTrack {
        slip_track_m: median,
        spread_m: spread,
        turns: n,
    })
}

#[cfg(test)]
mod tests;
