//! The path-space mutations' walks through media and null boundaries
//! (scenes with media only; a scene without runs none of this).
//!
//! A walk that extends a subpath — the bidirectional mutation's two sides,
//! the lens subpath mutation's new lens subpath — samples free flights as
//! BDPT's walks do (`integrator::bdpt::media`): in the medium it is in, the
//! one free-flight sampler ([`Medium::sample_flight`]) decides between a
//! medium vertex and the next surface; a null boundary is crossed without
//! a vertex, switching the medium and starting a new stretch with a new
//! distance; a medium vertex scatters by sampling its phase function. Its
//! density is then the one [`PathState::densities`] gives the new vertices
//! (the direction's density over d², the free-flight density of every
//! stretch: the path measure's `with_flights`), so the mutations' T(x̄→ȳ)
//! needs nothing more.
//!
//! **Which medium.** The measure tracks the media from the camera along the
//! path (`bdpt::media::walk_path`; [`PathState::media`]), and the walks use
//! the same: the camera side from the camera's medium or a kept vertex's,
//! the light side from a kept vertex's, or from a new emitter's as BDPT's
//! light subpath starts (`bdpt::media::area_light_medium`,
//! `other_light_medium`; a light at infinity in vacuum). A surface naming
//! media decides the medium a segment leaving it runs in. In a scene whose
//! media are consistent (every ray between two points crosses the same
//! boundaries) the two agree on every segment, as BDPT's two subpaths do;
//! in one that is not, a walk may sample a segment in another medium than
//! the measure values it in, as BDPT's subpaths then disagree.

use glam::Vec2;

use super::bidirectional::{scatter_ray, surface_vertex};
use super::state::PathState;
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::geometry::Ray;
use crate::integrator::Tracer;
use crate::integrator::bdpt::PathVertex;
use crate::sampler::Sampler;
#[cfg(feature = "media")]
use crate::{
    geometry::offset,
    integrator::bdpt::{self, PathEnd},
    integrator::tracer::MAX_NULL_CROSSINGS,
    scene::{Flight, MaterialKind, Medium, MediumId},
};

/// A walk extending a subpath: BSDF sampling and tracing, and in a scene
/// with media free flights, phase sampling and null crossings with the
/// medium it is in tracked (module docs). Without media (or the feature)
/// it draws and traces exactly what the surface-only walks did.
#[derive(Clone, Copy, Debug)]
pub(super) struct Walk {
    #[cfg(feature = "media")]
    media: bool,
    /// The medium around the walk's last vertex.
    #[cfg(feature = "media")]
    medium: Option<MediumId>,
}

impl Walk {
    /// A walk from the vertex `i` of `x` (its medium as `x` tracked it), or
    /// from a new lens point (`None`: the camera's medium) or a new
    /// emitter (`Some(i)` past `x`'s end: set by [`Walk::emitted`]).
    #[allow(unused_variables)]
    pub fn new<I: Intersector>(tr: &Tracer<'_, I>, x: &PathState, i: Option<usize>) -> Walk {
        Walk {
            #[cfg(feature = "media")]
            media: tr.has_media(),
            #[cfg(feature = "media")]
            medium: match i {
                Some(i) => x.media.get(i).copied().flatten(),
                None => tr.scene.camera_medium(),
            },
        }
    }

    /// The ray the walk continues along from `v`, reached from `from`
    /// (BSDF sampling in `mode`; phase sampling at a medium vertex), the
    /// medium it starts in noted.
    #[allow(clippy::too_many_arguments)]
    pub fn scatter<I: Intersector>(
        &mut self,
        tr: &mut Tracer<'_, I>,
        v: &PathVertex,
        from: &PathVertex,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<Ray> {
        #[cfg(feature = "media")]
        if self.media {
            let (ray, m) = next_ray(tr, v, from, self.medium, u_lobe, u, mode)?;
            self.medium = m;
            return Some(ray);
        }
        scatter_ray(tr, v, from, u_lobe, u, mode)
    }

    /// Notes the medium of the ray `ray` that emitter vertex `v` (the
    /// light side's first) emits: `kept` when it is `x`'s end, else new
    /// ([`emitter_medium`]).
    #[allow(unused_variables)]
    pub fn emitted<I: Intersector>(
        &mut self,
        tr: &mut Tracer<'_, I>,
        v: &PathVertex,
        ray: &Ray,
        kept: Option<(&PathState, usize)>,
    ) {
        #[cfg(feature = "media")]
        if self.media {
            self.medium = emitter_medium(tr, v, ray, kept);
        }
    }

    /// Traces `ray` to the walk's next vertex: `Some(None)` when it leaves
    /// the scene, `None` when the walk ends otherwise (a flight's event of
    /// zero density, too many null boundaries).
    #[allow(unused_variables)]
    pub fn trace<I: Intersector, R: Sampler>(
        &mut self,
        tr: &mut Tracer<'_, I>,
        ray: &Ray,
        rng: &mut R,
    ) -> Option<Option<PathVertex>> {
        #[cfg(feature = "media")]
        if self.media {
            let (v, m) = step(tr, *ray, self.medium, rng)?;
            self.medium = m;
            return Some(v);
        }
        Some(tr.trace(ray).map(surface_vertex))
    }
}

/// One step of a walk: `ray` in `medium`, free flights sampled from
/// `rng` (two numbers per stretch), null boundaries crossed, to the vertex
/// it reaches (a surface, or a point in a medium; `None` when it leaves
/// the scene) and the medium that vertex lies in (for a surface, the one
/// the ray arrived through). `None` when
/// the flight's event has zero density or the ray crosses more than
/// [`MAX_NULL_CROSSINGS`] null boundaries (as BDPT's walk ends).
#[cfg(feature = "media")]
pub(super) fn step<I: Intersector, R: Sampler>(
    tr: &mut Tracer<'_, I>,
    mut ray: Ray,
    mut medium: Option<MediumId>,
    rng: &mut R,
) -> Option<(Option<PathVertex>, Option<MediumId>)> {
    let scene = tr.scene;
    for _ in 0..=MAX_NULL_CROSSINGS {
        let dir = ray.d.normalize();
        let hit = tr.trace(&ray);
        let t_surface = hit
            .as_ref()
            .map_or(f32::INFINITY, |h| (h.sp.p - ray.o).length());
        if let Some(id) = medium {
            let (u_channel, u) = (rng.next_f32(), rng.next_f32());
            let m: &Medium = scene.medium(id);
            match m.sample_flight(t_surface, u_channel, u) {
                Flight::Absorbed => return None,
                Flight::Scatter { s, .. } => {
                    let v = bdpt::media::medium_path_vertex(scene, ray.o + dir * s, id);
                    return Some((Some(v), medium));
                }
                Flight::Pass { .. } => {}
            }
        }
        let Some(hit) = hit else {
            return Some((None, medium));
        };
        if !matches!(scene.material(&hit.sp).kind, MaterialKind::Null) {
            return Some((Some(surface_vertex(hit)), medium));
        }
        // An index-matched boundary: no vertex, a new stretch behind it.
        medium = leaving(tr, &surface_vertex(hit), medium, dir);
        let o = offset::offset_ray_origin(hit.sp.p, hit.sp.p_error, hit.sp.ng, dir);
        ray = Ray::new(o, ray.d);
    }
    None
}

/// The medium a segment leaving vertex `v` (lying in `medium`) along `d`
/// runs in: a medium vertex's own, a surface that names media decides,
/// any other keeps `medium`.
#[cfg(feature = "media")]
pub(super) fn leaving<I: Intersector>(
    tr: &Tracer<'_, I>,
    v: &PathVertex,
    medium: Option<MediumId>,
    d: glam::Vec3,
) -> Option<MediumId> {
    if v.is_medium() {
        return Some(MediumId(v.sp.prim));
    }
    let iface = tr.scene.surface_media(v.sp.surface);
    if v.sp.surface != u32::MAX && iface.is_transition() {
        iface.target(v.sp.ng, d)
    } else {
        medium
    }
}

/// The ray a medium vertex `v`, reached from `from`, scatters along by
/// sampling its phase function with `u` (exactly: its value is the
/// direction's density, as [`PathState::densities`] takes it).
#[cfg(feature = "media")]
pub(super) fn phase_ray<I: Intersector>(
    tr: &Tracer<'_, I>,
    v: &PathVertex,
    from: &PathVertex,
    u: Vec2,
) -> Option<Ray> {
    let phase = tr.scene.medium(MediumId(v.sp.prim)).phase();
    let ps = phase.sample((v.sp.p - from.sp.p).normalize(), u);
    (ps.pdf > 0.0).then(|| Ray::new(v.sp.p, ps.wi))
}

/// The medium the light side's ray `ray` leaving emitter vertex `v` starts
/// in: a new emitter's as BDPT's light subpath starts (`new`), a kept one's
/// as `x` tracked it (a surface naming media decides); vacuum for a light
/// at infinity (module docs).
#[cfg(feature = "media")]
pub(super) fn emitter_medium<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    v: &PathVertex,
    ray: &Ray,
    kept: Option<(&PathState, usize)>,
) -> Option<MediumId> {
    let end = PathEnd::of(tr.scene, v);
    if end.is_infinite() {
        return None;
    }
    let d = ray.d.normalize();
    match kept {
        Some((x, i)) => leaving(tr, v, x.media.get(i).copied().flatten(), d),
        None if end == PathEnd::Area => bdpt::media::area_light_medium(tr, &v.sp, d),
        None => bdpt::media::other_light_medium(tr, false, v.sp.p, d),
    }
}

/// The ray a walk continues along from `v` (lying in `medium`), reached
/// from `from`: phase sampling at a medium vertex, BSDF sampling in `mode`
/// at a surface ([`super::bidirectional::scatter_ray`]); with the medium
/// the ray starts in.
#[cfg(feature = "media")]
pub(super) fn next_ray<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    v: &PathVertex,
    from: &PathVertex,
    medium: Option<MediumId>,
    u_lobe: f32,
    u: Vec2,
    mode: TransportMode,
) -> Option<(Ray, Option<MediumId>)> {
    let ray = if v.is_medium() {
        phase_ray(tr, v, from, u)?
    } else {
        scatter_ray(tr, v, from, u_lobe, u, mode)?
    };
    let m = leaving(tr, v, medium, ray.d);
    Some((ray, m))
}
