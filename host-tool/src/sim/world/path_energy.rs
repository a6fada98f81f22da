//! Path-level energies of a driven scenario: each `clc` entry's energy against the `plp` entry
//! with the same ends in the same repeat, ΔE = (E_CLC − E_PLP)/E_PLP (thesis Eq 6.1), as thesis
//! Table 6.1 reports it. The truth is the world's own per-piece energy (arc, line, arc), so this
//! is the calibration check of a world against a published path table, not a measurement chain.

use super::scenario::{Manoeuvre, ManoeuvreKind, Scenario};
use super::timeline::ManoeuvreTruth;
use serde::Serialize;

/// ΔE of one CLC entry of a scenario, over its repeats.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PathDeltaE {
    /// Index of the `clc` entry in the scenario.
    pub scenario_index: usize,
    /// Commanded R/R' of both arcs (R' of the controller, as the scenario commands it).
    pub r_over_r_prime: f64,
    /// θ_A, θ_C [deg] and d [m] of the path.
    pub ends: [f64; 3],
    /// ΔE of each repeat [%].
    pub delta_e_pct: Vec<f64>,
    /// Mean ΔE over the repeats [%].
    pub mean_delta_e_pct: f64,
    /// Mean true radius of the arcs over the mean true radius of the R' arcs of the same
    /// scenario (thesis R_ACT/R'_ACT), when the scenario has a CLC entry at R/R' = 1.
    pub r_act_over_r_prime_act: Option<f64>,
}

/// Ends of a path entry: θ_A, θ_C, d.
fn ends_of(m: &Manoeuvre) -> Option<[f64; 3]> {
    match *m {
        Manoeuvre::Clc {
            start_heading_deg,
            end_heading_deg,
            distance_m,
            ..
        }
        | Manoeuvre::Plp {
            start_heading_deg,
            end_heading_deg,
            distance_m,
            ..
        } => Some([start_heading_deg, end_heading_deg, distance_m]),
        _ => None,
    }
}

/// Total energy of entry `index` in `repeat` (every piece, both sides) [J] and the mean true
/// radius of its arcs [m].
fn entry_energy(truth: &[ManoeuvreTruth], index: usize, repeat: u32) -> (f64, Option<f64>) {
    let pieces = truth
        .iter()
        .filter(|m| m.scenario_index == index && m.repeat == repeat);
    let mut energy = 0.0;
    let (mut radius_sum, mut arcs) = (0.0, 0);
    for m in pieces {
        energy += m.energy_j.left + m.energy_j.right;
        if let Some(r) = m.true_radius_m.filter(|r| r.is_finite()) {
            radius_sum += r;
            arcs += 1;
        }
    }
    (energy, (arcs > 0).then(|| radius_sum / f64::from(arcs)))
}

/// ΔE of every `clc` entry of `scenario` against the `plp` entry with the same ends, from the
/// world's truth of one simulated run of it; `r_prime_m` is the controller's R' (for entries
/// given by `radius_m`). Entries without a PLP counterpart are left out.
pub fn path_delta_e(
    scenario: &Scenario,
    truth: &[ManoeuvreTruth],
    r_prime_m: f64,
) -> Vec<PathDeltaE> {
    let same = |a: [f64; 3], b: [f64; 3]| a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-9);
    let plp_of = |ends: [f64; 3]| {
        scenario.manoeuvres.iter().position(|m| {
            m.kind() == ManoeuvreKind::Plp && ends_of(m).is_some_and(|e| same(e, ends))
        })
    };
    let mut out = Vec::new();
    for (index, m) in scenario.manoeuvres.iter().enumerate() {
        let Manoeuvre::Clc {
            r_over_r_prime,
            radius_m,
            ..
        } = *m
        else {
            continue;
        };
        let Some(ends) = ends_of(m) else { continue };
        let Some(plp) = plp_of(ends) else { continue };
        let mut delta = Vec::new();
        let mut radius = Vec::new();
        for repeat in 0..scenario.repeats {
            let (clc_j, r) = entry_energy(truth, index, repeat);
            let (plp_j, _) = entry_energy(truth, plp, repeat);
            if plp_j > 0.0 {
                delta.push(100.0 * (clc_j - plp_j) / plp_j);
            }
            radius.extend(r);
        }
        if delta.is_empty() {
            continue;
        }
        let mean = delta.iter().sum::<f64>() / delta.len() as f64;
        let r_act = (!radius.is_empty()).then(|| radius.iter().sum::<f64>() / radius.len() as f64);
        out.push((
            PathDeltaE {
                scenario_index: index,
                r_over_r_prime: r_over_r_prime
                    .or(radius_m.map(|r| r / r_prime_m))
                    .unwrap_or(f64::NAN),
                ends,
                delta_e_pct: delta,
                mean_delta_e_pct: mean,
                r_act_over_r_prime_act: None,
            },
            r_act,
        ));
    }
    // R'_ACT: the true radius driven when R' is commanded (thesis Section 6.1).
    let r_prime_act = out
        .iter()
        .find(|(p, _)| (p.r_over_r_prime - 1.0).abs() < 1e-9)
        .and_then(|(_, r)| *r);
    out.into_iter()
        .map(|(mut p, r)| {
            p.r_act_over_r_prime_act = r.zip(r_prime_act).map(|(r, rp)| r / rp);
            p
        })
        .collect()
}
