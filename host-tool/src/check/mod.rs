//! `host-tool check`: is this board healthy? A bring-up check with a pass/fail line per step and
//! a hint for each failure, for the first hour with a new board.
//!
//! The steps, in order (a step that cannot run after an earlier failure is `not-run`):
//! port (found by VID:PID or given) → open → DTR → hello (within a timeout, this protocol) →
//! chips (IDs 0x5449/0x2260, CAL read back) → averaging (configuration register read back) →
//! rate, losses, chip stability, bus voltages, standstill current (over a window of samples) →
//! configure (a `Configure` read back, then the original restored).
//!
//! This module holds the report types and the pure verdict of each step; [`session`] talks to a
//! port, [`sim`] runs the simulated board with injected faults.

pub mod hint;
pub mod session;
pub mod sim;
pub mod verdicts;
pub mod wiring;

pub use hint::{Hint, Side};

use std::fmt;
use std::time::Duration;

/// The steps of the check, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StepId {
    Port,
    Open,
    Dtr,
    Hello,
    Chips,
    Averaging,
    Rate,
    Losses,
    ChipStability,
    BusVoltages,
    Standstill,
    Configure,
}

impl StepId {
    /// Every step, in the order they run.
    pub const ALL: [StepId; 12] = [
        StepId::Port,
        StepId::Open,
        StepId::Dtr,
        StepId::Hello,
        StepId::Chips,
        StepId::Averaging,
        StepId::Rate,
        StepId::Losses,
        StepId::ChipStability,
        StepId::BusVoltages,
        StepId::Standstill,
        StepId::Configure,
    ];

    /// What the step checks, as the table shows it.
    pub fn title(self) -> &'static str {
        match self {
            StepId::Port => "board port",
            StepId::Open => "open port",
            StepId::Dtr => "assert DTR",
            StepId::Hello => "hello",
            StepId::Chips => "chips (ID, CAL)",
            StepId::Averaging => "averaging",
            StepId::Rate => "sample rate",
            StepId::Losses => "losses",
            StepId::ChipStability => "chip stability",
            StepId::BusVoltages => "bus voltages",
            StepId::Standstill => "standstill current",
            StepId::Configure => "configure",
        }
    }
}

/// How a step ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Outcome {
    Pass,
    Fail,
    /// An earlier step failed, so this one could not run.
    NotRun,
}

/// One step's result.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    pub id: StepId,
    pub outcome: Outcome,
    /// What was found (figures, IDs).
    pub detail: String,
    /// What to do, when it failed.
    pub hint: Option<Hint>,
}

impl Step {
    pub fn pass(id: StepId, detail: impl Into<String>) -> Self {
        Step {
            id,
            outcome: Outcome::Pass,
            detail: detail.into(),
            hint: None,
        }
    }

    pub fn fail(id: StepId, detail: impl Into<String>, hint: Hint) -> Self {
        Step {
            id,
            outcome: Outcome::Fail,
            detail: detail.into(),
            hint: Some(hint),
        }
    }

    pub fn not_run(id: StepId) -> Self {
        Step {
            id,
            outcome: Outcome::NotRun,
            detail: String::new(),
            hint: None,
        }
    }
}

impl serde::Serialize for Step {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut s = serializer.serialize_struct("Step", 5)?;
        s.serialize_field("step", &self.id)?;
        s.serialize_field("outcome", &self.outcome)?;
        s.serialize_field("detail", &self.detail)?;
        s.serialize_field("hint_kind", &self.hint.as_ref().map(Hint::kind))?;
        s.serialize_field("hint", &self.hint.as_ref().map(ToString::to_string))?;
        s.end()
    }
}

/// The whole check: every step, in order.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CheckReport {
    /// The port checked (`None` when none was found).
    pub port: Option<String>,
    /// Whether every step passed (the exit code is 0 only then).
    pub passed: bool,
    pub steps: Vec<Step>,
}

impl CheckReport {
    /// A report of `steps`, the steps not given filled in as not run.
    pub fn new(port: Option<String>, mut steps: Vec<Step>) -> Self {
        for id in StepId::ALL {
            if !steps.iter().any(|s| s.id == id) {
                steps.push(Step::not_run(id));
            }
        }
        steps.sort_by_key(|s| StepId::ALL.iter().position(|&id| id == s.id));
        let passed = steps.iter().all(|s| s.outcome == Outcome::Pass);
        CheckReport {
            port,
            passed,
            steps,
        }
    }

    /// The first failed step.
    pub fn first_failure(&self) -> Option<&Step> {
        self.steps.iter().find(|s| s.outcome == Outcome::Fail)
    }

    /// The step `id`.
    pub fn step(&self, id: StepId) -> Option<&Step> {
        self.steps.iter().find(|s| s.id == id)
    }
}

impl fmt::Display for CheckReport {
    /// One line per step (`PASS`, `FAIL`, `----`), the hint indented under a failure.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let width = StepId::ALL
            .iter()
            .map(|s| s.title().len())
            .max()
            .unwrap_or(0);
        for step in &self.steps {
            let mark = match step.outcome {
                Outcome::Pass => "PASS",
                Outcome::Fail => "FAIL",
                Outcome::NotRun => "----",
            };
            let detail = match step.outcome {
                Outcome::NotRun => "not run (an earlier step failed)",
                Outcome::Pass | Outcome::Fail => &step.detail,
            };
            writeln!(f, "{mark}  {:<width$}  {detail}", step.id.title())?;
            if let Some(hint) = &step.hint {
                writeln!(f, "      {:<width$}  hint: {hint}", "")?;
            }
        }
        let verdict = if self.passed {
            "board healthy: every step passed"
        } else {
            "board NOT ready: fix the first failed step and run the check again"
        };
        writeln!(f, "{verdict}")
    }
}

/// How long and how strictly the check looks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// How long to wait for the hello after DTR.
    pub hello_timeout: Duration,
    /// How long to watch the stream (rate, losses, voltages, currents).
    pub window: Duration,
    /// How long to wait for each command's answer.
    pub answer_timeout: Duration,
    /// Largest relative departure of the sample rate from the configured one.
    pub rate_tolerance: f64,
    /// Largest difference between the two chips' mean bus voltages [V] (one battery).
    pub bus_tolerance_v: f64,
    /// Lowest bus voltage that counts as a battery [V].
    pub min_bus_v: f64,
    /// Largest mean current per side at standstill [A]. The seed's Fig. 3.3 shows the Husky's
    /// built-in sensing reading 0.59 A at rest; diagnose takes up to 0.25 A as a driver's
    /// quiescent draw.
    pub standstill_max_a: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            hello_timeout: Duration::from_secs(3),
            window: Duration::from_secs(3),
            answer_timeout: Duration::from_secs(2),
            rate_tolerance: 0.01,
            bus_tolerance_v: 0.2,
            min_bus_v: 1.0,
            standstill_max_a: 0.25,
        }
    }
}

#[cfg(test)]
mod tests;
