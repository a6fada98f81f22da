//! `merge`: a board log and the robot's ROS 2 bag of the same drive, made one run log. The bag's
//! commanded twists become side speeds (Eq 2.4 inverted with the rover's controller slip track),
//! its IMU orientation yaw and pitch, its pose topic the tracked position; they land on the
//! board's samples as `record --merge-commands` lands a commands file on them.
//!
//! Lining up: both logs carry wall-clock time (the board log its anchor, the bag its `log_time`),
//! but two computers' clocks may disagree by seconds. The offset is measured from the data: the
//! board's power is constant between the commands' steps (a start, a stop, a turn), whatever its
//! level. At each lag within `max_offset_s`, on the sample grid and then to 0.25 ms around the
//! best, one free level per interval is fitted to the samples (each the chips' average over their
//! window); the offset is the lag that leaves the least misfit, as a share of the covered
//! samples' variance (a bag covering part of the run is judged on the part it covers). No power
//! model sets the levels,
//! so a terrain the model gets wrong lines up as well; the hard-ground model (paper Eq 21) only
//! says which command changes are steps.

use crate::log::commands::CommandRow;
use crate::log::run_log::RunLog;
use crate::record::CommandTimeline;
use crate::ros2::msgs::yaw_pitch_of;
use crate::ros2::read::RobotBag;
use model_core::power::IcrHardGround;
use model_core::wire::BoardFrame;
use model_core::{Rover, Sides};
use thiserror::Error;

/// Why two logs could not be merged.
#[derive(Debug, Error, PartialEq)]
pub enum MergeError {
    #[error("the board log has no wall-clock anchor (the `wall-clock` event `record` writes at the first sample; a run CSV made by `convert` has none: merge the MCAP log)")]
    NoWallClock,
    #[error("the bag's commands change the power {0} time(s): at least 2 steps (starts, stops, turns) are needed to line up the clocks")]
    NoSteps(usize),
    #[error("the board log has too few samples ({0}) to line up")]
    TooFewSamples(usize),
    #[error("the logs do not overlap: the board ran {board}, the bag's commands span {bag} (its log times against the board's wall clock), more than the {max_offset_s} s searched apart (--max-offset-s)")]
    NoOverlap {
        board: String,
        bag: String,
        max_offset_s: f64,
    },
    #[error("the clocks drift apart by {drift_ppm:+.0} ppm (offset {start_s:+.3} s at the start of the overlap, {end_s:+.3} s at its end), beyond the {MAX_DRIFT_PPM} ppm clocks drift: the logs are not of one drive, or a clock was set during it")]
    Drift {
        drift_ppm: f64,
        start_s: f64,
        end_s: f64,
    },
    #[error("the bag turns the other way: {0}; left and right are swapped somewhere (a mirrored twist or IMU frame)")]
    Mirrored(String),
    #[error("the IMU reports no orientation (orientation_covariance[0] = -1 or a zero quaternion) and no angular_velocity.z to integrate: give --imu-topic none, or a topic with orientation")]
    ImuUnusable,
    #[error("the board's power does not step where the bag's commands do at any offset within ±{max_offset_s} s (best R² {r2:.2} at {offset_s:+.3} s): wrong bag, wrong --cmd-topic, or clocks further apart")]
    NoMatch {
        r2: f64,
        offset_s: f64,
        max_offset_s: f64,
    },
}

/// How the bag was lined up with the board log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alignment {
    /// The bag's clock minus the board log's at the board's wall-clock anchor [s].
    pub offset_s: f64,
    /// How fast the bag's clock gains on the board's [ppm]: the offset at board run time t
    /// (from the anchor) is `offset_s + drift_ppm·1e-6·t`. 0 when not beyond twice its
    /// standard error, or not measured.
    pub drift_ppm: f64,
    /// Whether the drift was measured: at least three windows of the overlap, each with three
    /// steps or more, lined up alone.
    pub drift_measured: bool,
    /// R² of the step fit there: the share of the power's variance the commands' steps explain.
    pub r2: f64,
    /// Steps of the commanded power that lined the logs up.
    pub steps: usize,
    /// The best offset more than 0.5 s away from it with its R² (a repeated drive's echo).
    pub runner_up: Option<(f64, f64)>,
    /// Seconds of the board run the bag's commands cover.
    pub overlap_s: f64,
    /// The board run's duration [s].
    pub board_s: f64,
}

/// Where the merged yaw came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum YawSource {
    /// No IMU messages.
    None,
    /// The IMU's orientation (yaw and pitch).
    Orientation,
    /// `angular_velocity.z` integrated over the messages' log times (an IMU without
    /// orientation); no pitch.
    IntegratedRate,
}

/// What was merged.
#[derive(Debug, Clone)]
pub struct Merged {
    pub log: RunLog,
    pub alignment: Alignment,
    pub yaw_source: YawSource,
    /// Samples given a commanded speed, a yaw and a position fix from the bag.
    pub samples_with_cmd: usize,
    pub samples_with_yaw: usize,
    pub fixes: usize,
}

/// The hard-ground model of `rover` (paper Table 2's μ and G; the rover's geometry).
fn predictor(rover: &Rover) -> IcrHardGround {
    IcrHardGround {
        length_m: f64::from(rover.length_m),
        width_m: f64::from(rover.track_width_m),
        mass_kg: f64::from(rover.mass_kg),
        slip_track_m: f64::from(rover.slip_track_m),
        ..IcrHardGround::HUSKY_HARD_GROUND
    }
}

/// Side speeds of a twist with the controller's slip track (Eq 2.4 inverted).
pub fn side_speeds(rover: &Rover, linear_x: f64, angular_z: f64) -> Sides<f64> {
    let half = f64::from(rover.slip_track_m) / 2.0;
    Sides::new(linear_x - angular_z * half, linear_x + angular_z * half)
}

/// A change of the commanded power smaller than this is no step [W].
const STEP_W: f64 = 5.0;

/// The largest clock drift accepted [ppm]: crystals are specified to ±20–100 ppm over
/// temperature (a RealSense's is reported at 75 ppm); more is not a clock running free.
pub const MAX_DRIFT_PPM: f64 = 500.0;

/// Windows of the overlap lined up alone to measure the drift.
const DRIFT_WINDOWS: usize = 4;

/// How well "power is constant between the commands' steps" fits the board's samples when the
/// steps are `lag` later on the board's clock: the least-squares fit of one free level per
/// interval between `steps`, each sample the mean over the chips' averaging `window` that ended
/// half a window before it (so a sample across a step mixes two levels). Returns the mean
/// squared residual and the samples' variance, over the samples within `span`; `None` when
/// fewer than `min_n` are.
fn step_fit(
    t: &[f64],
    y: &[f64],
    steps: &[f64],
    span: (f64, f64),
    lag: f64,
    window: f64,
    min_n: usize,
) -> Option<(f64, f64)> {
    let m = steps.len() + 1;
    // The normal equations of the levels are tridiagonal: a sample touches two at most.
    let (mut diag, mut upper, mut rhs) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
    let (mut n, mut sy, mut syy) = (0usize, 0.0, 0.0);
    let (mut ja, mut jb) = (0, 0);
    for (&ti, &yi) in t.iter().zip(y) {
        let end = ti + lag - window / 2.0;
        let start = end - window;
        if start < span.0 || end > span.1 {
            continue;
        }
        while ja < steps.len() && steps[ja] <= start {
            ja += 1;
        }
        while jb < steps.len() && steps[jb] <= end {
            jb += 1;
        }
        // Commands faster than the window: the sample mixes its two end intervals only.
        let f = if ja == jb {
            1.0
        } else {
            (steps[ja] - start) / window
        };
        diag[ja] += f * f;
        rhs[ja] += f * yi;
        if ja != jb {
            upper[ja] += f * (1.0 - f);
            diag[jb] += (1.0 - f) * (1.0 - f);
            rhs[jb] += (1.0 - f) * yi;
        }
        n += 1;
        sy += yi;
        syy += yi * yi;
    }
    if n < min_n.max(2) {
        return None;
    }
    // Thomas algorithm; an interval without samples keeps level 0 (it adds nothing).
    let mut c = vec![0.0; m];
    let mut d = vec![0.0; m];
    for j in 0..m {
        let below = if j > 0 { upper[j - 1] } else { 0.0 };
        let pivot = diag[j] + 1e-12 - below * if j > 0 { c[j - 1] } else { 0.0 };
        c[j] = upper[j] / pivot;
        d[j] = (rhs[j] - below * if j > 0 { d[j - 1] } else { 0.0 }) / pivot;
    }
    let mut level = vec![0.0; m];
    for j in (0..m).rev() {
        level[j] = d[j] - if j + 1 < m { c[j] * level[j + 1] } else { 0.0 };
    }
    let explained: f64 = level.iter().zip(&rhs).map(|(l, b)| l * b).sum();
    let n = n as f64;
    Some(((syy - explained).max(0.0) / n, (syy - sy * sy / n) / n))
}

/// Lines up `bag` with `log`: the offset within ±`max_offset_s` where the board's power best
/// follows the power predicted for the bag's commands.
pub fn align(
    log: &RunLog,
    bag: &RobotBag,
    rover: &Rover,
    max_offset_s: f64,
) -> Result<Alignment, MergeError> {
    let (t_anchor, unix_anchor) = log.wall_clock().ok_or(MergeError::NoWallClock)?;
    let n = log.samples.len();
    if n < 20 {
        return Err(MergeError::TooFewSamples(n));
    }
    // Times in seconds from the board's anchor, on both clocks.
    let t: Vec<f64> = log.samples.iter().map(|s| s.t_s - t_anchor).collect();
    let power: Vec<f64> = log
        .samples
        .iter()
        .map(|s| s.bus_v.left * s.current_a.left + s.bus_v.right * s.current_a.right)
        .collect();
    let model = predictor(rover);
    let since_anchor = |ns: u64| (ns as i128 - unix_anchor as i128) as f64 * 1e-9;
    // Where the commanded power steps (the model only says where, not how far: the levels are
    // fitted), in seconds from the board's anchor on the bag's clock.
    let mut steps = Vec::new();
    let mut last_w: Option<f64> = None;
    for (ns, m) in &bag.cmd {
        let s = side_speeds(rover, m.linear_x, m.angular_z);
        let w = model.power_w(s.left, s.right);
        if last_w.is_some_and(|l| (w - l).abs() >= STEP_W) {
            steps.push(since_anchor(*ns));
        }
        if last_w.is_none_or(|l| (w - l).abs() >= STEP_W) {
            last_w = Some(w);
        }
    }
    let board_s = t[n - 1] - t[0];
    let period = board_s / (n - 1) as f64;
    // Each sample is the chips' latest result: the mean over their averaging window (the
    // board's hello says how long; else a sample period), finished on average half a window
    // before the read (the chips convert freely; the board reads on its own clock).
    let window = log
        .frames
        .iter()
        .find_map(|(_, f)| match f {
            BoardFrame::Hello(h) => Some(f64::from(h.adc.update_period_us()) * 1e-6),
            _ => None,
        })
        .filter(|w| *w > 0.0)
        .unwrap_or(period);
    let (bag_first, bag_last) = (
        since_anchor(bag.cmd[0].0),
        since_anchor(bag.cmd[bag.cmd.len() - 1].0),
    );
    let span = (bag_first, bag_last);
    let say = |a: f64, b: f64| format!("{a:+.1} … {b:+.1} s from the board's anchor");
    // Apart by more than the search reaches: say so before anything about the commands.
    if bag_last < t[0] - max_offset_s || bag_first > t[n - 1] + max_offset_s {
        return Err(MergeError::NoOverlap {
            board: say(t[0], t[n - 1]),
            bag: say(bag_first, bag_last),
            max_offset_s,
        });
    }
    if steps.len() < 2 {
        return Err(MergeError::NoSteps(steps.len()));
    }
    // A bag may cover part of the run: the fit needs most of the samples the bag's span can
    // cover, not most of the run.
    let coverable = (((bag_last - bag_first) / period) as usize).min(n);
    let min_n = (coverable * 4 / 5).max(20);

    let lags = (max_offset_s / period).ceil() as i64;
    let fit = |lag: f64| step_fit(&t, &power, &steps, span, lag, window, min_n);
    let scores: Vec<(f64, f64)> = (-lags..=lags)
        .filter_map(|k| {
            let lag = k as f64 * period;
            fit(lag).map(|(mse, var)| (lag, mse / var))
        })
        .collect();
    let Some(&(coarse, _)) = scores.iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
        return Err(MergeError::NoOverlap {
            board: say(t[0], t[n - 1]),
            bag: say(bag_first, bag_last),
            max_offset_s,
        });
    };
    let (offset_s, misfit) = refine(&fit, coarse, period).unwrap_or((coarse, f64::INFINITY));
    let r2 = 1.0 - misfit;
    let mut others: Vec<f64> = scores.iter().map(|s| s.1).collect();
    others.sort_by(f64::total_cmp);
    let typical = others[others.len() / 2];
    // The steps must explain the power, and far better than at a typical offset.
    if !(r2 >= 0.5 && misfit <= 0.5 * typical) {
        return Err(MergeError::NoMatch {
            r2,
            offset_s,
            max_offset_s,
        });
    }
    // The best fit more than 0.5 s away, as a fraction of the misfit it leaves.
    let runner_up = scores
        .iter()
        .filter(|(lag, _)| (lag - offset_s).abs() > 0.5)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|&(lag, other)| (lag, 1.0 - other));
    let covered = (
        t[0].max(bag_first - offset_s),
        t[n - 1].min(bag_last - offset_s),
    );
    let overlap_s = (covered.1 - covered.0).max(0.0);

    // Drift: each window of the overlap lined up alone near the whole's offset, then the
    // offsets' straight line over board time.
    let window_s = overlap_s / DRIFT_WINDOWS as f64;
    let reach = 0.02 + MAX_DRIFT_PPM * 1e-6 * overlap_s;
    let mut lined: Vec<(f64, f64)> = Vec::new();
    for w in 0..DRIFT_WINDOWS {
        let a = covered.0 + w as f64 * window_s;
        let part = (a + offset_s, a + window_s + offset_s);
        if steps.iter().filter(|&&x| x > part.0 && x < part.1).count() < 3 {
            continue;
        }
        let min_w = ((window_s / period) as usize * 4 / 5).max(20);
        let fit_w = |lag: f64| step_fit(&t, &power, &steps, part, lag, window, min_w);
        let k = (reach / period).ceil() as i64;
        let best = (-k..=k)
            .filter_map(|j| {
                let lag = offset_s + j as f64 * period;
                fit_w(lag).map(|(mse, var)| (lag, mse / var))
            })
            .min_by(|x, y| x.1.total_cmp(&y.1));
        if let Some((lag, _)) = best.and_then(|(lag, _)| refine(&fit_w, lag, period)) {
            lined.push((a + window_s / 2.0, lag));
        }
    }
    // A slope within twice its standard error is no drift: the offset stays the whole's.
    let (offset_s, drift_ppm, drift_measured) = match straight_line(&lined) {
        Some((at_anchor, slope, se)) if lined.len() >= 3 && slope.abs() > 2.0 * se => {
            (at_anchor, slope * 1e6, true)
        }
        Some(_) if lined.len() >= 3 => (offset_s, 0.0, true),
        _ => (offset_s, 0.0, false),
    };
    if drift_ppm.abs() > MAX_DRIFT_PPM {
        let at = |t: f64| offset_s + drift_ppm * 1e-6 * t;
        return Err(MergeError::Drift {
            drift_ppm,
            start_s: at(covered.0),
            end_s: at(covered.1),
        });
    }
    Ok(Alignment {
        offset_s,
        drift_ppm,
        drift_measured,
        r2,
        steps: steps.len(),
        runner_up,
        overlap_s,
        board_s,
    })
}

/// The best lag to 0.25 ms within a sample period either side of `coarse`: (lag, its misfit as
/// a share of the covered samples' variance).
fn refine(fit: &dyn Fn(f64) -> Option<(f64, f64)>, coarse: f64, period: f64) -> Option<(f64, f64)> {
    let fine_step = 0.25e-3;
    let fine = (period / fine_step).ceil() as i64;
    (-fine..=fine)
        .filter_map(|k| {
            let lag = coarse + k as f64 * fine_step;
            fit(lag).map(|(mse, var)| (lag, mse / var))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// Least-squares line through (x, y) points: (intercept at x = 0, slope, the slope's standard
/// error: infinite with two points); `None` with fewer than two distinct x.
fn straight_line(points: &[(f64, f64)]) -> Option<(f64, f64, f64)> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let slope = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / sxx;
    let intercept = my - slope * mx;
    let ss: f64 = points
        .iter()
        .map(|p| (p.1 - intercept - slope * p.0).powi(2))
        .sum();
    let se = if points.len() > 2 {
        (ss / (n - 2.0) / sxx).sqrt()
    } else {
        f64::INFINITY
    };
    Some((intercept, slope, se))
}

/// The board's run time [s] of a bag time [Unix ns]: the bag's clock `offset_s` ahead at the
/// board's anchor and gaining `drift_ppm`.
fn run_time_of(log: &RunLog, a: &Alignment) -> Result<impl Fn(u64) -> f64, MergeError> {
    let (t_anchor, unix_anchor) = log.wall_clock().ok_or(MergeError::NoWallClock)?;
    let (offset_s, rate) = (a.offset_s, 1.0 + a.drift_ppm * 1e-6);
    Ok(move |ns: u64| {
        let bag_s = (ns as i128 - unix_anchor as i128) as f64 * 1e-9;
        t_anchor + (bag_s - offset_s) / rate
    })
}

/// Yaw [rad] and pitch [deg] (when known) at an IMU message.
type YawPitch = (f64, Option<f64>);

/// The IMU's yaw (and pitch, when it has an orientation) at each message, and where it came
/// from: the orientation when every message has one, else `angular_velocity.z` integrated over
/// the log times (trapezoids) when every message has that.
fn imu_yaw(bag: &RobotBag) -> Result<(Vec<YawPitch>, YawSource), MergeError> {
    if bag.imu.is_empty() {
        return Ok((Vec::new(), YawSource::None));
    }
    if bag.imu.iter().all(|(_, m)| m.orientation_known) {
        let yaw = bag
            .imu
            .iter()
            .map(|(_, m)| {
                let (yaw, pitch) = yaw_pitch_of(m.orientation);
                (yaw, Some(pitch))
            })
            .collect();
        return Ok((yaw, YawSource::Orientation));
    }
    let rates: Option<Vec<f64>> = bag.imu.iter().map(|(_, m)| m.yaw_rate_rad_s).collect();
    let rates = rates.ok_or(MergeError::ImuUnusable)?;
    let mut yaw = 0.0;
    let mut out = Vec::with_capacity(rates.len());
    for (i, rate) in rates.iter().enumerate() {
        if i > 0 {
            let dt = (bag.imu[i].0 - bag.imu[i - 1].0) as f64 * 1e-9;
            yaw += 0.5 * (rates[i - 1] + rate) * dt;
        }
        out.push((yaw, None));
    }
    Ok((out, YawSource::IntegratedRate))
}

/// The bag's commands, yaw, pitch and fixes as commands rows on the board's run time, and where
/// the yaw came from.
fn command_rows(
    log: &RunLog,
    bag: &RobotBag,
    rover: &Rover,
    alignment: &Alignment,
) -> Result<(Vec<CommandRow>, YawSource), MergeError> {
    let run_time = run_time_of(log, alignment)?;
    let (yaw, yaw_source) = imu_yaw(bag)?;
    // Every message a row, in time order; rows at the same instant are one row.
    let mut rows: Vec<CommandRow> = Vec::new();
    let mut events: Vec<(u64, u8, usize)> = Vec::new();
    events.extend((0..bag.cmd.len()).map(|i| (bag.cmd[i].0, 0, i)));
    events.extend((0..bag.imu.len()).map(|i| (bag.imu[i].0, 1, i)));
    events.extend((0..bag.pose.len()).map(|i| (bag.pose[i].0, 2, i)));
    events.sort();
    let mut cmd = Sides::new(0.0, 0.0);
    for (ns, kind, i) in events {
        let t_s = run_time(ns);
        if rows.last().is_none_or(|r| r.t_s < t_s) {
            rows.push(CommandRow::new(t_s, cmd));
        }
        let row = rows.last_mut().expect("pushed");
        match kind {
            0 => {
                let m = bag.cmd[i].1;
                cmd = side_speeds(rover, m.linear_x, m.angular_z);
                row.cmd_mps = cmd;
            }
            1 => {
                row.yaw_rad = Some(yaw[i].0);
                row.pitch_deg = yaw[i].1;
            }
            _ => {
                let p = bag.pose[i].1;
                row.x_m = Some(p.x_m);
                row.y_m = Some(p.y_m);
            }
        }
    }
    Ok((rows, yaw_source))
}

/// The span of a topic's messages on the board's run time, to one message period past the
/// last (a message holds until the next would have come).
fn held_span(times: impl ExactSizeIterator<Item = f64> + Clone) -> Option<(f64, f64)> {
    let n = times.len();
    let first = times.clone().next()?;
    let last = times.last()?;
    let period = (last - first) / (n.max(2) - 1) as f64;
    Some((first, last + period))
}

/// Whether the bag turns the way the board log does: where the commands turn, the side they
/// make the outer one draws more power, and the IMU's yaw turns the commanded way. Mirrored
/// twists or a mirrored IMU frame (left and right swapped) fail this.
fn check_turn_sense(
    log: &RunLog,
    timeline: &CommandTimeline,
    yaw_known: bool,
) -> Result<(), MergeError> {
    // Sum over turning samples of sign(right side commanded faster) x sign(right − left
    // power), and of sign(commanded yaw) x the yaw's change: both positive when the bag's
    // left is the board's.
    let (mut power_agree, mut power_n) = (0.0, 0usize);
    let (mut yaw_agree, mut yaw_n) = (0.0, 0usize);
    let mut last: Option<(f64, f64)> = None;
    for s in &log.samples {
        let cmd = timeline.cmd_mps(s.t_s);
        let turn = cmd.right - cmd.left;
        let yaw = timeline.yaw_rad(s.t_s);
        if turn.abs() > 0.05 {
            let sense = turn.signum();
            // The outer side is the one commanded faster (backwards too); a point turn has none.
            let faster = cmd.right.abs() - cmd.left.abs();
            if faster.abs() > 0.02 {
                let right_more =
                    s.bus_v.right * s.current_a.right - s.bus_v.left * s.current_a.left;
                power_agree += faster.signum() * right_more.signum();
                power_n += 1;
            }
            if let (Some(y), Some((t0, y0))) = (yaw.filter(|_| yaw_known), last) {
                if s.t_s > t0 {
                    let d = (y - y0 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                        - std::f64::consts::PI;
                    if d != 0.0 {
                        yaw_agree += sense * d.signum();
                        yaw_n += 1;
                    }
                }
            }
        }
        last = yaw.map(|y| (s.t_s, y));
    }
    // A clear majority the other way; a mixed record (forward turns, reverse, sand) is left be.
    if power_n >= 50 && power_agree < -0.5 * power_n as f64 {
        return Err(MergeError::Mirrored(format!(
            "where its commands turn, the side they make the inner one draws more power on {:.0} % of {power_n} samples (the outer side draws more)",
            50.0 * (1.0 - power_agree / power_n as f64)
        )));
    }
    if yaw_n >= 50 && yaw_agree < -0.5 * yaw_n as f64 {
        return Err(MergeError::Mirrored(format!(
            "its IMU's yaw turns against its commands on {:.0} % of {yaw_n} turning samples",
            50.0 * (1.0 - yaw_agree / yaw_n as f64)
        )));
    }
    Ok(())
}

/// Merges `bag` into `log`: lines them up, then gives every sample the bag covers the bag's
/// commanded side speeds, yaw, pitch and position fixes; samples outside keep the log's own
/// values (with a pose topic, the bag's fixes only).
pub fn merge(
    mut log: RunLog,
    bag: &RobotBag,
    rover: &Rover,
    max_offset_s: f64,
) -> Result<Merged, MergeError> {
    let alignment = align(&log, bag, rover, max_offset_s)?;
    let (rows, yaw_source) = command_rows(&log, bag, rover, &alignment)?;
    let timeline = CommandTimeline::new(rows.clone());
    check_turn_sense(&log, &timeline, yaw_source != YawSource::None)?;
    let run_time = run_time_of(&log, &alignment)?;
    // Commands hold from the first to one twist period past the last (a controller holds the
    // last twist; beyond the bag's end it is not known); yaw and pitch likewise.
    let cmd_span = held_span(bag.cmd.iter().map(|m| run_time(m.0)));
    let imu_span = held_span(bag.imu.iter().map(|m| run_time(m.0)));
    let (mut with_cmd, mut with_yaw, mut fixes) = (0, 0, 0);
    for s in &mut log.samples {
        if cmd_span.is_some_and(|(a, b)| (a..=b).contains(&s.t_s)) {
            s.cmd_mps = timeline.cmd_mps(s.t_s);
            with_cmd += 1;
        }
        let in_imu = imu_span.is_some_and(|(a, b)| (a..=b).contains(&s.t_s));
        let yaw = timeline.yaw_rad(s.t_s).filter(|_| in_imu);
        if yaw.is_some() {
            s.yaw_rad = yaw;
            s.pitch_deg = timeline.pitch_deg(s.t_s);
            with_yaw += 1;
        }
        // With a pose topic, the bag's fixes replace the log's (a fix is an event: two sources'
        // would both count).
        if !bag.pose.is_empty() {
            let fix = timeline.fix_m(s.t_s);
            s.x_m = fix.map(|f| f.0);
            s.y_m = fix.map(|f| f.1);
            fixes += usize::from(fix.is_some());
        }
    }
    log.commands = rows;
    Ok(Merged {
        log,
        alignment,
        yaw_source,
        samples_with_cmd: with_cmd,
        samples_with_yaw: with_yaw,
        fixes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::run_csv::RunSample;
    use crate::log::run_log::LogEvent;
    use crate::ros2::msgs::TwistMsg;
    use model_core::rng::SplitMix64;

    /// A world apart from the simulator's: a rover whose power is 40 W + 600 W per rad/s of
    /// commanded yaw rate + 90 W per m/s (not the predictor's coefficients), measured by chips
    /// that average 4.48 ms and are read at a random age every 5 ms, with 3 W of noise; the
    /// robot's clock `offset_s` ahead.
    fn drive(offset_s: f64, seed: u64) -> (RunLog, RobotBag) {
        drive_drifting(offset_s, 0.0, seed)
    }

    /// [`drive`] with the robot's clock gaining `drift_ppm`, and the outer side of a turn
    /// drawing 150 W per rad/s more than the inner.
    fn drive_drifting(offset_s: f64, drift_ppm: f64, seed: u64) -> (RunLog, RobotBag) {
        drive_for(40.0, 5e-3, offset_s, drift_ppm, seed)
    }

    /// [`drive_drifting`] for `seconds`, the board sampling every `period` s.
    fn drive_for(
        seconds: f64,
        period: f64,
        offset_s: f64,
        drift_ppm: f64,
        seed: u64,
    ) -> (RunLog, RobotBag) {
        let ticks = (seconds / 0.05) as u64;
        let mut rng = SplitMix64::new(seed);
        let unix0: u64 = 1_764_000_000_000_000_000;
        // A twist every 50 ms: stops, straights and turns of 1–4 s each, in a random order
        // (a drive repeated at a steady rhythm fits several offsets: see `runner_up`).
        let kinds = [
            (0.0, 0.0),
            (0.3, 0.0),
            (0.0, 0.6),
            (0.3, 0.27),
            (0.2, -0.4),
            (0.1, 0.5),
        ];
        // Segment ends in 50 ms ticks: the drives act on the twists received.
        let mut segments = Vec::new();
        let mut end = 0u64;
        while end < ticks + 20 {
            end += 20 + rng.next_u64() % 60;
            segments.push((end, kinds[(rng.next_u64() % kinds.len() as u64) as usize]));
        }
        let twist_of_tick = |tick: u64| {
            segments
                .iter()
                .find(|(e, _)| tick < *e)
                .map_or((0.0, 0.0), |s| s.1)
        };
        let power_at = |t: f64| {
            let tick = (t / 0.05).floor().max(0.0) as u64;
            let (v, w): (f64, f64) = twist_of_tick(tick);
            (40.0 + 600.0 * w.abs() + 90.0 * v.abs(), 150.0 * w)
        };
        let cmd = (0..ticks)
            .map(|tick| {
                let (v, w) = twist_of_tick(tick);
                let ns = unix0 + tick * 50_000_000;
                let twist = TwistMsg {
                    stamp_ns: None,
                    linear_x: v,
                    angular_z: w,
                };
                let drifted = (tick as f64 * 0.05 * drift_ppm * 1e-6 * 1e9) as i64;
                (
                    ns.saturating_add_signed((offset_s * 1e9) as i64 + drifted),
                    twist,
                )
            })
            .collect();
        let window = 4.48e-3f64.min(period);
        let samples = (0..(seconds / period) as usize)
            .map(|k| {
                let t = k as f64 * period;
                let age = rng.uniform() * window;
                let (mean, outer) = (0..16)
                    .map(|j| power_at(t - age - window * (j as f64 + 0.5) / 16.0))
                    .fold((0.0, 0.0), |(a, b), (p, o)| (a + p / 16.0, b + o / 16.0));
                let p = mean + 3.0 * rng.normal();
                RunSample::new(
                    t,
                    Sides::new(24.0, 24.0),
                    Sides::new((p / 2.0 - outer) / 24.0, (p / 2.0 + outer) / 24.0),
                    Sides::new(0.0, 0.0),
                )
            })
            .collect();
        let log = RunLog {
            samples,
            frames: Vec::new(),
            commands: Vec::new(),
            events: vec![(0.0, LogEvent::WallClock { unix_ns: unix0 })],
        };
        (
            log,
            RobotBag {
                cmd,
                ..RobotBag::default()
            },
        )
    }

    #[test]
    fn the_clock_offset_is_measured_to_a_few_ms_in_a_world_of_its_own() {
        for (offset_s, seed) in [(0.0, 1), (7.3, 2), (-9.61, 3), (13.0, 4)] {
            let (log, bag) = drive(offset_s, seed);
            let a = align(&log, &bag, &Rover::HUSKY_A200, 30.0).expect("aligns");
            assert!(
                (a.offset_s - offset_s).abs() < 0.004,
                "seed {seed}: {} vs {offset_s}",
                a.offset_s
            );
            assert!(a.r2 > 0.9, "{}", a.r2);
        }
    }

    #[test]
    fn a_bag_beyond_the_searched_offset_is_refused() {
        let (log, bag) = drive(100.0, 5);
        assert!(matches!(
            align(&log, &bag, &Rover::HUSKY_A200, 30.0),
            Err(MergeError::NoOverlap { .. } | MergeError::NoMatch { .. })
        ));
        let (log, _) = drive(0.0, 6);
        assert_eq!(
            align(
                &RunLog {
                    events: Vec::new(),
                    ..log
                },
                &bag,
                &Rover::HUSKY_A200,
                30.0
            ),
            Err(MergeError::NoWallClock)
        );
    }

    #[test]
    fn a_drifting_clock_is_measured_and_one_beyond_what_clocks_do_is_refused() {
        // 300 ppm: 12 ms over the 40 s drive, the offset given at the board's anchor.
        let (log, bag) = drive_drifting(4.2, 300.0, 7);
        let a = align(&log, &bag, &Rover::HUSKY_A200, 30.0).expect("aligns");
        assert!(a.drift_measured);
        assert!((a.drift_ppm - 300.0).abs() < 60.0, "{a:?}");
        assert!((a.offset_s - 4.2).abs() < 0.004, "{a:?}");
        let (log, bag) = drive_drifting(4.2, 5000.0, 7);
        assert!(matches!(
            align(&log, &bag, &Rover::HUSKY_A200, 30.0),
            Err(MergeError::Drift { .. } | MergeError::NoMatch { .. })
        ));
    }

    #[test]
    fn a_robot_clock_100_ppm_fast_over_an_hours_drive_is_found_within_10_ppm() {
        // 0.36 s over the hour; the board at 20 Hz keeps the test quick.
        let (log, bag) = drive_for(3600.0, 0.05, 1.7, 100.0, 13);
        let a = align(&log, &bag, &Rover::HUSKY_A200, 2.0).expect("aligns");
        assert!(a.drift_measured, "{a:?}");
        assert!((a.drift_ppm - 100.0).abs() < 10.0, "{a:?}");
        // To half a sample period: the log has no hello saying the chips average 4.48 ms, so
        // each sample is taken as the mean over its 50 ms period.
        assert!((a.offset_s - 1.7).abs() < 0.026, "{a:?}");
    }

    #[test]
    fn a_bag_covering_part_of_the_run_lines_up_and_leaves_the_rest_alone() {
        let (mut log, mut bag) = drive(2.5, 9);
        // The robot recorded 20 s in the middle of the 40 s run.
        let from = bag.cmd[0].0 + 10_000_000_000;
        bag.cmd
            .retain(|(ns, _)| (from..from + 20_000_000_000).contains(ns));
        let marker = Sides::new(9.0, 9.0);
        for s in &mut log.samples {
            s.cmd_mps = marker;
        }
        let merged = merge(log, &bag, &Rover::HUSKY_A200, 30.0).expect("merges");
        let a = merged.alignment;
        assert!((a.offset_s - 2.5).abs() < 0.004, "{a:?}");
        assert!((a.overlap_s - 20.0).abs() < 0.2, "{a:?}");
        // Before and after the bag's span the board log's values stay.
        let first = merged.log.samples.first().expect("samples");
        let last = merged.log.samples.last().expect("samples");
        assert_eq!((first.cmd_mps, last.cmd_mps), (marker, marker));
        let n = merged.log.samples.len();
        assert!(
            (merged.samples_with_cmd as f64 - n as f64 / 2.0).abs() < 0.02 * n as f64,
            "{} of {n}",
            merged.samples_with_cmd
        );
    }

    #[test]
    fn a_bag_far_from_the_board_log_says_they_do_not_overlap() {
        let (log, bag) = drive(2.0 * 365.25 * 86_400.0, 10);
        assert!(matches!(
            align(&log, &bag, &Rover::HUSKY_A200, 30.0),
            Err(MergeError::NoOverlap { .. })
        ));
    }

    #[test]
    fn a_mirrored_bag_is_refused() {
        let (log, mut bag) = drive(0.0, 11);
        for (_, m) in &mut bag.cmd {
            m.angular_z = -m.angular_z;
        }
        let e = merge(log, &bag, &Rover::HUSKY_A200, 30.0).expect_err("mirrored");
        assert!(matches!(e, MergeError::Mirrored(_)), "{e}");
        let (log, bag) = drive(0.0, 11);
        merge(log, &bag, &Rover::HUSKY_A200, 30.0).expect("the same bag unmirrored merges");
    }

    #[test]
    fn an_imu_without_orientation_gives_yaw_integrated_from_its_rate() {
        use crate::ros2::msgs::ImuMsg;
        let (log, mut bag) = drive(0.0, 12);
        // A raw IMU at 50 Hz turning at 0.2 rad/s: no orientation, its rate only.
        let t0 = bag.cmd[0].0;
        bag.imu = (0..2000u64)
            .map(|i| {
                let m = ImuMsg {
                    stamp_ns: 0,
                    orientation: [0.0; 4],
                    orientation_known: false,
                    yaw_rate_rad_s: Some(0.2),
                };
                (t0 + i * 20_000_000, m)
            })
            .collect();
        let merged = merge(log, &bag, &Rover::HUSKY_A200, 30.0).expect("merges");
        assert_eq!(merged.yaw_source, YawSource::IntegratedRate);
        let run_time = run_time_of(&merged.log, &merged.alignment).expect("anchor");
        let t_first = run_time(t0);
        let s = merged
            .log
            .samples
            .iter()
            .find(|s| s.t_s >= t_first + 10.0)
            .expect("a sample 10 s in");
        let yaw = s.yaw_rad.expect("yaw");
        assert!((yaw - 0.2 * (s.t_s - t_first)).abs() < 0.01, "{yaw}");
        assert_eq!(s.pitch_deg, None);
        // Neither an orientation nor a rate: refused, naming the orientation.
        for (_, m) in &mut bag.imu {
            m.yaw_rate_rad_s = None;
        }
        let (log, _) = drive(0.0, 12);
        assert_eq!(
            merge(log, &bag, &Rover::HUSKY_A200, 30.0).map(|_| ()),
            Err(MergeError::ImuUnusable)
        );
    }

    #[test]
    fn twists_become_side_speeds_with_the_controllers_slip_track() {
        let s = side_speeds(&Rover::HUSKY_A200, 0.3, 0.5);
        // B_s = 1.1 m: V = 0.3 ∓ 0.5 · 0.55.
        assert!(
            (s.left - 0.025).abs() < 1e-6 && (s.right - 0.575).abs() < 1e-6,
            "{s:?}"
        );
    }
}
