//! The validation report: per-manoeuvre rows, the fit, departures per regime, the model
//! cross-check, and the plain numbers a plot needs. Serialises to JSON (`--json`), renders as
//! aligned text tables ([`fmt::Display`]) and exports the per-manoeuvre table as CSV.

use super::crosscheck::CrossCheck;
use super::fit::{Comparison, IcrFit};
use super::pose::{MeasuredSlipTrack, TrackStats};
use super::segment::ManoeuvreKind;
use super::turns::{ManoeuvreStats, SideTotal};
use model_core::kinematics::{Regime, TurnDirection};
use model_core::power::IcrHardGround;
use model_core::{Rover, Sides};
use serde::{Serialize, Serializer};

mod csv;
mod table;

pub use csv::{CSV_COLUMNS, POSE_CSV_COLUMNS};

fn regime_id<S: Serializer>(r: &Option<Regime>, s: S) -> Result<S::Ok, S::Error> {
    match r {
        Some(r) => s.serialize_some(r.id()),
        None => s.serialize_none(),
    }
}

fn direction_id<S: Serializer>(d: &Option<TurnDirection>, s: S) -> Result<S::Ok, S::Error> {
    match d {
        Some(d) => s.serialize_some(direction_name(*d)),
        None => s.serialize_none(),
    }
}

fn direction_name(d: TurnDirection) -> &'static str {
    match d {
        TurnDirection::Left => "left",
        TurnDirection::Right => "right",
    }
}

/// One analysed manoeuvre (a turn or a straight line) of one run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ManoeuvreRow {
    /// The run's name (its file).
    pub run: String,
    /// Index of the manoeuvre among the run's segments (standstill and short spans included).
    pub segment: usize,
    /// Turn or straight line.
    pub kind: ManoeuvreKind,
    /// Side of a turn (`"left"`, `"right"`).
    #[serde(serialize_with = "direction_id")]
    pub direction: Option<TurnDirection>,
    /// Time of its first sample [s].
    pub t_start_s: f64,
    /// Time of its last sample [s].
    pub t_end_s: f64,
    /// Index of its first sample in the run.
    pub first_sample: usize,
    /// One past the index of its last sample.
    pub end_sample: usize,
    /// Commanded side speeds (averaged over the span) [m/s].
    pub cmd_mps: Sides<f64>,
    /// Eq 2.6: commanded total absolute speed v_c [m/s].
    pub v_c_mps: f64,
    /// Eq 2.4: commanded turning radius [m]; `None` for straight lines.
    pub radius_cmd_m: Option<f64>,
    /// R_cmd / R' with R' = B_s/2 of the rover (Eq 2.5).
    pub r_over_r_prime: Option<f64>,
    /// The regime (`point`, `below-half-track`, `dragged-inner`, `at-r-prime`, `above-r-prime`,
    /// `straight`).
    #[serde(serialize_with = "regime_id")]
    pub regime: Option<Regime>,
    /// What was measured.
    #[serde(flatten)]
    pub stats: ManoeuvreStats,
    /// Whether the turn entered the ICR fit.
    pub in_fit: bool,
    /// Measured steady average total power against the fitted model; `None` without a fit.
    pub fit: Option<Comparison>,
    /// The hard-ground ICR model (paper Eq 21) at the commanded side speeds [W].
    pub hard_ground_w: Option<f64>,
    /// (measured − hard-ground) / hard-ground.
    pub hard_ground_residual_fraction: Option<f64>,
    /// R_ACT: the radius the rover's centre drove, from the pose track (Section 5.1) [m];
    /// absent for runs without positions.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub r_act_m: Option<f64>,
    /// R_ACT / R′_ACT with R′_ACT = the run's measured slip track / 2 (Table 6.1's axis).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub r_act_over_r_prime_act: Option<f64>,
    /// The pose track's details (fixes, fit residual, angular slip, wheel speeds, notes);
    /// turns of runs with positions only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub track: Option<TrackStats>,
}

/// What one run contributed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunReport {
    /// The run's name (its file).
    pub name: String,
    /// Samples in the run.
    pub samples: usize,
    /// First to last sample [s].
    pub duration_s: f64,
    /// Samples per second achieved: intervals between the first and last sample over their
    /// span [Hz] (0 for fewer than two samples).
    pub sample_rate_hz: f64,
    /// Samples the host knows were lost (sequence gaps in the board's frames); `None` for a run
    /// without frames (a run CSV).
    pub lost_samples: Option<u64>,
    /// Whether every sample has a yaw.
    pub has_yaw: bool,
    /// Whether any sample has a pitch.
    pub has_pitch: bool,
    /// Intervals longer than this are gaps [s].
    pub gap_threshold_s: f64,
    /// Spans of constant command.
    pub segments: usize,
    /// Of which standstill (not analysed).
    pub standstill: usize,
    /// Of which shorter than the minimum duration (not analysed).
    pub too_short: usize,
    /// Of which analysed (turns and straight lines).
    pub analysed: usize,
    /// The board's model frames against the host's recomputation; `None` for a run without
    /// frames (a run CSV).
    pub cross_check: Option<CrossCheck>,
    /// Appendix D: the slip track measured from the turns' R_ACT (median over the turns
    /// commanded at R′, else over all) [m]; runs with positions and at least one turn other
    /// than a point turn.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slip_track_measured_m: Option<f64>,
    /// The same with its spread over the turns.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slip_track_measured: Option<MeasuredSlipTrack>,
}

/// Departures from the fitted model, summarised per regime.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RegimeSummary {
    /// The regime's id.
    #[serde(serialize_with = "regime_id")]
    pub regime: Option<Regime>,
    /// Manoeuvres in the regime.
    pub manoeuvres: usize,
    /// Mean steady average total power [W].
    pub mean_power_w: f64,
    /// Mean residual against the fit [W]; `None` without a fit.
    pub mean_residual_w: Option<f64>,
    /// Mean relative residual against the fit.
    pub mean_residual_fraction: Option<f64>,
    /// Largest |relative residual| against the fit.
    pub max_abs_residual_fraction: Option<f64>,
    /// Manoeuvres flagged as departing from the fit.
    pub flagged: usize,
    /// Mean relative residual against the hard-ground model.
    pub mean_hard_ground_residual_fraction: Option<f64>,
}

/// The hard-ground ICR model used as a second reference (paper Eq 20–22, Table 2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HardGroundReference {
    /// The model's parameters (μ, G, L, W, m, B_s of the terrain), flat in the JSON.
    #[serde(flatten)]
    pub model: IcrHardGround,
    /// Paper Eq 22: F [N·m].
    pub skid_moment_nm: f64,
}

impl From<IcrHardGround> for HardGroundReference {
    fn from(model: IcrHardGround) -> Self {
        Self {
            model,
            skid_moment_nm: model.skid_moment_nm(),
        }
    }
}

/// One manoeuvre as a plot point (turns only: a straight line has no place on an R/R' axis).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PlotPoint {
    /// Index into [`ValidationReport::manoeuvres`].
    pub manoeuvre: usize,
    /// R_cmd / R'.
    pub r_over_r_prime: f64,
    /// The regime's id.
    #[serde(serialize_with = "regime_id")]
    pub regime: Option<Regime>,
    /// Steady average power [W].
    pub avg_power_w: SideTotal,
    /// Steady maximum total power [W].
    pub max_power_w: f64,
    /// τ ∝ P/ω per side [W·s/rad].
    pub torque_proportional: Sides<Option<f64>>,
    /// Fitted model's prediction [W].
    pub predicted_w: Option<f64>,
    /// Measured − predicted [W].
    pub residual_w: Option<f64>,
    /// Flagged as departing.
    pub flagged: bool,
}

/// The model curves against R/R' (at zero pitch and the turns' median v_c).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CurvePoint {
    /// R / R'.
    pub r_over_r_prime: f64,
    /// Fitted Eq 2.12 [W].
    pub fit_w: Option<f64>,
    /// Half-width of its 95 % prediction interval [W].
    pub fit_half_width_w: Option<f64>,
    /// Hard-ground model at the constant-v_c side speeds (Appendix A) [W].
    pub hard_ground_w: Option<f64>,
}

/// What a plot of power and τ against R/R' needs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlotData {
    /// R' = B_s/2 of the rover [m].
    pub r_prime_m: f64,
    /// v_c of the model curves (median of the turns) [m/s].
    pub v_c_mps: f64,
    /// One point per turn.
    pub points: Vec<PlotPoint>,
    /// The model curves.
    pub model_curve: Vec<CurvePoint>,
}

/// The settings a report was made with.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Settings {
    /// Tolerance on the commanded side speeds within a manoeuvre [m/s].
    pub speed_tolerance_mps: f64,
    /// Shortest manoeuvre analysed [s].
    pub min_duration_s: f64,
    /// Gap factor (× median interval).
    pub gap_factor: f64,
    /// Settle time cut for the steady statistics [s].
    pub settle_s: f64,
    /// Heading change assumed without yaw [deg].
    pub turn_deg: f64,
    /// Relative departure flagged (with the prediction interval).
    pub departure_fraction: f64,
    /// Tolerance around R = 0 and R' as a fraction of R'.
    pub r_prime_fraction: f64,
    /// Radii at or above this are straight [m].
    pub straight_from_m: f64,
    /// The tracked point's lateral offset, right positive [m]; when some run has positions.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tracker_offset_m: Option<f64>,
}

/// Everything `validate` found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ValidationReport {
    /// The rover.
    pub rover: Rover,
    /// The settings.
    pub settings: Settings,
    /// Per run.
    pub runs: Vec<RunReport>,
    /// Per analysed manoeuvre, in run order.
    pub manoeuvres: Vec<ManoeuvreRow>,
    /// The fitted ICR model; `None` when it could not be fitted (see `fit_error`).
    pub fit: Option<IcrFit>,
    /// Why there is no fit.
    pub fit_error: Option<String>,
    /// The hard-ground reference model, if one applies to this rover.
    pub hard_ground: Option<HardGroundReference>,
    /// Departures per regime.
    pub regimes: Vec<RegimeSummary>,
    /// Numbers for plots.
    pub plot: PlotData,
}

impl ValidationReport {
    /// Whether some run had positions (the pose columns and table are written).
    pub fn has_positions(&self) -> bool {
        self.settings.tracker_offset_m.is_some()
    }

    /// Manoeuvres flagged as departing from the fitted model.
    pub fn flagged(&self) -> impl Iterator<Item = &ManoeuvreRow> {
        self.manoeuvres
            .iter()
            .filter(|m| m.fit.is_some_and(|f| f.flagged))
    }
}
