//! The ICR power model fitted to the turns' average power (Eq 2.12, Table 4.3 form
//! P = c₁/R + c₂ + c₃θ), its 95 % prediction intervals, and where each manoeuvre's measured
//! power departs from the fitted model.
//!
//! What is fitted: turns with a commanded radius R' ≤ R ≤ 20 m (regimes at-R' and above-R'),
//! the "R ≥ R' case of Eq 2.12" the seed fits (Section 4.2), one point per turn (its steady
//! average total power and mean pitch). Radii within the R' tolerance enter as R'. Below R' the
//! model is the plateau 2c₁/B_s + c₂ + c₃θ (Eq 2.12, [`SimplifiedIcr`]), straight lines are c₂ +
//! c₃θ; both are predicted from the fitted coefficients, which is where the seed found the
//! hard-ground model failing on sand (Fig. 4.9: a 15–20 % peak for B/2 < R < R').
//!
//! Since every prediction is linear in (c₁, c₂, c₃) with regressors x₀ = (1/max(R, R'), 1, θ),
//! the ordinary least-squares prediction interval applies to all of them:
//! ŷ ± t(0.975, n − N) · s · √(1 + x₀ᵀ(XᵀX)⁻¹x₀).
//!
//! c₃ is fitted only when every fitted turn has a pitch and their mean pitches span at least
//! [`MIN_PITCH_SPREAD_DEG`]; otherwise c₃ is not identifiable and c₁, c₂ are fitted alone.

use model_core::fit::{Estimate, LinearFit, LinearFitResult, TurnPitchModel, MAX_FIT_RADIUS_M};
use model_core::power::SimplifiedIcr;
use serde::Serialize;

/// Smallest spread of the fitted turns' mean pitch that makes c₃ identifiable [deg]: below it the
/// pitch column is nearly constant and c₃ trades off against c₂.
pub const MIN_PITCH_SPREAD_DEG: f64 = 0.5;

/// Default relative departure that counts: a manoeuvre is flagged when its measured power lies
/// outside the 95 % prediction interval *and* differs from the prediction by more than this
/// fraction. The interval alone flags 5 % of perfectly modelled turns by chance; the fraction
/// alone ignores how noisy the data are. 10 % is half the seed's sand peak (Fig. 4.9).
pub const DEFAULT_DEPARTURE_FRACTION: f64 = 0.10;

/// One turn entering the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitPoint {
    /// Commanded radius [m] (R' ≤ R ≤ 20 m up to the R' tolerance, or `INFINITY` for a straight
    /// line).
    pub radius_m: f64,
    /// Mean pitch [deg], if measured.
    pub pitch_deg: Option<f64>,
    /// Steady average total power [W].
    pub power_w: f64,
}

/// A coefficient with its 95 % confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Coefficient {
    /// Least-squares value.
    pub value: f64,
    /// Standard error.
    pub standard_error: f64,
    /// Lower 95 % bound.
    pub lower: f64,
    /// Upper 95 % bound.
    pub upper: f64,
}

impl From<Estimate> for Coefficient {
    fn from(e: Estimate) -> Self {
        Self {
            value: e.value,
            standard_error: e.standard_error,
            lower: e.lower,
            upper: e.upper,
        }
    }
}

impl Coefficient {
    /// Whether `x` lies within the 95 % interval.
    pub fn contains(&self, x: f64) -> bool {
        self.lower <= x && x <= self.upper
    }

    fn estimate(&self) -> Estimate {
        Estimate {
            value: self.value,
            standard_error: self.standard_error,
            lower: self.lower,
            upper: self.upper,
        }
    }
}

/// The fitted Eq 2.12 / Table 4.3 model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IcrFit {
    /// c₁ [W·m] (Eq 2.13: μ v_c m g d_ICR).
    pub c1_w_m: Coefficient,
    /// c₂ [W] (Eq 2.14: 2 G v_c).
    pub c2_w: Coefficient,
    /// c₃ [W/deg]; `None` when not identifiable (see `c3_note`).
    pub c3_w_per_deg: Option<Coefficient>,
    /// Why c₃ was not fitted, if it was not.
    pub c3_note: Option<String>,
    /// r² (MATLAB's `rsquare`); `None` when all powers are equal.
    pub r_squared: Option<f64>,
    /// Residual standard error [W].
    pub residual_standard_error_w: f64,
    /// Turns fitted.
    pub n: usize,
    /// Residual degrees of freedom.
    pub dof: usize,
    /// t(0.975, dof) used for the intervals.
    pub t_quantile: f64,
    /// B_s of the plateau below R' (the rover's slip track) [m].
    pub slip_track_m: f64,
    /// The least-squares result over (1/max(R, R'), 1, θ), θ's column unused without c₃: the
    /// prediction intervals come from its covariance.
    #[serde(skip)]
    least_squares: LinearFitResult<3>,
}

/// A prediction of the fitted model with its 95 % prediction interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Prediction {
    /// Predicted total power [W].
    pub power_w: f64,
    /// Half-width of the 95 % prediction interval [W].
    pub half_width_w: f64,
}

/// Why no fit was made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IcrFitError {
    /// Fewer manoeuvres at or above R' than needed (3: two coefficients and a residual).
    #[error("{found} manoeuvres with R' ≤ R ≤ 20 m or straight; at least 3 are needed to fit c1 and c2 with confidence intervals")]
    TooFewTurns {
        /// Turns and straight lines available.
        found: usize,
    },
    /// All fitted turns share one radius: c₁ and c₂ cannot be told apart.
    #[error("all turns with R' ≤ R ≤ 20 m and straight lines have the same radius ({radius_m:.3} m); at least two radii are needed")]
    OneRadius {
        /// The radius.
        radius_m: f64,
    },
    /// The least-squares problem failed.
    #[error("least squares failed: {0}")]
    LeastSquares(String),
}

impl IcrFit {
    /// Fits c₁, c₂ (and c₃ when identifiable) to the turn points; `slip_track_m` is B_s of the
    /// plateau below R'.
    pub fn fit(points: &[FitPoint], slip_track_m: f64) -> Result<IcrFit, IcrFitError> {
        let r_prime = slip_track_m / 2.0;
        let points: Vec<FitPoint> = points
            .iter()
            // Straight lines (R = ∞) are Eq 2.12's limit P = c2 (+ c3 θ); the 20 m clip is the
            // seed's guard against huge instantaneous radii of free drives (Section 4.2).
            .filter(|p| p.radius_m <= MAX_FIT_RADIUS_M || p.radius_m == f64::INFINITY)
            .copied()
            .collect();
        if points.len() < 3 {
            return Err(IcrFitError::TooFewTurns {
                found: points.len(),
            });
        }
        let inv_r = |p: &FitPoint| 1.0 / p.radius_m.max(r_prime);
        let first = inv_r(&points[0]);
        if points
            .iter()
            .all(|p| (inv_r(p) - first).abs() <= 1e-9 * first)
        {
            return Err(IcrFitError::OneRadius {
                radius_m: 1.0 / first,
            });
        }
        let pitches: Option<Vec<f64>> = points.iter().map(|p| p.pitch_deg).collect();
        let c3_note = match &pitches {
            None => Some("not identifiable: not every fitted turn has a pitch".to_owned()),
            Some(p) => {
                let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                (hi - lo < MIN_PITCH_SPREAD_DEG).then(|| {
                    format!(
                        "not identifiable: the fitted turns' mean pitch spans {:.2}° (< {MIN_PITCH_SPREAD_DEG}°)",
                        hi - lo
                    )
                })
            }
        };
        let c3_note = match c3_note {
            None if points.len() < 4 => {
                Some("not identifiable: 4 turns are needed to fit c3 beside c1 and c2".to_owned())
            }
            note => note,
        };
        let ls = |e: model_core::fit::FitError| IcrFitError::LeastSquares(e.to_string());
        // c₃'s column is the third: without it the fit is of the first two.
        let columns = if c3_note.is_none() { 3 } else { 2 };
        let mut fit = LinearFit::<3>::with_columns(columns).map_err(ls)?;
        for p in &points {
            let row = [inv_r(p), 1.0, p.pitch_deg.unwrap_or(0.0)];
            fit.add_row(&row[..columns], p.power_w).map_err(ls)?;
        }
        let r = fit.solve().map_err(ls)?;
        Ok(IcrFit {
            c1_w_m: r.estimates[0].into(),
            c2_w: r.estimates[1].into(),
            c3_w_per_deg: c3_note.is_none().then(|| r.estimates[2].into()),
            c3_note,
            r_squared: r.r_squared,
            residual_standard_error_w: r.residual_standard_error,
            n: r.n,
            dof: r.dof,
            t_quantile: r.t_quantile,
            slip_track_m,
            least_squares: r,
        })
    }

    /// The fitted coefficients as model-core's Table 4.3 model (c₃ = 0 when not fitted).
    pub fn turn_pitch_model(&self) -> TurnPitchModel {
        TurnPitchModel {
            c1_w_m: self.c1_w_m.estimate(),
            c2_w: self.c2_w.estimate(),
            c3_w_per_deg: self.c3_w_per_deg.map(|c| c.estimate()).unwrap_or_default(),
            r_squared: self.r_squared,
            residual_standard_error_w: self.residual_standard_error_w,
            n: self.n,
        }
    }

    /// Eq 2.12 with the fitted coefficients ([`SimplifiedIcr::from_fit`]).
    pub fn model(&self) -> SimplifiedIcr {
        SimplifiedIcr::from_fit(&self.turn_pitch_model(), self.slip_track_m)
    }

    /// Predicted power at radius `radius_m` (`INFINITY` for straight) and pitch, with its 95 %
    /// prediction interval. Without a fitted c₃ the pitch is ignored.
    pub fn predict(&self, radius_m: f64, pitch_deg: Option<f64>) -> Prediction {
        let power_w = self.model().power_w(radius_m, pitch_deg.unwrap_or(0.0));
        let r_prime = self.slip_track_m / 2.0;
        let inv_r = if radius_m.is_infinite() {
            0.0
        } else {
            1.0 / radius_m.max(r_prime)
        };
        // Without a fitted c₃ its column is zero in the result, so the pitch drops out.
        let x0 = [inv_r, 1.0, pitch_deg.unwrap_or(0.0)];
        Prediction {
            power_w,
            half_width_w: self.least_squares.prediction_interval_half_width(x0),
        }
    }
}

/// How a manoeuvre's measured power compares with the fitted model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Comparison {
    /// Fitted model's prediction [W].
    pub predicted_w: f64,
    /// Half-width of the 95 % prediction interval [W].
    pub prediction_half_width_w: f64,
    /// Measured − predicted [W].
    pub residual_w: f64,
    /// `residual_w` relative to the prediction; `None` when the prediction is zero.
    pub residual_fraction: Option<f64>,
    /// The measurement lies outside the 95 % prediction interval.
    pub outside_prediction_interval: bool,
    /// |residual| exceeds the departure fraction of the prediction.
    pub beyond_threshold: bool,
    /// Both: the measurement departs from the model.
    pub flagged: bool,
}

impl Comparison {
    /// Compares `measured_w` with `prediction`; `departure_fraction` as in
    /// [`DEFAULT_DEPARTURE_FRACTION`].
    pub fn new(measured_w: f64, prediction: Prediction, departure_fraction: f64) -> Self {
        let residual_w = measured_w - prediction.power_w;
        let residual_fraction =
            (prediction.power_w != 0.0).then(|| residual_w / prediction.power_w.abs());
        let outside_prediction_interval = residual_w.abs() > prediction.half_width_w;
        let beyond_threshold = residual_w.abs() > departure_fraction * prediction.power_w.abs();
        Self {
            predicted_w: prediction.power_w,
            prediction_half_width_w: prediction.half_width_w,
            residual_w,
            residual_fraction,
            outside_prediction_interval,
            beyond_threshold,
            flagged: outside_prediction_interval && beyond_threshold,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_two_coefficient_data_is_recovered_with_tight_intervals() {
        let (c1, c2, bs) = (50.0, 20.0, 1.1);
        let radii = [0.55, 0.7, 0.9, 1.1, 2.0, 5.0];
        let points: Vec<FitPoint> = radii
            .iter()
            .enumerate()
            .map(|(k, &r)| FitPoint {
                radius_m: r,
                pitch_deg: None,
                // ±0.1 W alternating noise.
                power_w: c1 / r + c2 + if k % 2 == 0 { 0.1 } else { -0.1 },
            })
            .collect();
        let f = IcrFit::fit(&points, bs).expect("fits");
        assert!(f.c1_w_m.contains(c1) && f.c2_w.contains(c2), "{f:?}");
        assert!(f.c3_w_per_deg.is_none() && f.c3_note.is_some());
        assert!(f.r_squared.expect("varies") > 0.999);
        // Below R' the model is the plateau 2c₁/B_s + c₂.
        let below = f.predict(0.2, None);
        assert!(
            (below.power_w - (2.0 * c1 / bs + c2)).abs() < 0.5,
            "{below:?}"
        );
        // The interval is wider far from the data (straight line: 1/R = 0) than at its centre.
        assert!(f.predict(f64::INFINITY, None).half_width_w > f.predict(1.0, None).half_width_w);
    }

    #[test]
    fn prediction_interval_matches_the_textbook_simple_regression_formula() {
        // For y = b0 + b1 x: half-width t s √(1 + 1/n + (x0 − x̄)²/Sxx).
        let xs = [1.0, 1.5, 2.0, 2.5, 1.2];
        let ys = [70.0, 55.0, 46.0, 40.0, 62.0];
        let points: Vec<FitPoint> = xs
            .iter()
            .zip(ys)
            .map(|(&x, y)| FitPoint {
                radius_m: 1.0 / x,
                pitch_deg: None,
                power_w: y,
            })
            .collect();
        let f = IcrFit::fit(&points, 0.2).expect("fits");
        let n = xs.len() as f64;
        let xbar = xs.iter().sum::<f64>() / n;
        let sxx: f64 = xs.iter().map(|x| (x - xbar).powi(2)).sum();
        let x0 = 1.0 / 0.8;
        let want = f.t_quantile
            * f.residual_standard_error_w
            * (1.0 + 1.0 / n + (x0 - xbar).powi(2) / sxx).sqrt();
        let got = f.predict(0.8, None).half_width_w;
        assert!((got - want).abs() < 1e-9 * want, "{got} vs {want}");
    }

    #[test]
    fn pitch_makes_c3_identifiable() {
        let (c1, c2, c3) = (5.55, 139.4, 6.608);
        let mut points = Vec::new();
        for (k, r) in [0.6, 1.0, 2.0, 4.0, 8.0].into_iter().enumerate() {
            for pitch in [-8.0, -2.0, 3.0, 9.0] {
                let noise = [0.4, -0.3, 0.1, -0.2, 0.3][(k + pitch as usize % 5) % 5];
                points.push(FitPoint {
                    radius_m: r,
                    pitch_deg: Some(pitch),
                    power_w: c1 / r + c2 + c3 * pitch + noise,
                });
            }
        }
        let f = IcrFit::fit(&points, 1.1).expect("fits");
        let c3_fit = f.c3_w_per_deg.expect("identifiable");
        assert!(c3_fit.contains(c3), "{c3_fit:?}");
        assert!(f.c1_w_m.contains(c1) && f.c2_w.contains(c2), "{f:?}");
        assert!((f.predict(2.0, Some(5.0)).power_w - (c1 / 2.0 + c2 + 5.0 * c3)).abs() < 0.5);
        // Flat ground: c₃ is not identifiable, and the note says why.
        let flat: Vec<FitPoint> = points
            .iter()
            .map(|p| FitPoint {
                pitch_deg: Some(1.0),
                ..*p
            })
            .collect();
        let f = IcrFit::fit(&flat, 1.1).expect("fits");
        assert!(f.c3_w_per_deg.is_none());
        assert!(
            f.c3_note
                .as_deref()
                .is_some_and(|n| n.contains("spans 0.00")),
            "{f:?}"
        );
    }

    #[test]
    fn too_few_turns_or_radii_are_explained() {
        let p = |r: f64| FitPoint {
            radius_m: r,
            pitch_deg: None,
            power_w: 10.0 / r,
        };
        assert_eq!(
            IcrFit::fit(&[p(1.0), p(2.0)], 1.1),
            Err(IcrFitError::TooFewTurns { found: 2 })
        );
        // Beyond 20 m does not count (Section 4.2).
        assert_eq!(
            IcrFit::fit(&[p(1.0), p(2.0), p(25.0)], 1.1),
            Err(IcrFitError::TooFewTurns { found: 2 })
        );
        assert!(matches!(
            IcrFit::fit(&[p(1.0), p(1.0), p(1.0)], 1.1),
            Err(IcrFitError::OneRadius { .. })
        ));
    }

    #[test]
    fn departures_need_both_the_interval_and_the_threshold() {
        let pred = Prediction {
            power_w: 100.0,
            half_width_w: 5.0,
        };
        let c = Comparison::new(130.0, pred, 0.1);
        assert!(c.flagged && c.outside_prediction_interval && c.beyond_threshold);
        assert!((c.residual_fraction.expect("nonzero") - 0.3).abs() < 1e-12);
        // Outside a tight interval but only 6 %: not flagged.
        assert!(!Comparison::new(106.0, pred, 0.1).flagged);
        // 20 % off but inside a wide interval: not flagged.
        let wide = Prediction {
            power_w: 100.0,
            half_width_w: 30.0,
        };
        assert!(!Comparison::new(80.0, wide, 0.1).flagged);
    }
}
