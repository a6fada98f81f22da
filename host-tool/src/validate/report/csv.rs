//! The per-manoeuvre table as CSV (`--csv`): its columns and [`ValidationReport::write_csv`].

use super::{direction_name, ValidationReport};
use model_core::kinematics::Regime;
use std::io::{self, Write};

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
}
