//! Benchmarks of the front end (`cmlt bench …`).

pub mod rays;
