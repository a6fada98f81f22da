//! Cone penetrometer and GRC-1 relative density (Section 3.4, Eq 3.1–3.2).

use super::{check, finite_result, input, unbounded, SoilError};

/// Eq 3.1: cone index gradient G_CI, the least-squares slope of cone index against depth over
/// one insertion's `(depth_mm, cone_index_kpa)` samples [kPa/mm]:
/// Σ (d_i − d̄)(CI_i − CI̅) / Σ (d_i − d̄)². (The seed calls i "the insertion number" but sums
/// over the n measurements of one insertion; averaging insertions is left to the caller, as in
/// Fig 3.8b.) Restrict the slice to a depth range (e.g. the first 100 mm) to get Fig 3.8b's
/// curves.
///
/// `Err(InvalidInput)` for a non-finite sample, `Err(DegenerateData)` for fewer than two
/// samples or all at one depth.
pub fn cone_index_gradient_kpa_per_mm(samples: &[(f64, f64)]) -> Result<f64, SoilError> {
    check(samples.len() >= 2, SoilError::DegenerateData)?;
    let mut sum_d = 0.0;
    let mut sum_ci = 0.0;
    for &(d, ci) in samples {
        input(d, "depth_mm", unbounded)?;
        input(ci, "cone_index_kpa", unbounded)?;
        sum_d += d;
        sum_ci += ci;
    }
    let n = samples.len() as f64;
    let (mean_d, mean_ci) = (sum_d / n, sum_ci / n);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for &(d, ci) in samples {
        sxy += (d - mean_d) * (ci - mean_ci);
        sxx += (d - mean_d) * (d - mean_d);
    }
    check(sxx > 0.0, SoilError::DegenerateData)?;
    finite_result(sxy / sxx)
}

/// Eq 3.2: GRC-1 cone index gradient G_CI = 0.0834 D_R + 1.5811 [kPa/mm] at relative density
/// D_R [%] (Oravec et al.'s fit).
pub fn grc1_cone_index_gradient_kpa_per_mm(relative_density_percent: f64) -> f64 {
    0.0834 * relative_density_percent + 1.5811
}

/// Eq 3.2 inverted: GRC-1 relative density D_R = (G_CI − 1.5811) / 0.0834 [%] from a cone
/// index gradient [kPa/mm]. Outside 1.58–9.92 kPa/mm the result leaves 0–100 % (extrapolation).
///
/// Units: kPa/mm, N/cm³ and MPa/m are the same unit, so no unit reading changes the numbers.
/// The seed's sandbox gradient of Table 3.4, 9.5 kPa/mm, gives D_R = 94.95 % ("dense"), while
/// Section 3.4 settles on 65 % (G_CI = 7.00 kPa/mm by this equation) from the first 100 mm of
/// soil. The difference is the depth range, not the units: Fig 3.7's CI grows faster below
/// ~90 mm, Fig 3.8b shows D_R rising with the depth range, and Table 3.4's figure evidently
/// spans the full insertions.
pub fn grc1_relative_density_percent(cone_index_gradient_kpa_per_mm: f64) -> f64 {
    (cone_index_gradient_kpa_per_mm - 1.5811) / 0.0834
}

/// GRC-1 dry bulk density at relative density D_R [%], interpolated linearly between Oravec et
/// al.'s minimum 1.60 and maximum 1.89 g/cm³ [kg/m³]. This is the interpolation that gives the
/// seed's 1.7885 g/cm³ at D_R = 65 % (Table 3.3). (The standard definition of D_R is linear in
/// void ratio, not density; it would give 1.777 g/cm³ at 65 %.)
pub fn grc1_bulk_density_kg_m3(relative_density_percent: f64) -> f64 {
    1600.0 + relative_density_percent / 100.0 * (1890.0 - 1600.0)
}
