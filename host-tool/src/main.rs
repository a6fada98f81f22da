//! `host-tool`: the rover-power host tool's command line. A flat dispatch: each command is an
//! args struct with `run` in `cli/<command>.rs`; the work is in the library.

mod cli;

use clap::Parser;
use cli::{Cli, Command};
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = Cli::parse();
    // A stop signal removes the temporary files of the writes under way before exiting.
    if let Err(e) = host_tool::record::stop_signal::install_for_every_command() {
        host_tool::eprintln_best_effort!(
            "warning: no stop-signal handler ({e}): a stop leaves temporary files"
        );
    }
    host_tool::progress::set_quiet(cli.quiet);
    cli::set_salvage(cli.command.salvage());
    let result = match cli.command {
        Command::Demo(args) => args.run(),
        Command::Ports(args) => args.run(),
        Command::Check(args) => args.run(),
        Command::Record(args) => args.run(),
        Command::Validate(args) => args.run(),
        Command::Plot(args) => args.run(),
        Command::Convert(args) => args.run(),
        Command::Merge(args) => args.run(),
        Command::Replay(args) => args.run(),
        Command::Decode(args) => args.run(),
        Command::Diagnose(args) => args.run(),
        Command::DiagnoseBench(args) => args.run(),
        Command::Plan(args) => args.run(),
    };
    if host_tool::record::stop_signal::exiting() {
        // A stop signal is removing the temporary paths (the command may have failed because
        // they went) and exits with its own code: its exit, not this one.
        loop {
            std::thread::park();
        }
    }
    cli::exit_code(result)
}
