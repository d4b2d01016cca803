//! The cmlt front end as a library: scene loading (Mitsuba 3 XML), image
//! files, error metrics, the run-time choice of ray-tracing backend and the
//! multi-threaded render driver. The `cmlt` binary is a thin command-line
//! layer over it; tests use it directly.

pub mod accel;
pub mod bench;
pub mod frames;
pub mod image_io;
pub mod metrics;
pub mod render;

pub mod scene;
