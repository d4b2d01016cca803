//! Path tracing through homogeneous participating media and null
//! boundaries (the volumetric path tracer; the images of Mitsuba 3's
//! `volpath` and `volpathmis`).
//!
//! The current medium is tracked along the path: it starts as the
//! camera's, and changes wherever the path crosses a mesh that names
//! media (a null boundary, or a refraction through a dielectric whose
//! sides name them). Null boundaries are passed without a vertex: they
//! neither count towards the depth nor end a specular chain; the last
//! scattering vertex stays the one whose density competes with next-event
//! estimation when the path reaches an emitter.
//!
//! **Distance sampling: spectral MIS over the RGB channels** (Mitsuba 3's
//! `volpathmis`; Miller et al. 2019, "A null-scattering path integral
//! formulation of light transport", one-sample balance heuristic over the
//! wavelengths; Mitsuba's plain `volpath` divides by the chosen channel's
//! density alone, which its documentation says handles spectrally varying
//! extinction poorly).
//! A channel c is chosen uniformly and a free-flight distance drawn with
//! density σ_t,c e^{−σ_t,c s}; the estimator divides by the density
//! averaged over the channels, (1/3) Σ_c σ_t,c e^{−σ_t,c s} for a scattering
//! at s, (1/3) Σ_c e^{−σ_t,c t} for passing to the surface at t. Every
//! channel's estimate is then unbiased with bounded weights even when the
//! channels' σ_t differ by orders of magnitude (a coloured absorber), where
//! sampling by one fixed channel (or a grey σ_t) gives the others weights
//! e^{(σ_t,c − σ_t,k) s} without bound. A hero channel with the other
//! channels carried by their ratios is this same estimator without the
//! balance heuristic, and has exactly that variance problem.
//!
//! A medium that only absorbs (σ_s = 0 in every channel, the interior of
//! a tinted glass or liquid) is not sampled at all: the path passes it
//! with the transmittance as its weight, since there is no vertex to find
//! and a sampled distance would only make the transmittance a coin flip
//! (`Medium::sample_flight`).
//!
//! At a medium vertex the path scatters with probability σ_s/σ_t per
//! channel, folded into the weight σ_s e^{−σ_t s} / p(s); the phase
//! function is sampled exactly (weight 1). Next-event estimation at
//! surface and medium vertices multiplies the light's contribution by the
//! transmittance to it ([`Tracer::transmittance`]: analytic per medium,
//! through null boundaries, zero through anything else), and is weighted
//! against the phase or BSDF density with the power heuristic, as the
//! surface-only tracer does. Russian roulette has the same meaning: from
//! `rr_depth` scattering vertices on (medium and surface alike), survival
//! min(0.95, max(throughput) · η²).

use glam::Vec3;

use super::{Settings, continue_path, escaped};
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, offset};
use crate::integrator::tracer::{Endpoint, Shading, Tracer};
use crate::math::{Rgb, power_heuristic};
use crate::sampler::SampleStream;
use crate::scene::{EmitterSample, Flight, MaterialKind, MediumId, Phase};

/// Most null boundaries a path crosses in a row, without scattering,
/// before it is ended (a bound on the work of a path through a stack of
/// them, as [`crate::integrator::tracer::MAX_NULL_CROSSINGS`] for shadow
/// rays).
const MAX_NULL_RUN: u32 = 64;

/// A scattering vertex that next-event estimation starts from.
enum Vertex<'s> {
    /// A surface point, seen from local direction `wo`.
    Surface(&'s Shading, Vec3),
    /// A point in a medium reached travelling in unit direction `d`.
    Medium { p: Vec3, d: Vec3, phase: Phase },
}

impl Vertex<'_> {
    /// Position, error bound and geometric normal (zero in a medium).
    fn origin(&self) -> (Vec3, Vec3, Vec3) {
        match self {
            Vertex::Surface(hit, _) => (hit.sp.p, hit.sp.p_error, hit.sp.ng),
            Vertex::Medium { p, .. } => (*p, Vec3::ZERO, Vec3::ZERO),
        }
    }

    /// The scattered radiance's factor towards unit world direction `wi`
    /// (BSDF × |cos θ|, or the phase function) and the density with which
    /// the path's own continuation samples `wi`.
    fn eval<I: Intersector>(&self, t: &mut Tracer<'_, I>, wi: Vec3) -> (Rgb, f32) {
        match self {
            Vertex::Surface(hit, wo) => {
                let wl = hit.frame.to_local(wi);
                let f = t.eval_bsdf(&hit.bsdf, *wo, wl, TransportMode::Radiance);
                (f * wl.z.abs(), hit.bsdf.pdf(*wo, wl))
            }
            Vertex::Medium { d, phase, .. } => {
                let p = phase.eval(*d, wi);
                (Rgb::splat(p), p)
            }
        }
    }
}

/// Radiance arriving at the camera along `ray` in a scene with media or
/// null boundaries (see the module's description).
pub(super) fn radiance<I: Intersector>(
    t: &mut Tracer<'_, I>,
    settings: &Settings,
    ray: Ray,
    rng: &mut SampleStream,
) -> Rgb {
    let max_depth = settings.max_depth.unwrap_or(u32::MAX);
    let scene = t.scene;
    let mut l = Rgb::ZERO;
    let mut beta = Rgb::ONE;
    let mut ray = ray;
    let mut medium = scene.camera_medium();
    // The last scattering vertex, the density of the direction it
    // sampled, and whether that was a delta lobe (the camera counts as
    // one: emission seen directly has no competing strategy).
    let mut prev_p = ray.o;
    let mut prev_pdf = 0.0f32;
    let mut prev_delta = true;
    let mut eta_scale = 1.0f32;
    let mut depth = 0u32;
    let mut null_run = 0u32;
    while depth < max_depth {
        let dir = ray.d.normalize();
        let hit = t.trace(&ray);
        let t_surface = hit
            .as_ref()
            .map_or(f32::INFINITY, |h| (h.sp.p - ray.o).length());

        // Free flight through the current medium (spectral MIS).
        if let Some(id) = medium {
            let m = *scene.medium(id);
            let u_channel = rng.next_f32();
            let u = rng.next_f32();
            match m.sample_flight(t_surface, u_channel, u) {
                Flight::Absorbed => break,
                Flight::Pass { weight } => beta *= weight,
                Flight::Scatter { s, weight } => {
                    beta *= weight;
                    depth += 1;
                    if depth >= max_depth || beta.is_black() {
                        break;
                    }
                    let p = ray.o + dir * s;
                    let vertex = Vertex::Medium {
                        p,
                        d: dir,
                        phase: m.phase(),
                    };
                    l += beta * direct(t, &vertex, medium, rng);
                    let ps = m.phase().sample(dir, rng.next_2d());
                    if !(ps.pdf > 0.0) {
                        break;
                    }
                    // f / pdf = 1: the phase function is sampled exactly.
                    prev_p = p;
                    prev_pdf = ps.pdf;
                    prev_delta = false;
                    null_run = 0;
                    ray = Ray::new(p, ps.wi);
                    if !roulette(settings, depth, &mut beta, eta_scale, rng) {
                        break;
                    }
                    continue;
                }
            }
        }

        let Some(hit) = hit else {
            if cfg!(feature = "environment")
                && scene.lights.has_environment()
                && (depth > 0 || !settings.hide_emitters)
            {
                l += beta * escaped(t, dir, prev_pdf, prev_delta);
            }
            break;
        };
        let sp = hit.sp;
        let wo_world = -dir;

        // Emission reached by the last scattering vertex's sample (or seen
        // directly), weighted against next-event estimation from there.
        let le = scene.emitted(&sp, wo_world);
        if !le.is_black() && (depth > 0 || !settings.hide_emitters) {
            let w = if prev_delta {
                1.0
            } else {
                let d2 = (sp.p - prev_p).length_squared();
                let cos_l = sp.ng.dot(wo_world).abs();
                let pdf_light = scene.lights.pdf_area(sp.surface as usize) * d2 / cos_l;
                power_heuristic(prev_pdf, pdf_light)
            };
            l += beta * le * w;
        }

        let iface = scene.surface_media(sp.surface);
        if matches!(scene.material(&sp).kind, MaterialKind::Null) {
            // An index-matched boundary: the path goes on unchanged in the
            // medium behind it, with no vertex.
            null_run += 1;
            if null_run > MAX_NULL_RUN {
                break;
            }
            if iface.is_transition() {
                medium = iface.target(sp.ng, dir);
            }
            ray = Ray::new(
                offset::offset_ray_origin(sp.p, sp.p_error, sp.ng, dir),
                ray.d,
            );
            continue;
        }
        null_run = 0;
        depth += 1;
        if depth >= max_depth {
            break;
        }

        let wo = hit.frame.to_local(wo_world);
        if !hit.bsdf.is_delta() {
            l += beta * direct(t, &Vertex::Surface(&hit, wo), medium, rng);
        } else {
            // The same random numbers drawn either way.
            rng.next_f32();
            rng.next_2d();
        }

        let Some(bs) = continue_path(t, &hit, wo, rng, &mut beta, &mut eta_scale) else {
            break;
        };
        prev_p = sp.p;
        prev_pdf = bs.pdf;
        prev_delta = bs.delta;
        let wi_world = hit.frame.to_world(bs.wi);
        if iface.is_transition() {
            medium = iface.target(sp.ng, wi_world);
        }
        ray = offset::spawn_ray(sp.p, sp.p_error, sp.ng, wi_world);
        if !roulette(settings, depth, &mut beta, eta_scale, rng) {
            break;
        }
    }
    l
}

/// Russian roulette after a scattering vertex (Mitsuba: from `rr_depth`
/// vertices on, survival min(0.95, max(β) · η²)); false ends the path.
fn roulette(
    settings: &Settings,
    depth: u32,
    beta: &mut Rgb,
    eta_scale: f32,
    rng: &mut SampleStream,
) -> bool {
    if depth >= settings.rr_depth {
        let q = (beta.max_component() * eta_scale).min(0.95);
        if !(rng.next_f32() < q) {
            return false;
        }
        *beta /= q;
    }
    !beta.is_black()
}

/// Next-event estimation from `vertex` in `medium` (the medium around a
/// medium vertex; at a surface, the path's current medium, which the
/// surface's own media replace on the light's side): one light sample,
/// its contribution times the transmittance to it, weighted against the
/// vertex's density of the same direction (power heuristic; delta lights
/// unweighted).
fn direct<I: Intersector>(
    t: &mut Tracer<'_, I>,
    vertex: &Vertex<'_>,
    medium: Option<MediumId>,
    rng: &mut SampleStream,
) -> Rgb {
    let u_sel = rng.next_f32();
    let u_light = rng.next_2d();
    let scene = t.scene;
    let (p, p_error, ng) = vertex.origin();
    // The medium the shadow ray starts in.
    let start = |wi: Vec3| match vertex {
        Vertex::Surface(hit, _) => {
            let iface = scene.surface_media(hit.sp.surface);
            if iface.is_transition() {
                iface.target(ng, wi)
            } else {
                medium
            }
        }
        Vertex::Medium { .. } => medium,
    };
    match scene.sample_emitter(u_sel, u_light) {
        Some(EmitterSample::Area { sp: lp, pdf_area }) => {
            let to = lp.p - p;
            let d2 = to.length_squared();
            if !(d2 > 0.0 && pdf_area > 0.0) {
                return Rgb::ZERO;
            }
            let wi = to / libm::sqrtf(d2);
            let le = scene.emitted(&lp, -wi);
            let cos_l = lp.ng.dot(wi).abs();
            if le.is_black() || !(cos_l > 0.0) {
                return Rgb::ZERO;
            }
            let (f, pdf_vertex) = vertex.eval(t, wi);
            if f.is_black() {
                return Rgb::ZERO;
            }
            let tr = t.transmittance(p, p_error, ng, Endpoint::Surface(lp), start(wi));
            if tr.is_black() {
                return Rgb::ZERO;
            }
            let pdf_light = pdf_area * d2 / cos_l;
            let w = power_heuristic(pdf_light, pdf_vertex);
            f * tr * le * (w / pdf_light)
        }
        Some(EmitterSample::Other { index, pmf }) => {
            let Some(inc) = scene.lights.sample_incident(index, p, u_light) else {
                return Rgb::ZERO;
            };
            let pdf_light = pmf * inc.pdf;
            if !(pdf_light > 0.0) {
                return Rgb::ZERO;
            }
            let (f, pdf_vertex) = vertex.eval(t, inc.wi);
            if f.is_black() {
                return Rgb::ZERO;
            }
            let end = match inc.position {
                Some(q) => Endpoint::Point(q),
                None => Endpoint::Direction(inc.wi),
            };
            let tr = t.transmittance(p, p_error, ng, end, start(inc.wi));
            if tr.is_black() {
                return Rgb::ZERO;
            }
            let w = if inc.delta {
                1.0
            } else {
                power_heuristic(pdf_light, pdf_vertex)
            };
            f * tr * inc.li * (w / pdf_light)
        }
        None => Rgb::ZERO,
    }
}
