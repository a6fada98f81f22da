//! `host-tool plan`: energy of the optimal CLC path against the PLP path between two poses.

use super::output::{self, JsonOut};
use anyhow::Result;
use host_tool::plan::{self, ModelSource, Preset};
use std::path::PathBuf;

/// `plan --start-deg A --end-deg C --distance-m D [--preset P | --model M.toml] [--json FILE|-]`.
#[derive(clap::Args, Debug)]
pub struct PlanArgs {
    /// Start heading θ_A in the path frame [deg].
    #[arg(long, allow_negative_numbers = true)]
    start_deg: f64,
    /// End heading θ_C in the path frame [deg].
    #[arg(long, allow_negative_numbers = true)]
    end_deg: f64,
    /// Start-to-end distance d [m].
    #[arg(long, allow_negative_numbers = true)]
    distance_m: f64,
    /// Built-in energy model (husky-hard-ground: paper Table 2, reproduces Table 3).
    #[arg(
        long,
        value_enum,
        default_value = "husky-hard-ground",
        conflicts_with = "model"
    )]
    preset: PresetArg,
    /// Energy model file (TOML: rover, hard-ground base, effect terms; see the README).
    #[arg(long, value_name = "FILE")]
    model: Option<PathBuf>,
    #[command(flatten)]
    json: JsonOut,
    /// Overwrite an existing --json file (and --figure).
    #[arg(long)]
    force: bool,
    /// Sweep both CLC arcs over R/R' = 0 … --sweep-max instead: ΔE = (E_CLC − E_PLP)/E_PLP
    /// against R/R' (thesis Fig. 6.3), the optimum, and thesis Table 6.1's slices.
    #[arg(long)]
    sweep: bool,
    /// Largest R/R' of the sweep.
    #[arg(
        long,
        default_value_t = 3.0,
        requires = "sweep",
        value_name = "R_OVER_R_PRIME"
    )]
    sweep_max: f64,
    /// Draw the sweep as thesis Fig. 6.3 to FILE (.png or .svg).
    #[arg(long, requires = "sweep", value_name = "FILE")]
    figure: Option<PathBuf>,
}

/// `plan --preset` values.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum PresetArg {
    HuskyHardGround,
}

impl From<PresetArg> for Preset {
    fn from(p: PresetArg) -> Self {
        match p {
            PresetArg::HuskyHardGround => Preset::HuskyHardGround,
        }
    }
}

impl PlanArgs {
    /// Plans and prints (or writes) the comparison.
    pub fn run(self) -> Result<()> {
        self.json.check(self.force)?;
        let (model, source) = match &self.model {
            Some(path) => (plan::load_model(path)?, ModelSource::File(path.clone())),
            None => {
                let preset = Preset::from(self.preset);
                (preset.model(), ModelSource::Preset(preset))
            }
        };
        if self.sweep {
            return self.sweep(&model, &source);
        }
        let report = plan::plan(
            &model,
            &source,
            self.start_deg,
            self.end_deg,
            self.distance_m,
        )?;
        if !self.json.emit(&report, "plan", self.force)? {
            output::print(&report)?;
        }
        Ok(())
    }

    /// `--sweep`: ΔE against R/R' (thesis Fig. 6.3), printed or as JSON, and the figure.
    fn sweep(&self, model: &plan::EnergyModel, source: &ModelSource) -> Result<()> {
        if let Some(path) = &self.figure {
            output::check_new_file(path, self.force)?;
            output::create_parent(path)?;
        }
        let grid = plan::sweep::SweepGrid {
            max_r_over_r_prime: self.sweep_max,
            ..plan::sweep::SweepGrid::default()
        };
        let report = plan::sweep::sweep(
            model,
            source,
            self.start_deg,
            self.end_deg,
            self.distance_m,
            grid,
        )?;
        if let Some(path) = &self.figure {
            host_tool::plot::render(&report.chart(), path).map_err(|e| output::naming(path, e))?;
        }
        if !self.json.emit(&report, "sweep", self.force)? {
            output::print(&report)?;
        }
        Ok(())
    }
}
