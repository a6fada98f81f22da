//! One run validated in the pass that reads it, for runs whose records are not kept (this
//! tool's own run CSVs, read on every core, a stretch of samples at a time; MCAP logs, as a
//! [`RunLogSink`]: `runs::StreamedRuns`). Each manoeuvre is cut and measured as it ends, as
//! the streaming second pass ([`super::stream::RunPass`]) does; what that pass learns first —
//! the run's gap threshold, a median over the whole run — is guessed from the run's first
//! stretch instead. At the end the guess holds if it calls the same intervals gaps as the run's
//! threshold (the threshold enters the statistics only through `dt > threshold`), and then
//! every statistic is the one measured with the run's threshold, to the bit; otherwise the run
//! is read again as a stream. The frames are cross-checked as they come, with the commands read
//! so far, both ways until the first frame that answers a command says which (acked mode); the
//! check holds if every command came before the frames it governs (as a recorder writes them),
//! else the run is read again too. Memory: the current manoeuvre's samples, a stretch of
//! samples, the commands and the rows, not the run.

use super::crosscheck::{acknowledges, CrossChecker};
use super::run::{Measured, RunFacts, RunValidation};
use super::segment::{Segment, Segmenter};
use super::stream::RunScan;
use super::{check_options, ManoeuvreRow, RunReport, ValidateError, ValidateOptions};
use crate::log::commands::CommandRow;
use crate::log::run_csv::RunSample;
use crate::log::run_log::RunLogSink;
use model_core::wire::{BoardFrame, Sample};
use model_core::Rover;
use std::io;

/// Samples handed over as a sink are held until this many, the first stretch, which gives the
/// guess of the gap threshold (a run CSV's first job, given to [`OnePass::push`], holds
/// ≈ 11 000); later ones are measured as they come.
const STRETCH: usize = 8192;

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
    /// The first stretch's samples, until it is whole.
    held: Vec<RunSample>,
    /// The frames cross-checked as if no frame answers a command (dropped at the first that
    /// does), and as if one does.
    plain: Option<CrossChecker<'a>>,
    acked: CrossChecker<'a>,
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
            held: Vec::new(),
            plain: Some(CrossChecker::new(&[], rover, false)),
            acked: CrossChecker::new(&[], rover, true),
        })
    }

    /// Samples handed over: held until the first stretch is whole (it gives the guess), then
    /// measured as they come.
    fn take(&mut self, samples: &[RunSample]) {
        if self.guess.is_some() {
            return self.push(samples);
        }
        let (first, rest) = samples.split_at(samples.len().min(STRETCH - self.held.len()));
        self.held.extend_from_slice(first);
        if self.held.len() == STRETCH {
            let held = std::mem::take(&mut self.held);
            self.push(&held);
            self.push(rest);
        }
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
    pub fn finish(mut self) -> (RunScan, Option<Result<RunResult, ValidateError>>) {
        let held = std::mem::take(&mut self.held);
        if !held.is_empty() {
            self.push(&held);
        }
        let Self {
            name,
            rover,
            options,
            scan,
            segmenter,
            guess,
            plain,
            acked,
            ..
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
        let checker = match plain {
            Some(plain) if !scan.acked_mode() => plain,
            _ => acked,
        };
        if !checker.in_order() {
            return (scan, None);
        }
        let mut validation = RunValidation::new(&name, &facts, rover, options);
        for (seg, mut measured) in guess.measured {
            if let Some(m) = measured.as_mut().filter(|_| !facts.has_positions) {
                m.track = None;
            }
            validation.record(&seg, measured);
        }
        // (A run CSV has no frames: no cross-check.)
        let (report, rows) = validation.finish(checker.finish());
        (scan, Some(Ok((report, rows, facts.has_positions))))
    }
}

impl RunLogSink for OnePass<'_> {
    fn frame(&mut self, t_s: f64, frame: &BoardFrame) -> io::Result<()> {
        self.scan.frame(t_s, frame)?;
        if acknowledges(frame) {
            self.plain = None;
        }
        if let Some(plain) = &mut self.plain {
            plain.feed(t_s, frame);
        }
        self.acked.feed(t_s, frame);
        Ok(())
    }

    fn sample(&mut self, sample: &RunSample) -> io::Result<()> {
        self.take(std::slice::from_ref(sample));
        Ok(())
    }

    fn samples(&mut self, samples: &[RunSample], frames: &[Sample]) -> io::Result<()> {
        // The frames go to the cross-check and the samples to the manoeuvres, which do not
        // look at each other: each kind in order is the order of the two.
        for (sample, frame) in samples.iter().zip(frames) {
            self.frame(sample.t_s, &BoardFrame::Sample(*frame))?;
        }
        self.take(samples);
        Ok(())
    }

    fn command(&mut self, row: &CommandRow) -> io::Result<()> {
        self.scan.command(row)?;
        if let Some(plain) = &mut self.plain {
            plain.command(row);
        }
        self.acked.command(row);
        Ok(())
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
