//! The validation report as aligned text tables ([`fmt::Display`]): header, runs, manoeuvres,
//! pose tracks, fit, hard-ground reference, regimes, departures and the model cross-check.

use super::{direction_name, HardGroundReference, ValidationReport};
use crate::validate::fit::Coefficient;
use model_core::kinematics::Regime;
use std::fmt;

impl ValidationReport {
    /// The pose-track table: per turn R_ACT and what the track measured, per run the measured
    /// slip track.
    fn fmt_tracks(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let w = self.run_column_width();
        writeln!(
            f,
            "pose track (Section 5.1: Hampel filter and gap filling, circle fit; tracked point {} m right of the centre):",
            self.settings.tracker_offset_m.unwrap_or(0.0)
        )?;
        writeln!(
            f,
            "{:<w$} {:>3} {:<5} {:>8} {:>8} {:>9} {:>7} {:>5} {:>4} {:>6} {:>7} {:>6} {:>6} {:>7}  note",
            "run", "seg", "dir", "R_cmd[m]", "R_ACT[m]", "R/R'_ACT", "rms[mm]", "fixes", "fill",
            "θ[°]", "s_ω[%]", "v_i", "v_o", "B_s[m]",
        )?;
        for m in self.manoeuvres.iter().filter(|m| m.track.is_some()) {
            let Some(t) = &m.track else { continue };
            let run = run_column(&m.run);
            let notes: Vec<String> = t.notes.iter().map(ToString::to_string).collect();
            writeln!(
                f,
                "{:<w$} {:>3} {:<5} {:>8} {:>8} {:>9} {:>7} {:>5} {:>4} {:>6} {:>7} {:>6} {:>6} {:>7}  {}",
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
                notes.join("; "),
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

impl ValidationReport {
    /// The run column's width: the longest run's file name, whole.
    fn run_column_width(&self) -> usize {
        self.manoeuvres
            .iter()
            .map(|m| run_column(&m.run).chars().count())
            .fold("run".len(), usize::max)
    }
}

/// A run's column in the tables: its file name.
fn run_column(run: &str) -> &str {
    run.rsplit(['/', '\\']).next().unwrap_or(run)
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
        let w = self.run_column_width();
        writeln!(
            f,
            "{:<w$} {:>3} {:<5} {:>8} {:>6} {:<16} {:>6} {:>6} {:>6} {:>7} {:>7} {:>7} {:>7} {:>8} {:>7} {:>7} {:>6} {:>7} {:>7} {:>7} {:>7} {:<4}",
            "run", "seg", "dir", "R_cmd[m]", "R/R'", "regime", "dur[s]", "exp[s]", "s_ω[%]",
            "P_L[W]", "P_R[W]", "P[W]", "Pmax[W]", "E[J]", "τ_L", "τ_R", "θ[°]", "grow[W]",
            "pred[W]", "res[%]", "HG[%]", "flag",
        )?;
        for m in &self.manoeuvres {
            let s = &m.stats;
            let run = run_column(&m.run);
            writeln!(
                f,
                "{:<w$} {:>3} {:<5} {:>8} {:>6} {:<16} {:>6.2} {:>6} {:>6} {:>7.1} {:>7.1} {:>7.1} {:>7.1} {:>8.1} {:>7} {:>7} {:>6} {:>7} {:>7} {:>7} {:>7} {:<4}",
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
                if m.fit.is_some_and(|c| c.flagged) { "DEP" } else if m.in_fit { "fit" } else { "" },
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
                let c =
                    |c: &Coefficient| format!("{:.4} [{:.4}, {:.4}]", c.value, c.lower, c.upper);
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
