//! The core's integration tests, in one binary so that the generic
//! renderer, integrators and BVH kernels are compiled once for all of them
//! (each test binary instantiates them again; the six binaries merged here
//! took 280 s of compile time between them). Run one part with a filter,
//! e.g. `cargo test -p cmlt --test suite stability::`.
//!
//! - [`architecture`]: no import cycle between the core's top-level
//!   modules;
//! - [`bvh`]: the default BVH against brute force, watertightness, spawn
//!   offsets, packets with any mask;
//! - [`detail`]: normal maps, bump maps and alpha masks;
//! - [`furnace`]: white-furnace answers of every estimator;
//! - [`lights`]: point, spot, directional and environment lights with
//!   analytic answers;
//! - [`mlt`]: level-1 MLT and CMLT on scenes with exact answers;
//! - [`outputs`]: the resolve by rows in every pixel format and the
//!   auxiliary outputs (depth, normal, albedo, motion) on analytic scenes;
//! - [`renderer`]: the host's frame loop, including that it allocates
//!   nothing per frame;
//! - [`rough_diffuse`]: an Oren–Nayar plane under a sun, analytic;
//! - [`shapes`]: host-intersected analytic shapes;
//! - [`stability`]: the adversarial suite.
//!
//! `effects`, `miri` and `embree` stay separate binaries: CI builds them
//! with other features or under Miri.

#[path = "../common/mod.rs"]
mod common;
#[path = "../intersect/mod.rs"]
mod intersect;

mod architecture;
mod bvh;
mod detail;
mod furnace;
mod lights;
mod mlt;
mod outputs;
mod renderer;
mod rough_diffuse;
mod shapes;
mod stability;
