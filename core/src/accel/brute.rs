//! Brute-force intersector: every triangle, every ray. The ground truth the
//! BVH is tested against, and a fine backend for a handful of triangles.

use alloc::vec::Vec;

use glam::Vec3;

use super::Intersector;
use crate::geometry::triangle::{WatertightRay, is_degenerate};
use crate::geometry::{Hit, Ray};

/// Tests every triangle with the watertight test, in scene-global order.
#[derive(Clone, Debug, Default)]
pub struct BruteForce {
    /// Non-degenerate triangles with their scene-global index.
    tris: Vec<([Vec3; 3], u32)>,
}

impl BruteForce {
    /// Over triangles in scene-global order (the `i`-th is reported as
    /// `prim == i`). Degenerate triangles
    /// ([`is_degenerate`]) are
    /// dropped up front since they can never be hit.
    ///
    /// # Panics
    /// If there are `u32::MAX` triangles or more.
    pub fn new(tris: impl IntoIterator<Item = [Vec3; 3]>) -> Self {
        let tris = tris
            .into_iter()
            .enumerate()
            .map(|(i, t)| {
                (
                    t,
                    u32::try_from(i)
                        .ok()
                        .filter(|&i| i != u32::MAX)
                        .expect("too many triangles"),
                )
            })
            .filter(|(t, _)| !is_degenerate(t[0], t[1], t[2]))
            .collect();
        BruteForce { tris }
    }
}

impl Intersector for BruteForce {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let wr = WatertightRay::new(ray)?;
        let mut t_max = ray.t_max;
        let mut best = None;
        for (t, i) in &self.tris {
            // Strictly closer only: among exactly equal distances the first
            // triangle in global order wins.
            if let Some((d, b1, b2)) = wr.intersect(t[0], t[1], t[2], t_max) {
                t_max = d;
                best = Some(Hit {
                    t: d,
                    prim: *i,
                    b1,
                    b2,
                });
            }
        }
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let Some(wr) = WatertightRay::new(ray) else {
            return false;
        };
        self.tris
            .iter()
            .any(|(t, _)| wr.intersect(t[0], t[1], t[2], ray.t_max).is_some())
    }
}
