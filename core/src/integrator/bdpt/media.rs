//! BDPT through homogeneous media and null boundaries (scenes with media
//! only; a scene without runs none of this).
//!
//! Both subpaths sample medium vertices as path tracing does, with the one
//! free-flight sampler ([`Medium::sample_flight`]: a channel chosen
//! uniformly, the density averaged over the RGB channels), so the density
//! of a stretch of a segment is one scalar shared by all channels. Null
//! boundaries are passed without a vertex, each starting a new stretch
//! (the walk draws a new distance behind it); the medium is tracked along
//! both subpaths. A medium vertex scatters by its phase function, sampled
//! exactly, and is never specular. A medium that only absorbs holds no
//! vertices: the walks pass it with probability 1 and its transmittance
//! as the weight, and its stretches' densities are 1 (`Medium::
//! sample_flight`, `pass_density`).
//!
//! **Densities.** The area density of a vertex generated from its
//! neighbour is the direction density (phase or BSDF) over d², times the
//! cosine at the vertex if it lies on a surface, times the free-flight
//! density of the segment between them: the product over its stretches of
//! the probability of passing each (averaged over the channels), except
//! that the stretch ending at a medium vertex contributes the density of
//! scattering there instead. The walks store each segment's density in
//! both directions ([`MediaInfo`]); a connection gets its segment's from
//! the transmittance query that tests it ([`Tracer::transmittance_pieces`]),
//! so every strategy of a path sees the same densities and the power
//! heuristic's weights sum to one.
//!
//! **Where the light subpath starts.** A path reaching a surface that names
//! no media stays in the medium it was in, so the medium around an
//! emitter is not always written in the scene: an area light whose mesh
//! names media starts its subpath in the one on the side it emits to
//! (Mitsuba's convention for emitters in media); otherwise, and for point
//! and spot lights, in the medium of the nearest boundary around it, found
//! by a ray along the emitted direction ([`Tracer::enclosing_medium`]: the
//! medium on the near side of the first surface naming media, one more
//! ray per light subpath), and when that ray meets none, in the camera's
//! (an emitter in the medium the camera is in, as in a scene in a haze no
//! shape bounds). The camera's subpath tracks media the same way from the
//! camera, so in a scene whose media are consistent both subpaths agree
//! on the medium around every vertex. Lights at infinity start in vacuum.

use alloc::vec::Vec;

use glam::{Vec2, Vec3};

use super::{
    Kind, Local, PathEnd, PathStorage, PathVertex, Vertex, camera_vertex, count_eval, escape,
    finish, light_emission_pdf, other_light_vertex, scatter_surface, survives,
};
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, offset};
use crate::integrator::tracer::{Endpoint, MAX_NULL_CROSSINGS, Shading, Tracer};
use crate::math::Rgb;
use crate::sampler::Sampler;
use crate::scene::{
    EmitterSample, Flight, MaterialKind, Medium, MediumId, Phase, Scene, SurfacePoint,
};

/// What a subpath vertex needs beyond [`Vertex`] in a scene with media.
#[derive(Clone, Copy, Debug)]
pub(super) struct MediaInfo {
    /// The medium the vertex is in: around a medium vertex, the one a
    /// surface vertex was reached through, the one an endpoint's walk
    /// starts in.
    pub medium: Option<MediumId>,
    /// Free-flight density of reaching the predecessor from this vertex
    /// along the segment between them (1 for an endpoint; the forward
    /// one is in the vertex's `pdf_fwd`).
    pub rev: f32,
}

impl MediaInfo {
    /// The info of a subpath's first vertex, whose walk starts in `medium`.
    pub fn start(medium: Option<MediumId>) -> Self {
        MediaInfo { medium, rev: 1.0 }
    }
}

/// The stretches (between null boundaries) of one segment from an end a
/// to an end b, in order: the first, the last and the product of the
/// passing probabilities of those between.
struct Pieces<'s> {
    scene: &'s Scene,
    first: Option<(Option<MediumId>, f32)>,
    last: Option<(Option<MediumId>, f32)>,
    mid: f32,
}

impl<'s> Pieces<'s> {
    fn new(scene: &'s Scene) -> Self {
        Pieces {
            scene,
            first: None,
            last: None,
            mid: 1.0,
        }
    }

    /// Appends a stretch of `len` in `medium` (`None`: vacuum).
    fn push(&mut self, medium: Option<MediumId>, len: f32) {
        if self.first.is_none() {
            self.first = Some((medium, len));
            return;
        }
        if let Some(l) = self.last {
            self.mid *= self.factor(l, false);
        }
        self.last = Some((medium, len));
    }

    /// The free-flight density of a stretch: of scattering at its far end
    /// (`scatter`) or of passing it.
    fn factor(&self, (medium, len): (Option<MediumId>, f32), scatter: bool) -> f32 {
        match medium {
            Some(id) => {
                let m: &Medium = self.scene.medium(id);
                if scatter {
                    m.scatter_density(len)
                } else {
                    m.pass_density(len)
                }
            }
            // Nothing scatters in vacuum; everything passes.
            None => {
                if scatter {
                    0.0
                } else {
                    1.0
                }
            }
        }
    }

    /// The segment's free-flight densities (of reaching b from a, of
    /// reaching a from b), for ends that are medium vertices
    /// (`a_scatters`, `b_scatters`) or not.
    fn densities(&self, a_scatters: bool, b_scatters: bool) -> (f32, f32) {
        let Some(first) = self.first else {
            return (1.0, 1.0);
        };
        match self.last {
            None => (
                self.factor(first, b_scatters),
                self.factor(first, a_scatters),
            ),
            Some(last) => (
                self.factor(first, false) * self.mid * self.factor(last, b_scatters),
                self.factor(first, a_scatters) * self.mid * self.factor(last, false),
            ),
        }
    }
}

/// The medium an area light at `lp` emitting along `w` starts its subpath
/// in (see the module's description).
pub(crate) fn area_light_medium<I: Intersector>(
    t: &mut Tracer<'_, I>,
    lp: &SurfacePoint,
    w: Vec3,
) -> Option<MediumId> {
    let iface = t.scene.surface_media(lp.surface);
    if iface.is_transition() {
        iface.target(lp.ng, w)
    } else {
        t.enclosing_medium(lp.p, lp.p_error, lp.ng, w)
            .unwrap_or(t.scene.camera_medium())
    }
}

/// The medium a point or spot light at `p` emitting along `w`, or a light
/// at infinity (`infinite`), starts its subpath in (see the module's
/// description).
pub(crate) fn other_light_medium<I: Intersector>(
    t: &mut Tracer<'_, I>,
    infinite: bool,
    p: Vec3,
    w: Vec3,
) -> Option<MediumId> {
    if infinite {
        None
    } else {
        t.enclosing_medium(p, Vec3::ZERO, Vec3::ZERO, w)
            .unwrap_or(t.scene.camera_medium())
    }
}

/// The medium a segment leaving vertex `v` (in `medium`, its
/// [`MediaInfo::medium`]) along `w` runs in: a surface that names media
/// decides, any other keeps the vertex's.
fn medium_towards(
    scene: &Scene,
    medium: Option<MediumId>,
    v: &Vertex,
    w: Vec3,
) -> Option<MediumId> {
    if v.on_surface() {
        let iface = scene.surface_media(v.sp.surface);
        if iface.is_transition() {
            return iface.target(v.sp.ng, w);
        }
    }
    medium
}

/// A medium vertex at `p` in medium `id` with throughput `beta`.
fn medium_vertex(scene: &Scene, p: Vec3, id: MediumId, beta: Rgb) -> Vertex {
    let g = match scene.medium(id).phase() {
        Phase::Isotropic => 0.0,
        Phase::HenyeyGreenstein { g } => g,
    };
    Vertex {
        kind: Kind::Medium,
        sp: SurfacePoint {
            p,
            p_error: Vec3::ZERO,
            ng: Vec3::ZERO,
            ns: Vec3::ZERO,
            uv: Vec2::new(g, 0.0),
            surface: u32::MAX,
            prim: id.0,
        },
        local: None,
        beta,
        pdf_fwd: 0.0,
        pdf_rev: 0.0,
        delta: false,
    }
}

/// The camera subpath's walk from `ray` (the camera vertex is in place),
/// starting in `start`.
#[allow(clippy::too_many_arguments)]
// Out of line: the surface-only code that calls it stays as small as
// it was before media.
#[inline(never)]
pub(super) fn camera_walk<I: Intersector, S: Sampler>(
    t: &mut Tracer<'_, I>,
    ws: &mut PathStorage,
    ray: Ray,
    start: Option<MediumId>,
    max_vertices: usize,
    rr_depth: u32,
    rng: &mut S,
) {
    ws.camera_media.clear();
    ws.camera_media.push(MediaInfo::start(start));
    walk(
        t,
        &mut ws.camera,
        &mut ws.camera_media,
        ray,
        Rgb::ONE,
        max_vertices,
        TransportMode::Radiance,
        rr_depth,
        rng,
    );
}

/// The light subpath's walk from `ray` with throughput `beta` (the light
/// vertex is in place), starting in `start`.
#[allow(clippy::too_many_arguments)]
// Out of line: the surface-only code that calls it stays as small as
// it was before media.
#[inline(never)]
pub(super) fn light_walk<I: Intersector, S: Sampler>(
    t: &mut Tracer<'_, I>,
    ws: &mut PathStorage,
    ray: Ray,
    beta: Rgb,
    start: Option<MediumId>,
    max_vertices: usize,
    rr_depth: u32,
    rng: &mut S,
) {
    ws.light_media.clear();
    ws.light_media.push(MediaInfo::start(start));
    walk(
        t,
        &mut ws.light,
        &mut ws.light_media,
        ray,
        beta,
        max_vertices,
        TransportMode::Importance,
        rr_depth,
        rng,
    );
}

/// `super::random_walk` through media: free flight in the current medium
/// (a medium vertex where it scatters, the throughput weighted by
/// [`Medium::sample_flight`] either way), null boundaries crossed without
/// a vertex, the phase function sampled at medium vertices; densities as
/// the module describes, from the stored positions as there.
#[allow(clippy::too_many_arguments)]
fn walk<I: Intersector, S: Sampler>(
    t: &mut Tracer<'_, I>,
    path: &mut Vec<Vertex>,
    info: &mut Vec<MediaInfo>,
    mut ray: Ray,
    mut beta: Rgb,
    max_vertices: usize,
    mode: TransportMode,
    rr_depth: u32,
    rng: &mut S,
) {
    let beta0 = beta.max_component();
    let camera = t.camera;
    let scene = t.scene;
    let lights_pdf = |l: &Vertex, to: &Vertex| light_emission_pdf(scene, l, to);
    let mut medium = info.last().and_then(|i| i.medium);
    let mut pieces = Pieces::new(scene);
    let mut crossings = 0usize;
    while path.len() < max_vertices {
        let dir = ray.d.normalize();
        let hit = t.trace(&ray);
        let t_surface = hit
            .as_ref()
            .map_or(f32::INFINITY, |h| (h.sp.p - ray.o).length());
        let mut scatter = None;
        if let Some(id) = medium {
            let u_channel = rng.next_f32();
            let u = rng.next_f32();
            match scene.medium(id).sample_flight(t_surface, u_channel, u) {
                Flight::Absorbed => break,
                Flight::Pass { weight } => beta *= weight,
                Flight::Scatter { s, weight } => {
                    beta *= weight;
                    scatter = Some((s, id));
                }
            }
        }
        let n = path.len();
        let prev = path[n - 1];
        let mut surface: Option<Shading> = None;
        let mut v = match (scatter, hit) {
            (Some((s, id)), _) => {
                pieces.push(medium, s);
                medium_vertex(scene, ray.o + dir * s, id, beta)
            }
            (None, None) => {
                // A camera subpath leaving the scene ends on the
                // environment, as `random_walk` ends it.
                if cfg!(feature = "environment")
                    && mode == TransportMode::Radiance
                    && scene.lights.has_environment()
                {
                    pieces.push(medium, f32::INFINITY);
                    let (fwd, rev) = pieces.densities(prev.kind == Kind::Medium, false);
                    escape(scene, &camera, path, dir, beta);
                    if !prev.delta {
                        path[n].pdf_fwd *= fwd;
                        if n >= 2 {
                            path[n - 2].pdf_rev *= info[n - 1].rev;
                        }
                    }
                    info.push(MediaInfo { medium, rev });
                }
                break;
            }
            (None, Some(hit)) => {
                if matches!(scene.material(&hit.sp).kind, MaterialKind::Null) {
                    // An index-matched boundary: no vertex; a new stretch
                    // (and free-flight distance) behind it.
                    crossings += 1;
                    if crossings > MAX_NULL_CROSSINGS {
                        break;
                    }
                    pieces.push(medium, t_surface);
                    let iface = scene.surface_media(hit.sp.surface);
                    if iface.is_transition() {
                        medium = iface.target(hit.sp.ng, dir);
                    }
                    let o = offset::offset_ray_origin(hit.sp.p, hit.sp.p_error, hit.sp.ng, dir);
                    ray = Ray::new(o, ray.d);
                    continue;
                }
                // As `random_walk`: the predecessor must lie on the side
                // the ray arrived from.
                let arrival = if ray.d.dot(hit.sp.ng) < 0.0 {
                    1.0
                } else {
                    -1.0
                };
                if offset::side_of(hit.sp.ng, prev.sp.p - hit.sp.p) != Some(arrival) {
                    break;
                }
                pieces.push(medium, t_surface);
                surface = Some(hit);
                Vertex {
                    kind: Kind::Surface,
                    sp: hit.sp,
                    local: Some(Local {
                        bsdf: hit.bsdf,
                        frame: hit.frame,
                    }),
                    beta,
                    pdf_fwd: 0.0,
                    pdf_rev: 0.0,
                    delta: false,
                }
            }
        };
        crossings = 0;
        let (fwd, rev) = pieces.densities(prev.kind == Kind::Medium, v.kind == Kind::Medium);
        pieces = Pieces::new(scene);
        let before = n.checked_sub(2).map(|i| path[i]);
        if !prev.delta {
            v.pdf_fwd = prev.pdf(&camera, lights_pdf, before.as_ref(), &v) * fwd;
            if let Some(before) = before {
                path[n - 2].pdf_rev =
                    prev.pdf(&camera, lights_pdf, Some(&v), &before) * info[n - 1].rev;
            }
        }
        path.push(v);
        info.push(MediaInfo { medium, rev });
        if path.len() >= max_vertices {
            break;
        }

        let next = match surface {
            None => {
                // f / pdf = 1: the phase function is sampled exactly.
                let ps = v.phase().sample(dir, rng.next_2d());
                if !(ps.pdf > 0.0) {
                    break;
                }
                Ray::new(v.sp.p, ps.wi)
            }
            Some(hit) => {
                let Some((wi_world, weight, delta)) = scatter_surface(t, &hit, ray.d, rng, mode)
                else {
                    break;
                };
                beta *= weight;
                path[n].delta = delta;
                let iface = scene.surface_media(hit.sp.surface);
                if iface.is_transition() {
                    medium = iface.target(hit.sp.ng, wi_world);
                }
                offset::spawn_ray(hit.sp.p, hit.sp.p_error, hit.sp.ng, wi_world)
            }
        };

        // Russian roulette as in `random_walk`.
        if !survives(&mut beta, beta0, n as u32, rr_depth, rng) {
            break;
        }
        ray = next;
    }
}

/// The far end of a connection towards vertex `v`.
fn endpoint(v: &Vertex) -> Endpoint {
    if v.kind == Kind::Medium {
        Endpoint::Point(v.sp.p)
    } else {
        Endpoint::Surface(v.sp)
    }
}

/// `super::connect` in a scene with media: the same strategies, with
/// medium vertices at either end (phase function, no cosine), each
/// connection's contribution times the transmittance along it, and the
/// connection's free-flight densities handed to the MIS weight.
// Out of line: the surface-only code that calls it stays as small as
// it was before media.
#[inline(never)]
pub(super) fn connect<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    ws: &mut PathStorage,
    s: usize,
    t: usize,
    u: Vec2,
    u_sel: f32,
) -> Option<(Rgb, Option<Vec2>, Option<Vertex>)> {
    let scene = tr.scene;
    let camera = &{ tr.camera };
    let mut sampled: Option<Vertex> = None;
    let mut raster = None;
    let mut pieces = Pieces::new(scene);
    let scatters = |v: &Vertex| v.kind == Kind::Medium;
    let connectible =
        |v: &Vertex| matches!(v.kind, Kind::Surface | Kind::Medium) && v.connectible();
    // (density of reaching z_{t−1} from y_{s−1}, of y_{s−1} from z_{t−1}).
    let flight;
    let l = if s == 0 {
        // The camera subpath itself hit an emitter (through the media: its
        // throughput has the transmittance).
        flight = (1.0, 1.0);
        let pt = &ws.camera[t - 1];
        if pt.kind == Kind::Environment {
            pt.beta * scene.lights.environment_radiance(pt.sp.ng)
        } else {
            if pt.kind != Kind::Surface {
                return None;
            }
            let wo = (ws.camera[t - 2].sp.p - pt.sp.p).normalize();
            pt.beta * scene.emitted(&pt.sp, wo)
        }
    } else if t == 1 {
        // Light tracing: connect y_{s−1} to the lens.
        let qs = ws.light[s - 1];
        if !connectible(&qs) {
            return None;
        }
        let conn = camera.connect(qs.sp.p, u)?;
        let to_cam = conn.p_lens - qs.sp.p;
        let d2 = to_cam.length_squared();
        let w = to_cam / libm::sqrtf(d2);
        let prev = qs.pos_towards(&ws.light[s - 2]);
        let f = qs.f(prev, conn.p_lens, TransportMode::Importance);
        count_eval(tr, &qs);
        let l = qs.beta
            * f
            * (qs.cos_towards(w) * conn.we * conn.cos_theta / (d2 * conn.pdf_lens_area));
        if l.is_black() {
            return None;
        }
        let start = medium_towards(scene, ws.light_media[s - 1].medium, &qs, w);
        let trans = tr.transmittance_pieces(
            qs.sp.p,
            qs.sp.p_error,
            qs.sp.ng,
            Endpoint::Point(conn.p_lens),
            start,
            |m, len| pieces.push(m, len),
        );
        if trans.is_black() {
            return None;
        }
        flight = pieces.densities(scatters(&qs), false);
        let mut cv = camera_vertex(conn.p_lens, camera.forward());
        cv.beta = Rgb::splat(conn.we / conn.pdf_lens_area);
        sampled = Some(cv);
        raster = Some(conn.raster);
        l * trans
    } else if s == 1 {
        // Next-event estimation: a fresh point on a light.
        let pt = ws.camera[t - 1];
        if !connectible(&pt) {
            return None;
        }
        let (lp, pdf_area) = match scene.sample_emitter(u_sel, u)? {
            EmitterSample::Area { sp, pdf_area } => (sp, pdf_area),
            EmitterSample::Other { index, pmf } => {
                let (l, v, flight) = connect_other(tr, ws, t, index, pmf, u)?;
                return finish(scene, camera, ws, Some(v), s, t, l, raster, Some(flight));
            }
        };
        let to = lp.p - pt.sp.p;
        let d2 = to.length_squared();
        if !(d2 > 0.0 && pdf_area > 0.0) {
            return None;
        }
        let dir = to / libm::sqrtf(d2);
        let le = scene.emitted(&lp, -dir);
        if le.is_black() {
            return None;
        }
        let f = pt.f(ws.camera[t - 2].sp.p, lp.p, TransportMode::Radiance);
        count_eval(tr, &pt);
        let g = pt.cos_towards(dir) * lp.ng.dot(dir).abs() / d2;
        let l = pt.beta * f * le * (g / pdf_area);
        if l.is_black() {
            return None;
        }
        let start = medium_towards(scene, ws.camera_media[t - 1].medium, &pt, dir);
        let trans = tr.transmittance_pieces(
            pt.sp.p,
            pt.sp.p_error,
            pt.sp.ng,
            Endpoint::Surface(lp),
            start,
            |m, len| pieces.push(m, len),
        );
        if trans.is_black() {
            return None;
        }
        // Walked from z_{t−1}: the pair comes out the other way round.
        let (to_light, to_pt) = pieces.densities(scatters(&pt), false);
        flight = (to_pt, to_light);
        sampled = Some(Vertex {
            kind: Kind::Light,
            sp: lp,
            local: None,
            beta: le / pdf_area,
            pdf_fwd: pdf_area,
            pdf_rev: 0.0,
            delta: false,
        });
        l * trans
    } else {
        // Join y_{s−1} and z_{t−1} by an edge.
        let qs = ws.light[s - 1];
        let pt = ws.camera[t - 1];
        if !connectible(&qs) || !connectible(&pt) {
            return None;
        }
        let d = pt.sp.p - qs.sp.p;
        let d2 = d.length_squared();
        if d2 == 0.0 {
            return None;
        }
        let dn = d / libm::sqrtf(d2);
        let fq = qs.f(
            qs.pos_towards(&ws.light[s - 2]),
            pt.sp.p,
            TransportMode::Importance,
        );
        let fp = pt.f(ws.camera[t - 2].sp.p, qs.sp.p, TransportMode::Radiance);
        count_eval(tr, &qs);
        count_eval(tr, &pt);
        let g = qs.cos_towards(dn) * pt.cos_towards(dn) / d2;
        let l = qs.beta * fq * fp * pt.beta * g;
        if l.is_black() {
            return None;
        }
        let start = medium_towards(scene, ws.light_media[s - 1].medium, &qs, dn);
        let trans = tr.transmittance_pieces(
            qs.sp.p,
            qs.sp.p_error,
            qs.sp.ng,
            endpoint(&pt),
            start,
            |m, len| pieces.push(m, len),
        );
        if trans.is_black() {
            return None;
        }
        flight = pieces.densities(scatters(&qs), scatters(&pt));
        l * trans
    };
    finish(scene, camera, ws, sampled, s, t, l, raster, Some(flight))
}

/// `super::connect_other` in a scene with media: next-event estimation
/// (s = 1) towards non-area light `index`, through the media; also the
/// connection's free-flight densities as [`connect`] hands them on.
fn connect_other<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    ws: &PathStorage,
    t: usize,
    index: usize,
    pmf: f32,
    u: Vec2,
) -> Option<(Rgb, Vertex, (f32, f32))> {
    let scene = tr.scene;
    let pt = ws.camera[t - 1];
    let inc = scene.lights.sample_incident(index, pt.sp.p, u)?;
    let pdf = pmf * inc.pdf;
    if !(pdf > 0.0) {
        return None;
    }
    let dir = inc.wi;
    let f = pt.f(
        ws.camera[t - 2].sp.p,
        inc.position.unwrap_or(pt.sp.p + dir),
        TransportMode::Radiance,
    );
    count_eval(tr, &pt);
    let l = pt.beta * f * inc.li * (pt.cos_towards(dir) / pdf);
    if l.is_black() {
        return None;
    }
    let end = match inc.position {
        Some(q) => Endpoint::Point(q),
        None => Endpoint::Direction(dir),
    };
    let start = medium_towards(scene, ws.camera_media[t - 1].medium, &pt, dir);
    let mut pieces = Pieces::new(scene);
    let trans = tr.transmittance_pieces(pt.sp.p, pt.sp.p_error, pt.sp.ng, end, start, |m, len| {
        pieces.push(m, len)
    });
    if trans.is_black() {
        return None;
    }
    let (to_light, to_pt) = pieces.densities(pt.kind == Kind::Medium, false);
    let mut v = other_light_vertex(scene, index, inc.position.unwrap_or(pt.sp.p), pt.sp.p, dir);
    v.beta = inc.li * (1.0 / pdf);
    v.pdf_fwd = match v.kind {
        Kind::PointLight => pmf,
        Kind::Environment => scene.lights.pdf_environment(dir),
        _ => 0.0,
    };
    Some((l * trans, v, (to_pt, to_light)))
}

/// The far end of a path's segment towards `b`, its last vertex when
/// `last` (module docs of `path_measure`: a point light's position, a light
/// at infinity's direction), as the transmittance query wants it.
fn path_endpoint(scene: &Scene, b: &PathVertex, last: bool) -> Endpoint {
    if b.is_medium() {
        return Endpoint::Point(b.sp.p);
    }
    if last && b.sp.surface == u32::MAX {
        let end = PathEnd::of(scene, b);
        if end.is_infinite() {
            return Endpoint::Direction(b.sp.ng);
        }
        if end.is_delta() {
            return Endpoint::Point(b.sp.p);
        }
    }
    Endpoint::Surface(b.sp)
}

/// Walks the complete path x₀ … x_k's segments x_i → x_{i+1} from the
/// camera's medium, handing each to `seg(i, transmittance, flight)` —
/// `flight` the free-flight densities (of reaching x_{i+1} from x_i, of
/// reaching x_i from x_{i+1}) that BDPT's walks and connections give the
/// segment ([`Pieces`]: per stretch between null boundaries, a medium
/// vertex's stretch the scattering density) — and the medium each vertex
/// lies in to `around(i, medium)` (the one its incoming segment arrives
/// in; the camera's for x₀). Media are tracked as BDPT's walks track them
/// (a surface naming media decides, null boundaries switch), with the
/// transmittance queries BDPT connects with. The path's last vertex may be
/// an emitter of any kind (`path_measure`'s [`PathEnd`]). False when a
/// segment's transmittance is zero (blocked, or by rounding).
pub(crate) fn walk_path<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    path: &[PathVertex],
    mut seg: impl FnMut(usize, Rgb, (f32, f32)),
    mut around: impl FnMut(usize, Option<MediumId>),
) -> bool {
    let scene = tr.scene;
    let k = path.len() - 1;
    let mut medium = scene.camera_medium();
    around(0, medium);
    for i in 0..k {
        let (a, b) = (&path[i], &path[i + 1]);
        let end = path_endpoint(scene, b, i + 1 == k);
        let w = match end {
            Endpoint::Direction(d) => d,
            _ => b.sp.p - a.sp.p,
        };
        // The lens point and a medium vertex have no surface to offset
        // from (and the lens point's normal is the viewing direction).
        let (start, ng) = if i > 0 && !a.is_medium() {
            let iface = scene.surface_media(a.sp.surface);
            let start = if iface.is_transition() {
                iface.target(a.sp.ng, w)
            } else {
                medium
            };
            (start, a.sp.ng)
        } else {
            (medium, Vec3::ZERO)
        };
        let mut arrival = start;
        let mut pieces = Pieces::new(scene);
        let tr_i = tr.transmittance_pieces(a.sp.p, a.sp.p_error, ng, end, start, |m, len| {
            arrival = m;
            pieces.push(m, len);
        });
        if tr_i.is_black() || !tr_i.is_finite() {
            return false;
        }
        seg(i, tr_i, pieces.densities(a.is_medium(), b.is_medium()));
        medium = arrival;
        around(i + 1, medium);
    }
    true
}

/// σ_s × phase at medium vertex `v` for light between `a` and `b` (the
/// phase function depends only on the angle, so the order does not
/// matter): the medium vertex's factor in f(x̄) in place of a surface's
/// BSDF × cosine.
pub(crate) fn medium_factor(scene: &Scene, v: &PathVertex, a: Vec3, b: Vec3) -> Rgb {
    let m = scene.medium(MediumId(v.sp.prim));
    let d = (v.sp.p - a).normalize();
    let wi = (b - v.sp.p).normalize();
    m.sigma_s() * m.phase().eval(d, wi)
}

/// A medium vertex of a complete path ([`PathVertex::is_medium`]) at `p`
/// in medium `id`, as BDPT's walks make it.
pub(crate) fn medium_path_vertex(scene: &Scene, p: Vec3, id: MediumId) -> PathVertex {
    PathVertex {
        sp: medium_vertex(scene, p, id, Rgb::ONE).sp,
        shading: None,
        mixed_delta: false,
    }
}
