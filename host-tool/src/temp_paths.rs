//! Temporary files and staging directories that must not outlive their writer: the temporary
//! file of [`crate::log::write_atomically`] (`.NAME.PID-N.tmp`) and the staging directory of
//! [`crate::out_dir::write_dir_whole`] (`.NAME.partial-PID`).
//!
//! - While one exists it is [registered](TempPath::new); a stop signal removes every registered
//!   path before the process exits ([`remove_all`], called by
//!   [`crate::record::stop_signal`]'s handler).
//! - A SIGKILL (or a power cut) cannot be caught: the next writer of the same name sweeps the
//!   temporary paths of processes that are gone ([`sweep_dead`]).

use std::ffi::OsStr;
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

/// The temporary paths of this process now.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// A temporary path of this process, registered while this value lives. Dropping it only
/// unregisters the path: its owner removes it, or renames it into place.
#[derive(Debug)]
pub struct TempPath(PathBuf);

impl TempPath {
    /// Registers `path` (a file or a directory about to be created).
    pub fn new(path: PathBuf) -> Self {
        PENDING
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(path.clone());
        Self(path)
    }

    /// The path.
    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempPath {
    fn drop(&mut self) {
        let mut pending = PENDING.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(i) = pending.iter().rposition(|p| *p == self.0) {
            pending.swap_remove(i);
        }
    }
}

/// Removes every registered temporary path (files and directories): what a stop signal does
/// before the process exits. Never blocks on the registry (a signal may come while it is held).
pub fn remove_all() {
    let Ok(pending) = PENDING.try_lock() else {
        return;
    };
    for path in pending.iter() {
        remove(path);
    }
}

fn remove(path: &Path) {
    match fs::symlink_metadata(path) {
        Ok(m) if m.is_dir() => {
            let _ = fs::remove_dir_all(path);
        }
        Ok(_) => {
            let _ = fs::remove_file(path);
        }
        Err(_) => {}
    }
}

/// Removes, in `dir`, the temporary paths of `name` left by processes that are gone: entries
/// named `.{name}.{kind}` where `kind` holds a process id (`pid_of` finds it) of no running
/// process. Only on systems with `/proc` (elsewhere nothing is known to be dead, nothing
/// removed). Returns the paths removed.
pub fn sweep_dead(dir: &Path, name: &OsStr, pid_of: impl Fn(&str) -> Option<u32>) -> Vec<PathBuf> {
    let proc = Path::new("/proc");
    if !proc.join("self").exists() {
        return Vec::new();
    }
    let mut prefix = String::from(".");
    let Some(name) = name.to_str() else {
        return Vec::new();
    };
    prefix.push_str(name);
    prefix.push('.');
    let Ok(entries) = fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut removed = Vec::new();
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(rest) = file_name.to_str().and_then(|n| n.strip_prefix(&prefix)) else {
            continue;
        };
        let Some(pid) = pid_of(rest) else {
            continue;
        };
        if pid != std::process::id() && !proc.join(pid.to_string()).exists() {
            let path = entry.path();
            remove(&path);
            removed.push(path);
        }
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::tests_support::TempDir;

    /// A process id that is not running (the highest ids are rarely in use; checked).
    fn dead_pid() -> u32 {
        (1..1000)
            .map(|k| 4_194_304 - k)
            .find(|pid| !Path::new("/proc").join(pid.to_string()).exists())
            .expect("a free pid")
    }

    #[test]
    fn the_dead_writers_temporary_paths_of_this_name_are_swept_and_nothing_else() {
        let dir = TempDir::new("sweep");
        let dead = dead_pid();
        let me = std::process::id();
        for name in [
            format!(".out.mcap.{dead}-0.tmp"),
            format!(".out.mcap.{me}-0.tmp"),
            format!(".other.mcap.{dead}-0.tmp"),
            "out.mcap".to_owned(),
        ] {
            fs::write(dir.path().join(name), b"x").expect("file");
        }
        fs::create_dir(dir.path().join(format!(".out.mcap.partial-{dead}"))).expect("dir");
        let pid_of = |rest: &str| -> Option<u32> {
            let rest = rest.strip_suffix(".tmp")?;
            rest.split('-').next()?.parse().ok()
        };
        let removed = sweep_dead(dir.path(), OsStr::new("out.mcap"), pid_of);
        assert_eq!(removed.len(), 1, "{removed:?}");
        let removed = sweep_dead(dir.path(), OsStr::new("out.mcap"), |rest| {
            rest.strip_prefix("partial-")?.parse().ok()
        });
        assert_eq!(removed.len(), 1, "{removed:?}");
        let mut left = dir.entries();
        left.sort();
        assert_eq!(
            left,
            [
                format!(".other.mcap.{dead}-0.tmp"),
                format!(".out.mcap.{me}-0.tmp"),
                "out.mcap".to_owned()
            ]
        );
    }

    #[test]
    fn registered_paths_are_known_until_dropped_and_removed_whole() {
        let dir = TempDir::new("pending");
        let file = dir.path().join(".a.tmp");
        let staging = dir.path().join(".a.partial-1");
        fs::write(&file, b"x").expect("file");
        fs::create_dir(&staging).expect("dir");
        fs::write(staging.join("inside"), b"x").expect("file");
        let registered = |p: &Path| PENDING.lock().expect("lock").contains(&p.to_owned());
        let a = TempPath::new(file.clone());
        let b = TempPath::new(staging.clone());
        assert!(registered(&file) && registered(&staging));
        // What `remove_all` does to each (not called here: it would take other tests' files).
        remove(a.path());
        remove(b.path());
        assert!(!file.exists() && !staging.exists());
        drop((a, b));
        assert!(!registered(&file) && !registered(&staging));
    }
}
