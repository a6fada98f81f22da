//! Statistics of one manoeuvre: duration against the duration the command implies, angular slip
//! (Eq 6.3), electrical power per side and in total (P = V·I per sample), energy, the
//! torque-proportional estimate τ ∝ P/ω (Eq 5.14), pitch, and how power grows from the first
//! half of the turn to the second (Section 4.4.1: on sand, power rises as a turn progresses).
//!
//! Conventions (documented in the report too):
//! - Energy is integrated over the whole manoeuvre (trapezoid per interval between consecutive
//!   samples); intervals longer than the run's gap threshold are gaps and add nothing.
//! - "Steady" statistics (average and maximum power, τ, pitch, the two halves) skip the first
//!   `settle_s` seconds, where the drives accelerate to the new command. A manoeuvre with fewer
//!   than two samples after the settle time uses all its samples.
//! - Averages are time-weighted: the steady energy over the steady time without gaps (the plain
//!   sample mean when every interval is a gap).

use super::segment::{ManoeuvreKind, Segment};
use crate::log::run_csv::RunSample;
use model_core::energy::{torque_proportional, DEFAULT_MIN_WHEEL_RATE_RAD_S};
use model_core::fit::LinearFit;
use model_core::kinematics::{self, SideSpeeds};
use model_core::tracking;
use model_core::{Rover, Sides};
use serde::Serialize;

/// Default settle time cut from the start of each manoeuvre for the steady statistics [s]: the
/// Husky's drives reach a new side speed within a few tenths of a second.
pub const DEFAULT_SETTLE_S: f64 = 0.5;

/// Default heading change of a turn when the run has no yaw [deg]: the seed's turn experiments
/// are 90° turns (Sections 4.3–4.4, Fig. 6.7).
pub const DEFAULT_TURN_DEG: f64 = 90.0;

/// A quantity per side and for both sides together.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct SideTotal {
    /// Left side.
    pub left: f64,
    /// Right side.
    pub right: f64,
    /// Both sides (for a maximum: the largest sum at one sample, not the sum of the maxima).
    pub total: f64,
}

/// Average power over the two halves of a manoeuvre's steady part.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PhaseStats {
    /// Average power in the first half [W].
    pub first_half_w: SideTotal,
    /// Average power in the second half [W].
    pub second_half_w: SideTotal,
    /// Second minus first half, total power [W] (growth is in W everywhere: validate,
    /// diagnose, their tables, CSVs and JSON).
    pub growth_w: f64,
    /// Yaw rate in the first and the second half [rad/s] (the least-squares slope of the
    /// heading over each half); `None` without yaw.
    pub yaw_rate_rad_s: Option<[f64; 2]>,
}

/// What one manoeuvre measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ManoeuvreStats {
    /// Samples in the manoeuvre.
    pub samples: usize,
    /// Time from the first to the last sample [s].
    pub duration_s: f64,
    /// Time of the steady part (after the settle time) [s].
    pub steady_duration_s: f64,
    /// Number of gaps (intervals beyond the run's gap threshold) in the manoeuvre.
    pub gaps: usize,
    /// Time lost in those gaps [s].
    pub gap_s: f64,
    /// Eq 2.1: commanded yaw rate (V_r − V_l)/B_s with the rover's slip track, CCW positive [rad/s].
    pub yaw_rate_cmd_rad_s: f64,
    /// Commanded wheel rates, side speed / wheel radius [rad/s].
    pub wheel_rate_cmd_rad_s: Sides<f64>,
    /// Heading change of a turn [deg]: from the yaw if the run has it, else the assumed
    /// `turn_deg`. `None` for straight lines.
    pub turned_deg: Option<f64>,
    /// Whether `turned_deg` was measured (yaw) rather than assumed.
    pub turned_from_yaw: bool,
    /// Turned angle over the commanded yaw rate [s] (Fig. 6.7's expected time); turns only.
    pub expected_duration_s: Option<f64>,
    /// Mean measured yaw rate over the manoeuvre (heading change / duration), CCW positive
    /// [rad/s]; `None` without yaw.
    pub yaw_rate_act_rad_s: Option<f64>,
    /// Eq 6.3: s_ω = (ω_cmd − ω_act)/ω_cmd; turns with yaw only.
    pub angular_slip: Option<f64>,
    /// Average power over the steady part [W].
    pub avg_power_w: SideTotal,
    /// Largest power at one sample of the steady part [W].
    pub max_power_w: SideTotal,
    /// Energy over the whole manoeuvre, gaps excluded [J].
    pub energy_j: SideTotal,
    /// Eq 5.14: τ ∝ P/ω per side, steady average power over the commanded wheel rate [W·s/rad];
    /// `None` where |ω| < 0.1 rad/s (model-core's `DEFAULT_MIN_WHEEL_RATE_RAD_S`).
    pub torque_proportional: Sides<Option<f64>>,
    /// Mean pitch over the steady part [deg], nose-up positive; `None` without pitch.
    pub mean_pitch_deg: Option<f64>,
    /// First versus second half of the steady part; `None` when a half has < 2 samples.
    pub phases: Option<PhaseStats>,
}

/// Power per side of one sample, P = V·I [W].
pub fn sample_power_w(s: &RunSample) -> Sides<f64> {
    Sides::new(
        s.bus_v.left * s.current_a.left,
        s.bus_v.right * s.current_a.right,
    )
}

/// Energy, covered time and extremes of a slice of samples.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Integral {
    energy_j: Sides<f64>,
    covered_s: f64,
    gap_s: f64,
    gaps: usize,
    max_w: SideTotal,
}

impl Integral {
    fn of(samples: &[RunSample], gap_threshold_s: f64) -> Integral {
        let mut out = Integral {
            max_w: SideTotal {
                left: f64::NEG_INFINITY,
                right: f64::NEG_INFINITY,
                total: f64::NEG_INFINITY,
            },
            ..Integral::default()
        };
        for s in samples {
            let p = sample_power_w(s);
            out.max_w.left = out.max_w.left.max(p.left);
            out.max_w.right = out.max_w.right.max(p.right);
            out.max_w.total = out.max_w.total.max(p.left + p.right);
        }
        for w in samples.windows(2) {
            let dt = w[1].t_s - w[0].t_s;
            if dt > gap_threshold_s {
                out.gaps += 1;
                out.gap_s += dt;
                continue;
            }
            let (a, b) = (sample_power_w(&w[0]), sample_power_w(&w[1]));
            out.energy_j.left += 0.5 * (a.left + b.left) * dt;
            out.energy_j.right += 0.5 * (a.right + b.right) * dt;
            out.covered_s += dt;
        }
        out
    }

    /// Time-weighted average power; the sample mean when no interval is covered.
    fn average_w(&self, samples: &[RunSample]) -> SideTotal {
        let side = if self.covered_s > 0.0 {
            self.energy_j.map(|e| e / self.covered_s)
        } else {
            let n = samples.len().max(1) as f64;
            let sum = samples
                .iter()
                .map(sample_power_w)
                .fold(Sides::new(0.0, 0.0), |acc, p| {
                    Sides::new(acc.left + p.left, acc.right + p.right)
                });
            sum.map(|v| v / n)
        };
        SideTotal {
            left: side.left,
            right: side.right,
            total: side.left + side.right,
        }
    }
}

/// The options of [`analyse`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurnOptions {
    /// Settle time cut from the start for the steady statistics [s].
    pub settle_s: f64,
    /// Heading change assumed for turns when there is no yaw [deg].
    pub turn_deg: f64,
    /// Intervals longer than this are gaps [s].
    pub gap_threshold_s: f64,
}

/// The steady part of the manoeuvre `segment` of `samples` (the whole run): its samples from
/// `settle_s` after its start on, or all of them when fewer than two would remain.
pub fn steady_part<'a>(
    samples: &'a [RunSample],
    segment: &Segment,
    settle_s: f64,
) -> &'a [RunSample] {
    let span = &samples[segment.start..segment.end];
    let settle_from = segment.t_start_s + settle_s;
    let first_steady = span.partition_point(|s| s.t_s < settle_from);
    if span.len() - first_steady >= 2 {
        &span[first_steady..]
    } else {
        span
    }
}

/// Statistics of the manoeuvre `segment` of `samples` (the whole run).
pub fn analyse(
    samples: &[RunSample],
    segment: &Segment,
    rover: &Rover,
    options: &TurnOptions,
) -> ManoeuvreStats {
    let span = &samples[segment.start..segment.end];
    let whole = Integral::of(span, options.gap_threshold_s);
    let steady = steady_part(samples, segment, options.settle_s);
    let steady_int = Integral::of(steady, options.gap_threshold_s);
    let avg = steady_int.average_w(steady);

    let speeds = SideSpeeds::new(segment.cmd_mps.left as f32, segment.cmd_mps.right as f32);
    let yaw_rate_cmd =
        f64::from(kinematics::body_velocity(speeds, rover.slip_track_m).yaw_rate_rad_s);
    let wheel_rate = segment.cmd_mps.map(|v| v / f64::from(rover.wheel_radius_m));
    let tau = |p: f64, w: f64| {
        torque_proportional(p as f32, w as f32, DEFAULT_MIN_WHEEL_RATE_RAD_S).map(f64::from)
    };

    let duration_s = segment.duration_s();
    let yaws: Option<Vec<f64>> = span.iter().map(|s| s.yaw_rad).collect();
    let heading_change = yaws
        .as_deref()
        .and_then(|y| tracking::heading_change_rad(y).ok());
    let yaw_rate_act = heading_change
        .filter(|_| duration_s > 0.0)
        .map(|h| h / duration_s);
    let is_turn = segment.kind == ManoeuvreKind::Turn;
    let (turned_deg, turned_from_yaw) = match (is_turn, heading_change) {
        (false, _) => (None, false),
        (true, Some(h)) => (Some(h.abs().to_degrees()), true),
        (true, None) => (Some(options.turn_deg), false),
    };
    let expected_duration_s = turned_deg
        .filter(|_| yaw_rate_cmd != 0.0)
        .map(|deg| deg.to_radians() / yaw_rate_cmd.abs());
    let angular_slip = match (is_turn, yaw_rate_act) {
        (true, Some(act)) => {
            kinematics::angular_slip(yaw_rate_cmd as f32, act as f32).map(f64::from)
        }
        _ => None,
    };

    let pitches: Vec<f64> = steady.iter().filter_map(|s| s.pitch_deg).collect();
    let mean_pitch_deg =
        (!pitches.is_empty()).then(|| pitches.iter().sum::<f64>() / pitches.len() as f64);

    ManoeuvreStats {
        samples: span.len(),
        duration_s,
        steady_duration_s: steady[steady.len() - 1].t_s - steady[0].t_s,
        gaps: whole.gaps,
        gap_s: whole.gap_s,
        yaw_rate_cmd_rad_s: yaw_rate_cmd,
        wheel_rate_cmd_rad_s: wheel_rate,
        turned_deg,
        turned_from_yaw,
        expected_duration_s,
        yaw_rate_act_rad_s: yaw_rate_act,
        angular_slip,
        avg_power_w: avg,
        max_power_w: steady_int.max_w,
        energy_j: SideTotal {
            left: whole.energy_j.left,
            right: whole.energy_j.right,
            total: whole.energy_j.left + whole.energy_j.right,
        },
        torque_proportional: Sides::new(
            tau(avg.left, wheel_rate.left),
            tau(avg.right, wheel_rate.right),
        ),
        mean_pitch_deg,
        phases: phases(steady, options.gap_threshold_s),
    }
}

fn phases(steady: &[RunSample], gap_threshold_s: f64) -> Option<PhaseStats> {
    let (first, last) = (steady.first()?.t_s, steady.last()?.t_s);
    let mid = first + (last - first) / 2.0;
    let split = steady.partition_point(|s| s.t_s < mid);
    let (a, b) = steady.split_at(split);
    if a.len() < 2 || b.len() < 2 {
        return None;
    }
    let first_half_w = Integral::of(a, gap_threshold_s).average_w(a);
    let second_half_w = Integral::of(b, gap_threshold_s).average_w(b);
    let growth_w = second_half_w.total - first_half_w.total;
    Some(PhaseStats {
        first_half_w,
        second_half_w,
        growth_w,
        yaw_rate_rad_s: fitted_yaw_rate(a)
            .zip(fitted_yaw_rate(b))
            .map(|(a, b)| [a, b]),
    })
}

/// The least-squares slope of the heading (unwrapped sample to sample) over time [rad/s]: every
/// sample counts, so an IMU's noise on the first and last readings does not set the rate (a
/// rate still rising is read a little above its mean over the half). Streamed through
/// [`LinearFit`], no allocation per manoeuvre. `None` without yaw on every sample or without
/// spread in time.
fn fitted_yaw_rate(samples: &[RunSample]) -> Option<f64> {
    let first = samples.first()?;
    let (mut heading, mut previous) = (0.0, first.yaw_rad?);
    let mut fit = LinearFit::<2>::new();
    for s in samples {
        let yaw = s.yaw_rad.filter(|y| y.is_finite())?;
        heading += tracking::wrap_angle_rad(yaw - previous);
        previous = yaw;
        fit.add([1.0, s.t_s - first.t_s], heading).ok()?;
    }
    let [_, rate] = fit.coefficients().ok()?;
    Some(rate)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::validate::segment::{segment, SegmentOptions};
    use model_core::kinematics::{side_speeds_for, TurnDirection};

    const HUSKY: Rover = Rover::HUSKY_A200;

    fn opts() -> TurnOptions {
        TurnOptions {
            settle_s: 0.5,
            turn_deg: 90.0,
            gap_threshold_s: 0.05,
        }
    }

    /// A turn at constant commands, power `p(t)` per side, yaw integrating `yaw_rate_act`.
    fn turn(
        cmd: SideSpeeds,
        duration_s: f64,
        dt_s: f64,
        yaw_rate_act: Option<f64>,
        p: impl Fn(f64) -> (f64, f64),
    ) -> Vec<RunSample> {
        let n = (duration_s / dt_s).round() as usize + 1;
        (0..n)
            .map(|k| {
                let t = k as f64 * dt_s;
                let (pl, pr) = p(t);
                RunSample {
                    t_s: t,
                    bus_v: Sides::new(24.0, 25.0),
                    current_a: Sides::new(pl / 24.0, pr / 25.0),
                    cmd_mps: Sides::new(f64::from(cmd.left_mps), f64::from(cmd.right_mps)),
                    // Wrapped to (−π, π] as an IMU reports it.
                    yaw_rad: yaw_rate_act.map(|w| {
                        let a = w * t + 3.0;
                        a - std::f64::consts::TAU
                            * ((a + std::f64::consts::PI) / std::f64::consts::TAU).floor()
                    }),
                    pitch_deg: Some(2.0),
                    x_m: None,
                    y_m: None,
                }
            })
            .collect()
    }

    fn only_segment(samples: &[RunSample]) -> Segment {
        let segs = segment(samples, &HUSKY, &SegmentOptions::default()).expect("valid");
        assert_eq!(segs.len(), 1);
        segs[0]
    }

    #[test]
    fn constant_power_turn_with_yaw_gives_energy_slip_and_tau() {
        let rp = HUSKY.r_prime_m();
        let cmd = side_speeds_for(0.3, 2.0 * rp, rp, TurnDirection::Left);
        let w_cmd = 0.3 / (2.0 * f64::from(rp)); // Eq 2.9: v_c / R
        let w_cmd_eq_2_1 = f64::from(cmd.right_mps - cmd.left_mps) / 1.1;
        assert!((w_cmd - w_cmd_eq_2_1).abs() < 1e-6);
        // 10 % angular slip: ω_act = 0.9 ω_cmd, through a ±π wrap of the yaw.
        let samples = turn(cmd, 6.0, 0.01, Some(0.9 * w_cmd), |_| (40.0, 80.0));
        let seg = only_segment(&samples);
        let s = analyse(&samples, &seg, &HUSKY, &opts());
        assert!((s.duration_s - 6.0).abs() < 1e-9);
        assert!((s.yaw_rate_cmd_rad_s - w_cmd).abs() < 1e-6);
        assert!((s.angular_slip.expect("yaw") - 0.1).abs() < 1e-4, "{s:?}");
        let turned = 0.9 * w_cmd * 6.0;
        assert!(s.turned_from_yaw);
        assert!((s.turned_deg.expect("turn") - turned.to_degrees()).abs() < 1e-6);
        // Expected duration: turned angle / ω_cmd = 0.9 × 6 s.
        assert!((s.expected_duration_s.expect("turn") - 5.4).abs() < 1e-4);
        assert!((s.energy_j.left - 240.0).abs() < 1e-6 && (s.energy_j.right - 480.0).abs() < 1e-6);
        assert!((s.energy_j.total - 720.0).abs() < 1e-6);
        assert!((s.avg_power_w.total - 120.0).abs() < 1e-9);
        assert!((s.max_power_w.total - 120.0).abs() < 1e-9);
        // Eq 5.14: τ ∝ P/ω with ω = V/r.
        let tau_l = 40.0 / (f64::from(cmd.left_mps) / 0.165);
        let tau_r = 80.0 / (f64::from(cmd.right_mps) / 0.165);
        assert!((s.torque_proportional.left.expect("moving") - tau_l).abs() < 1e-3 * tau_l);
        assert!((s.torque_proportional.right.expect("moving") - tau_r).abs() < 1e-3 * tau_r);
        assert_eq!(s.mean_pitch_deg, Some(2.0));
        let ph = s.phases.expect("long enough");
        assert!(ph.growth_w.abs() < 1e-9);
    }

    #[test]
    fn right_turn_slip_has_the_same_sign_convention() {
        let rp = HUSKY.r_prime_m();
        let cmd = side_speeds_for(0.3, 0.0, rp, TurnDirection::Right);
        let w_cmd = -0.6 / 1.1;
        let samples = turn(cmd, 4.0, 0.01, Some(0.8 * w_cmd), |_| (50.0, 50.0));
        let s = analyse(&samples, &only_segment(&samples), &HUSKY, &opts());
        assert!(s.yaw_rate_cmd_rad_s < 0.0);
        assert!((s.angular_slip.expect("yaw") - 0.2).abs() < 1e-4, "{s:?}");
    }

    #[test]
    fn inner_wheel_at_r_prime_has_no_tau_and_no_yaw_assumes_turn_deg() {
        let rp = HUSKY.r_prime_m();
        let cmd = side_speeds_for(0.3, rp, rp, TurnDirection::Left);
        let samples = turn(cmd, 3.0, 0.01, None, |_| (5.0, 90.0));
        let s = analyse(&samples, &only_segment(&samples), &HUSKY, &opts());
        assert_eq!(s.torque_proportional.left, None);
        assert!(s.torque_proportional.right.is_some());
        assert!(!s.turned_from_yaw);
        assert_eq!(s.turned_deg, Some(90.0));
        assert_eq!(s.angular_slip, None);
        // 90° at ω = 2 v_c / B_s = 0.6/1.1 rad/s.
        let expected = std::f64::consts::FRAC_PI_2 / (0.6 / 1.1);
        assert!((s.expected_duration_s.expect("turn") - expected).abs() < 1e-4);
    }

    #[test]
    fn power_growth_through_the_turn_and_settle_time() {
        let cmd = SideSpeeds::new(-0.3, 0.3);
        // A start-up spike in the first 0.3 s, then power rising linearly 100 → 140 W total.
        let samples = turn(cmd, 4.5, 0.01, None, |t| {
            if t < 0.3 {
                (500.0, 500.0)
            } else {
                let p = 100.0 + 40.0 * (t - 0.5) / 4.0;
                (p / 2.0, p / 2.0)
            }
        });
        let s = analyse(&samples, &only_segment(&samples), &HUSKY, &opts());
        // The spike is in the settle time: not in the steady maximum, but in the energy.
        assert!(s.max_power_w.total < 141.0, "{:?}", s.max_power_w);
        assert!(s.energy_j.total > 0.3 * 1000.0);
        assert!(
            (s.avg_power_w.total - 120.0).abs() < 0.1,
            "{:?}",
            s.avg_power_w
        );
        let ph = s.phases.expect("long enough");
        // Halves average 110 W and 130 W.
        assert!((ph.first_half_w.total - 110.0).abs() < 0.2, "{ph:?}");
        assert!((ph.second_half_w.total - 130.0).abs() < 0.2, "{ph:?}");
        assert!((ph.growth_w - 20.0).abs() < 0.2, "{ph:?}");
    }

    /// A point turn whose speed loop lags the command (first order, τ = 0.35 s): the yaw rate
    /// and the power both rise as 1 − e^(−t/τ), so the first half of the steady part draws less
    /// than the second although nothing sinks. The halves' yaw rates carry nearly the same
    /// ratio, and growth read at one speed ([`still_speeding_up`]) is mostly gone; a power that
    /// rises at a steady yaw rate keeps its growth.
    #[test]
    fn a_lagging_speed_loop_shows_in_the_halves_yaw_rates() {
        use crate::diagnose::features::still_speeding_up;
        let (tau, w_ss, p_ss) = (0.35, 0.55, 400.0);
        let rising = |t: f64| 1.0 - (-t / tau).exp();
        let mut samples = turn(SideSpeeds::new(-0.3, 0.3), 3.0, 0.01, Some(1.0), |t| {
            (p_ss * rising(t), p_ss * rising(t))
        });
        for s in &mut samples {
            let heading = w_ss * (s.t_s - tau * rising(s.t_s));
            s.yaw_rad =
                Some(heading - std::f64::consts::TAU * (heading / std::f64::consts::TAU).round());
        }
        let ph = analyse(&samples, &only_segment(&samples), &HUSKY, &opts())
            .phases
            .expect("long enough");
        assert!(ph.growth_w > 10.0, "{ph:?}");
        let scale = still_speeding_up(&ph, false);
        let [first, second] = ph.yaw_rate_rad_s.expect("yaw");
        assert!(first < second && second < w_ss, "{ph:?}");
        let at_one_speed = ph.second_half_w.left - ph.first_half_w.left * scale;
        // Per side, a sixth of the growth is left (the slope reads a rising rate a little high).
        let per_side = 0.5 * ph.growth_w;
        assert!(
            at_one_speed.abs() < per_side / 5.0,
            "{at_one_speed} of {ph:?}"
        );
        assert_eq!(
            still_speeding_up(&ph, true),
            1.0,
            "straights have no yaw to read"
        );

        // Sinkage-like: the yaw rate steady from the start, power rising 20 W per side.
        let samples = turn(SideSpeeds::new(-0.3, 0.3), 4.5, 0.01, Some(w_ss), |t| {
            (100.0 + 40.0 * t / 4.5, 100.0 + 40.0 * t / 4.5)
        });
        let ph = analyse(&samples, &only_segment(&samples), &HUSKY, &opts())
            .phases
            .expect("long enough");
        let scale = still_speeding_up(&ph, false);
        assert!((scale - 1.0).abs() < 1e-6, "{ph:?}");
    }

    #[test]
    fn gaps_add_no_energy() {
        let cmd = SideSpeeds::new(0.3, 0.3);
        let mut samples = turn(cmd, 2.0, 0.01, None, |_| (10.0, 10.0));
        for s in samples.iter_mut().skip(100) {
            s.t_s += 10.0;
        }
        let seg = only_segment(&samples);
        let s = analyse(&samples, &seg, &HUSKY, &opts());
        assert_eq!(s.gaps, 1);
        assert!((s.gap_s - 10.01).abs() < 1e-9);
        // 2 s of 20 W, not 12 s.
        assert!(
            (s.energy_j.total - 40.0).abs() < 0.21,
            "{}",
            s.energy_j.total
        );
        assert!((s.avg_power_w.total - 20.0).abs() < 1e-9);
    }
}
