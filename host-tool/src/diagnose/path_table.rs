//! Path-level summaries: published tables of ΔE = (E_CLC − E_PLP)/E_PLP (thesis Eq 6.1) per
//! slice of R/R' (thesis Table 6.1) as diagnosis input, and their judgement against the
//! hard-ground model (paper Eq 26/39 through `plan`).
//!
//! Format: comma-separated, `#` comments and blank lines skipped, the header exactly
//! `start_deg,end_deg,distance_m,r_lo_over_r_prime,r_hi_over_r_prime,delta_e_pct[,p_value]`,
//! one slice per row: the path's headings (path frame, paper Eq 50) and distance, the slice
//! lo < hi of R/R' (R' of the terrain), the measured mean ΔE [%] and optionally the p of the
//! two-tailed t-test of CLC against PLP energy (0 < p ≤ 1; "< 0.001" written as 0.001 gives a
//! bound on the uncertainty, i.e. conservative). An empty p cell is allowed.
//!
//! Judgement ([`diagnose_path_table`]): the hard-ground model predicts each slice's mean ΔE;
//! a row's uncertainty comes from its p (|t| = Φ⁻¹(1 − p/2): a published table gives no df,
//! so the large-sample limit); gaps are tested row by row (Holm over the rows with a p) and
//! must exceed [`FLOOR_PP`]. Every catalogued effect that a path's energy can show is added to
//! the path energies (one shape per effect, linear in its parameters, the shapes of
//! [`super::effects`] integrated over each segment's duration at v_c) and scored by
//! leave-one-slice-out: fitted (weighted by 1/σ²) on the other slices, it predicts the held-out
//! slice's ΔE exactly through the path energies. The selection rule is the diagnosis'
//! (≥ 30 % of the held-out error closed, runner-up's held-out MSE ≥ 1.5×), on the held-out
//! error without Akaike's factor (see [`diagnose_path_table`]).

mod reader;

pub use reader::{
    is_path_table_file, load_path_table, parse_path_table, PathRow, PathTableError,
    PATH_TABLE_COLUMNS,
};

use super::catalogue;
use super::effect::PathSegment;
use super::verdict::{Scope, Verdict};
use crate::effect_id::EffectId;
use crate::plan::{EnergyModel, ModelLaw};
use model_core::kinematics::{Regime, RegimeBounds};
use model_core::paths::{ClcEnds, ClcPath, SegmentEnergy};
use model_core::Rover;
use serde::Serialize;
use std::fmt;

/// Smallest gap that counts in practice [percentage points] (the thesis matched CLC and PLP
/// displacements within ±2 %).
pub const FLOOR_PP: f64 = 2.0;

/// Points per slice over which the model's mean ΔE is taken (midpoint rule).
const SLICE_POINTS: u32 = 40;

/// The hard-ground model of `rover` for a path table without calibration runs: paper Table 2's
/// Husky values carried over (μ, G per kg, the terrain slip track per track width), as the
/// Argo J5 hard-ground world does. For the Husky file it is the `husky-hard-ground` preset up to
/// its 0.545 m track (paper Table 2: 0.55 m).
pub fn hard_ground_for(rover: &Rover) -> EnergyModel {
    let mut model = EnergyModel::husky_hard_ground();
    let preset = model.clone();
    let scale_m = f64::from(rover.mass_kg) / f64::from(preset.rover.mass_kg);
    let scale_w = f64::from(rover.track_width_m) / f64::from(preset.rover.track_width_m);
    model.rover = *rover;
    model.base.rolling_resistance_n *= scale_m;
    model.base.slip_track_m *= scale_w;
    model.description = Some(
        "hard ground: paper Table 2 carried over to the rover (μ, G per kg, B_s per track width)"
            .into(),
    );
    model
}

/// A slice judged against the hard-ground model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SliceVerdict {
    /// Line in the file.
    pub line: usize,
    /// Lower bound of R/R'.
    pub lo: f64,
    /// Upper bound of R/R'.
    pub hi: f64,
    /// Regime of the slice's centre (R' of the model's terrain).
    pub regime: Regime,
    /// Measured ΔE [%].
    pub measured_pct: f64,
    /// The hard-ground model's mean ΔE over the slice [%].
    pub model_pct: f64,
    /// measured − model [percentage points].
    pub gap_pp: f64,
    /// σ of the measured mean from its p [percentage points].
    pub sigma_pp: Option<f64>,
    /// gap/σ.
    pub z: Option<f64>,
    /// Two-tailed p of the gap.
    pub p: Option<f64>,
    /// Holm-adjusted p over the rows with a σ.
    pub p_holm: Option<f64>,
    /// Holm ≤ 0.05 and |gap| ≥ [`FLOOR_PP`].
    pub beyond_noise: bool,
}

/// One candidate effect's leave-one-slice-out score.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PathCandidate {
    /// The effect.
    pub effect: EffectId,
    /// Its parameters fitted on every slice (units of its shape: N, W or fractions).
    pub params: Vec<f64>,
    /// RMS of measured − hard-ground ΔE over the slices [pp].
    pub heldout_error_before: f64,
    /// RMS of measured − predicted ΔE, each slice predicted by the fit on the others [pp].
    pub heldout_error_after: f64,
    /// 100·(1 − after/before) [%].
    pub shrink_pct: f64,
    /// after² · (n + p)/(n − p) (Akaike's FPE) [pp²].
    pub penalised_mse: f64,
    /// Each slice's held-out prediction [%].
    pub heldout_pct: Vec<f64>,
}

/// The diagnosis of a path table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PathDiagnosis {
    /// A catalogue effect, `none` or `ambiguous`.
    pub effect: Verdict,
    /// The regime of the largest significant gap (`all` without one).
    pub regime: Scope,
    /// Whether some slice departs beyond its noise.
    pub significant: bool,
    /// The departing slice with the largest gap, as "lo – hi".
    pub departure: Option<String>,
    /// Every slice.
    pub slices: Vec<SliceVerdict>,
    /// Every scored candidate, best first.
    pub candidates: Vec<PathCandidate>,
    /// The hard-ground model used.
    pub model: EnergyModel,
    /// Caveats.
    pub notes: Vec<String>,
}

/// One slice of the table against the hard-ground model: the gap in ΔE, its σ from the
/// slice's p, and the gap's z and two-tailed p (Holm's adjustment comes later, over all slices).
fn slice_verdict(
    row: &PathRow,
    law: &ModelLaw,
    rover: &Rover,
) -> Result<SliceVerdict, PathTableError> {
    let e = row_energies(row, law, rover, None)?.ok_or(PathTableError::NoRows)?;
    let model_pct = 100.0 * (e.clc_j / e.plp_j - 1.0);
    let gap = row.delta_e_pct - model_pct;
    let sigma = row
        .p_value
        .filter(|_| row.delta_e_pct != 0.0)
        .map(|p| row.delta_e_pct.abs() / two_tailed_z(p));
    let z = sigma.map(|s| gap / s);
    let p =
        z.map(|z| 2.0 * (1.0 - model_core::fit::student_t_cdf(z.abs(), 1_000_000).unwrap_or(1.0)));
    let centre = 0.5 * (row.r_lo_over_r_prime + row.r_hi_over_r_prime) * law.r_prime_m();
    Ok(SliceVerdict {
        line: row.line,
        lo: row.r_lo_over_r_prime,
        hi: row.r_hi_over_r_prime,
        regime: Regime::of(centre as f32, rover, &RegimeBounds::default()),
        measured_pct: row.delta_e_pct,
        model_pct,
        gap_pp: gap,
        sigma_pp: sigma,
        z,
        p,
        p_holm: None,
        beyond_noise: false,
    })
}

/// Extra energy of a segment per unit of each parameter of `effect` [J per unit]; `None` for
/// effects a path table cannot show.
fn segment_regressors(
    effect: EffectId,
    law: &ModelLaw,
    width_m: f64,
    length_m: f64,
    radius_m: f64,
    dtheta_rad: f64,
) -> Option<Vec<f64>> {
    let rp = law.r_prime_m();
    let v = law.v_c_mps();
    let line = radius_m.is_infinite();
    let t_s = if line {
        dtheta_rad / v // dtheta carries the line's length
    } else {
        law.arc_duration_s(radius_m, dtheta_rad)
    };
    let rho = radius_m / rp;
    let e_hg_j = if line {
        0.0
    } else {
        law.hard_ground().arc_energy_j(radius_m, dtheta_rad)
    };
    let at_r_prime = (rho - 1.0).abs() <= f64::from(RegimeBounds::default().r_prime_fraction);
    catalogue::of(effect).path_segment(&PathSegment {
        line,
        t_s,
        rho,
        e_hg_j,
        at_r_prime,
        v_mps: v,
        r_prime_m: rp,
        width_m,
        length_m,
        radius_m,
        dtheta_rad,
    })
}

/// Extra energy of a whole path per unit of each parameter [J].
fn path_regressors(
    effect: EffectId,
    law: &ModelLaw,
    rover: &Rover,
    path: &ClcPath,
) -> Option<Vec<f64>> {
    let (w, l) = (f64::from(rover.track_width_m), f64::from(rover.length_m));
    let mut sum: Option<Vec<f64>> = None;
    for (r, a) in [
        (path.r1_m, path.first_turn_rad),
        (f64::INFINITY, path.line_length_m),
        (path.r2_m, path.second_turn_rad),
    ] {
        let g = segment_regressors(effect, law, w, l, r, a)?;
        sum = Some(match sum {
            None => g,
            Some(s) => s.iter().zip(&g).map(|(x, y)| x + y).collect(),
        });
    }
    sum
}

/// A row's path energies under the hard-ground model and one effect's regressors: the PLP's,
/// and the CLC's averaged over the slice.
struct RowEnergies {
    plp_j: f64,
    clc_j: f64,
    plp_g: Vec<f64>,
    clc_g: Vec<f64>,
}

fn row_energies(
    row: &PathRow,
    law: &ModelLaw,
    rover: &Rover,
    effect: Option<EffectId>,
) -> Result<Option<RowEnergies>, PathTableError> {
    let err = |why: String| PathTableError::Path {
        line: row.line,
        why,
    };
    let ends = ClcEnds::new(
        row.start_deg.to_radians(),
        row.end_deg.to_radians(),
        row.distance_m,
    )
    .map_err(|e| err(e.to_string()))?;
    let plp = ClcPath::plp(&ends);
    let regress = |p: &ClcPath| match effect {
        None => Some(Vec::new()),
        Some(e) => path_regressors(e, law, rover, p),
    };
    let Some(plp_g) = regress(&plp) else {
        return Ok(None);
    };
    let mut clc_j = 0.0;
    let mut clc_g = vec![0.0; plp_g.len()];
    let (lo, hi) = (row.r_lo_over_r_prime, row.r_hi_over_r_prime);
    for k in 0..SLICE_POINTS {
        let x = lo + (hi - lo) * (f64::from(k) + 0.5) / f64::from(SLICE_POINTS);
        let r = x * law.r_prime_m();
        let path = ClcPath::new(&ends, r, r)
            .map_err(|e| err(format!("no CLC path at R/R' = {x:.3}: {e}")))?;
        clc_j += path.energy_j(law) / f64::from(SLICE_POINTS);
        for (s, g) in clc_g.iter_mut().zip(regress(&path).unwrap_or_default()) {
            *s += g / f64::from(SLICE_POINTS);
        }
    }
    Ok(Some(RowEnergies {
        plp_j: plp.energy_j(law),
        clc_j,
        plp_g,
        clc_g,
    }))
}

/// z with P(|Z| > z) = p for a standard normal (the t-test's large-sample limit).
fn two_tailed_z(p: f64) -> f64 {
    let tail = |z: f64| 2.0 * (1.0 - model_core::fit::student_t_cdf(z, 1_000_000).unwrap_or(1.0));
    let (mut a, mut b) = (0.0, 40.0);
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if tail(m) > p {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// Weighted least squares without intercept for one or two columns; zeros where singular.
fn fit(x: &[Vec<f64>], y: &[f64], w: &[f64]) -> Vec<f64> {
    let p = x.first().map_or(0, Vec::len);
    let mut a = [[0.0; 2]; 2];
    let mut b = [0.0; 2];
    for ((xi, yi), wi) in x.iter().zip(y).zip(w) {
        for j in 0..p {
            b[j] += wi * xi[j] * yi;
            for k in 0..p {
                a[j][k] += wi * xi[j] * xi[k];
            }
        }
    }
    match p {
        1 if a[0][0] > 1e-300 => vec![b[0] / a[0][0]],
        2 => {
            let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
            let scale = a[0][0] * a[1][1];
            if det.abs() > 1e-12 * scale && scale > 0.0 {
                vec![
                    (b[0] * a[1][1] - b[1] * a[0][1]) / det,
                    (a[0][0] * b[1] - a[1][0] * b[0]) / det,
                ]
            } else if a[0][0] > 1e-300 {
                vec![b[0] / a[0][0], 0.0]
            } else if a[1][1] > 1e-300 {
                vec![0.0, b[1] / a[1][1]]
            } else {
                vec![0.0, 0.0]
            }
        }
        _ => vec![0.0; p],
    }
}

/// ΔE [%] of a row's energies with parameters `theta`.
fn predicted_pct(e: &RowEnergies, theta: &[f64]) -> f64 {
    let dot = |g: &[f64]| g.iter().zip(theta).map(|(g, t)| g * t).sum::<f64>();
    100.0 * ((e.clc_j + dot(&e.clc_g)) / (e.plp_j + dot(&e.plp_g)) - 1.0)
}

/// Scores `effect` by leave-one-slice-out (None if a path table cannot show it).
fn score(
    effect: EffectId,
    rows: &[PathRow],
    law: &ModelLaw,
    rover: &Rover,
    weights: &[f64],
    before: &[f64],
) -> Result<Option<PathCandidate>, PathTableError> {
    let mut energies = Vec::with_capacity(rows.len());
    for row in rows {
        match row_energies(row, law, rover, Some(effect))? {
            Some(e) => energies.push(e),
            None => return Ok(None),
        }
    }
    // (E_CLC + θ·g_CLC) = (1 + ΔE)(E_PLP + θ·g_PLP) is linear in θ: residual ≈ θ·x.
    let x: Vec<Vec<f64>> = energies
        .iter()
        .zip(rows)
        .map(|(e, r)| {
            e.clc_g
                .iter()
                .zip(&e.plp_g)
                .map(|(c, p)| 100.0 * (c - (1.0 + r.delta_e_pct / 100.0) * p) / e.plp_j)
                .collect()
        })
        .collect();
    let y: Vec<f64> = energies
        .iter()
        .zip(rows)
        .map(|(e, r)| r.delta_e_pct - 100.0 * (e.clc_j / e.plp_j - 1.0))
        .collect();
    let n = rows.len();
    let mut heldout_pct = Vec::with_capacity(n);
    for (i, held_out) in energies.iter().enumerate() {
        let keep = |v: &[f64]| -> Vec<f64> {
            v.iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, a)| *a)
                .collect()
        };
        let xs: Vec<Vec<f64>> = (0..n).filter(|&j| j != i).map(|j| x[j].clone()).collect();
        let theta = fit(&xs, &keep(&y), &keep(weights));
        heldout_pct.push(predicted_pct(held_out, &theta));
    }
    let rms = |e: &mut dyn Iterator<Item = f64>| {
        let v: Vec<f64> = e.collect();
        (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
    };
    let after = rms(&mut rows
        .iter()
        .zip(&heldout_pct)
        .map(|(r, p)| r.delta_e_pct - p));
    let before_rms = rms(&mut before.iter().copied());
    let p = x.first().map_or(1, Vec::len);
    let penalised = if n > p {
        after * after * (n + p) as f64 / (n - p) as f64
    } else {
        f64::INFINITY
    };
    Ok(Some(PathCandidate {
        effect,
        params: fit(&x, &y, weights),
        heldout_error_before: before_rms,
        heldout_error_after: after,
        shrink_pct: super::cv::shrink_pct(before_rms, after),
        penalised_mse: penalised,
        heldout_pct,
    }))
}

/// The law of `model` and its rover with the terrain's R' (the model's B_s), not the
/// controller's: what the rows are priced with.
fn law_and_rover(model: &EnergyModel) -> Result<(ModelLaw, Rover), PathTableError> {
    let law = model.law().map_err(|e| PathTableError::Path {
        line: 0,
        why: format!("model: {e}"),
    })?;
    let rover = Rover {
        slip_track_m: model.base.slip_track_m as f32,
        ..model.rover
    };
    Ok((law, rover))
}

/// Checks that `model` can price every row of one path table (the poses have a path at every
/// R/R' of the slice). Its errors name a line, so a caller merging files checks each file's
/// rows before [`diagnose_path_table`], whose errors cannot say which file a line is in.
pub fn check_rows(model: &EnergyModel, rows: &[PathRow]) -> Result<(), PathTableError> {
    let (law, rover) = law_and_rover(model)?;
    for row in rows {
        row_energies(row, &law, &rover, None)?;
    }
    Ok(())
}

/// Judges `rows` against `model` (a hard-ground model, e.g. [`hard_ground_for`]).
pub fn diagnose_path_table(
    model: &EnergyModel,
    rows: &[PathRow],
) -> Result<PathDiagnosis, PathTableError> {
    if rows.len() < 3 {
        return Err(PathTableError::TooFewRows(rows.len()));
    }
    let (law, rover) = law_and_rover(model)?;
    let mut slices = rows
        .iter()
        .map(|row| slice_verdict(row, &law, &rover))
        .collect::<Result<Vec<_>, _>>()?;
    let tested: Vec<usize> = (0..slices.len())
        .filter(|&i| slices[i].p.is_some())
        .collect();
    let adjusted = super::loo::holm(
        &tested
            .iter()
            .filter_map(|&i| slices[i].p)
            .collect::<Vec<_>>(),
    );
    for (&i, q) in tested.iter().zip(adjusted) {
        let s = &mut slices[i];
        s.p_holm = Some(q);
        s.beyond_noise = q <= 0.05 && s.gap_pp.abs() >= FLOOR_PP;
    }
    let mut notes = vec![
        "path table: ΔE per slice only (no power, no durations): the effects are fitted as \
         extra path energy; `motor-heating` (no run time) and `slope` (no pitch) are not scored"
            .to_owned(),
        "σ of each slice from its p with the normal quantile (a published table gives no df; a \
         small df would give larger σ)"
            .to_owned(),
    ];
    if tested.is_empty() {
        notes
            .push("no p-values: significance cannot be judged, every slice weighs the same".into());
    }
    let weights: Vec<f64> = slices
        .iter()
        .map(|s| match (tested.is_empty(), s.sigma_pp) {
            (true, _) => 1.0,
            (false, Some(sd)) if sd.is_finite() && sd > 0.0 => 1.0 / (sd * sd),
            _ => 0.0,
        })
        .collect();
    let before: Vec<f64> = slices.iter().map(|s| s.gap_pp).collect();
    let mut candidates = Vec::new();
    for effect in EffectId::ALL {
        if let Some(c) = score(effect, rows, &law, &rover, &weights, &before)? {
            candidates.push(c);
        }
    }
    // Ranked by the held-out error itself: it is out of sample already, and with five slices
    // Akaike's factor (n + p)/(n − p) = 2.33 for two parameters would rule out every
    // two-parameter shape however well it predicts (reported as `penalised_mse`).
    candidates.sort_by(|a, b| a.heldout_error_after.total_cmp(&b.heldout_error_after));
    let departing = slices
        .iter()
        .filter(|s| s.beyond_noise)
        .max_by(|a, b| a.gap_pp.abs().total_cmp(&b.gap_pp.abs()));
    let significant = departing.is_some();
    let effect = match (significant, candidates.first(), candidates.get(1)) {
        (false, _, _) | (true, None, _) => {
            if significant {
                Verdict::Ambiguous
            } else {
                Verdict::None
            }
        }
        (true, Some(best), runner) => {
            let mse = |c: &PathCandidate| c.heldout_error_after * c.heldout_error_after;
            let clear = runner.is_none_or(|r| mse(r) >= 1.5 * mse(best));
            if best.shrink_pct >= 30.0 && clear {
                Verdict::Effect(best.effect)
            } else {
                Verdict::Ambiguous
            }
        }
    };
    Ok(PathDiagnosis {
        effect,
        regime: departing.map_or(Scope::All, |s| Scope::Regime(s.regime)),
        significant,
        departure: departing.map(|s| format!("{} – {}", s.lo, s.hi)),
        slices,
        candidates,
        model: model.clone(),
        notes,
    })
}

impl PathDiagnosis {
    /// The JSON of `diagnose --json` for a path table: the run diagnosis' keys where they
    /// apply (`effect`, `regime`, `significant`, `candidates`, `metric`, `heldout`), plus the
    /// slices and the model.
    pub fn to_json(&self) -> serde_json::Value {
        let best = self.candidates.first();
        serde_json::json!({
            "input": "path-table",
            "effect": self.effect,
            "regime": self.regime,
            "significant": self.significant,
            "departure": self.departure,
            "candidates": self.candidates.iter().map(|c| serde_json::json!({
                "effect": c.effect.id(),
                "params": c.params,
                "heldout_error_before": c.heldout_error_before,
                "heldout_error_after": c.heldout_error_after,
                "shrink_pct": c.shrink_pct,
                "penalised_mse": c.penalised_mse,
                "heldout_pct": c.heldout_pct,
            })).collect::<Vec<_>>(),
            "metric": {
                "what": "RMS over slices of measured minus predicted ΔE = (E_CLC − E_PLP)/E_PLP, \
                         each slice predicted from the others (leave-one-slice-out)",
                "unit": "percentage points",
            },
            "heldout": best.map(|c| serde_json::json!({
                "scheme": "leave-one-slice-out",
                "effect": c.effect.id(),
                "error_before": c.heldout_error_before,
                "error_after": c.heldout_error_after,
                "shrink_pct": c.shrink_pct,
            })),
            "slices": self.slices,
            "model": self.model,
            "notes": self.notes,
        })
    }
}

impl fmt::Display for PathDiagnosis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "path table against {}",
            self.model
                .description
                .as_deref()
                .unwrap_or("the hard-ground model")
        )?;
        writeln!(
            f,
            "{:>11}  {:<17} {:>9} {:>9} {:>8} {:>7} {:>8}",
            "slice R/R'", "regime", "ΔE meas", "ΔE model", "gap pp", "σ pp", "p Holm"
        )?;
        for s in &self.slices {
            let opt = |v: Option<f64>, d: usize| v.map_or("-".into(), |v| format!("{v:.d$}"));
            writeln!(
                f,
                "{:>4.1} – {:<4.1}  {:<17} {:>+9.2} {:>+9.2} {:>+8.2} {:>7} {:>8}{}",
                s.lo,
                s.hi,
                s.regime.id(),
                s.measured_pct,
                s.model_pct,
                s.gap_pp,
                opt(s.sigma_pp, 2),
                opt(s.p_holm, 4),
                if s.beyond_noise { "  departs" } else { "" }
            )?;
        }
        writeln!(f, "candidates (leave-one-slice-out, RMS of ΔE in pp):")?;
        for c in &self.candidates {
            writeln!(
                f,
                "  {:<19} {:>6.2} -> {:>6.2} ({:>5.1} %)",
                c.effect.id(),
                c.heldout_error_before,
                c.heldout_error_after,
                c.shrink_pct
            )?;
        }
        writeln!(
            f,
            "verdict: {} @ {} ({}{})",
            self.effect,
            self.regime.label(),
            if self.significant {
                "significant"
            } else {
                "no significant gap"
            },
            self.departure.as_deref().map_or(String::new(), |d| format!(
                ", largest departure in slice {d}"
            ))
        )?;
        for n in &self.notes {
            writeln!(f, "note: {n}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
