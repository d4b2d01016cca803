//! The intersector seam: everything that traces rays goes through
//! [`Intersector`].
//!
//! Three kinds of backend plug in here:
//! - our own BVH ([`bvh`]), the default;
//! - Embree's `rtcIntersect1/4/8/16` (behind the `embree` feature);
//! - a host's ray tracer through C callbacks (the C API).
//!
//! [`backend`] (with `std`) picks one of the first two at run time.
//!
//! Packets exist because CMLT's multiple-try step traces k nearby rays at
//! once (a coherent bundle). A backend without a packet kernel inherits the
//! lane-by-lane defaults below, which are correct, only slower.

#[cfg(feature = "std")]
pub mod backend;
#[cfg(feature = "alloc")]
pub mod brute;
pub mod bvh;
mod dynamic;
#[cfg(feature = "embree")]
pub mod embree;

#[cfg(feature = "alloc")]
pub use brute::BruteForce;
pub use dynamic::DynIntersector;

use crate::geometry::{Hit, HitPacket, LaneMask, Ray, RayPacket};

/// Closest-hit and occlusion queries, for single rays and SoA packets.
///
/// Contract for every backend:
/// - hits are reported only for `t` in the open interval `(0, ray.t_max)`;
/// - `Hit::prim` uses the scene-global triangle numbering;
/// - triangles are hit from both sides (no back-face culling);
/// - lanes outside `active` are neither read nor written (their hit is left
///   untouched; their occlusion bit is returned clear);
/// - non-finite rays report no hit and never panic.
pub trait Intersector {
    /// The closest hit along `ray`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;

    /// Whether anything lies along `ray` in `(0, t_max)`.
    fn occluded(&self, ray: &Ray) -> bool;

    /// Closest hits for the active lanes of a packet (N = 4, 8 or 16).
    fn intersect_packet<const N: usize>(
        &self,
        rays: &RayPacket<N>,
        active: LaneMask,
        hits: &mut HitPacket<N>,
    ) {
        intersect_lanes(self, rays, active, hits)
    }

    /// Occlusion for the active lanes of a packet; bit `i` set = occluded.
    fn occluded_packet<const N: usize>(&self, rays: &RayPacket<N>, active: LaneMask) -> LaneMask {
        occluded_lanes(self, rays, active)
    }

    /// Closest hits of a stream of independent rays: `hits[i]` for
    /// `rays[i]`, for `i` below the shorter length. A backend may trace
    /// them in any order and several at once (our BVH keeps a few in
    /// flight so their memory loads overlap); each answer is what
    /// [`Self::intersect`] gives for that ray.
    fn intersect_stream(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        for (r, h) in rays.iter().zip(hits) {
            *h = self.intersect(r);
        }
    }

    /// Occlusion of a stream of independent rays: `occluded[i]` for
    /// `rays[i]`, for `i` below the shorter length; see
    /// [`Self::intersect_stream`].
    fn occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]) {
        for (r, o) in rays.iter().zip(occluded) {
            *o = self.occluded(r);
        }
    }
}

/// A packet's closest hits traced lane by lane with single rays: the
/// packet methods' default, and the form a packet takes where no kernel
/// is compiled for its width.
pub(crate) fn intersect_lanes<I: Intersector + ?Sized, const N: usize>(
    accel: &I,
    rays: &RayPacket<N>,
    active: LaneMask,
    hits: &mut HitPacket<N>,
) {
    for i in active.iter() {
        hits.set(i, accel.intersect(&rays.get(i)));
    }
}

/// A packet's occlusion traced lane by lane ([`intersect_lanes`]).
pub(crate) fn occluded_lanes<I: Intersector + ?Sized, const N: usize>(
    accel: &I,
    rays: &RayPacket<N>,
    active: LaneMask,
) -> LaneMask {
    let mut out = LaneMask::NONE;
    for i in active.iter() {
        if accel.occluded(&rays.get(i)) {
            out.set(i);
        }
    }
    out
}

impl<T: Intersector + ?Sized> Intersector for &T {
    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        (**self).intersect(ray)
    }
    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        (**self).occluded(ray)
    }
    #[inline]
    fn intersect_packet<const N: usize>(
        &self,
        rays: &RayPacket<N>,
        active: LaneMask,
        hits: &mut HitPacket<N>,
    ) {
        (**self).intersect_packet(rays, active, hits)
    }
    #[inline]
    fn occluded_packet<const N: usize>(&self, rays: &RayPacket<N>, active: LaneMask) -> LaneMask {
        (**self).occluded_packet(rays, active)
    }
    #[inline]
    fn intersect_stream(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        (**self).intersect_stream(rays, hits)
    }
    #[inline]
    fn occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]) {
        (**self).occluded_stream(rays, occluded)
    }
}
