//! Benchmarks of the front end (`cmlt bench …`).

pub mod flicker;
pub mod rays;
