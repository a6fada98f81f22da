//! A run log as a ROS 2 bag (`convert LOG OUT --to ros2-bag`), for ROS 2 tools (`ros2 bag
//! play`, rosbags, Foxglove):
//!
//! | topic | type | what |
//! |---|---|---|
//! | `/rover_power/sample` | `rover_power/msg/Sample` ([`sample_definition`], carried in the bag) | every sample |
//! | `/cmd_vel` | `geometry_msgs/msg/Twist` | the commanded side speeds as (v, ω), at the first sample and at each change |
//! | `/imu/data` | `sensor_msgs/msg/Imu` | the orientation where yaw was measured (pitch 0 where it was not), `base_link` |
//! | `/rover_power/tracker_pose` | `geometry_msgs/msg/PoseStamped` | the tracked position where a fix landed, with the IMU's orientation (identity without yaw), `map` |
//! | `/rosout` | `rcl_interfaces/msg/Log` | the log's events (recording started, samples lost, ...) |
//!
//! Log times (and header stamps) are Unix time [ns], the same as the MCAP log's `log_time` of
//! the same record ([`LogClock`]); run time for a log without a wall clock, as in MCAP. A topic
//! without messages is left out.

use super::cdr::{CdrError, CdrReader, CdrWriter};
use super::msgs::{
    complete_definition, encode_imu, encode_log, encode_pose_stamped, encode_twist, quaternion_of,
    write_stamp, StdType, TIME,
};
use super::write::{BagWriteError, BagWriter};
// Past HELD_MAX messages before the first sample without a wall clock, the MCAP log goes on
// run time, and so does the bag.
use crate::log::mcap::{describe_event, HELD_MAX};
use crate::log::run_csv::RunSample;
use crate::log::run_log::{LogEvent, Record, RunLog};
use crate::out_dir::{rebase, write_dir_whole, OutDirError};
use model_core::wire::BoardFrame;
use model_core::Sides;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Topic of the samples.
pub const TOPIC_SAMPLE: &str = "/rover_power/sample";
/// Topic of the commanded speeds.
pub const TOPIC_CMD_VEL: &str = "/cmd_vel";
/// Topic of the measured orientation.
pub const TOPIC_IMU: &str = "/imu/data";
/// Topic of the tracked position.
pub const TOPIC_TRACKER_POSE: &str = "/rover_power/tracker_pose";
/// Topic of the events.
pub const TOPIC_ROSOUT: &str = "/rosout";
/// Our sample's message type.
pub const SAMPLE_TYPE: &str = "rover_power/msg/Sample";
/// `rcl_interfaces/msg/Log` `name` of the events.
pub const LOGGER_NAME: &str = "rover_power";

/// Frame of the IMU orientation.
const IMU_FRAME: &str = "base_link";
/// Frame of the tracked pose.
const POSE_FRAME: &str = "map";

/// The ros2msg definition of `rover_power/msg/Sample` (with `builtin_interfaces/Time`), as
/// the bag stores it so that readers decode it without our package.
pub fn sample_definition() -> String {
    const SAMPLE: &str = "\
# One sample of the rover-power board (host-tool convert --to ros2-bag).
# NaN = not measured: yaw and pitch without an IMU or tracker, x and y where no tracker fix
# landed on this sample.
builtin_interfaces/Time stamp # Unix time the sample arrived (run time without a wall clock)
float64 left_bus_v            # bus voltage at the left motor driver [V]
float64 left_current_a        # current into the left motor driver [A], positive drawn from the battery
float64 right_bus_v           # [V]
float64 right_current_a       # [A]
float64 cmd_left_mps          # commanded speed of the left side [m/s], positive forward
float64 cmd_right_mps         # [m/s]
float64 yaw_rad               # yaw [rad], counter-clockwise positive; NaN = not measured
float64 pitch_deg             # pitch [deg], nose up positive; NaN = not measured
float64 x_m                   # tracked point in the fixed frame [m]; NaN = no fix on this sample
float64 y_m                   # [m]; NaN with x_m
float64 t_s                   # run time [s], since the recording started
";
    complete_definition(SAMPLE, &[TIME])
}

/// Where the log times come from: the MCAP sink's rule, so that a record has the same log time
/// in the bag as in the MCAP log written from the same run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogClock {
    /// Unix time [ns] of run time 0: the first [`LogEvent::WallClock`], when it comes before the
    /// first sample (as the recorder writes it).
    Unix { unix_ns_at_run_zero: i128 },
    /// The log has no wall clock (a run CSV, or one recorded without it): run time [ns].
    RunTime,
}

impl LogClock {
    /// The clock of a run's `records` ([`RunLog::in_time_order`]), as the MCAP sink picks it.
    fn of(records: &[(f64, Record<'_>)]) -> LogClock {
        let mut held = 0;
        for (t_s, record) in records {
            match record {
                Record::Event(LogEvent::WallClock { unix_ns }) => {
                    return match nanoseconds(*t_s) {
                        Some(ns) => LogClock::Unix {
                            unix_ns_at_run_zero: i128::from(*unix_ns) - ns,
                        },
                        None => LogClock::RunTime,
                    };
                }
                Record::Sample(_) => break,
                _ => {
                    // The sink holds messages, not records: a model or status frame is two.
                    let messages = match record {
                        Record::Frame(BoardFrame::Model(_) | BoardFrame::Status(_)) => 2,
                        _ => 1,
                    };
                    if held + messages > HELD_MAX {
                        break;
                    }
                    held += messages;
                }
            }
        }
        LogClock::RunTime
    }

    /// The log time [ns] of run time `t_s`.
    fn log_time_ns(self, t_s: f64) -> Result<u64, FromLogError> {
        let zero = match self {
            LogClock::Unix {
                unix_ns_at_run_zero,
            } => unix_ns_at_run_zero,
            LogClock::RunTime => 0,
        };
        nanoseconds(t_s)
            .and_then(|ns| u64::try_from(zero + ns).ok())
            .ok_or(FromLogError::Time { t_s, clock: self })
    }
}

/// `t_s` in whole nanoseconds, rounded as the MCAP sink rounds it.
fn nanoseconds(t_s: f64) -> Option<i128> {
    let ns = (t_s * 1e9).round();
    (ns.is_finite() && ns.abs() < 1e30).then_some(ns as i128)
}

/// Why no bag was written from a log.
#[derive(Debug, Error)]
pub enum FromLogError {
    #[error(transparent)]
    Write(#[from] BagWriteError),
    /// A record's time is before 1970 (or past 2554) on the bag's clock.
    #[error("run time {t_s} s has no bag log time ({})", match clock {
        LogClock::RunTime => "the log has no wall clock, and run time before 0 cannot be a log time",
        LogClock::Unix { .. } => "before 1970 or past 2554 on the log's wall clock",
    })]
    Time { t_s: f64, clock: LogClock },
}

/// How to turn the log's records into messages.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BagOptions {
    /// B_s, the rover controller's slip track [m]: ω = (v_r − v_l) / B_s on `/cmd_vel`.
    pub slip_track_m: f64,
}

/// What was written.
#[derive(Debug, Clone, PartialEq)]
pub struct BagWritten {
    /// The bag's MCAP file.
    pub mcap: PathBuf,
    /// Messages per topic, in the order the topics first had one.
    pub topics: Vec<(String, u64)>,
    /// Where the log times came from.
    pub clock: LogClock,
}

/// Writes `run` as the bag directory `out`, whole or not at all; an existing non-empty `out` is
/// replaced only with `force`. The MCAP file is named after the directory, as rosbag2 names it.
pub fn save_bag(
    out: &Path,
    force: bool,
    run: &RunLog,
    options: &BagOptions,
) -> Result<BagWritten, OutDirError<FromLogError>> {
    let stem = out
        .file_name()
        .and_then(|n| n.to_str())
        .filter(|n| !n.is_empty() && *n != "..")
        .unwrap_or("bag")
        .to_owned();
    write_dir_whole(out, force, |staging| {
        write_bag(staging, &stem, run, options).map(|mut bag| {
            bag.mcap = rebase(&bag.mcap, staging, out);
            bag
        })
    })
}

/// Writes `run` as a bag into the empty directory `dir` (its MCAP file `stem`_0.mcap).
pub fn write_bag(
    dir: &Path,
    stem: &str,
    run: &RunLog,
    options: &BagOptions,
) -> Result<BagWritten, FromLogError> {
    let records = run.in_time_order();
    let clock = LogClock::of(&records);
    let mut bag = Bag {
        writer: BagWriter::create(dir, stem)?,
        channels: [None; Topic::COUNT],
    };
    let mut last_cmd: Option<Sides<f64>> = None;
    for (t_s, record) in &records {
        match record {
            Record::Sample(s) => {
                let log_time = clock.log_time_ns(s.t_s)?;
                let stamp = stamp_ns(log_time);
                bag.write(Topic::Sample, log_time, &encode_sample(stamp, s))?;
                if last_cmd != Some(s.cmd_mps) {
                    last_cmd = Some(s.cmd_mps);
                    let (v, omega) = twist_of(s.cmd_mps, options.slip_track_m);
                    bag.write(Topic::CmdVel, log_time, &encode_twist(v, omega))?;
                }
                if let Some(yaw) = s.yaw_rad {
                    let q = quaternion_of(yaw, s.pitch_deg.unwrap_or(0.0));
                    bag.write(Topic::Imu, log_time, &encode_imu(stamp, IMU_FRAME, q))?;
                }
                if let (Some(x), Some(y)) = (s.x_m, s.y_m) {
                    // No yaw: the identity orientation (PoseStamped has no "unknown").
                    let q = s.yaw_rad.map_or([0.0, 0.0, 0.0, 1.0], |yaw| {
                        quaternion_of(yaw, s.pitch_deg.unwrap_or(0.0))
                    });
                    let pose = encode_pose_stamped(stamp, POSE_FRAME, [x, y, 0.0], q);
                    bag.write(Topic::TrackerPose, log_time, &pose)?;
                }
            }
            Record::Event(event) => {
                let log_time = clock.log_time_ns(*t_s)?;
                let (level, text) = log_line(event);
                let line = encode_log(stamp_ns(log_time), level, LOGGER_NAME, &text);
                bag.write(Topic::Rosout, log_time, &line)?;
            }
            Record::Frame(_) | Record::Command(_) => {}
        }
    }
    let topics = bag
        .writer
        .message_counts()
        .into_iter()
        .map(|(name, n)| (name.to_owned(), n))
        .collect();
    let mcap = bag.writer.finish(dir)?;
    Ok(BagWritten {
        mcap,
        topics,
        clock,
    })
}

/// Eq 2.1–2.2 (symmetric ICRs): (v, ω) of side speeds, v = (l + r)/2, ω = (r − l)/B_s
/// (counter-clockwise positive), in f64 (`model_core::kinematics::body_velocity` is f32).
pub fn twist_of(cmd_mps: Sides<f64>, slip_track_m: f64) -> (f64, f64) {
    (
        (cmd_mps.left + cmd_mps.right) / 2.0,
        (cmd_mps.right - cmd_mps.left) / slip_track_m,
    )
}

/// The `rcl_interfaces/msg/Log` level (20 INFO, 30 WARN) and text of an event: the MCAP log's.
pub fn log_line(event: &LogEvent) -> (u8, String) {
    const INFO: u8 = 20;
    const WARN: u8 = 30;
    let (foxglove_level, text) = describe_event(event);
    // foxglove.Log: 2 info, 3 warning.
    (if foxglove_level >= 3 { WARN } else { INFO }, text)
}

/// A `rover_power/msg/Sample` (see [`sample_definition`]).
fn encode_sample(stamp_ns: i64, s: &RunSample) -> Vec<u8> {
    let mut w = CdrWriter::new();
    write_stamp(&mut w, stamp_ns);
    let or_nan = |v: Option<f64>| v.unwrap_or(f64::NAN);
    for v in [
        s.bus_v.left,
        s.current_a.left,
        s.bus_v.right,
        s.current_a.right,
        s.cmd_mps.left,
        s.cmd_mps.right,
        or_nan(s.yaw_rad),
        or_nan(s.pitch_deg),
        or_nan(s.x_m),
        or_nan(s.y_m),
        s.t_s,
    ] {
        w.f64(v);
    }
    w.finish()
}

/// A `rover_power/msg/Sample` back into the sample it was written from ([`encode_sample`]): the
/// stamp is skipped (the run time is `t_s`), NaN is "not measured".
pub fn decode_sample(message: &[u8]) -> Result<RunSample, CdrError> {
    let mut r = CdrReader::new(message)?;
    r.i32("stamp.sec")?;
    r.u32("stamp.nanosec")?;
    let bus_left = r.f64("left_bus_v")?;
    let current_left = r.f64("left_current_a")?;
    let bus_right = r.f64("right_bus_v")?;
    let current_right = r.f64("right_current_a")?;
    let cmd_left = r.f64("cmd_left_mps")?;
    let cmd_right = r.f64("cmd_right_mps")?;
    let measured = |v: f64| (!v.is_nan()).then_some(v);
    let yaw_rad = measured(r.f64("yaw_rad")?);
    let pitch_deg = measured(r.f64("pitch_deg")?);
    let x_m = measured(r.f64("x_m")?);
    let y_m = measured(r.f64("y_m")?);
    Ok(RunSample {
        t_s: r.f64("t_s")?,
        bus_v: Sides::new(bus_left, bus_right),
        current_a: Sides::new(current_left, current_right),
        cmd_mps: Sides::new(cmd_left, cmd_right),
        yaw_rad,
        pitch_deg,
        x_m,
        y_m,
    })
}

/// A header stamp of a log time (a u64 beyond i64 is past the year 2262).
fn stamp_ns(log_time_ns: u64) -> i64 {
    i64::try_from(log_time_ns).unwrap_or(i64::MAX)
}

/// The bag's topics.
#[derive(Debug, Clone, Copy)]
enum Topic {
    Sample,
    CmdVel,
    Imu,
    TrackerPose,
    Rosout,
}

impl Topic {
    const COUNT: usize = 5;

    /// Name, type and definition.
    fn declaration(self) -> (&'static str, &'static str, String) {
        let std = |topic, ty: StdType| (topic, ty.name(), ty.definition());
        match self {
            Topic::Sample => (TOPIC_SAMPLE, SAMPLE_TYPE, sample_definition()),
            Topic::CmdVel => std(TOPIC_CMD_VEL, StdType::Twist),
            Topic::Imu => std(TOPIC_IMU, StdType::Imu),
            Topic::TrackerPose => std(TOPIC_TRACKER_POSE, StdType::PoseStamped),
            Topic::Rosout => std(TOPIC_ROSOUT, StdType::Log),
        }
    }
}

/// The writer, with each topic declared at its first message.
struct Bag {
    writer: BagWriter,
    channels: [Option<u16>; Topic::COUNT],
}

impl Bag {
    fn write(&mut self, topic: Topic, log_time_ns: u64, cdr: &[u8]) -> Result<(), BagWriteError> {
        let channel = match self.channels[topic as usize] {
            Some(channel) => channel,
            None => {
                let (name, ty, definition) = topic.declaration();
                let channel = self.writer.topic(name, ty, &definition)?;
                self.channels[topic as usize] = Some(channel);
                channel
            }
        };
        self.writer.write(channel, log_time_ns, cdr)
    }
}

#[cfg(test)]
mod tests;
