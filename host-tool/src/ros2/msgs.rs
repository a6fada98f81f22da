//! The standard ROS 2 messages a rover's bag carries that `merge` reads and the bags we write
//! hold: their `ros2msg` definitions and their CDR layouts.
//!
//! A definition is written as rosbag2 and rosbags write it (rosbags' `generate_msgdef`, byte for
//! byte): the type's fields with package-qualified types, then each nested type after a line of
//! 80 `=` and `MSG: pkg/Type` — without `/msg/`, which Foxglove's parser cannot resolve.
//!
//! The layouts are those of the ROS 2 interfaces, unchanged since Foxy. A bag's stored definition
//! is checked against them field by field before a message is decoded, so a custom type that
//! merely shares a name is refused rather than misread.

use super::cdr::{CdrError, CdrReader, CdrWriter};
use std::fmt::Write as _;

/// `builtin_interfaces/Time` as a nested type: `(pkg/Type, definition)` as it follows `MSG:`
/// (and so the other nested types below).
pub const TIME: (&str, &str) = ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n");
const HEADER: (&str, &str) = (
    "std_msgs/Header",
    "builtin_interfaces/Time stamp\nstring frame_id\n",
);
const VECTOR3: (&str, &str) = ("geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n");
const POINT: (&str, &str) = ("geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n");
const QUATERNION: (&str, &str) = (
    "geometry_msgs/Quaternion",
    "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
);
const TWIST: (&str, &str) = (
    "geometry_msgs/Twist",
    "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n",
);
const POSE: (&str, &str) = (
    "geometry_msgs/Pose",
    "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n",
);
const POSE_WITH_COVARIANCE: (&str, &str) = (
    "geometry_msgs/PoseWithCovariance",
    "geometry_msgs/Pose pose\nfloat64[36] covariance\n",
);
const TWIST_WITH_COVARIANCE: (&str, &str) = (
    "geometry_msgs/TwistWithCovariance",
    "geometry_msgs/Twist twist\nfloat64[36] covariance\n",
);

/// A standard message type: its name and complete `ros2msg` definition.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StdType {
    Twist,
    TwistStamped,
    Imu,
    Odometry,
    PoseStamped,
    Log,
}

impl StdType {
    pub const ALL: [StdType; 6] = [
        StdType::Twist,
        StdType::TwistStamped,
        StdType::Imu,
        StdType::Odometry,
        StdType::PoseStamped,
        StdType::Log,
    ];

    /// `pkg/msg/Type`.
    pub fn name(self) -> &'static str {
        match self {
            StdType::Twist => "geometry_msgs/msg/Twist",
            StdType::TwistStamped => "geometry_msgs/msg/TwistStamped",
            StdType::Imu => "sensor_msgs/msg/Imu",
            StdType::Odometry => "nav_msgs/msg/Odometry",
            StdType::PoseStamped => "geometry_msgs/msg/PoseStamped",
            StdType::Log => "rcl_interfaces/msg/Log",
        }
    }

    /// The type named `name` (`pkg/msg/Type`, or ROS 1 style `pkg/Type`).
    pub fn named(name: &str) -> Option<StdType> {
        StdType::ALL
            .into_iter()
            .find(|t| t.name() == name || t.name().replace("/msg/", "/") == name)
    }

    /// The top-level definition, then the nested ones in the order rosbags writes them (depth
    /// first, each once).
    fn parts(self) -> (&'static str, &'static [(&'static str, &'static str)]) {
        match self {
            StdType::Twist => (TWIST.1, &[VECTOR3]),
            StdType::TwistStamped => (
                "std_msgs/Header header\ngeometry_msgs/Twist twist\n",
                &[HEADER, TIME, TWIST, VECTOR3],
            ),
            StdType::Imu => (
                "std_msgs/Header header\n\
                 geometry_msgs/Quaternion orientation\n\
                 float64[9] orientation_covariance\n\
                 geometry_msgs/Vector3 angular_velocity\n\
                 float64[9] angular_velocity_covariance\n\
                 geometry_msgs/Vector3 linear_acceleration\n\
                 float64[9] linear_acceleration_covariance\n",
                &[HEADER, TIME, QUATERNION, VECTOR3],
            ),
            StdType::Odometry => (
                "std_msgs/Header header\n\
                 string child_frame_id\n\
                 geometry_msgs/PoseWithCovariance pose\n\
                 geometry_msgs/TwistWithCovariance twist\n",
                &[
                    HEADER,
                    TIME,
                    POSE_WITH_COVARIANCE,
                    POSE,
                    POINT,
                    QUATERNION,
                    TWIST_WITH_COVARIANCE,
                    TWIST,
                    VECTOR3,
                ],
            ),
            StdType::PoseStamped => (
                "std_msgs/Header header\ngeometry_msgs/Pose pose\n",
                &[HEADER, TIME, POSE, POINT, QUATERNION],
            ),
            StdType::Log => (
                "byte DEBUG=10\nbyte INFO=20\nbyte WARN=30\nbyte ERROR=40\nbyte FATAL=50\n\
                 builtin_interfaces/Time stamp\n\
                 uint8 level\n\
                 string name\n\
                 string msg\n\
                 string file\n\
                 string function\n\
                 uint32 line\n",
                &[TIME],
            ),
        }
    }

    /// The complete `ros2msg` definition, as a bag stores it.
    pub fn definition(self) -> String {
        let (top, nested) = self.parts();
        complete_definition(top, nested)
    }

    /// Whether a bag's stored definition has this type's fields (names, in order, at the top
    /// level; comments, constants and type spellings aside: `MSG: std_msgs/Header` as rosbag2
    /// writes it and `MSG: std_msgs/msg/Header` as this tool once did both match). An empty
    /// definition (a bag written without them) is taken on the name alone.
    pub fn matches_definition(self, stored: &str) -> bool {
        stored.trim().is_empty() || field_names(stored) == field_names(self.parts().0)
    }
}

/// `top`, then each `(pkg/Type, definition)` after the `ros2msg` delimiter.
pub fn complete_definition(top: &str, nested: &[(&str, &str)]) -> String {
    let mut text = top.to_string();
    for (name, definition) in nested {
        let _ = write!(text, "{}\nMSG: {name}\n{definition}", "=".repeat(80));
    }
    text
}

/// The field names of a definition's top-level part (constants and comments skipped).
fn field_names(definition: &str) -> Vec<&str> {
    definition
        .split(&"=".repeat(80))
        .next()
        .unwrap_or("")
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty() && !l.contains('='))
        .filter_map(|l| l.split_whitespace().nth(1))
        .collect()
}

/// A header stamp [ns since the Unix epoch] and the linear and angular velocity of a twist.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwistMsg {
    pub stamp_ns: Option<i64>,
    /// Forward speed [m/s] (`linear.x`).
    pub linear_x: f64,
    /// Yaw rate [rad/s], counter-clockwise positive (`angular.z`).
    pub angular_z: f64,
}

/// What `merge` takes from an IMU message: its stamp and orientation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuMsg {
    pub stamp_ns: i64,
    /// Orientation quaternion (x, y, z, w).
    pub orientation: [f64; 4],
    /// Whether the IMU reports an orientation: REP 145 says a driver without one sets
    /// `orientation_covariance[0]` to -1 (most raw IMU drivers, `/imu/data_raw`); a zero
    /// quaternion is no orientation either.
    pub orientation_known: bool,
    /// `angular_velocity.z` [rad/s], `None` when its covariance says it is not reported.
    pub yaw_rate_rad_s: Option<f64>,
}

/// What `merge` takes from a pose (Odometry or PoseStamped): its stamp and position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseMsg {
    pub stamp_ns: i64,
    pub x_m: f64,
    pub y_m: f64,
    /// Orientation quaternion (x, y, z, w).
    pub orientation: [f64; 4],
}

fn stamp(r: &mut CdrReader<'_>) -> Result<i64, CdrError> {
    let sec = r.i32("header.stamp.sec")?;
    let nanosec = r.u32("header.stamp.nanosec")?;
    Ok(i64::from(sec) * 1_000_000_000 + i64::from(nanosec))
}

fn header(r: &mut CdrReader<'_>) -> Result<i64, CdrError> {
    let ns = stamp(r)?;
    r.string("header.frame_id")?;
    Ok(ns)
}

fn vector3(r: &mut CdrReader<'_>, field: &'static str) -> Result<[f64; 3], CdrError> {
    Ok([r.f64(field)?, r.f64(field)?, r.f64(field)?])
}

fn quaternion(r: &mut CdrReader<'_>, field: &'static str) -> Result<[f64; 4], CdrError> {
    Ok([r.f64(field)?, r.f64(field)?, r.f64(field)?, r.f64(field)?])
}

/// Decodes a `Twist` or `TwistStamped`.
pub fn decode_twist(ty: StdType, message: &[u8]) -> Result<TwistMsg, CdrError> {
    let mut r = CdrReader::new(message)?;
    let stamp_ns = match ty {
        StdType::TwistStamped => Some(header(&mut r)?),
        _ => None,
    };
    let linear = vector3(&mut r, "linear")?;
    let angular = vector3(&mut r, "angular")?;
    Ok(TwistMsg {
        stamp_ns,
        linear_x: linear[0],
        angular_z: angular[2],
    })
}

/// Decodes a `sensor_msgs/msg/Imu`'s stamp and orientation.
pub fn decode_imu(message: &[u8]) -> Result<ImuMsg, CdrError> {
    let mut r = CdrReader::new(message)?;
    let stamp_ns = header(&mut r)?;
    let orientation = quaternion(&mut r, "orientation")?;
    let orientation_unset = r.f64("orientation_covariance")? == -1.0;
    r.skip_f64s(8, "orientation_covariance")?;
    let rate = vector3(&mut r, "angular_velocity")?;
    let rate_unset = r.f64("angular_velocity_covariance")? == -1.0;
    let norm = orientation.iter().map(|q| q * q).sum::<f64>().sqrt();
    Ok(ImuMsg {
        stamp_ns,
        orientation,
        orientation_known: !orientation_unset && norm > 0.5,
        yaw_rate_rad_s: (!rate_unset && rate[2].is_finite()).then_some(rate[2]),
    })
}

/// Decodes an `Odometry`'s or a `PoseStamped`'s stamp and pose.
pub fn decode_pose(ty: StdType, message: &[u8]) -> Result<PoseMsg, CdrError> {
    let mut r = CdrReader::new(message)?;
    let stamp_ns = header(&mut r)?;
    if ty == StdType::Odometry {
        r.string("child_frame_id")?;
    }
    let position = vector3(&mut r, "pose.position")?;
    let orientation = quaternion(&mut r, "pose.orientation")?;
    Ok(PoseMsg {
        stamp_ns,
        x_m: position[0],
        y_m: position[1],
        orientation,
    })
}

/// A `builtin_interfaces/msg/Time` of `ns` since the Unix epoch (seconds saturate at i32).
pub fn write_stamp(w: &mut CdrWriter, ns: i64) {
    let sec = ns.div_euclid(1_000_000_000);
    w.i32(i32::try_from(sec).unwrap_or(i32::MAX))
        .u32(ns.rem_euclid(1_000_000_000) as u32);
}

fn write_header(w: &mut CdrWriter, ns: i64, frame_id: &str) {
    write_stamp(w, ns);
    w.string(frame_id);
}

/// A `geometry_msgs/msg/Twist`.
pub fn encode_twist(linear_x: f64, angular_z: f64) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.f64(linear_x)
        .f64(0.0)
        .f64(0.0)
        .f64(0.0)
        .f64(0.0)
        .f64(angular_z);
    w.finish()
}

/// A `sensor_msgs/msg/Imu` with only its orientation known (the other covariances' first
/// element −1, the ROS convention for "not provided").
pub fn encode_imu(stamp_ns: i64, frame_id: &str, orientation: [f64; 4]) -> Vec<u8> {
    let mut w = CdrWriter::new();
    write_header(&mut w, stamp_ns, frame_id);
    for q in orientation {
        w.f64(q);
    }
    for _ in 0..9 {
        w.f64(0.0);
    }
    for _ in 0..2 {
        w.f64(0.0).f64(0.0).f64(0.0);
        w.f64(-1.0);
        for _ in 0..8 {
            w.f64(0.0);
        }
    }
    w.finish()
}

/// A `geometry_msgs/msg/PoseStamped`.
pub fn encode_pose_stamped(
    stamp_ns: i64,
    frame_id: &str,
    position: [f64; 3],
    orientation: [f64; 4],
) -> Vec<u8> {
    let mut w = CdrWriter::new();
    write_header(&mut w, stamp_ns, frame_id);
    for p in position {
        w.f64(p);
    }
    for q in orientation {
        w.f64(q);
    }
    w.finish()
}

/// An `rcl_interfaces/msg/Log`.
pub fn encode_log(stamp_ns: i64, level: u8, name: &str, msg: &str) -> Vec<u8> {
    let mut w = CdrWriter::new();
    write_stamp(&mut w, stamp_ns);
    w.u8(level)
        .string(name)
        .string(msg)
        .string("")
        .string("")
        .u32(0);
    w.finish()
}

/// Yaw [rad] and pitch [deg, nose up positive] of an orientation quaternion (x, y, z, w) in
/// ROS's z-up frame (REP 103: x forward, y left; a nose-up pitch is a negative rotation about y).
pub fn yaw_pitch_of(q: [f64; 4]) -> (f64, f64) {
    let [x, y, z, w] = q;
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    let sin_pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0);
    (yaw, -sin_pitch.asin().to_degrees())
}

/// The orientation quaternion (x, y, z, w) of yaw [rad] and pitch [deg, nose up positive]
/// (no roll); the inverse of [`yaw_pitch_of`].
pub fn quaternion_of(yaw_rad: f64, pitch_deg: f64) -> [f64; 4] {
    let (sy, cy) = (yaw_rad / 2.0).sin_cos();
    let (sp, cp) = (-pitch_deg.to_radians() / 2.0).sin_cos();
    [-sy * sp, cy * sp, sy * cp, cy * cp]
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn yaw_and_pitch_round_trip_through_the_quaternion() {
        for (yaw, pitch) in [(0.0, 0.0), (1.2, 5.0), (-2.9, -12.0), (3.1, 30.0)] {
            let (y, p) = yaw_pitch_of(quaternion_of(yaw, pitch));
            assert!(
                (y - yaw).abs() < 1e-12 && (p - pitch).abs() < 1e-9,
                "{y} {p}"
            );
        }
        // A nose-up pitch is a negative rotation about y (REP 103).
        assert!(quaternion_of(0.0, 10.0)[1] < 0.0);
    }

    #[test]
    fn messages_decode_as_they_were_encoded() {
        let t = decode_twist(StdType::Twist, &encode_twist(0.3, -0.5)).expect("test value");
        assert_eq!((t.linear_x, t.angular_z, t.stamp_ns), (0.3, -0.5, None));
        let q = quaternion_of(0.7, 3.0);
        let imu =
            decode_imu(&encode_imu(1_700_000_000_123_456_789, "imu_link", q)).expect("test value");
        assert_eq!(
            (imu.stamp_ns, imu.orientation),
            (1_700_000_000_123_456_789, q)
        );
        let pose = decode_pose(
            StdType::PoseStamped,
            &encode_pose_stamped(5, "map", [1.5, -2.0, 0.0], q),
        )
        .expect("test value");
        assert_eq!((pose.stamp_ns, pose.x_m, pose.y_m), (5, 1.5, -2.0));
    }

    #[test]
    fn stored_definitions_are_checked_field_by_field() {
        for ty in StdType::ALL {
            assert!(ty.matches_definition(&ty.definition()), "{ty:?}");
            assert_eq!(StdType::named(ty.name()), Some(ty));
        }
        // A ROS 2 Imu with comments and other spellings still matches; a custom one does not.
        let stored = "# IMU\nstd_msgs/msg/Header header # stamp\n\ngeometry_msgs/msg/Quaternion orientation\n\
                      float64[9] orientation_covariance\ngeometry_msgs/msg/Vector3 angular_velocity\n\
                      float64[9] angular_velocity_covariance\ngeometry_msgs/msg/Vector3 linear_acceleration\n\
                      float64[9] linear_acceleration_covariance\n";
        assert!(StdType::Imu.matches_definition(stored));
        assert!(!StdType::Imu.matches_definition("float64 yaw\nfloat64 pitch\n"));
        // The form this tool wrote before (`MSG: pkg/msg/Type`, types relative to the package)
        // still reads.
        let old = format!(
            "std_msgs/Header header\nPose pose\n{}\nMSG: std_msgs/msg/Header\n\
             builtin_interfaces/Time stamp\nstring frame_id\n",
            "=".repeat(80)
        );
        assert!(StdType::PoseStamped.matches_definition(&old));
        assert_eq!(StdType::named("sensor_msgs/Imu"), Some(StdType::Imu));
    }

    /// rosbags 0.11.9's `generate_msgdef("sensor_msgs/msg/Imu", ros_version=2)`, as rosbag2
    /// stores it: the form Foxglove's parser resolves.
    const ROSBAGS_IMU: &str = "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n\
        float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n\
        float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n\
        float64[9] linear_acceleration_covariance\n\
        ================================================================================\n\
        MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n\
        ================================================================================\n\
        MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n\
        ================================================================================\n\
        MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n\
        ================================================================================\n\
        MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";

    #[test]
    fn definitions_are_written_as_rosbag2_writes_them() {
        assert_eq!(StdType::Imu.definition(), ROSBAGS_IMU);
        for ty in StdType::ALL {
            assert_eq!(
                unresolved_types(&ty.definition()),
                Vec::<String>::new(),
                "{ty:?}"
            );
        }
        // The check finds what Foxglove rejected: a `/msg/` separator, a relative type.
        let old = format!(
            "std_msgs/Header header\nPose pose\n{}\nMSG: std_msgs/msg/Header\nint32 a\n",
            "=".repeat(80)
        );
        assert_eq!(
            unresolved_types(&old),
            ["std_msgs/Header", "Pose", "MSG: std_msgs/msg/Header"]
        );
    }

    /// What Foxglove's parser would fail to resolve in `definition` (a field type that is not a
    /// primitive and has no `MSG: pkg/Type` section of its exact name, or a section named
    /// with `/msg/`), in the order found.
    pub(crate) fn unresolved_types(definition: &str) -> Vec<String> {
        const PRIMITIVES: [&str; 17] = [
            "bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
            "uint64", "float32", "float64", "string", "wstring", "time", "duration",
        ];
        let sections: Vec<&str> = definition.split(&"=".repeat(80)).collect();
        let names: Vec<&str> = sections[1..]
            .iter()
            .filter_map(|s| s.trim_start().lines().next()?.strip_prefix("MSG: "))
            .collect();
        let mut unresolved = Vec::new();
        for section in &sections {
            for line in section.lines() {
                let line = line.split('#').next().unwrap_or("").trim();
                if line.is_empty() || line.starts_with("MSG: ") || line.contains('=') {
                    continue;
                }
                let ty = line.split_whitespace().next().unwrap_or("");
                let base = ty.split(['[', '<']).next().unwrap_or("");
                let resolved = PRIMITIVES.contains(&base) || names.contains(&base);
                if !resolved && !unresolved.iter().any(|u| u == base) {
                    unresolved.push(base.to_owned());
                }
            }
        }
        let separators = names.iter().filter(|n| n.contains("/msg/"));
        unresolved.extend(separators.map(|n| format!("MSG: {n}")));
        unresolved
    }
}
