//! Static sinkage (Bekker, Eq 1.24–1.26) and the slip-sinkage laws from the literature
//! (Reece, Vasil'ev, Lyasko, Ding: Eq 1.27–1.30).

use super::{check, finite_result, input, param, unbounded, SoilError};
use core::f64::consts::{FRAC_PI_2, PI};

/// Bekker pressure–sinkage parameters of a soil (Eq 1.24, 1.26). Units depend on n_s; SI
/// throughout. The seed gives none for GRC-1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BekkerSoil {
    /// k_c: cohesive modulus [N/m^(n_s+1)], ≥ 0.
    pub cohesive_modulus_si: f64,
    /// k_φ: frictional modulus [N/m^(n_s+2)], ≥ 0 (k_c + k_φ B_w > 0).
    pub frictional_modulus_si: f64,
    /// n_s: sinkage exponent, > 0 (< 3 for Eq 1.26).
    pub sinkage_exponent: f64,
}

/// Static sinkage of a rigid wheel under a vertical load (Eq 1.24–1.25).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaticSinkage {
    /// θ_s = θ_f = θ_r: the static entry angle [rad].
    pub entry_angle_rad: f64,
    /// d_0 = r (1 − cos θ_s) [m] (Eq 1.25).
    pub sinkage_m: f64,
}

/// Panels of the fixed-step composite Simpson rule used for Eq 1.24 and Eq 1.31 (even). With
/// n_s ≥ 0.5 the Eq 1.24 integral is within 0.05 % of its converged value.
pub const SIMPSON_PANELS: usize = 64;

/// Bisection steps for θ_s in Eq 1.24 on [0, π/2] (bracket 2⁻⁶⁰ π/2 ≈ 1.4e-18 rad: the
/// bisection stops at f64 resolution).
pub const STATIC_SINKAGE_BISECTIONS: u32 = 60;

/// Composite Simpson rule of `f` on [a, b] with [`SIMPSON_PANELS`] panels.
pub(super) fn simpson(a: f64, b: f64, f: impl Fn(f64) -> f64) -> f64 {
    let h = (b - a) / SIMPSON_PANELS as f64;
    let mut sum = f(a) + f(b);
    for i in 1..SIMPSON_PANELS {
        let weight = if i % 2 == 1 { 4.0 } else { 2.0 };
        sum += weight * f(a + i as f64 * h);
    }
    sum * h / 3.0
}

impl BekkerSoil {
    fn validate(&self, width_m: f64) -> Result<(), SoilError> {
        param(self.cohesive_modulus_si, "cohesive_modulus_si", |k| {
            k >= 0.0
        })?;
        param(self.frictional_modulus_si, "frictional_modulus_si", |k| {
            k >= 0.0
        })?;
        param(self.sinkage_exponent, "sinkage_exponent", |n| n > 0.0)?;
        let k = self.cohesive_modulus_si + self.frictional_modulus_si * width_m;
        check(
            k > 0.0 && k.is_finite(),
            SoilError::InvalidParameter("k_c + k_phi B_w"),
        )
    }

    /// Eq 1.24: the load [N] that holds a wheel of radius r and width B_w at static entry angle
    /// θ_s: p = r^(n+1) (k_c + k_φ B_w) ∫_{−θ_s}^{θ_s} (cos θ − cos θ_s)^n cos θ dθ, integrated
    /// with Simpson's rule (the integrand is even, so 2 ∫_0^{θ_s}). Unchecked inputs.
    pub(super) fn static_load_n(&self, radius_m: f64, width_m: f64, entry_angle_rad: f64) -> f64 {
        let n = self.sinkage_exponent;
        let cos_s = libm::cos(entry_angle_rad);
        let integral = 2.0
            * simpson(0.0, entry_angle_rad, |t| {
                let c = libm::cos(t);
                // max: rounding can make cos θ − cos θ_s slightly negative at θ = θ_s.
                libm::pow((c - cos_s).max(0.0), n) * c
            });
        libm::pow(radius_m, n + 1.0)
            * (self.cohesive_modulus_si + self.frictional_modulus_si * width_m)
            * integral
    }

    /// Eq 1.24–1.25: static sinkage of a rigid wheel (radius r, width B_w [m]) under a vertical
    /// load p [N]: θ_s solved from Eq 1.24 by bisection on [0, π/2]
    /// ([`STATIC_SINKAGE_BISECTIONS`] steps; the load grows with θ_s), then d_0 = r (1 − cos θ_s).
    /// `Err(NoSolution)` when even θ_s = π/2 (sinkage to the axle) cannot carry the load.
    ///
    /// Eq 1.24 lets the soil carry the wheel over the whole symmetric arc [−θ_s, θ_s]; the
    /// closed form Eq 1.26 is Bekker's rolling-wheel result, where only the front half of the
    /// arc carries it. For the same p, Eq 1.26 therefore gives about 2^(2/(2n_s+1)) times the
    /// sinkage of Eq 1.24 (×1.54 for n_s = 1.1): the two agree at Eq 1.24's load 2p (within 1 %
    /// for n_s = 1.1, within 8 % for n_s = 0.5, where the parabola behind Eq 1.26 is cruder).
    pub fn static_sinkage(
        &self,
        radius_m: f64,
        width_m: f64,
        load_n: f64,
    ) -> Result<StaticSinkage, SoilError> {
        let r = param(radius_m, "radius_m", |r| r > 0.0)?;
        let b = param(width_m, "width_m", |b| b > 0.0)?;
        self.validate(b)?;
        let p = input(load_n, "load_n", |p| p >= 0.0)?;
        let max_load = self.static_load_n(r, b, FRAC_PI_2);
        check(max_load.is_finite(), SoilError::Overflow)?;
        check(p <= max_load, SoilError::NoSolution)?;
        let (mut lo, mut hi) = (0.0, FRAC_PI_2);
        for _ in 0..STATIC_SINKAGE_BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if self.static_load_n(r, b, mid) < p {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let entry_angle_rad = 0.5 * (lo + hi);
        Ok(StaticSinkage {
            entry_angle_rad,
            sinkage_m: r * (1.0 - libm::cos(entry_angle_rad)),
        })
    }

    /// Eq 1.26: Bekker's closed-form sinkage [m] of a wheel (radius r, width B_w [m]) under load
    /// p [N]: d_0 = [3p / (B_w (3 − n_s)(k_c/B_w + k_φ) √(2r))]^(2/(2n_s+1)).
    ///
    /// Choice: the seed prints the exponent as "(2/2n_s+1)"; read as 2/(2n_s + 1), Bekker's
    /// exponent (the other reading, 2/(2n_s) + 1, is not dimensionally consistent). Needs
    /// n_s < 3. See [`BekkerSoil::static_sinkage`] for how it compares with Eq 1.24.
    pub fn closed_form_sinkage_m(
        &self,
        radius_m: f64,
        width_m: f64,
        load_n: f64,
    ) -> Result<f64, SoilError> {
        let r = param(radius_m, "radius_m", |r| r > 0.0)?;
        let b = param(width_m, "width_m", |b| b > 0.0)?;
        self.validate(b)?;
        let n = param(self.sinkage_exponent, "sinkage_exponent", |n| n < 3.0)?;
        let p = input(load_n, "load_n", |p| p >= 0.0)?;
        let k = b * (self.cohesive_modulus_si / b + self.frictional_modulus_si);
        let base = 3.0 * p / (k * (3.0 - n) * libm::sqrt(2.0 * r));
        finite_result(libm::pow(base, 2.0 / (2.0 * n + 1.0)))
    }
}

// ---------------------------------------------------------------------------------------------
// Slip-sinkage laws from the literature (Eq 1.27–1.30)
// ---------------------------------------------------------------------------------------------

fn slip_input(slip: f64) -> Result<f64, SoilError> {
    input(slip, "slip", |s| (0.0..=1.0).contains(&s))
}

/// Eq 1.27 (Reece): d = d_0 + h s_y / (1 − s_y) [m], from the static sinkage d_0 and grouser
/// height h [m]. Sinks by h at 50 % slip and without bound towards 100 %: s_y must lie in
/// [0, 1).
pub fn reece_sinkage_m(
    static_sinkage_m: f64,
    grouser_height_m: f64,
    slip: f64,
) -> Result<f64, SoilError> {
    let d0 = param(static_sinkage_m, "static_sinkage_m", |d| d >= 0.0)?;
    let h = param(grouser_height_m, "grouser_height_m", |h| h >= 0.0)?;
    let s = input(slip, "slip", |s| (0.0..1.0).contains(&s))?;
    finite_result(d0 + h * s / (1.0 - s))
}

/// Eq 1.28 (Vasil'ev): d = d_0 + s_y H_p [m], H_p an experimentally determined length [m];
/// s_y in [0, 1].
pub fn vasilev_sinkage_m(
    static_sinkage_m: f64,
    slip: f64,
    slip_sinkage_m: f64,
) -> Result<f64, SoilError> {
    let d0 = param(static_sinkage_m, "static_sinkage_m", |d| d >= 0.0)?;
    let hp = param(slip_sinkage_m, "slip_sinkage_m", |h| h >= 0.0)?;
    let s = slip_input(slip)?;
    Ok(d0 + s * hp)
}

/// Eq 1.29 (Lyasko): d = (1 + s_y) / (1 − 0.5 s_y) · d_0 [m]; s_y in [0, 1].
///
/// Seed inconsistency: the text says 0 % and 100 % slip give 2 d_0 and 4 d_0, but the formula
/// gives d_0 at s_y = 0 (no slip, static sinkage) and 2/0.5 d_0 = 4 d_0 at s_y = 1 (2 d_0 is
/// what it gives at 50 % slip). This implements the formula as printed; the text's "2 d_0 at
/// 0 %" is not reproduced.
pub fn lyasko_sinkage_m(static_sinkage_m: f64, slip: f64) -> Result<f64, SoilError> {
    let d0 = param(static_sinkage_m, "static_sinkage_m", |d| d >= 0.0)?;
    let s = slip_input(slip)?;
    Ok((1.0 + s) / (1.0 - 0.5 * s) * d0)
}

/// Eq 1.30 (Ding et al.): d = r (1 − cos θ_f) + h s_y − Δd_4 [m], from the wheel radius r, the
/// front entry angle θ_f (found by Ding's force balance, not reproduced in the seed, so an input
/// here), the grouser height h and the experimental offset Δd_4 [m]; s_y in [0, 1]. Returned as
/// computed: a large Δd_4 can make it negative.
pub fn ding_sinkage_m(
    radius_m: f64,
    front_angle_rad: f64,
    grouser_height_m: f64,
    slip: f64,
    offset_m: f64,
) -> Result<f64, SoilError> {
    let r = param(radius_m, "radius_m", |r| r > 0.0)?;
    let h = param(grouser_height_m, "grouser_height_m", |h| h >= 0.0)?;
    let dd4 = param(offset_m, "offset_m", unbounded)?;
    let tf = input(front_angle_rad, "front_angle_rad", |t| {
        (0.0..=PI).contains(&t)
    })?;
    let s = slip_input(slip)?;
    Ok(r * (1.0 - libm::cos(tf)) + h * s - dd4)
}
