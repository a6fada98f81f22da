//! One dataset end to end ([`run_dataset`]): its calibration and test runs simulated and
//! sampled, validated into rows, diagnosed blind with the calibration runs passed as
//! calibration — the diagnosis sees only the samples and the rover — and scored against the
//! truth.

use super::family::{DatasetClass, DatasetSpec, CALIBRATION_RUNS};
use super::truth::{truth_of, Truth};
use crate::diagnose::calibration::Calibration;
use crate::diagnose::cv::shrink_pct;
use crate::diagnose::features::{self, TurnRow};
use crate::diagnose::{DiagnoseError, Diagnosis};
use crate::effect_id::EffectId;
use crate::log::run_csv::RunSample;
use crate::sim::world::{Timeline, WorldError};
use crate::validate::pose::without_positions;
use crate::validate::{self, RunInput, ValidateError, ValidateOptions};
use model_core::{Rover, Sides};
use serde::Serialize;
use std::time::Instant;

/// The verdict label a structure-only dataset may also get right: the baseline does not fit
/// its own calibration data.
pub const BASELINE_MISFIT: &str = "baseline-misfit";

/// Why a dataset could not be diagnosed.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// The world did not simulate the scenario.
    #[error("simulation: {0}")]
    World(#[from] WorldError),
    /// Validation failed.
    #[error("validation: {0}")]
    Validate(#[from] ValidateError),
    /// The diagnosis failed.
    #[error("diagnosis: {0}")]
    Diagnose(#[from] DiagnoseError),
}

/// A dataset's runs as the diagnosis sees them, and its truth.
#[derive(Debug, Clone)]
pub struct SimulatedDataset {
    /// Each calibration run's samples.
    pub calibration: Vec<Vec<RunSample>>,
    /// Each test run's samples.
    pub runs: Vec<Vec<RunSample>>,
    /// The ground truth (over the test runs).
    pub truth: Truth,
}

impl SimulatedDataset {
    /// The calibration runs' rows and the test runs' rows, as the bench diagnoses them
    /// ([`rows_for`]).
    pub fn rows(
        &self,
        rover: &Rover,
        tracker_offset_m: Option<f64>,
    ) -> Result<(Vec<TurnRow>, Vec<TurnRow>), ValidateError> {
        Ok((
            rows_for(rover, &self.calibration, "cal", tracker_offset_m)?,
            rows_for(rover, &self.runs, "run", tracker_offset_m)?,
        ))
    }
}

/// `timeline` sampled at `sample_hz` into run samples (what a recorder would log, without the
/// board and the pty). Each tracker fix lands on the first sample at or after it, as the
/// recorder places them.
pub fn sample_run(timeline: &Timeline, sample_hz: u64) -> Vec<RunSample> {
    let step_us = 1_000_000 / sample_hz.max(1);
    let fix_times = timeline.fix_times_us();
    let mut next_fix = 0;
    (0..=timeline.duration_us() / step_us)
        .map(|i| {
            let t_us = i * step_us;
            let load = timeline.load_at(t_us);
            // As the IMU reads them: a noise-free yaw makes every turn's slip exact, and a
            // test of slips against each other degenerate.
            let (yaw_rad, pitch_deg) = timeline.measured_pose_at(t_us);
            let mut fix = None;
            while let Some(&t_fix) = fix_times.get(next_fix).filter(|&&t| t <= t_us) {
                fix = timeline.fix_at(t_fix).or(fix);
                next_fix += 1;
            }
            RunSample {
                t_s: t_us as f64 * 1e-6,
                bus_v: Sides::new(load.left.bus_v, load.right.bus_v),
                current_a: Sides::new(load.left.current_a, load.right.current_a),
                cmd_mps: timeline.command_at(t_us),
                yaw_rad: Some(yaw_rad),
                pitch_deg: Some(pitch_deg),
                x_m: fix.map(|p| p.0),
                y_m: fix.map(|p| p.1),
            }
        })
        .collect()
}

/// Simulates the calibration and test runs of `spec` and works out its truth.
pub fn simulate(spec: &DatasetSpec) -> Result<SimulatedDataset, DatasetError> {
    let world = spec.world();
    let cal = spec.calibration_scenario();
    let cal_world = spec.calibration_world();
    let mut cal_truths = Vec::new();
    let calibration = (0..CALIBRATION_RUNS)
        .map(|k| {
            let t = cal_world.simulate(&cal, spec.seed.wrapping_add(k as u64))?;
            cal_truths.extend(t.manoeuvres().iter().cloned());
            Ok(sample_run(&t, spec.sample_hz))
        })
        .collect::<Result<Vec<_>, WorldError>>()?;
    let mut runs = Vec::new();
    let mut truths = Vec::new();
    for (k, scenario) in spec.test_scenarios().iter().enumerate() {
        let seed = spec.seed.wrapping_add((CALIBRATION_RUNS + k) as u64);
        let timeline = world.simulate(scenario, seed)?;
        runs.push(sample_run(&timeline, spec.sample_hz));
        truths.extend(timeline.manoeuvres().iter().cloned());
    }
    Ok(SimulatedDataset {
        calibration,
        runs,
        truth: truth_of(spec.effect(), &truths, &cal_truths),
    })
}

/// The diagnosis' rows of the Husky's `runs` (samples only, as from run CSVs, without their
/// pose track).
pub fn rows_of(runs: &[Vec<RunSample>]) -> Result<Vec<TurnRow>, ValidateError> {
    rows_for(&Rover::HUSKY_A200, runs, "run", None)
}

/// The diagnosis' rows of `rover`'s `runs`, named `{prefix}-{k}`. With `tracker_offset_m`
/// the runs' position fixes are used (the tracked point that far right of the centre [m]);
/// without, they are dropped first, as for runs recorded without a tracker.
pub fn rows_for(
    rover: &Rover,
    runs: &[Vec<RunSample>],
    prefix: &str,
    tracker_offset_m: Option<f64>,
) -> Result<Vec<TurnRow>, ValidateError> {
    let stripped: Vec<Vec<RunSample>>;
    let runs = if tracker_offset_m.is_some() {
        runs
    } else {
        stripped = runs.iter().map(|r| without_positions(r)).collect();
        &stripped
    };
    let names: Vec<String> = (0..runs.len()).map(|k| format!("{prefix}-{k}")).collect();
    let inputs: Vec<RunInput<'_>> = runs
        .iter()
        .zip(&names)
        .map(|(s, n)| RunInput::from_samples(n, s))
        .collect();
    let options = ValidateOptions {
        tracker_offset_m: tracker_offset_m.unwrap_or(0.0),
        ..ValidateOptions::for_rover(rover)
    };
    let report = validate::validate(rover, &inputs, &options)?;
    let slices: Vec<&[RunSample]> = runs.iter().map(Vec::as_slice).collect();
    Ok(features::rows(&report, &slices))
}

/// What the diagnosis said on one dataset, against its truth.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DatasetResult {
    /// The dataset.
    pub spec: DatasetSpec,
    /// Its truth (`None` when it could not be simulated).
    pub truth: Option<Truth>,
    /// The diagnosed effect: a catalogue id, `none`, `ambiguous`, `baseline-misfit`, or `error`.
    pub diagnosed: String,
    /// The diagnosed regime (`error` on error).
    pub diagnosed_regime: String,
    /// Whether any gap was significant.
    pub significant: bool,
    /// The significant gaps (what made a control or a missed effect `ambiguous`).
    pub significant_gaps: Vec<GapNote>,
    /// The best candidate and its held-out shrink [%].
    pub best_candidate: Option<(EffectId, f64)>,
    /// Held-out shrink of the true effect, all rows [%]: the diagnosis' `heldout` entry for
    /// all rows when it is about the true effect, else the true effect's candidate score.
    pub true_effect_shrink_pct: Option<f64>,
    /// Held-out shrink of the true effect in the true regime [%], when the diagnosis' held-out
    /// figures are about the true effect.
    pub true_regime_shrink_pct: Option<f64>,
    /// The held-out shrink a perfect model of the true effect would give, all rows [%]:
    /// [`shrink_pct`] of the diagnosis' baseline-only held-out error against that of the
    /// dataset's twin (the same world, runs and seeds without the effect, whose
    /// diagnosis chooses its own baseline). It is the shrink of removing exactly the effect; a
    /// catalogue term exceeds it only by also fitting structure the baseline misses (an I² term
    /// takes copper-like misfit) or by chance (the twin's noise differs where the effect
    /// changes a manoeuvre's length). `None` without an effect.
    pub ceiling_shrink_pct: Option<f64>,
    /// The error, if any.
    pub error: Option<String>,
    /// Whether the first verdict was open (rivals in play, [`crate::diagnose::next_runs`]).
    pub opened: bool,
    /// Each round of driving what the diagnosis suggested and diagnosing again.
    pub next_rounds: Vec<NextRound>,
    /// Simulation, sampling and validation time [s].
    pub simulate_s: f64,
    /// Diagnosis time [s].
    pub diagnose_s: f64,
}

/// One round of the closed loop: the suggestions driven as a new run in the same world.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NextRound {
    /// Manoeuvres driven (repeats counted).
    pub manoeuvres: u32,
    /// The verdict after them.
    pub diagnosed: String,
    /// Whether it is still open.
    pub open: bool,
}

impl DatasetResult {
    /// The verdict after the closed loop (the first one without rounds).
    pub fn settled_label(&self) -> &str {
        self.next_rounds
            .last()
            .map_or(&self.diagnosed, |r| &r.diagnosed)
    }

    /// Whether the verdict is still open after the loop.
    pub fn still_open(&self) -> bool {
        self.next_rounds.last().map_or(self.opened, |r| r.open)
    }

    /// Extra manoeuvres the loop drove.
    pub fn extra_manoeuvres(&self) -> u32 {
        self.next_rounds.iter().map(|r| r.manoeuvres).sum()
    }

    /// Whether `label` is the right answer for this dataset (see [`DatasetResult::right`]).
    pub fn right_label(&self, label: &str) -> bool {
        match self.spec.class {
            DatasetClass::Effect(e) => label == e.id(),
            DatasetClass::Control => label == "none",
            DatasetClass::StructureOnly => label == "none" || label == BASELINE_MISFIT,
        }
    }

    /// Whether `label` names a wrong effect: another than the true one, or any on a dataset
    /// without one.
    pub fn wrong_label(&self, label: &str) -> bool {
        EffectId::from_id(label).is_some() && !self.right_label(label)
    }

    /// The true class label (`none` for controls, `structure-only`).
    pub fn true_label(&self) -> &'static str {
        self.spec.class.label()
    }

    /// Whether the diagnosis named a catalogue effect.
    pub fn named_an_effect(&self) -> bool {
        EffectId::from_id(&self.diagnosed).is_some()
    }

    /// Whether the answer is right: the effect for effect datasets, `none` for controls,
    /// `none` or `baseline-misfit` for structure-only datasets.
    pub fn right(&self) -> bool {
        self.right_label(&self.diagnosed)
    }

    /// Whether the true effect was named.
    pub fn named_right(&self) -> bool {
        self.spec.effect().is_some() && self.right()
    }

    /// Whether the truth's peak extra power reaches the diagnosis' practical floor (no effect:
    /// false).
    pub fn detectable(&self) -> bool {
        self.spec.effect().is_some()
            && self
                .truth
                .as_ref()
                .is_some_and(|t| t.peak_extra_power_w >= crate::diagnose::stats::PRACTICAL_FLOOR_W)
    }

    /// Whether the effect shows beyond what the calibration runs absorb
    /// ([`Truth::visible_after_calibration`]); `current-offset` always (a sensor offset reads at
    /// standstill, which the diagnosis looks at directly). No effect: false.
    pub fn visible_after_calibration(&self) -> bool {
        match self.spec.effect() {
            None => false,
            Some(EffectId::CurrentOffset) => true,
            Some(_) => self
                .truth
                .as_ref()
                .is_some_and(|t| t.visible_after_calibration),
        }
    }

    /// Whether the diagnosed regime is the true one.
    pub fn regime_hit(&self) -> bool {
        self.truth
            .as_ref()
            .is_some_and(|t| self.diagnosed_regime == t.regime)
    }
}

/// A significant gap of a diagnosis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GapNote {
    /// Regime id.
    pub regime: String,
    /// `inner` or `outer`.
    pub side: String,
    /// Mean effective-power residual [W].
    pub mean_w: f64,
    /// Its 95 % bootstrap interval [W].
    pub ci_w: (f64, f64),
    /// Side observations.
    pub n: usize,
}

/// Simulates and diagnoses one dataset (without its pose track; see [`run_dataset_with`]).
pub fn run_dataset(spec: &DatasetSpec) -> DatasetResult {
    run_dataset_with(spec, false)
}

/// Simulates and diagnoses one dataset; with `poses`, the runs keep the world tracker's
/// position fixes, so `validate` measures R_ACT and the slip track and the diagnosis uses them.
pub fn run_dataset_with(spec: &DatasetSpec, poses: bool) -> DatasetResult {
    run_dataset_closing(spec, poses, 0)
}

/// [`run_dataset_with`], then up to `rounds` times while the verdict is open: the suggested
/// manoeuvres ([`next_runs`](crate::diagnose::next_runs)) driven as one more test run in the
/// same world, and the dataset diagnosed again.
pub fn run_dataset_closing(spec: &DatasetSpec, poses: bool, rounds: u32) -> DatasetResult {
    let t0 = Instant::now();
    let mut result = DatasetResult {
        spec: spec.clone(),
        truth: None,
        diagnosed: "error".into(),
        diagnosed_regime: "error".into(),
        significant: false,
        significant_gaps: Vec::new(),
        best_candidate: None,
        true_effect_shrink_pct: None,
        true_regime_shrink_pct: None,
        ceiling_shrink_pct: None,
        error: None,
        opened: false,
        next_rounds: Vec::new(),
        simulate_s: 0.0,
        diagnose_s: 0.0,
    };
    let rover = spec.rover.rover();
    let offset = poses.then(|| spec.world().tracker.offset_m);
    let mut data = None;
    let rows = simulate(spec).and_then(|d| {
        // The truth is kept even when validation fails.
        result.truth = Some(d.truth.clone());
        let rows = d.rows(&rover, offset)?;
        data = Some(d);
        Ok(rows)
    });
    result.simulate_s = t0.elapsed().as_secs_f64();
    let (cal_rows, rows) = match rows {
        Ok(rows) => rows,
        Err(e) => {
            result.error = Some(e.to_string());
            return result;
        }
    };
    let t1 = Instant::now();
    let diagnosis = diagnose_rows(&rover, &cal_rows, &rows);
    result.diagnose_s = t1.elapsed().as_secs_f64();
    if let Ok(d) = &diagnosis {
        result.ceiling_shrink_pct = ceiling_shrink_pct(spec, &rover, offset, d);
    }
    match diagnosis {
        Ok(d) => {
            score(&mut result, &d);
            result.opened = d.next.open();
            if let Some(data) = data.as_mut() {
                result.next_rounds = close_the_loop(spec, offset, data, &cal_rows, d, rounds);
            }
        }
        Err(e) => result.error = Some(DatasetError::from(e).to_string()),
    }
    result
}

/// Up to `rounds` rounds of driving `d`'s suggestions in `spec`'s world as one more test run of
/// `data` and diagnosing again, while the verdict is open and something is suggested. A round
/// that fails (the world refuses the scenario, validation or the diagnosis fails) ends the loop
/// and is recorded as `error`.
fn close_the_loop(
    spec: &DatasetSpec,
    tracker_offset_m: Option<f64>,
    data: &mut SimulatedDataset,
    cal_rows: &[TurnRow],
    mut d: Diagnosis,
    rounds: u32,
) -> Vec<NextRound> {
    let rover = spec.rover.rover();
    let world = spec.world();
    let mut out = Vec::new();
    for round in 1..=rounds {
        if !d.next.open() || d.next.runs.is_empty() {
            break;
        }
        let manoeuvres = d.next.manoeuvres();
        let seed = spec
            .seed
            .wrapping_add(NEXT_RUN_SEED_OFFSET + u64::from(round));
        let next = world
            .simulate(&d.next.scenario(), seed)
            .map_err(DatasetError::from)
            .and_then(|t| {
                data.runs.push(sample_run(&t, spec.sample_hz));
                Ok(rows_for(&rover, &data.runs, "run", tracker_offset_m)?)
            })
            .and_then(|rows| Ok(diagnose_rows(&rover, cal_rows, &rows)?));
        match next {
            Ok(again) => {
                out.push(NextRound {
                    manoeuvres,
                    diagnosed: verdict_label(&again),
                    open: again.next.open(),
                });
                d = again;
            }
            Err(_) => {
                out.push(NextRound {
                    manoeuvres,
                    diagnosed: "error".into(),
                    open: false,
                });
                break;
            }
        }
    }
    out
}

/// Seeds of the closed loop's runs: the dataset's seed plus this plus the round (clear of the
/// calibration and test runs' seeds).
const NEXT_RUN_SEED_OFFSET: u64 = 10_000;

/// [`DatasetResult::ceiling_shrink_pct`] of `spec`, whose diagnosis is `d`; `None` without an
/// effect or when the twin cannot be simulated or diagnosed.
fn ceiling_shrink_pct(
    spec: &DatasetSpec,
    rover: &Rover,
    tracker_offset_m: Option<f64>,
    d: &Diagnosis,
) -> Option<f64> {
    spec.effect()?;
    let twin = DatasetSpec {
        class: DatasetClass::StructureOnly,
        ..spec.clone()
    };
    let (cal_rows, rows) = simulate(&twin).ok()?.rows(rover, tracker_offset_m).ok()?;
    let twin_d = diagnose_rows(rover, &cal_rows, &rows).ok()?;
    let baseline_error_w = |d: &Diagnosis| d.candidates.first().map(|c| c.heldout_error_before);
    Some(shrink_pct(baseline_error_w(d)?, baseline_error_w(&twin_d)?))
}

/// The diagnosis the bench makes of a dataset's rows: calibrated on its calibration runs.
fn diagnose_rows(
    rover: &Rover,
    cal_rows: &[TurnRow],
    rows: &[TurnRow],
) -> Result<Diagnosis, DiagnoseError> {
    crate::diagnose::diagnose_with(rover, rows, Calibration::rows(cal_rows))
}

/// Simulates and diagnoses one dataset as the bench does, for reading the diagnosis whole
/// (`diagnose-bench --explain`): works for datasets `--dump` cannot hand to `diagnose` (the
/// Argo J5's currents beyond the board's range).
pub fn explain(spec: &DatasetSpec, poses: bool) -> Result<(Truth, Diagnosis), DatasetError> {
    let rover = spec.rover.rover();
    let offset = poses.then(|| spec.world().tracker.offset_m);
    let d = simulate(spec)?;
    let (cal_rows, rows) = d.rows(&rover, offset)?;
    let diagnosis = diagnose_rows(&rover, &cal_rows, &rows)?;
    Ok((d.truth, diagnosis))
}

/// The verdict as the bench's label (`none`, `ambiguous`, `baseline-misfit` or an effect id):
/// the one place that reads the diagnosis' verdict.
fn verdict_label(d: &Diagnosis) -> String {
    d.effect.label().to_owned()
}

/// Fills `result` from the diagnosis.
fn score(result: &mut DatasetResult, d: &Diagnosis) {
    result.diagnosed = verdict_label(d);
    result.diagnosed_regime = d.regime.label().to_owned();
    result.significant = d.significant;
    result.significant_gaps = d
        .gaps
        .iter()
        .filter(|g| g.significant)
        .map(|g| GapNote {
            regime: g.regime.id().into(),
            side: g.side.id().into(),
            mean_w: g.mean_w,
            ci_w: g.ci_w,
            n: g.n,
        })
        .collect();
    result.best_candidate = d.candidates.first().map(|c| (c.effect, c.shrink_pct));
    let Some(effect) = result.spec.effect() else {
        return;
    };
    let about_truth = |regime: &str| {
        d.heldout
            .iter()
            .find(|h| h.effect == effect && h.regime == regime)
            .map(|h| h.shrink_pct)
    };
    result.true_effect_shrink_pct = about_truth("all").or_else(|| {
        d.candidates
            .iter()
            .find(|c| c.effect == effect)
            .map(|c| c.shrink_pct)
    });
    result.true_regime_shrink_pct = result.truth.as_ref().and_then(|t| about_truth(&t.regime));
}

/// Timing of one diagnosis of a one-hour log (the second speed goal).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LongLogTiming {
    /// Length of the simulated test run [s].
    pub run_s: f64,
    /// Its samples.
    pub samples: usize,
    /// Manoeuvres diagnosed.
    pub manoeuvres: usize,
    /// `validate` and the diagnosis' features [s].
    pub validate_s: f64,
    /// The diagnosis [s].
    pub diagnose_s: f64,
}

/// The one-hour log to time: `spec`'s world driving its turn set until an hour has passed, as
/// one test run, diagnosed against `spec`'s calibration runs.
pub fn time_one_hour_log(spec: &DatasetSpec) -> Result<LongLogTiming, DatasetError> {
    const HOUR_S: f64 = 3600.0;
    let world = spec.world();
    let mut one = spec.clone();
    one.repeats = 1;
    let set_s = world
        .simulate(&one.test_scenarios()[0], spec.seed)?
        .duration_s();
    let mut long = spec.clone();
    // One set more than the estimate: the long run's seed draws other pauses.
    long.repeats = (HOUR_S / set_s.max(1.0)).ceil() as u32 + 1;
    let rover = spec.rover.rover();
    let calibration = spec
        .calibration_world()
        .simulate(&long.calibration_scenario(), spec.seed)?;
    let run = world.simulate(&long.test_scenarios()[0], spec.seed.wrapping_add(1))?;
    let samples = [sample_run(&run, spec.sample_hz)];
    let cal_rows = rows_for(
        &rover,
        &[sample_run(&calibration, spec.sample_hz)],
        "cal",
        None,
    )?;
    let t0 = Instant::now();
    let rows = rows_for(&rover, &samples, "run", None)?;
    let validate_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    crate::diagnose::diagnose_with(&rover, &rows, Calibration::rows(&cal_rows))?;
    Ok(LongLogTiming {
        run_s: run.duration_s(),
        samples: samples[0].len(),
        manoeuvres: rows.len(),
        validate_s,
        diagnose_s: t1.elapsed().as_secs_f64(),
    })
}
