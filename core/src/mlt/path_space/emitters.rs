//! What the path-space mutations need of a path's emitter end x_k beyond
//! its measure ([`bdpt::PathEnd`] and the path measure's docs say how
//! f(x̄) and the densities treat each kind): a new emitter vertex, the ray
//! leaving a kept one, and the visibility of an edge that ends on it.
//!
//! Each is sampled with the density the path measure gives it, as BDPT's
//! light subpaths sample it: a point on an area light by area then a
//! cosine-distributed direction; a point or spot light's direction by its
//! emission distribution; a light at infinity's direction by light
//! selection and its own sampling, then the ray's origin uniformly on the
//! bounding sphere's disk. A delta light's direction (a directional light)
//! or position (a point light) is fixed: only the free part is drawn.

use glam::Vec2;

use crate::accel::Intersector;
use crate::geometry::{Ray, offset};
use crate::integrator::Tracer;
use crate::integrator::bdpt::{self, PathEnd, PathVertex};
use crate::math::{Frame, warp};
use crate::scene::{EmitterSample, Scene};

/// A new emitter vertex and, for a light that is not a mesh, the ray it
/// emits (sampled together: [`crate::scene::light::LightSet::sample_emission`]).
pub(super) fn new_emitter<I: Intersector>(
    tr: &Tracer<'_, I>,
    u_select: f32,
    u_pos: Vec2,
    u_dir: Vec2,
) -> Option<(PathVertex, Option<Ray>)> {
    match tr.scene.sample_emitter(u_select, u_pos)? {
        EmitterSample::Area { sp, .. } => {
            Some((super::bidirectional::surface_vertex(tr.shade(sp)), None))
        }
        EmitterSample::Other { index, .. } => {
            let e = tr.scene.lights.sample_emission(index, u_pos, u_dir)?;
            let v = bdpt::emission_vertex(tr.scene, index, &e);
            Some((v, Some(Ray::new(e.origin, e.dir))))
        }
    }
}

/// The ray leaving emitter vertex `v` (the end of a path of `scene`)
/// towards the rest of a light subpath, `u` placing it (module docs).
pub(super) fn emission_ray(scene: &Scene, v: &PathVertex, u: Vec2) -> Option<Ray> {
    let sp = &v.sp;
    match PathEnd::of(scene, v) {
        PathEnd::Area => {
            let w = Frame::from_normal(sp.ns).to_world(warp::square_to_cosine_hemisphere(u));
            Some(offset::spawn_ray(sp.p, sp.p_error, sp.ng, w))
        }
        // The position (point) or the direction (directional) is the
        // light's own; `sample_emission` draws the other from `u`.
        PathEnd::Point(i) | PathEnd::Directional(i) => {
            let e = scene.lights.sample_emission(i as usize, u, u)?;
            Some(Ray::new(e.origin, e.dir))
        }
        PathEnd::Environment => Some(Ray::new(scene.lights.disk_origin(sp.ng, u), -sp.ng)),
    }
}

/// Whether the edge x_i – x_{i+1} of `path` is unblocked: to the lens
/// point (i = 0), to a point light's position, towards a light at
/// infinity, or between two surface points.
pub(super) fn edge_visible<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    path: &[PathVertex],
    i: usize,
) -> bool {
    let (a, b) = (&path[i], &path[i + 1]);
    if i == 0 {
        return !tr.occluded_to_point(&b.sp, a.sp.p);
    }
    if i + 2 == path.len() {
        let end = PathEnd::of(tr.scene, b);
        if end.is_infinite() {
            return !tr.occluded_towards(&a.sp, b.sp.ng);
        }
        if end.is_delta() {
            return !tr.occluded_to_point(&a.sp, b.sp.p);
        }
    }
    !tr.occluded_between(&a.sp, &b.sp)
}
