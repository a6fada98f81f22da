//! Ordinary least squares for a handful of regressors, without allocation, and the seed's two
//! linear power fits: pitch and roll (Section 4.1, Eq 4.1, Tables 4.1–4.2) and turning radius and
//! pitch (Section 4.2, Table 4.3).
//!
//! The seed fits with MATLAB's `fit` and reports coefficients with 95 % confidence bounds and r².
//! [`LinearFit`] reproduces those numbers: the bounds are b ± t(0.975, n − N) · SE(b), with SE from
//! s² (XᵀX)⁻¹ and s² = SSR / (n − N), and r² = 1 − SSR / SST with SST taken about the mean of y.
//!
//! This is post-processing (host) code, so it works in `f64`; it is still `no_std` and allocation-
//! free: observations stream in one at a time and the state is O(N²).
#![warn(missing_docs)]

use crate::kinematics::{self, SideSpeeds};

/// Why a fit (or a t quantile) has no answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FitError {
    /// Fewer observations than needed: N for the coefficients, N + 1 for their uncertainty.
    TooFewSamples,
    /// An input was NaN or infinite, or a result overflowed.
    NonFinite,
    /// The regressors are linearly dependent, or so nearly that the column-scaled design's
    /// condition number exceeds [`MAX_CONDITION`].
    Singular,
    /// Input slices of different lengths.
    LengthMismatch,
    /// A parameter outside its domain (a probability not in (0, 1), zero degrees of freedom, a
    /// negative turning radius…).
    InvalidParameter,
}

impl core::fmt::Display for FitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FitError::TooFewSamples => "too few samples for the fit",
            FitError::NonFinite => "non-finite input or result",
            FitError::Singular => "singular or ill-conditioned design",
            FitError::LengthMismatch => "input slices differ in length",
            FitError::InvalidParameter => "parameter outside its domain",
        })
    }
}

/// Largest accepted condition number of the design matrix after scaling each column to unit norm
/// (Frobenius-norm estimate). Beyond it the coefficients would carry fewer than ~6 significant
/// digits in `f64`, and the fit is refused as [`FitError::Singular`].
pub const MAX_CONDITION: f64 = 1e10;

/// Confidence level of the seed's bounds (Tables 4.2 and 4.3).
pub const SEED_CONFIDENCE: f64 = 0.95;

/// Streaming ordinary least squares y ≈ Σ b_j x_j for N regressors (include a constant 1 among the
/// x for an intercept).
///
/// Each [`add`](Self::add) folds the observation into an upper-triangular R with RᵀR = XᵀX (the
/// normal equations' matrix) by Givens rotations, so the normal equations are accumulated
/// incrementally without ever forming XᵀX: the condition number is not squared, and the residual
/// sum of squares falls out as a sum of squares (never negative, exact to rounding even for a
/// perfect fit). O(N²) work per observation, O(N²) memory, no allocation.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearFit<const N: usize> {
    /// Upper-triangular R (RᵀR = XᵀX).
    r: [[f64; N]; N],
    /// Qᵀy, the rotated right-hand side.
    qty: [f64; N],
    /// Residual sum of squares of the least-squares solution.
    ssr: f64,
    n: usize,
    /// Welford's running mean and sum of squared deviations of y (SST).
    y_mean: f64,
    y_m2: f64,
}

impl<const N: usize> Default for LinearFit<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> LinearFit<N> {
    /// An empty fit.
    pub const fn new() -> Self {
        Self {
            r: [[0.0; N]; N],
            qty: [0.0; N],
            ssr: 0.0,
            n: 0,
            y_mean: 0.0,
            y_m2: 0.0,
        }
    }

    /// Adds the observation (x, y). A NaN or infinite value is refused with
    /// [`FitError::NonFinite`] and leaves the fit unchanged.
    #[allow(clippy::needless_range_loop)] // matrix code: i and j index several arrays at once
    pub fn add(&mut self, x: [f64; N], y: f64) -> Result<(), FitError> {
        if !y.is_finite() || x.iter().any(|v| !v.is_finite()) {
            return Err(FitError::NonFinite);
        }
        let mut row = x;
        let mut rhs = y;
        for i in 0..N {
            let xi = row[i];
            if xi == 0.0 {
                continue;
            }
            // Rotate (r_ii, x_i) onto (h, 0); r_ii stays ≥ 0.
            let rii = self.r[i][i];
            let h = libm::hypot(rii, xi);
            let (c, s) = (rii / h, xi / h);
            self.r[i][i] = h;
            for j in (i + 1)..N {
                let (rij, xj) = (self.r[i][j], row[j]);
                self.r[i][j] = c * rij + s * xj;
                row[j] = c * xj - s * rij;
            }
            let zi = self.qty[i];
            self.qty[i] = c * zi + s * rhs;
            rhs = c * rhs - s * zi;
        }
        // What the rotations leave of y is orthogonal to the column space: a residual component.
        self.ssr += rhs * rhs;
        self.n += 1;
        let delta = y - self.y_mean;
        self.y_mean += delta / self.n as f64;
        self.y_m2 += delta * (y - self.y_mean);
        Ok(())
    }

    /// A fit of the rows `x[k]` against `y[k]`.
    pub fn from_rows(x: &[[f64; N]], y: &[f64]) -> Result<Self, FitError> {
        if x.len() != y.len() {
            return Err(FitError::LengthMismatch);
        }
        let mut fit = Self::new();
        for (row, &yk) in x.iter().zip(y) {
            fit.add(*row, yk)?;
        }
        Ok(fit)
    }

    /// Number of observations added.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True before the first observation.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The least-squares coefficients alone (needs n ≥ N; an exactly determined system is fine).
    pub fn coefficients(&self) -> Result<[f64; N], FitError> {
        if self.n < N {
            return Err(FitError::TooFewSamples);
        }
        self.r_inverse()?;
        self.back_substitute()
    }

    /// Back substitution R b = Qᵀy (R already checked non-singular).
    #[allow(clippy::needless_range_loop)]
    fn back_substitute(&self) -> Result<[f64; N], FitError> {
        let mut b = [0.0; N];
        for i in (0..N).rev() {
            let mut acc = self.qty[i];
            for k in (i + 1)..N {
                acc -= self.r[i][k] * b[k];
            }
            b[i] = acc / self.r[i][i];
        }
        if b.iter().all(|v| v.is_finite()) {
            Ok(b)
        } else {
            Err(FitError::NonFinite)
        }
    }

    /// Coefficients with 95 % confidence bounds, r² and the residual standard error, as MATLAB's
    /// `fit` reports them (Tables 4.2, 4.3). Needs n > N (at least one residual degree of freedom).
    pub fn solve(&self) -> Result<LinearFitResult<N>, FitError> {
        self.solve_with_confidence(SEED_CONFIDENCE)
    }

    /// [`solve`](Self::solve) at another two-sided confidence level in (0, 1).
    pub fn solve_with_confidence(&self, confidence: f64) -> Result<LinearFitResult<N>, FitError> {
        if !(confidence > 0.0 && confidence < 1.0) {
            return Err(FitError::InvalidParameter);
        }
        if self.n <= N {
            return Err(FitError::TooFewSamples);
        }
        let r_inv = self.r_inverse()?;
        let b = self.back_substitute()?;
        let dof = self.n - N;
        let residual_standard_error = libm::sqrt(self.ssr / dof as f64);
        let t = student_t_quantile(0.5 + confidence / 2.0, dof)?;
        let mut estimates = [Estimate::default(); N];
        for (i, est) in estimates.iter_mut().enumerate() {
            // Cov(b) = s² (RᵀR)⁻¹ = s² R⁻¹ R⁻ᵀ: the variance of b_i is s² times the squared norm of
            // row i of R⁻¹.
            let row_norm_sq: f64 = r_inv[i].iter().map(|v| v * v).sum();
            let se = residual_standard_error * libm::sqrt(row_norm_sq);
            *est = Estimate {
                value: b[i],
                standard_error: se,
                lower: b[i] - t * se,
                upper: b[i] + t * se,
            };
        }
        // Cov(b)_ij = s² Σ_k R⁻¹_ik R⁻¹_jk.
        let mut covariance = [[0.0; N]; N];
        for (i, row) in covariance.iter_mut().enumerate() {
            for (j, c) in row.iter_mut().enumerate() {
                let dot: f64 = (0..N).map(|k| r_inv[i][k] * r_inv[j][k]).sum();
                *c = residual_standard_error * residual_standard_error * dot;
            }
        }
        let r_squared = (self.y_m2 > 0.0).then(|| 1.0 - self.ssr / self.y_m2);
        let finite = estimates
            .iter()
            .all(|e| e.standard_error.is_finite() && e.lower.is_finite() && e.upper.is_finite())
            && residual_standard_error.is_finite()
            && r_squared.is_none_or(f64::is_finite);
        if !finite {
            return Err(FitError::NonFinite);
        }
        Ok(LinearFitResult {
            estimates,
            covariance,
            r_squared,
            residual_standard_error,
            n: self.n,
            dof,
            confidence,
            t_quantile: t,
        })
    }

    /// R⁻¹, after checking that the design has full rank and an acceptable condition number.
    #[allow(clippy::needless_range_loop)]
    fn r_inverse(&self) -> Result<[[f64; N]; N], FitError> {
        // Column norms of X equal those of R (Q is orthogonal).
        let mut norms = [0.0; N];
        for j in 0..N {
            let sq: f64 = (0..=j).map(|i| self.r[i][j] * self.r[i][j]).sum();
            norms[j] = libm::sqrt(sq);
            if !norms[j].is_finite() {
                return Err(FitError::NonFinite);
            }
            if norms[j] == 0.0 || self.r[j][j] == 0.0 {
                return Err(FitError::Singular);
            }
        }
        let mut inv = [[0.0; N]; N];
        for j in 0..N {
            inv[j][j] = 1.0 / self.r[j][j];
            for i in (0..j).rev() {
                let s: f64 = ((i + 1)..=j).map(|k| self.r[i][k] * inv[k][j]).sum();
                inv[i][j] = -s / self.r[i][i];
            }
        }
        // Condition number of the column-scaled R̃ = R D⁻¹: ‖R̃‖_F ‖R̃⁻¹‖_F, with ‖R̃‖_F = √N and
        // R̃⁻¹ = D R⁻¹ (row i of R⁻¹ scaled by the norm of column i).
        let mut inv_scaled_sq = 0.0;
        for i in 0..N {
            for j in i..N {
                let v = norms[i] * inv[i][j];
                inv_scaled_sq += v * v;
            }
        }
        let condition = libm::sqrt(N as f64 * inv_scaled_sq);
        // Written so that a NaN condition is refused too.
        if condition <= MAX_CONDITION {
            Ok(inv)
        } else {
            Err(FitError::Singular)
        }
    }
}

/// One fitted coefficient with its standard error and two-sided confidence bounds.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Estimate {
    /// The least-squares value of the coefficient.
    pub value: f64,
    /// Its standard error, s √[(XᵀX)⁻¹]_jj.
    pub standard_error: f64,
    /// Lower confidence bound: value − t · SE.
    pub lower: f64,
    /// Upper confidence bound: value + t · SE.
    pub upper: f64,
}

impl Estimate {
    /// Whether `x` lies within the confidence bounds (inclusive).
    pub fn contains(&self, x: f64) -> bool {
        self.lower <= x && x <= self.upper
    }

    /// Half the width of the confidence interval (t · SE).
    pub fn half_width(&self) -> f64 {
        (self.upper - self.lower) / 2.0
    }
}

/// What [`LinearFit::solve`] returns.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearFitResult<const N: usize> {
    /// One per regressor, in the order of the x arrays.
    pub estimates: [Estimate; N],
    /// Covariance of the estimates, s² (XᵀX)⁻¹ (the variances are the squared standard errors).
    pub covariance: [[f64; N]; N],
    /// r² = 1 − SSR/SST with SST about the mean of y (MATLAB's `rsquare`). `None` when all y are
    /// equal (SST = 0).
    pub r_squared: Option<f64>,
    /// s = √(SSR / (n − N)), in the units of y.
    pub residual_standard_error: f64,
    /// Number of observations.
    pub n: usize,
    /// Residual degrees of freedom, n − N.
    pub dof: usize,
    /// Two-sided confidence level of the bounds (0.95 for [`LinearFit::solve`]).
    pub confidence: f64,
    /// The Student t quantile used for the bounds.
    pub t_quantile: f64,
}

impl<const N: usize> LinearFitResult<N> {
    /// The coefficient values.
    pub fn coefficients(&self) -> [f64; N] {
        self.estimates.map(|e| e.value)
    }

    /// The fitted value Σ b_j x_j.
    pub fn predict(&self, x: [f64; N]) -> f64 {
        self.estimates
            .iter()
            .zip(x)
            .map(|(e, xj)| e.value * xj)
            .sum()
    }

    /// Standard error of the fitted value at x (the mean response, not a new observation),
    /// √(xᵀ Cov(b) x).
    pub fn prediction_standard_error(&self, x: [f64; N]) -> f64 {
        let mut v = 0.0;
        for (i, xi) in x.iter().enumerate() {
            for (j, xj) in x.iter().enumerate() {
                v += xi * self.covariance[i][j] * xj;
            }
        }
        libm::sqrt(v.max(0.0))
    }
}

// ---------------------------------------------------------------------------------------------
// Student t distribution
// ---------------------------------------------------------------------------------------------

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
fn t_upper_quantile_bisection(tail: f64, nu: f64) -> f64 {
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
fn normal_upper_quantile(tail: f64) -> f64 {
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
fn cornish_fisher_t(z: f64, nu: f64) -> f64 {
    let z2 = z * z;
    let g1 = z * (z2 + 1.0) / 4.0;
    let g2 = z * ((5.0 * z2 + 16.0) * z2 + 3.0) / 96.0;
    let g3 = z * (((3.0 * z2 + 19.0) * z2 + 17.0) * z2 - 15.0) / 384.0;
    let g4 = z * ((((79.0 * z2 + 776.0) * z2 + 1482.0) * z2 - 1920.0) * z2 - 945.0) / 92160.0;
    z + (g1 + (g2 + (g3 + g4 / nu) / nu) / nu) / nu
}

// ---------------------------------------------------------------------------------------------
// The seed's fits
// ---------------------------------------------------------------------------------------------

/// Eq 4.1: P(θ, φ) = ξθ + ηφ + ζ, the power of a manoeuvre against the rover's pitch θ and roll φ
/// (Section 4.1; Table 4.1 gives ξ, η, ζ per turning radius, Table 4.2 their 95 % bounds and r²).
///
/// Units follow the seed: angles in degrees (ξ ≈ 22.5–27 W/deg for R ≥ 1 m), power in W. The seed
/// fits "pitch and absolute roll value", so the regressor φ is |roll|: [`add`](Self::add) takes
/// the signed IMU roll and uses its magnitude.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PitchRollFit {
    fit: LinearFit<3>,
}

impl PitchRollFit {
    /// An empty Eq 4.1 fit.
    pub const fn new() -> Self {
        Self {
            fit: LinearFit::new(),
        }
    }

    /// Adds one power sample [W] at pitch θ and roll φ [deg] (regressors θ, |φ|, 1).
    pub fn add(&mut self, pitch_deg: f64, roll_deg: f64, power_w: f64) -> Result<(), FitError> {
        self.fit
            .add([pitch_deg, libm::fabs(roll_deg), 1.0], power_w)
    }

    /// A fit of equally long series of pitch [deg], roll [deg] and power [W].
    pub fn from_samples(
        pitch_deg: &[f64],
        roll_deg: &[f64],
        power_w: &[f64],
    ) -> Result<Self, FitError> {
        if pitch_deg.len() != roll_deg.len() || pitch_deg.len() != power_w.len() {
            return Err(FitError::LengthMismatch);
        }
        let mut fit = Self::new();
        for ((&theta, &phi), &p) in pitch_deg.iter().zip(roll_deg).zip(power_w) {
            fit.add(theta, phi, p)?;
        }
        Ok(fit)
    }

    /// Number of samples added.
    pub fn len(&self) -> usize {
        self.fit.len()
    }

    /// True before the first sample.
    pub fn is_empty(&self) -> bool {
        self.fit.is_empty()
    }

    /// ξ, η, ζ with 95 % bounds and r² (Tables 4.1, 4.2).
    pub fn solve(&self) -> Result<PitchRollModel, FitError> {
        let r = self.fit.solve()?;
        let [xi, eta, zeta] = r.estimates;
        Ok(PitchRollModel {
            xi_w_per_deg: xi,
            eta_w_per_deg: eta,
            zeta_w: zeta,
            r_squared: r.r_squared,
            residual_standard_error_w: r.residual_standard_error,
            n: r.n,
        })
    }
}

/// The fitted Eq 4.1 (one row of Tables 4.1 and 4.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PitchRollModel {
    /// ξ: sensitivity to pitch [W/deg].
    pub xi_w_per_deg: Estimate,
    /// η: sensitivity to |roll| [W/deg].
    pub eta_w_per_deg: Estimate,
    /// ζ: power on level ground [W].
    pub zeta_w: Estimate,
    /// r² (Tables 4.2, 4.3); `None` when all powers are equal.
    pub r_squared: Option<f64>,
    /// Residual standard error of the power [W].
    pub residual_standard_error_w: f64,
    /// Number of samples fitted.
    pub n: usize,
}

impl PitchRollModel {
    /// Eq 4.1 evaluated: P = ξθ + η|φ| + ζ [W].
    pub fn power_w(&self, pitch_deg: f64, roll_deg: f64) -> f64 {
        self.xi_w_per_deg.value * pitch_deg
            + self.eta_w_per_deg.value * libm::fabs(roll_deg)
            + self.zeta_w.value
    }
}

/// The seed's stand-in radius for a point turn in the Table 4.3 fit (Section 4.2: "a 0 m turning
/// radius … was set to 0.001 m"), which caps 1/R at 1000 m⁻¹. Note that with Table 4.3's
/// c₁ = 5.55 W·m this makes the fitted model predict c₁/0.001 ≈ 5.5 kW at a point turn: the model
/// is not meant to be evaluated there, and point-turn samples carry great leverage on c₁.
pub const POINT_TURN_RADIUS_M: f64 = 0.001;

/// Turning radii above this are left out of the Table 4.3 fit (Section 4.2: "turning radii larger
/// than 20 m were neglected"); straight driving (R = ∞) with them.
pub const MAX_FIT_RADIUS_M: f64 = 20.0;

/// Whether a sample went into a fit or was left out by the seed's conventions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleUse {
    /// The sample went into the fit.
    Used,
    /// R > [`MAX_FIT_RADIUS_M`] (or no motion, hence no radius).
    Dropped,
}

/// Table 4.3: P = c₁/R + c₂ + c₃θ, the R ≥ R' case of Eq 2.12 on slopes (Section 4.2), fitted
/// linearly in the regressors 1/R, 1 and θ. The seed's White Sands fit: c₁ = 5.55 W·m
/// [5.269, 5.831], c₂ = 139.4 W [138.1, 140.7], c₃ = 6.608 W/deg [6.418, 6.799], r² = 0.685.
///
/// Conventions of the seed (Section 4.2): R is the instantaneous radius of Eq 2.4 (with the
/// controller's B_s = 1.1 m, see [`add_side_speeds`](Self::add_side_speeds)); radii above
/// [`MAX_FIT_RADIUS_M`] are dropped; a point turn's R = 0 becomes [`POINT_TURN_RADIUS_M`]. Any
/// radius below 0.001 m is raised to 0.001 m (our choice: the seed names only R = 0, and a smaller
/// radius can only come from noise around a point turn). Pitch θ in degrees, power in W.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TurnPitchFit {
    fit: LinearFit<3>,
}

impl TurnPitchFit {
    /// An empty Table 4.3 fit.
    pub const fn new() -> Self {
        Self {
            fit: LinearFit::new(),
        }
    }

    /// Adds one power sample [W] at turning radius R ≥ 0 [m] (`INFINITY` for straight) and pitch
    /// θ [deg]. Negative R is [`FitError::InvalidParameter`] (radii are magnitudes); NaN anywhere is
    /// [`FitError::NonFinite`].
    pub fn add(
        &mut self,
        radius_m: f64,
        pitch_deg: f64,
        power_w: f64,
    ) -> Result<SampleUse, FitError> {
        if radius_m.is_nan() || !pitch_deg.is_finite() || !power_w.is_finite() {
            return Err(FitError::NonFinite);
        }
        if radius_m < 0.0 {
            return Err(FitError::InvalidParameter);
        }
        if radius_m > MAX_FIT_RADIUS_M {
            return Ok(SampleUse::Dropped);
        }
        let r = radius_m.max(POINT_TURN_RADIUS_M);
        self.fit.add([1.0 / r, 1.0, pitch_deg], power_w)?;
        Ok(SampleUse::Used)
    }

    /// Adds a sample whose radius comes from the side speeds by Eq 2.4 with slip track
    /// `slip_track_m` (the seed used the controller's 1.1 m). Standstill has no radius and is
    /// dropped.
    pub fn add_side_speeds(
        &mut self,
        speeds: SideSpeeds,
        slip_track_m: f32,
        pitch_deg: f64,
        power_w: f64,
    ) -> Result<SampleUse, FitError> {
        match kinematics::turning_radius_m(speeds, slip_track_m) {
            Some(r) => self.add(f64::from(r), pitch_deg, power_w),
            None if pitch_deg.is_finite() && power_w.is_finite() => Ok(SampleUse::Dropped),
            None => Err(FitError::NonFinite),
        }
    }

    /// Number of samples used (dropped ones not counted).
    pub fn len(&self) -> usize {
        self.fit.len()
    }

    /// True before the first used sample.
    pub fn is_empty(&self) -> bool {
        self.fit.is_empty()
    }

    /// c₁, c₂, c₃ with 95 % bounds and r² (Table 4.3).
    pub fn solve(&self) -> Result<TurnPitchModel, FitError> {
        let r = self.fit.solve()?;
        let [c1, c2, c3] = r.estimates;
        Ok(TurnPitchModel {
            c1_w_m: c1,
            c2_w: c2,
            c3_w_per_deg: c3,
            r_squared: r.r_squared,
            residual_standard_error_w: r.residual_standard_error,
            n: r.n,
        })
    }
}

/// The fitted Table 4.3 model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurnPitchModel {
    /// c₁ [W·m].
    pub c1_w_m: Estimate,
    /// c₂ [W].
    pub c2_w: Estimate,
    /// c₃ [W/deg].
    pub c3_w_per_deg: Estimate,
    /// r² (Tables 4.2, 4.3); `None` when all powers are equal.
    pub r_squared: Option<f64>,
    /// Residual standard error of the power [W].
    pub residual_standard_error_w: f64,
    /// Number of samples fitted.
    pub n: usize,
}

impl TurnPitchModel {
    /// P = c₁/R + c₂ + c₃θ [W], with the fit's convention R < 0.001 m → 0.001 m. Meant for
    /// 0 ≤ R ≤ 20 m, the range the model was fitted on.
    pub fn power_w(&self, radius_m: f64, pitch_deg: f64) -> f64 {
        self.c1_w_m.value / radius_m.max(POINT_TURN_RADIUS_M)
            + self.c2_w.value
            + self.c3_w_per_deg.value * pitch_deg
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::Rng;
    use proptest::prelude::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn f_upper_tail_matches_tables_and_t() {
        // F(0.95; 2, 4) = 6.944272, F(0.99; 6, 8) = 6.370681 (standard F tables).
        assert!(close(
            f_upper_tail(6.944_272, 2, 4).expect("valid"),
            0.05,
            1e-6
        ));
        assert!(close(
            f_upper_tail(6.370_681, 6, 8).expect("valid"),
            0.01,
            1e-6
        ));
        // F(1, ν) is t² with ν degrees of freedom.
        let t = 2.228_139;
        let two_tail = 2.0 * (1.0 - student_t_cdf(t, 10).expect("valid"));
        assert!(close(
            f_upper_tail(t * t, 1, 10).expect("valid"),
            two_tail,
            1e-9
        ));
        assert_eq!(f_upper_tail(0.0, 3, 3), Ok(1.0));
        assert_eq!(f_upper_tail(1.0, 0, 3), Err(FitError::InvalidParameter));
    }

    /// Straight-line regression: the mean response's standard error has the textbook closed
    /// form s √(1/n + (x₀ − x̄)²/Sxx), and the covariance's diagonal is the squared SEs.
    #[test]
    fn prediction_standard_error_matches_the_straight_line_formula() {
        let xs = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0];
        let ys = [0.1, 1.9, 4.2, 5.8, 8.3, 9.7];
        let rows: Vec<[f64; 2]> = xs.iter().map(|&x| [1.0, x]).collect();
        let fit = LinearFit::<2>::from_rows(&rows, &ys)
            .expect("rows")
            .solve()
            .expect("solves");
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let sxx: f64 = xs.iter().map(|x| (x - mean) * (x - mean)).sum();
        let s = fit.residual_standard_error;
        for x0 in [-1.0, 0.0, 2.5, 7.0] {
            let want = s * libm::sqrt(1.0 / n + (x0 - mean) * (x0 - mean) / sxx);
            let got = fit.prediction_standard_error([1.0, x0]);
            assert!(
                close(got, want, 1e-12 * want.max(1.0)),
                "x0 {x0}: {got} vs {want}"
            );
        }
        for (i, e) in fit.estimates.iter().enumerate() {
            assert!(close(fit.covariance[i][i].sqrt(), e.standard_error, 1e-12));
        }
        assert!(close(fit.covariance[0][1], fit.covariance[1][0], 1e-15));
        assert!(
            fit.covariance[0][1] < 0.0,
            "intercept and slope anticorrelate for x̄ > 0"
        );
    }

    #[test]
    fn t_quantiles_match_tables() {
        // Reference values from standard t tables (6 decimals).
        let cases = [
            (0.975, 1, 12.706_205),
            (0.975, 2, 4.302_653),
            (0.975, 5, 2.570_582),
            (0.975, 10, 2.228_139),
            (0.975, 30, 2.042_272),
            (0.975, 100, 1.983_972),
            (0.995, 10, 3.169_273),
            (0.9, 3, 1.637_744),
            (0.975, 1_000_000, 1.959_966),
            (0.975, usize::MAX, 1.959_964),
        ];
        for (p, dof, want) in cases {
            let got = student_t_quantile(p, dof).expect("valid");
            println!("t({p}, {dof}) = {got:.6}");
            assert!(close(got, want, 1e-5), "t({p}, {dof}) = {got}, want {want}");
            let low = student_t_quantile(1.0 - p, dof).expect("valid");
            assert!(close(low, -got, 1e-9), "symmetry at dof {dof}");
        }
        assert_eq!(student_t_quantile(0.5, 7), Ok(0.0));
    }

    #[test]
    fn t_quantile_matches_closed_forms_for_one_and_two_dof() {
        // ν = 1 (Cauchy): tan(π(p − ½)); ν = 2: (2p − 1)/√(2p(1 − p)).
        for k in 1..200 {
            let p = k as f64 / 200.0;
            let cauchy = (core::f64::consts::PI * (p - 0.5)).tan();
            let t1 = student_t_quantile(p, 1).expect("valid");
            assert!(close(t1, cauchy, 1e-10 * cauchy.abs().max(1.0)), "p {p}");
            let two = (2.0 * p - 1.0) / (2.0 * p * (1.0 - p)).sqrt();
            let t2 = student_t_quantile(p, 2).expect("valid");
            assert!(close(t2, two, 1e-10 * two.abs().max(1.0)), "p {p}");
        }
        // Far tail: ν = 1 at p = 1 − 1e-10 → 1/(π·1e-10) to first order.
        let t = student_t_quantile(1.0 - 1e-10, 1).expect("valid");
        assert!(close(t, 1.0 / (core::f64::consts::PI * 1e-10), 1e-3 * t));
    }

    #[test]
    fn cornish_fisher_agrees_with_bisection_where_they_meet() {
        for dof in [1000usize, 1500, 5000, 50_000] {
            for tail in [0.4, 0.1, 0.025, 0.005, 1e-4, 1e-8] {
                let nu = dof as f64;
                let cf = cornish_fisher_t(normal_upper_quantile(tail), nu);
                let bis = t_upper_quantile_bisection(tail, nu);
                assert!(
                    close(cf, bis, 1e-9 * bis),
                    "dof {dof} tail {tail}: {cf} vs {bis}"
                );
            }
        }
    }

    #[test]
    fn cdf_inverts_the_quantile() {
        for dof in [1usize, 2, 3, 7, 30, 999, 1000, 20_000] {
            for p in [1e-6, 0.01, 0.2, 0.5, 0.8, 0.975, 0.999_999] {
                let t = student_t_quantile(p, dof).expect("valid");
                let back = student_t_cdf(t, dof).expect("valid");
                assert!(
                    close(back, p, 1e-9 * p.max(1e-3)),
                    "dof {dof} p {p}: {back}"
                );
            }
        }
    }

    #[test]
    fn t_quantile_rejects_bad_arguments() {
        for p in [0.0, 1.0, -0.1, 1.5, f64::NAN, f64::INFINITY] {
            assert_eq!(student_t_quantile(p, 5), Err(FitError::InvalidParameter));
        }
        assert_eq!(student_t_quantile(0.9, 0), Err(FitError::InvalidParameter));
        assert_eq!(student_t_cdf(f64::NAN, 3), Err(FitError::NonFinite));
        assert_eq!(student_t_cdf(f64::INFINITY, 3), Ok(1.0));
        assert_eq!(student_t_cdf(f64::NEG_INFINITY, 3), Ok(0.0));
    }

    #[test]
    fn exact_recovery_on_noiseless_data() {
        let truth = [2.5, -1.25, 0.75, 40.0];
        let mut fit = LinearFit::<4>::new();
        let mut rng = Rng::new(1);
        for _ in 0..50 {
            let x = [
                rng.range(-3.0, 3.0),
                rng.range(0.0, 10.0),
                rng.range(-1.0, 1.0),
                1.0,
            ];
            let y: f64 = x.iter().zip(truth).map(|(a, b)| a * b).sum();
            fit.add(x, y).expect("finite");
        }
        let r = fit.solve().expect("well posed");
        for (e, t) in r.estimates.iter().zip(truth) {
            assert!(close(e.value, t, 1e-12), "{e:?} vs {t}");
            // The bounds shrink to rounding width: SE ~ 1e-15, no longer a meaningful interval.
            assert!(e.standard_error < 1e-12, "{e:?}");
        }
        assert!(r.residual_standard_error < 1e-12);
        assert!(close(r.r_squared.expect("y varies"), 1.0, 1e-12));
        assert_eq!((r.n, r.dof), (50, 46));
        let c = fit.coefficients().expect("well posed");
        assert!(close(c[3], 40.0, 1e-12));
        assert!(close(
            r.predict([1.0, 2.0, 3.0, 1.0]),
            2.5 - 2.5 + 2.25 + 40.0,
            1e-10
        ));
    }

    #[test]
    fn exactly_determined_system_has_coefficients_but_no_bounds() {
        let fit = LinearFit::<2>::from_rows(&[[1.0, 1.0], [3.0, 1.0]], &[5.0, 9.0])
            .expect("same lengths");
        let c = fit.coefficients().expect("two points, two unknowns");
        assert!(close(c[0], 2.0, 1e-14) && close(c[1], 3.0, 1e-14));
        assert_eq!(fit.solve(), Err(FitError::TooFewSamples));
        let one = LinearFit::<2>::from_rows(&[[1.0, 1.0]], &[5.0]).expect("same lengths");
        assert_eq!(one.coefficients(), Err(FitError::TooFewSamples));
    }

    #[test]
    fn simple_regression_matches_textbook_formulas() {
        // Independent oracle: for y = b0 + b1 x, SE(b1) = s/√Sxx, SE(b0) = s √(1/n + x̄²/Sxx).
        let mut rng = Rng::new(7);
        let xs: Vec<f64> = (0..25).map(|_| rng.range(0.0, 10.0)).collect();
        let ys: Vec<f64> = xs.iter().map(|x| 1.0 + 0.5 * x + rng.normal()).collect();
        let rows: Vec<[f64; 2]> = xs.iter().map(|&x| [1.0, x]).collect();
        let r = LinearFit::from_rows(&rows, &ys)
            .expect("finite")
            .solve()
            .expect("well posed");
        let n = xs.len() as f64;
        let xbar = xs.iter().sum::<f64>() / n;
        let ybar = ys.iter().sum::<f64>() / n;
        let sxx: f64 = xs.iter().map(|x| (x - xbar).powi(2)).sum();
        let sxy: f64 = xs
            .iter()
            .zip(&ys)
            .map(|(x, y)| (x - xbar) * (y - ybar))
            .sum();
        let b1 = sxy / sxx;
        let b0 = ybar - b1 * xbar;
        let ssr: f64 = xs
            .iter()
            .zip(&ys)
            .map(|(x, y)| (y - b0 - b1 * x).powi(2))
            .sum();
        let s = (ssr / (n - 2.0)).sqrt();
        assert!(close(r.estimates[0].value, b0, 1e-12));
        assert!(close(r.estimates[1].value, b1, 1e-12));
        assert!(close(r.estimates[1].standard_error, s / sxx.sqrt(), 1e-12));
        assert!(close(
            r.estimates[0].standard_error,
            s * (1.0 / n + xbar * xbar / sxx).sqrt(),
            1e-12
        ));
        assert!(close(r.residual_standard_error, s, 1e-12));
        // t(0.975, 23) = 2.068658.
        assert!(close(r.t_quantile, 2.068_658, 1e-6));
        assert!(close(
            r.estimates[1].half_width(),
            2.068_658 * s / sxx.sqrt(),
            1e-6
        ));
    }

    #[test]
    fn r_squared_is_one_minus_ssr_over_sst() {
        let mut rng = Rng::new(3);
        let mut rows = Vec::new();
        let mut ys = Vec::new();
        for _ in 0..200 {
            let (a, b) = (rng.range(-15.0, 15.0), rng.range(0.0, 10.0));
            rows.push([a, b, 1.0]);
            ys.push(300.0 + 20.0 * a - 2.0 * b + 60.0 * rng.normal());
        }
        let r = LinearFit::from_rows(&rows, &ys)
            .expect("finite")
            .solve()
            .expect("well posed");
        let c = r.coefficients();
        let ssr: f64 = rows
            .iter()
            .zip(&ys)
            .map(|(x, y)| (y - (c[0] * x[0] + c[1] * x[1] + c[2])).powi(2))
            .sum();
        let mean = ys.iter().sum::<f64>() / ys.len() as f64;
        let sst: f64 = ys.iter().map(|y| (y - mean).powi(2)).sum();
        let r2 = r.r_squared.expect("y varies");
        assert!(
            close(r2, 1.0 - ssr / sst, 1e-12),
            "{r2} vs {}",
            1.0 - ssr / sst
        );
        assert!(close(r.residual_standard_error, (ssr / 197.0).sqrt(), 1e-9));
        assert!(r2 > 0.5 && r2 < 0.95);
    }

    /// Fraction of 95 % intervals that cover the truth over `trials` independent small fits, per
    /// coefficient; with the t quantile, and with the normal 1.96 for contrast.
    fn coverage(trials: usize, n: usize) -> ([f64; 3], [f64; 3]) {
        let truth = [1.5, -0.7, 10.0];
        let mut hits_t = [0usize; 3];
        let mut hits_z = [0usize; 3];
        for seed in 0..trials {
            let mut rng = Rng::new(1000 + seed as u64);
            let mut fit = LinearFit::<3>::new();
            for _ in 0..n {
                let x = [rng.range(-2.0, 2.0), rng.range(0.0, 5.0), 1.0];
                let y: f64 =
                    x.iter().zip(truth).map(|(a, b)| a * b).sum::<f64>() + 0.8 * rng.normal();
                fit.add(x, y).expect("finite");
            }
            let r = fit.solve().expect("well posed");
            for k in 0..3 {
                let e = r.estimates[k];
                hits_t[k] += usize::from(e.contains(truth[k]));
                hits_z[k] += usize::from((e.value - truth[k]).abs() <= 1.96 * e.standard_error);
            }
        }
        let rate = |h: [usize; 3]| h.map(|v| v as f64 / trials as f64);
        (rate(hits_t), rate(hits_z))
    }

    #[test]
    fn confidence_intervals_cover_the_truth_95_percent_of_the_time() {
        // n = 8, N = 3: 5 residual degrees of freedom, where t(0.975, 5) = 2.571 and the normal
        // 1.96 would cover only ~89 %. 4000 trials: binomial SD of the rate 0.0034.
        let (with_t, with_z) = coverage(4000, 8);
        println!("coverage with t: {with_t:?}, with z = 1.96: {with_z:?}");
        for k in 0..3 {
            assert!(
                (0.935..=0.965).contains(&with_t[k]),
                "coefficient {k}: {}",
                with_t[k]
            );
            assert!(
                with_z[k] < 0.92,
                "the test must tell t from z: {}",
                with_z[k]
            );
        }
    }

    #[test]
    fn singular_designs_are_refused() {
        // Second column twice the first.
        let rows: Vec<[f64; 3]> = (0..10).map(|i| [i as f64, 2.0 * i as f64, 1.0]).collect();
        let ys: Vec<f64> = (0..10).map(|i| i as f64).collect();
        let fit = LinearFit::from_rows(&rows, &ys).expect("finite");
        assert_eq!(fit.solve(), Err(FitError::Singular));
        assert_eq!(fit.coefficients(), Err(FitError::Singular));
        // A regressor that is always zero.
        let rows: Vec<[f64; 2]> = (0..10).map(|i| [i as f64, 0.0]).collect();
        let fit = LinearFit::from_rows(&rows, &ys).expect("finite");
        assert_eq!(fit.solve(), Err(FitError::Singular));
        // Nearly collinear: a constant column and one that varies by 1e-12 relative.
        let rows: Vec<[f64; 2]> = (0..10).map(|i| [1.0, 1.0 + 1e-12 * i as f64]).collect();
        let fit = LinearFit::from_rows(&rows, &ys).expect("finite");
        assert_eq!(fit.solve(), Err(FitError::Singular));
        // Badly scaled but independent columns are fine (the check is scale-invariant).
        let rows: Vec<[f64; 2]> = (0..10).map(|i| [1e-9 * i as f64, 1e9]).collect();
        let fit = LinearFit::from_rows(&rows, &ys).expect("finite");
        let c = fit.coefficients().expect("independent");
        assert!(close(c[0], 1e9, 1e-3) && close(c[1], 0.0, 1e-15));
    }

    #[test]
    fn non_finite_and_mismatched_input_is_refused() {
        let mut fit = LinearFit::<2>::new();
        fit.add([1.0, 1.0], 2.0).expect("finite");
        let before = fit.clone();
        assert_eq!(fit.add([f64::NAN, 1.0], 2.0), Err(FitError::NonFinite));
        assert_eq!(fit.add([1.0, 1.0], f64::INFINITY), Err(FitError::NonFinite));
        assert_eq!(fit, before);
        assert_eq!(
            LinearFit::<2>::from_rows(&[[1.0, 1.0]], &[1.0, 2.0]),
            Err(FitError::LengthMismatch)
        );
        assert_eq!(
            fit.solve_with_confidence(1.0),
            Err(FitError::InvalidParameter)
        );
        // Values whose squares overflow: no panic, an error.
        let mut big = LinearFit::<1>::new();
        big.add([1.0], 1e200).expect("finite");
        big.add([1.0], -1e200).expect("finite");
        assert_eq!(big.solve(), Err(FitError::NonFinite));
    }

    #[test]
    fn table_4_1_two_metre_row_is_recovered() {
        // P = 22.54θ − 0.07985|φ| + 338.1 (Table 4.1, R = 2 m; Table 4.2 bounds
        // ξ [21.69, 23.38], η [−1.26, 1.1], ζ [331.7, 344.5], r² 0.7069). Pitch within ±15°
        // (Section 4.1), noise chosen to give r² ≈ 0.7.
        let (xi, eta, zeta) = (22.54, -0.07985, 338.1);
        let mut rng = Rng::new(42);
        let mut fit = PitchRollFit::new();
        for _ in 0..2000 {
            let pitch = rng.range(-15.0, 15.0);
            let roll = rng.range(-10.0, 10.0);
            let p = xi * pitch + eta * roll.abs() + zeta + 130.0 * rng.normal();
            fit.add(pitch, roll, p).expect("finite");
        }
        let m = fit.solve().expect("well posed");
        println!("{m:?}");
        assert!(m.xi_w_per_deg.contains(xi), "{:?}", m.xi_w_per_deg);
        assert!(m.eta_w_per_deg.contains(eta), "{:?}", m.eta_w_per_deg);
        assert!(m.zeta_w.contains(zeta), "{:?}", m.zeta_w);
        // The estimates also fall within the seed's published bounds (Table 4.2).
        assert!((21.69..=23.38).contains(&m.xi_w_per_deg.value));
        assert!((-1.26..=1.1).contains(&m.eta_w_per_deg.value));
        assert!((331.7..=344.5).contains(&m.zeta_w.value));
        let r2 = m.r_squared.expect("y varies");
        assert!((0.65..0.76).contains(&r2), "r² {r2}");
        assert_eq!(m.n, 2000);
        assert!(close(m.power_w(10.0, -2.0), m.power_w(10.0, 2.0), 1e-12));
    }

    #[test]
    fn table_4_3_coefficients_are_recovered() {
        // P = 5.55/R + 139.4 + 6.608θ (Table 4.3) from random drives: radii from point turns to
        // beyond 20 m (dropped), pitch within ±15°.
        let (c1, c2, c3) = (5.55, 139.4, 6.608);
        let mut rng = Rng::new(2019);
        let mut fit = TurnPitchFit::new();
        let mut dropped = 0;
        for k in 0..6000 {
            let r = match k % 10 {
                0 => 0.0,
                1 => f64::INFINITY,
                2 => rng.range(20.0, 60.0),
                _ => rng.range(0.2, 20.0),
            };
            let pitch = rng.range(-15.0, 15.0);
            let p = c1 / r.max(POINT_TURN_RADIUS_M) + c2 + c3 * pitch + 40.0 * rng.normal();
            if fit.add(r, pitch, p).expect("valid") == SampleUse::Dropped {
                dropped += 1;
            }
        }
        assert_eq!(dropped, 1200);
        let m = fit.solve().expect("well posed");
        println!("{m:?}");
        assert!(m.c1_w_m.contains(c1), "{:?}", m.c1_w_m);
        assert!(m.c2_w.contains(c2), "{:?}", m.c2_w);
        assert!(m.c3_w_per_deg.contains(c3), "{:?}", m.c3_w_per_deg);
        assert!((5.269..=5.831).contains(&m.c1_w_m.value));
        assert!((138.1..=140.7).contains(&m.c2_w.value));
        assert!((6.418..=6.799).contains(&m.c3_w_per_deg.value));
        assert_eq!(m.n, 4800);
        assert!(close(m.power_w(0.0, 0.0), m.power_w(0.001, 0.0), 1e-12));
    }

    #[test]
    fn turn_pitch_conventions() {
        let mut fit = TurnPitchFit::new();
        assert_eq!(fit.add(20.0, 0.0, 1.0), Ok(SampleUse::Used));
        assert_eq!(fit.add(20.000_001, 0.0, 1.0), Ok(SampleUse::Dropped));
        assert_eq!(fit.add(f64::INFINITY, 0.0, 1.0), Ok(SampleUse::Dropped));
        assert_eq!(fit.add(-1.0, 0.0, 1.0), Err(FitError::InvalidParameter));
        assert_eq!(fit.add(f64::NAN, 0.0, 1.0), Err(FitError::NonFinite));
        assert_eq!(fit.add(30.0, f64::NAN, 1.0), Err(FitError::NonFinite));
        assert_eq!(fit.len(), 1);
        // Eq 2.4 with the controller's B_s = 1.1 m: point turn, straight line, standstill.
        let b_s = 1.1;
        let point = SideSpeeds::new(-0.3, 0.3);
        let straight = SideSpeeds::new(0.3, 0.3);
        let still = SideSpeeds::new(0.0, 0.0);
        let r_prime = SideSpeeds::new(0.0, 0.6);
        assert_eq!(
            fit.add_side_speeds(point, b_s, 0.0, 1.0),
            Ok(SampleUse::Used)
        );
        assert_eq!(
            fit.add_side_speeds(straight, b_s, 0.0, 1.0),
            Ok(SampleUse::Dropped)
        );
        assert_eq!(
            fit.add_side_speeds(still, b_s, 0.0, 1.0),
            Ok(SampleUse::Dropped)
        );
        assert_eq!(
            fit.add_side_speeds(still, b_s, f64::NAN, 1.0),
            Err(FitError::NonFinite)
        );
        assert_eq!(
            fit.add_side_speeds(r_prime, b_s, 1.0, 2.0),
            Ok(SampleUse::Used)
        );
        assert_eq!(fit.len(), 3);
        // The point turn entered as R = 0.001 m: the same state as adding 0.001 directly.
        let mut direct = TurnPitchFit::new();
        direct.add(20.0, 0.0, 1.0).expect("valid");
        direct.add(0.001, 0.0, 1.0).expect("valid");
        direct.add(0.55, 1.0, 2.0).expect("valid");
        let (a, b) = (fit.fit.coefficients(), direct.fit.coefficients());
        assert_eq!(a.is_ok(), b.is_ok());
        if let (Ok(a), Ok(b)) = (a, b) {
            for (x, y) in a.iter().zip(b) {
                assert!(close(*x, y, 1e-6 * y.abs().max(1.0)), "{a:?} vs {b:?}");
            }
        }
    }

    fn any_f64() -> impl Strategy<Value = f64> {
        prop_oneof![
            4 => -1e3..1e3f64,
            1 => any::<f64>(),
            1 => Just(f64::NAN),
            1 => Just(0.0),
        ]
    }

    proptest! {
        #[test]
        fn fits_never_panic(rows in proptest::collection::vec((any_f64(), any_f64(), any_f64()), 0..30)) {
            let mut fit = LinearFit::<3>::new();
            let mut pr = PitchRollFit::new();
            let mut tp = TurnPitchFit::new();
            for &(a, b, y) in &rows {
                let _ = fit.add([a, b, 1.0], y);
                let _ = pr.add(a, b, y);
                let _ = tp.add(a, b, y);
                let _ = tp.add_side_speeds(SideSpeeds::new(a as f32, b as f32), 1.1, a, y);
            }
            if let Ok(r) = fit.solve() {
                for e in r.estimates {
                    prop_assert!(e.lower <= e.value && e.value <= e.upper);
                }
                prop_assert!(r.residual_standard_error >= 0.0);
            }
            let _ = fit.coefficients();
            let _ = pr.solve();
            let _ = tp.solve();
        }

        #[test]
        fn t_quantile_never_panics_and_is_monotone(p in any_f64(), dof in 0usize..5000) {
            if let Ok(t) = student_t_quantile(p, dof) {
                prop_assert!(!t.is_nan());
                if p < 0.999 {
                    let next = student_t_quantile(p + 0.001, dof);
                    prop_assert!(next.is_ok_and(|u| u > t));
                }
            }
            let _ = student_t_cdf(p, dof);
        }
    }
}
