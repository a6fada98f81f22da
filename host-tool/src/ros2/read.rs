//! Reads what `merge` needs from a robot's rosbag2 bag (MCAP or sqlite3 storage, CDR, split
//! into several files or not, compressed per message or per file with zstd or lz4): the
//! commanded twists, the IMU's orientation and the tracked pose, each at the bag's `log_time`
//! (the recording host's receive time, Unix ns).

use super::cdr::CdrError;
use super::layout::{self, BagFile, Compression, MessageCompression, Storage};
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
    #[error("{}: storage `{storage}` is not read here, only MCAP and sqlite3 (`ros2 bag convert` rewrites a bag with `storage_id: mcap`)", path.display())]
    Storage { path: PathBuf, storage: String },
    #[error("{}: compression mode `{mode}` with format `{format}` is not read here, only none, and `message` or `file` with `zstd` or `lz4`", path.display())]
    Compression {
        path: PathBuf,
        mode: String,
        format: String,
    },
    #[error("{}: its metadata.yaml lists {listed:?}, but {missing:?} is not in the bag directory", path.display())]
    MissingFiles {
        path: PathBuf,
        missing: Vec<String>,
        listed: Vec<String>,
    },
    #[error("{}: no metadata.yaml listing its files, and not one MCAP or .db3 file in the bag directory (found {found:?})", path.display())]
    NoStorageFile { path: PathBuf, found: Vec<String> },
    /// A storage file compressed whole (`compression_mode: file`) that does not decompress.
    #[error("{}: {what}", path.display())]
    CompressedFile { path: PathBuf, what: String },
    /// `what` is [`crate::mcap_damage::describe`]'s: `mcap`'s own text of a record that does
    /// not parse is a coloured backtrace.
    #[error("{}: not a readable MCAP file, damaged before byte {read_bytes} of {len}{}: {what}", path.display(), if *decompressed { " (decompressed)" } else { "" })]
    Mcap {
        path: PathBuf,
        /// How far the reader got: the damage is in the record read last.
        read_bytes: u64,
        len: u64,
        decompressed: bool,
        what: String,
    },
    /// `what` is SQLite's own sentence ("database disk image is malformed").
    #[error("{}: not a readable sqlite3 bag{}: {what}", path.display(), if *decompressed { " (decompressed)" } else { "" })]
    Sqlite {
        path: PathBuf,
        decompressed: bool,
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
    /// A message compressed on its own (`compression_mode: message`) that does not decompress.
    #[error("{}: message {index} on {topic} (log time {log_time_ns} ns): {what}", path.display())]
    CompressedMessage {
        path: PathBuf,
        topic: String,
        index: usize,
        log_time_ns: u64,
        what: String,
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
    /// The storage file read, or the bag directory when it has several.
    pub file: PathBuf,
    pub cmd: Vec<(u64, TwistMsg)>,
    pub imu: Vec<(u64, ImuMsg)>,
    pub pose: Vec<(u64, PoseMsg)>,
    /// Every topic in the bag with its type, for messages.
    pub topics: Vec<(String, String)>,
}

/// The storage file of a one-file bag: `path` itself, or the one its directory's
/// `metadata.yaml` lists (or the only storage file in it).
pub fn bag_file(path: &Path) -> Result<PathBuf, BagReadError> {
    let mut files = layout::bag_files(path)?;
    match files.len() {
        1 => Ok(files.remove(0).path),
        _ => Err(BagReadError::NoStorageFile {
            path: path.to_owned(),
            found: files.iter().map(layout::BagFile::name).collect(),
        }),
    }
}

/// A topic as its storage describes it, for the type check on its first message.
struct Channel {
    type_name: String,
    message_encoding: String,
    /// `ros2msg`, `ros2idl`, or empty when the bag stores no definition.
    definition_encoding: String,
    definition: String,
}

/// The messages of the wanted topics, gathered file by file.
struct Gather<'a> {
    topics: &'a BagTopics,
    bag: RobotBag,
    /// Each topic's type, checked once on its first message.
    checked: Vec<(String, Option<StdType>)>,
}

impl Gather<'_> {
    /// The type `topic` is decoded as (`None`: not wanted), checking it on its first message.
    fn type_of(
        &mut self,
        file: &Path,
        topic: &str,
        channel: impl FnOnce() -> Channel,
    ) -> Result<Option<StdType>, BagReadError> {
        if let Some((_, ty)) = self.checked.iter().find(|(t, _)| t == topic) {
            return Ok(*ty);
        }
        let channel = channel();
        self.bag
            .topics
            .push((topic.to_owned(), channel.type_name.clone()));
        let ty = match self.wanted(topic) {
            None => None,
            Some((types, wanted_name)) => {
                let ty = StdType::named(&channel.type_name)
                    .filter(|t| types.contains(t))
                    .filter(|_| channel.message_encoding == "cdr");
                let Some(ty) = ty else {
                    return Err(BagReadError::WrongType {
                        path: file.to_owned(),
                        topic: topic.to_owned(),
                        found: channel.type_name,
                        encoding: channel.message_encoding,
                        wanted: wanted_name.to_owned(),
                    });
                };
                // sqlite3 bags before Iron store no definition: the type name check alone.
                if channel.definition_encoding == "ros2msg"
                    && !ty.matches_definition(&channel.definition)
                {
                    return Err(BagReadError::WrongDefinition {
                        path: file.to_owned(),
                        topic: topic.to_owned(),
                        type_name: channel.type_name,
                    });
                }
                Some(ty)
            }
        };
        self.checked.push((topic.to_owned(), ty));
        Ok(ty)
    }

    fn wanted(&self, topic: &str) -> Option<(&'static [StdType], &'static str)> {
        let topics = self.topics;
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
    }

    /// Decodes one message of `topic` (of type `ty`) at log time `t`.
    fn message(
        &mut self,
        file: &BagFile,
        topic: &str,
        ty: StdType,
        t: u64,
        data: &[u8],
    ) -> Result<(), BagReadError> {
        let index = match ty {
            StdType::Twist | StdType::TwistStamped => self.bag.cmd.len(),
            StdType::Imu => self.bag.imu.len(),
            StdType::Odometry | StdType::PoseStamped => self.bag.pose.len(),
            StdType::Log => return Ok(()),
        };
        let compression = match file.messages {
            MessageCompression::None => None,
            MessageCompression::Each(c) => Some(c),
            MessageCompression::Sniffed => Compression::of_frame(data),
        };
        let decompressed;
        let data = match compression {
            None => data,
            Some(c) => {
                decompressed = layout::decompress(c, data).map_err(|what| {
                    BagReadError::CompressedMessage {
                        path: file.path.clone(),
                        topic: topic.to_owned(),
                        index,
                        log_time_ns: t,
                        what,
                    }
                })?;
                &decompressed
            }
        };
        let fail = |source| BagReadError::Message {
            path: file.path.clone(),
            topic: topic.to_owned(),
            index,
            log_time_ns: t,
            source,
        };
        match ty {
            StdType::Twist | StdType::TwistStamped => {
                let m = msgs::decode_twist(ty, data).map_err(fail)?;
                self.bag.cmd.push((t, m));
            }
            StdType::Imu => {
                let m = msgs::decode_imu(data).map_err(fail)?;
                self.bag.imu.push((t, m));
            }
            StdType::Odometry | StdType::PoseStamped => {
                let m = msgs::decode_pose(ty, data).map_err(fail)?;
                self.bag.pose.push((t, m));
            }
            StdType::Log => {}
        }
        Ok(())
    }
}

/// Reads `topics` from the bag at `path` (a bag directory or one of its storage files).
pub fn read_bag(path: &Path, topics: &BagTopics) -> Result<RobotBag, BagReadError> {
    let files = layout::bag_files(path)?;
    let shown = match files.as_slice() {
        [one] => one.path.clone(),
        _ => path.to_owned(),
    };
    let mut gather = Gather {
        topics,
        bag: RobotBag {
            file: shown.clone(),
            ..RobotBag::default()
        },
        checked: Vec::new(),
    };
    for file in &files {
        read_file(file, &mut gather)?;
    }
    let mut bag = gather.bag;
    let names: Vec<String> = bag.topics.iter().map(|(t, _)| t.clone()).collect();
    let missing = |topic: &str| BagReadError::NoTopic {
        path: shown.clone(),
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
    // Neither MCAP files nor sqlite3 rows need be in log-time order; split files overlap.
    bag.cmd.sort_by_key(|m| m.0);
    bag.imu.sort_by_key(|m| m.0);
    bag.pose.sort_by_key(|m| m.0);
    Ok(bag)
}

/// Reads one storage file of a bag into `gather`, decompressing it first if it is compressed
/// whole.
fn read_file(file: &BagFile, gather: &mut Gather) -> Result<(), BagReadError> {
    let whole = match (file.file_compression, file.storage) {
        // A plain sqlite3 file is read where it lies: SQLite pages through it.
        (None, Storage::Sqlite3) => None,
        _ => {
            let bytes = std::fs::read(&file.path).map_err(|source| BagReadError::Io {
                path: file.path.clone(),
                source,
            })?;
            Some(match file.file_compression {
                None => bytes,
                Some(c) => {
                    layout::decompress(c, &bytes).map_err(|what| BagReadError::CompressedFile {
                        path: file.path.clone(),
                        what: format!("the file's {what}"),
                    })?
                }
            })
        }
    };
    let decompressed = file.file_compression.is_some();
    match file.storage {
        Storage::Mcap => read_mcap(
            file,
            whole.as_deref().unwrap_or_default(),
            decompressed,
            gather,
        ),
        Storage::Sqlite3 => read_sqlite(file, whole, gather).map_err(|e| match e {
            SqliteRead::Bag(e) => e,
            SqliteRead::Sqlite(what) => BagReadError::Sqlite {
                path: file.path.clone(),
                decompressed,
                what,
            },
        }),
    }
}

/// Reads an MCAP storage file record by record: `mcap`'s raw reader for the top-level records
/// (bounded lengths), chunks decoded and walked here (the crate's chunk walk underflows on a
/// record longer than its chunk), each record parsed once its string lengths are known to fit
/// (the crate's parser allocates a string's claimed length first: 4 GiB for one damaged length).
fn read_mcap(
    file: &BagFile,
    bytes: &[u8],
    decompressed: bool,
    gather: &mut Gather,
) -> Result<(), BagReadError> {
    use ::mcap::records::op;
    use ::mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
    // Any record up to the file's size (or 64 MiB) reads: a damaged length cannot claim more.
    let options = LinearReaderOptions::default()
        .with_record_length_limit(bytes.len().max(MAX_RECORD_BYTES))
        .with_emit_chunks(true);
    let mut reader = LinearReader::new_with_options(options);
    let mut fed = 0;
    let damaged = |fed: usize, what: String| BagReadError::Mcap {
        path: file.path.clone(),
        read_bytes: fed as u64,
        len: bytes.len() as u64,
        decompressed,
        what,
    };
    let mut records = McapRecords::default();
    let mut chunks = crate::log::mcap::ChunkDecoder::default();
    while let Some(event) = reader.next_event() {
        match event {
            Err(e) => return Err(damaged(fed, crate::mcap_damage::describe(&e))),
            Ok(LinearReadEvent::ReadRequest(n)) => {
                let n = n.min(bytes.len() - fed);
                reader.insert(n).copy_from_slice(&bytes[fed..fed + n]);
                reader.notify_read(n);
                fed += n;
            }
            Ok(LinearReadEvent::Record { opcode, data }) if opcode == op::CHUNK => {
                let inner = chunks.decode(data).map_err(|problem| {
                    damaged(
                        fed,
                        match problem {
                            crate::log::mcap::ChunkProblem::Damaged(what) => {
                                format!("a damaged chunk: {what}")
                            }
                            crate::log::mcap::ChunkProblem::Unsupported(c) => {
                                format!("a chunk with compression `{c}`, not read here")
                            }
                        },
                    )
                })?;
                let mut rest = inner;
                while !rest.is_empty() {
                    let record = rest
                        .get(..9)
                        .map(|h| {
                            (
                                h[0],
                                u64::from_le_bytes(h[1..9].try_into().unwrap_or_default()),
                            )
                        })
                        .and_then(|(opcode, len)| {
                            let end = 9usize.checked_add(usize::try_from(len).ok()?)?;
                            Some((opcode, rest.get(9..end)?, end))
                        });
                    let Some((opcode, body, end)) = record else {
                        return Err(damaged(
                            fed,
                            "a record runs past the end of its chunk".into(),
                        ));
                    };
                    records
                        .record(file, opcode, body, gather)
                        .map_err(|e| e.or_damage(|what| damaged(fed, what)))?;
                    rest = &rest[end..];
                }
            }
            Ok(LinearReadEvent::Record { opcode, data }) => records
                .record(file, opcode, data, gather)
                .map_err(|e| e.or_damage(|what| damaged(fed, what)))?,
        }
    }
    Ok(())
}

/// The schemas and channels an MCAP file has defined so far.
#[derive(Default)]
struct McapRecords {
    /// (id, name, encoding, definition)
    schemas: Vec<(u16, String, String, String)>,
    /// (id, topic, schema id, message encoding)
    channels: Vec<(u16, String, u16, String)>,
}

/// A record that did not read: the bag's own error, or damage in plain words.
enum RecordError {
    Bag(BagReadError),
    Damage(String),
}

impl RecordError {
    fn or_damage(self, damaged: impl FnOnce(String) -> BagReadError) -> BagReadError {
        match self {
            RecordError::Bag(e) => e,
            RecordError::Damage(what) => damaged(what),
        }
    }
}

impl McapRecords {
    /// Takes in one record (header, schema, channel and message records are parsed; the rest,
    /// which the reader does not need, are skipped).
    fn record(
        &mut self,
        file: &BagFile,
        opcode: u8,
        body: &[u8],
        gather: &mut Gather,
    ) -> Result<(), RecordError> {
        use ::mcap::records::{op, Record};
        if !matches!(opcode, op::HEADER | op::SCHEMA | op::CHANNEL | op::MESSAGE) {
            return Ok(());
        }
        match crate::log::mcap::parse_record(opcode, body).map_err(RecordError::Damage)? {
            Record::Schema { header, data } => self.schemas.push((
                header.id,
                header.name,
                header.encoding,
                String::from_utf8_lossy(&data).into_owned(),
            )),
            Record::Channel(c) => {
                self.channels
                    .push((c.id, c.topic, c.schema_id, c.message_encoding));
            }
            Record::Message { header, data } => {
                let Some((_, topic, schema_id, encoding)) =
                    self.channels.iter().find(|c| c.0 == header.channel_id)
                else {
                    return Err(RecordError::Damage(format!(
                        "a message on channel {}, which no channel record defines",
                        header.channel_id
                    )));
                };
                let schemas = &self.schemas;
                let ty = gather
                    .type_of(&file.path, topic, || {
                        let schema = schemas.iter().find(|s| s.0 == *schema_id);
                        Channel {
                            type_name: schema.map(|s| s.1.clone()).unwrap_or_default(),
                            message_encoding: encoding.clone(),
                            definition_encoding: schema.map(|s| s.2.clone()).unwrap_or_default(),
                            definition: schema.map(|s| s.3.clone()).unwrap_or_default(),
                        }
                    })
                    .map_err(RecordError::Bag)?;
                if let Some(ty) = ty {
                    gather
                        .message(file, topic, ty, header.log_time, &data)
                        .map_err(RecordError::Bag)?;
                }
            }
            _ => {}
        }
        Ok(())
    }
}

/// A sqlite3 bag file that did not read: the bag's own error (a type, a message), or SQLite's
/// sentence for a file it cannot read.
enum SqliteRead {
    Bag(BagReadError),
    Sqlite(String),
}

impl From<rusqlite::Error> for SqliteRead {
    /// SQLite's sentence on one line: a damaged schema's error quotes its SQL, newlines and all.
    fn from(e: rusqlite::Error) -> Self {
        let text = e
            .to_string()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        SqliteRead::Sqlite(match text.char_indices().nth(200) {
            Some((cut, _)) => format!("{}…", &text[..cut]),
            None => text,
        })
    }
}

/// Reads a sqlite3 bag file: from `decompressed` (a `.db3.zstd`'s contents) or where it lies,
/// read-only.
fn read_sqlite(
    file: &BagFile,
    decompressed: Option<Vec<u8>>,
    gather: &mut Gather,
) -> Result<(), SqliteRead> {
    use rusqlite::{Connection, OpenFlags};
    let read_only = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX;
    let (db, len) = match decompressed {
        Some(bytes) => {
            if bytes.is_empty() {
                return Err(SqliteRead::Sqlite("the file is empty".into()));
            }
            let mut db = Connection::open_in_memory()?;
            // `decompress` bounds `bytes` to 1 GiB: within SQLite's int sizes.
            db.deserialize_read_exact("main", bytes.as_slice(), bytes.len(), true)?;
            (db, bytes.len())
        }
        None => {
            let len = std::fs::metadata(&file.path)
                .map_err(|source| {
                    SqliteRead::Bag(BagReadError::Io {
                        path: file.path.clone(),
                        source,
                    })
                })?
                .len();
            // `immutable`: no lock, no journal or -shm file beside the bag. A bag with a write-ahead
            // log (rosbag2's `resilient` preset, a recording cut short) is opened plainly
            // read-only, so that SQLite reads the log too.
            let mut wal = file.path.clone().into_os_string();
            wal.push("-wal");
            let db = if Path::new(&wal).exists() {
                Connection::open_with_flags(&file.path, read_only)?
            } else {
                Connection::open_with_flags(
                    format!("file:{}?immutable=1", uri_path(&file.path)),
                    read_only | OpenFlags::SQLITE_OPEN_URI,
                )?
            };
            (db, usize::try_from(len).unwrap_or(usize::MAX))
        }
    };
    // No value (a damaged blob length) larger than the file, or 64 MiB.
    let max_value = len.max(MAX_RECORD_BYTES).min(i32::MAX as usize) as i32;
    db.set_limit(rusqlite::limits::Limit::SQLITE_LIMIT_LENGTH, max_value)?;

    // (id, name, type, serialization format)
    let mut topics: Vec<(i64, String, String, String)> = Vec::new();
    let mut rows = db.prepare("SELECT id, name, type, serialization_format FROM topics")?;
    let mut query = rows.query([])?;
    while let Some(row) = query.next()? {
        topics.push((row.get(0)?, row.get(1)?, row.get(2)?, row.get(3)?));
    }
    // Iron and later store each type's definition; Humble and older do not.
    let has_definitions: bool = db.query_row(
        "SELECT count(*) > 0 FROM sqlite_master WHERE type = 'table' AND name = 'message_definitions'",
        [],
        |row| row.get(0),
    )?;
    let mut definitions: Vec<(String, String, String)> = Vec::new();
    if has_definitions {
        let mut rows = db.prepare(
            "SELECT topic_type, encoding, encoded_message_definition FROM message_definitions",
        )?;
        let mut query = rows.query([])?;
        while let Some(row) = query.next()? {
            definitions.push((row.get(0)?, row.get(1)?, row.get(2)?));
        }
    }

    let mut rows = db.prepare("SELECT id, topic_id, timestamp, data FROM messages ORDER BY id")?;
    let mut query = rows.query([])?;
    while let Some(row) = query.next()? {
        let id: i64 = row.get(0)?;
        let topic_id: i64 = row.get(1)?;
        let Some(index) = topics.iter().position(|t| t.0 == topic_id) else {
            return Err(SqliteRead::Sqlite(format!(
                "message {id} is on topic id {topic_id}, which the topics table lacks"
            )));
        };
        let timestamp: i64 = row.get(2)?;
        let Ok(t) = u64::try_from(timestamp) else {
            return Err(SqliteRead::Sqlite(format!(
                "message {id} has a negative timestamp ({timestamp} ns)"
            )));
        };
        let (_, topic, type_name, format) = &topics[index];
        let ty = gather
            .type_of(&file.path, topic, || {
                let definition = definitions.iter().find(|d| &d.0 == type_name);
                Channel {
                    type_name: type_name.clone(),
                    message_encoding: format.clone(),
                    definition_encoding: definition.map(|d| d.1.clone()).unwrap_or_default(),
                    definition: definition.map(|d| d.2.clone()).unwrap_or_default(),
                }
            })
            .map_err(SqliteRead::Bag)?;
        if let Some(ty) = ty {
            let Ok(data) = row.get_ref(3)?.as_blob() else {
                return Err(SqliteRead::Sqlite(format!(
                    "message {id}'s data is not a blob"
                )));
            };
            gather
                .message(file, topic, ty, t, data)
                .map_err(SqliteRead::Bag)?;
        }
    }
    Ok(())
}

/// `path` as the path of a `file:` URI (every byte but unreserved ones and `/` escaped).
fn uri_path(path: &Path) -> String {
    let mut uri = String::new();
    for &b in path.as_os_str().as_encoded_bytes() {
        if b.is_ascii_alphanumeric() || b"/-._~".contains(&b) {
            uri.push(b as char);
        } else {
            uri.push_str(&format!("%{b:02X}"));
        }
    }
    uri
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
                "{}: not a readable MCAP file, damaged before byte {header_end} of {}: record 0x01: the Header \
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
}
