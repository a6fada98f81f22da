//! Hampel identifier (the outlier filter behind the data-loss correction, Section 5.1).

use super::{TrackingError, MAD_TO_SIGMA, MAX_HAMPEL_HALF_WINDOW};

/// Parameters of the Hampel identifier (Section 5.1 uses MATLAB's defaults: 3 and 3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HampelConfig {
    /// k: neighbours on each side of a sample in its window (window 2k + 1), at most
    /// [`MAX_HAMPEL_HALF_WINDOW`].
    pub half_window: usize,
    /// A sample is an outlier when it lies more than this many scaled MADs from its window median.
    pub n_sigmas: f64,
}

impl Default for HampelConfig {
    fn default() -> Self {
        Self {
            half_window: 3,
            n_sigmas: 3.0,
        }
    }
}

impl HampelConfig {
    pub(super) fn validate(&self) -> Result<(), TrackingError> {
        if self.half_window <= MAX_HAMPEL_HALF_WINDOW
            && self.n_sigmas.is_finite()
            && self.n_sigmas >= 0.0
        {
            Ok(())
        } else {
            Err(TrackingError::InvalidParameter)
        }
    }
}

/// What the Hampel identifier says about one sample (MATLAB's `xmedian`, `xsigma` and `j`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HampelPoint {
    /// Median of the sample's window.
    pub median: f64,
    /// 1.4826 × the median absolute deviation of the window from that median.
    pub sigma: f64,
    /// |x − median| > n_sigmas · sigma (strictly).
    pub outlier: bool,
}

/// Median of a small window, sorted in place; the mean of the two middle values for an even count
/// (MATLAB's `median`).
fn median_in_place(w: &mut [f64]) -> f64 {
    w.sort_unstable_by(f64::total_cmp);
    let n = w.len();
    match (w.get(n.wrapping_sub(1) / 2), w.get(n / 2)) {
        (Some(lo), Some(hi)) => (lo + hi) / 2.0,
        _ => f64::NAN,
    }
}

/// The Hampel identifier at sample `i` of a series of `len` values given by `value`.
pub(super) fn hampel_at(
    len: usize,
    value: impl Fn(usize) -> f64,
    i: usize,
    config: &HampelConfig,
) -> HampelPoint {
    // MATLAB semantics at the edges: the window is truncated to the samples that exist.
    let k = config.half_window.min(MAX_HAMPEL_HALF_WINDOW);
    let lo = i.saturating_sub(k);
    let hi = i.saturating_add(k).min(len.saturating_sub(1));
    let mut buf = [0.0; 2 * MAX_HAMPEL_HALF_WINDOW + 1];
    let mut count = 0;
    for (slot, j) in buf.iter_mut().zip(lo..=hi) {
        *slot = value(j);
        count += 1;
    }
    let window = &mut buf[..count];
    let median = median_in_place(window);
    for v in window.iter_mut() {
        *v = libm::fabs(*v - median);
    }
    let sigma = MAD_TO_SIGMA * median_in_place(window);
    let x = value(i);
    HampelPoint {
        median,
        sigma,
        outlier: libm::fabs(x - median) > config.n_sigmas * sigma,
    }
}

/// The Hampel identifier over a series, as MATLAB's `hampel(x, k, nsigma)` (Section 5.1): each
/// sample's window is the sample and k neighbours per side; the sample is an outlier if it differs
/// from the window median by more than `n_sigmas` × 1.4826 × MAD.
///
/// Edges follow MATLAB: near the ends the window is truncated to the samples that exist (k + 1
/// samples at the first one), and an even-sized window's median is the mean of its two middle
/// values. Unlike MATLAB, which skips NaNs, any NaN/∞ is refused (`NonFinite`). A window whose MAD
/// is 0 flags any sample that differs from the median at all. Writes one [`HampelPoint`] per
/// value into `out` and returns the number of outliers.
pub fn hampel(
    values: &[f64],
    config: &HampelConfig,
    out: &mut [HampelPoint],
) -> Result<usize, TrackingError> {
    config.validate()?;
    if out.len() < values.len() {
        return Err(TrackingError::OutputTooSmall);
    }
    if values.iter().any(|v| !v.is_finite()) {
        return Err(TrackingError::NonFinite);
    }
    let value = |j: usize| values.get(j).copied().unwrap_or(f64::NAN);
    let mut outliers = 0;
    for (i, slot) in out.iter_mut().enumerate().take(values.len()) {
        *slot = hampel_at(values.len(), value, i, config);
        outliers += usize::from(slot.outlier);
    }
    Ok(outliers)
}
