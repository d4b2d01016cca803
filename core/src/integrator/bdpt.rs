//! Bidirectional path tracing with MIS over all (s, t) strategies
//! (Veach 1997, ch. 10; the data layout follows pbrt's presentation).
//!
//! A camera subpath z₀…z_{t−1} and a light subpath y₀…y_{s−1} are sampled
//! once per pixel sample, then every connection (s, t) whose path has at most
//! `max_depth` segments is evaluated:
//! - s = 0: the camera subpath hits an emitter;
//! - s = 1: a fresh light sample is connected to z_{t−1} (next-event);
//! - t = 1: y_{s−1} is connected to a point on the lens and splatted
//!   wherever it lands (light tracing);
//! - otherwise y_{s−1} and z_{t−1} are joined by a visibility-tested edge.
//!
//! Each vertex stores the area densities of being generated from either
//! direction (`pdf_fwd`, `pdf_rev`); the power-heuristic weight of a strategy
//! follows from products of their ratios (Veach 1997, §10.2.1), with the
//! connection vertices' reverse densities recomputed per strategy.
//!
//! Lights that are not meshes follow pbrt-v4's BDPT: a point or spot light
//! is a vertex at a delta position (`Kind::PointLight`), a light at
//! infinity a vertex at infinity (`Kind::Directional`, `Kind::Environment`)
//! whose `sp.ng` is the unit direction from the scene towards it and whose
//! densities are in solid angle: the vertex after it is placed through a
//! disk of the scene's bounding sphere (density 1/(π r²) · |cos|), and a
//! camera subpath that escapes the scene ends on an environment vertex
//! (s = 0). Delta lights are never reached by s = 0.
//!
//! Both entry points are generic over [`Sampler`]: [`sample`] renders one
//! pixel sample with every strategy (the BDPT estimator), and
//! [`sample_strategy`] evaluates a single strategy of a fixed path depth
//! (the target function of primary-sample-space Metropolis light transport,
//! pbrt-v4's `MLTIntegrator::L`). Random numbers are drawn from three
//! streams — camera subpath, light subpath, connection — which plain random
//! streams ignore and the Metropolis sampler keeps apart.
//!
//! In a scene with media or null boundaries the walks and connections are
//! those of the `media` submodule (medium vertices, transmittance, the
//! free-flight densities in the MIS weights); a scene without runs the
//! code here alone, as before media existed.

mod path_measure;

pub use path_measure::{
    PathEnd, emission_vertex, environment_vertex, path_contribution, path_densities,
    strategy_density, with_flights,
};

use alloc::vec::Vec;

use glam::{Vec2, Vec3};

use super::Settings;
use super::tracer::{Shading, Tracer};
use crate::accel::Intersector;
use crate::bsdf::{Bsdf, TransportMode};
use crate::film::Film;
use crate::geometry::{Ray, offset};
use crate::math::{Frame, INV_PI, Rgb, warp};
use crate::sampler::{CAMERA_STREAM, CONNECTION_STREAM, LIGHT_STREAM, Sampler};
use crate::scene::{Camera, EmitterSample, Light, Phase, Scene, SurfacePoint};

#[cfg(feature = "media")]
pub(crate) mod media;
#[cfg(feature = "media")]
use media::MediaInfo;

/// Hard cap on subpath length when `max_depth` is unbounded; Russian
/// roulette ends paths long before this in any scene that absorbs light.
const UNBOUNDED_DEPTH: u32 = 1024;

/// What a vertex is. One byte without payload, in an order that makes
/// every test of `Vertex` a range check (the light index of a point or
/// directional light lives in the vertex's `sp.prim`, which such a vertex
/// has no other use for), so that `Vertex` stays small to copy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
enum Kind {
    Camera,
    /// A point on an area light.
    Light,
    Surface,
    /// A point or spot light of the scene's other lights (a delta
    /// position).
    PointLight,
    /// A directional light (at infinity, a delta direction).
    Directional,
    /// The environment (every non-delta light at infinity).
    Environment,
    /// A scattering point in a medium (scenes with media only): `sp.p`
    /// the point, `sp.ng` zero, `sp.prim` the medium's index and
    /// `sp.uv.x` its phase function's g (0 for isotropic, whose value
    /// Henyey–Greenstein's equals at g = 0), so that evaluating the
    /// vertex needs no scene.
    Medium,
}

/// One vertex of a subpath.
#[derive(Clone, Copy, Debug)]
struct Vertex {
    kind: Kind,
    /// Position and normals (a camera vertex uses the viewing direction).
    sp: SurfacePoint,
    /// BSDF and frame (surface vertices only): with `sp`, the vertex's
    /// [`Shading`] (see [`Vertex::shading`]).
    local: Option<Local>,
    /// Throughput of the subpath up to and including this vertex.
    beta: Rgb,
    /// Area density of generating this vertex from its predecessor.
    pdf_fwd: f32,
    /// Area density of generating this vertex from its successor.
    pdf_rev: f32,
    /// Sampled by a Dirac lobe: cannot be connected to.
    delta: bool,
}

/// The BSDF and shading frame of a surface vertex, kept apart from its
/// surface point so that a `Vertex` holds that point once: subpaths are
/// copied vertex by vertex, and a smaller vertex copies faster.
#[derive(Clone, Copy, Debug)]
struct Local {
    bsdf: Bsdf,
    frame: Frame,
}

impl Vertex {
    /// The shaded point of a surface vertex.
    #[inline]
    fn shading(&self) -> Option<Shading> {
        self.local.map(|l| Shading {
            sp: self.sp,
            bsdf: l.bsdf,
            frame: l.frame,
        })
    }

    fn on_surface(&self) -> bool {
        matches!(self.kind, Kind::Light | Kind::Surface)
    }

    /// A vertex at infinity: `sp.ng` is the direction towards it.
    #[inline]
    fn is_infinite(&self) -> bool {
        matches!(self.kind, Kind::Directional | Kind::Environment)
    }

    /// A light no ray can hit (s = 0 cannot sample it).
    #[inline]
    fn is_delta_light(&self) -> bool {
        matches!(self.kind, Kind::PointLight | Kind::Directional)
    }

    /// Unit direction from `self` towards `other`.
    #[inline]
    fn dir_to(&self, other: &Vertex) -> Vec3 {
        if other.is_infinite() {
            other.sp.ng
        } else if self.is_infinite() {
            -self.sp.ng
        } else {
            (other.sp.p - self.sp.p).normalize()
        }
    }

    /// A point that lies from `self` in the direction of `other` (`other`
    /// itself unless it is at infinity), for [`Vertex::f`].
    #[inline]
    fn pos_towards(&self, other: &Vertex) -> Vec3 {
        if other.is_infinite() {
            self.sp.p + other.sp.ng
        } else {
            other.sp.p
        }
    }

    fn connectible(&self) -> bool {
        match self.kind {
            Kind::Surface => !self.local.is_some_and(|l| l.bsdf.is_delta()),
            _ => true,
        }
    }

    /// Converts a solid-angle density at `self` towards `next` into an area
    /// density at `next` (Veach eq. 8.10).
    fn area_density_at(&self, pdf_sa: f32, next: &Vertex) -> f32 {
        // Densities of vertices at infinity stay in solid angle (pbrt's
        // `ConvertDensity`).
        if next.is_infinite() {
            return pdf_sa;
        }
        let w = next.sp.p - self.sp.p;
        let d2 = w.length_squared();
        if d2 == 0.0 {
            return 0.0;
        }
        let mut pdf = pdf_sa / d2;
        if next.on_surface() {
            pdf *= next.sp.ng.dot(w).abs() / libm::sqrtf(d2);
        }
        pdf
    }

    /// BSDF times the shading-normal correction for adjoint transport
    /// (Veach 1997, §5.3), from `prev` to `next` through `self`; the phase
    /// function at a medium vertex (the same in both transport modes).
    fn f(&self, prev: Vec3, next: Vec3, mode: TransportMode) -> Rgb {
        match &self.local {
            Some(l) => scatter_at(&self.sp, &l.bsdf, &l.frame, prev, next, mode),
            None if self.kind == Kind::Medium => {
                let d = (self.sp.p - prev).normalize();
                let wi = (next - self.sp.p).normalize();
                Rgb::splat(self.phase().eval(d, wi))
            }
            None => Rgb::ZERO,
        }
    }

    /// The phase function of a medium vertex (see [`Kind::Medium`]).
    #[inline]
    fn phase(&self) -> Phase {
        let g = self.sp.uv.x;
        if g == 0.0 {
            Phase::Isotropic
        } else {
            Phase::HenyeyGreenstein { g }
        }
    }

    /// The geometry term's cosine at `self` for a segment along unit `w`:
    /// |ns · w| at a surface, none (1) in a medium.
    #[cfg(feature = "media")]
    #[inline]
    fn cos_towards(&self, w: Vec3) -> f32 {
        if self.kind == Kind::Medium {
            1.0
        } else {
            self.sp.ns.dot(w).abs()
        }
    }

    /// Area density at `next` of `self` scattering towards it, having been
    /// reached from `prev` (`None` for endpoints).
    fn pdf(
        &self,
        camera: &Camera,
        lights_pdf: impl Fn(&Vertex, &Vertex) -> f32,
        prev: Option<&Vertex>,
        next: &Vertex,
    ) -> f32 {
        match self.kind {
            Kind::Camera => {
                let w = self.dir_to(next);
                self.area_density_at(camera.pdf_ray(self.sp.p, w).1, next)
            }
            Kind::Light | Kind::PointLight | Kind::Directional | Kind::Environment => {
                lights_pdf(self, next)
            }
            Kind::Surface => {
                let (Some(sh), Some(prev)) = (&self.local, prev) else {
                    return 0.0;
                };
                let wp = sh.frame.to_local(self.dir_to(prev));
                let wn = sh.frame.to_local(self.dir_to(next));
                self.area_density_at(sh.bsdf.pdf(wp, wn), next)
            }
            // The phase function is sampled exactly: its value is the
            // direction's density. The free-flight density along the
            // segment is the caller's (`MediaInfo`, `Pieces`).
            Kind::Medium => {
                let Some(prev) = prev else {
                    return 0.0;
                };
                let pdf = self.phase().eval(prev.dir_to(self), self.dir_to(next));
                self.area_density_at(pdf, next)
            }
        }
    }
}

/// The BSDF at shaded point `sh` from `prev` to `next` (world positions),
/// with the shading-normal correction of adjoint transport (Veach 1997,
/// §5.3) for `Importance`; zero for Dirac lobes. The one definition of a
/// non-specular vertex's factor in f(x̄), shared by BDPT and the path-space
/// perturbations.
#[inline]
pub fn scatter(sh: &Shading, prev: Vec3, next: Vec3, mode: TransportMode) -> Rgb {
    scatter_at(&sh.sp, &sh.bsdf, &sh.frame, prev, next, mode)
}

/// [`scatter`] of a shaded point given by its parts.
#[inline]
fn scatter_at(
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    frame: &Frame,
    prev: Vec3,
    next: Vec3,
    mode: TransportMode,
) -> Rgb {
    let wo = (prev - sp.p).normalize();
    let wi = (next - sp.p).normalize();
    let f = bsdf.eval(frame.to_local(wo), frame.to_local(wi), mode);
    if mode == TransportMode::Importance {
        f * shading_correction(sp, wo, wi)
    } else {
        f
    }
}

/// Counts the BSDF evaluation [`Vertex::f`] did at `v` (the work
/// statistics; `f` itself has no tracer to count in).
#[inline]
fn count_eval<I: Intersector>(tr: &mut Tracer<'_, I>, v: &Vertex) {
    if let Some(sh) = &v.local {
        tr.stats.bsdf_evals.add(sh.bsdf.lobe());
    }
}

/// |wo·ns||wi·ng| / (|wo·ng||wi·ns|): makes light-path throughput with
/// shading normals consistent with camera paths (Veach 1997, eq. 5.19).
pub fn shading_correction(sp: &SurfacePoint, wo: Vec3, wi: Vec3) -> f32 {
    let den = wo.dot(sp.ng).abs() * wi.dot(sp.ns).abs();
    if den == 0.0 {
        0.0
    } else {
        wo.dot(sp.ns).abs() * wi.dot(sp.ng).abs() / den
    }
}

/// Density per unit area at `to` of light vertex `light` emitting towards
/// it: cosine-weighted emission around the shading normal of an area
/// light, the direction density over d² of a point light, uniform on the
/// bounding sphere's disk for a light at infinity (pbrt-v4's `PdfLight`).
fn light_emission_pdf(scene: &Scene, light: &Vertex, to: &Vertex) -> f32 {
    match light.kind {
        // An area light's point, or the emitting surface vertex a camera
        // subpath reached (s = 0): below.
        Kind::Light | Kind::Surface | Kind::Camera => {}
        Kind::Medium => return 0.0,
        Kind::PointLight => {
            let i = light.sp.prim;
            let w = to.sp.p - light.sp.p;
            let d2 = w.length_squared();
            if d2 == 0.0 {
                return 0.0;
            }
            let w = w / libm::sqrtf(d2);
            let mut pdf = scene.lights.pdf_emit_dir(i as usize, w) / d2;
            if to.on_surface() {
                pdf *= to.sp.ng.dot(w).abs();
            }
            return pdf;
        }
        Kind::Directional | Kind::Environment => {
            let mut pdf = scene.lights.pdf_disk();
            if to.on_surface() {
                pdf *= to.sp.ng.dot(light.sp.ng).abs();
            }
            return pdf;
        }
    }
    let w = to.sp.p - light.sp.p;
    let d2 = w.length_squared();
    if d2 == 0.0 {
        return 0.0;
    }
    let w = w / libm::sqrtf(d2);
    let cos = light.sp.ns.dot(w);
    if cos <= 0.0 {
        return 0.0;
    }
    let mut pdf = cos * INV_PI / d2;
    if to.on_surface() {
        pdf *= to.sp.ng.dot(w).abs();
    }
    pdf
}

/// Reusable subpath storage of one worker (no allocation per sample once
/// warmed up).
#[derive(Default)]
pub struct PathStorage {
    camera: Vec<Vertex>,
    light: Vec<Vertex>,
    /// With media in the scene, each subpath vertex's medium and the
    /// free-flight densities of the segment that reached it, index for
    /// index with `camera` and `light` (empty otherwise: the vertices stay
    /// as small as without media).
    #[cfg(feature = "media")]
    camera_media: Vec<MediaInfo>,
    #[cfg(feature = "media")]
    light_media: Vec<MediaInfo>,
    only: Option<fn(usize, usize) -> bool>,
    /// The last [`sample_strategy`] with a contribution: (s, t) and the
    /// endpoint its connection sampled (light point for s = 1, lens point
    /// for t = 1), which the subpaths do not hold.
    last: Option<(usize, usize, Option<Vertex>)>,
}

/// A vertex of a complete path x₀ (lens) … x_k (emitter), as level 2 of
/// CMLT perturbs it.
#[derive(Clone, Copy, Debug)]
pub struct PathVertex {
    /// Position and normals (the lens point for x₀, with the viewing
    /// direction as normal).
    pub sp: SurfacePoint,
    /// BSDF and frame of surface vertices (`None` for x₀ and for a light
    /// point sampled on an emitter).
    pub shading: Option<Shading>,
    /// The path scatters here through the Dirac lobe of a BSDF that also
    /// has smooth lobes (smooth plastic's coating): `eval` does not see
    /// that lobe, so no perturbation may re-evaluate this vertex (see
    /// `mlt::perturbation::classify`).
    pub mixed_delta: bool,
}

impl PathVertex {
    /// True when the vertex scatters only through Dirac lobes.
    #[inline]
    pub fn is_specular(&self) -> bool {
        self.shading.is_some_and(|s| s.bsdf.is_delta())
    }

    /// True for a scattering point in a medium (scenes with media only):
    /// the one kind of vertex on no surface (`sp.surface` is `u32::MAX`)
    /// with a zero normal and no shading, its medium's index in
    /// `sp.prim` (the lens point has the viewing direction as normal, a
    /// point or spot light the direction it is seen in).
    #[inline]
    pub fn is_medium(&self) -> bool {
        self.shading.is_none() && self.sp.surface == u32::MAX && self.sp.ng == Vec3::ZERO
    }
}

/// Writes the complete path x₀ … x_k of the last [`sample_strategy`] call
/// that returned a contribution into `out` (cleared first), camera end
/// first; false (and `out` empty) when the last call had none. Valid until
/// `ws` is used again.
pub fn strategy_path(ws: &PathStorage, out: &mut Vec<PathVertex>) -> bool {
    out.clear();
    let Some((s, t, sampled)) = ws.last else {
        return false;
    };
    // A vertex's `delta` says how its subpath left it; the ends of the
    // connection (the last vertex of each subpath) did not leave that way
    // in this path.
    let as_path = |v: &Vertex, end: bool| PathVertex {
        sp: v.sp,
        shading: v.shading(),
        mixed_delta: !end && v.delta && v.local.is_some_and(|l| !l.bsdf.is_delta()),
    };
    for (i, v) in ws.camera[..t].iter().enumerate() {
        match (i, t, &sampled) {
            (0, 1, Some(lens)) => out.push(as_path(lens, true)),
            _ => out.push(as_path(v, i + 1 == t)),
        }
    }
    for (i, v) in ws.light[..s].iter().enumerate().rev() {
        match (i, s, &sampled) {
            (0, 1, Some(light)) => out.push(as_path(light, true)),
            _ => out.push(as_path(v, i + 1 == s)),
        }
    }
    true
}

impl PathStorage {
    /// Empty storage.
    pub fn new() -> Self {
        Self::default()
    }

    /// Storage for paths of up to `depth` segments: sampling such paths
    /// never allocates (a renderer's frame must not).
    pub fn with_capacity(depth: u32) -> Self {
        let n = depth as usize + 2;
        PathStorage {
            camera: Vec::with_capacity(n),
            light: Vec::with_capacity(n),
            #[cfg(feature = "media")]
            camera_media: Vec::with_capacity(n),
            #[cfg(feature = "media")]
            light_media: Vec::with_capacity(n),
            ..Self::default()
        }
    }

    /// Debugging aid (pbrt's "visualize strategies"): evaluate only the
    /// strategies (s, t) for which `only(s, t)` holds, each *unweighted*
    /// (MIS weight 1). A single strategy alone is then an unbiased estimator
    /// of the paths it can sample, which lets tests check every strategy
    /// separately. Off by default; changes results when on.
    pub fn set_strategy_filter(&mut self, only: Option<fn(usize, usize) -> bool>) {
        self.only = only;
    }
}

/// Extends a subpath by random walk from `ray` (Veach §10.2; pbrt's
/// `RandomWalk`), recording forward and reverse area densities.
///
/// Both densities of a vertex are evaluated from the vertex *positions*
/// (`Vertex::pdf`), exactly as `mis_weight` re-evaluates them at a
/// connection, not from the sampled direction: the ray leaves an offset
/// origin, so the sampled direction differs from the one between the stored
/// points by up to the offset over the segment length. The power heuristic
/// sums to one over the strategies of a path only if every strategy sees
/// the same densities of it; mixing the two made BDPT 4.5% dark 10⁵ from
/// the origin, where offsets (γ(7)·|p| ≈ 0.05) are a few percent of a
/// unit scene's segments.
#[allow(clippy::too_many_arguments)]
fn random_walk<I: Intersector, S: Sampler>(
    t: &mut Tracer<'_, I>,
    path: &mut Vec<Vertex>,
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
    while path.len() < max_vertices {
        let Some(hit) = t.trace(&ray) else {
            // A camera subpath leaving the scene ends on the environment
            // (pbrt's escaped-ray light vertex), with its density in solid
            // angle.
            if cfg!(feature = "environment")
                && mode == TransportMode::Radiance
                && scene.lights.has_environment()
            {
                escape(scene, &camera, path, ray.d.normalize(), beta);
            }
            break;
        };
        let n = path.len();
        let prev = path[n - 1];
        // Connections evaluate the BSDF here with the direction towards
        // `prev` taken from the stored positions: that must lie on the side
        // the ray arrived from. It can fail only for a segment tangent to
        // the hit surface to within rounding (a walk from a point on a mesh
        // edge to the adjacent face), where it leaked light through closed
        // meshes; such a vertex carries no measure, so the walk ends.
        let arrival = if ray.d.dot(hit.sp.ng) < 0.0 {
            1.0
        } else {
            -1.0
        };
        if offset::side_of(hit.sp.ng, prev.sp.p - hit.sp.p) != Some(arrival) {
            break;
        }
        let before = n.checked_sub(2).map(|i| path[i]);
        let mut v = Vertex {
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
        };
        if !prev.delta {
            v.pdf_fwd = prev.pdf(&camera, lights_pdf, before.as_ref(), &v);
            if let Some(before) = before {
                path[n - 2].pdf_rev = prev.pdf(&camera, lights_pdf, Some(&v), &before);
            }
        }
        path.push(v);
        if path.len() >= max_vertices {
            break;
        }
        let Some((wi_world, weight, delta)) = scatter_surface(t, &hit, ray.d, rng, mode) else {
            break;
        };
        beta *= weight;
        path[n].delta = delta;
        if !survives(&mut beta, beta0, n as u32, rr_depth, rng) {
            break;
        }
        ray = offset::spawn_ray(hit.sp.p, hit.sp.p_error, hit.sp.ng, wi_world);
    }
}

/// A surface vertex's scattering in a random walk that reached `hit` along
/// `ray_d`: the BSDF sampled there, as the world direction, the throughput
/// factor f·|cos θ|/pdf (times the shading-normal correction when
/// importance is transported, Veach §5.3) and whether the lobe was a Dirac
/// one. `None` ends the walk. The surface walk and the media walk share it.
#[inline(always)]
fn scatter_surface<I: Intersector, S: Sampler>(
    t: &mut Tracer<'_, I>,
    hit: &Shading,
    ray_d: Vec3,
    rng: &mut S,
    mode: TransportMode,
) -> Option<(Vec3, Rgb, bool)> {
    let wo_world = (-ray_d).normalize();
    let wo = hit.frame.to_local(wo_world);
    let u_lobe = rng.next_f32();
    let u = rng.next_2d();
    let bs = t.sample_bsdf(&hit.bsdf, wo, u_lobe, u, mode)?;
    if bs.pdf <= 0.0 || bs.f.is_black() {
        return None;
    }
    let wi_world = hit.frame.to_world(bs.wi);
    let mut weight = bs.f * (bs.wi.z.abs() / bs.pdf);
    if mode == TransportMode::Importance {
        weight *= shading_correction(&hit.sp, wo_world, wi_world);
    }
    Some((wi_world, weight, bs.delta))
}

/// Russian roulette on a subpath's throughput `beta` relative to its
/// start's largest channel `beta0`, from `rr_depth` vertices on: `false`
/// ends the walk (also when `beta` is black or not finite); otherwise
/// `beta` is divided by the survival probability, so the walk stays
/// unbiased.
#[inline(always)]
fn survives<S: Sampler>(
    beta: &mut Rgb,
    beta0: f32,
    depth: u32,
    rr_depth: u32,
    rng: &mut S,
) -> bool {
    if depth >= rr_depth {
        let q = (beta.max_component() / beta0).min(0.95);
        if !(rng.next_f32() < q) {
            return false;
        }
        *beta /= q;
    }
    !beta.is_black() && beta.is_finite()
}

/// Appends the environment vertex a camera subpath reaches along unit `d`
/// with throughput `beta`, with its forward density and its predecessor's
/// reverse one.
#[inline(never)]
fn escape(scene: &Scene, camera: &Camera, path: &mut Vec<Vertex>, d: Vec3, beta: Rgb) {
    let lights_pdf = |l: &Vertex, to: &Vertex| light_emission_pdf(scene, l, to);
    let n = path.len();
    let prev = path[n - 1];
    let (center, r) = scene.lights.bounding_sphere();
    let mut v = at_infinity(Kind::Environment, prev.sp.p, d, center, r);
    v.beta = beta;
    let before = n.checked_sub(2).map(|i| path[i]);
    if !prev.delta {
        v.pdf_fwd = prev.pdf(camera, lights_pdf, before.as_ref(), &v);
        if let Some(before) = before {
            path[n - 2].pdf_rev = prev.pdf(camera, lights_pdf, Some(&v), &before);
        }
    }
    path.push(v);
}

/// A vertex of kind `kind` at infinity in unit direction `d` seen from
/// `from`, placed (for the rare use of its position) outside the bounding
/// sphere (`center`, `r`).
fn at_infinity(kind: Kind, from: Vec3, d: Vec3, center: Vec3, r: f32) -> Vertex {
    let far = 2.0 * r + (from - center).length();
    let sp = SurfacePoint {
        p: from + d * far,
        p_error: Vec3::ZERO,
        ng: d,
        ns: d,
        uv: Vec2::ZERO,
        surface: u32::MAX,
        prim: u32::MAX,
    };
    Vertex {
        kind,
        sp,
        local: None,
        beta: Rgb::ZERO,
        pdf_fwd: 0.0,
        pdf_rev: 0.0,
        delta: false,
    }
}

/// The light vertex of non-area light `index` (kind by light type):
/// `p` its position for a point or spot light, `d` the unit direction
/// towards it from `from` for a light at infinity.
fn other_light_vertex(scene: &Scene, index: usize, p: Vec3, from: Vec3, d: Vec3) -> Vertex {
    let (center, r) = scene.lights.bounding_sphere();
    match scene.lights.others().nth(index) {
        Some(Light::Directional { .. }) => {
            let mut v = at_infinity(Kind::Directional, from, d, center, r);
            v.sp.prim = index as u32;
            v
        }
        Some(Light::Constant { .. } | Light::Envmap { .. } | Light::Sun { .. }) => {
            at_infinity(Kind::Environment, from, d, center, r)
        }
        _ => {
            let mut v = at_infinity(Kind::PointLight, p, d, p, 0.0);
            v.sp.p = p;
            v.sp.prim = index as u32;
            v
        }
    }
}

fn camera_vertex(p: Vec3, forward: Vec3) -> Vertex {
    let sp = SurfacePoint {
        p,
        p_error: Vec3::ZERO,
        ng: forward,
        ns: forward,
        uv: Vec2::ZERO,
        surface: u32::MAX,
        prim: u32::MAX,
    };
    Vertex {
        kind: Kind::Camera,
        sp,
        local: None,
        beta: Rgb::ONE,
        pdf_fwd: 0.0,
        pdf_rev: 0.0,
        delta: false,
    }
}

/// Renders one BDPT sample through `raster` of pixel `(px, py)`: adds the
/// camera-side strategies to the pixel and splats light tracing (t = 1).
#[allow(clippy::too_many_arguments)]
pub fn sample<I: Intersector, S: Sampler>(
    t: &mut Tracer<'_, I>,
    settings: &Settings,
    ws: &mut PathStorage,
    raster: Vec2,
    px: u32,
    py: u32,
    rng: &mut S,
    film: &mut Film,
) {
    let mut l_pixel = Rgb::ZERO;
    sample_each(
        t,
        settings,
        ws,
        raster,
        rng,
        |_, _, l, raster_splat| match raster_splat {
            Some(r) => film.add_splat(r, l),
            None => l_pixel += l,
        },
    );
    film.add_sample(px, py, l_pixel);
}

/// One BDPT sample through `raster`, handing every non-zero MIS-weighted
/// strategy contribution to `emit(s, t, l, splat)`: `splat` is the raster
/// position for light tracing (t = 1), `None` for contributions to the
/// sample's own pixel. The path has s + t − 1 segments. [`sample`] is this
/// with a film as the sink; the MLT bootstrap tallies luminance by depth.
pub fn sample_each<I: Intersector, S: Sampler>(
    t: &mut Tracer<'_, I>,
    settings: &Settings,
    ws: &mut PathStorage,
    raster: Vec2,
    rng: &mut S,
    mut emit: impl FnMut(usize, usize, Rgb, Option<Vec2>),
) {
    let max_depth = settings
        .max_depth
        .unwrap_or(UNBOUNDED_DEPTH)
        .min(UNBOUNDED_DEPTH) as usize;

    // Camera subpath: up to max_depth + 1 vertices.
    rng.start_stream(CAMERA_STREAM);
    let u_lens = rng.next_2d();
    camera_subpath(t, ws, raster, u_lens, max_depth + 1, settings.rr_depth, rng);

    // Light subpath: up to max_depth vertices.
    rng.start_stream(LIGHT_STREAM);
    light_subpath(t, ws, max_depth, settings.rr_depth, rng);

    rng.start_stream(CONNECTION_STREAM);
    let n_cam = ws.camera.len();
    let n_light = ws.light.len();
    for tt in 1..=n_cam {
        for s in 0..=n_light {
            let segments = (s + tt) as isize - 1;
            if (s == 1 && tt == 1) || segments < 1 || segments as usize > max_depth {
                continue;
            }
            if tt == 2 && s == 0 && settings.hide_emitters {
                continue;
            }
            if ws.only.is_some_and(|only| !only(s, tt)) {
                continue;
            }
            if let Some((l, raster_splat, _)) = connect(t, ws, s, tt, rng) {
                emit(s, tt, l, raster_splat);
            }
        }
    }
}

/// Traces the camera subpath through `raster` (lens point from `u_lens`)
/// into `ws.camera`: the camera vertex and at most `max_vertices − 1`
/// surface vertices.
#[allow(clippy::too_many_arguments)]
fn camera_subpath<I: Intersector, S: Sampler>(
    t: &mut Tracer<'_, I>,
    ws: &mut PathStorage,
    raster: Vec2,
    u_lens: Vec2,
    max_vertices: usize,
    rr_depth: u32,
    rng: &mut S,
) {
    ws.camera.clear();
    let ray = t.camera_ray(raster, u_lens);
    let camera = &t.camera;
    ws.camera.push(camera_vertex(ray.o, camera.forward()));
    #[cfg(feature = "media")]
    if t.has_media() {
        let start = t.scene.camera_medium();
        return media::camera_walk(t, ws, ray, start, max_vertices, rr_depth, rng);
    }
    random_walk(
        t,
        &mut ws.camera,
        ray,
        Rgb::ONE,
        max_vertices,
        TransportMode::Radiance,
        rr_depth,
        rng,
    );
}

/// Samples a light point and traces the light subpath from it into
/// `ws.light`: at most `max_vertices` vertices (none when `max_vertices` is
/// 0 or the light sample fails). Always draws the same five numbers first,
/// so the stream layout does not depend on the outcome.
fn light_subpath<I: Intersector, S: Sampler>(
    t: &mut Tracer<'_, I>,
    ws: &mut PathStorage,
    max_vertices: usize,
    rr_depth: u32,
    rng: &mut S,
) {
    let scene = t.scene;
    ws.light.clear();
    #[cfg(feature = "media")]
    ws.light_media.clear();
    let u_sel = rng.next_f32();
    let u_pos = rng.next_2d();
    let u_dir = rng.next_2d();
    if max_vertices == 0 {
        return;
    }
    let (lp, pdf_area) = match scene.sample_emitter(u_sel, u_pos) {
        Some(EmitterSample::Area { sp, pdf_area }) => (sp, pdf_area),
        Some(EmitterSample::Other { index, pmf }) => {
            other_light_subpath(t, ws, index, pmf, u_pos, u_dir, max_vertices, rr_depth, rng);
            return;
        }
        None => return,
    };
    let frame = Frame::from_normal(lp.ns);
    let local = warp::square_to_cosine_hemisphere(u_dir);
    let pdf_dir = warp::cosine_hemisphere_pdf(local);
    let w = frame.to_world(local);
    let le = scene.emitted(&lp, w);
    if !(pdf_dir > 0.0 && pdf_area > 0.0) || le.is_black() {
        return;
    }
    ws.light.push(Vertex {
        kind: Kind::Light,
        sp: lp,
        local: None,
        beta: le,
        pdf_fwd: pdf_area,
        pdf_rev: 0.0,
        delta: false,
    });
    let beta = le * (lp.ng.dot(w).abs() / (pdf_area * pdf_dir));
    let ray = offset::spawn_ray(lp.p, lp.p_error, lp.ng, w);
    #[cfg(feature = "media")]
    if t.has_media() {
        let start = media::area_light_medium(t, &lp, w);
        return media::light_walk(t, ws, ray, beta, start, max_vertices, rr_depth, rng);
    }
    random_walk(
        t,
        &mut ws.light,
        ray,
        beta,
        max_vertices,
        TransportMode::Importance,
        rr_depth,
        rng,
    );
}

/// [`light_subpath`] from non-area light `index`, chosen with
/// probability `pmf` (pbrt-v4's `GenerateLightSubpath` with `SampleLe`).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn other_light_subpath<I: Intersector, S: Sampler>(
    t: &mut Tracer<'_, I>,
    ws: &mut PathStorage,
    index: usize,
    pmf: f32,
    u_pos: Vec2,
    u_dir: Vec2,
    max_vertices: usize,
    rr_depth: u32,
    rng: &mut S,
) {
    let scene = t.scene;
    let lights = &scene.lights;
    let Some(e) = lights.sample_emission(index, u_pos, u_dir) else {
        return;
    };
    let pdf = pmf * e.pdf_pos * e.pdf_dir;
    if !(pdf > 0.0) {
        return;
    }
    let mut v = other_light_vertex(scene, index, e.origin, e.origin, -e.dir);
    v.sp.p = e.origin;
    v.beta = e.le;
    // The origin's density: the selection for a point light (its position
    // is certain); for a light at infinity the density of its direction,
    // in solid angle, as the escaped camera ray's origin density
    // (`InfiniteLightDensity`; zero for a delta direction).
    v.pdf_fwd = match v.kind {
        Kind::PointLight => pmf * e.pdf_pos,
        Kind::Environment => lights.pdf_environment(-e.dir),
        _ => 0.0,
    };
    #[cfg(feature = "media")]
    let start = if t.has_media() {
        media::other_light_medium(t, v.is_infinite(), e.origin, e.dir)
    } else {
        None
    };
    ws.light.push(v);
    let beta = e.le * (1.0 / pdf);
    #[cfg(feature = "media")]
    if t.has_media() {
        let ray = Ray::new(e.origin, e.dir);
        return media::light_walk(t, ws, ray, beta, start, max_vertices, rr_depth, rng);
    }
    random_walk(
        t,
        &mut ws.light,
        Ray::new(e.origin, e.dir),
        beta,
        max_vertices,
        TransportMode::Importance,
        rr_depth,
        rng,
    );
}

/// Number of strategies (s, t) that sample a path of `depth` segments
/// (s + t = depth + 1 vertices, t ≥ 1): s = 0 … depth, except that a
/// single segment has only (0, 2) — (1, 1) would connect a light point to
/// the lens without a scattering vertex, which BDPT does not evaluate.
///
/// pbrt-v4 counts depth in bounces (our depth − 1), hence its
/// `depth + 2`.
#[inline]
pub fn strategy_count(depth: usize) -> usize {
    if depth <= 1 { 1 } else { depth + 1 }
}

/// One evaluation of the Metropolis target: a single BDPT strategy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrategySample {
    /// MIS-weighted contribution of strategy (s, t), multiplied by
    /// [`strategy_count`] (the inverse probability of having chosen it).
    /// Zero when the path could not be built or carries nothing.
    pub l: Rgb,
    /// Continuous raster position the contribution belongs to: the camera
    /// ray's for t ≥ 2, the lens connection's for t = 1.
    pub raster: Vec2,
    /// Light subpath vertices of the chosen strategy.
    pub s: u32,
    /// Camera subpath vertices of the chosen strategy.
    pub t: u32,
}

/// Evaluates one strategy of one path depth: the function of primary
/// sample space that Metropolis light transport explores (Kelemen et al.
/// 2002 over BDPT, as pbrt-v4's `MLTIntegrator::L` does).
///
/// For a path of `depth` segments (1 ≤ depth; Mitsuba's counting), the
/// strategy is chosen uniformly among the [`strategy_count`]`(depth)`
/// strategies, exactly the subpath lengths it needs are traced (no Russian
/// roulette: the lengths are fixed), and the strategy's MIS-weighted
/// contribution is returned times the strategy count. Summed over depths,
/// E[l · 1{raster ∈ pixel}] · (width · height) is the pixel's value, the
/// same quantity one BDPT sample per pixel estimates.
///
/// Dimensions drawn: camera stream 0–1 raster position (uniform over the
/// image), 2 strategy, 3–4 lens, then 3 per camera bounce; light stream 0–4
/// light point and direction, then 3 per light bounce; connection stream
/// 0–2 the lens or light sample of t = 1 / s = 1. Settings other than
/// `hide_emitters` are ignored: the caller chooses `depth`.
pub fn sample_strategy<I: Intersector, S: Sampler>(
    tr: &mut Tracer<'_, I>,
    settings: &Settings,
    ws: &mut PathStorage,
    depth: usize,
    rng: &mut S,
) -> StrategySample {
    let camera = tr.camera;
    let depth = depth.max(1);
    let n = strategy_count(depth);
    ws.last = None;

    rng.start_stream(CAMERA_STREAM);
    let u = rng.next_2d();
    let raster = Vec2::new(u.x * camera.width() as f32, u.y * camera.height() as f32);
    let u_strategy = rng.next_f32();
    let s = if depth == 1 {
        0
    } else {
        ((u_strategy * n as f32) as usize).min(n - 1)
    };
    let t = depth + 1 - s;
    let mut out = StrategySample {
        l: Rgb::ZERO,
        raster,
        s: s as u32,
        t: t as u32,
    };
    if s == 0 && t == 2 && settings.hide_emitters {
        return out;
    }

    // Exactly t camera vertices; no roulette, so the strategy's path is
    // either built in full or not at all.
    let u_lens = rng.next_2d();
    camera_subpath(tr, ws, raster, u_lens, t, u32::MAX, rng);
    if ws.camera.len() != t {
        return out;
    }

    rng.start_stream(LIGHT_STREAM);
    if s == 1 {
        // Next-event estimation samples its own light point in `connect`
        // (from the connection stream); the slot only has to exist, since
        // `mis_weight` overwrites it with that point.
        ws.light.clear();
        ws.light.push(camera_vertex(Vec3::ZERO, Vec3::Z));
        #[cfg(feature = "media")]
        if tr.has_media() {
            ws.light_media.clear();
            ws.light_media.push(MediaInfo::start(None));
        }
    } else {
        light_subpath(tr, ws, s, u32::MAX, rng);
        if ws.light.len() != s {
            return out;
        }
    }

    rng.start_stream(CONNECTION_STREAM);
    if let Some((l, splat, sampled)) = connect(tr, ws, s, t, rng) {
        out.l = l * n as f32;
        if let Some(r) = splat {
            out.raster = r;
        }
        ws.last = Some((s, t, sampled));
    }
    out
}

/// Evaluates strategy (s, t): its MIS-weighted contribution, for t = 1 the
/// raster position to splat it at, and the endpoint the connection sampled
/// (s = 1, t = 1).
fn connect<I: Intersector, S: Sampler>(
    tr: &mut Tracer<'_, I>,
    ws: &mut PathStorage,
    s: usize,
    t: usize,
    rng: &mut S,
) -> Option<(Rgb, Option<Vec2>, Option<Vertex>)> {
    let scene = tr.scene;
    // A copy: `tr` is borrowed mutably below.
    let camera = &{ tr.camera };
    let mut sampled: Option<Vertex> = None;
    let mut raster = None;
    // Random numbers are drawn for every strategy that may need them so that
    // the stream layout does not depend on visibility results.
    let u = rng.next_2d();
    let u_sel = rng.next_f32();
    #[cfg(feature = "media")]
    if tr.has_media() {
        return media::connect(tr, ws, s, t, u, u_sel);
    }
    let l = if s == 0 {
        // The camera subpath itself hit an emitter.
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
        if !qs.connectible() || qs.kind != Kind::Surface {
            return None;
        }
        let conn = camera.connect(qs.sp.p, u)?;
        let to_cam = conn.p_lens - qs.sp.p;
        let d2 = to_cam.length_squared();
        let w = to_cam / libm::sqrtf(d2);
        let prev = qs.pos_towards(&ws.light[s - 2]);
        let f = qs.f(prev, conn.p_lens, TransportMode::Importance);
        count_eval(tr, &qs);
        if f.is_black() {
            return None;
        }
        let l = qs.beta
            * f
            * (qs.sp.ns.dot(w).abs() * conn.we * conn.cos_theta / (d2 * conn.pdf_lens_area));
        if l.is_black() || tr.occluded_to_point(&qs.sp, conn.p_lens) {
            return None;
        }
        let mut cv = camera_vertex(conn.p_lens, camera.forward());
        cv.beta = Rgb::splat(conn.we / conn.pdf_lens_area);
        sampled = Some(cv);
        raster = Some(conn.raster);
        l
    } else if s == 1 {
        // Next-event estimation: a fresh point on a light.
        let pt = ws.camera[t - 1];
        if !pt.connectible() || pt.kind != Kind::Surface {
            return None;
        }
        let (lp, pdf_area) = match scene.sample_emitter(u_sel, u)? {
            EmitterSample::Area { sp, pdf_area } => (sp, pdf_area),
            EmitterSample::Other { index, pmf } => {
                let (l, v) = connect_other(tr, ws, t, index, pmf, u)?;
                sampled = Some(v);
                return finish(scene, camera, ws, sampled, s, t, l, raster, None);
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
        let g = pt.sp.ns.dot(dir).abs() * lp.ng.dot(dir).abs() / d2;
        let l = pt.beta * f * le * (g / pdf_area);
        if l.is_black() || tr.occluded_between(&pt.sp, &lp) {
            return None;
        }
        sampled = Some(Vertex {
            kind: Kind::Light,
            sp: lp,
            local: None,
            beta: le / pdf_area,
            pdf_fwd: pdf_area,
            pdf_rev: 0.0,
            delta: false,
        });
        l
    } else {
        // Join y_{s−1} and z_{t−1} by an edge.
        let qs = ws.light[s - 1];
        let pt = ws.camera[t - 1];
        if !qs.connectible()
            || !pt.connectible()
            || qs.kind != Kind::Surface
            || pt.kind != Kind::Surface
        {
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
        let g = qs.sp.ns.dot(dn).abs() * pt.sp.ns.dot(dn).abs() / d2;
        let l = qs.beta * fq * fp * pt.beta * g;
        if l.is_black() || tr.occluded_between(&qs.sp, &pt.sp) {
            return None;
        }
        l
    };
    finish(scene, camera, ws, sampled, s, t, l, raster, None)
}

/// The MIS-weighted result of strategy (s, t) with unweighted
/// contribution `l` (see [`connect`]); `flight` the connection's
/// free-flight densities in a scene with media (see [`mis_weight`]).
#[allow(clippy::too_many_arguments)]
#[inline]
fn finish(
    scene: &Scene,
    camera: &Camera,
    ws: &mut PathStorage,
    sampled: Option<Vertex>,
    s: usize,
    t: usize,
    l: Rgb,
    raster: Option<Vec2>,
    flight: Option<(f32, f32)>,
) -> Option<(Rgb, Option<Vec2>, Option<Vertex>)> {
    if l.is_black() {
        return None;
    }
    let w = if ws.only.is_some() {
        1.0
    } else {
        mis_weight(scene, camera, ws, sampled, s, t, flight)
    };
    Some((l * w, raster, sampled))
}

/// Next-event estimation (s = 1) towards non-area light `index`, chosen
/// with probability `pmf`: the unweighted contribution and the light
/// vertex it sampled (pbrt-v4's `SampleLi` in `ConnectBDPT`).
#[inline(never)]
fn connect_other<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    ws: &PathStorage,
    t: usize,
    index: usize,
    pmf: f32,
    u: Vec2,
) -> Option<(Rgb, Vertex)> {
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
    let l = pt.beta * f * inc.li * (pt.sp.ns.dot(dir).abs() / pdf);
    if l.is_black() {
        return None;
    }
    let occluded = match inc.position {
        Some(p) => tr.occluded_to_point(&pt.sp, p),
        None => tr.occluded_towards(&pt.sp, dir),
    };
    if occluded {
        return None;
    }
    let mut v = other_light_vertex(scene, index, inc.position.unwrap_or(pt.sp.p), pt.sp.p, dir);
    v.beta = inc.li * (1.0 / pdf);
    // As in `other_light_subpath`; unused for delta lights, which s = 0
    // never samples.
    v.pdf_fwd = match v.kind {
        Kind::PointLight => pmf,
        Kind::Environment => scene.lights.pdf_environment(dir),
        _ => 0.0,
    };
    Some((l, v))
}

/// Power-heuristic weight of strategy (s, t) against every other strategy
/// that could have produced the same path (Veach 1997, §10.2.1, with β = 2).
///
/// In a scene with media, `flight` holds the free-flight densities of the
/// connecting segment (of reaching z_{t−1} from y_{s−1}, and y_{s−1} from
/// z_{t−1}: scattering or passing, averaged over the channels), and the
/// reverse densities recomputed along the subpaths' last segments take
/// theirs from the subpaths' [`MediaInfo`]; every area density then has
/// its free-flight density in it, as the walks stored them.
fn mis_weight(
    scene: &crate::scene::Scene,
    camera: &crate::scene::Camera,
    ws: &mut PathStorage,
    sampled: Option<Vertex>,
    s: usize,
    t: usize,
    flight: Option<(f32, f32)>,
) -> f32 {
    if s + t == 2 {
        return 1.0;
    }
    let lights_pdf = |l: &Vertex, to: &Vertex| light_emission_pdf(scene, l, to);
    // Density of light sampling producing the emitter vertex v that a
    // camera subpath reached: per unit area on an area light, per unit
    // solid angle on the environment.
    let origin_pdf = |v: &Vertex| {
        if v.kind == Kind::Environment {
            scene.lights.pdf_environment(v.sp.ng)
        } else {
            scene.lights.pdf_area(v.sp.surface as usize)
        }
    };

    // The strategy changes the reverse density and the delta flag of at
    // most two vertices on each side (and replaces an endpoint by the one
    // its connection sampled): those fields are saved and restored, so the
    // subpaths stay valid for the next strategy. Saving fields, not whole
    // vertices, keeps this per-strategy step free of large copies.
    let fields = |v: &Vertex| (v.pdf_rev, v.delta);
    let save_cam: [Option<(f32, bool)>; 2] = [
        t.checked_sub(1).map(|i| fields(&ws.camera[i])),
        t.checked_sub(2).map(|i| fields(&ws.camera[i])),
    ];
    let save_light: [Option<(f32, bool)>; 2] = [
        s.checked_sub(1).map(|i| fields(&ws.light[i])),
        s.checked_sub(2).map(|i| fields(&ws.light[i])),
    ];
    let mut save_endpoint: Option<(bool, Vertex)> = None;
    if let Some(v) = sampled {
        if s == 1 {
            save_endpoint = Some((true, core::mem::replace(&mut ws.light[0], v)));
        } else if t == 1 {
            save_endpoint = Some((false, core::mem::replace(&mut ws.camera[0], v)));
        }
    }
    // Ends of the connection are not delta for this strategy.
    if t > 0 {
        ws.camera[t - 1].delta = false;
    }
    if s > 0 {
        ws.light[s - 1].delta = false;
    }
    // Reverse densities at the connection's ends and their neighbours,
    // computed from the vertices in place (`Vertex::pdf` reads no
    // `pdf_rev`), then stored.
    let (pt_rev, pt_minus_rev, qs_rev, qs_minus_rev) = {
        let pt = &ws.camera[t - 1];
        let pt_minus = if t > 1 { Some(&ws.camera[t - 2]) } else { None };
        let qs = if s > 0 { Some(&ws.light[s - 1]) } else { None };
        let qs_minus = if s > 1 { Some(&ws.light[s - 2]) } else { None };
        let pt_rev = match (qs, qs_minus) {
            (Some(q), qm) => q.pdf(camera, lights_pdf, qm, pt),
            (None, _) => origin_pdf(pt),
        };
        let pt_minus_rev = pt_minus.map(|pm| match qs {
            Some(q) => pt.pdf(camera, lights_pdf, Some(q), pm),
            None => lights_pdf(pt, pm),
        });
        let qs_rev = qs.map(|q| pt.pdf(camera, lights_pdf, pt_minus, q));
        let qs_minus_rev = match (qs, qs_minus) {
            (Some(q), Some(qm)) => Some(q.pdf(camera, lights_pdf, Some(pt), qm)),
            _ => None,
        };
        (pt_rev, pt_minus_rev, qs_rev, qs_minus_rev)
    };
    #[cfg(feature = "media")]
    let (pt_rev, pt_minus_rev, qs_rev, qs_minus_rev) = match flight {
        None => (pt_rev, pt_minus_rev, qs_rev, qs_minus_rev),
        Some((to_pt, to_qs)) => (
            if s > 0 { pt_rev * to_pt } else { pt_rev },
            pt_minus_rev.map(|r| r * ws.camera_media[t - 1].rev),
            qs_rev.map(|r| r * to_qs),
            qs_minus_rev.map(|r| r * ws.light_media[s - 1].rev),
        ),
    };
    #[cfg(not(feature = "media"))]
    let _ = flight;
    ws.camera[t - 1].pdf_rev = pt_rev;
    if let Some(r) = pt_minus_rev {
        ws.camera[t - 2].pdf_rev = r;
    }
    if let Some(r) = qs_rev {
        ws.light[s - 1].pdf_rev = r;
    }
    if let Some(r) = qs_minus_rev {
        ws.light[s - 2].pdf_rev = r;
    }

    let remap = |x: f32| if x != 0.0 { x } else { 1.0 };
    let mut sum = 0.0f32;
    let mut ri = 1.0f32;
    for i in (1..t).rev() {
        let r = remap(ws.camera[i].pdf_rev) / remap(ws.camera[i].pdf_fwd);
        ri *= r * r;
        if !ws.camera[i].delta && !ws.camera[i - 1].delta {
            sum += ri;
        }
    }
    ri = 1.0;
    for i in (0..s).rev() {
        let r = remap(ws.light[i].pdf_rev) / remap(ws.light[i].pdf_fwd);
        ri *= r * r;
        // y₀ of a delta light cannot be hit: no strategy s = 0.
        let prev_delta = if i > 0 {
            ws.light[i - 1].delta
        } else {
            ws.light[0].is_delta_light()
        };
        if !ws.light[i].delta && !prev_delta {
            sum += ri;
        }
    }

    for (k, f) in save_cam.into_iter().enumerate() {
        if let Some((pdf_rev, delta)) = f {
            let v = &mut ws.camera[t - 1 - k];
            (v.pdf_rev, v.delta) = (pdf_rev, delta);
        }
    }
    for (k, f) in save_light.into_iter().enumerate() {
        if let Some((pdf_rev, delta)) = f {
            let v = &mut ws.light[s - 1 - k];
            (v.pdf_rev, v.delta) = (pdf_rev, delta);
        }
    }
    match save_endpoint {
        Some((true, v)) => ws.light[0] = v,
        Some((false, v)) => ws.camera[0] = v,
        None => {}
    }
    let w = 1.0 / (1.0 + sum);
    if w.is_finite() { w } else { 0.0 }
}
