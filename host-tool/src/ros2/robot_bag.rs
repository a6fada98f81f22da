//! The robot's own bag of a drive, as a ROS 2 rover records it beside the board (`demo
//! --robot-bag`): the commanded twist on `/cmd_vel`, the IMU's orientation on `/imu/data` and the
//! tracker's pose on `/tracker/pose`, each stamped with the robot computer's clock.

use super::from_log::twist_of;
use super::msgs::{self, StdType};
use super::write::{BagWriteError, BagWriter};
use crate::log::commands::CommandRow;
use crate::out_dir::{write_dir_whole, OutDirError};
use model_core::Rover;
use std::path::Path;

/// The topics of a robot bag.
pub const CMD_TOPIC: &str = "/cmd_vel";
pub const IMU_TOPIC: &str = "/imu/data";
pub const POSE_TOPIC: &str = "/tracker/pose";

/// Messages written per topic: (twists, IMU, poses).
pub type RobotBagCounts = (usize, usize, usize);

/// Writes the bag directory `dir` (whole or not at all; replaced if `replace`) from the rows a
/// run's robot side sent (commanded side speeds, yaw, pitch, tracked position at run time
/// `t_s`). `unix_ns_at(t_s)` is the board log's wall clock; the robot's runs `clock_offset_s`
/// ahead of it.
pub fn write_robot_bag(
    dir: &Path,
    replace: bool,
    rows: &[CommandRow],
    rover: &Rover,
    unix_ns_at: impl Fn(f64) -> u64,
    clock_offset_s: f64,
) -> Result<RobotBagCounts, OutDirError<BagWriteError>> {
    let offset_ns = (clock_offset_s * 1e9).round() as i64;
    let stem = dir
        .file_name()
        .map_or("robot".into(), |n| n.to_string_lossy().into_owned());
    write_dir_whole(dir, replace, |staging| {
        let mut bag = BagWriter::create(staging, &stem)?;
        let cmd = bag.topic(
            CMD_TOPIC,
            StdType::Twist.name(),
            &StdType::Twist.definition(),
        )?;
        let imu = bag.topic(IMU_TOPIC, StdType::Imu.name(), &StdType::Imu.definition())?;
        let pose = bag.topic(
            POSE_TOPIC,
            StdType::PoseStamped.name(),
            &StdType::PoseStamped.definition(),
        )?;
        let mut counts = (0, 0, 0);
        let slip_track_m = f64::from(rover.slip_track_m);
        for row in rows {
            let ns = unix_ns_at(row.t_s).saturating_add_signed(offset_ns);
            let stamp = ns as i64;
            let (v, omega) = twist_of(row.cmd_mps, slip_track_m);
            bag.write(cmd, ns, &msgs::encode_twist(v, omega))?;
            counts.0 += 1;
            let q = row
                .yaw_rad
                .map(|yaw| msgs::quaternion_of(yaw, row.pitch_deg.unwrap_or(0.0)));
            if let Some(q) = q {
                bag.write(imu, ns, &msgs::encode_imu(stamp, "imu_link", q))?;
                counts.1 += 1;
            }
            if let (Some(x), Some(y)) = (row.x_m, row.y_m) {
                let q = q.unwrap_or([0.0, 0.0, 0.0, 1.0]);
                bag.write(
                    pose,
                    ns,
                    &msgs::encode_pose_stamped(stamp, "map", [x, y, 0.0], q),
                )?;
                counts.2 += 1;
            }
        }
        bag.finish(staging)?;
        Ok(counts)
    })
}
