//! PLACEHOLDER: brute-force intersector (being written).

use alloc::vec::Vec;


use glam::Vec3;

use super::Intersector;
use crate::geometry::{Hit, Ray, triangle::intersect_triangle};

/// Tests every triangle; the ground truth the BVH is checked against.
pub struct BruteForce {
    tris: Vec<[Vec3; 3]>,
}

impl BruteForce {
    /// Over triangles in scene-global order.
    pub fn new(tris: impl IntoIterator<Item = [Vec3; 3]>) -> Self {
        BruteForce { tris: tris.into_iter().collect() }
    }
}

impl Intersector for BruteForce {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut r = *ray;
        let mut best = None;
        for (i, t) in self.tris.iter().enumerate() {
            if let Some((d, b1, b2)) = intersect_triangle(&r, t[0], t[1], t[2]) {
                r.t_max = d;
                best = Some(Hit { t: d, prim: i as u32, b1, b2 });
            }
        }
        best
    }
    fn occluded(&self, ray: &Ray) -> bool {
        self.tris.iter().any(|t| intersect_triangle(ray, t[0], t[1], t[2]).is_some())
    }
}
