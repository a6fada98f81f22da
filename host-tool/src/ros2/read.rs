//! Reads what `merge` needs from a robot's rosbag2 bag (MCAP storage, CDR): the commanded
//! twists, the IMU's orientation and the tracked pose, each at the bag's `log_time` (the
//! recording host's receive time, Unix ns).

use super::cdr::CdrError;
use super::msgs::{self, ImuMsg, PoseMsg, StdType, TwistMsg};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a bag could not be read.
#[derive(Debug, Error)]
pub enum BagReadError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: storage `{storage}` is not read here, only MCAP (`ros2 bag convert` rewrites a bag with `storage_id: mcap`; ROS 2 Iron and later record MCAP by default)", path.display())]
    Storage { path: PathBuf, storage: String },
    #[error("{}: no MCAP file in the bag directory (its metadata.yaml lists {listed:?})", path.display())]
    NoMcap { path: PathBuf, listed: Vec<String> },
    /// `what` is [`crate::mcap_damage::describe`]'s: `mcap`'s own text of a record that does
    /// not parse is a coloured backtrace.
    #[error("{}: not a readable MCAP file, damaged before byte {read_bytes} of {len}: {what}", path.display())]
    Mcap {
        path: PathBuf,
        /// How far the reader got: the damage is in the record read last.
        read_bytes: u64,
        len: u64,
        what: String,
    },
    #[error("{}: topic {topic} is not in the bag; it has: {}", path.display(), topics.join(", "))]
    NoTopic {
        path: PathBuf,
        topic: String,
        topics: Vec<String>,
    },
    #[error("{}: topic {topic} is `{found}` ({encoding}); {wanted} is needed", path.display())]
    WrongType {
        path: PathBuf,
        topic: String,
        found: String,
        encoding: String,
        wanted: String,
    },
    #[error("{}: topic {topic} claims `{type_name}` but its stored definition has other fields", path.display())]
    WrongDefinition {
        path: PathBuf,
        topic: String,
        type_name: String,
    },
    #[error("{}: message {index} on {topic} (log time {log_time_ns} ns): {source}", path.display())]
    Message {
        path: PathBuf,
        topic: String,
        index: usize,
        log_time_ns: u64,
        #[source]
        source: CdrError,
    },
}

/// The largest record read from a bag smaller than this (larger files: their size).
const MAX_RECORD_BYTES: usize = 64 << 20;

/// The topics to read; `None` leaves that part out.
#[derive(Debug, Clone)]
pub struct BagTopics {
    /// `Twist` or `TwistStamped`.
    pub cmd: String,
    /// `sensor_msgs/msg/Imu`; `optional`: absent from the bag is not an error.
    pub imu: Option<(String, bool)>,
    /// `nav_msgs/msg/Odometry` or `geometry_msgs/msg/PoseStamped`.
    pub pose: Option<String>,
}

/// What a robot's bag says about a drive, each message at its `log_time` [Unix ns].
#[derive(Debug, Clone, Default)]
pub struct RobotBag {
    /// The MCAP file read.
    pub file: PathBuf,
    pub cmd: Vec<(u64, TwistMsg)>,
    pub imu: Vec<(u64, ImuMsg)>,
    pub pose: Vec<(u64, PoseMsg)>,
    /// Every topic in the bag with its type, for messages.
    pub topics: Vec<(String, String)>,
}

/// The MCAP file of a bag: `path` itself, or the one its directory's `metadata.yaml` lists
/// (or the only `.mcap` in it).
pub fn bag_file(path: &Path) -> Result<PathBuf, BagReadError> {
    let io = |source| BagReadError::Io {
        path: path.to_owned(),
        source,
    };
    if !path.is_dir() {
        if path.extension().is_some_and(|e| e == "db3") {
            return Err(BagReadError::Storage {
                path: path.to_owned(),
                storage: "sqlite3".into(),
            });
        }
        std::fs::metadata(path).map_err(io)?;
        return Ok(path.to_owned());
    }
    let metadata = path.join("metadata.yaml");
    let mut listed = Vec::new();
    if metadata.exists() {
        let text = std::fs::read_to_string(&metadata).map_err(|source| BagReadError::Io {
            path: metadata.clone(),
            source,
        })?;
        if let Some(storage) = yaml_value(&text, "storage_identifier") {
            if storage != "mcap" {
                return Err(BagReadError::Storage {
                    path: path.to_owned(),
                    storage,
                });
            }
        }
        listed = yaml_list(&text, "relative_file_paths");
    }
    let mut candidates: Vec<PathBuf> = listed.iter().map(|f| path.join(f)).collect();
    if candidates.is_empty() {
        let entries = std::fs::read_dir(path).map_err(io)?;
        candidates = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
            .collect();
        candidates.sort();
    }
    match candidates.as_slice() {
        [one] if one.exists() => Ok(one.clone()),
        _ => Err(BagReadError::NoMcap {
            path: path.to_owned(),
            listed,
        }),
    }
}

/// `key: value` anywhere in a YAML text (the value unquoted).
fn yaml_value(text: &str, key: &str) -> Option<String> {
    text.lines().find_map(|l| {
        let rest = l.trim().strip_prefix(key)?.strip_prefix(':')?;
        Some(rest.trim().trim_matches(['"', '\'']).to_owned())
    })
}

/// The `- item` lines under `key:`.
fn yaml_list(text: &str, key: &str) -> Vec<String> {
    let mut lines = text.lines().skip_while(|l| l.trim() != format!("{key}:"));
    lines.next();
    lines
        .map_while(|l| l.trim().strip_prefix("- "))
        .map(|v| v.trim().trim_matches(['"', '\'']).to_owned())
        .collect()
}

/// Reads `topics` from the bag at `path` (a bag directory or its MCAP file).
pub fn read_bag(path: &Path, topics: &BagTopics) -> Result<RobotBag, BagReadError> {
    let file = bag_file(path)?;
    let bytes = std::fs::read(&file).map_err(|source| BagReadError::Io {
        path: file.clone(),
        source,
    })?;
    // `MessageStream` sets no record length limit: a damaged length inside a compressed chunk
    // made it allocate that many bytes (exabytes) and abort. Any record up to the file's size
    // (or 64 MiB, for highly compressible ones) still reads; chunk CRCs are checked.
    let options = ::mcap::sans_io::LinearReaderOptions::default()
        .with_record_length_limit(bytes.len().max(MAX_RECORD_BYTES))
        .with_validate_chunk_crcs(true);
    let mut unread = bytes.as_slice();
    let mut stream = ::mcap::io::MessageReader::new_with_options(&mut unread, options);
    let mut bag = RobotBag {
        file: file.clone(),
        ..RobotBag::default()
    };
    // Each topic's type is checked once, on its first message.
    let mut checked: Vec<(String, Option<StdType>)> = Vec::new();
    let wanted = |topic: &str| -> Option<(&'static [StdType], &'static str)> {
        if topic == topics.cmd {
            Some((
                &[StdType::Twist, StdType::TwistStamped],
                "geometry_msgs/msg/Twist or TwistStamped",
            ))
        } else if topics.imu.as_ref().is_some_and(|(t, _)| t == topic) {
            Some((&[StdType::Imu], "sensor_msgs/msg/Imu"))
        } else if topics.pose.as_deref() == Some(topic) {
            Some((
                &[StdType::Odometry, StdType::PoseStamped],
                "nav_msgs/msg/Odometry or geometry_msgs/msg/PoseStamped",
            ))
        } else {
            None
        }
    };
    while let Some(message) = stream.next() {
        let message = match message {
            Ok(m) => m,
            Err(e) => {
                let unread = stream.into_inner().len();
                return Err(BagReadError::Mcap {
                    path: file.clone(),
                    read_bytes: (bytes.len() - unread) as u64,
                    len: bytes.len() as u64,
                    what: crate::mcap_damage::describe(&e),
                });
            }
        };
        let channel = &message.channel;
        let topic = channel.topic.as_str();
        let ty = match checked.iter().find(|(t, _)| t == topic) {
            Some((_, ty)) => *ty,
            None => {
                let (name, encoding, definition) = match &channel.schema {
                    Some(s) => (
                        s.name.clone(),
                        s.encoding.clone(),
                        String::from_utf8_lossy(&s.data).into_owned(),
                    ),
                    None => (String::new(), String::new(), String::new()),
                };
                bag.topics.push((topic.to_owned(), name.clone()));
                let ty = match wanted(topic) {
                    None => None,
                    Some((types, wanted_name)) => {
                        let ty = StdType::named(&name)
                            .filter(|t| types.contains(t))
                            .filter(|_| channel.message_encoding == "cdr");
                        let Some(ty) = ty else {
                            return Err(BagReadError::WrongType {
                                path: file.clone(),
                                topic: topic.to_owned(),
                                found: name,
                                encoding: channel.message_encoding.clone(),
                                wanted: wanted_name.to_owned(),
                            });
                        };
                        if encoding == "ros2msg" && !ty.matches_definition(&definition) {
                            return Err(BagReadError::WrongDefinition {
                                path: file.clone(),
                                topic: topic.to_owned(),
                                type_name: name,
                            });
                        }
                        Some(ty)
                    }
                };
                checked.push((topic.to_owned(), ty));
                ty
            }
        };
        let Some(ty) = ty else { continue };
        let t = message.log_time;
        let fail = |index: usize, source| BagReadError::Message {
            path: file.clone(),
            topic: topic.to_owned(),
            index,
            log_time_ns: t,
            source,
        };
        match ty {
            StdType::Twist | StdType::TwistStamped => {
                let m =
                    msgs::decode_twist(ty, &message.data).map_err(|e| fail(bag.cmd.len(), e))?;
                bag.cmd.push((t, m));
            }
            StdType::Imu => {
                let m = msgs::decode_imu(&message.data).map_err(|e| fail(bag.imu.len(), e))?;
                bag.imu.push((t, m));
            }
            StdType::Odometry | StdType::PoseStamped => {
                let m =
                    msgs::decode_pose(ty, &message.data).map_err(|e| fail(bag.pose.len(), e))?;
                bag.pose.push((t, m));
            }
            StdType::Log => {}
        }
    }
    let names: Vec<String> = bag.topics.iter().map(|(t, _)| t.clone()).collect();
    let missing = |topic: &str| BagReadError::NoTopic {
        path: file.clone(),
        topic: topic.to_owned(),
        topics: names.clone(),
    };
    if bag.cmd.is_empty() {
        return Err(missing(&topics.cmd));
    }
    if let Some((imu, optional)) = &topics.imu {
        if bag.imu.is_empty() && !optional {
            return Err(missing(imu));
        }
    }
    if let Some(pose) = &topics.pose {
        if bag.pose.is_empty() {
            return Err(missing(pose));
        }
    }
    // MCAP files need not be in log-time order.
    bag.cmd.sort_by_key(|m| m.0);
    bag.imu.sort_by_key(|m| m.0);
    bag.pose.sort_by_key(|m| m.0);
    Ok(bag)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::commands::CommandRow;
    use crate::log::tests_support::TempDir;
    use model_core::{Rover, Sides};

    /// The robot bag's twists alone.
    fn cmd_only() -> BagTopics {
        BagTopics {
            cmd: crate::ros2::robot_bag::CMD_TOPIC.into(),
            imu: None,
            pose: None,
        }
    }

    /// A robot bag of `n` twists in `dir`; its MCAP file.
    fn robot_bag(dir: &TempDir, n: u32) -> PathBuf {
        let bag = dir.path().join("robot");
        let rows: Vec<CommandRow> = (0..n)
            .map(|i| CommandRow::new(f64::from(i) * 0.1, Sides::new(0.3, 0.4)))
            .collect();
        let unix_ns_at = |t_s: f64| 1_700_000_000_000_000_000 + (t_s * 1e9) as u64;
        crate::ros2::robot_bag::write_robot_bag(
            &bag,
            false,
            &rows,
            &Rover::HUSKY_A200,
            unix_ns_at,
            0.0,
        )
        .expect("bag");
        bag_file(&bag).expect("its MCAP file")
    }

    /// How the error reads on stderr (the whole chain).
    fn shown(e: BagReadError) -> String {
        crate::stderr::error_text(&anyhow::Error::new(e))
    }

    #[test]
    fn a_damaged_record_is_named_without_a_backtrace() {
        let dir = TempDir::new("bag-damaged-header");
        let file = robot_bag(&dir, 5);
        let mut bytes = std::fs::read(&file).expect("read");
        // The Header record (opcode 0x01 after the 8-byte magic, body from byte 17): its profile
        // string claims more bytes than the record holds.
        assert_eq!(bytes[8], 0x01);
        bytes[17..21].copy_from_slice(&0xffffu32.to_le_bytes());
        std::fs::write(&file, &bytes).expect("write");
        let text = shown(read_bag(&file, &cmd_only()).expect_err("damaged"));
        let header_end = 17 + u64::from_le_bytes(bytes[9..17].try_into().expect("8 bytes"));
        assert_eq!(
            text,
            format!(
                "{}: not a readable MCAP file, damaged before byte {header_end} of {}: the Header \
                 record's field `profile`: the record ends before this field does (a damaged length)",
                file.display(),
                bytes.len()
            )
        );
    }

    /// Every byte of a small bag flipped in turn: the read fails or succeeds, never aborts (a
    /// damaged length in a compressed chunk made `mcap`'s stream allocate exabytes), and every
    /// error names the file in plain words.
    #[test]
    fn any_flipped_byte_gives_a_plain_error_naming_the_file() {
        let dir = TempDir::new("bag-flipped");
        let file = robot_bag(&dir, 5);
        let good = std::fs::read(&file).expect("read");
        let name = file.display().to_string();
        for at in 0..good.len() {
            let mut bytes = good.clone();
            bytes[at] ^= 0xff;
            std::fs::write(&file, &bytes).expect("write");
            if let Err(e) = read_bag(&file, &cmd_only()) {
                let text = shown(e);
                assert!(text.starts_with(&name), "byte {at}: {text:?}");
                assert!(
                    !text.contains('\x1b') && !text.contains(".rs:") && !text.contains('\n'),
                    "byte {at}: {text:?}"
                );
            }
        }
    }

    #[test]
    fn metadata_yaml_names_storage_and_files() {
        let text = "rosbag2_bagfile_information:\n  version: 8\n  storage_identifier: mcap\n  relative_file_paths:\n    - drive_0.mcap\n  files:\n    - path: drive_0.mcap\n";
        assert_eq!(
            yaml_value(text, "storage_identifier").as_deref(),
            Some("mcap")
        );
        assert_eq!(yaml_list(text, "relative_file_paths"), vec!["drive_0.mcap"]);
    }
}
