//! Shared helpers for the workspace-level end-to-end tests in `tests/`.
//!
//! The tests drive the `damper` binary exactly as a user would.

use std::path::PathBuf;

/// Absolute path of the workspace root (where `models/`, `beams/` and `scenarios/` live).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}
