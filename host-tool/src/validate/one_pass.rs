//! One run validated in the pass that reads it, for runs whose samples arrive a stretch at a
//! time and are not kept (this tool's own run CSVs, read on every core: `runs::StreamedRuns`).
//! Each manoeuvre is cut and measured as it ends, as the streaming second pass
//! ([`super::stream::RunPass`]) does; what that pass learns first — the run's gap threshold, a
//! median over the whole run — is guessed from the run's first stretch instead. At the end the
//! guess holds if it calls the same intervals gaps as the run's threshold (the threshold enters
//! the statistics only through `dt > threshold`), and then every statistic is the one measured
//! with the run's threshold, to the bit; otherwise the run is read again as a stream. Memory:
//! the current manoeuvre's samples and the rows, not the run.

use super::run::{Measured, RunFacts, RunValidation};
use super::segment::{Segment, Segmenter};
use super::stream::RunScan;
use super::{check_options, crosscheck, ManoeuvreRow, RunReport, ValidateError, ValidateOptions};
use crate::log::run_csv::RunSample;
use model_core::Rover;

/// A run's part of the report, as [`super::validate_run`] gives it: its report, its manoeuvre
/// rows and whether it has tracked positions.
pub type RunResult = (RunReport, Vec<ManoeuvreRow>, bool);

/// One run being read and validated at once.
#[derive(Debug)]
pub struct OnePass<'a> {
    name: String,
    rover: &'a Rover,
    options: &'a ValidateOptions,
    scan: RunScan,
    segmenter: Segmenter<'a>,
    /// The manoeuvres measured so far, with the guessed threshold (from the first stretch on).
    guess: Option<Guess<'a>>,
}

/// Manoeuvres measured with a guessed gap threshold.
#[derive(Debug)]
struct Guess<'a> {
    gap_threshold_s: f64,
    /// Measures only: its report is not used.
    validation: RunValidation<'a>,
    measured: Vec<(Segment, Option<Measured>)>,
}

impl<'a> OnePass<'a> {
    /// The pass over run `name`; `None` for options that [`super::validate`] refuses (it says
    /// why: the run is left to the streaming path).
    pub fn new(name: &str, rover: &'a Rover, options: &'a ValidateOptions) -> Option<Self> {
        check_options(options).ok()?;
        Some(Self {
            name: name.to_owned(),
            rover,
            options,
            scan: RunScan::default(),
            segmenter: Segmenter::new(rover, &options.segment).ok()?,
            guess: None,
        })
    }

    /// The run's next samples, in order.
    pub fn push(&mut self, samples: &[RunSample]) {
        samples.iter().for_each(|s| self.scan.push(s));
        let guess = self
            .guess
            .get_or_insert_with(|| Guess::new(&self.name, &self.scan, self.rover, self.options));
        for s in samples {
            self.segmenter
                .push(s, |seg, span| guess.manoeuvre(seg, span));
        }
    }

    /// The run's first pass ([`RunScan`]: its digest, and what a second pass needs) and, unless
    /// the guess failed (the run must then be read again, [`super::stream::RunPass`]), the
    /// run's part of the report or why it cannot be validated, as [`super::validate`] says it.
    pub fn finish(self) -> (RunScan, Option<Result<RunResult, ValidateError>>) {
        let Self {
            name,
            rover,
            options,
            scan,
            segmenter,
            guess,
        } = self;
        if let Err(source) = scan.facts().check() {
            return (scan, Some(Err(ValidateError::Run { name, source })));
        }
        let Some(mut guess) = guess else {
            // No samples: refused by the check above.
            return (scan, None);
        };
        segmenter.finish(|seg, span| guess.manoeuvre(seg, span));
        let facts = scan.facts().facts(options.segment.gap_factor);
        if !scan
            .facts()
            .same_gaps(guess.gap_threshold_s, facts.gap_threshold_s)
        {
            return (scan, None);
        }
        let mut validation = RunValidation::new(&name, &facts, rover, options);
        for (seg, mut measured) in guess.measured {
            if let Some(m) = measured.as_mut().filter(|_| !facts.has_positions) {
                m.track = None;
            }
            validation.record(&seg, measured);
        }
        // A run CSV has no frames or commands to cross-check.
        let (report, rows) = validation.finish(crosscheck::cross_check(&[], &[], rover));
        (scan, Some(Ok((report, rows, facts.has_positions))))
    }
}

impl<'a> Guess<'a> {
    /// The guess from the samples `scan` has seen (the run's first stretch).
    fn new(name: &str, scan: &RunScan, rover: &'a Rover, options: &'a ValidateOptions) -> Self {
        // Whether a manoeuvre's samples include tracked positions is known as it is measured;
        // whether the run has any, only at its end: each turn's track is measured and dropped
        // at the end if the run has none (as the run's facts would skip it).
        let gap_threshold_s = scan
            .facts()
            .facts(options.segment.gap_factor)
            .gap_threshold_s;
        let facts = RunFacts {
            samples: 0,
            duration_s: 0.0,
            has_yaw: false,
            has_pitch: false,
            has_positions: true,
            gap_threshold_s,
        };
        Self {
            gap_threshold_s,
            validation: RunValidation::new(name, &facts, rover, options),
            measured: Vec::new(),
        }
    }

    fn manoeuvre(&mut self, seg: &Segment, span: &[RunSample]) {
        let measured = self.validation.measure(seg, span);
        self.measured.push((*seg, measured));
    }
}
