//! `host-tool convert`: MCAP ↔ run CSV, or a normalised copy.

use super::output::{self, check_new_file, create_parent};
use anyhow::{bail, Result};
use host_tool::eprintln_best_effort;
use host_tool::log::convert::{convert_salvaging, same_file};
use host_tool::log::load::lost_data;
use host_tool::runs::{damage_warnings, truncation_warning};
use std::path::PathBuf;

/// `convert IN OUT [--force]`.
#[derive(clap::Args, Debug)]
pub struct ConvertArgs {
    #[command(flatten)]
    pub salvage: super::SalvageArg,
    /// The run log to read (.mcap or .csv).
    input: PathBuf,
    /// The file to write (.mcap or .csv); written whole or not at all.
    output: PathBuf,
    /// Overwrite an existing output file.
    #[arg(long)]
    force: bool,
}

impl ConvertArgs {
    /// Converts and prints what was converted.
    pub fn run(self) -> Result<()> {
        if same_file(&self.input, &self.output) {
            bail!("{}: the output is the input file", self.output.display());
        }
        check_new_file(&self.output, self.force)?;
        create_parent(&self.output)?;
        let done = convert_salvaging(&self.input, &self.output, super::salvage())?;
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
}
