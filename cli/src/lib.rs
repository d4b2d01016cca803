//! The cmlt front end as a library: image files, error metrics, the
//! multi-threaded render driver and the benchmarks, over the scene loading
//! (Mitsuba 3 XML) and run-time backend choice of `cmlt-scene`, which it
//! re-exports as [`scene`] and [`accel`]. The `cmlt` binary is a thin
//! command-line layer over it; tests use it directly.

pub mod bench;
pub mod frames;
pub mod image_io;
pub mod metrics;
pub mod render;

/// The Mitsuba 3 loader (crate `cmlt-scene`, re-exported).
pub use cmlt_scene as scene;
/// The run-time choice of backend (crate `cmlt-scene`, re-exported).
pub use cmlt_scene::accel;
