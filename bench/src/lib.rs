//! The benchmarks of cmlt (`cmlt-bench …`): the lab apart from the
//! product. They drive the same API as `cmlt render` and C hosts (the
//! core's renderer through [`cmlt_cli::render`] and [`cmlt_cli::frames`]);
//! the product never depends on this crate.
//!
//! - [`rays`]: ray throughput of every traversal kernel;
//! - [`ray_targets`]: the throughput targets against Embree checked on `rays`'
//!   measurements (one run, or the CSVs of several);
//! - [`convergence`]: error against a reference versus time, per method;
//! - [`params`]: CMLT's σ × k × m grid at a fixed time;
//! - [`flicker`]: frame-to-frame flicker with and without the temporal
//!   switches;
//! - [`effects`]: samples/s and mutations/s with the scene analysis on
//!   versus `--all-effects`;
//! - [`frames`]: a game engine's frame loop through the C API (the C++
//!   host `examples-c/frame_trial.cpp`) against frame-time, set-up, black
//!   pixel and flicker targets;
//! - [`prepare`]: a first frame's bootstrap on one thread versus spread
//!   over the workers' threads;
//! - [`outputs`]: the per-frame resolve in every pixel format against the
//!   resolve before `resolve_rows`, and the auxiliary outputs;
//! - [`still`]: a still camera's frames kept by the accumulation against
//!   one offline render of the same mutations and of the same time;
//! - [`study`]: what the accuracy benchmarks share (one scored render);
//! - [`plot`]: their PNG/SVG plots.

pub mod convergence;
pub mod effects;
pub mod flicker;
pub mod frames;
pub mod outputs;
pub mod params;
pub mod plot;
pub mod prepare;
pub mod ray_targets;
pub mod rays;
pub mod still;
pub mod study;
