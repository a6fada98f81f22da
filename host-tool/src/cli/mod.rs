//! The command line: one module per command (an args struct with `run`, as probe-rs's `cmd/`),
//! the conventions they share ([`output`]) and the exit codes. `main.rs` only dispatches.

pub mod check;
pub mod convert;
pub mod decode;
pub mod demo;
pub mod diagnose;
pub mod diagnose_bench;
pub mod merge;
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

/// `--salvage`, offered by the commands that read run logs.
#[derive(clap::Args, Debug, Clone, Copy, Default)]
pub struct SalvageArg {
    /// Accept a damaged run log: use what could be read (exit 0, not 4) and leave out damaged
    /// run CSV rows instead of refusing them.
    #[arg(long)]
    pub salvage: bool,
}

impl Command {
    /// Whether `--salvage` was given (only the commands that read run logs offer it).
    pub fn salvage(&self) -> bool {
        match self {
            Command::Validate(a) => a.salvage.salvage,
            Command::Plot(a) => a.salvage.salvage,
            Command::Convert(a) => a.salvage.salvage,
            Command::Replay(a) => a.salvage.salvage,
            Command::Diagnose(a) => a.salvage.salvage,
            _ => false,
        }
    }
}

/// `--rover`, the same on every command that needs the rover.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct RoverArg {
    /// Rover TOML (see rovers/; default: the Husky A200, exactly rovers/husky-a200.toml).
    #[arg(long, value_name = "ROVER.toml")]
    pub rover: Option<std::path::PathBuf>,
}

impl RoverArg {
    /// The rover file given, or the Husky A200's.
    pub fn load(&self) -> anyhow::Result<host_tool::rover::RoverFile> {
        Ok(host_tool::rover::load_rover_file_or_husky(
            self.rover.as_deref(),
        )?)
    }
}

/// Records `--salvage` for the commands.
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

/// The conventions the commands follow, shown under each `--help` (a macro, so that each
/// command's examples can be put before it with `concat!`).
macro_rules! conventions {
    () => {
        "\
Conventions:
  --json FILE|-   where a command offers it: JSON to FILE, or to stdout with `-` (or `--json`
                  alone; then no table is printed)
  outputs         an existing file, or a non-empty output directory, is refused unless --force;
                  missing directories are created; files and output directories are written
                  whole or not at all
  units           options with a unit carry it in their name (--duration-s, --distance-m)
Exit codes: 0 done; 1 error; 2 bad arguments; 3 the runs depart from the model
(validate, diagnose with --fail-on-departure); 4 a run log lost data to damage (the outputs hold
the rest; --salvage accepts that: 0); a closed stdout (`| head`) ends quietly with 0, a
closed stderr loses only the messages."
    };
}

/// The conventions, under the top-level `--help`.
pub const CONVENTIONS: &str = conventions!();

/// A command's `after_help`: its examples, then the conventions.
macro_rules! examples {
    ($($line:literal),+ $(,)?) => {
        concat!("Examples:\n", $("  ", $line, "\n",)+ "\n", conventions!())
    };
}

/// The rover-power host tool.
#[derive(Parser, Debug)]
#[command(version, about = "rover-power host tool", after_help = CONVENTIONS)]
pub struct Cli {
    /// Hide progress bars (they are drawn only on a terminal anyway).
    #[arg(long, global = true)]
    pub quiet: bool,
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
    #[command(after_help = examples!(
        "host-tool demo",
        "host-tool demo --out /tmp/demo --runs 1",
        "host-tool demo --serve          # watch it in Foxglove (ws://127.0.0.1:8765)",
    ))]
    Demo(demo::DemoArgs),
    /// Bring-up check: is the board healthy? Finds it by VID:PID (or --port), asserts DTR,
    /// waits for its hello, checks both INA226 (IDs, CAL, averaging read back), the sample rate,
    /// losses, chip resets, the two bus voltages, the standstill currents, and a Configure read
    /// back; one PASS/FAIL line per step with a hint for each failure. Exit 0 only when every
    /// step passes. --simulated checks the simulated board (--fault injects one).
    #[command(after_help = examples!(
        "host-tool check",
        "host-tool check --port /dev/ttyACM0 --json check.json",
        "host-tool check --simulated --fault missing-chip",
    ))]
    Check(check::CheckArgs),
    /// List the serial ports: name, USB VID:PID, product, manufacturer, serial number.
    #[command(after_help = examples!(
        "host-tool ports",
        "host-tool ports --json -",
    ))]
    Ports(ports::PortsArgs),
    /// Record the board's stream from a serial port into a run log, with a live status line.
    /// Stops on Ctrl-C, --duration-s or --samples; waits --reconnect-timeout-s for an
    /// unplugged board to come back (a pseudo-terminal, e.g. a replay's, ends the recording
    /// when it closes).
    #[command(after_help = examples!(
        "host-tool record --port /dev/ttyACM0 --out run-1.mcap",
        "host-tool record --port /dev/ttyACM0 --out run-1.mcap --serve --duration-s 120",
        "host-tool record --port /dev/ttyACM0 --out run-1.csv --commands turns.commands.csv",
    ))]
    Record(record::RecordArgs),
    /// Validate runs against the power models of the thesis and its paper: cut them into manoeuvres from the
    /// commanded speeds, print a per-turn table (R_cmd, R/R', regime, duration vs expected,
    /// angular slip, power, energy, τ ∝ P/ω), fit the ICR model (c1, c2, c3 with pitch) with
    /// 95 % bounds and r², flag where measured power departs from it, and cross-check the
    /// board's model frames against the host's recomputation.
    #[command(after_help = examples!(
        "host-tool validate --rover rovers/husky-a200.toml --runs run-1.mcap run-2.mcap",
        "host-tool validate --rover rovers/husky-a200.toml --runs demo-out/run-?.csv --json report.json",
    ))]
    Validate(validate::ValidateArgs),
    /// Draw the validation figures of runs: power vs time per turn (one file per run), average
    /// and maximum power vs R/R' with the model curves, τ ∝ P/ω per side, residuals.
    #[command(after_help = examples!(
        "host-tool plot --rover rovers/husky-a200.toml --runs run-1.mcap --out figures",
        "host-tool plot --rover rovers/husky-a200.toml --runs demo-out/run-?.csv --out figures --format svg",
    ))]
    Plot(plot::PlotArgs),
    /// Convert a run log between MCAP (.mcap) and the run CSV (.csv), or normalise one (same
    /// format in and out; repairs an MCAP file cut short by a killed recorder, and rewrites a log
    /// of an earlier version, JSON samples, in today's protobuf channels). CSV → MCAP adds
    /// the wire frames the board would have sent (registers quantised at 1.25 mV / 0.5 mA), so
    /// the result replays like a recording.
    #[command(after_help = examples!(
        "host-tool convert run-1.mcap run-1.csv",
        "host-tool convert run-1.csv run-1.mcap",
        "host-tool convert old.mcap new.mcap          # rewrite an older log in today's channels",
        "host-tool convert run-1.mcap run-1-bag --to ros2-bag",
    ))]
    Convert(convert::ConvertArgs),
    /// Merge a board log with the robot's ROS 2 bag of the same drive into one run log: the
    /// bag's commanded twist (side speeds), IMU yaw and pitch, and optionally the tracked pose
    /// land on the board's samples. The two are lined up by wall clock; the offset between the
    /// computers' clocks is measured from the data (the board's power steps where the commands
    /// do) and reported. Then validate, plot and diagnose read the result.
    #[command(after_help = examples!(
        "host-tool merge --board drive-1.mcap --bag rosbag2_drive --out drive-1.merged.mcap",
        "host-tool merge --board drive-1.mcap --bag rosbag2_drive --pose-topic /tracker/pose --out d.csv",
    ))]
    Merge(merge::MergeArgs),
    /// Replay a run log (.mcap or .csv) as the board's byte stream: into a pseudo-terminal that
    /// other tools open like /dev/ttyACM0, or into a capture file for `decode`. The commanded
    /// speeds travel as the board's status reports, so `record` on the pty logs them.
    #[command(after_help = examples!(
        "host-tool replay --to-pty run-1.mcap        # then: host-tool record --port <pty> ...",
        "host-tool replay --serve --speed 5 run-1.mcap",
        "host-tool replay --to capture.bin run-1.mcap",
    ))]
    Replay(replay::ReplayArgs),
    /// Decode a raw capture of the board's serial stream and summarise it: frames, losses,
    /// duration, and the board's model frames and energy against the host's recomputation.
    #[command(after_help = examples!(
        "host-tool decode capture.bin",
        "host-tool decode capture.bin --json -",
    ))]
    Decode(decode::DecodeArgs),
    /// Diagnose the gap between the hard-ground model and the runs: where it departs (gaps per
    /// regime and side, significant beyond the repeat noise), which catalogued unmodelled effect
    /// explains it (grouped cross-validation, penalised; named only when its own signature is in
    /// the data, e.g. the standstill current for a sensor offset, and against a baseline that
    /// misfits its calibration only when that signature needs no power model), and how much of
    /// the held-out gap it closes. Table on the terminal; JSON with --json; report, figures and a
    /// `plan --model` file with --out.
    #[command(after_help = examples!(
        "host-tool diagnose --rover rovers/husky-a200.toml --runs run-1.csv run-2.csv",
        "host-tool diagnose --calibration hard-1.csv --runs sand-1.csv --out diagnosis",
        "host-tool diagnose --rover rovers/husky-a200.toml --runs demo-out/run-?.csv --next-runs next.toml",
    ))]
    Diagnose(diagnose::DiagnoseArgs),
    /// Checks `diagnose` on simulated datasets whose effect and structure it is not told, drawn
    /// from a world family (power split, constant angular slip, motor losses, standstill draw,
    /// Husky or Argo, turn direction, speed, rate, noise): each carries one catalogue effect,
    /// none (control) or only a non-default structure; prints per part (tuning, held-out) the
    /// confusion matrix, accuracy per structure, the regime hit rate and the median shrink beside
    /// its ceiling (each effect dataset simulated again without its effect).
    #[command(after_help = examples!(
        "host-tool diagnose-bench --datasets 100 --seed 1",
        "host-tool diagnose-bench --part held-out --json bench.json",
        "host-tool diagnose-bench --part held-out --explain 17",
    ))]
    DiagnoseBench(diagnose_bench::DiagnoseBenchArgs),
    /// Energy of the optimal CLC path (arc – line – arc) against the PLP path (point turn –
    /// line – point turn) between two poses (paper Eq 23–50). Headings are in the path frame:
    /// from the start-to-end line, counter-clockwise positive, both in (0, 90] or both in
    /// [-90, 0).
    #[command(after_help = examples!(
        "host-tool plan --start-deg 45 --end-deg 45 --distance-m 10",
        "host-tool plan --start-deg 90 --end-deg 90 --distance-m 10 --model demo-out/diagnosis/model.toml",
        "host-tool plan --start-deg 45 --end-deg 45 --distance-m 10 --sweep --figure sweep.png",
    ))]
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
    eprintln_best_effort!("Error: {}", host_tool::stderr::error_text(&error));
    ExitCode::FAILURE
}

#[cfg(test)]
mod examples_tests {
    use super::Cli;
    use clap::{CommandFactory, Parser};

    /// Every example under a command's `--help` parses as that command (a renamed or removed
    /// option breaks this test, not a user's copy of the example), and only the commands that
    /// read run logs offer `--salvage`.
    #[test]
    fn every_example_parses_and_salvage_is_offered_only_where_it_acts() {
        let cli = Cli::command();
        let mut examples = 0;
        for command in cli.get_subcommands() {
            let help = command
                .get_after_help()
                .map(|h| h.to_string())
                .unwrap_or_default();
            let block = help
                .strip_prefix("Examples:\n")
                .unwrap_or_else(|| panic!("{}: no examples", command.get_name()));
            for line in block.lines().take_while(|l| !l.is_empty()) {
                // A trailing `# note` is the example's comment.
                let line = line.split(" #").next().unwrap_or(line);
                // Wider, and `--help` would wrap it onto a line a user cannot copy.
                assert!(
                    line.chars().count() <= 100,
                    "{line}: too long to stay on one line"
                );
                let words: Vec<&str> = line.split_whitespace().collect();
                assert_eq!(words.get(1), Some(&command.get_name()), "{line}");
                if let Err(e) = Cli::try_parse_from(&words) {
                    panic!("{line}: {e}");
                }
                examples += 1;
            }
            let salvage = command.get_arguments().any(|a| a.get_id() == "salvage");
            let reads_run_logs = ["validate", "plot", "convert", "replay", "diagnose"];
            assert_eq!(
                salvage,
                reads_run_logs.contains(&command.get_name()),
                "{}",
                command.get_name()
            );
        }
        assert!(examples >= 24, "{examples}");
    }
}

#[cfg(test)]
mod reference_tests {
    use super::Cli;
    use clap::CommandFactory;
    use std::path::Path;

    /// `docs/cli.md`: every command's `--help`, as the definitions print it.
    fn cli_reference() -> String {
        let mut cli = Cli::command();
        cli.build();
        let mut out = String::from(
            "# CLI reference\n\nEvery command's `--help`, generated from the command-line \
             definitions (a test fails when this page and they differ; \
             `UPDATE_DOCS=1 cargo test -p host-tool --bin host-tool cli_reference` rewrites \
             it).\n\n",
        );
        let names: Vec<String> = cli
            .get_subcommands()
            .map(|c| c.get_name().to_owned())
            .filter(|name| name != "help")
            .collect();
        for name in &names {
            out.push_str(&format!("- [`{name}`](#host-tool-{name})\n"));
        }
        out.push_str(&format!(
            "\n## host-tool\n\n```text\n{}```\n",
            cli.render_long_help()
        ));
        for sub in cli.get_subcommands_mut().filter(|c| c.get_name() != "help") {
            let help = sub.render_long_help().to_string();
            out.push_str(&format!(
                "\n## host-tool {}\n\n```text\n{}```\n",
                sub.get_name(),
                help
            ));
        }
        out
    }

    #[test]
    fn cli_reference_is_the_help_the_commands_print() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/cli.md");
        let want = cli_reference();
        if std::env::var_os("UPDATE_DOCS").is_some() {
            std::fs::write(&path, &want).expect("docs/cli.md written");
        }
        let have = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            have == want,
            "docs/cli.md is not the commands' --help: rewrite it with \
             UPDATE_DOCS=1 cargo test -p host-tool --bin host-tool cli_reference"
        );
    }
}
