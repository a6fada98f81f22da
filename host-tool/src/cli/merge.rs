//! `host-tool merge`: a board log and the robot's ROS 2 bag of the same drive, one run log.

use super::output::{self, check_new_file, create_parent};
use anyhow::{bail, Context, Result};
use host_tool::eprintln_best_effort;
use host_tool::log::convert::save_run;
use host_tool::log::load::load_run;
use host_tool::log::Existing;
use host_tool::merge::{merge, YawSource};
use host_tool::ros2::read::{read_bag, BagTopics};
use std::path::PathBuf;

/// `merge --board LOG --bag BAG --out RUN`.
#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// The board's run log (.mcap or .csv, with its wall-clock anchor, as `record` writes it).
    #[arg(long, value_name = "LOG")]
    board: PathBuf,
    /// The robot's rosbag2 bag of the same drive: its directory (with metadata.yaml) or its
    /// storage file. MCAP or sqlite3 storage, split or not, zstd or lz4 compressed or not; CDR.
    #[arg(long, value_name = "BAG")]
    bag: PathBuf,
    #[command(flatten)]
    rover: super::RoverArg,
    /// The merged run log to write (.mcap or .csv); written whole or not at all.
    #[arg(long)]
    out: PathBuf,
    /// Overwrite an existing output file.
    #[arg(long)]
    force: bool,
    /// The commanded twist (geometry_msgs/msg/Twist or TwistStamped): side speeds with the
    /// rover's controller slip track, V = v ∓ ω·B_s/2.
    #[arg(long, default_value = "/cmd_vel", value_name = "TOPIC")]
    cmd_topic: String,
    /// The IMU (sensor_msgs/msg/Imu): yaw and pitch from its orientation; an IMU without one
    /// (orientation_covariance[0] = -1, as raw drivers publish) gives yaw integrated from
    /// angular_velocity.z and no pitch. Left out when the bag has no such topic and this is the
    /// default; `none` leaves it out.
    #[arg(long, default_value = "/imu/data", value_name = "TOPIC")]
    imu_topic: String,
    /// The tracked point's pose (nav_msgs/msg/Odometry or geometry_msgs/msg/PoseStamped): x, y
    /// as position fixes, for the pose track (R_ACT, slip track).
    #[arg(long, value_name = "TOPIC")]
    pose_topic: Option<String>,
    /// How far apart the two computers' clocks may be [s]; the offset is measured within it.
    #[arg(long, default_value_t = 30.0, value_name = "S")]
    max_offset_s: f64,
}

impl MergeArgs {
    /// Merges and prints how the two logs were lined up.
    pub fn run(self) -> Result<()> {
        if !(self.max_offset_s.is_finite()
            && self.max_offset_s > 0.0
            && self.max_offset_s <= 3600.0)
        {
            bail!("--max-offset-s {} must be in (0, 3600]", self.max_offset_s);
        }
        let roles = [
            ("--cmd-topic", Some(&self.cmd_topic)),
            (
                "--imu-topic",
                Some(&self.imu_topic).filter(|t| *t != "none"),
            ),
            ("--pose-topic", self.pose_topic.as_ref()),
        ];
        for (i, (a, ta)) in roles.iter().enumerate() {
            for (b, tb) in &roles[i + 1..] {
                if let (Some(ta), Some(tb)) = (ta, tb) {
                    if ta == tb {
                        bail!("{a} and {b} both name {ta}: one topic cannot be two of the commanded twist, the IMU and the pose");
                    }
                }
            }
        }
        check_new_file(&self.out, self.force)?;
        let rover = self.rover.load()?.rover;
        let log = load_run(&self.board).map_err(|e| output::naming(&self.board, e))?;
        let imu = (self.imu_topic != "none")
            .then(|| (self.imu_topic.clone(), self.imu_topic == "/imu/data"));
        let topics = BagTopics {
            cmd: self.cmd_topic.clone(),
            imu,
            pose: self.pose_topic.clone(),
        };
        let bag = read_bag(&self.bag, &topics)?;
        let merged = merge(log, &bag, &rover, self.max_offset_s).with_context(|| {
            format!(
                "merging {} and {}",
                self.board.display(),
                self.bag.display()
            )
        })?;
        create_parent(&self.out)?;
        save_run(&self.out, Existing::from_force(self.force), &merged.log)
            .map_err(|e| output::naming(&self.out, e))?;

        let a = merged.alignment;
        let n = merged.log.samples.len();
        if bag.imu.is_empty() && topics.imu.is_some() {
            eprintln_best_effort!("note: the bag has no {}: no yaw or pitch", self.imu_topic);
        }
        if merged.yaw_source == YawSource::IntegratedRate {
            eprintln_best_effort!(
                "note: {} reports no orientation (orientation_covariance[0] = -1): yaw integrated from angular_velocity.z (it drifts with the gyro's bias), no pitch",
                self.imu_topic
            );
        }
        if a.overlap_s < 0.9 * a.board_s {
            eprintln_best_effort!(
                "warning: the bag covers {:.1} s of the board's {:.1} s run; samples outside keep the board log's values",
                a.overlap_s,
                a.board_s
            );
        }
        // Another offset leaving less than twice the misfit: the steps repeat at that rhythm.
        if let Some((lag, r2)) = a.runner_up.filter(|&(_, r2)| 1.0 - r2 < 2.0 * (1.0 - a.r2)) {
            eprintln_best_effort!(
                "warning: another offset fits almost as well ({lag:+.3} s, R² = {r2:.3}): a drive repeated at a steady rhythm; narrow --max-offset-s if the clocks are known to agree better"
            );
        }
        output::print(format_args!(
            "{} + {} -> {}: {n} samples\n  clock offset: the bag's clock is {:+.3} s ahead of the board log's at its start (the power steps where the commands do, {} steps: R² = {:.3}); {}\n  overlap: {:.1} s of the board's {:.1} s run\n  from the bag: commanded speeds on {} samples ({} twists on {}), yaw and pitch on {} ({}), {} position fixes{}\n",
            self.board.display(),
            bag.file.display(),
            self.out.display(),
            a.offset_s,
            a.steps,
            a.r2,
            if a.drift_measured {
                format!("drift {:+.0} ppm ({:+.1} ms over the overlap)", a.drift_ppm, a.drift_ppm * 1e-3 * a.overlap_s)
            } else {
                "drift not measured (too few steps in parts of the overlap)".to_owned()
            },
            a.overlap_s,
            a.board_s,
            merged.samples_with_cmd,
            bag.cmd.len(),
            self.cmd_topic,
            merged.samples_with_yaw,
            if bag.imu.is_empty() { "no IMU".to_owned() } else { self.imu_topic.clone() },
            merged.fixes,
            self.pose_topic.as_ref().map(|p| format!(" ({p})")).unwrap_or_default(),
        ))
    }
}
