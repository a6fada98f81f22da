//! Which files a rosbag2 bag has, in which storage and with which compression: as its
//! `metadata.yaml` lists them, or (a file given alone) as its name says.

use super::read::BagReadError;
use std::io::Read;
use std::path::{Path, PathBuf};

/// A storage plugin's file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Storage {
    Mcap,
    /// `.db3`: the default of ROS 2 Humble and older.
    Sqlite3,
}

/// A compression rosbag2 writes (`compression_format`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    Zstd,
    Lz4,
}

impl Compression {
    pub fn name(self) -> &'static str {
        match self {
            Compression::Zstd => "zstd",
            Compression::Lz4 => "lz4",
        }
    }

    /// The compression a file name ends in (`drive_0.mcap.zstd`).
    fn of_extension(path: &Path) -> Option<Compression> {
        match path.extension()?.to_str()? {
            "zstd" | "zst" => Some(Compression::Zstd),
            "lz4" => Some(Compression::Lz4),
            _ => None,
        }
    }

    /// The compression whose frame `bytes` starts with (a CDR message starts with its
    /// encapsulation, `00 0x`, never with a frame's magic number).
    pub fn of_frame(bytes: &[u8]) -> Option<Compression> {
        match bytes.get(..4)? {
            [0x28, 0xb5, 0x2f, 0xfd] => Some(Compression::Zstd),
            [0x04, 0x22, 0x4d, 0x18] => Some(Compression::Lz4),
            _ => None,
        }
    }
}

/// How the messages of a [`BagFile`] are compressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MessageCompression {
    None,
    /// `compression_mode: message`: every message is one frame of this format.
    Each(Compression),
    /// A file given without its bag's metadata: a message that starts with a frame's magic
    /// number is that frame.
    Sniffed,
}

/// One storage file of a bag.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BagFile {
    pub path: PathBuf,
    pub storage: Storage,
    /// `compression_mode: file`: the whole storage file is one frame of this format.
    pub file_compression: Option<Compression>,
    pub messages: MessageCompression,
}

impl BagFile {
    /// The file's name, for messages that list a bag's files.
    pub fn name(&self) -> String {
        self.path
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into()
    }
}

/// A bag's storage and compression settings, from its `metadata.yaml`.
struct Metadata {
    storage: Option<Storage>,
    file_compression: Option<Compression>,
    message_compression: Option<Compression>,
    files: Vec<String>,
}

impl Metadata {
    fn read(bag: &Path, file: &Path) -> Result<Metadata, BagReadError> {
        let text = std::fs::read_to_string(file).map_err(|source| BagReadError::Io {
            path: file.to_owned(),
            source,
        })?;
        let storage = match yaml_value(&text, "storage_identifier").as_deref() {
            None | Some("") => None,
            Some("mcap") => Some(Storage::Mcap),
            Some("sqlite3") => Some(Storage::Sqlite3),
            Some(other) => {
                return Err(BagReadError::Storage {
                    path: bag.to_owned(),
                    storage: other.to_owned(),
                })
            }
        };
        // rosbag2 writes `MESSAGE`/`FILE`, rosbags `message`/`file`; no compression is `""`
        // (or `NONE`).
        let mode = yaml_value(&text, "compression_mode")
            .unwrap_or_default()
            .to_ascii_lowercase();
        let format = yaml_value(&text, "compression_format")
            .unwrap_or_default()
            .to_ascii_lowercase();
        let compression = match format.as_str() {
            "zstd" => Some(Compression::Zstd),
            "lz4" => Some(Compression::Lz4),
            _ => None,
        };
        let unread = || BagReadError::Compression {
            path: bag.to_owned(),
            mode: mode.clone(),
            format: format.clone(),
        };
        let (file_compression, message_compression) = match mode.as_str() {
            "" | "none" => (None, None),
            "file" => (Some(compression.ok_or_else(unread)?), None),
            "message" => (None, Some(compression.ok_or_else(unread)?)),
            _ => return Err(unread()),
        };
        Ok(Metadata {
            storage,
            file_compression,
            message_compression,
            files: yaml_list(&text, "relative_file_paths"),
        })
    }

    fn file(&self, path: PathBuf) -> BagFile {
        BagFile {
            storage: self.storage.unwrap_or_else(|| storage_of_name(&path)),
            file_compression: self.file_compression,
            messages: match self.message_compression {
                Some(c) => MessageCompression::Each(c),
                None => MessageCompression::None,
            },
            path,
        }
    }
}

/// The storage a file's name says (`.db3`, `.db3.zstd`: sqlite3; anything else: MCAP).
fn storage_of_name(path: &Path) -> Storage {
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let name = name
        .strip_suffix(".zstd")
        .or_else(|| name.strip_suffix(".zst"))
        .or_else(|| name.strip_suffix(".lz4"))
        .unwrap_or(&name);
    if name.ends_with(".db3") {
        Storage::Sqlite3
    } else {
        Storage::Mcap
    }
}

/// The storage files of the bag at `path`, in the order to read them: a bag directory's files
/// as its `metadata.yaml` lists them (or its only storage file), or `path` itself (read with the
/// settings of its directory's `metadata.yaml` when that lists it).
pub fn bag_files(path: &Path) -> Result<Vec<BagFile>, BagReadError> {
    let io = |source| BagReadError::Io {
        path: path.to_owned(),
        source,
    };
    if !path.is_dir() {
        std::fs::metadata(path).map_err(io)?;
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        let listing = path
            .parent()
            .map(|dir| dir.join("metadata.yaml"))
            .filter(|m| m.is_file());
        if let (Some(metadata), Some(name)) = (listing, name) {
            let bag = path.parent().unwrap_or(path);
            let metadata = Metadata::read(bag, &metadata)?;
            if metadata.files.contains(&name) {
                return Ok(vec![metadata.file(path.to_owned())]);
            }
        }
        return Ok(vec![BagFile {
            path: path.to_owned(),
            storage: storage_of_name(path),
            file_compression: Compression::of_extension(path),
            messages: MessageCompression::Sniffed,
        }]);
    }
    let metadata_path = path.join("metadata.yaml");
    if metadata_path.exists() {
        let metadata = Metadata::read(path, &metadata_path)?;
        if !metadata.files.is_empty() {
            let files: Vec<BagFile> = metadata
                .files
                .iter()
                .map(|f| metadata.file(path.join(f)))
                .collect();
            let missing: Vec<String> = files
                .iter()
                .filter(|f| !f.path.is_file())
                .map(BagFile::name)
                .collect();
            if !missing.is_empty() {
                return Err(BagReadError::MissingFiles {
                    path: path.to_owned(),
                    missing,
                    listed: metadata.files.clone(),
                });
            }
            return Ok(files);
        }
    }
    let entries = std::fs::read_dir(path).map_err(io)?;
    let mut candidates: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let name = p.file_name().unwrap_or_default().to_string_lossy();
            [".mcap", ".db3"].iter().any(|ext| {
                name.ends_with(ext)
                    || [".zstd", ".lz4"]
                        .iter()
                        .any(|c| name.ends_with(&format!("{ext}{c}")))
            })
        })
        .collect();
    candidates.sort();
    match candidates.as_slice() {
        [one] => Ok(vec![BagFile {
            path: one.clone(),
            storage: storage_of_name(one),
            file_compression: Compression::of_extension(one),
            messages: MessageCompression::Sniffed,
        }]),
        _ => Err(BagReadError::NoStorageFile {
            path: path.to_owned(),
            found: candidates
                .iter()
                .map(|p| p.file_name().unwrap_or_default().to_string_lossy().into())
                .collect(),
        }),
    }
}

/// The most bytes a frame of `compressed_len` bytes may decompress to: 64× its size (at least
/// 1 MiB, at most 1 GiB), so that a damaged frame cannot claim unbounded memory.
pub fn decompressed_limit(compressed_len: usize) -> usize {
    compressed_len
        .saturating_mul(64)
        .clamp(MIN_DECOMPRESSED, MAX_DECOMPRESSED)
}

const MIN_DECOMPRESSED: usize = 1 << 20;
const MAX_DECOMPRESSED: usize = 1 << 30;

/// `compressed`, one or more frames of `format`, decompressed; `Err` says why not in one line.
pub fn decompress(format: Compression, compressed: &[u8]) -> Result<Vec<u8>, String> {
    let limit = decompressed_limit(compressed.len());
    let failed =
        |e: std::io::Error| format!("its {} compression does not decompress: {e}", format.name());
    let out = match format {
        Compression::Zstd => {
            // The decoder's window is capped (128 MiB by default): its own buffers are bounded.
            let decoder = zstd::stream::read::Decoder::with_buffer(compressed).map_err(failed)?;
            read_bounded(decoder, limit)
        }
        Compression::Lz4 => {
            let decoder = lz4::Decoder::new(compressed).map_err(failed)?;
            read_bounded(decoder, limit)
        }
    }
    .map_err(failed)?;
    out.ok_or_else(|| {
        format!(
            "its {} compression decompresses to more than {limit} bytes (64× its {} compressed \
             bytes, at least 1 MiB, at most 1 GiB): damaged, or too large to read here",
            format.name(),
            compressed.len()
        )
    })
}

/// All of `reader`, or `None` if it holds more than `limit` bytes. Grows its buffer with
/// `try_reserve` (never more than `limit` + 1 bytes): a refused allocation is an error, not
/// an abort.
fn read_bounded(mut reader: impl Read, limit: usize) -> std::io::Result<Option<Vec<u8>>> {
    let mut out: Vec<u8> = Vec::new();
    let mut chunk = [0u8; 64 * 1024];
    loop {
        let n = match reader.read(&mut chunk) {
            Ok(0) => return Ok(Some(out)),
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if out.len() + n > limit {
            return Ok(None);
        }
        if out.capacity() - out.len() < n {
            let want = (out.len() * 2).clamp(out.len() + n, limit);
            out.try_reserve_exact(want - out.len())
                .map_err(|e| std::io::Error::new(std::io::ErrorKind::OutOfMemory, e))?;
        }
        out.extend_from_slice(&chunk[..n]);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metadata_yaml_names_storage_and_files() {
        let text = "rosbag2_bagfile_information:\n  version: 8\n  storage_identifier: mcap\n  relative_file_paths:\n    - drive_0.mcap\n    - drive_1.mcap\n  files:\n    - path: drive_0.mcap\n";
        assert_eq!(
            yaml_value(text, "storage_identifier").as_deref(),
            Some("mcap")
        );
        assert_eq!(
            yaml_list(text, "relative_file_paths"),
            vec!["drive_0.mcap", "drive_1.mcap"]
        );
    }

    #[test]
    fn file_names_say_storage_and_compression() {
        for (name, storage, compression) in [
            ("a.mcap", Storage::Mcap, None),
            ("a.db3", Storage::Sqlite3, None),
            ("a_0.db3.zstd", Storage::Sqlite3, Some(Compression::Zstd)),
            ("a_0.mcap.lz4", Storage::Mcap, Some(Compression::Lz4)),
        ] {
            let path = Path::new(name);
            assert_eq!(storage_of_name(path), storage, "{name}");
            assert_eq!(Compression::of_extension(path), compression, "{name}");
        }
    }

    #[test]
    fn zstd_and_lz4_frames_decompress() {
        let message: Vec<u8> = (0..5000u32).flat_map(|i| (i % 7).to_le_bytes()).collect();
        let zstd = zstd::encode_all(message.as_slice(), 3).expect("compresses");
        assert_eq!(Compression::of_frame(&zstd), Some(Compression::Zstd));
        assert_eq!(decompress(Compression::Zstd, &zstd), Ok(message.clone()));

        let mut encoder = lz4::EncoderBuilder::new()
            .build(Vec::new())
            .expect("encoder");
        std::io::Write::write_all(&mut encoder, &message).expect("written");
        let (lz4, done) = encoder.finish();
        done.expect("finished");
        assert_eq!(Compression::of_frame(&lz4), Some(Compression::Lz4));
        assert_eq!(decompress(Compression::Lz4, &lz4), Ok(message));

        // Not a frame: a plain error, not a panic.
        let e = decompress(Compression::Zstd, &[0, 1, 0, 0, 5]).expect_err("not zstd");
        assert!(
            e.starts_with("its zstd compression does not decompress"),
            "{e}"
        );
    }

    /// A frame that expands beyond 64× (and 1 MiB) is refused, saying the limit.
    #[test]
    fn a_frame_expanding_past_the_limit_is_refused() {
        let zeros = vec![0u8; 4 << 20];
        let zstd = zstd::encode_all(zeros.as_slice(), 3).expect("compresses");
        assert!(zstd.len() * 64 < zeros.len(), "{}", zstd.len());
        let e = decompress(Compression::Zstd, &zstd).expect_err("too large");
        assert!(
            e.contains(&format!("more than {} bytes", 1 << 20)) && e.contains("64×"),
            "{e}"
        );
        assert_eq!(decompressed_limit(10 << 20), 640 << 20);
        assert_eq!(decompressed_limit(100 << 20), 1 << 30);
    }
}
