//! The commands file as a function of run time: the commanded side speeds in force at each
//! sample, the tracker's yaw and pitch interpolated between its rows, and its position fixes.

use crate::log::commands::CommandRow;
use core::f64::consts::PI;
use model_core::Sides;
use std::cell::Cell;

/// Commands over run time. Rows as read from a commands CSV (`t_s` strictly increasing).
///
/// Look-ups at non-decreasing times (a recording's samples) cost O(1): each table remembers
/// where the previous look-up landed and binary-searches only when the time moved past its
/// neighbour rows.
#[derive(Debug, Clone, Default)]
pub struct CommandTimeline {
    rows: Vec<CommandRow>,
    yaw: Vec<(f64, f64)>,
    pitch: Vec<(f64, f64)>,
    /// Position fixes (t_s, x_m, y_m).
    fixes: Vec<(f64, f64, f64)>,
    /// The previous look-up's `partition_point` in `rows`, `yaw`, `pitch` and `fixes`.
    hints: [Cell<usize>; 4],
    /// Fixes already handed out by [`CommandTimeline::fix_m`].
    fixes_given: Cell<usize>,
}

impl PartialEq for CommandTimeline {
    fn eq(&self, other: &Self) -> bool {
        // The pose tracks and hints follow from the rows.
        self.rows == other.rows
    }
}

/// `times.partition_point(|t| t <= t_s)` for increasing `times` (given as `len` and `time(i)`),
/// starting from `hint` (the previous answer), which it updates.
fn partition_after(hint: &Cell<usize>, len: usize, time: impl Fn(usize) -> f64, t_s: f64) -> usize {
    let fits = |n: usize| (n == 0 || time(n - 1) <= t_s) && (n == len || time(n) > t_s);
    let h = hint.get().min(len);
    let n = if fits(h) {
        h
    } else if h < len && fits(h + 1) {
        h + 1
    } else {
        let (mut lo, mut hi) = (0, len);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if time(mid) <= t_s {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        lo
    };
    hint.set(n);
    n
}

/// `angle` wrapped into [−π, π).
fn wrap_pi(angle: f64) -> f64 {
    angle - 2.0 * PI * ((angle + PI) / (2.0 * PI)).floor()
}

/// Linear interpolation in `points` (time, value) at `t_s`: `None` before the first point, the
/// last value after the last. `angle`: values are angles, interpolated the short way round.
fn interpolate(points: &[(f64, f64)], hint: &Cell<usize>, t_s: f64, angle: bool) -> Option<f64> {
    let i = partition_after(hint, points.len(), |k| points[k].0, t_s);
    let &(t0, v0) = points.get(i.checked_sub(1)?)?;
    let Some(&(t1, v1)) = points.get(i) else {
        return Some(v0);
    };
    let frac = (t_s - t0) / (t1 - t0);
    if !angle {
        return Some(v0 + frac * (v1 - v0));
    }
    let v = v0 + frac * wrap_pi(v1 - v0);
    // A tracker that reports wrapped yaw keeps getting wrapped yaw; an unwrapped one, unwrapped.
    let wrapped = |a: f64| (-PI..=PI).contains(&a);
    Some(if wrapped(v0) && wrapped(v1) && !wrapped(v) {
        wrap_pi(v)
    } else {
        v
    })
}

impl CommandTimeline {
    /// The timeline of `rows` (strictly increasing `t_s`, as the commands CSV reader ensures).
    pub fn new(rows: Vec<CommandRow>) -> Self {
        let track = |f: fn(&CommandRow) -> Option<f64>| {
            rows.iter()
                .filter_map(|r| Some((r.t_s, f(r)?)))
                .collect::<Vec<_>>()
        };
        Self {
            fixes_given: Cell::new(0),
            yaw: track(|r| r.yaw_rad),
            pitch: track(|r| r.pitch_deg),
            fixes: rows
                .iter()
                .filter_map(|r| Some((r.t_s, r.x_m?, r.y_m?)))
                .collect(),
            rows,
            hints: Default::default(),
        }
    }

    /// Appends a row learnt while recording (`t_s` at or after the last row's; a row at the
    /// same time replaces it). Pose rows are not tracked: a learnt row has none.
    pub fn push(&mut self, row: CommandRow) {
        match self.rows.last_mut() {
            Some(last) if row.t_s <= last.t_s => {
                *last = CommandRow {
                    t_s: last.t_s,
                    ..row
                }
            }
            _ => self.rows.push(row),
        }
    }

    /// The rows.
    pub fn rows(&self) -> &[CommandRow] {
        &self.rows
    }

    /// The sample times (from `samples_us`, run time [µs], increasing) at which a recorder
    /// forwarding these rows sends a command: as `Recorder::forward` does, the row in force at
    /// each sample when its speeds differ from the last ones sent.
    pub fn sends_us(&self, samples_us: impl IntoIterator<Item = u64>) -> Vec<u64> {
        let mut last_sent = None;
        let mut sends = Vec::new();
        for t_us in samples_us {
            let Some((_, row)) = self.active(super::RunClock::seconds(t_us)) else {
                continue;
            };
            if last_sent != Some(row.cmd_mps) {
                last_sent = Some(row.cmd_mps);
                sends.push(t_us);
            }
        }
        sends
    }

    /// The row in force at `t_s` (the last one at or before it) and its index.
    pub fn active(&self, t_s: f64) -> Option<(usize, &CommandRow)> {
        let rows = &self.rows;
        let i = partition_after(&self.hints[0], rows.len(), |k| rows[k].t_s, t_s).checked_sub(1)?;
        Some((i, self.rows.get(i)?))
    }

    /// Commanded side speeds at `t_s` [m/s]: the row in force, 0 before the first row.
    pub fn cmd_mps(&self, t_s: f64) -> Sides<f64> {
        self.active(t_s)
            .map_or(Sides::new(0.0, 0.0), |(_, row)| row.cmd_mps)
    }

    /// Yaw at `t_s` [rad], interpolated linearly between the rows that have one (the short way
    /// round), held after the last; `None` before the first.
    pub fn yaw_rad(&self, t_s: f64) -> Option<f64> {
        interpolate(&self.yaw, &self.hints[1], t_s, true)
    }

    /// Pitch at `t_s` [deg], interpolated like [`CommandTimeline::yaw_rad`].
    pub fn pitch_deg(&self, t_s: f64) -> Option<f64> {
        interpolate(&self.pitch, &self.hints[2], t_s, false)
    }

    /// The tracker's newest position fix (x, y) [m] at or before `t_s` that no earlier call
    /// returned, for samples taken at non-decreasing times. A fix is a measurement of one
    /// instant, so it lands on one sample (the first at or after it) instead of being
    /// interpolated into a 200 Hz track the tracker never measured; the ≤ one sample period of
    /// time shift moves it along the path only (the circle fit does not see it).
    pub fn fix_m(&self, t_s: f64) -> Option<(f64, f64)> {
        let fixes = &self.fixes;
        let n = partition_after(&self.hints[3], fixes.len(), |k| fixes[k].0, t_s);
        if n <= self.fixes_given.get() {
            return None;
        }
        self.fixes_given.set(n);
        let &(_, x, y) = fixes.get(n - 1)?;
        Some((x, y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t_s: f64, left: f64, yaw: Option<f64>, pitch: Option<f64>) -> CommandRow {
        CommandRow {
            t_s,
            cmd_mps: Sides::new(left, -left),
            yaw_rad: yaw,
            pitch_deg: pitch,
            x_m: None,
            y_m: None,
        }
    }

    #[test]
    fn speeds_hold_the_row_in_force_and_are_zero_before_the_first() {
        let tl = CommandTimeline::new(vec![row(1.0, 0.5, None, None), row(2.0, 0.7, None, None)]);
        assert_eq!(tl.cmd_mps(0.5), Sides::new(0.0, 0.0));
        assert_eq!(tl.cmd_mps(1.0), Sides::new(0.5, -0.5));
        assert_eq!(tl.cmd_mps(1.99), Sides::new(0.5, -0.5));
        assert_eq!(tl.cmd_mps(9.0), Sides::new(0.7, -0.7));
        assert_eq!(tl.active(1.5).map(|(i, _)| i), Some(0));
        assert_eq!(tl.active(0.0), None);
    }

    /// A send at the first sample a row is in force, once per change of speeds; a row that is
    /// in force at no sample (replaced within one period) is never sent.
    #[test]
    fn sends_are_the_samples_where_the_speeds_in_force_change() {
        let tl = CommandTimeline::new(vec![
            row(0.0, 0.5, None, None),
            row(0.0075, 0.5, None, None),
            row(0.012, 0.7, None, None),
            row(0.021, 0.9, None, None),
            row(0.022, 0.3, None, None),
        ]);
        let samples = (0..10).map(|k| k * 5_000);
        assert_eq!(tl.sends_us(samples), [0, 15_000, 25_000]);
    }

    #[test]
    fn look_ups_in_any_order_match_a_fresh_binary_search() {
        // The remembered position must never change an answer: forwards, backwards, repeated,
        // jumping, exactly on rows, before the first and after the last.
        let rows: Vec<CommandRow> = (0..50)
            .map(|k| {
                let t = f64::from(k) * 0.05;
                row(t, t, (k % 3 != 0).then_some(t), (k % 4 != 0).then_some(-t))
            })
            .collect();
        let tl = CommandTimeline::new(rows.clone());
        let fresh = |t: f64| {
            let tl = CommandTimeline::new(rows.clone());
            (
                tl.cmd_mps(t),
                tl.yaw_rad(t),
                tl.pitch_deg(t),
                tl.active(t).map(|(i, _)| i),
            )
        };
        let mut times: Vec<f64> = (0..600).map(|k| f64::from(k) * 0.005 - 0.1).collect();
        times.extend([2.45, 2.45, 0.0, 1.0, -5.0, 9.0, 0.05, 0.1, 0.049, f64::NAN]);
        times.extend((0..300).rev().map(|k| f64::from(k) * 0.01));
        for &t in &times {
            let got = (
                tl.cmd_mps(t),
                tl.yaw_rad(t),
                tl.pitch_deg(t),
                tl.active(t).map(|(i, _)| i),
            );
            let want = fresh(t);
            assert_eq!(format!("{got:?}"), format!("{want:?}"), "at t = {t}");
        }
    }

    #[test]
    fn pushed_rows_extend_the_timeline_and_a_row_at_the_same_time_replaces_it() {
        let mut tl = CommandTimeline::new(Vec::new());
        tl.push(row(1.0, 0.5, None, None));
        tl.push(row(1.0, 0.6, None, None));
        tl.push(row(2.0, 0.7, None, None));
        assert_eq!(tl.rows().len(), 2);
        assert_eq!(tl.cmd_mps(1.5), Sides::new(0.6, -0.6));
        assert_eq!(tl.cmd_mps(2.5), Sides::new(0.7, -0.7));
    }

    #[test]
    fn pose_is_interpolated_between_tracker_rows_only() {
        let tl = CommandTimeline::new(vec![
            row(0.0, 0.1, Some(0.0), Some(2.0)),
            row(1.0, 0.1, None, None),
            row(2.0, 0.1, Some(1.0), Some(4.0)),
        ]);
        assert_eq!(tl.yaw_rad(-1.0), None);
        assert_eq!(tl.yaw_rad(0.0), Some(0.0));
        assert!((tl.yaw_rad(1.0).expect("yaw") - 0.5).abs() < 1e-12);
        assert!((tl.pitch_deg(1.5).expect("pitch") - 3.5).abs() < 1e-12);
        assert_eq!(tl.yaw_rad(5.0), Some(1.0), "held after the last");
    }

    #[test]
    fn each_fix_lands_on_one_sample() {
        let mut rows: Vec<CommandRow> = (0..4)
            .map(|k| row(f64::from(k) * 0.2, 0.3, None, None))
            .collect();
        rows[0].x_m = Some(1.0);
        rows[0].y_m = Some(2.0);
        rows[2].x_m = Some(3.0);
        rows[2].y_m = Some(4.0);
        rows[3].x_m = Some(5.0); // no y: not a fix
        let tl = CommandTimeline::new(rows);
        let got: Vec<Option<(f64, f64)>> = [0.0, 0.005, 0.2, 0.4, 0.405, 0.6, 0.8]
            .iter()
            .map(|&t| tl.fix_m(t))
            .collect();
        assert_eq!(
            got,
            [
                Some((1.0, 2.0)),
                None,
                None,
                Some((3.0, 4.0)),
                None,
                None,
                None
            ]
        );
    }

    #[test]
    fn yaw_goes_the_short_way_across_pi() {
        let tl = CommandTimeline::new(vec![
            row(0.0, 0.0, Some(3.0), None),
            row(1.0, 0.0, Some(-3.0), None),
        ]);
        // 3 → −3 is +0.283 rad through π, not −6 rad.
        let mid = tl.yaw_rad(0.5).expect("yaw");
        assert!((mid.abs() - PI).abs() < 1e-9, "{mid}");
        let late = tl.yaw_rad(0.9).expect("yaw");
        assert!(
            (late - (-3.0 - 0.1 * (2.0 * PI - 6.0))).abs() < 1e-9,
            "{late}"
        );
        assert_eq!(tl.yaw_rad(1.0), Some(-3.0));
        // An unwrapped track stays unwrapped.
        let tl = CommandTimeline::new(vec![
            row(0.0, 0.0, Some(6.0), None),
            row(1.0, 0.0, Some(7.0), None),
        ]);
        assert!((tl.yaw_rad(0.5).expect("yaw") - 6.5).abs() < 1e-12);
    }
}
