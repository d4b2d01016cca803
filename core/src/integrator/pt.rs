//! Unidirectional path tracing with next-event estimation and MIS.
//!
//! Each vertex combines two strategies for the next segment's emission —
//! sampling a point on a light (next-event estimation) and sampling the
//! BSDF — with the power heuristic (Veach 1997, §9.2). Depth and Russian
//! roulette follow Mitsuba 3's `path` integrator, so that images agree with
//! the references: a path of `max_depth` segments is the longest allowed,
//! and from `rr_depth` segments on a path survives with probability
//! min(0.95, max(throughput) · η²).
//!
//! Lights other than emissive meshes (see [`crate::scene::Light`]) enter
//! in two places only, so a scene of area lights runs none of their code:
//! next-event estimation samples them when the light selection picks one
//! (delta lights with weight 1: no BSDF sample can reach them), and a ray
//! that leaves the scene gathers the environment's radiance, MIS-weighted
//! against next-event estimation's solid-angle density of that direction.

use glam::Vec2;

use super::Settings;
use super::tracer::{Shading, Tracer};
use crate::accel::Intersector;
use crate::bsdf::{BsdfSample, TransportMode};
use crate::geometry::{Ray, offset};
use crate::math::{Rgb, power_heuristic};
use crate::sampler::SampleStream;
use crate::scene::EmitterSample;

#[cfg(feature = "media")]
mod media;

/// Radiance arriving at the camera along `ray` (the primary ray). A scene
/// with media or null boundaries takes `pt/media.rs`'s estimator (the same
/// one, extended), so that a scene without them runs none of its code.
pub fn radiance<I: Intersector>(
    t: &mut Tracer<'_, I>,
    settings: &Settings,
    ray: Ray,
    rng: &mut SampleStream,
) -> Rgb {
    #[cfg(feature = "media")]
    if t.has_media() {
        return media::radiance(t, settings, ray, rng);
    }
    let max_depth = settings.max_depth.unwrap_or(u32::MAX);
    let mut l = Rgb::ZERO;
    let mut beta = Rgb::ONE;
    let mut ray = ray;
    // Solid-angle density of the BSDF sample that produced `ray`, and
    // whether it was a delta lobe (the camera ray counts as one: emission
    // seen directly has no competing strategy).
    let mut prev_pdf = 0.0f32;
    let mut prev_delta = true;
    let mut eta_scale = 1.0f32;
    let mut depth = 0u32;
    while depth < max_depth {
        let Some(hit) = t.trace(&ray) else {
            // The ray left the scene (segment depth + 1 ≤ max_depth): the
            // environment it sees, hidden from the camera with the other
            // emitters (Mitsuba's `hide_emitters`).
            if cfg!(feature = "environment")
                && t.scene.lights.has_environment()
                && (depth > 0 || !settings.hide_emitters)
            {
                l += beta * escaped(t, ray.d.normalize(), prev_pdf, prev_delta);
            }
            break;
        };
        depth += 1;
        let wo_world = (-ray.d).normalize();
        let sp = hit.sp;

        // Emission reached by the BSDF sample (or seen directly).
        let le = t.scene.emitted(&sp, wo_world);
        if !le.is_black() && (depth > 1 || !settings.hide_emitters) {
            let w = if prev_delta {
                1.0
            } else {
                let d2 = (sp.p - ray.o).length_squared();
                let cos_l = sp.ng.dot(wo_world).abs();
                let pdf_light = t.scene.lights.pdf_area(sp.surface as usize) * d2 / cos_l;
                power_heuristic(prev_pdf, pdf_light)
            };
            l += beta * le * w;
        }
        if depth >= max_depth {
            break;
        }

        let wo = hit.frame.to_local(wo_world);

        // Next-event estimation: one light sample, weighted against the
        // BSDF's density of the same direction.
        let u_sel = rng.next_f32();
        let u_light = rng.next_2d();
        let emitter = if hit.bsdf.is_delta() {
            None
        } else {
            t.scene.sample_emitter(u_sel, u_light)
        };
        if let Some(EmitterSample::Other { index, pmf }) = emitter {
            l += beta * direct_other(t, &hit, wo, index, pmf, u_light);
        }
        if let Some(EmitterSample::Area { sp: lp, pdf_area }) = emitter {
            let to = lp.p - sp.p;
            let d2 = to.length_squared();
            if d2 > 0.0 && pdf_area > 0.0 {
                let dir = to / libm::sqrtf(d2);
                let le = t.scene.emitted(&lp, -dir);
                let cos_l = lp.ng.dot(dir).abs();
                if !le.is_black() && cos_l > 0.0 {
                    let wi = hit.frame.to_local(dir);
                    let f = t.eval_bsdf(&hit.bsdf, wo, wi, TransportMode::Radiance);
                    if !f.is_black() && !t.occluded_between(&sp, &lp) {
                        let pdf_light = pdf_area * d2 / cos_l;
                        let w = power_heuristic(pdf_light, hit.bsdf.pdf(wo, wi));
                        l += beta * f * le * (wi.z.abs() * w / pdf_light);
                    }
                }
            }
        }

        // Continue the path by sampling the BSDF.
        let Some(bs) = continue_path(t, &hit, wo, rng, &mut beta, &mut eta_scale) else {
            break;
        };
        prev_pdf = bs.pdf;
        prev_delta = bs.delta;
        let wi_world = hit.frame.to_world(bs.wi);
        ray = offset::spawn_ray(sp.p, sp.p_error, sp.ng, wi_world);

        // Russian roulette (Mitsuba: from rr_depth segments on).
        if depth >= settings.rr_depth {
            let q = (beta.max_component() * eta_scale).min(0.95);
            if !(rng.next_f32() < q) {
                break;
            }
            beta /= q;
        }
        if beta.is_black() {
            break;
        }
    }
    l
}

/// Samples the BSDF at `hit` (local outgoing direction `wo`) to continue
/// the path: the sample, with the throughput `beta` multiplied by
/// f·|cos θ|/p and `eta_scale` by η² across a refraction (roulette
/// compares the throughput with the radiance scaling η² undone). `None`
/// ends the path: no sample, or one that carries nothing.
#[inline]
fn continue_path<I: Intersector>(
    t: &mut Tracer<'_, I>,
    hit: &Shading,
    wo: glam::Vec3,
    rng: &mut SampleStream,
    beta: &mut Rgb,
    eta_scale: &mut f32,
) -> Option<BsdfSample> {
    let u_lobe = rng.next_f32();
    let u_dir: Vec2 = rng.next_2d();
    let bs = t.sample_bsdf(&hit.bsdf, wo, u_lobe, u_dir, TransportMode::Radiance)?;
    if bs.pdf <= 0.0 || bs.f.is_black() {
        return None;
    }
    *beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
    if bs.eta != 1.0 {
        *eta_scale *= bs.eta * bs.eta;
    }
    Some(bs)
}

/// Radiance of the environment arriving along unit `d` from the scene,
/// reached by a BSDF sample of solid-angle density `prev_pdf` (or a delta
/// lobe / the camera ray, `prev_delta`): each environment light weighted
/// against next-event estimation's density of `d` (power heuristic).
fn escaped<I: Intersector>(
    t: &Tracer<'_, I>,
    d: glam::Vec3,
    prev_pdf: f32,
    prev_delta: bool,
) -> Rgb {
    let lights = &t.scene.lights;
    let mut l = Rgb::ZERO;
    for i in lights.environment() {
        let le = lights.radiance(i, d);
        if le.is_black() {
            continue;
        }
        let w = if prev_delta {
            1.0
        } else {
            power_heuristic(prev_pdf, lights.pmf_other(i) * lights.pdf_incident(i, d))
        };
        l += le * w;
    }
    l
}

/// Next-event estimation towards light `index` of the scene's non-area
/// lights, chosen with probability `pmf` (`u` places a direction on an
/// environment): f · Li · |cos| / p, MIS-weighted against the BSDF for an
/// environment, unweighted for a delta light (the only strategy that
/// reaches it).
fn direct_other<I: Intersector>(
    t: &mut Tracer<'_, I>,
    hit: &Shading,
    wo: glam::Vec3,
    index: usize,
    pmf: f32,
    u: Vec2,
) -> Rgb {
    let Some(inc) = t.scene.lights.sample_incident(index, hit.sp.p, u) else {
        return Rgb::ZERO;
    };
    let pdf_light = pmf * inc.pdf;
    if !(pdf_light > 0.0) {
        return Rgb::ZERO;
    }
    let wi = hit.frame.to_local(inc.wi);
    let f = t.eval_bsdf(&hit.bsdf, wo, wi, TransportMode::Radiance);
    if f.is_black() {
        return Rgb::ZERO;
    }
    let occluded = match inc.position {
        Some(p) => t.occluded_to_point(&hit.sp, p),
        None => t.occluded_towards(&hit.sp, inc.wi),
    };
    if occluded {
        return Rgb::ZERO;
    }
    let w = if inc.delta {
        1.0
    } else {
        power_heuristic(pdf_light, hit.bsdf.pdf(wo, wi))
    };
    f * inc.li * (wi.z.abs() * w / pdf_light)
}
