//! Manoeuvres from the commanded speeds: a run is cut into maximal spans of constant commanded
//! side speeds (standstill, straight line, turn), each classified with model-core's kinematics
//! (Eq 2.4 for the commanded radius with the rover's slip track, [`Regime`] for the regime).

use crate::log::run_csv::RunSample;
use model_core::kinematics::{self, Regime, RegimeBounds, SideSpeeds, TurnDirection};
use model_core::{Rover, Sides};
use serde::Serialize;

/// Default tolerance on the commanded side speeds within one manoeuvre [m/s]: a sample whose
/// command differs from the span's first sample by more than this (on either side) starts a new
/// manoeuvre. 5 mm/s absorbs float noise and the quantisation of a controller's output while
/// keeping the seed's turn set apart (at v_c = 0.3 m/s its nearest side speeds differ by 0.1 m/s).
pub const DEFAULT_SPEED_TOLERANCE_MPS: f64 = 0.005;

/// Default shortest manoeuvre that is analysed [s]. Shorter spans are transitions between
/// commands (a ramp, a joystick twitch); a 90° turn of the seed takes ≥ 2.9 s (point turn at
/// v_c = 0.3 m/s with B_s = 1.1 m), so 1 s keeps every real manoeuvre.
pub const DEFAULT_MIN_DURATION_S: f64 = 1.0;

/// Default gap factor: an interval between two samples longer than this many times the run's
/// median interval is a gap in the recording (lost samples, an unplugged board). Nothing is
/// integrated across a gap.
pub const DEFAULT_GAP_FACTOR: f64 = 5.0;

/// How a run is cut into manoeuvres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SegmentOptions {
    /// Tolerance on each commanded side speed within a manoeuvre [m/s] (> 0).
    pub speed_tolerance_mps: f64,
    /// Manoeuvres shorter than this are marked too short and not analysed [s] (≥ 0).
    pub min_duration_s: f64,
    /// Intervals longer than this many times the median interval are gaps (> 1).
    pub gap_factor: f64,
    /// Where the regimes meet (tolerances around R = 0 and R', the straight-line threshold).
    #[serde(skip)]
    pub regime_bounds: RegimeBounds,
}

impl Default for SegmentOptions {
    fn default() -> Self {
        Self {
            speed_tolerance_mps: DEFAULT_SPEED_TOLERANCE_MPS,
            min_duration_s: DEFAULT_MIN_DURATION_S,
            gap_factor: DEFAULT_GAP_FACTOR,
            regime_bounds: RegimeBounds::default(),
        }
    }
}

/// What the rover was commanded to do during a manoeuvre.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ManoeuvreKind {
    /// Both sides commanded (within tolerance) to zero.
    Standstill,
    /// Equal side speeds, or a radius in the straight regime (≥ 20 m by default).
    Straight,
    /// Anything else: a turn of finite commanded radius (point turns included).
    Turn,
}

impl ManoeuvreKind {
    /// Stable identifier used in tables and CSV.
    pub const fn id(self) -> &'static str {
        match self {
            ManoeuvreKind::Standstill => "standstill",
            ManoeuvreKind::Straight => "straight",
            ManoeuvreKind::Turn => "turn",
        }
    }
}

/// One maximal span of constant commanded side speeds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Index of the span's first sample in the run.
    pub start: usize,
    /// One past the index of its last sample.
    pub end: usize,
    /// Time of the first sample [s].
    pub t_start_s: f64,
    /// Time of the last sample [s].
    pub t_end_s: f64,
    /// Commanded side speeds, averaged over the span (removes the jitter the tolerance allows) [m/s].
    pub cmd_mps: Sides<f64>,
    /// Standstill, straight line or turn.
    pub kind: ManoeuvreKind,
    /// Side of a turn; `None` for straight lines and standstill.
    pub direction: Option<TurnDirection>,
    /// Eq 2.4: commanded turning radius with the rover's slip track [m]; `None` for straight
    /// lines and standstill.
    pub radius_cmd_m: Option<f64>,
    /// The regime of the commanded radius; `None` at standstill.
    pub regime: Option<Regime>,
    /// Shorter than [`SegmentOptions::min_duration_s`] (or a single sample): not analysed.
    pub too_short: bool,
}

impl Segment {
    /// Number of samples in the span.
    pub fn len(&self) -> usize {
        self.end - self.start
    }

    /// True for an empty span (never produced by [`segment`]).
    pub fn is_empty(&self) -> bool {
        self.end == self.start
    }

    /// Time from the first to the last sample [s].
    pub fn duration_s(&self) -> f64 {
        self.t_end_s - self.t_start_s
    }
}

/// Why a run cannot be segmented.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SegmentError {
    /// The run has no samples.
    #[error("the run has no samples")]
    Empty,
    /// The run has a single sample: no interval, no manoeuvre.
    #[error("the run has a single sample (at least two are needed)")]
    SingleSample,
    /// A time or commanded speed is NaN or infinite.
    #[error("sample {index}: time or commanded speed is not finite")]
    NonFinite {
        /// 0-based sample index.
        index: usize,
    },
    /// Time does not strictly increase.
    #[error(
        "sample {index}: t_s = {t_s} does not increase past the previous sample's {previous_t_s}"
    )]
    TimeNotIncreasing {
        /// 0-based sample index.
        index: usize,
        /// Its time [s].
        t_s: f64,
        /// The previous sample's time [s].
        previous_t_s: f64,
    },
    /// An option is out of its domain.
    #[error("segmentation option {name} = {value} is out of range")]
    InvalidOption {
        /// The option.
        name: &'static str,
        /// Its value.
        value: f64,
    },
}

/// Checks that a run can be segmented: ≥ 2 samples, finite times and commands, time strictly
/// increasing.
pub fn check_run(samples: &[RunSample]) -> Result<(), SegmentError> {
    let mut check = RunCheck::default();
    for s in samples {
        check.push(s);
    }
    check.finish()
}

/// [`check_run`] sample by sample, for a run read as a stream: the same verdict, the first
/// problem found.
#[derive(Debug, Clone, Copy, Default)]
pub struct RunCheck {
    samples: usize,
    previous_t_s: Option<f64>,
    problem: Option<SegmentError>,
}

impl RunCheck {
    /// The run's next sample.
    pub fn push(&mut self, s: &RunSample) {
        let index = self.samples;
        self.samples += 1;
        if self.problem.is_some() {
            return;
        }
        if !(s.t_s.is_finite() && s.cmd_mps.left.is_finite() && s.cmd_mps.right.is_finite()) {
            self.problem = Some(SegmentError::NonFinite { index });
            return;
        }
        if let Some(previous_t_s) = self.previous_t_s {
            if s.t_s <= previous_t_s {
                self.problem = Some(SegmentError::TimeNotIncreasing {
                    index,
                    t_s: s.t_s,
                    previous_t_s,
                });
                return;
            }
        }
        self.previous_t_s = Some(s.t_s);
    }

    /// The verdict on the samples pushed.
    pub fn finish(&self) -> Result<(), SegmentError> {
        match (self.samples, self.problem) {
            (0, _) => Err(SegmentError::Empty),
            (1, _) => Err(SegmentError::SingleSample),
            (_, Some(problem)) => Err(problem),
            (_, None) => Ok(()),
        }
    }
}

/// The interval above which two consecutive samples are separated by a gap [s]:
/// `gap_factor` × the median interval of the run (`INFINITY` for fewer than two samples).
pub fn gap_threshold_s(samples: &[RunSample], gap_factor: f64) -> f64 {
    let mut dts: Vec<f64> = samples.windows(2).map(|w| w[1].t_s - w[0].t_s).collect();
    if dts.is_empty() {
        return f64::INFINITY;
    }
    let mid = dts.len() / 2;
    let (_, median, _) = dts.select_nth_unstable_by(mid, f64::total_cmp);
    gap_factor * *median
}

/// [`gap_threshold_s`] from the intervals one by one, for a run read as a stream: the same
/// median (the interval at the same place in the same order), from a count of each distinct
/// interval, so memory grows with the distinct intervals (21 in an hour recorded at 200 Hz),
/// not with the run.
#[derive(Debug, Clone, Default)]
pub struct IntervalMedian {
    /// Occurrences of each interval, by its bits.
    counts: std::collections::HashMap<u64, u64, BitsHash>,
    intervals: u64,
    last_t_s: Option<f64>,
}

impl IntervalMedian {
    /// The next sample's time.
    pub fn push(&mut self, t_s: f64) {
        if let Some(last) = self.last_t_s {
            *self.counts.entry((t_s - last).to_bits()).or_insert(0) += 1;
            self.intervals += 1;
        }
        self.last_t_s = Some(t_s);
    }

    /// `gap_factor` × the median interval (`INFINITY` for fewer than two samples).
    pub fn gap_threshold_s(&self, gap_factor: f64) -> f64 {
        let mut distinct: Vec<(f64, u64)> = self
            .counts
            .iter()
            .map(|(&bits, &n)| (f64::from_bits(bits), n))
            .collect();
        distinct.sort_by(|a, b| a.0.total_cmp(&b.0));
        // The interval at place `mid` of all of them sorted, as `select_nth_unstable_by` finds it.
        let mid = self.intervals / 2;
        let mut below = 0;
        for (dt, n) in distinct {
            below += n;
            if below > mid {
                return gap_factor * dt;
            }
        }
        f64::INFINITY
    }

    /// Whether thresholds `a` and `b` call the same intervals gaps (`dt > threshold`), so
    /// statistics measured with one are those of the other, to the bit.
    pub fn same_gaps(&self, a: f64, b: f64) -> bool {
        self.counts.keys().all(|&bits| {
            let dt = f64::from_bits(bits);
            (dt > a) == (dt > b)
        })
    }
}

/// The hasher of [`IntervalMedian`]'s keys: a few distinct interval bits, one lookup per
/// sample, so one multiply (Fibonacci hashing) rather than SipHash (the keys come from the
/// run, not from an adversary choosing collisions).
#[derive(Debug, Clone, Copy, Default)]
struct BitsHash;

impl std::hash::BuildHasher for BitsHash {
    type Hasher = BitsHasher;
    fn build_hasher(&self) -> BitsHasher {
        BitsHasher(0)
    }
}

#[derive(Debug, Clone, Copy)]
struct BitsHasher(u64);

impl std::hash::Hasher for BitsHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }
    fn write_u64(&mut self, bits: u64) {
        // The high bits select the bucket (hashbrown takes the top 7 as the tag too).
        let mixed = (self.0 ^ bits).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        self.0 = mixed ^ (mixed >> 29);
    }
}

/// Cuts a run into maximal spans of constant commanded side speeds. The spans partition the
/// samples in order (every sample belongs to exactly one span); spans shorter than
/// `min_duration_s` are returned marked [`Segment::too_short`].
pub fn segment(
    samples: &[RunSample],
    rover: &Rover,
    options: &SegmentOptions,
) -> Result<Vec<Segment>, SegmentError> {
    check_options(options)?;
    match samples.len() {
        0 => return Err(SegmentError::Empty),
        1 => return Err(SegmentError::SingleSample),
        _ => {}
    }
    // One pass over the samples: [`check_run`]'s verdict as the cuts are found, each span
    // classified while its samples are in the cache.
    let mut check = RunCheck::default();
    let mut segments = Vec::new();
    let mut start = 0;
    for (i, sample) in samples.iter().enumerate() {
        check.push(sample);
        if let Some(problem) = check.problem {
            return Err(problem);
        }
        if i > 0 && starts_manoeuvre(sample, &samples[start], options) {
            segments.push(classify(samples, start, i, rover, options));
            start = i;
        }
    }
    segments.push(classify(samples, start, samples.len(), rover, options));
    Ok(segments)
}

/// Whether `sample` starts a new manoeuvre after the one whose first sample is `first`: a
/// commanded side speed differs by more than the tolerance.
fn starts_manoeuvre(sample: &RunSample, first: &RunSample, options: &SegmentOptions) -> bool {
    let tol = options.speed_tolerance_mps;
    let (a, b) = (sample.cmd_mps, first.cmd_mps);
    (a.left - b.left).abs() > tol || (a.right - b.right).abs() > tol
}

/// [`segment`] sample by sample, for a run read as a stream: each manoeuvre is handed over
/// with its samples as soon as the next one starts (or at [`Segmenter::finish`]), so memory
/// holds one manoeuvre, not the run. The run must pass [`check_run`] ([`RunCheck`]).
#[derive(Debug)]
pub struct Segmenter<'a> {
    rover: &'a Rover,
    options: SegmentOptions,
    /// The current manoeuvre's samples.
    span: Vec<RunSample>,
    /// Index of its first sample in the run.
    start: usize,
}

impl<'a> Segmenter<'a> {
    /// A segmenter with checked options.
    pub fn new(rover: &'a Rover, options: &SegmentOptions) -> Result<Self, SegmentError> {
        check_options(options)?;
        Ok(Self {
            rover,
            options: *options,
            span: Vec::new(),
            start: 0,
        })
    }

    /// The run's next sample; `done` gets the manoeuvre it ends (if it starts one), as
    /// [`segment`] gives it, and that manoeuvre's samples.
    pub fn push(&mut self, sample: &RunSample, done: impl FnOnce(&Segment, &[RunSample])) {
        if self
            .span
            .first()
            .is_some_and(|first| starts_manoeuvre(sample, first, &self.options))
        {
            self.hand_over(done);
        }
        self.span.push(*sample);
    }

    /// Ends the run: `done` gets its last manoeuvre (none for an empty run).
    pub fn finish(mut self, done: impl FnOnce(&Segment, &[RunSample])) {
        if !self.span.is_empty() {
            self.hand_over(done);
        }
    }

    fn hand_over(&mut self, done: impl FnOnce(&Segment, &[RunSample])) {
        let n = self.span.len();
        let mut seg = classify(&self.span, 0, n, self.rover, &self.options);
        seg.start += self.start;
        seg.end += self.start;
        done(&seg, &self.span);
        self.start += n;
        self.span.clear();
    }
}

fn check_options(options: &SegmentOptions) -> Result<(), SegmentError> {
    let checks = [
        (
            "speed_tolerance_mps",
            options.speed_tolerance_mps,
            options.speed_tolerance_mps > 0.0,
        ),
        (
            "min_duration_s",
            options.min_duration_s,
            options.min_duration_s >= 0.0,
        ),
        ("gap_factor", options.gap_factor, options.gap_factor > 1.0),
    ];
    for (name, value, ok) in checks {
        if !(ok && value.is_finite()) {
            return Err(SegmentError::InvalidOption { name, value });
        }
    }
    Ok(())
}

fn classify(
    samples: &[RunSample],
    start: usize,
    end: usize,
    rover: &Rover,
    options: &SegmentOptions,
) -> Segment {
    let span = &samples[start..end];
    let n = span.len() as f64;
    let cmd = Sides::new(
        span.iter().map(|s| s.cmd_mps.left).sum::<f64>() / n,
        span.iter().map(|s| s.cmd_mps.right).sum::<f64>() / n,
    );
    let tol = options.speed_tolerance_mps;
    let speeds = SideSpeeds::new(cmd.left as f32, cmd.right as f32);
    let radius = kinematics::turning_radius_m(speeds, rover.slip_track_m);
    let standstill = cmd.left.abs() <= tol && cmd.right.abs() <= tol;
    let (kind, regime, radius_cmd_m) = match radius {
        _ if standstill => (ManoeuvreKind::Standstill, None, None),
        None => (ManoeuvreKind::Standstill, None, None),
        Some(r) => match Regime::of(r, rover, &options.regime_bounds) {
            Regime::Straight => (ManoeuvreKind::Straight, Some(Regime::Straight), None),
            regime => (ManoeuvreKind::Turn, Some(regime), Some(f64::from(r))),
        },
    };
    let direction = match kind {
        ManoeuvreKind::Turn => kinematics::turn_direction(speeds),
        _ => None,
    };
    let (t_start_s, t_end_s) = (span[0].t_s, span[span.len() - 1].t_s);
    Segment {
        start,
        end,
        t_start_s,
        t_end_s,
        cmd_mps: cmd,
        kind,
        direction,
        radius_cmd_m,
        regime,
        too_short: span.len() < 2 || t_end_s - t_start_s < options.min_duration_s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const HUSKY: Rover = Rover::HUSKY_A200;

    fn sample(t_s: f64, left: f64, right: f64) -> RunSample {
        RunSample {
            t_s,
            bus_v: Sides::new(24.0, 24.0),
            current_a: Sides::new(1.0, 1.0),
            cmd_mps: Sides::new(left, right),
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        }
    }

    /// `(duration_s, left, right)` pieces sampled every `dt_s`, with optional jitter.
    fn run(pieces: &[(f64, f64, f64)], dt_s: f64, jitter_mps: f64) -> Vec<RunSample> {
        let mut out = Vec::new();
        let mut t = 0.0;
        let mut k = 0u32;
        for &(duration, left, right) in pieces {
            let n = (duration / dt_s).round() as usize;
            for _ in 0..n {
                // Deterministic jitter: ±jitter alternating with a slow pattern.
                let j = jitter_mps * [1.0, -0.6, 0.3, -1.0, 0.8][(k % 5) as usize];
                out.push(sample(t, left + j, right - j));
                t += dt_s;
                k += 1;
            }
        }
        out
    }

    #[test]
    fn command_sequence_with_jitter_and_both_directions() {
        let rp = f64::from(HUSKY.r_prime_m());
        // standstill, point turn left, R' turn right, straight, 2R' turn left, standstill.
        let pieces = [
            (1.5, 0.0, 0.0),
            (3.0, -0.3, 0.3),
            (3.0, 0.6, 0.0),
            (2.0, 0.3, 0.3),
            (4.0, 0.15, 0.45),
            (1.5, 0.0, 0.0),
        ];
        let samples = run(&pieces, 0.01, 0.001);
        let segs = segment(&samples, &HUSKY, &SegmentOptions::default()).expect("valid run");
        let kinds: Vec<_> = segs
            .iter()
            .map(|s| (s.kind, s.direction, s.regime))
            .collect();
        assert_eq!(
            kinds,
            vec![
                (ManoeuvreKind::Standstill, None, None),
                (
                    ManoeuvreKind::Turn,
                    Some(TurnDirection::Left),
                    Some(Regime::Point)
                ),
                (
                    ManoeuvreKind::Turn,
                    Some(TurnDirection::Right),
                    Some(Regime::AtRPrime)
                ),
                (ManoeuvreKind::Straight, None, Some(Regime::Straight)),
                (
                    ManoeuvreKind::Turn,
                    Some(TurnDirection::Left),
                    Some(Regime::AboveRPrime)
                ),
                (ManoeuvreKind::Standstill, None, None),
            ]
        );
        // Eq 2.4 on the averaged commands: R' and 2R'.
        let r_at = segs[2].radius_cmd_m.expect("turn");
        assert!((r_at - rp).abs() < 1e-3, "{r_at}");
        let r_two = segs[4].radius_cmd_m.expect("turn");
        assert!((r_two - 2.0 * rp).abs() < 1e-3, "{r_two}");
        assert!(segs.iter().all(|s| !s.too_short));
        assert_eq!(segs[1].len(), 300);
        assert!((segs[1].cmd_mps.left + 0.3).abs() < 1e-3);
    }

    #[test]
    fn short_spans_are_kept_but_marked() {
        let pieces = [(2.0, 0.3, 0.3), (0.2, 0.2, 0.4), (2.0, 0.3, 0.3)];
        let samples = run(&pieces, 0.01, 0.0);
        let segs = segment(&samples, &HUSKY, &SegmentOptions::default()).expect("valid run");
        assert_eq!(segs.len(), 3);
        assert_eq!(
            segs.iter().map(|s| s.too_short).collect::<Vec<_>>(),
            [false, true, false]
        );
    }

    #[test]
    fn jitter_beyond_the_tolerance_splits() {
        let mut samples = run(&[(2.0, 0.3, 0.3)], 0.01, 0.0);
        samples[100].cmd_mps.left += 0.02;
        let segs = segment(&samples, &HUSKY, &SegmentOptions::default()).expect("valid run");
        assert_eq!(segs.len(), 3);
        assert_eq!((segs[1].start, segs[1].end), (100, 101));
        assert!(segs[1].too_short);
    }

    #[test]
    fn gap_threshold_is_a_multiple_of_the_median_interval() {
        let mut samples = run(&[(1.0, 0.3, 0.3)], 0.01, 0.0);
        for s in samples.iter_mut().skip(50) {
            s.t_s += 3.0;
        }
        let g = gap_threshold_s(&samples, 5.0);
        assert!((g - 0.05).abs() < 1e-9, "{g}");
        // The gap does not split the manoeuvre (the command did not change).
        let segs = segment(&samples, &HUSKY, &SegmentOptions::default()).expect("valid run");
        assert_eq!(segs.len(), 1);
    }

    proptest! {
        /// The streamed median (counts of distinct intervals) is the in-memory one
        /// (`select_nth_unstable_by`) to the bit, whatever the intervals: repeated, jittered
        /// in the last bits as recorded times are, with gaps.
        #[test]
        fn interval_median_is_the_select_nth_median(
            steps in proptest::collection::vec((0usize..6, 0u64..4), 0..400),
            start in -1e3f64..1e6,
        ) {
            let mut t = start;
            let mut samples = Vec::new();
            for (kind, jitter) in steps {
                samples.push(sample(t, 0.1, 0.1));
                let dt = [0.005, 0.01, 0.005, 0.5, 0.004_999_999_999_999_893, 1e-6][kind];
                t = f64::from_bits((t + dt).to_bits() + jitter);
            }
            let mut median = IntervalMedian::default();
            samples.iter().for_each(|s| median.push(s.t_s));
            let (want, got) = (gap_threshold_s(&samples, 5.0), median.gap_threshold_s(5.0));
            prop_assert_eq!(got.to_bits(), want.to_bits(), "{} vs {}", got, want);
        }
    }

    #[test]
    fn malformed_runs_are_clear_errors() {
        let opts = SegmentOptions::default();
        assert_eq!(segment(&[], &HUSKY, &opts), Err(SegmentError::Empty));
        assert_eq!(
            segment(&[sample(0.0, 0.1, 0.1)], &HUSKY, &opts),
            Err(SegmentError::SingleSample)
        );
        let e = segment(
            &[sample(1.0, 0.0, 0.0), sample(1.0, 0.0, 0.0)],
            &HUSKY,
            &opts,
        )
        .expect_err("repeated time");
        assert!(matches!(
            e,
            SegmentError::TimeNotIncreasing { index: 1, .. }
        ));
        assert!(e.to_string().contains("sample 1"), "{e}");
        assert_eq!(
            segment(
                &[sample(0.0, 0.0, 0.0), sample(1.0, f64::NAN, 0.0)],
                &HUSKY,
                &opts
            ),
            Err(SegmentError::NonFinite { index: 1 })
        );
        let bad = SegmentOptions {
            gap_factor: 0.5,
            ..opts
        };
        assert!(matches!(
            segment(&run(&[(1.0, 0.0, 0.0)], 0.1, 0.0), &HUSKY, &bad),
            Err(SegmentError::InvalidOption {
                name: "gap_factor",
                ..
            })
        ));
    }

    proptest! {
        /// Any monotone time series with arbitrary commands: the spans partition the samples in
        /// order, each span's commands stay within the tolerance of its first sample, and
        /// neighbouring spans start with a command change.
        #[test]
        fn segments_partition_the_samples(
            steps in proptest::collection::vec(
                (1e-4f64..2.0, prop_oneof![Just(0.0), Just(0.3), -1.0f64..1.0], prop_oneof![Just(0.0), Just(0.3), -1.0f64..1.0]),
                2..300,
            ),
        ) {
            let mut t = 0.0;
            let samples: Vec<RunSample> = steps
                .iter()
                .map(|&(dt, l, r)| {
                    t += dt;
                    sample(t, l, r)
                })
                .collect();
            let opts = SegmentOptions::default();
            let segs = segment(&samples, &HUSKY, &opts).expect("valid run");
            let mut next = 0;
            for s in &segs {
                prop_assert_eq!(s.start, next);
                prop_assert!(s.end > s.start);
                for x in &samples[s.start..s.end] {
                    prop_assert!((x.cmd_mps.left - samples[s.start].cmd_mps.left).abs() <= opts.speed_tolerance_mps);
                    prop_assert!((x.cmd_mps.right - samples[s.start].cmd_mps.right).abs() <= opts.speed_tolerance_mps);
                }
                prop_assert_eq!(s.kind == ManoeuvreKind::Turn, s.radius_cmd_m.is_some());
                prop_assert_eq!(s.kind == ManoeuvreKind::Standstill, s.regime.is_none());
                next = s.end;
            }
            prop_assert_eq!(next, samples.len());
        }
    }
}
