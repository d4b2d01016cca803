//! The CLI crate's integration tests, in one binary so that the renderer
//! and loader code they share is compiled once (each test binary
//! instantiates the generic renderer again). Run one part with a filter,
//! e.g. `cargo test -p cmlt-cli --test suite references::`.
//!
//! - [`bvh_scenes`]: the default BVH against brute force on the shared
//!   scenes;
//! - [`cli`]: the `cmlt` binary end to end, bad input included;
//! - [`conductor_presets`]: the conductors' `material` presets against
//!   Mitsuba 3 itself;
//! - [`corpus`]: Bitterli's 25 Mitsuba scenes against an expectation table;
//! - [`effects`]: the effect analysis of the shared scenes;
//! - [`frames`]: kept Metropolis chains after a camera that moves and
//!   returns against the Cornell-box reference;
//! - [`loader`]: the Mitsuba 3 XML loader and its malformed corpus;
//! - [`media_loader`]: participating media and the null BSDF in the
//!   loader, malformed media refused with their line;
//! - [`mlt`]: level-1 MLT against the Cornell-box reference, determinism;
//! - [`pfm_images`]: PFM environment maps and textures as Mitsuba 3 reads
//!   them, and malformed files refused;
//! - [`parts`]: renders split into parts and merged (`--part`, `cmlt
//!   merge`) against single renders, and the merge's refusals;
//! - [`references`]: PT and BDPT against Mitsuba 3's references.
//!
//! `embree_render` stays a separate binary: CI builds it with the `embree`
//! feature. The benchmarks' tests are the `cmlt-bench` crate's (`bench/`).

#[path = "../common/mod.rs"]
mod common;

mod bvh_scenes;
mod cli;
mod conductor_presets;
mod corpus;
mod effects;
mod frames;
mod grid_textures;
mod loader;
mod media_loader;
mod mlt;
mod parts;
mod pfm_images;
mod references;
