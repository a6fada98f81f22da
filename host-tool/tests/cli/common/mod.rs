//! What the CLI tests share: the binary under test, a scratch directory, the Husky rover file.
#![allow(dead_code)] // not every helper is used by every build of the tests

use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh scratch directory `TAG-PID` in the system temp dir (a stale one is removed).
pub fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// The `host-tool` binary, with backtraces off so error output is what a user sees.
pub fn host_tool() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_host-tool"));
    c.env_remove("RUST_BACKTRACE")
        .env_remove("RUST_LIB_BACKTRACE");
    c
}

/// Runs `host-tool demo --runs 1 --out DIR/demo` and returns that directory (the test fails with
/// the demo's stderr if it fails).
pub fn demo_once(dir: &Path) -> PathBuf {
    let demo = dir.join("demo");
    let made = host_tool()
        .args(["demo", "--runs", "1", "--out"])
        .arg(&demo)
        .output()
        .expect("demo runs");
    assert!(
        made.status.success(),
        "{}",
        String::from_utf8_lossy(&made.stderr)
    );
    demo
}

/// `rovers/husky-a200.toml`.
pub fn rover_toml() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../rovers/husky-a200.toml")
}
