//! The cmlt front end as a library: the command line's options
//! ([`args`]), image files, error metrics, the multi-threaded drivers over
//! the core's renderer ([`render`], [`frames`]), what `cmlt render`
//! writes ([`output`]) and the mergeable state of a part of a render split
//! over machines ([`state`], `cmlt merge`), over the scene loading (Mitsuba 3 XML)
//! of `cmlt-mitsuba` and the core's run-time backend choice, which it
//! re-exports as [`mitsuba`] and [`accel`]. The `cmlt` binary is a thin command-line layer
//! over it; the benchmarks (crate `cmlt-bench`) and the tests use it
//! directly.

pub mod args;
pub mod frames;
pub mod image_io;
pub mod metrics;
pub mod output;
pub mod render;
pub mod state;

use std::path::Path;

/// The run-time choice of backend (the core's `accel::backend`,
/// re-exported).
pub use cmlt::accel::backend as accel;
/// The Mitsuba 3 loader (crate `cmlt-mitsuba`, re-exported).
pub use cmlt_mitsuba as mitsuba;

use mitsuba::{LoadedScene, builtin_scene, load_scene};

/// Loads `name`: a built-in scene name (`cornell-box`) unless a file of
/// that name exists, else a Mitsuba 3 XML file; `defines` override the
/// scene's `<default>`s (`-D resx=64`).
pub fn load_scene_or_builtin(
    name: &str,
    defines: &[(String, String)],
) -> Result<LoadedScene, String> {
    match builtin_scene(name, defines) {
        Some(r) if !Path::new(name).exists() => r.map_err(|e| e.to_string()),
        _ => load_scene(Path::new(name), defines).map_err(|e| e.to_string()),
    }
}
