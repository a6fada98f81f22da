//! The command line: one module per command (an args struct with `run`, as probe-rs's `cmd/`),
//! the conventions they share ([`output`]) and the exit codes. `main.rs` only dispatches.

pub mod check;
pub mod convert;
pub mod decode;
pub mod demo;
pub mod diagnose;
pub mod diagnose_bench;
pub mod output;
pub mod plan;
pub mod plot;
pub mod ports;
pub mod record;
pub mod replay;
pub mod serve;
pub mod validate;

use clap::{Parser, Subcommand};
use host_tool::eprintln_best_effort;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set from `--salvage` before the command runs.
static SALVAGE: AtomicBool = AtomicBool::new(false);
/// Set when a run log a command read lost data to damage.
static DATA_LOST: AtomicBool = AtomicBool::new(false);

/// Records `--salvage` for the commands (a global flag of every command).
pub fn set_salvage(salvage: bool) {
    SALVAGE.store(salvage, Ordering::Relaxed);
}

/// Whether `--salvage` was given.
pub fn salvage() -> bool {
    SALVAGE.load(Ordering::Relaxed)
}

/// Prints the damage `warnings` of a run log read and, when data inside it was lost, makes the
/// exit code 4 (unless `--salvage`).
pub fn report_damage(warnings: &[String], lost_data: bool) {
    for w in warnings {
        eprintln_best_effort!("{w}");
    }
    if lost_data {
        DATA_LOST.store(true, Ordering::Relaxed);
    }
}

/// The conventions every command follows, shown under each `--help`.
pub const CONVENTIONS: &str = "\
Conventions (every command):
  --json FILE|-   JSON to FILE, or to stdout with `-` (or `--json` alone; then no table is printed)
  outputs         an existing file, or a non-empty output directory, is refused unless --force;
                  missing directories are created; files and output directories are written
                  whole or not at all
  units           options with a unit carry it in their name (--duration-s, --distance-m)
Exit codes: 0 done; 1 error; 2 bad arguments; 3 the runs depart from the model
(validate, diagnose with --fail-on-departure); 4 a run log lost data to damage (the outputs hold
the rest; --salvage accepts that: 0); a closed stdout (`| head`) ends quietly with 0, a
closed stderr loses only the messages.";

/// The rover-power host tool.
#[derive(Parser, Debug)]
#[command(version, about = "rover-power host tool", after_help = CONVENTIONS)]
pub struct Cli {
    /// Hide progress bars (they are drawn only on a terminal anyway).
    #[arg(long, global = true)]
    pub quiet: bool,
    /// Accept a damaged run log: use what could be read (exit 0, not 4) and leave out damaged
    /// run CSV rows instead of refusing them.
    #[arg(long, global = true)]
    pub salvage: bool,
    /// The command.
    #[command(subcommand)]
    pub command: Command,
}

/// The commands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// The main job, no hardware needed: a simulated Husky A200 drives the thesis' turn set in
    /// loose sand; the firmware's own code samples it through simulated INA226 chips into a
    /// pseudo-terminal; the recorder reads it like /dev/ttyACM0; the runs are validated against
    /// the power models of the thesis and its paper, diagnosed and planned with. Tables on the terminal; logs,
    /// reports and figures in --out.
    #[command(after_help = CONVENTIONS)]
    Demo(demo::DemoArgs),
    /// Bring-up check: is the board healthy? Finds it by VID:PID (or --port), asserts DTR,
    /// waits for its hello, checks both INA226 (IDs, CAL, averaging read back), the sample rate,
    /// losses, chip resets, the two bus voltages, the standstill currents, and a Configure read
    /// back; one PASS/FAIL line per step with a hint for each failure. Exit 0 only when every
    /// step passes. --simulated checks the simulated board (--fault injects one).
    #[command(after_help = CONVENTIONS)]
    Check(check::CheckArgs),
    /// List the serial ports: name, USB VID:PID, product, manufacturer, serial number.
    #[command(after_help = CONVENTIONS)]
    Ports(ports::PortsArgs),
    /// Record the board's stream from a serial port into a run log, with a live status line.
    /// Stops on Ctrl-C, --duration-s or --samples; waits --reconnect-timeout-s for an
    /// unplugged board to come back (a pseudo-terminal, e.g. a replay's, ends the recording
    /// when it closes).
    #[command(after_help = CONVENTIONS)]
    Record(record::RecordArgs),
    /// Validate runs against the power models of the thesis and its paper: cut them into manoeuvres from the
    /// commanded speeds, print a per-turn table (R_cmd, R/R', regime, duration vs expected,
    /// angular slip, power, energy, τ ∝ P/ω), fit the ICR model (c1, c2, c3 with pitch) with
    /// 95 % bounds and r², flag where measured power departs from it, and cross-check the
    /// board's model frames against the host's recomputation.
    #[command(after_help = CONVENTIONS)]
    Validate(validate::ValidateArgs),
    /// Draw the validation figures of runs: power vs time per turn (one file per run), average
    /// and maximum power vs R/R' with the model curves, τ ∝ P/ω per side, residuals.
    #[command(after_help = CONVENTIONS)]
    Plot(plot::PlotArgs),
    /// Convert a run log between MCAP (.mcap) and the run CSV (.csv), or normalise one (same
    /// format in and out; repairs an MCAP file cut short by a killed recorder). CSV → MCAP adds
    /// the wire frames the board would have sent (registers quantised at 1.25 mV / 0.5 mA), so
    /// the result replays like a recording.
    #[command(after_help = CONVENTIONS)]
    Convert(convert::ConvertArgs),
    /// Replay a run log (.mcap or .csv) as the board's byte stream: into a pseudo-terminal that
    /// other tools open like /dev/ttyACM0, or into a capture file for `decode`. The commanded
    /// speeds travel as the board's status reports, so `record` on the pty logs them.
    #[command(after_help = CONVENTIONS)]
    Replay(replay::ReplayArgs),
    /// Decode a raw capture of the board's serial stream and summarise it: frames, losses,
    /// duration, and the board's model frames and energy against the host's recomputation.
    #[command(after_help = CONVENTIONS)]
    Decode(decode::DecodeArgs),
    /// Diagnose the gap between the hard-ground model and the runs: where it departs (gaps per
    /// regime and side, significant beyond the repeat noise), which catalogued unmodelled effect
    /// explains it (grouped cross-validation, penalised; named only when its own signature is in
    /// the data, e.g. the standstill current for a sensor offset, and against a baseline that
    /// misfits its calibration only when that signature needs no power model), and how much of
    /// the held-out gap it closes. Table on the terminal; JSON with --json; report, figures and a
    /// `plan --model` file with --out.
    #[command(after_help = CONVENTIONS)]
    Diagnose(diagnose::DiagnoseArgs),
    /// Checks `diagnose` on simulated datasets whose effect and structure it is not told, drawn
    /// from a world family (power split, constant angular slip, motor losses, standstill draw,
    /// Husky or Argo, turn direction, speed, rate, noise): each carries one catalogue effect,
    /// none (control) or only a non-default structure; prints per part (tuning, held-out) the
    /// confusion matrix, accuracy per structure, the regime hit rate and the median shrink beside
    /// its ceiling (each effect dataset simulated again without its effect).
    #[command(after_help = CONVENTIONS)]
    DiagnoseBench(diagnose_bench::DiagnoseBenchArgs),
    /// Energy of the optimal CLC path (arc – line – arc) against the PLP path (point turn –
    /// line – point turn) between two poses (paper Eq 23–50). Headings are in the path frame:
    /// from the start-to-end line, counter-clockwise positive, both in (0, 90] or both in
    /// [-90, 0).
    #[command(after_help = CONVENTIONS)]
    Plan(plan::PlanArgs),
}

/// The runs depart from the model (`--fail-on-departure`): exit code 3.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Departure(pub String);

/// The exit code of a command's result: 0 done, 3 a departure (`--fail-on-departure`), 4 done
/// but a run log lost data (without `--salvage`), 1 any other error (printed on stderr); a closed stdout is not an error (0, nothing printed).
pub fn exit_code(result: anyhow::Result<()>) -> ExitCode {
    let Err(error) = result else {
        if DATA_LOST.load(Ordering::Relaxed) && !salvage() {
            eprintln_best_effort!(
                "error: data was lost to damage (see the warnings above); the outputs hold the \
                 rest. --salvage accepts that (exit 0)."
            );
            return ExitCode::from(4);
        }
        return ExitCode::SUCCESS;
    };
    let closed_stdout = error.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    });
    if closed_stdout {
        return ExitCode::SUCCESS;
    }
    if let Some(departure) = error.downcast_ref::<Departure>() {
        eprintln_best_effort!("departure: {departure}");
        return ExitCode::from(3);
    }
    eprintln_best_effort!("Error: {}", error_text(&error));
    ExitCode::FAILURE
}

/// The error's message and its causes, each cause once: a library error names its source in
/// its own text (whole when shown alone, as in a report), so a cause whose text the message
/// already holds is not printed again (`{:#}` would: `x.csv: No such file or directory (os
/// error 2): No such file or directory (os error 2)`).
fn error_text(error: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in error.chain() {
        let cause = cause.to_string();
        if text.contains(&cause) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&cause);
    }
    text
}

#[cfg(test)]
mod tests {
    use super::error_text;
    use anyhow::Context;
    use std::io;

    #[derive(Debug, thiserror::Error)]
    #[error("{path}: {source}")]
    struct Named {
        path: &'static str,
        #[source]
        source: io::Error,
    }

    #[derive(Debug, thiserror::Error)]
    #[error("{0}")]
    struct Quoting(#[source] Named);

    #[test]
    fn error_text_prints_each_cause_once() {
        let missing = || io::Error::new(io::ErrorKind::NotFound, "No such file or directory");
        // A source quoted in the message, twice over (wrapper and file error).
        let quoted = anyhow::Error::new(Quoting(Named {
            path: "nosuch.csv",
            source: missing(),
        }));
        assert_eq!(error_text(&quoted), "nosuch.csv: No such file or directory");
        // Context that does not quote its cause keeps it, once.
        let context = Err::<(), _>(missing())
            .context("reading x.csv")
            .expect_err("error");
        assert_eq!(
            error_text(&context),
            "reading x.csv: No such file or directory"
        );
        // Both: context above a quoting error.
        let both = Err::<(), _>(Named {
            path: "/dev/ttyNOPE",
            source: missing(),
        })
        .context("record")
        .expect_err("error");
        assert_eq!(
            error_text(&both),
            "record: /dev/ttyNOPE: No such file or directory"
        );
    }
}
