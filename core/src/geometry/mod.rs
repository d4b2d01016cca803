//! Rays, hits and the robust geometry they need.
//!
//! - [`Ray`]/[`Hit`]: the single-ray currency of the intersector seam.
//! - [`packet`]: the SoA packets of 4/8/16 rays that coherent bundles use.
//! - [`triangle`]: the watertight ray–triangle test (Woop, Benthin, Wald 2013).
//! - [`offset`]: error-bounded spawn points so secondary rays never re-hit
//!   their own surface, with no scene-scale epsilon (pbrt-v4, §6.8).

pub mod offset;
pub mod packet;
pub mod triangle;

use glam::Vec3;

pub use packet::{HitPacket, LaneMask, RayPacket};

/// A ray `o + t·d` for `t` in the open interval `(0, t_max)`.
///
/// `d` need not be unit length: `t` is measured in units of `|d|`. Shadow
/// rays use an unnormalised `d` spanning the segment and `t_max < 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin (already offset off its surface by the spawner).
    pub o: Vec3,
    /// Direction.
    pub d: Vec3,
    /// Exclusive upper bound of the hit distance, in units of `|d|`.
    pub t_max: f32,
}

impl Ray {
    /// An unbounded ray.
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray {
            o,
            d,
            t_max: f32::INFINITY,
        }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// The closest intersection found along a ray.
///
/// `prim` is the scene-global triangle index (meshes are numbered in the
/// order they were added, triangles consecutively within each mesh); every
/// backend — our BVH, Embree, host callbacks — reports this numbering.
/// `(b1, b2)` are the barycentric weights of vertices 1 and 2. A host
/// intersector hitting one of its own analytic shapes reports
/// `prim = SHAPE_PRIM_BIT | shape` and its surface parameters in
/// `(b1, b2)` instead (`scene::shapes`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit, in `(0, t_max)`.
    pub t: f32,
    /// Scene-global triangle index (or host shape index with
    /// `SHAPE_PRIM_BIT`).
    pub prim: u32,
    /// Barycentric weight of the triangle's second vertex.
    pub b1: f32,
    /// Barycentric weight of the triangle's third vertex.
    pub b2: f32,
}
