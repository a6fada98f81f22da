//! `plan`: the energy of the optimal circular arc – line – circular arc (CLC) path between two
//! poses against its point turn – line – point turn (PLP) counterpart (paper Section 3,
//! Eq 23–50), under an energy model: the paper's hard-ground model with the Husky values of its
//! Table 2 (the preset, which reproduces Table 3), or a model file (below) — the hard-ground model
//! of a rover on a terrain plus effects diagnosed from the user's runs.
//!
//! Angles are in the paper's path-defined frame (Fig. 5): the start A at the origin, the end C at
//! (d, 0), headings from A→C counter-clockwise positive, both in (0°, 90°] or both in [−90°, 0°)
//! (Eq 50). The geometry and the optimiser are `model_core::paths`.
//!
//! [`sweep`]: ΔE of the CLC path against R/R' for one pair of poses (`plan --sweep`, thesis
//! Fig. 6.3 and Table 6.1).
//!
//! # Model file (TOML, format version 1)
//!
//! ```toml
//! version = 1                       # format version; anything else is rejected
//! description = "Husky on sand"     # optional, free text
//! v_c_mps = 0.3                     # total absolute speed v_c = (|V_l| + |V_r|)/2 (Eq 2.6) [m/s]
//!
//! [rover]                           # exactly the rover TOML's five keys (rovers/*.toml)
//! track_width_m = 0.55              # W of paper Eq 22 [m]
//! length_m = 0.52                   # L of paper Eq 22 [m]
//! wheel_radius_m = 0.165
//! mass_kg = 63.0                    # m; p = mg/4 [kg]
//! slip_track_m = 1.1                # the controller's B_s (not used by the planner)
//!
//! [base]                            # hard-ground ICR model, paper Eq 21–22
//! mu = 0.74                         # μ
//! rolling_resistance_n = 30.85      # G [N = W·s/m]
//! slip_track_m = 1.29               # B_s of this rover on this terrain [m]; R' = B_s/2
//!
//! [[effects]]                       # zero or more additive terms
//! name = "sand, inner wheels dragged"
//! r_over_r_prime = [0.0, 0.5, 1.0, 2.0, 3.0]   # breakpoints of R/R', strictly increasing, ≥ 0
//! extra_power_w  = [0.0, 12.0, 30.0, 8.0, 0.0] # extra power at those R/R' at v_c [W]
//! ```
//!
//! Every key of `rover`, `base` and `effects` is required and no other key is accepted (a typo
//! cannot silently leave a value at a default). An effect adds power linearly interpolated between
//! its breakpoints and held at its end values outside them, so its last value also applies to
//! straight lines (R = ∞). Under the constant-v_c constraint a turn of |Δθ| at radius R lasts
//! |Δθ| max(R, R')/v_c (Eq 2.8–2.9: ω = v_c/R' for R ≤ R', v_y = v_c above) and a line of length ℓ
//! lasts ℓ/v_c, so an effect adds ΔP(R/R') |Δθ| max(R, R')/v_c to an arc and ΔP(∞)/v_c per metre
//! of line. R/R' is taken with the terrain's B_s; commanded and actual radii have the same R/R'
//! (both are (V_r + V_l)/(V_r − V_l) for symmetric ICRs), so terms fitted against the commanded
//! R/R' of the runs apply unchanged. An effect whose turns also last longer than commanded
//! (angular slip, thesis Eq 6.3) enters as energy-equivalent power: measured turn energy over
//! commanded duration, minus the hard-ground power. A file with no effects is the hard-ground
//! model; [`EnergyModel::husky_hard_ground`] written out ([`EnergyModel::to_toml`]) is the preset.

pub mod sweep;

use crate::excerpt::{self, Number};
use crate::file_error::{read_and_parse, FileError};
use crate::rover::{decimal_f64, rover_of_table};
use crate::toml_syntax::TomlSyntaxError;
use model_core::paths::{optimise_clc, ClcEnds, ClcPath, PathError, SegmentEnergy};
use model_core::power::IcrHardGround;
use model_core::Rover;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;
use std::path::{Path, PathBuf};

/// The model file format this module reads and writes.
pub const MODEL_FORMAT_VERSION: u32 = 1;

/// v_c of the paper's numerical computations: (V_l + V_r) = 0.6 m/s (paper Table 2) [m/s].
pub const HUSKY_HARD_GROUND_V_C_MPS: f64 = 0.3;

/// Built-in energy models.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Preset {
    /// The Husky on hard ground with the paper's Table 2 values (reproduces Table 3).
    HuskyHardGround,
}

impl Preset {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Preset::HuskyHardGround => "husky-hard-ground",
        }
    }

    /// The preset's model.
    pub fn model(self) -> EnergyModel {
        match self {
            Preset::HuskyHardGround => EnergyModel::husky_hard_ground(),
        }
    }
}

/// Hard-ground ICR parameters of a rover on a terrain (paper Eq 21–22); geometry and mass come
/// from the model's rover.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HardGroundBase {
    /// μ: friction coefficient (paper Eq 22).
    pub mu: f64,
    /// G: internal and rolling resistance coefficient (paper Eq 21) [N = W·s/m].
    pub rolling_resistance_n: f64,
    /// B_s: slip track of the rover on this terrain [m]; R' = B_s/2 (paper Definition 1).
    pub slip_track_m: f64,
}

/// An additive effect: extra power [W] at the model's v_c, piecewise linear in R/R' and held at
/// its end values outside the breakpoints (so the last value applies to straight lines too).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectTerm {
    /// What the term stands for (e.g. the diagnosed cause).
    pub name: String,
    /// Breakpoints of R/R', strictly increasing, finite and ≥ 0.
    pub r_over_r_prime: Vec<f64>,
    /// Extra power at each breakpoint [W] (may be negative).
    pub extra_power_w: Vec<f64>,
}

impl EffectTerm {
    /// Extra power at R/R' = `r_over_r_prime` [W] (∞ for a straight line).
    pub fn extra_power_w(&self, r_over_r_prime: f64) -> f64 {
        let mut points = self.r_over_r_prime.iter().zip(&self.extra_power_w);
        let Some((&x0, &y0)) = points.next() else {
            return 0.0;
        };
        if r_over_r_prime <= x0 {
            return y0;
        }
        let (mut xa, mut ya) = (x0, y0);
        for (&xb, &yb) in points {
            if r_over_r_prime <= xb {
                return ya + (yb - ya) * (r_over_r_prime - xa) / (xb - xa);
            }
            (xa, ya) = (xb, yb);
        }
        ya
    }

    fn check(&self) -> Result<(), ModelError> {
        let bad = |why: String| ModelError::Effect {
            name: self.name.clone(),
            why,
        };
        if self.r_over_r_prime.is_empty() {
            return Err(bad("has no breakpoints".into()));
        }
        if self.r_over_r_prime.len() != self.extra_power_w.len() {
            return Err(bad(format!(
                "has {} values of r_over_r_prime but {} of extra_power_w",
                self.r_over_r_prime.len(),
                self.extra_power_w.len()
            )));
        }
        if let Some(x) = self
            .r_over_r_prime
            .iter()
            .find(|x| !(x.is_finite() && **x >= 0.0))
        {
            return Err(bad(format!("r_over_r_prime {x} must be finite and >= 0")));
        }
        if let Some(w) = self.r_over_r_prime.windows(2).find(|w| w[1] <= w[0]) {
            return Err(bad(format!(
                "r_over_r_prime must increase strictly ({} then {})",
                w[0], w[1]
            )));
        }
        if let Some(p) = self.extra_power_w.iter().find(|p| !p.is_finite()) {
            return Err(bad(format!("extra_power_w {p} must be finite")));
        }
        // Beyond both sides at the board's full scale no measurement could have shown it: a
        // unit error, and sums of such numbers overflow to inf/NaN in the plan.
        let max_w = 2.0 * crate::log::run_csv::BUS_V_MAX * crate::log::run_csv::CURRENT_A_MAX;
        if let Some(p) = self.extra_power_w.iter().find(|p| p.abs() > max_w) {
            return Err(bad(format!(
                "extra_power_w {p} W is beyond the rover's measurable power (±{max_w:.0} W: both \
                 sides at the INA226's full scale)"
            )));
        }
        Ok(())
    }
}

/// An energy model for planning: the model file's content (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnergyModel {
    /// Format version, [`MODEL_FORMAT_VERSION`].
    pub version: u32,
    /// Free text (where the model comes from).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// v_c = (|V_l| + |V_r|)/2 (Eq 2.6), the constant speed the paths are driven at [m/s].
    pub v_c_mps: f64,
    /// Geometry and mass (the rover TOML's keys, validated as there).
    #[serde(
        deserialize_with = "rover_from_table",
        serialize_with = "rover_as_decimals"
    )]
    pub rover: Rover,
    /// Hard-ground ICR parameters on the terrain (paper Eq 21–22).
    pub base: HardGroundBase,
    /// Additive effect terms (none: the hard-ground model).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub effects: Vec<EffectTerm>,
}

fn rover_from_table<'de, D: Deserializer<'de>>(d: D) -> Result<Rover, D::Error> {
    let table = toml::Table::deserialize(d)?;
    rover_of_table(&table).map_err(|e| serde::de::Error::custom(format!("rover: {e}")))
}

fn rover_as_decimals<S: Serializer>(rover: &Rover, s: S) -> Result<S::Ok, S::Error> {
    #[derive(Serialize)]
    struct Decimals {
        track_width_m: f64,
        length_m: f64,
        wheel_radius_m: f64,
        mass_kg: f64,
        slip_track_m: f64,
    }
    Decimals {
        track_width_m: decimal_f64(rover.track_width_m),
        length_m: decimal_f64(rover.length_m),
        wheel_radius_m: decimal_f64(rover.wheel_radius_m),
        mass_kg: decimal_f64(rover.mass_kg),
        slip_track_m: decimal_f64(rover.slip_track_m),
    }
    .serialize(s)
}

impl EnergyModel {
    /// The preset: paper Table 2 (μ 0.74, G 30.85 W·s/m, V_l + V_r = 0.6 m/s, L 0.52 m,
    /// W 0.55 m, m 63 kg, B_s 1.29 m) on the Husky A200 (wheel radius and controller slip track
    /// from thesis Table 3.2), no effects.
    pub fn husky_hard_ground() -> Self {
        let hg = IcrHardGround::HUSKY_HARD_GROUND;
        Self {
            version: MODEL_FORMAT_VERSION,
            description: Some("Husky A200 on hard ground, paper Table 2".into()),
            v_c_mps: HUSKY_HARD_GROUND_V_C_MPS,
            rover: Rover {
                track_width_m: 0.55,
                length_m: 0.52,
                mass_kg: 63.0,
                ..Rover::HUSKY_A200
            },
            base: HardGroundBase {
                mu: hg.mu,
                rolling_resistance_n: hg.rolling_resistance_n,
                slip_track_m: hg.slip_track_m,
            },
            effects: Vec::new(),
        }
    }

    /// The hard-ground model (paper Eq 21–22) of this rover on this terrain.
    pub fn hard_ground(&self) -> IcrHardGround {
        IcrHardGround {
            mu: self.base.mu,
            rolling_resistance_n: self.base.rolling_resistance_n,
            length_m: decimal_f64(self.rover.length_m),
            width_m: decimal_f64(self.rover.track_width_m),
            mass_kg: decimal_f64(self.rover.mass_kg),
            slip_track_m: self.base.slip_track_m,
        }
    }

    /// Checks every value (version, ranges, effect breakpoints).
    pub fn check(&self) -> Result<(), ModelError> {
        if self.version != MODEL_FORMAT_VERSION {
            return Err(ModelError::UnsupportedVersion(self.version));
        }
        let positive = |key: &'static str, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(ModelError::OutOfRange {
                    key,
                    value,
                    want: "finite and > 0",
                })
            }
        };
        let non_negative = |key: &'static str, value: f64| {
            if value.is_finite() && value >= 0.0 {
                Ok(())
            } else {
                Err(ModelError::OutOfRange {
                    key,
                    value,
                    want: "finite and >= 0",
                })
            }
        };
        positive("v_c_mps", self.v_c_mps)?;
        let r = &self.rover;
        positive("rover.track_width_m", f64::from(r.track_width_m))?;
        positive("rover.length_m", f64::from(r.length_m))?;
        positive("rover.wheel_radius_m", f64::from(r.wheel_radius_m))?;
        positive("rover.mass_kg", f64::from(r.mass_kg))?;
        positive("rover.slip_track_m", f64::from(r.slip_track_m))?;
        non_negative("base.mu", self.base.mu)?;
        non_negative("base.rolling_resistance_n", self.base.rolling_resistance_n)?;
        positive("base.slip_track_m", self.base.slip_track_m)?;
        self.effects.iter().try_for_each(EffectTerm::check)
    }

    /// The segment-energy law of this model (checked first).
    pub fn law(&self) -> Result<ModelLaw, ModelError> {
        self.check()?;
        Ok(ModelLaw {
            hard_ground: self.hard_ground(),
            v_c_mps: self.v_c_mps,
            effects: self.effects.clone(),
        })
    }

    /// The model as a model file (TOML).
    pub fn to_toml(&self) -> Result<String, ModelError> {
        toml::to_string(self).map_err(|e| ModelError::Write(e.to_string()))
    }
}

/// Parses and checks the text of a model file.
pub fn parse_model(text: &str) -> Result<EnergyModel, ModelError> {
    let model: EnergyModel =
        toml::from_str(text).map_err(|e| ModelError::Syntax(TomlSyntaxError::new(text, &e)))?;
    model.check()?;
    Ok(model)
}

/// Reads, parses and checks a model file.
pub fn load_model(path: &Path) -> Result<EnergyModel, ModelFileError> {
    read_and_parse(path, parse_model)
}

/// What is wrong with a model.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// Not TOML, a missing or unknown key, a wrong type, or an invalid rover table (the message
    /// carries the line and column).
    #[error("{0}")]
    Syntax(#[source] TomlSyntaxError),
    /// A format version this tool does not read.
    #[error("version {0} is not supported (this tool reads version {MODEL_FORMAT_VERSION})")]
    UnsupportedVersion(u32),
    /// A value outside its range.
    #[error("`{key}` = {} must be {want}", Number(*.value))]
    OutOfRange {
        /// The key (`table.key`).
        key: &'static str,
        /// The value.
        value: f64,
        /// The range.
        want: &'static str,
    },
    /// An effect term with bad breakpoints.
    #[error("effect {:?} {why}", excerpt::cut(name))]
    Effect {
        /// The term's name.
        name: String,
        /// What is wrong.
        why: String,
    },
    /// The model could not be written as TOML.
    #[error("cannot write the model as TOML: {0}")]
    Write(String),
}

/// A model file that could not be read or is invalid; names the file.
pub type ModelFileError = FileError<ModelError>;

/// The segment energies of an [`EnergyModel`]: paper Theorem 1 (Eq 26) and Lemma 1 (Eq 39) for
/// the hard-ground model, plus each effect's extra power times the segment's duration at v_c.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelLaw {
    hard_ground: IcrHardGround,
    v_c_mps: f64,
    effects: Vec<EffectTerm>,
}

impl ModelLaw {
    /// R' = B_s/2 on the terrain [m].
    pub fn r_prime_m(&self) -> f64 {
        self.hard_ground.r_prime_m()
    }

    /// v_c [m/s].
    pub fn v_c_mps(&self) -> f64 {
        self.v_c_mps
    }

    /// The hard-ground part (paper Eq 21–22).
    pub fn hard_ground(&self) -> &IcrHardGround {
        &self.hard_ground
    }

    /// Sum of the effects' extra power at R/R' [W].
    fn extra_power_w(&self, r_over_r_prime: f64) -> f64 {
        self.effects
            .iter()
            .map(|t| t.extra_power_w(r_over_r_prime))
            .sum()
    }

    /// Duration of an arc at constant v_c (Eq 2.8–2.9): |Δθ| max(R, R')/v_c [s].
    pub fn arc_duration_s(&self, radius_m: f64, dtheta_rad: f64) -> f64 {
        dtheta_rad.abs() * radius_m.max(self.r_prime_m()) / self.v_c_mps
    }

    /// Duration of a line at constant v_c: ℓ/v_c [s].
    pub fn line_duration_s(&self, length_m: f64) -> f64 {
        length_m / self.v_c_mps
    }

    /// Duration of a whole path [s].
    pub fn path_duration_s(&self, path: &ClcPath) -> f64 {
        self.arc_duration_s(path.r1_m, path.first_turn_rad)
            + self.line_duration_s(path.line_length_m)
            + self.arc_duration_s(path.r2_m, path.second_turn_rad)
    }
}

impl SegmentEnergy for ModelLaw {
    /// Paper Eq 26 plus ΔP(R/R') |Δθ| max(R, R')/v_c [J]; NaN where Eq 26 is.
    fn arc_energy_j(&self, radius_m: f64, dtheta_rad: f64) -> f64 {
        let base = self.hard_ground.arc_energy_j(radius_m, dtheta_rad);
        if self.effects.is_empty() || base.is_nan() {
            return base;
        }
        base + self.extra_power_w(radius_m / self.r_prime_m())
            * self.arc_duration_s(radius_m, dtheta_rad)
    }

    /// Paper Eq 39 (2G) plus ΔP(∞)/v_c [J/m].
    fn line_energy_j_per_m(&self) -> f64 {
        let base = self.hard_ground.line_energy_j_per_m();
        if self.effects.is_empty() {
            return base;
        }
        base + self.extra_power_w(f64::INFINITY) / self.v_c_mps
    }

    /// R', where Eq 26 switches branch.
    fn kink_radius_m(&self) -> Option<f64> {
        self.hard_ground.kink_radius_m()
    }
}

/// Where the plan's model comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum ModelSource {
    /// A built-in model.
    Preset(Preset),
    /// A model file.
    File(PathBuf),
}

/// Why a plan could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// A heading is NaN or infinite.
    #[error("--{which}-deg must be a finite angle, got {value_deg}")]
    NonFiniteHeading {
        /// `start` or `end`.
        which: &'static str,
        /// The value given [deg].
        value_deg: f64,
    },
    /// The distance is not finite and > 0.
    #[error("--distance-m must be finite and > 0, got {0}")]
    InvalidDistance(f64),
    /// The headings break paper Eq 50.
    #[error(
        "start {start_deg}° and end {end_deg}° must both be in (0, 90] or both in [-90, 0) \
         (paper Eq 50: headings in the path frame, from the start-to-end line, counter-clockwise \
         positive; the CLC family is not defined for other pairs)"
    )]
    HeadingsOutsideEq50 {
        /// θ_A [deg].
        start_deg: f64,
        /// θ_C [deg].
        end_deg: f64,
    },
    /// The model is invalid.
    #[error("model: {0}")]
    Model(#[from] ModelError),
    /// The optimiser found no path.
    #[error("no path: {0}")]
    Path(PathError),
    /// A sweep range that is not finite and > 0.
    #[error("--sweep-max must be finite and > 0, got {0}")]
    InvalidSweep(f64),
}

/// A path of the plan: its geometry, energy and duration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PlannedPath {
    /// E (paper Eq 44–45) [J].
    pub energy_j: f64,
    /// R1 [m] (0: point turn).
    pub r1_m: f64,
    /// R2 [m] (0: point turn).
    pub r2_m: f64,
    /// θ_B^P, heading of the line in the path frame [deg] (degrees as the headings given).
    pub line_heading_deg: f64,
    /// |B1B2| [m].
    pub line_length_m: f64,
    /// |θ_B − θ_A| [deg].
    pub first_turn_deg: f64,
    /// |θ_B − θ_C| [deg].
    pub second_turn_deg: f64,
    /// B1, end of the first arc, (x^P, y^P) [m] (paper Eq 49).
    pub b1_m: [f64; 2],
    /// B2, start of the second arc, (x^P, y^P) [m] (paper Eq 49).
    pub b2_m: [f64; 2],
    /// Duration at constant v_c [s].
    pub duration_s: f64,
}

impl PlannedPath {
    fn of(path: &ClcPath, law: &ModelLaw) -> Self {
        Self {
            energy_j: path.energy_j(law),
            r1_m: path.r1_m,
            r2_m: path.r2_m,
            line_heading_deg: degrees(path.line_heading_rad),
            line_length_m: path.line_length_m,
            first_turn_deg: degrees(path.first_turn_rad),
            second_turn_deg: degrees(path.second_turn_rad),
            b1_m: [path.b1.x_m, path.b1.y_m],
            b2_m: [path.b2.x_m, path.b2.y_m],
            duration_s: law.path_duration_s(path),
        }
    }
}

/// An angle [rad] in degrees to 1e-9° (far below any heading's meaning): 60° given comes back
/// as 60, not 59.99999999999999.
fn degrees(rad: f64) -> f64 {
    (rad.to_degrees() * 1e9).round() / 1e9
}

/// What a plan was asked for and with which model: the head of [`PlanReport`] and of
/// [`sweep::SweepReport`] (flattened into their JSON).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanSetting {
    /// The preset used, if any.
    pub preset: Option<&'static str>,
    /// The model file used, if any.
    pub model: Option<String>,
    /// The model's description.
    pub model_description: Option<String>,
    /// θ_A^P [deg].
    pub start_deg: f64,
    /// θ_C^P [deg].
    pub end_deg: f64,
    /// d = |AC| [m].
    pub distance_m: f64,
    /// v_c [m/s].
    pub v_c_mps: f64,
    /// R' = B_s/2 on the terrain [m].
    pub r_prime_m: f64,
}

impl PlanSetting {
    /// `preset NAME`, `model FILE` or `model`, as the tables name the model.
    pub fn source(&self) -> String {
        match (&self.preset, &self.model) {
            (Some(p), _) => format!("preset {p}"),
            (None, Some(m)) => format!("model {m}"),
            (None, None) => "model".into(),
        }
    }
}

/// The result of `plan`: the optimal CLC path (paper Eq 46) and the PLP path between the same
/// poses, as in paper Table 3.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanReport {
    /// The model and the poses.
    #[serde(flatten)]
    pub setting: PlanSetting,
    /// The optimal CLC path.
    pub clc: PlannedPath,
    /// The PLP path.
    pub plp: PlannedPath,
    /// E_PLP − E_CLC [J].
    pub saving_j: f64,
    /// (E_PLP − E_CLC)/E_PLP [%].
    pub saving_pct: f64,
}

/// Plans between A = (0, 0) at `start_deg` and C = (`distance_m`, 0) at `end_deg` (path frame,
/// paper Fig. 5) under `model`: the CLC path of least energy (paper Eq 46, R1, R2 ≥ 0) and the
/// PLP path.
pub fn plan(
    model: &EnergyModel,
    source: &ModelSource,
    start_deg: f64,
    end_deg: f64,
    distance_m: f64,
) -> Result<PlanReport, PlanError> {
    for (which, value_deg) in [("start", start_deg), ("end", end_deg)] {
        if !value_deg.is_finite() {
            return Err(PlanError::NonFiniteHeading { which, value_deg });
        }
    }
    if !(distance_m.is_finite() && distance_m > 0.0) {
        return Err(PlanError::InvalidDistance(distance_m));
    }
    let law = model.law()?;
    let ends = ClcEnds::new(start_deg.to_radians(), end_deg.to_radians(), distance_m).map_err(
        |e| match e {
            PathError::HeadingsOutsideEq50 => PlanError::HeadingsOutsideEq50 { start_deg, end_deg },
            PathError::InvalidDistance => PlanError::InvalidDistance(distance_m),
            other => PlanError::Path(other),
        },
    )?;
    let optimum = optimise_clc(&law, &ends).map_err(PlanError::Path)?;
    let clc_path = ClcPath::new(&ends, optimum.r1_m, optimum.r2_m).map_err(PlanError::Path)?;
    let clc = PlannedPath::of(&clc_path, &law);
    let plp = PlannedPath::of(&ClcPath::plp(&ends), &law);
    let saving_j = plp.energy_j - clc.energy_j;
    let (preset, file) = match source {
        ModelSource::Preset(p) => (Some(p.name()), None),
        ModelSource::File(path) => (None, Some(path.display().to_string())),
    };
    Ok(PlanReport {
        setting: PlanSetting {
            preset,
            model: file,
            model_description: model.description.clone(),
            start_deg,
            end_deg,
            distance_m,
            v_c_mps: law.v_c_mps(),
            r_prime_m: law.r_prime_m(),
        },
        clc,
        plp,
        saving_j,
        saving_pct: 100.0 * saving_j / plp.energy_j,
    })
}

/// Plans with a preset (see [`plan`]).
pub fn plan_preset(
    preset: Preset,
    start_deg: f64,
    end_deg: f64,
    distance_m: f64,
) -> Result<PlanReport, PlanError> {
    plan(
        &preset.model(),
        &ModelSource::Preset(preset),
        start_deg,
        end_deg,
        distance_m,
    )
}

impl fmt::Display for PlanReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.setting;
        let source = s.source();
        writeln!(
            f,
            "plan: {}° -> {}° over {} m (path frame), {source}{}",
            s.start_deg,
            s.end_deg,
            s.distance_m,
            s.model_description
                .as_deref()
                .map_or(String::new(), |d| format!(" ({d})")),
        )?;
        writeln!(f, "v_c = {} m/s, R' = {:.3} m", s.v_c_mps, s.r_prime_m)?;
        writeln!(
            f,
            "{:<4}  {:>10}  {:>7}  {:>7}  {:>9}  {:>8}  {:>7}",
            "path", "energy J", "R1 m", "R2 m", "θ_B °", "line m", "time s"
        )?;
        for (name, p) in [("CLC", &self.clc), ("PLP", &self.plp)] {
            writeln!(
                f,
                "{name:<4}  {:>10.2}  {:>7.3}  {:>7.3}  {:>9.2}  {:>8.3}  {:>7.1}",
                p.energy_j, p.r1_m, p.r2_m, p.line_heading_deg, p.line_length_m, p.duration_s
            )?;
        }
        writeln!(
            f,
            "CLC saves {:.2} J ({:.2} %) over PLP",
            self.saving_j, self.saving_pct
        )
    }
}

#[cfg(test)]
mod tests;
