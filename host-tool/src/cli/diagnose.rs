//! `host-tool diagnose`: where the hard-ground model departs, which effect, how much it closes.

use super::output::{self, JsonOut};
use super::validate::{done_reading, reader, RigRangeArg};
use super::Departure;
use anyhow::{bail, Context, Result};
use host_tool::analysis::{self, Diagnosed};
use host_tool::diagnose::path_table::PathDiagnosis;
use host_tool::diagnose::{self, calibration::Calibration, report};
use host_tool::log::Existing;
use host_tool::out_dir::{is_missing_or_empty, write_dir_whole};
use std::io::Write as _;
use std::path::PathBuf;

/// `diagnose --rover R.toml [--calibration CAL…] --runs FILES… [...]`.
#[derive(clap::Args, Debug)]
pub struct DiagnoseArgs {
    #[command(flatten)]
    pub salvage: super::SalvageArg,
    #[command(flatten)]
    rover: super::RoverArg,
    /// Calibration runs, .csv or .mcap: their straights, point turns and turns with R ≥ 2R′ fit
    /// the hard-ground baseline and are not scored (default: those manoeuvres of --runs).
    #[arg(long, num_args = 1..)]
    calibration: Vec<PathBuf>,
    /// Runs to diagnose: run CSVs or MCAP logs, or per-turn summary CSVs (header with
    /// radius_m,avg_power_w and optional v_c_mps, pitch_deg; e.g. a published table).
    #[arg(long, num_args = 1.., required = true)]
    runs: Vec<PathBuf>,
    #[command(flatten)]
    rig_range: RigRangeArg,
    #[command(flatten)]
    json: JsonOut,
    /// Output directory: diagnosis.md, figures (PNG, SVG) and model.toml for `plan --model`;
    /// written whole or not at all.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Overwrite an existing --json file and replace a non-empty --out directory.
    #[arg(long)]
    force: bool,
    /// Exit with code 3 when the model departs significantly from the runs (scripted checks).
    #[arg(long)]
    fail_on_departure: bool,
    /// Write what to drive next as a scenario file (`demo --scenario` drives it as is); none is
    /// written when there is nothing to drive (the verdict is settled, or no manoeuvre within
    /// the rover's limits separates its rivals).
    #[arg(long, value_name = "FILE.toml")]
    next_runs: Option<PathBuf>,
}

impl DiagnoseArgs {
    /// Diagnoses the runs; prints the table (or writes JSON) and writes --out.
    pub fn run(self) -> Result<()> {
        self.json.check(self.force)?;
        if let Some(path) = &self.next_runs {
            if !self.force && path.exists() {
                bail!(
                    "{}: the file exists (pass --force to overwrite it)",
                    path.display()
                );
            }
        }
        if let Some(dir) = &self.out {
            if !self.force && !is_missing_or_empty(dir) {
                bail!(
                    "{}: the output directory exists and is not empty (pass --force to replace it)",
                    dir.display()
                );
            }
        }
        let rover_file = self.rover.load()?;
        let is_path_table = self
            .runs
            .iter()
            .any(|p| diagnose::path_table::is_path_table_file(p));
        if is_path_table
            && (!self.calibration.is_empty() || self.out.is_some() || self.next_runs.is_some())
        {
            bail!(
                "a path table is judged against paper Table 2's hard-ground model carried over to \
                 the rover: --calibration, --out and --next-runs do not apply"
            );
        }
        let mut reader = reader(self.rig_range.range);
        let diagnosed =
            analysis::diagnose(&rover_file, &self.runs, &self.calibration, &mut reader)?;
        done_reading(&reader);
        let (diagnosis, rows, calibration) = match &diagnosed {
            Diagnosed::PathTable(diagnosis) => return self.path_table(diagnosis),
            Diagnosed::Runs {
                diagnosis,
                rows,
                calibration_rows,
            } => (
                diagnosis,
                rows,
                calibration_rows
                    .as_deref()
                    .map_or(Calibration::FROM_RUNS, Calibration::rows),
            ),
        };
        let rover = &rover_file.rover;
        // Files first: a closed stdout (`| head`) must not lose them.
        let files = match &self.out {
            Some(dir) => write_dir_whole(dir, self.force, |staging| {
                report::write_out_dir(staging, rover, diagnosis, rows, calibration)
                    .map(|files| output::rebased(files, staging, dir))
            })?,
            None => Vec::new(),
        };
        let next_runs_note = match &self.next_runs {
            Some(path) if !diagnosis.next.runs.is_empty() => {
                host_tool::log::write_atomically(path, Existing::from_force(self.force), |w| {
                    w.write_all(diagnosis.next.scenario_toml().as_bytes())
                })
                .with_context(|| format!("writing {}", path.display()))?;
                Some(format!("{}\n", path.display()))
            }
            Some(path) => Some(format!(
                "{}: not written, nothing to drive next (the verdict is settled or no \
                 manoeuvre within the limits separates its rivals)\n",
                path.display()
            )),
            None => None,
        };
        if !self
            .json
            .emit(&diagnosis.to_json(), "diagnosis", self.force)?
        {
            let mut text = report::table(diagnosis).to_string();
            if !files.is_empty() {
                text.push('\n');
            }
            for file in files {
                text += &format!("{}\n", file.display());
            }
            text += next_runs_note.as_deref().unwrap_or("");
            output::print(text)?;
        }
        if self.fail_on_departure && diagnosis.significant {
            return Err(Departure(format!(
                "the hard-ground model departs from the runs: {} @ {}",
                diagnosis.effect, diagnosis.regime
            ))
            .into());
        }
        Ok(())
    }

    /// Prints (or writes) a path table's diagnosis.
    fn path_table(&self, diagnosis: &PathDiagnosis) -> Result<()> {
        if !self
            .json
            .emit(&diagnosis.to_json(), "diagnosis", self.force)?
        {
            output::print(diagnosis)?;
        }
        if self.fail_on_departure && diagnosis.significant {
            return Err(
                Departure("the hard-ground model departs from the path table".into()).into(),
            );
        }
        Ok(())
    }
}
