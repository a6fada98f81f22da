//! `host-tool replay`: a run log as the board's byte stream, into a pty or a capture file.

use super::output::{self, check_new_file, create_parent};
use anyhow::{bail, Context, Result};
use host_tool::eprintln_best_effort;
use host_tool::live::serve_run;
use host_tool::log::convert::same_file;
use host_tool::log::load::{load_salvaging, Loaded};
use host_tool::log::run_csv::RigRange;
use host_tool::log::run_log::RunLog;
use host_tool::log::write_atomically;
use host_tool::log::Existing;
use host_tool::record::stop_signal;
use host_tool::replay::{ReplayPacing, ReplayPty, ReplaySource};
use host_tool::runs::{damage_warnings, truncation_warning};
use model_core::Rover;
use std::path::{Path, PathBuf};

/// `replay LOG (--to-pty | --to FILE | --serve [ADDR]) [--speed K | --as-fast-as-possible]
/// [--rover R.toml]`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("target").required(true).args(["to_pty", "to", "serve"])))]
pub struct ReplayArgs {
    #[command(flatten)]
    pub salvage: super::SalvageArg,
    /// The run log (.mcap: its frames byte for byte, plus the board's report of each commanded
    /// speed after its ack; .csv: frames synthesised from samples and commanded speeds).
    log: PathBuf,
    /// Stream into a new pty: prints its path, waits for a reader, streams, hangs up (a
    /// `record` on it then stops).
    #[arg(long)]
    to_pty: bool,
    /// Write the whole byte stream to this file instead.
    #[arg(long, value_name = "FILE")]
    to: Option<PathBuf>,
    /// Also write the robot's side of the run to FILE, as a commands CSV: each sample's
    /// commanded speeds, tracker yaw, pitch and position (what the board's stream cannot
    /// carry), on the recording's run time; `record --merge-commands FILE` puts them back.
    #[arg(long, value_name = "FILE", conflicts_with = "serve")]
    commands_out: Option<PathBuf>,
    /// Overwrite an existing --to or --commands-out file.
    #[arg(long)]
    force: bool,
    /// Playback speed factor (2 = twice real time).
    #[arg(long, default_value_t = 1.0, value_parser = positive_factor, value_name = "K")]
    speed: f64,
    /// Write as fast as the reader takes the bytes (ignores --speed; not with --serve, whose
    /// viewers see time pass).
    #[arg(long, conflicts_with = "serve")]
    as_fast_as_possible: bool,
    /// The rover whose wheel radius turns commanded speeds into the reported wheel rates (give
    /// `record` the same).
    #[command(flatten)]
    rover: super::RoverArg,
    // --serve: the log's messages to Foxglove at real time (or --speed K), stamped as
    // happening now; starts when the first viewer subscribes (`replay LOG --serve`, the log
    // first: `--serve LOG` would read LOG as the address).
    #[command(flatten)]
    serve: super::serve::ServeArgs,
}

/// Tells the user what reading `log` found: a cut end, damaged stretches, dropped rows.
fn warn_about<R>(log: &Path, found: &Loaded<R>) {
    if let Some(t) = &found.truncated {
        eprintln_best_effort!("{}", truncation_warning(log, t));
    }
    super::report_damage(
        &damage_warnings(log, &found.losses, &found.dropped_rows),
        found.lost_data(),
    );
}

/// A finite factor > 0.
pub fn positive_factor(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(k) if k.is_finite() && k > 0.0 => Ok(k),
        _ => Err(format!(
            "{text:?} is not a speed factor (a finite number > 0)"
        )),
    }
}

impl ReplayArgs {
    /// Replays the log.
    pub fn run(self) -> Result<()> {
        let rover = self.rover.load()?.rover;
        for out in [&self.to, &self.commands_out].into_iter().flatten() {
            if same_file(&self.log, out) {
                bail!("{}: the output is the input file", out.display());
            }
            check_new_file(out, self.force)?;
        }
        if self.serve.serve.is_some() {
            // Served as the board's frames: its range, whatever the rig.
            let range = RigRange::BoardStream;
            let loaded = load_salvaging(&self.log, super::salvage(), range)?;
            warn_about(&self.log, &loaded);
            return self.serve_live(&loaded.run, &rover);
        }
        // Streamed: a first pass learns what the log holds, the replay reads it again.
        let (source, found) = ReplaySource::open(&self.log, super::salvage(), &rover)?;
        warn_about(&self.log, &found);
        if source.is_empty() {
            bail!(
                "{}: nothing to replay (no frames, no samples)",
                self.log.display()
            );
        }
        // Before the stream: a recorder started on the pty needs the file at once.
        if let Some(out) = &self.commands_out {
            create_parent(out)?;
            let rows = write_atomically(out, Existing::from_force(self.force), |w| {
                source.write_robot_side(w)
            })?;
            eprintln_best_effort!(
                "{}: {rows} rows (commanded speeds and tracker pose); record with \
                 --merge-commands {}",
                out.display(),
                out.display()
            );
        }
        if let Some(out) = &self.to {
            create_parent(out)?;
            // The error names the file (either part of AtomicWriteError).
            let stats = write_atomically(out, Existing::from_force(self.force), |w| {
                source.write_stream(w)
            })?;
            output::print(format_args!(
                "{}: {} frames, {} bytes\n",
                out.display(),
                stats.frames,
                stats.bytes
            ))
        } else {
            let pacing = if self.as_fast_as_possible {
                ReplayPacing::AsFastAsPossible
            } else {
                ReplayPacing::RealTime { speed: self.speed }
            };
            let replay = ReplayPty::spawn_streaming(move |emit| source.emit(emit), pacing, None)?;
            output::print(format_args!("{}\n", replay.path()))?;
            let stats = replay.join().context("replaying into the pty")?;
            eprintln_best_effort!("replayed {} frames, {} bytes", stats.frames, stats.bytes);
            Ok(())
        }
    }

    /// `--serve`: waits for a viewer's subscription, then publishes the log paced.
    fn serve_live(&self, run: &RunLog, rover: &Rover) -> Result<()> {
        if run.samples.is_empty() && run.frames.is_empty() {
            bail!(
                "{}: nothing to replay (no frames, no samples)",
                self.log.display()
            );
        }
        let stop = stop_signal::install().context("installing the stop-signal handler")?;
        let server = self.serve.start()?.context("--serve")?;
        // The address on stdout (a script or test connects to it), the rest on stderr.
        output::print(format_args!("ws://{}\n", server.local_addr()))?;
        eprintln_best_effort!("waiting for a viewer to subscribe (Ctrl-C to stop)");
        if !server.wait_for_subscriber(None, &stop) {
            super::serve::finish(Some(server), "rover-power: the replay was stopped");
            return Ok(());
        }
        let stats = serve_run(&server, run, rover, self.speed, &stop);
        eprintln_best_effort!(
            "served {} records ({:.1} s of the run){}",
            stats.records,
            stats.run_s,
            if stats.stopped { ", stopped" } else { "" }
        );
        let note = match stats.stopped {
            true => "rover-power: the replay was stopped",
            false => "rover-power: the replay has ended (the whole log was sent)",
        };
        super::serve::finish(Some(server), note);
        Ok(())
    }
}
