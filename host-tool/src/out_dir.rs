//! Output directories written whole or not at all (`diagnose --out`, `plot --out`, `demo
//! --out`): the files go into a hidden sibling directory first, which replaces the target only
//! when every file is written. A command that fails half-way leaves the old directory as it was
//! (no new figures beside an old `model.toml`), and no partial one.

use crate::temp_paths::TempPath;
use std::ffi::OsString;
use std::fs;
use std::io;
use std::path::{Path, PathBuf};

/// Why an output directory was not written.
#[derive(Debug, thiserror::Error)]
pub enum OutDirError<E> {
    /// The target exists, holds files and may not be replaced.
    #[error("{}: the output directory exists and is not empty (pass --force to replace it)", .0.display())]
    Exists(PathBuf),
    /// The target is a file, not a directory.
    #[error("{}: exists and is not a directory", .0.display())]
    NotADirectory(PathBuf),
    /// Creating, renaming or removing a directory failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The directory.
        path: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// Writing the content failed; the target is untouched.
    #[error(transparent)]
    Content(E),
}

/// Whether `dir` is missing or an empty directory.
pub fn is_missing_or_empty(dir: &Path) -> bool {
    fs::read_dir(dir).map_or(!dir.exists(), |mut entries| entries.next().is_none())
}

/// Writes the directory `dir` whole or not at all: `write` fills a fresh staging directory
/// (its argument), which then takes `dir`'s place. An existing non-empty `dir` is replaced only
/// when `replace` (the CLI's `--force`); otherwise it is an error before anything is written.
/// Parent directories are created. Paths `write` returns under the staging directory are
/// best mapped back with [`rebase`].
pub fn write_dir_whole<T, E>(
    dir: &Path,
    replace: bool,
    write: impl FnOnce(&Path) -> Result<T, E>,
) -> Result<T, OutDirError<E>> {
    let io_err = |path: &Path| {
        let path = path.to_owned();
        move |source| OutDirError::Io { path, source }
    };
    if dir.exists() && !dir.is_dir() {
        return Err(OutDirError::NotADirectory(dir.to_owned()));
    }
    if !replace && !is_missing_or_empty(dir) {
        return Err(OutDirError::Exists(dir.to_owned()));
    }
    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_owned(),
        _ => PathBuf::from("."),
    };
    fs::create_dir_all(&parent).map_err(io_err(&parent))?;
    // What a killed writer of this directory left (a SIGKILL cannot be caught).
    if let Some(name) = dir.file_name() {
        // Only staging directories: a `.old-PID` one holds the previous output of a writer
        // killed between its two renames.
        crate::temp_paths::sweep_dead(&parent, name, |rest| {
            rest.strip_prefix("partial-")?.parse().ok()
        });
    }
    let staging = sibling(dir, &parent, "partial");
    if staging.exists() {
        fs::remove_dir_all(&staging).map_err(io_err(&staging))?;
    }
    // Registered while it exists: a stop signal removes it ([`crate::temp_paths`]).
    let _registered = TempPath::new(staging.clone());
    fs::create_dir(&staging).map_err(io_err(&staging))?;
    let value = match write(&staging) {
        Ok(value) => value,
        Err(e) => {
            let _ = fs::remove_dir_all(&staging);
            return Err(OutDirError::Content(e));
        }
    };
    if dir.exists() {
        // Two renames: the old directory is never half replaced.
        let old = sibling(dir, &parent, "old");
        fs::rename(dir, &old).map_err(io_err(dir))?;
        if let Err(source) = fs::rename(&staging, dir) {
            let _ = fs::rename(&old, dir);
            return Err(OutDirError::Io {
                path: dir.to_owned(),
                source,
            });
        }
        fs::remove_dir_all(&old).map_err(io_err(&old))?;
    } else {
        fs::rename(&staging, dir).map_err(io_err(dir))?;
    }
    Ok(value)
}

/// `path` under `from` moved to the same place under `to` (unchanged if not under `from`).
pub fn rebase(path: &Path, from: &Path, to: &Path) -> PathBuf {
    path.strip_prefix(from)
        .map_or_else(|_| path.to_owned(), |rest| to.join(rest))
}

/// A hidden sibling of `dir` for this process: `.NAME.KIND-PID`.
fn sibling(dir: &Path, parent: &Path, kind: &str) -> PathBuf {
    let mut name = OsString::from(".");
    name.push(dir.file_name().unwrap_or(dir.as_os_str()));
    name.push(format!(".{kind}-{}", std::process::id()));
    parent.join(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("out-dir-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).expect("temp dir");
        dir
    }

    #[test]
    fn a_failure_half_way_leaves_the_old_directory_as_it_was() {
        // Issue 11, bug 6: diagnose left the old model.toml beside new figures.
        let root = temp("fail");
        let out = root.join("diag");
        fs::create_dir(&out).expect("dir");
        fs::write(out.join("model.toml"), "old").expect("old file");
        let result: Result<(), OutDirError<&str>> = write_dir_whole(&out, true, |tmp| {
            fs::write(tmp.join("figure.png"), "new").expect("new file");
            Err("the report failed")
        });
        assert!(matches!(
            result,
            Err(OutDirError::Content("the report failed"))
        ));
        let names: Vec<_> = fs::read_dir(&out)
            .expect("still there")
            .map(|e| e.expect("entry").file_name())
            .collect();
        assert_eq!(names, ["model.toml"]);
        assert_eq!(
            fs::read_to_string(out.join("model.toml")).expect("old"),
            "old"
        );
        assert_eq!(
            fs::read_dir(&root).expect("root").count(),
            1,
            "no staging left"
        );
        let _ = fs::remove_dir_all(&root);
    }

    #[test]
    fn success_replaces_the_directory_whole_and_refuses_without_force() {
        let root = temp("ok");
        let out = root.join("a/b/diag");
        let files = write_dir_whole(&out, false, |tmp| {
            fs::write(tmp.join("x.txt"), "1").map(|()| vec![tmp.join("x.txt")])
        })
        .expect("written, parents created");
        assert_eq!(fs::read_to_string(out.join("x.txt")).expect("x"), "1");
        assert!(files[0].starts_with(root.join("a/b")));
        let e = write_dir_whole(&out, false, |_| Ok::<_, io::Error>(()))
            .expect_err("not empty, no force");
        assert!(e.to_string().contains("--force"), "{e}");
        write_dir_whole(&out, true, |tmp| fs::write(tmp.join("y.txt"), "2")).expect("replaced");
        assert!(
            !out.join("x.txt").exists(),
            "nothing of the old directory stays"
        );
        assert!(out.join("y.txt").exists());
        assert_eq!(
            rebase(&root.join(".s/z.png"), &root.join(".s"), &out),
            out.join("z.png")
        );
        let _ = fs::remove_dir_all(&root);
    }
}
