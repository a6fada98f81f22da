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
//!
//! It is the workspace's one least-squares solver: the host tool's fits (validate's ICR fit with
//! its prediction intervals, diagnose's baseline and effect terms) call it too.
//! [`LinearFit::with_columns`] fits a column count chosen at run time within the capacity N, and
//! [`RankTest`] picks how a (nearly) dependent design is refused.
#![warn(missing_docs)]

mod linear;
mod seed_fits;
mod student_t;

pub use linear::*;
pub use seed_fits::*;
pub use student_t::*;

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

#[cfg(test)]
mod tests;
