//! `host-tool validate`: runs against the seed's power models.

use super::output::{self, write_file, JsonOut};
use super::Departure;
use anyhow::Result;
use host_tool::analysis::{stream_and_validate, Reader};
use host_tool::eprintln_best_effort;
use host_tool::log::run_csv::RigRange;
use host_tool::validate::{self, ValidateOptions, ValidationReport};
use model_core::power::IcrHardGround;
use std::path::PathBuf;

/// `validate --rover R.toml --runs FILES… [...]`.
#[derive(clap::Args, Debug)]
pub struct ValidateArgs {
    #[command(flatten)]
    pub salvage: super::SalvageArg,
    #[command(flatten)]
    rover: super::RoverArg,
    /// Run logs, .csv or .mcap (each is validated as an independent run).
    #[arg(long, num_args = 1.., required = true)]
    runs: Vec<PathBuf>,
    #[command(flatten)]
    rig_range: RigRangeArg,
    #[command(flatten)]
    json: JsonOut,
    /// Write the per-manoeuvre table as CSV to FILE.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Overwrite existing --json and --csv files.
    #[arg(long)]
    force: bool,
    /// Exit with code 3 when a manoeuvre departs from the fitted model (scripted checks).
    #[arg(long)]
    fail_on_departure: bool,
    /// Heading change of each turn when the runs have no yaw [deg].
    #[arg(long, default_value_t = validate::DEFAULT_TURN_DEG)]
    turn_deg: f64,
    /// Settle time cut from the start of each manoeuvre for the steady statistics [s].
    #[arg(long, default_value_t = validate::DEFAULT_SETTLE_S)]
    settle_s: f64,
    /// Shortest manoeuvre analysed [s].
    #[arg(long, default_value_t = validate::segment::DEFAULT_MIN_DURATION_S)]
    min_duration_s: f64,
    /// Tolerance on the commanded side speeds within one manoeuvre [m/s].
    #[arg(long, default_value_t = validate::segment::DEFAULT_SPEED_TOLERANCE_MPS)]
    speed_tolerance_mps: f64,
    /// Flag manoeuvres whose power departs from the fit by more than this [%] (and lies
    /// outside the 95 % prediction interval).
    #[arg(long, default_value_t = 100.0 * validate::DEFAULT_DEPARTURE_FRACTION)]
    departure_pct: f64,
    /// Hard-ground reference model as `MU,G_N,BS_M` (friction coefficient, rolling
    /// resistance [N], the terrain's slip track [m]; geometry and mass from the rover).
    /// Default: the paper's Husky values (its Table 2) for the Husky, none otherwise.
    #[arg(long, value_name = "MU,G_N,BS_M", value_parser = parse_hard_ground, conflicts_with = "no_hard_ground")]
    hard_ground: Option<[f64; 3]>,
    /// No hard-ground reference column.
    #[arg(long)]
    no_hard_ground: bool,
}

/// `--rig-range`, on the commands that read run CSVs for analysis (`validate`, `plot`,
/// `diagnose`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct RigRangeArg {
    /// Readings a run CSV may hold: `physical` (any physical reading, bus 0 to 1000 V, current
    /// ±1000 A: files from other rigs), `board` (this board's INA226, bus 0 to 40.96 V, current
    /// ±16.384 A), or the rig's own range as BUS_V,CURRENT_A (e.g. 60,50). A reading beyond is
    /// an error naming the file, line and column. MCAP logs keep the board's range.
    #[arg(
        long = "rig-range",
        value_name = "physical|board|BUS_V,CURRENT_A",
        default_value = "physical",
        value_parser = RigRange::parse
    )]
    pub range: RigRange,
}

/// `MU,G_N,BS_M` → three finite positive numbers.
fn parse_hard_ground(text: &str) -> Result<[f64; 3], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>().map_err(|e| format!("{v:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match values[..] {
        [mu, g, bs] if values.iter().all(|v| v.is_finite() && *v > 0.0) => Ok([mu, g, bs]),
        _ => Err("expected three positive numbers MU,G_N,BS_M (e.g. 0.74,30.85,1.29)".into()),
    }
}

/// A [`Reader`] for a command's run logs: `--salvage` and `range`; warnings to stderr as they
/// are found.
pub fn reader(range: RigRange) -> Reader<'static> {
    Reader::new(super::salvage(), range, |text: &str| {
        eprintln_best_effort!("{text}")
    })
}

/// Marks data lost to damage for the exit code (4, unless `--salvage`).
pub fn done_reading(reader: &Reader<'_>) {
    super::report_damage(&[], reader.lost_data());
}

/// Manoeuvres flagged as departing from the fitted model.
pub fn departures(report: &ValidationReport) -> usize {
    report.regimes.iter().map(|r| r.flagged).sum()
}

impl ValidateArgs {
    /// Validates and prints the table (or writes JSON/CSV).
    pub fn run(self) -> Result<()> {
        self.json.check(self.force)?;
        if let Some(path) = &self.csv {
            output::check_new_file(path, self.force)?;
        }
        let rover_file = self.rover.load()?;
        let rover = rover_file.rover;
        let mut options = ValidateOptions::for_rover(&rover);
        options.tracker_offset_m = rover_file.tracker_offset_m;
        options.turn_deg = self.turn_deg;
        options.settle_s = self.settle_s;
        options.segment.min_duration_s = self.min_duration_s;
        options.segment.speed_tolerance_mps = self.speed_tolerance_mps;
        options.departure_fraction = self.departure_pct / 100.0;
        if self.no_hard_ground {
            options.hard_ground = None;
        } else if let Some([mu, g, bs]) = self.hard_ground {
            options.hard_ground = Some(IcrHardGround {
                mu,
                rolling_resistance_n: g,
                length_m: f64::from(rover.length_m),
                width_m: f64::from(rover.track_width_m),
                mass_kg: f64::from(rover.mass_kg),
                slip_track_m: bs,
            });
        }
        let mut reader = reader(self.rig_range.range);
        let (_, report) = stream_and_validate(&rover, &self.runs, &mut reader, &options)?;
        done_reading(&reader);
        let json_to_stdout = self.json.emit(&report, "report", self.force)?;
        if let Some(path) = &self.csv {
            let mut text = Vec::new();
            report.write_csv(&mut text)?;
            write_file(path, &text, self.force)?;
        }
        if !json_to_stdout {
            output::print(&report)?;
        }
        let flagged = departures(&report);
        if self.fail_on_departure && flagged > 0 {
            return Err(
                Departure(format!("{flagged} manoeuvres depart from the fitted model")).into(),
            );
        }
        Ok(())
    }
}
