//! Student t (and F) distribution: cdf, upper tails and quantiles.

use super::FitError;

/// From this many degrees of freedom on, the t quantile uses the Cornish–Fisher expansion about
/// the normal quantile (error O(z¹¹/ν⁵): relative error below 1e-10 against the bisection for
/// |z| ≤ 8 at ν = 1000, smaller for larger ν).
const CORNISH_FISHER_FROM_DOF: usize = 1000;
/// Beyond this many degrees of freedom Cornish–Fisher is used for any tail probability.
const CORNISH_FISHER_ALWAYS_FROM_DOF: usize = 1_000_000;
/// Upper-tail probabilities at or above this (|z| ≲ 8) may use Cornish–Fisher.
const CORNISH_FISHER_MIN_TAIL: f64 = 1e-15;
/// Iteration cap of the incomplete-beta continued fraction (it needs O(√a) terms; a < 5·10⁵ here).
const BETA_CF_MAX_ITERATIONS: usize = 100_000;

/// Cumulative distribution function of Student's t with `dof` degrees of freedom:
/// P(T ≤ t) = 1 − ½ I_x(ν/2, ½) for t ≥ 0, x = ν/(ν + t²) (regularized incomplete beta I, by its
/// continued fraction). Used for the confidence bounds of Tables 4.2 and 4.3.
pub fn student_t_cdf(t: f64, dof: usize) -> Result<f64, FitError> {
    if dof == 0 {
        return Err(FitError::InvalidParameter);
    }
    if t.is_nan() {
        return Err(FitError::NonFinite);
    }
    let tail = t_upper_tail(libm::fabs(t), dof as f64);
    Ok(if t >= 0.0 { 1.0 - tail } else { tail })
}

/// Upper tail of Fisher's F with (`d1`, `d2`) degrees of freedom: P(F > f) =
/// I_x(d2/2, d1/2), x = d2/(d2 + d1 f) (the p-value of a lack-of-fit or nested-model F test).
pub fn f_upper_tail(f: f64, d1: usize, d2: usize) -> Result<f64, FitError> {
    if d1 == 0 || d2 == 0 {
        return Err(FitError::InvalidParameter);
    }
    if f.is_nan() {
        return Err(FitError::NonFinite);
    }
    if f <= 0.0 {
        return Ok(1.0);
    }
    if !f.is_finite() {
        return Ok(0.0);
    }
    let (n1, n2) = (d1 as f64, d2 as f64);
    let denom = n2 + n1 * f;
    Ok(regularized_incomplete_beta(
        n2 / 2.0,
        n1 / 2.0,
        n2 / denom,
        n1 * f / denom,
    ))
}

/// The p-quantile of Student's t with `dof` degrees of freedom (p in (0, 1), dof ≥ 1): the t in
/// the seed's 95 % bounds b ± t(0.975, n − N) SE (Tables 4.2, 4.3).
///
/// Below 1000 degrees of freedom: bisection on the CDF ([`student_t_cdf`]) to full double
/// precision. From 1000 on (for |t| ≲ 8, and beyond 10⁶ degrees of freedom always): the
/// Cornish–Fisher expansion to ν⁻⁴ about the normal quantile (Abramowitz & Stegun 26.7.5).
/// t(0.975, 1) = 12.7062, t(0.975, 5) = 2.5706, t(0.975, 30) = 2.0423, t(0.975, ∞) = 1.9600.
/// Quantiles beyond the range of `f64` (only for p within ~1e-308 of 0 or 1) come out infinite.
pub fn student_t_quantile(p: f64, dof: usize) -> Result<f64, FitError> {
    if !(p > 0.0 && p < 1.0) || dof == 0 {
        return Err(FitError::InvalidParameter);
    }
    if p == 0.5 {
        return Ok(0.0);
    }
    // Upper-tail probability; 1 − p is exact for p ≥ 0.5 (Sterbenz).
    let (tail, sign) = if p > 0.5 { (1.0 - p, 1.0) } else { (p, -1.0) };
    let nu = dof as f64;
    let use_cornish_fisher = dof >= CORNISH_FISHER_ALWAYS_FROM_DOF
        || (dof >= CORNISH_FISHER_FROM_DOF && tail >= CORNISH_FISHER_MIN_TAIL);
    let t = if use_cornish_fisher {
        cornish_fisher_t(normal_upper_quantile(tail), nu)
    } else {
        t_upper_quantile_bisection(tail, nu)
    };
    Ok(sign * t)
}

/// P(T > t) for t ≥ 0: ½ I_x(ν/2, ½), x = ν/(ν + t²).
fn t_upper_tail(t: f64, nu: f64) -> f64 {
    let t2 = t * t;
    if !t2.is_finite() {
        return 0.0;
    }
    let denom = nu + t2;
    // x and 1 − x each computed directly, without cancellation.
    0.5 * regularized_incomplete_beta(nu / 2.0, 0.5, nu / denom, t2 / denom)
}

/// The t with P(T > t) = `tail` (0 < tail < ½), by bracketing and bisection.
pub(super) fn t_upper_quantile_bisection(tail: f64, nu: f64) -> f64 {
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    // Doubling reaches f64::MAX in ~1024 steps, then infinity, whose tail is 0: bounded.
    for _ in 0..1100 {
        if t_upper_tail(hi, nu) <= tail {
            break;
        }
        lo = hi;
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if t_upper_tail(mid, nu) > tail {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// I_x(a, b) with y = 1 − x supplied separately (Numerical Recipes §6.4).
fn regularized_incomplete_beta(a: f64, b: f64, x: f64, y: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if y.is_nan() || y <= 0.0 {
        return 1.0;
    }
    let ln_front = libm::lgamma(a + b) - libm::lgamma(a) - libm::lgamma(b)
        + a * libm::log(x)
        + b * libm::log(y);
    let front = libm::exp(ln_front);
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_continued_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_continued_fraction(b, a, y) / b
    }
}

/// The continued fraction of the incomplete beta function, by the modified Lentz method.
fn beta_continued_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    const EPS: f64 = 1e-16;
    let guard = |v: f64| if libm::fabs(v) < TINY { TINY } else { v };
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 / guard(1.0 - qab * x / qap);
    let mut h = d;
    for m in 1..=BETA_CF_MAX_ITERATIONS {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 / guard(1.0 + aa * d);
        c = guard(1.0 + aa / c);
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 / guard(1.0 + aa * d);
        c = guard(1.0 + aa / c);
        let del = d * c;
        h *= del;
        let change = libm::fabs(del - 1.0);
        // Also stops on NaN (no progress possible).
        if change < EPS || change.is_nan() {
            break;
        }
    }
    h
}

/// The z with P(Z > z) = `tail` for a standard normal Z (0 < tail < ½), by bisection on erfc.
pub(super) fn normal_upper_quantile(tail: f64) -> f64 {
    let (mut lo, mut hi) = (0.0_f64, 40.0_f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if 0.5 * libm::erfc(mid / core::f64::consts::SQRT_2) > tail {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Cornish–Fisher expansion of the t quantile about the normal quantile z (A&S 26.7.5).
pub(super) fn cornish_fisher_t(z: f64, nu: f64) -> f64 {
    let z2 = z * z;
    let g1 = z * (z2 + 1.0) / 4.0;
    let g2 = z * ((5.0 * z2 + 16.0) * z2 + 3.0) / 96.0;
    let g3 = z * (((3.0 * z2 + 19.0) * z2 + 17.0) * z2 - 15.0) / 384.0;
    let g4 = z * ((((79.0 * z2 + 776.0) * z2 + 1482.0) * z2 - 1920.0) * z2 - 945.0) / 92160.0;
    z + (g1 + (g2 + (g3 + g4 / nu) / nu) / nu) / nu
}
