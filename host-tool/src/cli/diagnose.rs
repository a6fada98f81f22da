//! `host-tool diagnose`: where the hard-ground model departs, which effect, how much it closes.

use super::output::{self, JsonOut};
use super::validate::{stream_and_validate, RigRangeArg};
use super::Departure;
use anyhow::{bail, Context, Result};
use host_tool::diagnose::features::{RunSampleScan, TurnRow};
use host_tool::diagnose::{self, calibration::Calibration, report};
use host_tool::log::run_csv::RigRange;
use host_tool::out_dir::{is_missing_or_empty, write_dir_whole};
use host_tool::validate::ValidateOptions;
use model_core::Rover;
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

/// The diagnosis rows of `paths`: run logs through `validate` (run CSVs' readings within
/// `range`), and per-turn summary CSVs (header with `radius_m` and `avg_power_w`, see
/// `diagnose::summary`) as total-only rows, each file its own run; plus the summaries' caveats.
fn diagnosis_rows(
    rover: &Rover,
    tracker_offset_m: f64,
    paths: &[PathBuf],
    range: RigRange,
    what: &str,
) -> Result<(Vec<TurnRow>, Vec<String>)> {
    let (summaries, runs): (Vec<&PathBuf>, Vec<&PathBuf>) = paths
        .iter()
        .partition(|p| diagnose::summary::is_summary_file(p));
    let mut rows = if runs.is_empty() {
        Vec::new()
    } else {
        let runs: Vec<PathBuf> = runs.into_iter().cloned().collect();
        let options = ValidateOptions {
            tracker_offset_m,
            ..ValidateOptions::for_rover(rover)
        };
        // Streamed: validate reads each file twice, the standstill draw and the manoeuvres'
        // bus voltage a third time; memory stays bounded whatever the logs' length.
        let (streamed, report) = stream_and_validate(rover, &runs, range, &options)
            .with_context(|| format!("{what} runs"))?;
        let mut facts = Vec::with_capacity(runs.len());
        for index in 0..runs.len() {
            let mut scan = RunSampleScan::new(&report, index);
            if let Some(read) = streamed.read_again(index, &mut scan) {
                read.with_context(|| format!("{what} runs"))?;
            }
            facts.push(scan.finish());
        }
        diagnose::features::rows_from_facts(&report, &facts)
    };
    let mut notes = Vec::new();
    for path in summaries {
        let summary = diagnose::summary::load_summary(path)?;
        let run_index = rows.iter().map(|r| r.run_index + 1).max().unwrap_or(0);
        let mut of = diagnose::summary::summary_rows(rover, &summary, &path.display().to_string());
        for row in &mut of {
            row.run_index = run_index;
        }
        rows.extend(of);
        notes.extend(
            diagnose::summary::summary_notes(&summary)
                .into_iter()
                .map(|n| format!("{}: {n}", path.display())),
        );
    }
    Ok((rows, notes))
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
        let (rover, offset) = (rover_file.rover, rover_file.tracker_offset_m);
        // Path-level summaries (thesis Table 6.1) have their own judgement.
        if self
            .runs
            .iter()
            .any(|p| diagnose::path_table::is_path_table_file(p))
        {
            return self.path_table(&rover);
        }
        let range = self.rig_range.range;
        let (rows, notes) = diagnosis_rows(&rover, offset, &self.runs, range, "diagnosed")?;
        let cal_rows = if self.calibration.is_empty() {
            None
        } else {
            Some(diagnosis_rows(&rover, offset, &self.calibration, range, "calibration")?.0)
        };
        let calibration = match &cal_rows {
            Some(rows) => Calibration::rows(rows),
            None => Calibration::FROM_RUNS,
        };
        let mut diagnosis = diagnose::diagnose_with(&rover, &rows, calibration)
            .with_context(|| format!("diagnosing {}", output::runs_named(&self.runs)))?;
        // The inputs' caveats first, then the diagnosis' own.
        diagnosis.notes.splice(0..0, notes);
        // Files first: a closed stdout (`| head`) must not lose them.
        let files = match &self.out {
            Some(dir) => write_dir_whole(dir, self.force, |staging| {
                report::write_out_dir(staging, &rover, &diagnosis, &rows, calibration)
                    .map(|files| output::rebased(files, staging, dir))
            })?,
            None => Vec::new(),
        };
        let next_runs_note = match &self.next_runs {
            Some(path) if !diagnosis.next.runs.is_empty() => {
                host_tool::log::write_atomically(path, |w| {
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
            let mut text = report::table(&diagnosis).to_string();
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

    /// `diagnose` on a path table: every `--runs` file must be one; no calibration runs.
    fn path_table(&self, rover: &Rover) -> Result<()> {
        use diagnose::path_table;
        if let Some(p) = self
            .runs
            .iter()
            .find(|p| !path_table::is_path_table_file(p))
        {
            bail!(
                "{}: a path table (header start_deg,end_deg,…) cannot be diagnosed with runs or \
                 per-turn summaries; pass them separately",
                p.display()
            );
        }
        if !self.calibration.is_empty() || self.out.is_some() || self.next_runs.is_some() {
            bail!(
                "a path table is judged against paper Table 2's hard-ground model carried over to \
                 the rover: --calibration, --out and --next-runs do not apply"
            );
        }
        let model = path_table::hard_ground_for(rover);
        let mut rows = Vec::new();
        for path in &self.runs {
            let of = path_table::load_path_table(path)?;
            // Each file's rows on their own: the error's line is then in a file it can name.
            path_table::check_rows(&model, &of).map_err(|e| output::naming(path, e))?;
            rows.extend(of);
        }
        let diagnosis = path_table::diagnose_path_table(&model, &rows)?;
        if !self
            .json
            .emit(&diagnosis.to_json(), "diagnosis", self.force)?
        {
            output::print(&diagnosis)?;
        }
        if self.fail_on_departure && diagnosis.significant {
            return Err(
                Departure("the hard-ground model departs from the path table".into()).into(),
            );
        }
        Ok(())
    }
}
