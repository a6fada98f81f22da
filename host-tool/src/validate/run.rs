//! One run's part of [`validate`](super::validate): what is known of the run before its
//! manoeuvres ([`RunFacts`]), then each manoeuvre measured as it comes ([`RunValidation`]). The
//! in-memory path feeds it the run's slices; the streaming path ([`super::stream`]) feeds it
//! from a file read twice, so both give the same report.

use super::crosscheck::CrossCheck;
use super::segment::{IntervalMedian, RunCheck, Segment, SegmentError};
use super::ValidateOptions;
use super::{apply_measured_slip_track, pose, turns, ManoeuvreKind, ManoeuvreRow, RunReport};
use crate::log::run_csv::RunSample;
use model_core::kinematics;
use model_core::kinematics::SideSpeeds;
use model_core::Rover;

/// What validation needs to know of a whole run before measuring its manoeuvres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunFacts {
    /// Samples in the run.
    pub samples: usize,
    /// First to last sample [s].
    pub duration_s: f64,
    /// Whether every sample has a yaw.
    pub has_yaw: bool,
    /// Whether any sample has a pitch.
    pub has_pitch: bool,
    /// Whether any sample has a tracked position ([`pose::has_positions`]).
    pub has_positions: bool,
    /// Intervals longer than this are gaps [s] ([`gap_threshold_s`]).
    pub gap_threshold_s: f64,
}

impl RunFacts {
    /// The facts of a run held in memory (of at least two samples): [`FactsScan`]'s, in one
    /// pass over the samples.
    pub fn of(samples: &[RunSample], gap_factor: f64) -> Self {
        let mut scan = FactsScan::default();
        samples.iter().for_each(|s| scan.push(s));
        scan.facts(gap_factor)
    }
}

/// [`RunFacts`] and [`super::segment::check_run`]'s verdict gathered sample by sample, for a
/// run read as a stream (memory: the distinct sample intervals, not the run).
#[derive(Debug, Clone, Default)]
pub struct FactsScan {
    samples: usize,
    first_t_s: Option<f64>,
    last_t_s: f64,
    missing_yaw: bool,
    has_pitch: bool,
    has_positions: bool,
    intervals: IntervalMedian,
    check: RunCheck,
}

impl FactsScan {
    /// The run's next sample.
    pub fn push(&mut self, s: &RunSample) {
        self.samples += 1;
        self.first_t_s.get_or_insert(s.t_s);
        self.last_t_s = s.t_s;
        self.missing_yaw |= s.yaw_rad.is_none();
        self.has_pitch |= s.pitch_deg.is_some();
        self.has_positions |= s.x_m.is_some() && s.y_m.is_some();
        self.intervals.push(s.t_s);
        self.check.push(s);
    }

    /// Samples pushed.
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// Whether the run can be segmented ([`super::segment::check_run`]).
    pub fn check(&self) -> Result<(), SegmentError> {
        self.check.finish()
    }

    /// Whether gap thresholds `a` and `b` call the same of the intervals pushed gaps
    /// ([`IntervalMedian::same_gaps`]).
    pub fn same_gaps(&self, a: f64, b: f64) -> bool {
        self.intervals.same_gaps(a, b)
    }

    /// The facts of the samples pushed.
    pub fn facts(&self, gap_factor: f64) -> RunFacts {
        RunFacts {
            samples: self.samples,
            duration_s: self.first_t_s.map_or(0.0, |first| self.last_t_s - first),
            has_yaw: !self.missing_yaw,
            has_pitch: self.has_pitch,
            has_positions: self.has_positions,
            gap_threshold_s: self.intervals.gap_threshold_s(gap_factor),
        }
    }
}

/// What [`RunValidation`] measures of one analysed manoeuvre.
#[derive(Debug)]
pub(super) struct Measured {
    stats: turns::ManoeuvreStats,
    pub(super) track: Option<pose::TrackStats>,
}

/// One run being validated, manoeuvre by manoeuvre.
#[derive(Debug)]
pub struct RunValidation<'a> {
    rover: &'a Rover,
    options: &'a ValidateOptions,
    turn_options: turns::TurnOptions,
    has_positions: bool,
    report: RunReport,
    rows: Vec<ManoeuvreRow>,
}

impl<'a> RunValidation<'a> {
    /// Starts the run `name` with its `facts`.
    pub fn new(
        name: &str,
        facts: &RunFacts,
        rover: &'a Rover,
        options: &'a ValidateOptions,
    ) -> Self {
        Self {
            rover,
            options,
            turn_options: turns::TurnOptions {
                settle_s: options.settle_s,
                turn_deg: options.turn_deg,
                gap_threshold_s: facts.gap_threshold_s,
            },
            has_positions: facts.has_positions,
            report: RunReport {
                name: name.to_owned(),
                samples: facts.samples,
                duration_s: facts.duration_s,
                sample_rate_hz: if facts.duration_s > 0.0 {
                    facts.samples.saturating_sub(1) as f64 / facts.duration_s
                } else {
                    0.0
                },
                lost_samples: None,
                has_yaw: facts.has_yaw,
                has_pitch: facts.has_pitch,
                gap_threshold_s: facts.gap_threshold_s,
                segments: 0,
                standstill: 0,
                too_short: 0,
                analysed: 0,
                cross_check: None,
                slip_track_measured_m: None,
                slip_track_measured: None,
            },
            rows: Vec::new(),
        }
    }

    /// The run's next manoeuvre `seg` (as [`super::segment::segment`] cuts it) and its
    /// samples.
    pub fn manoeuvre(&mut self, seg: &Segment, span: &[RunSample]) {
        let measured = self.measure(seg, span);
        self.record(seg, measured);
    }

    /// All the manoeuvres `segs` of a run held in memory (`samples`), in order: measured on
    /// every core, in shares of about equal samples (the statistics are independent per
    /// manoeuvre), then recorded in order, so the rows are [`Self::manoeuvre`]'s one by one.
    pub fn manoeuvres(&mut self, segs: &[Segment], samples: &[RunSample]) {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get().min(8));
        // Segment index where each core's share begins.
        let cuts: Vec<usize> = (0..=cores)
            .map(|k| segs.partition_point(|s| s.start < samples.len() * k / cores))
            .collect();
        let this = &*self;
        let measure_all = |segs: &[Segment]| -> Vec<Option<Measured>> {
            segs.iter()
                .map(|seg| this.measure(seg, &samples[seg.start..seg.end]))
                .collect()
        };
        let measured: Vec<Vec<Option<Measured>>> = if cores == 1 || segs.len() < 2 {
            vec![measure_all(segs)]
        } else {
            std::thread::scope(|s| {
                let shares: Vec<_> = cuts
                    .windows(2)
                    .skip(1)
                    .map(|w| {
                        let share = &segs[w[0]..w[1]];
                        s.spawn(move || measure_all(share))
                    })
                    .collect();
                // The first share on this thread.
                let mut all = vec![measure_all(&segs[..cuts[1]])];
                for share in shares {
                    // A panic in a share is a bug: pass it on.
                    all.push(
                        share
                            .join()
                            .unwrap_or_else(|e| std::panic::resume_unwind(e)),
                    );
                }
                all
            })
        };
        for (seg, m) in segs.iter().zip(measured.into_iter().flatten()) {
            self.record(seg, m);
        }
    }

    /// The statistics of manoeuvre `seg` (its samples `span`); `None` for a standstill or a
    /// manoeuvre too short to analyse.
    pub(super) fn measure(&self, seg: &Segment, span: &[RunSample]) -> Option<Measured> {
        if seg.kind == ManoeuvreKind::Standstill || seg.too_short {
            return None;
        }
        let (rover, options) = (self.rover, self.options);
        // The statistics see the span alone: the same manoeuvre, counted from 0.
        let local = Segment {
            start: 0,
            end: span.len(),
            ..*seg
        };
        let stats = turns::analyse(span, &local, rover, &self.turn_options);
        let track = (self.has_positions && seg.kind == ManoeuvreKind::Turn).then(|| {
            let turn = pose::TurnContext {
                rover,
                cmd_mps: seg.cmd_mps,
                direction: seg.direction,
                radius_cmd_m: seg.radius_cmd_m,
                yaw_rate_cmd_rad_s: stats.yaw_rate_cmd_rad_s,
                tracker_offset_m: options.tracker_offset_m,
            };
            pose::analyse_track(turns::steady_part(span, &local, options.settle_s), &turn)
        });
        Some(Measured { stats, track })
    }

    /// Counts manoeuvre `seg` and adds its row if it was `measured`.
    pub(super) fn record(&mut self, seg: &Segment, measured: Option<Measured>) {
        let index = self.report.segments;
        self.report.segments += 1;
        let Some(Measured { stats, track }) = measured else {
            if seg.kind == ManoeuvreKind::Standstill {
                self.report.standstill += 1;
            } else {
                self.report.too_short += 1;
            }
            return;
        };
        self.report.analysed += 1;
        let rover = self.rover;
        let speeds = SideSpeeds::new(seg.cmd_mps.left as f32, seg.cmd_mps.right as f32);
        let r_prime = f64::from(rover.r_prime_m());
        self.rows.push(ManoeuvreRow {
            run: self.report.name.clone(),
            segment: index,
            kind: seg.kind,
            direction: seg.direction,
            t_start_s: seg.t_start_s,
            t_end_s: seg.t_end_s,
            first_sample: seg.start,
            end_sample: seg.end,
            cmd_mps: seg.cmd_mps,
            v_c_mps: f64::from(kinematics::total_absolute_speed_mps(speeds)),
            radius_cmd_m: seg.radius_cmd_m,
            r_over_r_prime: seg.radius_cmd_m.map(|r| r / r_prime),
            regime: seg.regime,
            in_fit: false,
            stats,
            fit: None,
            hard_ground_w: None,
            hard_ground_residual_fraction: None,
            r_act_m: track.as_ref().and_then(|t| t.r_act_m),
            r_act_over_r_prime_act: None,
            track,
        });
    }

    /// The run's report and manoeuvre rows, with the cross-check of its frames.
    pub fn finish(mut self, cross_check: Option<CrossCheck>) -> (RunReport, Vec<ManoeuvreRow>) {
        self.report.lost_samples = cross_check.as_ref().map(|c| c.lost_samples);
        self.report.cross_check = cross_check;
        if self.has_positions {
            apply_measured_slip_track(&mut self.report, &mut self.rows, self.rover);
        }
        (self.report, self.rows)
    }
}
