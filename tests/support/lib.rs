//! Shared support for the workspace-level end-to-end tests in `tests/`: the fixture
//! mechanisms generated at build time by `tests/support/build.rs`.

use std::path::PathBuf;

/// Absolute path of the workspace root (where `models/`, `beams/` and `scenarios/` live).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Mechanisms generated from their model files at build time.
pub mod fixtures {
    /// `models/double_bar.toml`
    pub mod double_bar {
        include!(concat!(env!("OUT_DIR"), "/double_bar.rs"));
    }
    /// `models/four_bar.toml`
    pub mod four_bar {
        include!(concat!(env!("OUT_DIR"), "/four_bar.rs"));
    }
    /// `models/slider_crank.toml`
    pub mod slider_crank {
        include!(concat!(env!("OUT_DIR"), "/slider_crank.rs"));
    }
    /// `tests/fixtures/spatial_arm.toml`
    pub mod spatial_arm {
        include!(concat!(env!("OUT_DIR"), "/spatial_arm.rs"));
    }
    /// `mbs_symbolic::samples::spatial_chain(16)` (struct `Chain16`): the 16-body spatial
    /// chain of the benchmarks.
    pub mod chain16 {
        include!(concat!(env!("OUT_DIR"), "/chain16.rs"));
    }
}
