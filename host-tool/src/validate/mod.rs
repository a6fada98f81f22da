//! `validate`: recorded runs against the seed's power models. Runs are cut into manoeuvres from
//! the commanded speeds ([`segment`]), each manoeuvre is measured ([`turns`]: duration against
//! the commanded yaw rate, angular slip Eq 6.3, power and energy per side, τ ∝ P/ω Eq 5.14,
//! power growth through the turn), the ICR model Eq 2.12 is fitted to the turns' average power
//! ([`fit`]: c₁, c₂ and c₃ with pitch, 95 % intervals, r²) and compared per manoeuvre and regime
//! with the measurement and with the hard-ground model (paper Eq 21), and the board's on-device
//! model frames are checked against the host's recomputation ([`crosscheck`]). Runs with a
//! tracked point's positions (`x_m,y_m`) also get each turn's measured radius R_ACT and the
//! run's measured slip track ([`pose`], Section 5.1 and Appendix D).
//!
//! The one entry point is [`validate`]; runs are independent (nothing is merged across runs).

pub mod crosscheck;
pub mod fit;
pub mod one_pass;
pub mod pose;
pub mod report;
pub mod run;
pub mod segment;
pub mod stream;
pub mod turns;

use crate::log::commands::CommandRow;
use crate::log::run_csv::RunSample;
use crate::log::run_log::RunLog;
use model_core::kinematics::{self, side_speeds_for, Regime, TurnDirection};
use model_core::power::IcrHardGround;
use model_core::wire::BoardFrame;
use model_core::Rover;

pub use fit::{Comparison, IcrFit, IcrFitError, DEFAULT_DEPARTURE_FRACTION};
pub use report::{ManoeuvreRow, PlotData, RegimeSummary, RunReport, ValidationReport};
pub use run::{FactsScan, RunFacts, RunValidation};
pub use segment::{ManoeuvreKind, Segment, SegmentError, SegmentOptions};
pub use turns::{ManoeuvreStats, PhaseStats, DEFAULT_SETTLE_S, DEFAULT_TURN_DEG};

/// One run to validate: its samples and, if it was recorded from the board, its wire frames and
/// forwarded commands.
#[derive(Debug, Clone, Copy)]
pub struct RunInput<'a> {
    /// A name for reports (usually the file).
    pub name: &'a str,
    /// Physical samples on the run's time base.
    pub samples: &'a [RunSample],
    /// The board's frames with their run time (empty for a run CSV).
    pub frames: &'a [(f64, BoardFrame)],
    /// Commands forwarded during the run (empty if none).
    pub commands: &'a [CommandRow],
}

impl<'a> RunInput<'a> {
    /// A run with samples only (a run CSV).
    pub fn from_samples(name: &'a str, samples: &'a [RunSample]) -> Self {
        Self {
            name,
            samples,
            frames: &[],
            commands: &[],
        }
    }

    /// A run read back from any log format.
    pub fn from_log(name: &'a str, log: &'a RunLog) -> Self {
        Self {
            name,
            samples: &log.samples,
            frames: &log.frames,
            commands: &log.commands,
        }
    }
}

/// How runs are validated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidateOptions {
    /// How runs are cut into manoeuvres (and where regimes meet).
    pub segment: SegmentOptions,
    /// Settle time cut from each manoeuvre for its steady statistics [s] (≥ 0).
    pub settle_s: f64,
    /// Heading change of a turn when the run has no yaw [deg] (> 0).
    pub turn_deg: f64,
    /// Relative departure that is flagged (together with the prediction interval) (> 0).
    pub departure_fraction: f64,
    /// The hard-ground reference model; `None` for no reference.
    pub hard_ground: Option<IcrHardGround>,
    /// Lateral offset of the tracked point (`x_m,y_m`) from the rover's centre, right
    /// positive [m] (the rover TOML's `tracker_offset_m`; the thesis' prism: 0.21).
    pub tracker_offset_m: f64,
}

impl Default for ValidateOptions {
    fn default() -> Self {
        Self {
            segment: SegmentOptions::default(),
            settle_s: DEFAULT_SETTLE_S,
            turn_deg: DEFAULT_TURN_DEG,
            departure_fraction: DEFAULT_DEPARTURE_FRACTION,
            hard_ground: None,
            tracker_offset_m: 0.0,
        }
    }
}

impl ValidateOptions {
    /// Defaults, with the seed's hard-ground parameters (paper Table 2) as the reference when the
    /// rover is the seed's Husky A200; no reference for other rovers (the seed measured μ, G and
    /// B_s for the Husky only).
    pub fn for_rover(rover: &Rover) -> Self {
        Self {
            hard_ground: (*rover == Rover::HUSKY_A200).then_some(IcrHardGround::HUSKY_HARD_GROUND),
            ..Self::default()
        }
    }
}

/// Why validation could not produce a report.
#[derive(Debug, Clone, thiserror::Error)]
pub enum ValidateError {
    /// No run was given.
    #[error("no runs to validate")]
    NoRuns,
    /// A run cannot be segmented.
    #[error("run {name}: {source}")]
    Run {
        /// The run's name.
        name: String,
        /// Why.
        #[source]
        source: SegmentError,
    },
    /// Nothing to analyse in any run.
    #[error("no manoeuvre to validate: {spans} spans in {runs} run(s), {standstill} standstill and {too_short} shorter than {min_duration_s} s")]
    NoManoeuvres {
        /// Runs given.
        runs: usize,
        /// Spans found.
        spans: usize,
        /// Of which standstill.
        standstill: usize,
        /// Of which too short.
        too_short: usize,
        /// The minimum duration [s].
        min_duration_s: f64,
    },
    /// An option is out of range.
    #[error("option {name} = {value} is out of range")]
    InvalidOption {
        /// The option.
        name: &'static str,
        /// Its value.
        value: f64,
    },
}

fn check_options(options: &ValidateOptions) -> Result<(), ValidateError> {
    let checks = [
        ("settle_s", options.settle_s, options.settle_s >= 0.0),
        (
            "turn_deg",
            options.turn_deg,
            options.turn_deg > 0.0 && options.turn_deg <= 36_000.0,
        ),
        (
            "departure_fraction",
            options.departure_fraction,
            options.departure_fraction > 0.0,
        ),
        ("tracker_offset_m", options.tracker_offset_m, true),
    ];
    for (name, value, ok) in checks {
        if !(ok && value.is_finite()) {
            return Err(ValidateError::InvalidOption { name, value });
        }
    }
    Ok(())
}

/// Validates `runs` of `rover`: segmentation, per-manoeuvre statistics, the ICR fit, departures
/// per manoeuvre and regime, the hard-ground reference and the model cross-check.
pub fn validate(
    rover: &Rover,
    runs: &[RunInput<'_>],
    options: &ValidateOptions,
) -> Result<ValidationReport, ValidateError> {
    stream::begin(runs.len(), options)?;
    let runs = runs
        .iter()
        .map(|run| validate_run(rover, run, options))
        .collect::<Result<Vec<_>, _>>()?;
    stream::finish(rover, options, runs)
}

/// One run held in memory, validated on every core: its report, its manoeuvre rows and whether
/// it has tracked positions (what [`stream::finish`] assembles). The segmentation and the
/// run's facts (the gap threshold: a median over the run) are found side by side, then the
/// manoeuvres measured in shares ([`RunValidation::manoeuvres`]).
pub fn validate_run(
    rover: &Rover,
    run: &RunInput<'_>,
    options: &ValidateOptions,
) -> Result<(RunReport, Vec<ManoeuvreRow>, bool), ValidateError> {
    let (segs, facts) = std::thread::scope(|s| {
        let facts = s.spawn(|| RunFacts::of(run.samples, options.segment.gap_factor));
        let segs = segment::segment(run.samples, rover, &options.segment);
        // A panic there is a bug: pass it on.
        (
            segs,
            facts
                .join()
                .unwrap_or_else(|e| std::panic::resume_unwind(e)),
        )
    });
    let segs = segs.map_err(|source| ValidateError::Run {
        name: run.name.to_owned(),
        source,
    })?;
    let mut validation = RunValidation::new(run.name, &facts, rover, options);
    validation.manoeuvres(&segs, run.samples);
    let (report, rows) =
        validation.finish(crosscheck::cross_check(run.frames, run.commands, rover));
    Ok((report, rows, facts.has_positions))
}

/// The report of validated runs: each run's report and manoeuvre rows (in run order) → the
/// ICR fit, departures, the hard-ground reference, regime summaries and plot data.
/// `any_positions`: whether any run has tracked positions.
pub(crate) fn assemble(
    rover: &Rover,
    options: &ValidateOptions,
    run_reports: Vec<RunReport>,
    mut rows: Vec<ManoeuvreRow>,
    any_positions: bool,
) -> Result<ValidationReport, ValidateError> {
    let r_prime = f64::from(rover.r_prime_m());
    if rows.is_empty() {
        return Err(ValidateError::NoManoeuvres {
            runs: run_reports.len(),
            spans: run_reports.iter().map(|r| r.segments).sum(),
            standstill: run_reports.iter().map(|r| r.standstill).sum(),
            too_short: run_reports.iter().map(|r| r.too_short).sum(),
            min_duration_s: options.segment.min_duration_s,
        });
    }

    // The fit: turns at or above R' (Eq 2.12's R ≥ R' case, Section 4.2) and straight lines
    // (its R → ∞ limit, which pins c2).
    let mut points = Vec::new();
    for row in rows.iter_mut() {
        let radius = match row.regime {
            Some(Regime::AtRPrime | Regime::AboveRPrime) => row.radius_cmd_m,
            Some(Regime::Straight) => Some(f64::INFINITY),
            _ => None,
        };
        if let Some(radius_m) = radius {
            if radius_m <= model_core::fit::MAX_FIT_RADIUS_M || radius_m == f64::INFINITY {
                row.in_fit = true;
                points.push(fit::FitPoint {
                    radius_m,
                    pitch_deg: row.stats.mean_pitch_deg,
                    power_w: row.stats.avg_power_w.total,
                });
            }
        }
    }
    let (icr_fit, fit_error) = match IcrFit::fit(&points, f64::from(rover.slip_track_m)) {
        Ok(f) => (Some(f), None),
        Err(e) => {
            for row in rows.iter_mut() {
                row.in_fit = false;
            }
            (None, Some(e.to_string()))
        }
    };
    for row in rows.iter_mut() {
        let measured = row.stats.avg_power_w.total;
        if let Some(f) = &icr_fit {
            let radius = row.radius_cmd_m.unwrap_or(f64::INFINITY);
            let prediction = f.predict(radius, row.stats.mean_pitch_deg);
            row.fit = Some(Comparison::new(
                measured,
                prediction,
                options.departure_fraction,
            ));
        }
        if let Some(hg) = &options.hard_ground {
            let p = hg.power_w(row.cmd_mps.left, row.cmd_mps.right);
            row.hard_ground_w = Some(p);
            row.hard_ground_residual_fraction = (p != 0.0).then(|| (measured - p) / p);
        }
    }

    let regimes = regime_summaries(&rows);
    let plot = plot_data(
        &rows,
        icr_fit.as_ref(),
        options.hard_ground.as_ref(),
        r_prime,
    );
    let bounds = options.segment.regime_bounds;
    Ok(ValidationReport {
        rover: *rover,
        settings: report::Settings {
            speed_tolerance_mps: options.segment.speed_tolerance_mps,
            min_duration_s: options.segment.min_duration_s,
            gap_factor: options.segment.gap_factor,
            settle_s: options.settle_s,
            turn_deg: options.turn_deg,
            departure_fraction: options.departure_fraction,
            r_prime_fraction: f64::from(bounds.r_prime_fraction),
            straight_from_m: f64::from(bounds.straight_from_m),
            tracker_offset_m: any_positions.then_some(options.tracker_offset_m),
        },
        runs: run_reports,
        manoeuvres: rows,
        fit: icr_fit,
        fit_error,
        hard_ground: options.hard_ground.map(report::HardGroundReference::from),
        regimes,
        plot,
    })
}

/// Appendix D per run: the measured slip track from its turns' R_ACT, then R′_ACT = B_s/2,
/// each turn's R_ACT/R′_ACT (Table 6.1's axis) and its slip angles (Eq 5.1–5.2). R′_ACT is the
/// radius driven when R′ is commanded (Eq 5.1's definition, Table D.1: B_s = 2 R_ACT there), so
/// the run's turns commanded at R′ give it when it has any; else all its turns do.
fn apply_measured_slip_track(report: &mut RunReport, rows: &mut [ManoeuvreRow], rover: &Rover) {
    let of = |at_r_prime: bool| -> Vec<f64> {
        rows.iter()
            .filter(|r| !at_r_prime || r.regime == Some(Regime::AtRPrime))
            .filter_map(|r| r.track.as_ref()?.slip_track_m)
            .collect()
    };
    let mut per_turn = of(true);
    if per_turn.is_empty() {
        per_turn = of(false);
    }
    let Some(measured) = pose::measured_slip_track(&per_turn) else {
        return;
    };
    report.slip_track_measured_m = Some(measured.slip_track_m);
    report.slip_track_measured = Some(measured);
    let r_prime_act = measured.slip_track_m / 2.0;
    for row in rows.iter_mut() {
        let Some(r_act) = row.r_act_m else { continue };
        row.r_act_over_r_prime_act = (r_prime_act > 0.0).then(|| r_act / r_prime_act);
        if let Some(track) = row.track.as_mut() {
            track.slip_angles_deg = Some(kinematics::slip_angles(
                r_act as f32,
                r_prime_act as f32,
                rover,
            ));
        }
    }
}

fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

fn regime_summaries(rows: &[ManoeuvreRow]) -> Vec<RegimeSummary> {
    Regime::ALL
        .iter()
        .filter_map(|&regime| {
            let of: Vec<&ManoeuvreRow> = rows.iter().filter(|r| r.regime == Some(regime)).collect();
            if of.is_empty() {
                return None;
            }
            let fits = || of.iter().filter_map(|r| r.fit);
            Some(RegimeSummary {
                regime: Some(regime),
                manoeuvres: of.len(),
                mean_power_w: mean(of.iter().map(|r| r.stats.avg_power_w.total)).unwrap_or(0.0),
                mean_residual_w: mean(fits().map(|c| c.residual_w)),
                mean_residual_fraction: mean(fits().filter_map(|c| c.residual_fraction)),
                max_abs_residual_fraction: fits()
                    .filter_map(|c| c.residual_fraction)
                    .map(f64::abs)
                    .reduce(f64::max),
                flagged: fits().filter(|c| c.flagged).count(),
                mean_hard_ground_residual_fraction: mean(
                    of.iter().filter_map(|r| r.hard_ground_residual_fraction),
                ),
            })
        })
        .collect()
}

/// Points of the model curves.
const CURVE_POINTS: usize = 161;

fn plot_data(
    rows: &[ManoeuvreRow],
    icr_fit: Option<&IcrFit>,
    hard_ground: Option<&IcrHardGround>,
    r_prime: f64,
) -> PlotData {
    let points: Vec<report::PlotPoint> = rows
        .iter()
        .enumerate()
        .filter_map(|(i, r)| {
            Some(report::PlotPoint {
                manoeuvre: i,
                r_over_r_prime: r.r_over_r_prime?,
                regime: r.regime,
                avg_power_w: r.stats.avg_power_w,
                max_power_w: r.stats.max_power_w.total,
                torque_proportional: r.stats.torque_proportional,
                predicted_w: r.fit.map(|c| c.predicted_w),
                residual_w: r.fit.map(|c| c.residual_w),
                flagged: r.fit.is_some_and(|c| c.flagged),
            })
        })
        .collect();
    let mut v_cs: Vec<f64> = rows
        .iter()
        .filter(|r| r.kind == ManoeuvreKind::Turn)
        .map(|r| r.v_c_mps)
        .collect();
    v_cs.sort_by(f64::total_cmp);
    let v_c = v_cs.get(v_cs.len() / 2).copied().unwrap_or(0.0);
    let max_ratio = points
        .iter()
        .map(|p| p.r_over_r_prime)
        .fold(4.0_f64, f64::max);
    let model_curve = (0..CURVE_POINTS)
        .map(|k| {
            let ratio = max_ratio * k as f64 / (CURVE_POINTS - 1) as f64;
            let radius = ratio * r_prime;
            let prediction = icr_fit.map(|f| f.predict(radius, Some(0.0)));
            let hard_ground_w = hard_ground.filter(|_| v_c > 0.0).map(|hg| {
                let s = side_speeds_for(
                    v_c as f32,
                    radius as f32,
                    r_prime as f32,
                    TurnDirection::Left,
                );
                hg.power_w(f64::from(s.left_mps), f64::from(s.right_mps))
            });
            report::CurvePoint {
                r_over_r_prime: ratio,
                fit_w: prediction.map(|p| p.power_w),
                fit_half_width_w: prediction.map(|p| p.half_width_w),
                hard_ground_w,
            }
        })
        .collect();
    PlotData {
        r_prime_m: r_prime,
        v_c_mps: v_c,
        points,
        model_curve,
    }
}

#[cfg(test)]
mod tests;
