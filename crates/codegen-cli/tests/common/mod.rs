//! Shared harness of the CLI end-to-end tests: run the `damper` binary as a user would.

#![allow(dead_code)] // each test binary uses its own subset

use std::path::PathBuf;
use std::process::Command;

/// The workspace root (the binary runs there, so bundled paths like `models/...` resolve).
pub fn root() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

/// Runs `damper ARGS` in the workspace root: (exit code, stdout, stderr).
pub fn damper(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_damper"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("run damper");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}
