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
//! - [`effects`]: scenes needing an effect whose feature is off are
//!   refused (here, with every effect, they render);
//! - [`furnace`]: white-furnace answers of every estimator;
//! - [`lights`]: point, spot, directional and environment lights with
//!   analytic answers;
//! - [`media`]: participating media with analytic answers (slab
//!   transmittance, the scattering furnace), and their refusal by the
//!   estimators that do not render them yet;
//! - [`miri`]: the subset Miri runs (scalar BVH kernel, packets, tiny
//!   render passes), natively;
//! - [`mlt`]: level-1 MLT and CMLT on scenes with exact answers;
//! - [`outputs`]: the resolve by rows in every pixel format and the
//!   auxiliary outputs (depth, normal, albedo, motion) on analytic scenes;
//! - [`pixel_block`]: PT and BDPT passes at a coarser pixel grid
//!   (dynamic resolution): filled blocks, the block-filtered image, full
//!   frames below one pass;
//! - [`renderer`]: the host's frame loop, including that it allocates
//!   nothing per frame;
//! - [`rough_diffuse`]: an Oren–Nayar plane under a sun, analytic;
//! - [`shapes`]: host-intersected analytic shapes;
//! - [`stability`]: the adversarial suite.
//!
//! `effects` and `miri` also have roots of their own (`tests/effects.rs`,
//! `tests/miri.rs`) that `cargo test` skips: CI builds those without the
//! effects and under Miri. `embree` is a separate binary with its feature.

#[path = "../common/mod.rs"]
mod common;
#[path = "../intersect/mod.rs"]
mod intersect;

mod architecture;
mod block_fill;
mod bvh;
mod detail;
mod effects;
mod furnace;
mod lights;
mod media;
mod miri;
mod mlt;
mod outputs;
mod pixel_block;
mod renderer;
mod rough_diffuse;
mod shapes;
mod stability;
