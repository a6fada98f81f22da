//! What every command's outputs have in common: `--json FILE|-`, `--force`, directories
//! created, files written whole or not at all, and stdout written without `print!` (a closed
//! stdout is an error that ends the command quietly, not a panic).

use anyhow::{bail, Context, Result};
use host_tool::log::write_atomically;
use host_tool::log::Existing;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

pub use host_tool::analysis::naming;

/// `--json FILE|-`, the same for every command.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct JsonOut {
    /// Write JSON to FILE, or to stdout with `-` (or `--json` alone); then no table is printed.
    #[arg(long, value_name = "FILE|-", num_args = 0..=1, default_missing_value = "-")]
    pub json: Option<PathBuf>,
}

impl JsonOut {
    /// Writes `value` as pretty JSON where `--json` says (nothing without it). Returns whether
    /// it went to stdout.
    pub fn emit(&self, value: &impl serde::Serialize, what: &str, force: bool) -> Result<bool> {
        let Some(path) = &self.json else {
            return Ok(false);
        };
        let mut text =
            serde_json::to_vec_pretty(value).with_context(|| format!("serialising the {what}"))?;
        text.push(b'\n');
        if is_stdout(path) {
            stdout(&text)?;
            Ok(true)
        } else {
            write_file(path, &text, force)?;
            Ok(false)
        }
    }

    /// Refuses an existing JSON file before any work is done (unless `force`).
    pub fn check(&self, force: bool) -> Result<()> {
        match &self.json {
            Some(path) if !is_stdout(path) => check_new_file(path, force),
            _ => Ok(()),
        }
    }
}

fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Writes `bytes` to stdout (a closed stdout is an error, not a panic).
pub fn stdout(bytes: &[u8]) -> Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(bytes)?;
    out.flush()?;
    Ok(())
}

/// Writes `text` to stdout.
pub fn print(text: impl std::fmt::Display) -> Result<()> {
    stdout(text.to_string().as_bytes())
}

/// An existing regular file at `path` is refused unless `force` (devices and FIFOs such as
/// `/dev/null` are written in place, never replaced).
pub fn check_new_file(path: &Path, force: bool) -> Result<()> {
    if !force && fs::metadata(path).is_ok_and(|m| m.is_file()) {
        bail!("{}: exists (pass --force to overwrite it)", path.display());
    }
    if path.is_dir() {
        bail!("{}: is a directory, not a file", path.display());
    }
    Ok(())
}

/// Writes `bytes` to `path` whole or not at all, creating its directory; an existing file
/// needs `force`.
pub fn write_file(path: &Path, bytes: &[u8], force: bool) -> Result<()> {
    check_new_file(path, force)?;
    create_parent(path)?;
    // The error names the file (either part of AtomicWriteError).
    write_atomically(path, Existing::from_force(force), |w| w.write_all(bytes))?;
    Ok(())
}

/// Creates the directory `path` will be written into.
pub fn create_parent(path: &Path) -> Result<()> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => {
            fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))
        }
        _ => Ok(()),
    }
}

/// Paths written under a staging directory, named under the directory they now live in.
pub fn rebased(files: Vec<PathBuf>, staging: &Path, dir: &Path) -> Vec<PathBuf> {
    files
        .iter()
        .map(|f| host_tool::out_dir::rebase(f, staging, dir))
        .collect()
}
