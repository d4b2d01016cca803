//! Helpers shared by the benchmarks' integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

/// The test scenes: `$CMLT_SCENES_DIR` if set, else the copies of the
/// shared scenes committed under `tests/scenes`.
pub fn scenes_dir() -> PathBuf {
    let dir = std::env::var_os("CMLT_SCENES_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/scenes")));
    assert!(dir.is_dir(), "no test scenes at {}", dir.display());
    dir
}
