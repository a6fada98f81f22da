//! Writes a rosbag2 bag: a directory holding `metadata.yaml` and one MCAP file with the `ros2`
//! profile, CDR messages and `ros2msg` schemas, as `ros2 bag record -s mcap` writes it. The
//! directory is written whole or not at all ([`crate::out_dir`]).

use ::mcap::records::MessageHeader;
use ::mcap::{Compression, WriteOptions, Writer};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a bag was not written.
#[derive(Debug, Error)]
pub enum BagWriteError {
    #[error(transparent)]
    Mcap(#[from] ::mcap::McapError),
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// The QoS offered on every topic, as `ros2 bag record` (Humble to Jazzy) stores a publisher's:
/// reliable (1), volatile (2), automatic liveliness (1), infinite deadline and lifespan; history
/// and depth are not part of an offer (3 = unknown, 0). rosbags matches a topic of
/// `metadata.yaml` to its MCAP channel by this profile too, so both hold the same text.
const QOS: &str = "- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n  deadline:\n    sec: 9223372036\n    nsec: 854775807\n  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n  avoid_ros_namespace_conventions: false";

struct Topic {
    channel: u16,
    name: String,
    type_name: String,
    count: u64,
}

/// A bag being written into a staging directory; [`BagWriter::finish`] completes it.
pub struct BagWriter {
    writer: Writer<BufWriter<File>>,
    file_name: String,
    topics: Vec<Topic>,
    schemas: BTreeMap<String, u16>,
    time_ns: Option<(u64, u64)>,
    sequence: u32,
}

impl std::fmt::Debug for BagWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BagWriter")
            .field("file_name", &self.file_name)
            .field("topics", &self.topics.len())
            .finish_non_exhaustive()
    }
}

impl BagWriter {
    /// Starts a bag whose MCAP file is `dir`/`stem`_0.mcap (`dir` is the staging directory of
    /// [`crate::out_dir::write_dir_whole`], or any empty directory).
    pub fn create(dir: &Path, stem: &str) -> Result<Self, BagWriteError> {
        let file_name = format!("{stem}_0.mcap");
        let options = WriteOptions::new()
            .profile("ros2")
            .library(format!(
                "rover-power host-tool {}",
                env!("CARGO_PKG_VERSION")
            ))
            .compression(Some(Compression::Zstd))
            .compression_threads(0);
        let file = BufWriter::new(File::create(dir.join(&file_name))?);
        Ok(Self {
            writer: Writer::with_options(file, options)?,
            file_name,
            topics: Vec::new(),
            schemas: BTreeMap::new(),
            time_ns: None,
            sequence: 0,
        })
    }

    /// Declares `topic` of type `type_name` (`pkg/msg/Type`) with its complete `ros2msg`
    /// definition; returns the channel to write its messages on.
    pub fn topic(
        &mut self,
        topic: &str,
        type_name: &str,
        definition: &str,
    ) -> Result<u16, BagWriteError> {
        let schema = match self.schemas.get(type_name) {
            Some(&id) => id,
            None => {
                let id = self
                    .writer
                    .add_schema(type_name, "ros2msg", definition.as_bytes())?;
                self.schemas.insert(type_name.to_owned(), id);
                id
            }
        };
        let metadata = BTreeMap::from([("offered_qos_profiles".to_owned(), QOS.to_owned())]);
        let channel = self.writer.add_channel(schema, topic, "cdr", &metadata)?;
        // The mcap crate numbers channels from 1 and returns the same id for a topic declared
        // twice: the topics are found by id, not position.
        if !self.topics.iter().any(|t| t.channel == channel) {
            self.topics.push(Topic {
                channel,
                name: topic.to_owned(),
                type_name: type_name.to_owned(),
                count: 0,
            });
        }
        Ok(channel)
    }

    /// Writes one CDR message on `channel`, received at Unix time `log_time_ns`.
    pub fn write(
        &mut self,
        channel: u16,
        log_time_ns: u64,
        cdr: &[u8],
    ) -> Result<(), BagWriteError> {
        self.sequence = self.sequence.wrapping_add(1);
        self.writer.write_to_known_channel(
            &MessageHeader {
                channel_id: channel,
                sequence: self.sequence,
                log_time: log_time_ns,
                publish_time: log_time_ns,
            },
            cdr,
        )?;
        if let Some(topic) = self.topics.iter_mut().find(|t| t.channel == channel) {
            topic.count += 1;
        }
        self.time_ns = Some(match self.time_ns {
            None => (log_time_ns, log_time_ns),
            Some((a, b)) => (a.min(log_time_ns), b.max(log_time_ns)),
        });
        Ok(())
    }

    /// Messages written so far per topic, in the order the topics were declared.
    pub fn message_counts(&self) -> Vec<(&str, u64)> {
        self.topics
            .iter()
            .map(|t| (t.name.as_str(), t.count))
            .collect()
    }

    /// Finishes the MCAP file (synced to disk) and writes `metadata.yaml` beside it (rosbag2
    /// format version 8, as Jazzy writes it); returns the MCAP file's path.
    pub fn finish(mut self, dir: &Path) -> Result<PathBuf, BagWriteError> {
        self.writer.finish()?;
        let yaml = self.metadata_yaml();
        let path = dir.join(&self.file_name);
        let file = self
            .writer
            .into_inner()
            .into_inner()
            .map_err(|e| e.into_error())?;
        file.sync_all()?;
        std::fs::write(dir.join("metadata.yaml"), yaml)?;
        Ok(path)
    }

    /// rosbag2's `metadata.yaml`: version 8 keeps each topic's `offered_qos_profiles` as a YAML
    /// document inside a string.
    fn metadata_yaml(&self) -> String {
        let (start, end) = self.time_ns.unwrap_or((0, 0));
        let duration = end - start;
        let total: u64 = self.topics.iter().map(|t| t.count).sum();
        let mut yaml = format!(
            "rosbag2_bagfile_information:\n  version: 8\n  storage_identifier: mcap\n  \
             duration:\n    nanoseconds: {duration}\n  starting_time:\n    \
             nanoseconds_since_epoch: {start}\n  message_count: {total}\n  \
             topics_with_message_count:\n"
        );
        for t in &self.topics {
            let _ = write!(
                yaml,
                "    - topic_metadata:\n        name: {}\n        type: {}\n        \
                 serialization_format: cdr\n        offered_qos_profiles: {}\n        \
                 type_description_hash: \"\"\n      message_count: {}\n",
                yaml_string(&t.name),
                yaml_string(&t.type_name),
                yaml_string(QOS),
                t.count
            );
        }
        let _ = write!(
            yaml,
            "  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n    \
             - {file}\n  files:\n    - path: {file}\n      starting_time:\n        \
             nanoseconds_since_epoch: {start}\n      duration:\n        nanoseconds: {duration}\n      \
             message_count: {total}\n  custom_data: ~\n  ros_distro: \"\"\n",
            file = yaml_string(&self.file_name)
        );
        yaml
    }
}

/// `text` as a double-quoted YAML scalar (topic names, types and file names hold no characters
/// that need it today, but a plain scalar would misread one starting with `-`, `&` or `*`).
fn yaml_string(text: &str) -> String {
    let mut quoted = String::with_capacity(text.len() + 2);
    quoted.push('"');
    for c in text.chars() {
        match c {
            '"' => quoted.push_str("\\\""),
            '\\' => quoted.push_str("\\\\"),
            '\n' => quoted.push_str("\\n"),
            c if c.is_control() => {
                let _ = write!(quoted, "\\u{:04x}", u32::from(c));
            }
            c => quoted.push(c),
        }
    }
    quoted.push('"');
    quoted
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::tests_support::TempDir;
    use crate::ros2::msgs::{encode_twist, StdType};

    #[test]
    fn counts_follow_the_channels_and_metadata_spans_the_messages() {
        let dir = TempDir::new("bag-write");
        let mut bag = BagWriter::create(dir.path(), "b").expect("create");
        let twist = StdType::Twist;
        let a = bag
            .topic("/a", twist.name(), &twist.definition())
            .expect("a");
        let b = bag
            .topic("/b", twist.name(), &twist.definition())
            .expect("b");
        // The mcap crate numbers channels from 1 and gives a re-declared topic its channel.
        assert_eq!(
            bag.topic("/a", twist.name(), &twist.definition())
                .expect("again"),
            a
        );
        for (channel, t) in [(b, 30), (a, 10), (b, 20)] {
            bag.write(channel, t, &encode_twist(0.1, 0.2))
                .expect("write");
        }
        assert_eq!(bag.message_counts(), [("/a", 1), ("/b", 2)]);
        let mcap = bag.finish(dir.path()).expect("finish");
        assert_eq!(mcap, dir.path().join("b_0.mcap"));
        let yaml = std::fs::read_to_string(dir.path().join("metadata.yaml")).expect("yaml");
        assert!(yaml.contains("  duration:\n    nanoseconds: 20\n  starting_time:\n    nanoseconds_since_epoch: 10\n  message_count: 3\n"), "{yaml}");
        assert!(yaml.contains("name: \"/a\"\n        type: \"geometry_msgs/msg/Twist\"\n        serialization_format: cdr\n        offered_qos_profiles: \"- history: 3\\n  depth: 0\\n"), "{yaml}");
        assert_eq!(yaml_string("a\"b\\c\nd\u{1}"), "\"a\\\"b\\\\c\\nd\\u0001\"");
    }
}
