//! [`validate`](super::validate) over runs read as streams, in memory bounded whatever the
//! runs' length: each run is read twice. The first pass ([`RunScan`]) gathers what the
//! manoeuvres need before the first of them (the gap threshold is the whole run's median
//! interval; acked mode needs every frame) and the commands; the second ([`RunPass`]) cuts the
//! run into manoeuvres as it goes, measures each and forgets its samples, and replays the
//! frames through the cross-check. Memory: one manoeuvre's samples, the commands, the distinct
//! sample intervals and the report. The report is the in-memory path's, to the bit.

use super::crosscheck::{acknowledges, CrossChecker};
use super::run::{FactsScan, RunValidation};
use super::segment::Segmenter;
use super::ValidationReport;
use super::{assemble, check_options, ManoeuvreRow, RunReport, ValidateError, ValidateOptions};
use crate::log::commands::CommandRow;
use crate::log::load::RunDigest;
use crate::log::run_csv::RunSample;
use crate::log::run_log::RunLogSink;
use model_core::wire::BoardFrame;
use model_core::Rover;
use std::io;

/// The first pass over a run: what validating it needs before its first manoeuvre, and its
/// content digest (duplicate runs are refused by it).
#[derive(Debug, Default)]
pub struct RunScan {
    facts: FactsScan,
    commands: Vec<CommandRow>,
    acked_mode: bool,
    digest: RunDigest,
}

impl RunScan {
    /// Samples read.
    pub fn samples(&self) -> usize {
        self.facts.samples()
    }

    /// The digest of the run's samples.
    pub fn digest(&self) -> &RunDigest {
        &self.digest
    }

    /// The run's next sample.
    pub fn push(&mut self, sample: &RunSample) {
        self.facts.push(sample);
        self.digest.push(sample);
    }

    /// What is known of the samples pushed ([`FactsScan`]).
    pub fn facts(&self) -> &FactsScan {
        &self.facts
    }

    /// Whether any frame answered a forwarded command (the run's cross-check is in acked mode).
    pub fn acked_mode(&self) -> bool {
        self.acked_mode
    }
}

impl RunLogSink for RunScan {
    fn frame(&mut self, _t_s: f64, frame: &BoardFrame) -> io::Result<()> {
        self.acked_mode |= acknowledges(frame);
        Ok(())
    }

    fn sample(&mut self, sample: &RunSample) -> io::Result<()> {
        self.push(sample);
        Ok(())
    }

    fn command(&mut self, row: &CommandRow) -> io::Result<()> {
        self.commands.push(*row);
        Ok(())
    }
}

/// Checks what [`validate`](super::validate) checks before any run: there are runs, the
/// options are in range.
pub fn begin(runs: usize, options: &ValidateOptions) -> Result<(), ValidateError> {
    if runs == 0 {
        return Err(ValidateError::NoRuns);
    }
    check_options(options)
}

/// The second pass over a run scanned by [`RunScan`]: hand it the same records again.
#[derive(Debug)]
pub struct RunPass<'a> {
    segmenter: Segmenter<'a>,
    validation: RunValidation<'a>,
    checker: CrossChecker<'a>,
    has_positions: bool,
    samples: usize,
}

impl<'a> RunPass<'a> {
    /// The second pass of the run `name`; refuses a run that cannot be segmented, as
    /// [`validate`](super::validate) does.
    pub fn new(
        name: &str,
        scan: &'a RunScan,
        rover: &'a Rover,
        options: &'a ValidateOptions,
    ) -> Result<Self, ValidateError> {
        let refused = |source| ValidateError::Run {
            name: name.to_owned(),
            source,
        };
        let segmenter = Segmenter::new(rover, &options.segment).map_err(refused)?;
        scan.facts.check().map_err(refused)?;
        let facts = scan.facts.facts(options.segment.gap_factor);
        Ok(Self {
            segmenter,
            validation: RunValidation::new(name, &facts, rover, options),
            checker: CrossChecker::new(&scan.commands, rover, scan.acked_mode),
            has_positions: facts.has_positions,
            samples: 0,
        })
    }

    /// Samples read in this pass (the first pass's count, unless the file changed between).
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// The run's report and manoeuvre rows, and whether it has tracked positions.
    pub fn finish(self) -> (RunReport, Vec<ManoeuvreRow>, bool) {
        let Self {
            segmenter,
            mut validation,
            checker,
            has_positions,
            ..
        } = self;
        segmenter.finish(|seg, span| validation.manoeuvre(seg, span));
        let (report, rows) = validation.finish(checker.finish());
        (report, rows, has_positions)
    }
}

impl RunLogSink for RunPass<'_> {
    fn frame(&mut self, t_s: f64, frame: &BoardFrame) -> io::Result<()> {
        self.checker.feed(t_s, frame);
        Ok(())
    }

    fn sample(&mut self, sample: &RunSample) -> io::Result<()> {
        self.samples += 1;
        let Self {
            segmenter,
            validation,
            ..
        } = self;
        segmenter.push(sample, |seg, span| validation.manoeuvre(seg, span));
        Ok(())
    }
}

/// The report of runs validated by [`RunPass`]es (in run order), as
/// [`validate`](super::validate) ends.
pub fn finish(
    rover: &Rover,
    options: &ValidateOptions,
    runs: Vec<(RunReport, Vec<ManoeuvreRow>, bool)>,
) -> Result<ValidationReport, ValidateError> {
    let any_positions = runs.iter().any(|r| r.2);
    let mut reports = Vec::with_capacity(runs.len());
    let mut rows = Vec::new();
    for (report, run_rows, _) in runs {
        reports.push(report);
        rows.extend(run_rows);
    }
    assemble(rover, options, reports, rows, any_positions)
}
