//! The design matrix of the diagnosis: one [`TurnRow`] per analysed manoeuvre of
//! [`validate`](crate::validate), with each side labelled inner or outer, the quantities every
//! candidate effect is a function of (regime, R/R', v_c, duration against the commanded yaw
//! rate, angular slip Eq 6.3, growth through the turn, run time, pitch) and the measured power.
//!
//! The measured quantity the diagnosis compares is the **effective power** per side,
//! P_eff = E / T_expected [W]: the manoeuvre's energy over the time the commanded yaw rate
//! needed for the measured heading change (Fig 6.7's expected time; straights: the actual
//! duration). It equals the average power when the rover turns as commanded and grows as
//! 1/(1 − s_ω) when it turns slower (Eq 6.3), so power-type effects (drag, bulldozing, offsets,
//! heating, slope) and time-type effects (angular slip, slip track) appear in one unit, and
//! E = P_eff · T_expected is what a planner needs for an arc.
//!
//! Runs with a pose track (`x_m,y_m`) put each turn where it was driven: its regime comes from
//! the measured R_ACT and R′_ACT (the run's measured slip track / 2, Appendix D) instead of the
//! command, and the row carries R_ACT/R′_ACT ([`MeasuredRadius`]); which one a diagnosis used
//! is in its notes ([`radius_source_note`]). `r_over_r_prime` — the axis of the effect shapes
//! and of the model file — stays the command's: the planner commands radii, and a term fitted
//! on measured ratios but tabulated on commanded ones moved the demo's planned arc from 2R′
//! to 1.6R′. Whether a manoeuvre is a calibration kind stays a property of the command too.

use super::winding_heat::{CopperHeat, WindingHeat};
use crate::log::run_csv::RunSample;
use crate::validate::{ManoeuvreKind, PhaseStats, ValidationReport};
use model_core::kinematics::{Regime, RegimeBounds, TurnDirection};
use model_core::Sides;
use serde::Serialize;

/// Which side of the turn a side was on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SideRole {
    /// The side towards the turning centre.
    Inner,
    /// The side away from it.
    Outer,
}

impl SideRole {
    /// Stable identifier in reports (`inner`, `outer`).
    pub const fn id(self) -> &'static str {
        match self {
            SideRole::Inner => "inner",
            SideRole::Outer => "outer",
        }
    }
}

/// One side of one manoeuvre.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SideObs {
    /// Inner or outer (straights: left is labelled outer, right inner, by convention only).
    pub role: SideRole,
    /// Commanded side speed, positive forward [m/s].
    pub cmd_mps: f64,
    /// Average power over the steady part [W].
    pub avg_power_w: f64,
    /// Largest power at one sample of the steady part [W] (noise included).
    pub max_power_w: f64,
    /// Energy over the whole manoeuvre [J].
    pub energy_j: f64,
    /// Energy over the expected duration, E / T_expected [W] (the diagnosis' measured value).
    pub effective_power_w: f64,
    /// Second minus first half of the steady part, average power [W], the first half's taken
    /// at the second half's yaw rate where the yaw shows the rover still speeding up
    /// ([`still_speeding_up`]); `None` if too short.
    pub growth_w: Option<f64>,
}

/// What was measured of a manoeuvre.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum Observed {
    /// Both sides (run CSVs): the `sides` hold the measured powers and energies.
    #[default]
    Sides,
    /// Only the total average power (per-turn summaries, [`summary`](super::summary)): the
    /// `sides` hold the commanded speeds, and their measured fields are NaN (not observed).
    /// With no duration, the effective power is the average power.
    Total {
        /// Total average power [W].
        avg_power_w: f64,
    },
}

/// One manoeuvre (turn or straight) as the diagnosis sees it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TurnRow {
    /// The run it came from (a grouping key of the cross-validation).
    pub run: String,
    /// Index of the run in the input order.
    pub run_index: usize,
    /// Index into the validation report's manoeuvres.
    pub manoeuvre: usize,
    /// Regime of the commanded radius.
    pub regime: Regime,
    /// Commanded turn radius [m]; ∞ for straights.
    pub radius_cmd_m: f64,
    /// R/R' with the rover's controller slip track; ∞ for straights.
    pub r_over_r_prime: f64,
    /// v_c = (|V_l| + |V_r|)/2 [m/s].
    pub v_c_mps: f64,
    /// Commanded yaw rate magnitude [rad/s] (0 for straights).
    pub yaw_rate_cmd_rad_s: f64,
    /// Measured duration [s].
    pub duration_s: f64,
    /// Expected duration: turned angle over the commanded yaw rate; the duration for straights [s].
    pub expected_duration_s: f64,
    /// Whether the turned angle came from the yaw (else an assumed angle: time-type effects are
    /// invisible).
    pub turned_from_yaw: bool,
    /// Eq 6.3 angular slip, turns with yaw only.
    pub angular_slip: Option<f64>,
    /// Mean measured yaw rate (heading change over the duration), CCW positive [rad/s];
    /// `None` without yaw. On a straight, a side asymmetry (a smaller tyre, a weaker driver)
    /// turns the rover.
    pub yaw_rate_act_rad_s: Option<f64>,
    /// Run time at the start of the manoeuvre [s].
    pub t_start_s: f64,
    /// Mean pitch over the steady part [deg]; `None` without pitch.
    pub pitch_deg: Option<f64>,
    /// Mean current per side at standstill in this run [A]; `None` if the run never stands
    /// still long enough.
    pub standstill_current_a: Option<Sides<f64>>,
    /// Mean bus voltage over the manoeuvre's steady part, per side [V] (for current-type terms).
    pub bus_v: f64,
    /// The standstill current of each side (inner/outer order, as `sides`) at this
    /// manoeuvre's bus voltage [W]; 0 when the run never stands still.
    pub standstill_w: [f64; 2],
    /// The inner then the outer side (turns), or left then right (straights).
    pub sides: [SideObs; 2],
    /// Whether the manoeuvre is of a kind the hard-ground model is trusted on (straights, point
    /// turns, turns with R ≥ 2R').
    pub calibration_kind: bool,
    /// Per side or the total only.
    pub observed: Observed,
    /// The manoeuvre's copper-loss history per τ, inner then outer
    /// ([`winding_heat`](super::winding_heat)); `None` without samples (per-turn tables).
    pub copper_heat_a4: Option<CopperHeat>,
    /// The turn as measured by a pose track; `None` without one (the regime is then the
    /// command's).
    pub measured: Option<MeasuredRadius>,
    /// Side of the turn; `None` for straights and when not known (per-turn tables).
    pub direction: Option<TurnDirection>,
}

/// A turn's radius as a pose track measured it (`validate`'s R_ACT, Section 5.1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MeasuredRadius {
    /// R_ACT [m].
    pub r_act_m: f64,
    /// R_ACT / R'_ACT.
    pub r_act_over_r_prime_act: f64,
    /// The run's measured slip track (Appendix D) [m]; 2 R'_ACT.
    pub slip_track_m: f64,
}

/// Which radius the rows' regimes and R/R' came from, for a diagnosis' notes.
pub fn radius_source_note(rows: &[TurnRow]) -> Option<String> {
    let turns = rows.iter().filter(|r| !r.is_straight()).count();
    let measured: Vec<&MeasuredRadius> = rows.iter().filter_map(|r| r.measured.as_ref()).collect();
    if measured.is_empty() {
        return None;
    }
    let mut tracks: Vec<f64> = measured.iter().map(|m| m.slip_track_m).collect();
    tracks.sort_by(f64::total_cmp);
    tracks.dedup();
    let list: Vec<String> = tracks.iter().map(|b| format!("{b:.3}")).collect();
    Some(format!(
        "regimes from the measured R_ACT/R'_ACT (pose track) on {} of {turns} turns, the rest \
         from the command (the R/R' axis of the effect terms and the model file stays the \
         commanded one); measured slip track {} m",
        measured.len(),
        list.join(", ")
    ))
}

impl TurnRow {
    /// Whether this is a straight line.
    pub fn is_straight(&self) -> bool {
        self.regime == Regime::Straight
    }

    /// Total effective power [W] (the average power of a total-only row).
    pub fn effective_power_w(&self) -> f64 {
        match self.observed {
            Observed::Sides => self.sides[0].effective_power_w + self.sides[1].effective_power_w,
            Observed::Total { avg_power_w } => avg_power_w,
        }
    }

    /// Whether only the total is observed.
    pub fn is_total_only(&self) -> bool {
        matches!(self.observed, Observed::Total { .. })
    }
}

/// R/R' from which a turn is a calibration manoeuvre (the issue: "wide turns R ≥ 2R'").
pub const CALIBRATION_MIN_R_OVER_R_PRIME: f64 = 2.0;

/// Time a run must have stood still before its current counts as the standstill draw [s].
pub const STANDSTILL_SETTLE_S: f64 = 0.5;

/// Mean current per side over the settled standstill samples of a run: those of the standstill
/// before the run first moves, at least [`STANDSTILL_SETTLE_S`] after it starts (no wheel is
/// stopping then); without 10 such samples, of each later standstill the samples at least
/// [`STANDSTILL_SETTLE_S`] after the stop and in its later half (a wheel whose speed loop lags
/// still draws as it stops). `None` if there are fewer than 10.
pub fn standstill_current_a(samples: &[RunSample]) -> Option<Sides<f64>> {
    let mut still = StandstillCurrent::default();
    samples.iter().for_each(|s| still.push(s));
    still.mean_a()
}

/// Sums of settled standstill currents: (left, right, count).
type Sums = (f64, f64, usize);

/// [`standstill_current_a`] sample by sample: the standstill under way is held until it ends.
#[derive(Debug, Clone, Default)]
struct StandstillCurrent {
    /// Whether the run has moved yet.
    moved: bool,
    /// The current standstill's samples: (time, left, right).
    span: Vec<(f64, f64, f64)>,
    /// The standstill before the first motion.
    before_moving: Sums,
    /// The later standstills.
    after_moving: Sums,
}

impl StandstillCurrent {
    fn push(&mut self, s: &RunSample) {
        let still = s.cmd_mps.left == 0.0 && s.cmd_mps.right == 0.0;
        if still {
            self.span.push((s.t_s, s.current_a.left, s.current_a.right));
        } else {
            self.close_span();
            self.moved = true;
        }
    }

    fn close_span(&mut self) {
        if self.span.is_empty() {
            return;
        }
        let (sums, later_half) = if self.moved {
            (&mut self.after_moving, true)
        } else {
            (&mut self.before_moving, false)
        };
        let (l, r, n) = Self::settled(&self.span, later_half);
        *sums = (sums.0 + l, sums.1 + r, sums.2 + n);
        self.span.clear();
    }

    /// Sums and count of the settled samples of one standstill.
    fn settled(span: &[(f64, f64, f64)], later_half: bool) -> Sums {
        let (Some(first), Some(last)) = (span.first(), span.last()) else {
            return (0.0, 0.0, 0);
        };
        let wait = if later_half {
            STANDSTILL_SETTLE_S.max(0.5 * (last.0 - first.0))
        } else {
            STANDSTILL_SETTLE_S
        };
        span.iter()
            .filter(|(t, _, _)| *t >= first.0 + wait)
            .fold((0.0, 0.0, 0), |(l, r, n), s| (l + s.1, r + s.2, n + 1))
    }

    fn mean_a(&self) -> Option<Sides<f64>> {
        // The standstill under way counts as if it ended here (without copying its samples).
        let (pl, pr, pn) = Self::settled(&self.span, self.moved);
        let with_pending = |sums: Sums, its: bool| {
            if its {
                (sums.0 + pl, sums.1 + pr, sums.2 + pn)
            } else {
                sums
            }
        };
        let before = with_pending(self.before_moving, !self.moved);
        let (l, r, n) = if before.2 >= 10 {
            before
        } else {
            with_pending(self.after_moving, self.moved)
        };
        let count = n as f64;
        (n >= 10).then(|| Sides::new(l / count, r / count))
    }
}

/// What [`rows`] needs of one run's samples besides the report: its standstill draw and
/// each of its manoeuvres' mean bus voltage and copper-loss history.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunSampleFacts {
    /// [`standstill_current_a`] of the run.
    pub standstill_current_a: Option<Sides<f64>>,
    /// Mean of the two sides' bus voltage over each manoeuvre's samples [V], by the
    /// manoeuvre's index in the report (0 for a manoeuvre of another run or without samples).
    pub span_bus_v: Vec<f64>,
    /// Mean copper-loss history over each manoeuvre's samples (left, right), by the same index
    /// (`None` for a manoeuvre without samples in this run).
    pub span_copper_heat_a4: Vec<Option<CopperHeat>>,
}

impl crate::log::run_log::RunLogSink for RunSampleScan {
    fn sample(&mut self, sample: &RunSample) -> std::io::Result<()> {
        self.push(sample);
        Ok(())
    }
}

/// [`RunSampleFacts`] of run `run_index` of `report`, gathered sample by sample (a run read as
/// a stream: memory holds the report's manoeuvres, not the run).
#[derive(Debug, Clone)]
pub struct RunSampleScan {
    still: StandstillCurrent,
    /// (report index, first sample, end sample) of the run's manoeuvres, in sample order.
    spans: Vec<(usize, usize, usize)>,
    /// The span the next sample may fall in.
    at: usize,
    /// Samples pushed.
    index: usize,
    sum: Vec<(f64, usize)>,
    heat: WindingHeat,
    heat_sum: Vec<CopperHeat>,
}

impl RunSampleScan {
    /// The scan of the report's run `run_index`.
    pub fn new(report: &ValidationReport, run_index: usize) -> Self {
        let name = report.runs.get(run_index).map(|r| r.name.as_str());
        let mut spans: Vec<(usize, usize, usize)> = report
            .manoeuvres
            .iter()
            .enumerate()
            .filter(|(_, m)| Some(m.run.as_str()) == name)
            .map(|(i, m)| (i, m.first_sample, m.end_sample))
            .collect();
        spans.sort_by_key(|&(_, first, _)| first);
        Self {
            still: StandstillCurrent::default(),
            spans,
            at: 0,
            index: 0,
            // -0.0: where `Iterator::sum` starts, so the sums are its to the bit.
            sum: vec![(-0.0, 0); report.manoeuvres.len()],
            heat: WindingHeat::default(),
            heat_sum: vec![CopperHeat::default(); report.manoeuvres.len()],
        }
    }

    /// The run's next sample.
    pub fn push(&mut self, s: &RunSample) {
        self.still.push(s);
        let heat = self.heat.push(s.t_s, [s.current_a.left, s.current_a.right]);
        let k = self.index;
        self.index += 1;
        while self.spans.get(self.at).is_some_and(|&(_, _, end)| end <= k) {
            self.at += 1;
        }
        if let Some(&(i, first, _)) = self.spans.get(self.at) {
            if first <= k {
                let (sum, n) = &mut self.sum[i];
                *sum += 0.5 * (s.bus_v.left + s.bus_v.right);
                *n += 1;
                for (acc, h) in self.heat_sum[i].iter_mut().zip(heat) {
                    acc[0] += h[0];
                    acc[1] += h[1];
                }
            }
        }
    }

    /// The facts of the samples pushed.
    pub fn finish(self) -> RunSampleFacts {
        RunSampleFacts {
            standstill_current_a: self.still.mean_a(),
            span_bus_v: self
                .sum
                .iter()
                .map(|&(sum, n)| if n == 0 { 0.0 } else { sum / n as f64 })
                .collect(),
            span_copper_heat_a4: self
                .sum
                .iter()
                .zip(&self.heat_sum)
                .map(|(&(_, n), h)| (n > 0).then(|| h.map(|s| s.map(|x| x / n as f64))))
                .collect(),
        }
    }
}

/// How much faster a turn turns in the second half of its steady part than in the first,
/// measured by its yaw: a speed loop that lags the command is still bringing the wheels up to
/// speed after the settle time, and a turn's power (its tread couple times the wheels' speed)
/// rises with them; growth is read at one speed, the second half's, so that a lag does not
/// pass for power rising as the wheels sink. 1 for straights, without yaw, and when the halves
/// turn in opposite senses or one more than twice as fast as the other (not a lag).
pub fn still_speeding_up(phases: &PhaseStats, straight: bool) -> f64 {
    match phases.yaw_rate_rad_s {
        Some([first, second]) if !straight && first != 0.0 => {
            let ratio = second / first;
            if (0.5..=2.0).contains(&ratio) {
                ratio
            } else {
                1.0
            }
        }
        _ => 1.0,
    }
}

/// The rows of `report` (turns and straights; standstill and too-short spans are not in it),
/// with each run's samples for the standstill current and bus voltage. `runs[i]` must be the
/// samples of the report's `runs[i]`.
pub fn rows(report: &ValidationReport, runs: &[&[RunSample]]) -> Vec<TurnRow> {
    let facts: Vec<RunSampleFacts> = (0..report.runs.len())
        .map(|i| {
            let mut scan = RunSampleScan::new(report, i);
            runs.get(i)
                .copied()
                .unwrap_or(&[])
                .iter()
                .for_each(|s| scan.push(s));
            scan.finish()
        })
        .collect();
    rows_from_facts(report, &facts)
}

/// [`rows`] from each run's [`RunSampleFacts`] (`facts[i]` of the report's `runs[i]`) instead of
/// its samples.
pub fn rows_from_facts(report: &ValidationReport, facts: &[RunSampleFacts]) -> Vec<TurnRow> {
    let mut out = Vec::new();
    for (index, m) in report.manoeuvres.iter().enumerate() {
        let Some(run_index) = report.runs.iter().position(|r| r.name == m.run) else {
            continue;
        };
        let Some(regime) = m.regime else { continue };
        if m.kind == ManoeuvreKind::Standstill {
            continue;
        }
        let s = &m.stats;
        let straight = regime == Regime::Straight;
        let expected_duration_s = if straight {
            s.duration_s
        } else {
            match s.expected_duration_s {
                Some(t) if t > 0.0 => t,
                _ => continue,
            }
        };
        // Inner is the side towards the turning centre: the left side of a left (CCW) turn.
        let left_inner = !straight && m.direction != Some(TurnDirection::Right);
        let side = |left: bool, role: SideRole| {
            let pick = |l: f64, r: f64| if left { l } else { r };
            let energy_j = pick(s.energy_j.left, s.energy_j.right);
            SideObs {
                role,
                cmd_mps: pick(m.cmd_mps.left, m.cmd_mps.right),
                avg_power_w: pick(s.avg_power_w.left, s.avg_power_w.right),
                max_power_w: pick(s.max_power_w.left, s.max_power_w.right),
                energy_j,
                effective_power_w: energy_j / expected_duration_s,
                growth_w: s.phases.map(|p| {
                    pick(p.second_half_w.left, p.second_half_w.right)
                        - pick(p.first_half_w.left, p.first_half_w.right)
                            * still_speeding_up(&p, straight)
                }),
            }
        };
        let sides = [
            side(left_inner, SideRole::Inner),
            side(!left_inner, SideRole::Outer),
        ];
        let run_facts = facts.get(run_index);
        let bus_v = run_facts
            .and_then(|f| f.span_bus_v.get(index))
            .copied()
            .unwrap_or(0.0);
        let copper_heat_a4 = run_facts
            .and_then(|f| f.span_copper_heat_a4.get(index).copied().flatten())
            .map(|h| h.map(|[l, r]| if left_inner { [l, r] } else { [r, l] }));
        let r_over_r_prime_cmd = m.r_over_r_prime.unwrap_or(f64::INFINITY);
        let measured = measured_radius(report, run_index, m.r_act_m, m.r_act_over_r_prime_act);
        let regime = match measured {
            Some(mr) if !straight => Regime::of(
                mr.r_act_m as f32,
                &report.rover.with_slip_track(mr.slip_track_m as f32),
                &RegimeBounds::default(),
            ),
            _ => regime,
        };
        let r_over_r_prime = r_over_r_prime_cmd;
        let still = run_facts.and_then(|f| f.standstill_current_a);
        out.push(TurnRow {
            run: m.run.clone(),
            run_index,
            manoeuvre: index,
            regime,
            radius_cmd_m: m.radius_cmd_m.unwrap_or(f64::INFINITY),
            r_over_r_prime,
            v_c_mps: m.v_c_mps,
            yaw_rate_cmd_rad_s: s.yaw_rate_cmd_rad_s.abs(),
            duration_s: s.duration_s,
            expected_duration_s,
            turned_from_yaw: s.turned_from_yaw,
            angular_slip: s.angular_slip,
            yaw_rate_act_rad_s: s.yaw_rate_act_rad_s,
            t_start_s: m.t_start_s,
            pitch_deg: s.mean_pitch_deg,
            standstill_current_a: still,
            standstill_w: still.map_or([0.0; 2], |a| {
                let (l, r) = (a.left * bus_v, a.right * bus_v);
                if left_inner {
                    [l, r]
                } else {
                    [r, l]
                }
            }),
            bus_v,
            sides,
            calibration_kind: straight
                || m.regime == Some(Regime::Point)
                || r_over_r_prime_cmd >= CALIBRATION_MIN_R_OVER_R_PRIME - 1e-9,
            observed: Observed::Sides,
            copper_heat_a4,
            measured: measured.filter(|_| !straight),
            direction: if straight { None } else { m.direction },
        });
    }
    out
}

/// The turn's measured radius when its run has a measured slip track.
fn measured_radius(
    report: &ValidationReport,
    run_index: usize,
    r_act_m: Option<f64>,
    ratio: Option<f64>,
) -> Option<MeasuredRadius> {
    let slip_track_m = report.runs.get(run_index)?.slip_track_measured_m?;
    Some(MeasuredRadius {
        r_act_m: r_act_m?,
        r_act_over_r_prime_act: ratio?,
        slip_track_m,
    })
}

/// The commanded radius of `row` as a group key: R/R′ to 0.01, straights all in one. The
/// manoeuvres leave-one-radius-out holds out together.
pub fn radius_group(row: &TurnRow) -> i64 {
    if row.r_over_r_prime.is_finite() {
        (row.r_over_r_prime * 100.0).round() as i64
    } else {
        i64::MAX
    }
}

#[cfg(test)]
mod standstill_tests {
    use super::*;

    /// A drive whose speed loop lags still draws as it stops: 1 A decaying over the first
    /// 0.9 s of each 2 s standstill, then its 0.05 A quiescent draw. Without a standstill
    /// before the first motion, the later half of each standstill reads the quiescent draw (a
    /// fixed 0.5 s wait read the decay too); with one, that standstill is read alone.
    #[test]
    fn the_standstill_draw_waits_for_a_lagging_stop() {
        let mut samples = Vec::new();
        for span in 0..3 {
            let t0 = 4.0 * span as f64;
            for i in 0..400 {
                let t = t0 + 0.01 * i as f64;
                let still = t - t0 >= 2.0;
                let since = t - t0 - 2.0;
                let current = match () {
                    () if !still => 3.0,
                    () if since < 0.9 => 0.05 + 0.95 * (1.0 - since / 0.9),
                    () => 0.05,
                };
                let cmd = if still { 0.0 } else { 0.3 };
                samples.push(RunSample::new(
                    t,
                    Sides::new(24.0, 24.0),
                    Sides::new(current, current),
                    Sides::new(cmd, cmd),
                ));
            }
        }
        let still = standstill_current_a(&samples).expect("settled samples");
        assert!((still.left - 0.05).abs() < 1e-9, "{still:?}");
        // A standstill before the run moves, at a draw of 0.07 A: it alone is read.
        let mut lead: Vec<RunSample> = (0..100)
            .map(|i| {
                RunSample::new(
                    -1.0 + 0.01 * i as f64,
                    Sides::new(24.0, 24.0),
                    Sides::new(0.07, 0.07),
                    Sides::new(0.0, 0.0),
                )
            })
            .collect();
        lead.extend(samples);
        let still = standstill_current_a(&lead).expect("settled samples");
        assert!((still.left - 0.07).abs() < 1e-9, "{still:?}");
    }
}
