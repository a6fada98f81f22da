//! Log files: what a recording holds ([`run_log`]), the run CSV interchange format ([`run_csv`]),
//! MCAP run logs ([`mcap`]), reading and converting either by extension ([`load`],
//! [`convert`]), the commands CSV ([`commands`]), a run CSV written live ([`csv_sink`]) and
//! crash-safe writing of whole files ([`write_atomically`]).

pub mod commands;
pub mod convert;
pub mod csv_sink;
pub mod load;
pub mod mcap;
pub mod run_csv;
pub mod run_log;
pub mod synthesis;

use crate::temp_paths::TempPath;
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Why [`write_atomically`] did not produce its file.
#[derive(Debug, thiserror::Error)]
pub enum AtomicWriteError<E> {
    /// Creating, syncing or renaming the file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file (the target, or the temporary file beside it).
        path: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// The content callback failed (a full disk while writing, bad content); nothing was written
    /// at the target path. Names the target: an `io::Error` does not. Its source, not
    /// transparent: the CLI finds an `io::Error` such as a closed stdout in the chain.
    #[error("{}: {source}", path.display())]
    Content {
        /// The file that was being written (the target, not the temporary file beside it).
        path: PathBuf,
        /// Why.
        #[source]
        source: E,
    },
}

/// What [`write_atomically`] does with a file at its path when it is done.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Existing {
    /// Replace it: the user asked to (`--force`), or the path is in a directory of this
    /// program's own making.
    Replace,
    /// Keep it and fail: the caller found no file there (or refused one), so a file there now
    /// is another program's.
    Keep,
}

impl Existing {
    /// `--force` replaces, its absence keeps.
    pub fn from_force(force: bool) -> Self {
        if force {
            Self::Replace
        } else {
            Self::Keep
        }
    }
}

/// Writes a whole file or nothing: `write` fills a temporary file in the target's directory,
/// which is then flushed, fsynced and moved to `path` (and the directory fsynced on Unix).
/// If `write` fails (or panics), or any step fails, the temporary file is removed and `path` is
/// left as it was — absent, or with its previous complete content.
///
/// With [`Existing::Keep`] (a caller that found no file there, or refuses one without
/// `--force`) a file that appeared at `path` meanwhile — another program's finished
/// recording, a second `convert` to the same name — is kept, and this write fails with
/// [`io::ErrorKind::AlreadyExists`] ([`place_new`]); with [`Existing::Replace`] it is replaced.
///
/// An existing target that is not a regular file (`/dev/null`, a FIFO, a terminal) is written
/// in place: renaming over it would replace the device with a regular file.
pub fn write_atomically<T, E>(
    path: &Path,
    existing: Existing,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<T, E>,
) -> Result<T, AtomicWriteError<E>> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let io_err = |path: &Path| {
        let path = path.to_owned();
        move |source| AtomicWriteError::Io { path, source }
    };
    let content_err = |path: &Path| {
        let path = path.to_owned();
        move |source| AtomicWriteError::Content { path, source }
    };
    if fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
        let file = OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(io_err(path))?;
        let mut out = BufWriter::new(file);
        let value = write(&mut out).map_err(content_err(path))?;
        out.flush().map_err(io_err(path))?;
        return Ok(value);
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_owned(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().ok_or_else(|| AtomicWriteError::Io {
        path: path.to_owned(),
        source: io::Error::new(io::ErrorKind::InvalidInput, "not a file path"),
    })?;
    // What a killed writer of this name left (a SIGKILL cannot be caught).
    crate::temp_paths::sweep_dead(&dir, name, |rest| {
        rest.strip_suffix(".tmp")?.split('-').next()?.parse().ok()
    });
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(
        ".{}-{}.tmp",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let tmp_path = dir.join(tmp_name);
    let mut tmp = TempFile(Some(TempPath::new(tmp_path.clone())));
    let file = match OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp_path)
    {
        Ok(file) => file,
        Err(e) => {
            // Not created: not ours to remove.
            drop(tmp.0.take());
            return Err(io_err(&tmp_path)(e));
        }
    };
    let mut out = BufWriter::new(file);
    let value = write(&mut out).map_err(content_err(path))?;
    let file = out
        .into_inner()
        .map_err(|e| io_err(&tmp_path)(e.into_error()))?;
    file.sync_all().map_err(io_err(&tmp_path))?;
    drop(file);
    if existing == Existing::Replace {
        fs::rename(&tmp_path, path).map_err(io_err(path))?;
        tmp.0 = None; // renamed: nothing left to clean up
    } else {
        place_new(&tmp_path, path).map_err(io_err(path))?;
        // Linked into place: the temporary name goes when `tmp` drops.
    }
    #[cfg(unix)]
    File::open(&dir)
        .and_then(|d| d.sync_all())
        .map_err(io_err(&dir))?;
    Ok(value)
}

/// Gives the finished temporary file `tmp` the name `path` only if no file has that name: a
/// hard link fails when the name exists, atomically, where a rename would replace it. On a
/// file system without hard links, the rename after a check (a window of microseconds, not the
/// whole write). The temporary name is left for the caller to remove.
fn place_new(tmp: &Path, path: &Path) -> io::Result<()> {
    let appeared = || {
        io::Error::new(
            io::ErrorKind::AlreadyExists,
            "a file appeared there while this one was being written (another program writing \
             the same name?): it was kept, and this output was not written",
        )
    };
    match fs::hard_link(tmp, path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == io::ErrorKind::AlreadyExists => Err(appeared()),
        Err(_) if fs::symlink_metadata(path).is_ok() => Err(appeared()),
        Err(_) => fs::rename(tmp, path),
    }
}

/// Removes the temporary file unless it was renamed into place; registered meanwhile, so
/// that a stop signal removes it too ([`crate::temp_paths`]).
struct TempFile(Option<TempPath>);

impl Drop for TempFile {
    fn drop(&mut self) {
        if let Some(tmp) = self.0.take() {
            let _ = fs::remove_file(tmp.path());
        }
    }
}

#[cfg(test)]
pub(crate) mod tests_support {
    use std::path::{Path, PathBuf};
    use std::sync::atomic::{AtomicU64, Ordering};

    /// Cases of a damage-fuzzing property test: `cases` by default, `PROPTEST_CASES` when set
    /// (CI's bounded fuzz step runs them long).
    pub(crate) fn fuzz_config(cases: u32) -> proptest::test_runner::Config {
        match std::env::var("PROPTEST_CASES") {
            Ok(_) => proptest::test_runner::Config::default(),
            Err(_) => proptest::test_runner::Config::with_cases(cases),
        }
    }

    /// A fresh directory under the system temp dir, removed on drop.
    #[derive(Debug)]
    pub(crate) struct TempDir(PathBuf);

    impl TempDir {
        pub(crate) fn new(tag: &str) -> Self {
            static N: AtomicU64 = AtomicU64::new(0);
            let path = std::env::temp_dir().join(format!(
                "host-tool-{tag}-{}-{}",
                std::process::id(),
                N.fetch_add(1, Ordering::Relaxed)
            ));
            std::fs::create_dir_all(&path).expect("create temp dir");
            Self(path)
        }

        pub(crate) fn path(&self) -> &Path {
            &self.0
        }

        /// Names of the entries in the directory, sorted.
        pub(crate) fn entries(&self) -> Vec<String> {
            let mut names: Vec<String> = std::fs::read_dir(&self.0)
                .expect("read dir")
                .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
                .collect();
            names.sort();
            names
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::tests_support::TempDir;
    use super::*;
    use std::io::Write;

    #[test]
    fn success_leaves_only_the_file() {
        let dir = TempDir::new("atomic-ok");
        let path = dir.path().join("out.txt");
        write_atomically::<_, io::Error>(&path, Existing::Replace, |w| w.write_all(b"hello"))
            .expect("written");
        assert_eq!(fs::read(&path).expect("read"), b"hello");
        assert_eq!(dir.entries(), ["out.txt"]);
    }

    #[test]
    fn failure_leaves_nothing_and_keeps_the_old_file() {
        let dir = TempDir::new("atomic-fail");
        let path = dir.path().join("out.txt");
        let e = write_atomically(&path, Existing::Replace, |w| {
            w.write_all(b"half")?;
            Err::<(), _>(io::Error::other("input broke"))
        })
        .expect_err("fails");
        assert!(matches!(&e, AtomicWriteError::Content { path: p, .. } if *p == path));
        assert_eq!(e.to_string(), format!("{}: input broke", path.display()));
        assert!(dir.entries().is_empty(), "{:?}", dir.entries());

        fs::write(&path, b"old").expect("write");
        let _ = write_atomically(&path, Existing::Replace, |w| {
            w.write_all(b"new but broken")?;
            Err::<(), _>(io::Error::other("input broke"))
        });
        assert_eq!(fs::read(&path).expect("read"), b"old");
        assert_eq!(dir.entries(), ["out.txt"]);
    }

    /// `convert big.csv out.mcap` (no `--force`) started just before `record --out out.mcap`
    /// once replaced the finished recording with its own output, both exiting 0. A file that
    /// appears while one is written is kept, and the later writer fails; a file that was there
    /// at the start (the caller's `--force`) is still replaced.
    #[test]
    fn a_file_that_appears_while_writing_is_kept() {
        let dir = TempDir::new("atomic-race");
        let path = dir.path().join("out.mcap");
        let e = write_atomically::<_, io::Error>(&path, Existing::Keep, |w| {
            fs::write(&path, b"the recording").expect("the other program");
            w.write_all(b"the conversion")
        })
        .expect_err("refused");
        assert!(
            matches!(&e, AtomicWriteError::Io { source, path: p }
                if source.kind() == io::ErrorKind::AlreadyExists && *p == path),
            "{e:?}"
        );
        assert!(e.to_string().contains("was kept"), "{e}");
        assert_eq!(fs::read(&path).expect("read"), b"the recording");
        assert_eq!(dir.entries(), ["out.mcap"], "no temporary file left");

        // The caller was given --force: replaced.
        write_atomically::<_, io::Error>(&path, Existing::Replace, |w| w.write_all(b"forced"))
            .expect("replaced");
        assert_eq!(fs::read(&path).expect("read"), b"forced");
        assert_eq!(dir.entries(), ["out.mcap"]);
    }

    /// Two writers to one new name at once: exactly one wins, whole; the other fails.
    #[test]
    fn two_writers_to_one_new_name_one_wins() {
        let dir = TempDir::new("atomic-two");
        let path = dir.path().join("out.csv");
        let barrier = std::sync::Barrier::new(2);
        let results: Vec<bool> = std::thread::scope(|s| {
            let writers: Vec<_> = [b"first".as_slice(), b"second".as_slice()]
                .into_iter()
                .map(|text| {
                    let (path, barrier) = (&path, &barrier);
                    s.spawn(move || {
                        write_atomically::<_, io::Error>(path, Existing::Keep, |w| {
                            w.write_all(text)?;
                            barrier.wait();
                            Ok(())
                        })
                        .is_ok()
                    })
                })
                .collect();
            writers
                .into_iter()
                .map(|w| w.join().expect("thread"))
                .collect()
        });
        assert_eq!(results.iter().filter(|ok| **ok).count(), 1, "{results:?}");
        let winner = if results[0] {
            b"first".as_slice()
        } else {
            b"second"
        };
        assert_eq!(fs::read(&path).expect("read"), winner);
        assert_eq!(dir.entries(), ["out.csv"]);
    }

    #[test]
    fn missing_directory_is_an_io_error_naming_it() {
        let dir = TempDir::new("atomic-nodir");
        let path = dir.path().join("no/such/dir/out.txt");
        let e = write_atomically::<_, io::Error>(&path, Existing::Replace, |_| Ok(()))
            .expect_err("no dir");
        assert!(matches!(e, AtomicWriteError::Io { .. }));
        assert!(e.to_string().contains("no/such/dir"), "{e}");
    }

    /// `--json /dev/null` once replaced the machine's /dev/null with a regular file (the rename
    /// of the temporary file); a device is written in place and stays a device.
    #[cfg(unix)]
    #[test]
    fn a_device_target_is_written_in_place() {
        use std::os::unix::fs::FileTypeExt;
        let null = Path::new("/dev/null");
        let is_device = |p: &Path| fs::metadata(p).is_ok_and(|m| m.file_type().is_char_device());
        if !is_device(null) {
            return; // not a Unix machine with a /dev/null device: nothing to check
        }
        write_atomically::<_, io::Error>(null, Existing::Replace, |w| w.write_all(b"discarded"))
            .expect("writes");
        assert!(is_device(null), "/dev/null is no longer a device");
    }

    /// Issue 34: `No space left on device` from `plot`, `diagnose --out` named no file (the
    /// content's io::Error knows none).
    #[cfg(target_os = "linux")]
    #[test]
    fn a_full_disk_while_writing_names_the_file() {
        let full = Path::new("/dev/full");
        if !full.exists() {
            return; // no /dev/full here: nothing to check
        }
        // Larger than BufWriter's buffer: the write itself fails (Content), not the flush (Io).
        let e = write_atomically::<_, io::Error>(full, Existing::Replace, |w| {
            w.write_all(&[0; 1 << 16])
        })
        .expect_err("disk full");
        assert!(matches!(e, AtomicWriteError::Content { .. }), "{e:?}");
        let shown = e.to_string();
        assert!(shown.starts_with("/dev/full: "), "{shown}");
        assert!(shown.contains("No space left on device"), "{shown}");
        // A small write fails at the flush: also named.
        let e = write_atomically::<_, io::Error>(full, Existing::Replace, |w| w.write_all(b"x"))
            .expect_err("full");
        assert!(e.to_string().starts_with("/dev/full: "), "{e}");
    }
}
