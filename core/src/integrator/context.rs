//! What every estimator needs per sample: the scene, the intersector and
//! counters.

use glam::Vec3;

use crate::accel::Intersector;
use crate::bsdf::Bsdf;
use crate::geometry::{Ray, offset};
use crate::math::Frame;
use crate::scene::{Scene, SurfacePoint};

/// Work counters of one worker; summed across workers by the host.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Closest-hit rays traced.
    pub rays: u64,
    /// Occlusion (shadow/connection) rays traced.
    pub shadow_rays: u64,
    /// Camera samples (one per pixel per pass).
    pub samples: u64,
}

impl Stats {
    /// Adds another worker's counters.
    pub fn merge(&mut self, o: &Stats) {
        self.rays += o.rays;
        self.shadow_rays += o.shadow_rays;
        self.samples += o.samples;
    }

    /// All rays of both kinds.
    pub fn total_rays(&self) -> u64 {
        self.rays + self.shadow_rays
    }
}

/// Scene, intersector and counters for one worker.
pub struct Tracer<'a, I: Intersector> {
    /// The scene.
    pub scene: &'a Scene,
    /// The intersector over the scene's triangles.
    pub accel: &'a I,
    /// This worker's counters.
    pub stats: Stats,
}

/// A surface point with its resolved BSDF and shading frame.
#[derive(Clone, Copy, Debug)]
pub struct Shading {
    /// The point.
    pub sp: SurfacePoint,
    /// BSDF with textures evaluated at the point.
    pub bsdf: Bsdf,
    /// Frame around the shading normal.
    pub frame: Frame,
}

impl<'a, I: Intersector> Tracer<'a, I> {
    /// A tracer with zeroed counters.
    pub fn new(scene: &'a Scene, accel: &'a I) -> Self {
        Tracer {
            scene,
            accel,
            stats: Stats::default(),
        }
    }

    /// Closest surface along `ray`, resolved for shading. Degenerate
    /// triangles are treated as misses.
    #[inline]
    pub fn trace(&mut self, ray: &Ray) -> Option<Shading> {
        self.stats.rays += 1;
        let hit = self.accel.intersect(ray)?;
        let sp = self.scene.hit_point(&hit)?;
        Some(self.shade(sp))
    }

    /// Resolves the BSDF and frame at a surface point.
    #[inline]
    pub fn shade(&self, sp: SurfacePoint) -> Shading {
        let scene = self.scene;
        let bsdf = Bsdf::new(scene.material(&sp), |t| t.eval(sp.uv, &scene.bitmaps));
        Shading {
            sp,
            bsdf,
            frame: Frame::from_normal(sp.ns),
        }
    }

    /// Whether the segment between two surface points is blocked.
    #[inline]
    pub fn occluded_between(&mut self, a: &SurfacePoint, b: &SurfacePoint) -> bool {
        self.stats.shadow_rays += 1;
        let r = offset::spawn_ray_between(a.p, a.p_error, a.ng, b.p, b.p_error, b.ng);
        self.accel.occluded(&r)
    }

    /// Whether the segment from a surface point to a free point (a camera
    /// lens) is blocked.
    #[inline]
    pub fn occluded_to_point(&mut self, a: &SurfacePoint, p: Vec3) -> bool {
        self.stats.shadow_rays += 1;
        let r = offset::spawn_ray_between(a.p, a.p_error, a.ng, p, Vec3::ZERO, Vec3::ZERO);
        self.accel.occluded(&r)
    }
}
