//! `host-tool convert`: MCAP ↔ run CSV, or a normalised copy; or a run log as a ROS 2 bag
//! (`--to ros2-bag`).

use super::output::{self, check_new_file, create_parent};
use anyhow::{bail, Result};
use host_tool::eprintln_best_effort;
use host_tool::log::convert::{convert_salvaging, same_file};
use host_tool::log::load::{load_salvaging, lost_data, RunFormat};
use host_tool::log::run_csv::RigRange;
use host_tool::log::Existing;
use host_tool::out_dir::is_missing_or_empty;
use host_tool::ros2::from_log::{save_bag, BagOptions, LogClock};
use host_tool::runs::{damage_warnings, truncation_warning};
use std::path::PathBuf;

/// `convert IN OUT [--to ros2-bag [--rover R.toml]] [--force]`.
#[derive(clap::Args, Debug)]
pub struct ConvertArgs {
    #[command(flatten)]
    pub salvage: super::SalvageArg,
    /// The run log to read (.mcap or .csv).
    input: PathBuf,
    /// The file to write (.mcap or .csv), or with `--to ros2-bag` the bag directory; written
    /// whole or not at all.
    output: PathBuf,
    /// Write OUT in this format instead of the one its extension names.
    #[arg(long, value_enum, value_name = "FORMAT")]
    to: Option<ConvertTo>,
    /// With `--to ros2-bag`: the rover whose controller slip track turns the commanded side
    /// speeds into /cmd_vel's (v, ω).
    #[command(flatten)]
    rover: super::RoverArg,
    /// Overwrite an existing output file (replace a non-empty bag directory).
    #[arg(long)]
    force: bool,
}

/// A format `--to` names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ConvertTo {
    /// A rosbag2 directory (MCAP storage, CDR messages) for ROS 2 tools: the samples as
    /// rover_power/msg/Sample (its definition is in the bag), /cmd_vel (ω with --rover's slip
    /// track), /imu/data, /rover_power/tracker_pose and the events on /rosout, at the log's Unix
    /// times.
    Ros2Bag,
}

impl ConvertArgs {
    /// Converts and prints what was converted.
    pub fn run(self) -> Result<()> {
        match self.to {
            Some(ConvertTo::Ros2Bag) => return self.run_ros2_bag(),
            None if self.rover.rover.is_some() => {
                bail!("--rover is used only with --to ros2-bag (for /cmd_vel)")
            }
            None => {}
        }
        if same_file(&self.input, &self.output) {
            bail!("{}: the output is the input file", self.output.display());
        }
        check_new_file(&self.output, self.force)?;
        create_parent(&self.output)?;
        let done = convert_salvaging(
            &self.input,
            &self.output,
            super::salvage(),
            Existing::from_force(self.force),
        )?;
        if let Some(t) = &done.truncated {
            eprintln_best_effort!("{}", truncation_warning(&self.input, t));
        }
        super::report_damage(
            &damage_warnings(&self.input, &done.losses, &done.dropped_rows),
            lost_data(&done.losses, &done.dropped_rows),
        );
        let mut line = format!(
            "{} ({}) -> {} ({}): {} samples",
            self.input.display(),
            done.from,
            self.output.display(),
            done.to,
            done.samples
        );
        if done.frames > 0 {
            let how = if done.synthesised_frames {
                " (synthesised from the samples)"
            } else {
                ""
            };
            line += &format!(", {} frames{how}", done.frames);
        }
        output::print(format_args!("{line}\n"))
    }

    /// `--to ros2-bag`: the log as a bag directory.
    fn run_ros2_bag(self) -> Result<()> {
        let out = &self.output;
        if RunFormat::of_name(out).is_ok() {
            bail!(
                "{}: --to ros2-bag writes a bag directory, but .{} is a run log file's \
                 extension; name the directory without it",
                out.display(),
                out.extension().unwrap_or_default().to_string_lossy()
            );
        }
        if !self.force && !is_missing_or_empty(out) {
            bail!(
                "{}: the output directory exists and is not empty (pass --force to replace it)",
                out.display()
            );
        }
        // --force replaces the whole directory: never the one holding the input.
        if let (Ok(input), Ok(dir)) = (self.input.canonicalize(), out.canonicalize()) {
            if input.starts_with(&dir) {
                bail!(
                    "{}: the input {} is inside this directory; choose another output",
                    out.display(),
                    self.input.display()
                );
            }
        }
        let rover = self.rover.load()?;
        let loaded = load_salvaging(&self.input, super::salvage(), RigRange::Physical)?;
        if let Some(t) = &loaded.truncated {
            eprintln_best_effort!("{}", truncation_warning(&self.input, t));
        }
        super::report_damage(
            &damage_warnings(&self.input, &loaded.losses, &loaded.dropped_rows),
            loaded.lost_data(),
        );
        let options = BagOptions {
            slip_track_m: f64::from(rover.rover.slip_track_m),
        };
        let bag = save_bag(out, self.force, &loaded.run, &options)?;
        if bag.clock == LogClock::RunTime {
            eprintln_best_effort!(
                "note: {} has no wall clock before its first sample (a run CSV, or a log \
                 recorded without one): the bag's log times and stamps are run time (ns since \
                 the recording started), not Unix time",
                self.input.display()
            );
        }
        let topics: Vec<String> = bag
            .topics
            .iter()
            .map(|(topic, n)| format!("{n} {topic}"))
            .collect();
        output::print(format_args!(
            "{} ({}) -> {} (ROS 2 bag): {}\n",
            self.input.display(),
            loaded.format,
            out.display(),
            if topics.is_empty() {
                "no messages".to_owned()
            } else {
                topics.join(", ")
            }
        ))
    }
}
