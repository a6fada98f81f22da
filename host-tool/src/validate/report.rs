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
use std::fmt;
use std::io::{self, Write};

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

/// The CSV columns of [`ValidationReport::write_csv`].
pub const CSV_COLUMNS: [&str; 43] = [
    "run",
    "segment",
    "kind",
    "direction",
    "t_start_s",
    "t_end_s",
    "cmd_left_mps",
    "cmd_right_mps",
    "v_c_mps",
    "radius_cmd_m",
    "r_over_r_prime",
    "regime",
    "duration_s",
    "expected_duration_s",
    "turned_deg",
    "turned_from_yaw",
    "yaw_rate_cmd_rad_s",
    "yaw_rate_act_rad_s",
    "angular_slip",
    "avg_left_w",
    "avg_right_w",
    "avg_total_w",
    "max_left_w",
    "max_right_w",
    "max_total_w",
    "energy_left_j",
    "energy_right_j",
    "energy_total_j",
    "tau_left_w_s_per_rad",
    "tau_right_w_s_per_rad",
    "mean_pitch_deg",
    "first_half_total_w",
    "second_half_total_w",
    "growth_w",
    "gaps",
    "in_fit",
    "predicted_w",
    "prediction_half_width_w",
    "residual_w",
    "residual_fraction",
    "flagged",
    "hard_ground_w",
    "hard_ground_residual_fraction",
];

/// The CSV columns [`ValidationReport::write_csv`] adds after [`CSV_COLUMNS`] when some run has
/// positions (`slip_track_measured_m`: the run's).
pub const POSE_CSV_COLUMNS: [&str; 13] = [
    "r_act_m",
    "r_act_over_r_prime_act",
    "slip_track_measured_m",
    "track_fixes",
    "track_filled",
    "track_fit_rms_m",
    "track_swept_deg",
    "track_yaw_rate_act_rad_s",
    "track_angular_slip",
    "track_inner_speed_mps",
    "track_outer_speed_mps",
    "track_slip_track_m",
    "track_notes",
];

/// A CSV number in its shortest form; a value computed in f32 (the board's kinematics) in the
/// f32's shortest form (`0.3`, not `0.30000001192092896`).
fn cell(v: Option<f64>) -> String {
    v.map_or_else(String::new, |v| {
        let single = v as f32;
        if f64::from(single) == v {
            format!("{single}")
        } else {
            format!("{v}")
        }
    })
}

fn quote(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

impl ValidationReport {
    /// Whether some run had positions (the pose columns and table are written).
    pub fn has_positions(&self) -> bool {
        self.settings.tracker_offset_m.is_some()
    }

    /// The run's measured slip track [m].
    fn slip_track_of(&self, run: &str) -> Option<f64> {
        self.runs
            .iter()
            .find(|r| r.name == run)
            .and_then(|r| r.slip_track_measured_m)
    }

    /// Writes the per-manoeuvre table as CSV (header [`CSV_COLUMNS`], then
    /// [`POSE_CSV_COLUMNS`] when some run has positions; empty cells for "none").
    pub fn write_csv(&self, out: &mut impl Write) -> io::Result<()> {
        let poses = self.has_positions();
        write!(out, "{}", CSV_COLUMNS.join(","))?;
        if poses {
            write!(out, ",{}", POSE_CSV_COLUMNS.join(","))?;
        }
        writeln!(out)?;
        for m in &self.manoeuvres {
            let s = &m.stats;
            let fit = m.fit.as_ref();
            let mut cells = vec![
                quote(&m.run),
                m.segment.to_string(),
                m.kind.id().to_owned(),
                m.direction.map_or("", direction_name).to_owned(),
                cell(Some(m.t_start_s)),
                cell(Some(m.t_end_s)),
                cell(Some(m.cmd_mps.left)),
                cell(Some(m.cmd_mps.right)),
                cell(Some(m.v_c_mps)),
                cell(m.radius_cmd_m),
                cell(m.r_over_r_prime),
                m.regime.map_or("", Regime::id).to_owned(),
                cell(Some(s.duration_s)),
                cell(s.expected_duration_s),
                cell(s.turned_deg),
                s.turned_from_yaw.to_string(),
                cell(Some(s.yaw_rate_cmd_rad_s)),
                cell(s.yaw_rate_act_rad_s),
                cell(s.angular_slip),
                cell(Some(s.avg_power_w.left)),
                cell(Some(s.avg_power_w.right)),
                cell(Some(s.avg_power_w.total)),
                cell(Some(s.max_power_w.left)),
                cell(Some(s.max_power_w.right)),
                cell(Some(s.max_power_w.total)),
                cell(Some(s.energy_j.left)),
                cell(Some(s.energy_j.right)),
                cell(Some(s.energy_j.total)),
                cell(s.torque_proportional.left),
                cell(s.torque_proportional.right),
                cell(s.mean_pitch_deg),
                cell(s.phases.map(|p| p.first_half_w.total)),
                cell(s.phases.map(|p| p.second_half_w.total)),
                cell(s.phases.map(|p| p.growth_w)),
                s.gaps.to_string(),
                m.in_fit.to_string(),
                cell(fit.map(|f| f.predicted_w)),
                cell(fit.map(|f| f.prediction_half_width_w)),
                cell(fit.map(|f| f.residual_w)),
                cell(fit.and_then(|f| f.residual_fraction)),
                fit.is_some_and(|f| f.flagged).to_string(),
                cell(m.hard_ground_w),
                cell(m.hard_ground_residual_fraction),
            ];
            if poses {
                let t = m.track.as_ref();
                let speeds = t.and_then(|t| t.wheel_speed_mps);
                let notes: Vec<String> = t
                    .map(|t| t.notes.iter().map(ToString::to_string).collect())
                    .unwrap_or_default();
                cells.extend([
                    cell(m.r_act_m),
                    cell(m.r_act_over_r_prime_act),
                    cell(self.slip_track_of(&m.run)),
                    t.map_or_else(String::new, |t| t.fixes.to_string()),
                    t.map_or_else(String::new, |t| t.filled.to_string()),
                    cell(t.and_then(|t| t.fit_rms_m)),
                    cell(t.and_then(|t| t.swept_deg)),
                    cell(t.and_then(|t| t.yaw_rate_act_rad_s)),
                    cell(t.and_then(|t| t.angular_slip)),
                    cell(speeds.map(|v| v.inner)),
                    cell(speeds.map(|v| v.outer)),
                    cell(t.and_then(|t| t.slip_track_m)),
                    quote(&notes.join("; ")),
                ]);
            }
            writeln!(out, "{}", cells.join(","))?;
        }
        Ok(())
    }

    /// Manoeuvres flagged as departing from the fitted model.
    pub fn flagged(&self) -> impl Iterator<Item = &ManoeuvreRow> {
        self.manoeuvres
            .iter()
            .filter(|m| m.fit.is_some_and(|f| f.flagged))
    }
}

impl ValidationReport {
    /// The pose-track table: per turn R_ACT and what the track measured, per run the measured
    /// slip track.
    fn fmt_tracks(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "pose track (Section 5.1: Hampel filter and gap filling, circle fit; tracked point {} m right of the centre):",
            self.settings.tracker_offset_m.unwrap_or(0.0)
        )?;
        writeln!(
            f,
            "{:<12} {:>3} {:<5} {:>8} {:>8} {:>9} {:>7} {:>5} {:>4} {:>6} {:>7} {:>6} {:>6} {:>7}  note",
            "run", "seg", "dir", "R_cmd[m]", "R_ACT[m]", "R/R'_ACT", "rms[mm]", "fixes", "fill",
            "θ[°]", "s_ω[%]", "v_i", "v_o", "B_s[m]"
        )?;
        for m in self.manoeuvres.iter().filter(|m| m.track.is_some()) {
            let Some(t) = &m.track else { continue };
            let name = m.run.rsplit(['/', '\\']).next().unwrap_or(&m.run);
            let run: String = name
                .chars()
                .skip(name.chars().count().saturating_sub(12))
                .collect();
            let notes: Vec<String> = t.notes.iter().map(ToString::to_string).collect();
            writeln!(
                f,
                "{:<12} {:>3} {:<5} {:>8} {:>8} {:>9} {:>7} {:>5} {:>4} {:>6} {:>7} {:>6} {:>6} {:>7}  {}",
                run,
                m.segment,
                m.direction.map_or("", direction_name),
                num(m.radius_cmd_m, 3),
                num(m.r_act_m, 3),
                num(m.r_act_over_r_prime_act, 2),
                num(t.fit_rms_m.map(|v| 1e3 * v), 1),
                t.fixes,
                t.filled,
                num(t.swept_deg, 1),
                pct(t.angular_slip),
                num(t.wheel_speed_mps.map(|v| v.inner), 3),
                num(t.wheel_speed_mps.map(|v| v.outer), 3),
                num(t.slip_track_m, 3),
                notes.join("; ")
            )?;
        }
        writeln!(f, "  (R'_ACT = measured slip track / 2; rms: fixes from the fitted circle; θ swept about its centre; s_ω Eq 6.3 from the track; v_i, v_o wheel speeds Eq 5.10–5.13 [m/s]; B_s Appendix D per turn)")?;
        for run in &self.runs {
            match &run.slip_track_measured {
                Some(st) => writeln!(
                    f,
                    "  {}: measured slip track (Appendix D) {:.3} m (median of {} turns, sd {:.3} m; controller {} m), R'_ACT {:.3} m",
                    run.name,
                    st.slip_track_m,
                    st.turns,
                    st.spread_m,
                    self.rover.slip_track_m,
                    st.slip_track_m / 2.0
                )?,
                None => writeln!(
                    f,
                    "  {}: no measured slip track (no turn other than a point turn with an R_ACT)",
                    run.name
                )?,
            }
        }
        writeln!(f)
    }
}

/// `v` with `prec` decimals, or "–".
fn num(v: Option<f64>, prec: usize) -> String {
    v.map_or_else(|| "–".to_owned(), |v| format!("{v:.prec$}"))
}

fn pct(v: Option<f64>) -> String {
    v.map_or_else(|| "–".to_owned(), |v| format!("{:+.1}", 100.0 * v))
}

impl ValidationReport {
    /// The rover's parameters and the settings, then a blank line.
    fn fmt_header(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.rover;
        writeln!(
            f,
            "rover: B {} m, L {} m, r {} m, m {} kg, B_s {} m (R' = {:.3} m, B/2 = {:.4} m)",
            r.track_width_m,
            r.length_m,
            r.wheel_radius_m,
            r.mass_kg,
            r.slip_track_m,
            r.r_prime_m(),
            r.half_track_m()
        )?;
        let st = &self.settings;
        writeln!(
            f,
            "settings: speed tolerance {} m/s, min duration {} s, settle {} s, gaps > {}× median dt, turn {}° without yaw, departures > {:.0} % outside the 95 % prediction interval",
            st.speed_tolerance_mps, st.min_duration_s, st.settle_s, st.gap_factor, st.turn_deg, 100.0 * st.departure_fraction
        )?;
        writeln!(f)
    }

    /// One line per run: its samples and spans, then a blank line.
    fn fmt_runs(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "runs:")?;
        for run in &self.runs {
            writeln!(
                f,
                "  {}: {} samples, {:.1} s{}{}; {} spans: {} analysed, {} standstill, {} too short",
                run.name,
                run.samples,
                run.duration_s,
                if run.has_yaw { ", yaw" } else { "" },
                if run.has_pitch { ", pitch" } else { "" },
                run.segments,
                run.analysed,
                run.standstill,
                run.too_short
            )?;
        }
        writeln!(f)?;
        Ok(())
    }

    /// The manoeuvre table and its legend, then a blank line.
    fn fmt_manoeuvres(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{:<12} {:>3} {:<5} {:>8} {:>6} {:<16} {:>6} {:>6} {:>6} {:>7} {:>7} {:>7} {:>7} {:>8} {:>7} {:>7} {:>6} {:>7} {:>7} {:>7} {:>7} {:<4}",
            "run", "seg", "dir", "R_cmd[m]", "R/R'", "regime", "dur[s]", "exp[s]", "s_ω[%]",
            "P_L[W]", "P_R[W]", "P[W]", "Pmax[W]", "E[J]", "τ_L", "τ_R", "θ[°]", "grow[W]",
            "pred[W]", "res[%]", "HG[%]", "flag"
        )?;
        for m in &self.manoeuvres {
            let s = &m.stats;
            // The file name, its last 12 characters if longer.
            let name = m.run.rsplit(['/', '\\']).next().unwrap_or(&m.run);
            let run: String = name
                .chars()
                .skip(name.chars().count().saturating_sub(12))
                .collect();
            writeln!(
                f,
                "{:<12} {:>3} {:<5} {:>8} {:>6} {:<16} {:>6.2} {:>6} {:>6} {:>7.1} {:>7.1} {:>7.1} {:>7.1} {:>8.1} {:>7} {:>7} {:>6} {:>7} {:>7} {:>7} {:>7} {:<4}",
                run,
                m.segment,
                m.direction.map_or("", direction_name),
                num(m.radius_cmd_m, 3),
                num(m.r_over_r_prime, 2),
                m.regime.map_or("", Regime::id),
                s.duration_s,
                num(s.expected_duration_s, 2),
                pct(s.angular_slip),
                s.avg_power_w.left,
                s.avg_power_w.right,
                s.avg_power_w.total,
                s.max_power_w.total,
                s.energy_j.total,
                num(s.torque_proportional.left, 2),
                num(s.torque_proportional.right, 2),
                num(s.mean_pitch_deg, 1),
                num(s.phases.map(|p| p.growth_w), 1),
                num(m.fit.map(|c| c.predicted_w), 1),
                pct(m.fit.and_then(|c| c.residual_fraction)),
                pct(m.hard_ground_residual_fraction),
                if m.fit.is_some_and(|c| c.flagged) { "DEP" } else if m.in_fit { "fit" } else { "" }
            )?;
        }
        writeln!(f, "  (τ ∝ P/ω in W·s/rad; s_ω Eq 6.3; grow: second minus first half of the steady part; res vs fitted Eq 2.12; HG vs hard-ground paper Eq 21; fit: used in the fit; DEP: departs from the fit)")?;
        writeln!(f)?;
        Ok(())
    }

    /// The ICR fit's coefficients, or why there is none.
    fn fmt_fit(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (&self.fit, &self.fit_error) {
            (Some(fit), _) => {
                let c = |c: &super::fit::Coefficient| {
                    format!("{:.4} [{:.4}, {:.4}]", c.value, c.lower, c.upper)
                };
                writeln!(
                    f,
                    "ICR fit (Eq 2.12 / Table 4.3 form P = c1/max(R, R') + c2 + c3 θ; {} manoeuvres: turns with R' ≤ R ≤ 20 m and straight lines, 95 % bounds):",
                    fit.n
                )?;
                writeln!(f, "  c1 = {} W·m", c(&fit.c1_w_m))?;
                writeln!(f, "  c2 = {} W", c(&fit.c2_w))?;
                match (&fit.c3_w_per_deg, &fit.c3_note) {
                    (Some(c3), _) => writeln!(f, "  c3 = {} W/deg", c(c3))?,
                    (None, note) => {
                        writeln!(f, "  c3 {}", note.as_deref().unwrap_or("not fitted"))?
                    }
                }
                writeln!(
                    f,
                    "  r² = {}, residual standard error {:.3} W, dof {}",
                    num(fit.r_squared, 4),
                    fit.residual_standard_error_w,
                    fit.dof
                )?;
            }
            (None, Some(e)) => writeln!(f, "ICR fit: not possible: {e}")?,
            (None, None) => writeln!(f, "ICR fit: not attempted")?,
        }
        Ok(())
    }

    /// The hard-ground reference's parameters, then a blank line.
    fn fmt_hard_ground(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(HardGroundReference {
            model: hg,
            skid_moment_nm,
        }) = &self.hard_ground
        {
            writeln!(
                f,
                "hard-ground reference (paper Eq 21): μ {}, G {} N, L {} m, W {} m, m {} kg, B_s {} m (F = {:.2} N·m)",
                hg.mu, hg.rolling_resistance_n, hg.length_m, hg.width_m, hg.mass_kg, hg.slip_track_m, skid_moment_nm
            )?;
        } else {
            writeln!(
                f,
                "hard-ground reference: none for this rover (pass --hard-ground MU,G,BS)"
            )?;
        }
        writeln!(f)?;
        Ok(())
    }

    /// The per-regime table.
    fn fmt_regimes(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{:<18} {:>4} {:>8} {:>9} {:>8} {:>9} {:>7} {:>7}",
            "regime", "n", "P[W]", "res[W]", "res[%]", "|res|max%", "flagged", "HG[%]"
        )?;
        for g in &self.regimes {
            writeln!(
                f,
                "{:<18} {:>4} {:>8.1} {:>9} {:>8} {:>9} {:>7} {:>7}",
                g.regime.map_or("", Regime::id),
                g.manoeuvres,
                g.mean_power_w,
                num(g.mean_residual_w, 1),
                pct(g.mean_residual_fraction),
                g.max_abs_residual_fraction
                    .map_or_else(|| "–".to_owned(), |v| format!("{:.1}", 100.0 * v)),
                g.flagged,
                pct(g.mean_hard_ground_residual_fraction)
            )?;
        }
        Ok(())
    }

    /// The manoeuvres departing from the fit, then a blank line.
    fn fmt_departures(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let flagged: Vec<String> = self
            .flagged()
            .map(|m| {
                format!(
                    "{} seg {} ({}, {})",
                    m.run,
                    m.segment,
                    m.regime.map_or("", Regime::id),
                    pct(m.fit.and_then(|c| c.residual_fraction))
                )
            })
            .collect();
        if flagged.is_empty() {
            writeln!(f, "departures from the fitted model: none")?;
        } else {
            writeln!(
                f,
                "departures from the fitted model: {}",
                flagged.join("; ")
            )?;
        }
        writeln!(f)?;
        Ok(())
    }

    /// Per run, the board's model frames against the host's recomputation.
    fn fmt_cross_check(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "board model vs host recomputation:")?;
        for run in &self.runs {
            match &run.cross_check {
                None => writeln!(f, "  {}: no frames (nothing to cross-check)", run.name)?,
                Some(c) => writeln!(
                    f,
                    "  {}: {} model frames, differing from the host's recomputation: {}; max |Δenergy| {}/{} LSB·µs ({:.6}/{:.6} J), max |Δpower| {}/{} LSB, max |Δτ| {:.3e}/{:.3e} W·s/rad ({} compared){}; {} definedness mismatches, {} lost samples, {} board restarts",
                    run.name,
                    c.model_frames,
                    c.model_mismatches,
                    c.energy_lsb_us.max_abs.left,
                    c.energy_lsb_us.max_abs.right,
                    c.energy_max_abs_j.left,
                    c.energy_max_abs_j.right,
                    c.power_lsb.max_abs.left,
                    c.power_lsb.max_abs.right,
                    c.torque_proportional.max_abs.left,
                    c.torque_proportional.max_abs.right,
                    c.torque_proportional.compared,
                    c.torque_proportional.at_t_s.map_or_else(String::new, |t| format!(" at t = {t:.3} s")),
                    c.definedness_mismatches,
                    c.lost_samples,
                    c.board_restarts
                )?,
            }
        }
        Ok(())
    }
}

impl fmt::Display for ValidationReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.fmt_header(f)?;
        self.fmt_runs(f)?;
        self.fmt_manoeuvres(f)?;
        if self.has_positions() {
            self.fmt_tracks(f)?;
        }
        self.fmt_fit(f)?;
        self.fmt_hard_ground(f)?;
        self.fmt_regimes(f)?;
        self.fmt_departures(f)?;
        self.fmt_cross_check(f)
    }
}
