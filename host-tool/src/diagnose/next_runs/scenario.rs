//! The scenario file writer: the suggestions as the scenario the simulator drives, and as a
//! scenario file that says what each manoeuvre separates.

use super::drivable::{DEFAULT_STRAIGHT_M, PAUSE_S};
use super::suggestion::{NextRun, NextRuns};
use crate::scenario::{Manoeuvre, Scenario, Side};
use std::fmt::Write as _;

impl NextRuns {
    /// The suggestions as a scenario (what `demo --scenario` and the simulator drive).
    pub fn scenario(&self) -> Scenario {
        let manoeuvres = self
            .runs
            .iter()
            .flat_map(|r| std::iter::repeat_n(manoeuvre_of(r), r.repeats as usize))
            .collect();
        Scenario {
            repeats: 1,
            pause_s: PAUSE_S,
            lead_in_s: PAUSE_S,
            lead_out_s: PAUSE_S,
            manoeuvres,
        }
    }

    /// [`NextRuns::scenario`] as a scenario file, each manoeuvre with what it separates.
    pub fn scenario_toml(&self) -> String {
        let mut out = String::from(
            "# What to drive next, written by `host-tool diagnose --next-runs`: the manoeuvres\n\
             # that separate the rivals the diagnosis left in play, by the repeat noise σ of the\n\
             # runs diagnosed. Drive it as one run (`host-tool demo --scenario FILE` drives it on\n\
             # the simulated rover), then diagnose the runs again with it added.\n",
        );
        let _ = writeln!(
            out,
            "# In play: {}.",
            self.in_play
                .iter()
                .map(|r| r.label())
                .collect::<Vec<_>>()
                .join(", ")
        );
        let _ = writeln!(
            out,
            "repeats = 1\npause_s = {PAUSE_S:?}\nlead_in_s = {PAUSE_S:?}\nlead_out_s = {PAUSE_S:?}"
        );
        for r in &self.runs {
            let _ = writeln!(out, "\n# {}", r.describe());
            let block = match manoeuvre_of(r) {
                Manoeuvre::Straight {
                    distance_m,
                    speed_mps,
                } => format!(
                    "[[manoeuvres]]\nkind = \"straight\"\ndistance_m = {distance_m:?}\n\
                     speed_mps = {speed_mps:?}\n"
                ),
                Manoeuvre::Turn {
                    r_over_r_prime,
                    angle_deg,
                    v_c_mps,
                    direction,
                    ..
                } => format!(
                    "[[manoeuvres]]\nkind = \"turn\"\nr_over_r_prime = {:?}\nangle_deg = \
                     {angle_deg:?}\nv_c_mps = {v_c_mps:?}\ndirection = \"{}\"\n",
                    r_over_r_prime.unwrap_or(0.0),
                    match direction {
                        Side::Left => "left",
                        Side::Right => "right",
                    }
                ),
                _ => unreachable!("suggestions are turns and straights"),
            };
            for _ in 0..r.repeats {
                out.push_str(&block);
            }
        }
        out
    }
}

/// The scenario entry of `r`.
fn manoeuvre_of(r: &NextRun) -> Manoeuvre {
    match r.r_over_r_prime {
        Some(x) => Manoeuvre::Turn {
            radius_m: None,
            r_over_r_prime: Some(x),
            angle_deg: r.turn_deg,
            v_c_mps: r.v_c_mps,
            direction: r.direction,
        },
        None => Manoeuvre::Straight {
            distance_m: r.distance_m.unwrap_or(DEFAULT_STRAIGHT_M),
            speed_mps: r.v_c_mps,
        },
    }
}
