//! `host-tool plot`: the validation figures of runs.

use super::output;
use super::validate::{done_reading, reader, RigRangeArg};
use anyhow::Result;
use host_tool::analysis::load_and_validate;
use host_tool::figures::write_figures_with;
use host_tool::out_dir::write_dir_whole;
use host_tool::plot::Format;
use host_tool::validate::ValidateOptions;
use std::path::PathBuf;

/// `plot --rover R.toml --runs FILES… [--out DIR] [--format png|svg|both] [--force]`.
#[derive(clap::Args, Debug)]
pub struct PlotArgs {
    #[command(flatten)]
    pub salvage: super::SalvageArg,
    #[command(flatten)]
    rover: super::RoverArg,
    /// Run logs, .csv or .mcap.
    #[arg(long, num_args = 1.., required = true)]
    runs: Vec<PathBuf>,
    #[command(flatten)]
    rig_range: RigRangeArg,
    /// Output directory (created if missing; written whole or not at all).
    #[arg(long, default_value = "plots")]
    out: PathBuf,
    /// Replace an existing, non-empty output directory.
    #[arg(long)]
    force: bool,
    /// Figure format(s).
    #[arg(long, value_enum, default_value = "both")]
    format: FigureFormat,
    /// Also draw each run's left and right power through each turn
    /// (`power-vs-time-per-side[-STEM]`, two panels).
    #[arg(long)]
    per_side: bool,
}

/// Which figure files to write.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum FigureFormat {
    Png,
    Svg,
    Both,
}

impl FigureFormat {
    fn formats(self) -> &'static [Format] {
        match self {
            FigureFormat::Png => &[Format::Png],
            FigureFormat::Svg => &[Format::Svg],
            FigureFormat::Both => &[Format::Png, Format::Svg],
        }
    }
}

impl PlotArgs {
    /// Validates the runs and draws the figures.
    pub fn run(self) -> Result<()> {
        if !self.force && !host_tool::out_dir::is_missing_or_empty(&self.out) {
            // Refused before the work, not after.
            anyhow::bail!(
                "{}: the output directory exists and is not empty (pass --force to replace it)",
                self.out.display()
            );
        }
        let rover_file = self.rover.load()?;
        let rover = rover_file.rover;
        // As `validate` does: the tracker's point from the rover file.
        let mut options = ValidateOptions::for_rover(&rover);
        options.tracker_offset_m = rover_file.tracker_offset_m;
        let mut reader = reader(self.rig_range.range);
        let (runs, report) = load_and_validate(&rover, &self.runs, &mut reader, &options)?;
        done_reading(&reader);
        let samples = runs.samples();
        let files = write_dir_whole(&self.out, self.force, |staging| {
            write_figures_with(
                &report,
                &samples,
                staging,
                self.format.formats(),
                self.per_side,
            )
            .map(|files| output::rebased(files, staging, &self.out))
        })?;
        let mut text = String::new();
        for file in files {
            text += &format!("{}\n", file.display());
        }
        output::print(text)
    }
}
