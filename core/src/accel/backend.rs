//! The ray-tracing backend a render uses, chosen at run time
//! (`cmlt render --accel ours|embree`, the C API's `CMLT_ACCEL_*`), for
//! hosts with `std` (building our BVH needs it).
//!
//! [`Accel`] is one [`Intersector`] over either backend, so every method
//! (PT, BDPT, MLT, CMLT) and the render driver stay generic over the trait
//! and never learn which backend they trace through. The dispatch is one
//! predictable branch per query, negligible next to a traversal.

use super::Intersector;
use super::bvh::Bvh;
use crate::geometry::{Hit, HitPacket, LaneMask, Ray, RayPacket};
use crate::math::Vec3;

/// Which backend to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AccelKind {
    /// Our BVH ([`super::bvh`]), always available.
    Ours,
    /// Embree 3 (`accel::embree`); only in builds with the `embree`
    /// feature.
    Embree,
}

impl AccelKind {
    /// Whether this build can use the backend.
    pub fn is_available(self) -> bool {
        match self {
            AccelKind::Ours => true,
            AccelKind::Embree => cfg!(feature = "embree"),
        }
    }
}

/// A built backend over a scene's triangles (scene-global numbering).
pub enum Accel {
    /// Our BVH.
    Ours(Bvh),
    /// Embree's BVH.
    #[cfg(feature = "embree")]
    Embree(crate::accel::embree::EmbreeScene),
}

impl Accel {
    /// Builds `kind` over `tris`. Errors name the reason: Embree asked of a
    /// build without the feature, or Embree failing to create its device.
    pub fn build(kind: AccelKind, tris: &[[Vec3; 3]]) -> Result<Accel, String> {
        match kind {
            AccelKind::Ours => Ok(Accel::Ours(Bvh::build(tris))),
            #[cfg(feature = "embree")]
            AccelKind::Embree => crate::accel::embree::EmbreeScene::new(tris)
                .map(Accel::Embree)
                .map_err(|e| format!("Embree: {e}")),
            #[cfg(not(feature = "embree"))]
            AccelKind::Embree => Err(
                "--accel embree: this cmlt was built without Embree (rebuild with `--features embree`)"
                    .to_string(),
            ),
        }
    }

    /// Follows `scene`'s triangles after meshes moved (same topology,
    /// `Scene::update_mesh`): our BVH is refitted in place, Embree's scene
    /// is rebuilt (its build is fast; a refit would need vertex buffers
    /// shared with Embree). On error `self` is unchanged.
    pub fn update(&mut self, scene: &crate::scene::Scene) -> Result<(), String> {
        match self {
            Accel::Ours(bvh) => bvh.refit(|p| scene.triangle(p)),
            #[cfg(feature = "embree")]
            Accel::Embree(_) => {
                *self = Accel::build(AccelKind::Embree, &scene.triangles().collect::<Vec<_>>())?;
            }
        }
        Ok(())
    }

    /// Short name (`ours`, `embree`), for logs.
    pub fn name(&self) -> &'static str {
        match self {
            Accel::Ours(_) => "ours",
            #[cfg(feature = "embree")]
            Accel::Embree(_) => "embree",
        }
    }
}

/// Calls `$body` with `$i` bound to the backend inside `$accel`.
macro_rules! dispatch {
    ($accel:expr, $i:ident => $body:expr) => {
        match $accel {
            Accel::Ours($i) => $body,
            #[cfg(feature = "embree")]
            Accel::Embree($i) => $body,
        }
    };
}

impl Intersector for Accel {
    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        dispatch!(self, i => i.intersect(ray))
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        dispatch!(self, i => i.occluded(ray))
    }

    #[inline]
    fn intersect_packet<const N: usize>(
        &self,
        rays: &RayPacket<N>,
        active: LaneMask,
        hits: &mut HitPacket<N>,
    ) {
        dispatch!(self, i => i.intersect_packet(rays, active, hits))
    }

    #[inline]
    fn occluded_packet<const N: usize>(&self, rays: &RayPacket<N>, active: LaneMask) -> LaneMask {
        dispatch!(self, i => i.occluded_packet(rays, active))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square in the z = 0 plane, as two triangles.
    fn square() -> [[Vec3; 3]; 2] {
        let [a, b, c, d] = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        [[a, b, c], [a, c, d]]
    }

    /// Our backend behind the switch answers exactly as the BVH it wraps.
    #[test]
    fn ours_answers_as_our_bvh() {
        let tris = square();
        let accel = Accel::build(AccelKind::Ours, &tris).unwrap();
        let bvh = Bvh::build(&tris);
        assert_eq!(accel.name(), "ours");
        for (x, y, hits) in [(0.75, 0.25, true), (0.25, 0.75, true), (1.5, 0.5, false)] {
            let ray = Ray::new(Vec3::new(x, y, -1.0), Vec3::Z);
            let hit = accel.intersect(&ray);
            assert_eq!(hit.is_some(), hits, "({x}, {y})");
            assert_eq!(hit, bvh.intersect(&ray));
            assert_eq!(accel.occluded(&ray), hits);
        }
    }

    /// Embree is available exactly in builds with the feature; asking a
    /// build without it is an error that says how to get it.
    #[test]
    fn embree_only_with_the_feature() {
        assert!(AccelKind::Ours.is_available());
        assert_eq!(AccelKind::Embree.is_available(), cfg!(feature = "embree"));
        if !cfg!(feature = "embree") {
            let e = Accel::build(AccelKind::Embree, &square()).err().unwrap();
            assert!(e.contains("built without Embree") && e.contains("--features embree"));
        }
    }
}
