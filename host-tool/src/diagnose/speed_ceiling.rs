//! Would a drive's top speed explain the turns' slowdown? The rival of `angular-slip`'s mark that
//! the catalogue does not hold.
//!
//! Under the thesis' command law (Eq 2.6, |V_l| + |V_r| = 2 v_c) the outer side's command rises
//! from v_c at the point turn to 2 v_c at R′: R′ asks for the fastest wheel of the whole drive
//! set, and the calibration (point turns, R ≥ 2R′, straights) never asks for it. A PWM drive's
//! top speed scales with its bus voltage, and a heavy turn pulls the bus down, so a drive that
//! cannot reach 2 v_c turns the R′ turns slower than commanded while the point turns are on
//! time: angular slip's mark, with no slip of the ground.
//!
//! The two differ in shape. A speed ceiling (one top speed per volt, h) takes
//! (1 − s₀)·(v_out − min(v_out, h·V_bus)) / (v_out − v_in) from each turn: nothing below its
//! knee, then a rise with R/R′ of fixed slope (1 − s₀)/2, since v_out = v_c (1 + R/R′) below R′.
//! A slip of the ground rises as the terrain makes it. The ceiling is one parameter; it explains
//! the turns when its lack of fit against the turns' own condition means is not significant.
//! Then timing alone cannot tell the two apart, and the mark is not read as the ground's.

use super::features::TurnRow;
use super::matched_slip::yaw_timed;
use super::signature::{ALPHA, MIN_SLIP_EXCESS};
use super::stats::t_upper;
use model_core::fit::f_upper_tail;

/// Largest R/R′ of the turns the ceiling is fitted on: up to R′ they share the point turn's yaw
/// rate (Eq 2.6), so a slip that grows with the yaw rate does not enter.
const MAX_RHO: f64 = 1.05;

/// Steps of the top speed's grid between the slowest and the fastest demand.
const GRID: usize = 400;

/// A fitted ceiling that explains the turns as well as their condition means do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SpeedCeiling {
    /// The top wheel speed on the bus of the turns commanded fastest [m/s].
    pub top_speed_mps: f64,
    /// That bus voltage [V]; `None` when the turns carry none (a top speed fixed in m/s).
    pub bus_v: Option<f64>,
    /// The fastest commanded wheel speed of those turns [m/s].
    pub fastest_cmd_mps: f64,
    /// p of its lack of fit (F test against the condition means); NaN when not testable (no
    /// more conditions than the ceiling's one parameter, or no spread within them).
    pub p_lack_of_fit: f64,
}

impl SpeedCeiling {
    /// The report's words.
    pub(crate) fn words(&self) -> String {
        let fit = if self.p_lack_of_fit.is_nan() {
            "too few conditions to test its shape".to_owned()
        } else if self.p_lack_of_fit < ALPHA {
            format!(
                "an ideal clip misses them (lack of fit p = {}), by less than 2 % at every radius, \
                 and the turns on a lower bus are slower",
                super::signature::format_p(self.p_lack_of_fit)
            )
        } else {
            format!("its shape fits, lack of fit p = {:.2}", self.p_lack_of_fit)
        };
        let bus = self
            .bus_v
            .map_or(String::new(), |v| format!(" on their {v:.1} V bus"));
        format!(
            "but a drive that reaches only {:.3} m/s of the {:.3} m/s these turns command{bus} \
             slows the same turns alike ({fit}): timing alone cannot tell the ground's slip from \
             the drive's top speed; drive the R′ turns slower, or measure the wheels' speed",
            self.top_speed_mps, self.fastest_cmd_mps
        )
    }
}

/// A drive's top speed as a function of its bus voltage: `at_ref` m/s at `v_ref`, changing by
/// `beta` × proportionally with the bus (1: a top speed proportional to the voltage, as at no
/// load; below 1: the winding's IR drop under load takes a fixed share).
#[derive(Debug, Clone, Copy)]
struct TopSpeed {
    at_ref: f64,
    v_ref: f64,
    beta: f64,
}

impl TopSpeed {
    fn at(&self, bus_v: f64) -> f64 {
        self.at_ref * (1.0 + self.beta * (bus_v - self.v_ref) / self.v_ref)
    }
}

/// Steps of the bus dependence `beta` between 0 and 1.
const BETA_STEPS: usize = 10;

/// One turn: its slip beyond the reference, its side commands (inner, outer) and bus voltage.
struct Turn {
    excess: f64,
    v_in: f64,
    v_out: f64,
    bus_v: f64,
    rho: f64,
    v_c: f64,
}

impl Turn {
    /// The slip beyond the reference that the top speed `top` takes from this turn.
    fn predicted(&self, top: &TopSpeed, s0: f64) -> f64 {
        let cap = top.at(self.bus_v);
        let capped = |v: f64| v.signum() * v.abs().min(cap);
        let commanded = self.v_out - self.v_in;
        (1.0 - s0) * (1.0 - (capped(self.v_out) - capped(self.v_in)) / commanded)
    }

    /// Fastest commanded wheel speed.
    fn fastest(&self) -> f64 {
        self.v_out.abs().max(self.v_in.abs())
    }
}

/// The ceiling that explains the runs' yaw-timed turns with R ≤ R′ beyond the reference slip
/// `s0` (the point turns'), or `None`: no ceiling slows a turn by [`MIN_SLIP_EXCESS`] and fits
/// better than none, or its shape is rejected (p < [`ALPHA`], and missing a condition's mean
/// by more than [`MIN_SLIP_EXCESS`] or not followed by the turns' bus voltages).
pub(crate) fn explains(rows: &[TurnRow], calibration: &[TurnRow], s0: f64) -> Option<SpeedCeiling> {
    let with_bus = rows.iter().all(|r| r.bus_v > 0.0);
    let turns: Vec<Turn> = yaw_timed(rows)
        .filter(|(r, _)| r.r_over_r_prime <= MAX_RHO)
        .filter_map(|(r, slip)| {
            let (v_in, v_out) = (r.sides[0].cmd_mps, r.sides[1].cmd_mps);
            (v_out - v_in > 1e-6).then_some(Turn {
                excess: slip - s0,
                v_in,
                v_out,
                bus_v: if with_bus { r.bus_v } else { 1.0 },
                rho: r.r_over_r_prime,
                v_c: r.v_c_mps,
            })
        })
        .collect();
    let n = turns.len();
    if n == 0 {
        return None;
    }
    let fastest_cmd_mps = turns.iter().map(Turn::fastest).fold(0.0, f64::max);
    let slowest_cmd_mps = turns
        .iter()
        .map(Turn::fastest)
        .fold(f64::INFINITY, f64::min);
    let at_fastest: Vec<f64> = turns
        .iter()
        .filter(|t| t.fastest() >= fastest_cmd_mps * (1.0 - 1e-9))
        .map(|t| t.bus_v)
        .collect();
    let v_ref = at_fastest.iter().sum::<f64>() / at_fastest.len() as f64;
    // The calibration is taken as driven at its commands (the baseline is fitted on it so): a
    // top speed below a wheel speed the calibration reached on its bus is no rival.
    let reached: Vec<(f64, f64)> = calibration
        .iter()
        .filter(|r| r.bus_v > 0.0 && with_bus)
        .map(|r| {
            (
                r.sides[0].cmd_mps.abs().max(r.sides[1].cmd_mps.abs()),
                r.bus_v,
            )
        })
        .collect();
    let ss = |top: &TopSpeed| -> f64 {
        turns
            .iter()
            .map(|t| (t.excess - t.predicted(top, s0)).powi(2))
            .sum()
    };
    let unbound = ss(&TopSpeed {
        at_ref: 2.0 * fastest_cmd_mps,
        v_ref,
        beta: 0.0,
    });
    let (top, ss_ceiling) = (0..=BETA_STEPS)
        .flat_map(|j| {
            (0..=GRID).map(move |i| TopSpeed {
                at_ref: 0.5 * slowest_cmd_mps
                    + (fastest_cmd_mps - 0.5 * slowest_cmd_mps) * i as f64 / GRID as f64,
                v_ref,
                beta: j as f64 / BETA_STEPS as f64,
            })
        })
        .filter(|top| reached.iter().all(|&(v, bus)| top.at(bus) >= v))
        .map(|top| (top, ss(&top)))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    // A ceiling that slows no turn by the mark's floor explains no mark.
    let slowest = turns
        .iter()
        .map(|t| t.predicted(&top, s0))
        .fold(0.0, f64::max);
    if ss_ceiling >= unbound || slowest < MIN_SLIP_EXCESS {
        return None;
    }
    let groups = conditions(&turns);
    let k = groups.len();
    let ss_within: f64 = groups
        .iter()
        .map(|g| {
            let mean = g.iter().map(|&i| turns[i].excess).sum::<f64>() / g.len() as f64;
            g.iter()
                .map(|&i| (turns[i].excess - mean).powi(2))
                .sum::<f64>()
        })
        .sum();
    // Two parameters: the top speed and its bus dependence.
    let p = if k < 3 || n <= k || ss_within <= 1e-12 {
        f64::NAN
    } else {
        let f = ((ss_ceiling - ss_within).max(0.0) / (k - 2) as f64) / (ss_within / (n - k) as f64);
        f_upper_tail(f, k - 2, n - k).unwrap_or(f64::NAN)
    };
    // An ideal clip misses a real drive's turns a little (a drive saturates softly, and the
    // ground slips less at the slower wheel). A significant miss is forgiven only where it is
    // below the mark's own floor and the turns follow the bus as a top speed does: within each
    // condition, those on a lower bus slower by as much as the ceiling says.
    let worst_miss = groups
        .iter()
        .map(|g| {
            let miss: f64 = g
                .iter()
                .map(|&i| turns[i].excess - turns[i].predicted(&top, s0))
                .sum();
            (miss / g.len() as f64).abs()
        })
        .fold(0.0, f64::max);
    if p < ALPHA && (worst_miss > MIN_SLIP_EXCESS || !follows_the_bus(&turns, &groups, &top, s0)) {
        return None;
    }
    Some(SpeedCeiling {
        top_speed_mps: top.at(v_ref),
        fastest_cmd_mps,
        bus_v: with_bus.then_some(v_ref),
        p_lack_of_fit: p,
    })
}

/// Whether, within conditions, the turns' slip follows the ceiling's prediction from each
/// turn's own bus voltage: the slope through the origin of the slip's deviations from their
/// condition's mean on the prediction's, one-sided t, p < [`ALPHA`]. A ground's slip does not
/// know the bus.
fn follows_the_bus(turns: &[Turn], groups: &[Vec<usize>], top: &TopSpeed, s0: f64) -> bool {
    let mut pairs = Vec::new();
    for g in groups {
        let mean = |f: &dyn Fn(&Turn) -> f64| {
            g.iter().map(|&i| f(&turns[i])).sum::<f64>() / g.len() as f64
        };
        let (e_mean, p_mean) = (mean(&|t| t.excess), mean(&|t| t.predicted(top, s0)));
        pairs.extend(g.iter().map(|&i| {
            (
                turns[i].predicted(top, s0) - p_mean,
                turns[i].excess - e_mean,
            )
        }));
    }
    let dof = turns.len() as f64 - groups.len() as f64 - 1.0;
    let sxx: f64 = pairs.iter().map(|(x, _)| x * x).sum();
    if dof < 1.0 || sxx <= 1e-12 {
        return false;
    }
    let slope = pairs.iter().map(|(x, y)| x * y).sum::<f64>() / sxx;
    let ss_res: f64 = pairs.iter().map(|(x, y)| (y - slope * x).powi(2)).sum();
    let se = (ss_res / dof / sxx).sqrt();
    se > 0.0 && t_upper(slope / se, dof) < ALPHA
}

/// The turns grouped by condition: R/R′ within 0.05 + 10 % and v_c within 15 %.
fn conditions(turns: &[Turn]) -> Vec<Vec<usize>> {
    let alike = |a: &Turn, b: &Turn| {
        (a.rho - b.rho).abs() <= 0.05 + 0.1 * a.rho.max(b.rho)
            && (a.v_c - b.v_c).abs() <= 0.15 * a.v_c.max(b.v_c)
    };
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, t) in turns.iter().enumerate() {
        match groups.iter_mut().find(|g| alike(&turns[g[0]], t)) {
            Some(g) => g.push(i),
            None => groups.push(vec![i]),
        }
    }
    groups
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::matched_slip::tests::turn;

    const V_C: f64 = 0.3;

    /// Three runs of turns at R/R′ 0, 1/3, 2/3, 0.8 and 1 under Eq 2.6 at v_c 0.3 m/s, each run
    /// on its own battery charge and the bus sagging with the outer command, each turn's slip
    /// `slip(R/R′, inner, outer, bus)` plus a repeat noise of ±0.2 % that knows nothing of the bus.
    fn drive(slip: impl Fn(f64, f64, f64, f64) -> f64) -> Vec<TurnRow> {
        let noise = [
            [0.0, 2.0, -2.0, 1.0, -1.0],
            [2.0, -1.0, 0.0, -2.0, 1.0],
            [-2.0, -1.0, 2.0, 1.0, 0.0],
        ];
        let mut rows = Vec::new();
        for (run, noise) in noise.iter().enumerate() {
            for (rho, noise) in [0.0, 1.0 / 3.0, 2.0 / 3.0, 0.8, 1.0].into_iter().zip(noise) {
                let (v_in, v_out) = (V_C * (rho - 1.0), V_C * (1.0 + rho));
                let bus = 24.0 - 3.0 * v_out - 0.3 * run as f64;
                let slip = slip(rho, v_in, v_out, bus) + 0.001 * noise;
                let mut r = turn(run, rho, slip, bus, 0.0);
                r.sides[0].cmd_mps = v_in;
                r.sides[1].cmd_mps = v_out;
                rows.push(r);
            }
        }
        rows
    }

    /// The slip of a drive whose top speed is `per_volt` × the bus, clipped softly over `soft`
    /// m/s (0: an ideal clip), on top of a ground slip `s0`.
    fn ceiling(s0: f64, per_volt: f64, soft: f64) -> impl Fn(f64, f64, f64, f64) -> f64 {
        move |_, v_in, v_out, bus| {
            let cap = per_volt * bus;
            let reached = if soft > 0.0 {
                cap - soft * ((cap - v_out) / soft).exp().ln_1p()
            } else {
                v_out.min(cap)
            };
            s0 + (1.0 - s0) * (v_out - reached) / (v_out - v_in)
        }
    }

    #[test]
    fn a_drive_that_cannot_reach_r_primes_wheel_speed_explains_its_slowdown() {
        // A top speed of 0.025 m/s per volt (0.55 m/s on the R′ turns' 21.9 V bus) against the
        // 0.6 m/s R′ asks for: R′ turns 8 % slower, 0.8 R′ 2 %, the rest on time.
        let s0 = 0.05;
        let rows = drive(ceiling(s0, 0.025, 0.0));
        let found = explains(&rows, &[], s0).expect("the ceiling explains the slowdown");
        let bus = found.bus_v.expect("the turns carry their bus voltage");
        assert!((bus - 21.9).abs() < 1e-9, "{found:?}");
        assert!(
            (found.top_speed_mps / (0.025 * bus) - 1.0).abs() < 0.02,
            "{found:?}"
        );
        assert!((found.fastest_cmd_mps - 0.6).abs() < 1e-9);
        assert!(found.words().contains("drive the R′ turns slower"));
    }

    #[test]
    fn a_soft_ceiling_is_still_a_ceiling_when_the_turns_follow_the_bus() {
        // A drive that saturates over 0.025 m/s: the ideal clip misses its conditions' means
        // beyond their noise, by less than the mark's floor, and each run's turns slow with
        // its bus.
        let s0 = 0.05;
        let rows = drive(ceiling(s0, 0.025, 0.025));
        assert!(explains(&rows, &[], s0).is_some());
    }

    #[test]
    fn a_ground_slip_rising_towards_r_prime_is_not_a_ceiling() {
        // World D's angular-slip effect: a slip peaking at R′ over a width in R′. A broad one
        // (10 % at R′ over 0.45 R′) cannot be a ceiling's fixed-slope rise from its knee; a
        // narrow one (20 % over 0.30 R′) nearly is, but it does not follow the bus.
        let s0 = 0.05;
        for (a, width) in [(0.10, 0.45), (0.20, 0.30)] {
            let rows = drive(|rho, _, _, _| s0 + a * (-((rho - 1.0) / width).powi(2)).exp());
            assert_eq!(explains(&rows, &[], s0), None, "{a} over {width} R′");
        }
    }

    #[test]
    fn a_top_speed_the_calibration_reached_is_no_rival() {
        // The same ceiling as above, but the calibration drove 0.6 m/s on a 22 V bus: the
        // drive reaches 0.027 m/s per volt, and nothing slower explains the runs.
        let s0 = 0.05;
        let rows = drive(ceiling(s0, 0.025, 0.0));
        let mut fast = turn(0, 1.0, s0, 22.0, 0.0);
        fast.sides[1].cmd_mps = 0.6;
        assert!(explains(&rows, &[], s0).is_some());
        assert_eq!(explains(&rows, &[fast], s0), None);
    }

    #[test]
    fn turns_on_time_need_no_ceiling() {
        let rows = drive(|_, _, _, _| 0.05);
        assert_eq!(explains(&rows, &[], 0.05), None);
    }
}
