//! Host shapes: surfaces the host defines analytically (spheres, patches,
//! displaced or implicit surfaces) and intersects with its own ray tracer.
//!
//! The core never intersects a shape. A host intersector that hits one
//! reports `prim = SHAPE_PRIM_BIT | shape` and puts two numbers of its own
//! choosing — the shape's surface parameters, e.g. the polar angles of a
//! sphere — into `Hit::b1`/`b2`. The core hands them back to
//! [`ShapeSurface::surface`] to learn the point it shades: position, its
//! error bound, normals, texture coordinates. This is the split of
//! Embree's user geometry (intersection from the host, the hit record
//! carrying parameters) and pbrt's shapes (the shape reconstructs its
//! interaction from them).
//!
//! Shapes scatter with a material but do not emit: light sampling needs
//! an area measure the core can sample, which only triangles give it.

use alloc::sync::Arc;
use core::fmt;

use glam::{Vec2, Vec3};

use super::material::MaterialId;

/// `Hit::prim` values with this bit set name a host shape (the low 31 bits
/// are its index among the scene's shapes); without it, a triangle.
pub const SHAPE_PRIM_BIT: u32 = 1 << 31;

/// A point on a host shape as the host describes it (not yet checked).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShapePoint {
    /// Position.
    pub p: Vec3,
    /// Conservative absolute error bound of `p` per axis: ray origins are
    /// pushed past it so secondary rays do not hit the surface they leave.
    /// For a point reprojected onto an analytic surface, a few ulps of
    /// `|p|` per axis (pbrt's γ₅·|p|) is right.
    pub p_error: Vec3,
    /// Geometric normal (any length > 0): the true surface normal.
    pub ng: Vec3,
    /// Shading normal (any length > 0); equal to `ng` for no shading
    /// normals.
    pub ns: Vec3,
    /// Texture coordinates.
    pub uv: Vec2,
}

impl ShapePoint {
    /// Whether the host's point is usable: everything finite, a
    /// non-negative error bound and non-zero normals. A point that fails
    /// is treated like a degenerate triangle (nothing scatters there).
    pub fn is_valid(&self) -> bool {
        self.p.is_finite()
            && self.p_error.is_finite()
            && self.p_error.min_element() >= 0.0
            && self.uv.is_finite()
            && [self.ng, self.ns]
                .iter()
                .all(|n| n.is_finite() && n.length_squared() > 0.0)
    }

    /// Unit normals, the geometric one turned to the shading normal's side
    /// (the invariant [`super::SurfacePoint`] keeps for triangles too), or
    /// `None` when the point is not [valid](Self::is_valid).
    pub fn unit_normals(&self) -> Option<(Vec3, Vec3)> {
        if !self.is_valid() {
            return None;
        }
        // length_squared > 0 may still underflow to a zero length for
        // subnormal components; normalize_or_zero catches that.
        let ns = self.ns.normalize_or_zero();
        let ng = self.ng.normalize_or_zero();
        if ns == Vec3::ZERO || ng == Vec3::ZERO {
            return None;
        }
        Some((if ng.dot(ns) < 0.0 { -ng } else { ng }, ns))
    }
}

/// The host's side of its shapes: where on shape `shape` (an index within
/// the group, `0..count`) the surface parameters `(u, v)` its intersector
/// reported lie. Called from every render thread; must not panic for any
/// `(u, v)` its own intersector produced.
pub trait ShapeSurface: Send + Sync {
    /// The surface point, or `None` when the host has none there.
    fn surface(&self, shape: u32, u: f32, v: f32) -> Option<ShapePoint>;
}

/// A group of host shapes sharing one material and one [`ShapeSurface`].
#[derive(Clone)]
pub struct ShapeGroup {
    /// Number of shapes; they take the next `count` shape indices.
    pub count: u32,
    /// Material of every shape of the group.
    pub material: MaterialId,
    /// The host's surface reconstruction.
    pub surface: Arc<dyn ShapeSurface>,
}

impl fmt::Debug for ShapeGroup {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ShapeGroup")
            .field("count", &self.count)
            .field("material", &self.material)
            .finish_non_exhaustive()
    }
}
