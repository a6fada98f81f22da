//! Streaming ordinary least squares ([`LinearFit`]) and its result with MATLAB-style bounds.

use super::student_t::student_t_quantile;
use super::FitError;

/// Largest accepted condition number of the design matrix after scaling each column to unit norm
/// (Frobenius-norm estimate). Beyond it the coefficients would carry fewer than ~6 significant
/// digits in `f64`, and the fit is refused as [`FitError::Singular`].
pub const MAX_CONDITION: f64 = 1e10;

/// Confidence level of the seed's bounds (Tables 4.2 and 4.3).
pub const SEED_CONFIDENCE: f64 = 0.95;

/// How a fit decides that its design is (numerically) rank-deficient, and refuses it as
/// [`FitError::Singular`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RankTest {
    /// The column-scaled design's condition number exceeds this ([`MAX_CONDITION`] for
    /// [`LinearFit::coefficients`] and [`LinearFit::solve`]).
    Condition(f64),
    /// Some column's pivot |r_jj| is at most this fraction of the column's norm: the column is
    /// (nearly) a combination of the ones before it. A per-column test, for searches that try
    /// many candidate columns and only need to know whether each adds a direction.
    RelativePivot(f64),
}

/// Streaming ordinary least squares y ≈ Σ b_j x_j for N regressors (include a constant 1 among the
/// x for an intercept). N is the capacity: [`with_columns`](Self::with_columns) fits fewer
/// columns, chosen at run time, without allocation (the unused coefficients are 0).
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
    /// Columns in use, k ≤ N.
    k: usize,
}

impl<const N: usize> Default for LinearFit<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> LinearFit<N> {
    /// An empty fit of all N columns.
    pub const fn new() -> Self {
        Self {
            r: [[0.0; N]; N],
            qty: [0.0; N],
            ssr: 0.0,
            n: 0,
            y_mean: 0.0,
            y_m2: 0.0,
            k: N,
        }
    }

    /// An empty fit of the first `k` of the N columns (1 ≤ k ≤ N, else
    /// [`FitError::InvalidParameter`]); rows go in through [`add_row`](Self::add_row).
    pub const fn with_columns(k: usize) -> Result<Self, FitError> {
        if k == 0 || k > N {
            return Err(FitError::InvalidParameter);
        }
        let mut fit = Self::new();
        fit.k = k;
        Ok(fit)
    }

    /// Number of columns fitted (N unless made with [`with_columns`](Self::with_columns)).
    pub fn columns(&self) -> usize {
        self.k
    }

    /// Adds the observation (x, y) to a fit of all N columns (one with fewer takes
    /// [`add_row`](Self::add_row)). A NaN or infinite value is refused with
    /// [`FitError::NonFinite`] and leaves the fit unchanged.
    pub fn add(&mut self, x: [f64; N], y: f64) -> Result<(), FitError> {
        self.add_row(&x, y)
    }

    /// Adds the observation (x, y) with one value per column in use
    /// ([`FitError::LengthMismatch`] otherwise). A NaN or infinite value is refused with
    /// [`FitError::NonFinite`]; a refused row leaves the fit unchanged.
    #[allow(clippy::needless_range_loop)] // matrix code: i and j index several arrays at once
    pub fn add_row(&mut self, x: &[f64], y: f64) -> Result<(), FitError> {
        let k = self.k;
        if x.len() != k {
            return Err(FitError::LengthMismatch);
        }
        if !y.is_finite() || x.iter().any(|v| !v.is_finite()) {
            return Err(FitError::NonFinite);
        }
        let mut row = [0.0; N];
        row[..k].copy_from_slice(x);
        let mut rhs = y;
        for i in 0..k {
            let xi = row[i];
            if xi == 0.0 {
                continue;
            }
            // Rotate (r_ii, x_i) onto (h, 0); r_ii stays ≥ 0. The plain root, not hypot: the
            // column norms square the regressors anyway (a design whose squares overflow is
            // refused as non-finite), and hypot's scaling cost 12 % of a diagnosis.
            let rii = self.r[i][i];
            let h = libm::sqrt(rii * rii + xi * xi);
            let (c, s) = (rii / h, xi / h);
            self.r[i][i] = h;
            for j in (i + 1)..k {
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

    /// The residual sum of squares of the least-squares solution (what the rotations leave of y).
    pub fn residual_sum_of_squares(&self) -> f64 {
        self.ssr
    }

    /// The least-squares coefficients alone (needs n ≥ k; an exactly determined system is fine),
    /// refused when the condition number exceeds [`MAX_CONDITION`].
    pub fn coefficients(&self) -> Result<[f64; N], FitError> {
        self.coefficients_with(RankTest::Condition(MAX_CONDITION))
    }

    /// [`coefficients`](Self::coefficients) with another test of the design's rank.
    pub fn coefficients_with(&self, rank: RankTest) -> Result<[f64; N], FitError> {
        if self.n < self.k {
            return Err(FitError::TooFewSamples);
        }
        let norms = self.column_norms()?;
        match rank {
            RankTest::Condition(max) => {
                self.r_inverse(&norms, max)?;
            }
            RankTest::RelativePivot(min) => {
                // Written so that a NaN pivot is refused too.
                if !(0..self.k).all(|j| self.r[j][j] > min * norms[j]) {
                    return Err(FitError::Singular);
                }
            }
        }
        self.back_substitute()
    }

    /// Back substitution R b = Qᵀy (R already checked non-singular).
    #[allow(clippy::needless_range_loop)]
    fn back_substitute(&self) -> Result<[f64; N], FitError> {
        let mut b = [0.0; N];
        for i in (0..self.k).rev() {
            let mut acc = self.qty[i];
            for k in (i + 1)..self.k {
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
        self.solve_with_t(confidence, |dof| {
            student_t_quantile(0.5 + confidence / 2.0, dof)
        })
    }

    /// [`solve_with_confidence`](Self::solve_with_confidence) with the Student-t quantile of
    /// `confidence` given for the residual degrees of freedom (0.5 + confidence / 2): a caller
    /// that fits many times can keep the (iterative) quantiles it needs.
    pub fn solve_with_t(
        &self,
        confidence: f64,
        t_quantile: impl FnOnce(usize) -> Result<f64, FitError>,
    ) -> Result<LinearFitResult<N>, FitError> {
        if !(confidence > 0.0 && confidence < 1.0) {
            return Err(FitError::InvalidParameter);
        }
        let k = self.k;
        if self.n <= k {
            return Err(FitError::TooFewSamples);
        }
        let r_inv = self.r_inverse(&self.column_norms()?, MAX_CONDITION)?;
        let b = self.back_substitute()?;
        let dof = self.n - k;
        let residual_standard_error = libm::sqrt(self.ssr / dof as f64);
        let t = t_quantile(dof)?;
        let mut estimates = [Estimate::default(); N];
        for (i, est) in estimates.iter_mut().enumerate().take(k) {
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
        for (i, row) in covariance.iter_mut().enumerate().take(k) {
            for (j, c) in row.iter_mut().enumerate().take(k) {
                let dot: f64 = (0..k).map(|k| r_inv[i][k] * r_inv[j][k]).sum();
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

    /// The norms of the columns in use, after checking that none is zero or has a zero pivot.
    #[allow(clippy::needless_range_loop)]
    fn column_norms(&self) -> Result<[f64; N], FitError> {
        // Column norms of X equal those of R (Q is orthogonal).
        let mut norms = [0.0; N];
        for j in 0..self.k {
            let sq: f64 = (0..=j).map(|i| self.r[i][j] * self.r[i][j]).sum();
            norms[j] = libm::sqrt(sq);
            if !norms[j].is_finite() {
                return Err(FitError::NonFinite);
            }
            if norms[j] == 0.0 || self.r[j][j] == 0.0 {
                return Err(FitError::Singular);
            }
        }
        Ok(norms)
    }

    /// R⁻¹ of the columns in use, after checking that the condition number of the design (with
    /// column `norms`) is at most `max_condition`.
    #[allow(clippy::needless_range_loop)]
    fn r_inverse(&self, norms: &[f64; N], max_condition: f64) -> Result<[[f64; N]; N], FitError> {
        let k = self.k;
        let mut inv = [[0.0; N]; N];
        for j in 0..k {
            inv[j][j] = 1.0 / self.r[j][j];
            for i in (0..j).rev() {
                let s: f64 = ((i + 1)..=j).map(|k| self.r[i][k] * inv[k][j]).sum();
                inv[i][j] = -s / self.r[i][i];
            }
        }
        // Condition number of the column-scaled R̃ = R D⁻¹: ‖R̃‖_F ‖R̃⁻¹‖_F, with ‖R̃‖_F = √k and
        // R̃⁻¹ = D R⁻¹ (row i of R⁻¹ scaled by the norm of column i).
        let mut inv_scaled_sq = 0.0;
        for i in 0..k {
            for j in i..k {
                let v = norms[i] * inv[i][j];
                inv_scaled_sq += v * v;
            }
        }
        let condition = libm::sqrt(k as f64 * inv_scaled_sq);
        // Written so that a NaN condition is refused too.
        if condition <= max_condition {
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
    /// One per regressor, in the order of the x arrays (zero past the fit's columns).
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
        libm::sqrt(self.mean_response_variance(x))
    }

    /// Half-width of the prediction interval of a new observation at x, at the fit's
    /// confidence: t · √(s² + xᵀ Cov(b) x) = t · s · √(1 + xᵀ(XᵀX)⁻¹x).
    pub fn prediction_interval_half_width(&self, x: [f64; N]) -> f64 {
        let s = self.residual_standard_error;
        self.t_quantile * libm::sqrt(s * s + self.mean_response_variance(x))
    }

    /// xᵀ Cov(b) x, clamped at 0 against rounding.
    fn mean_response_variance(&self, x: [f64; N]) -> f64 {
        let mut v = 0.0;
        for (i, xi) in x.iter().enumerate() {
            for (j, xj) in x.iter().enumerate() {
                v += xi * self.covariance[i][j] * xj;
            }
        }
        v.max(0.0)
    }
}
