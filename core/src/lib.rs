//! # cmlt — Coherent Metropolis Light Transport
//!
//! An embeddable rendering core: physically based light transport with
//! Metropolis sampling and multiple-try perturbations traced as coherent ray
//! bundles (Segovia, Iehl, Péroche 2007).
//!
//! ## How the pieces fit
//!
//! ```text
//!   scene (meshes, materials, lights, camera) ──┐
//!                                               ▼
//!   accel::Intersector  ◄── our BVH | Embree | host callbacks
//!          ▲
//!          │ rays / packets
//!   integrator (PT, BDPT)  ──► film (accumulate + splat) ──► resolve
//!          ▲        ▲
//!          │   mlt (bootstrap b, chains over primary sample space)
//!          │        ▲
//!   sampler (Sampler trait: per-sample RNG streams | PrimarySampler)
//! ```
//!
//! - [`math`]: colour, frames, warps.
//! - [`geometry`]: rays, hits, packets, watertight triangles, robust offsets.
//! - [`accel`]: the intersector seam and the default BVH.
//! - [`scene`]: validated scene description, camera, lights.
//! - [`bsdf`]: scattering models evaluated in the local shading frame.
//! - [`sampler`]: deterministic random streams.
//! - [`integrator`]: path tracing and bidirectional path tracing.
//! - [`mlt`]: Metropolis light transport (level 1: primary-sample-space MLT
//!   over BDPT).
//! - [`film`]: pixel accumulation and splatting.
//! - [`renderer`]: the host's frame loop — a renderer plus one worker per
//!   host thread, all storage sized up front, merged at resolve.
//!
//! ## `no_std`
//!
//! Without default features the crate is `no_std` and allocation-free: math,
//! geometry, BSDFs and traversal over borrowed slices. `alloc` adds owned
//! scenes and films; `std` adds BVH construction (obvhs' PLOC and our binned
//! SAH builder, collapsed into 8-wide nodes).

#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]
// `!(x > 0.0)` is how this crate rejects NaN along with non-positive values;
// rewriting it as `x <= 0.0` would let NaN through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

#[cfg(feature = "alloc")]
extern crate alloc;

// The unit tests below `mlt` include the integration tests' scene builders
// (`core/tests/common`), which name this crate `cmlt`.
#[cfg(all(test, feature = "std"))]
extern crate self as cmlt;

pub mod accel;
pub mod bsdf;
pub mod geometry;
pub mod math;
pub mod sampler;
pub mod scene;

#[cfg(feature = "alloc")]
pub mod aov;
#[cfg(feature = "alloc")]
pub mod film;
#[cfg(feature = "alloc")]
pub mod integrator;
#[cfg(feature = "alloc")]
pub mod mlt;
#[cfg(feature = "alloc")]
pub mod renderer;
