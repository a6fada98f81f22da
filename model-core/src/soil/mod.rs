//! Wheel–soil interaction on loose sand: slip (Eq 1.22–1.23), static and slip sinkage
//! (Eq 1.24–1.30), the seed's 2D slip-sinkage model (Section 5.3.1, Eq 5.15–5.28), sand
//! bulldozing (Ishigami, Eq 1.31–1.35; the simplified Skonieczny model of Section 5.4,
//! Eq 5.29–5.39) and the GRC-1 cone-penetrometer relations (Section 3.4, Eq 3.1–3.2).
//!
//! Unlike the board-side modules these use `f64`: they run in the host's simulator, once per
//! sample. Everything is allocation-free and panic-free: parameters are validated when a model is
//! built, per-sample inputs on every call, and anything invalid comes back as a [`SoilError`]
//! with the model state left as it was.
//!
//! Sign conventions. Speeds enter the 2D model and the bulldozing model as magnitudes (their
//! absolute value is used) and the slip angle β only through |cos β| and |sin β|, so a wheel
//! turning backwards, β and −β, and β and 180° − β all give the same result. The published model
//! does not distinguish them either; the seed notes (Section 5.3.2) that it misses the extra
//! sinkage of a wheel turning against its motion (β > 90°).

mod bulldozing;
mod cone;
mod sinkage;
mod slip;
mod slip_sinkage_2d;

pub use bulldozing::*;
pub use cone::*;
pub use sinkage::*;
pub use slip::*;
pub use slip_sinkage_2d::*;

/// Why a soil model refused a parameter or an input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SoilError {
    /// A model parameter is not finite or lies outside its domain (named).
    InvalidParameter(&'static str),
    /// A per-call input is not finite or lies outside its domain (named).
    InvalidInput(&'static str),
    /// Eq 3.1 needs at least two samples at different depths.
    DegenerateData,
    /// The equation has no solution in its domain (a Bekker load that would sink the wheel past
    /// its axle, Eq 1.24).
    NoSolution,
    /// Finite inputs whose result is not finite (overflow); nothing was updated.
    Overflow,
}

impl core::fmt::Display for SoilError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SoilError::InvalidParameter(name) => write!(f, "invalid parameter {name}"),
            SoilError::InvalidInput(name) => write!(f, "invalid input {name}"),
            SoilError::DegenerateData => f.write_str("need two samples at different depths"),
            SoilError::NoSolution => f.write_str("no solution in the equation's domain"),
            SoilError::Overflow => f.write_str("result is not finite"),
        }
    }
}

fn check(ok: bool, error: SoilError) -> Result<(), SoilError> {
    if ok {
        Ok(())
    } else {
        Err(error)
    }
}

/// Parameter `x` must be finite and satisfy `domain`.
fn param(x: f64, name: &'static str, domain: impl Fn(f64) -> bool) -> Result<f64, SoilError> {
    check(
        x.is_finite() && domain(x),
        SoilError::InvalidParameter(name),
    )
    .map(|()| x)
}

/// Input `x` must be finite and satisfy `domain`.
fn input(x: f64, name: &'static str, domain: impl Fn(f64) -> bool) -> Result<f64, SoilError> {
    check(x.is_finite() && domain(x), SoilError::InvalidInput(name)).map(|()| x)
}

fn unbounded(_: f64) -> bool {
    true
}

fn finite_result(x: f64) -> Result<f64, SoilError> {
    check(x.is_finite(), SoilError::Overflow).map(|()| x)
}

#[cfg(test)]
mod tests;
