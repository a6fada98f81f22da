//! `host-tool check`: is the board healthy? One pass/fail line per step, a hint per failure.

use super::output::{self, JsonOut};
use anyhow::{bail, Context, Result};
use host_tool::check::sim::{SimFault, SimulatedBoard};
use host_tool::check::{session, Limits};
use host_tool::serial::list_ports;
use host_tool::sim::board::Pacing;
use std::time::Duration;

/// `check [--port P | --simulated [--fault F]] [--window-s S] [--json FILE|-]`.
#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// The board's port (default: the one port with the board's VID:PID and serial prefix).
    #[arg(long, conflicts_with = "simulated")]
    port: Option<String>,
    /// Check the simulated board (the firmware's own code on simulated chips, through a pty).
    #[arg(long)]
    simulated: bool,
    /// With --simulated: inject a fault (missing-chip, wrong-id, reset-chip, no-dtr,
    /// wrong-protocol, silent-port, standstill-offset) to see its failure and hint.
    #[arg(long, requires = "simulated", value_parser = SimFault::parse)]
    fault: Option<SimFault>,
    /// Seconds to watch the stream (rate, losses, resets, voltages, currents).
    #[arg(long = "window-s", default_value_t = 3.0, value_parser = positive_seconds)]
    window_s: f64,
    /// Seconds to wait for the board's hello after DTR.
    #[arg(long = "hello-timeout-s", default_value_t = 3.0, value_parser = positive_seconds)]
    hello_timeout_s: f64,
    /// Largest mean current per side at standstill [A] (the thesis' Fig. 3.3 offset: 0.59 A).
    #[arg(long = "standstill-max-a", default_value_t = 0.25, value_parser = positive_seconds)]
    standstill_max_a: f64,
    /// Largest difference between the chips' bus voltages [V] (both measure one battery).
    #[arg(long = "bus-tolerance-v", default_value_t = 0.2, value_parser = positive_seconds)]
    bus_tolerance_v: f64,
    #[command(flatten)]
    json: JsonOut,
    /// Overwrite an existing --json file.
    #[arg(long)]
    force: bool,
}

/// A finite number > 0.
fn positive_seconds(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(format!("{text:?} must be a finite number > 0")),
    }
}

impl CheckArgs {
    /// Runs the check; fails (exit 1) unless every step passed.
    pub fn run(self) -> Result<()> {
        self.json.check(self.force)?;
        let limits = Limits {
            hello_timeout: Duration::from_secs_f64(self.hello_timeout_s),
            window: Duration::from_secs_f64(self.window_s),
            standstill_max_a: self.standstill_max_a,
            bus_tolerance_v: self.bus_tolerance_v,
            ..Limits::default()
        };
        let report = if self.simulated {
            let board = SimulatedBoard::spawn(self.fault, Pacing::RealTime)
                .context("starting the simulated board")?;
            let mut open = board.opener();
            let path = board.path().to_owned();
            let report = session::run(Some(&path), &[], &mut open, &limits);
            board.finish().context("the simulated board")?;
            report
        } else {
            let ports = if self.port.is_some() {
                Vec::new()
            } else {
                list_ports()?
            };
            let mut open = session::serial_opener();
            session::run(self.port.as_deref(), &ports, &mut open, &limits)
        };
        // As every command: with --json (file or stdout) no table.
        self.json.emit(&report, "check report", self.force)?;
        if self.json.json.is_none() {
            output::print(&report)?;
        }
        if let Some(failed) = report.first_failure() {
            let count = report
                .steps
                .iter()
                .filter(|s| s.outcome == host_tool::check::Outcome::Fail)
                .count();
            bail!(
                "the board is not ready: {count} step(s) failed, first: {}",
                failed.id.title()
            );
        }
        Ok(())
    }
}
