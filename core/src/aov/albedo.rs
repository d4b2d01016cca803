//! The albedo a denoiser is guided by: the directional-hemispherical
//! reflectance ρ(ωo) = ∫ f(ωo, ωi) |cos θi| dωi of the BSDF at a hit,
//! towards the camera.
//!
//! Estimated with the BSDF's own importance sampling at a fixed set of
//! stratified points (one for the Lambertian and smooth conductor models,
//! [`SAMPLES`] for the others), the same for every pixel, so the output
//! has no noise (a denoiser takes noise in its guide for detail): each
//! sample's weight f·|cos θi|/pdf is exactly the model's reflectance for a
//! Lambertian surface (cosine sampling), for mirrors (the Fresnel weight)
//! and for smooth glass (reflection and transmission, chosen by the lobe
//! coordinate in proportion to Fresnel), so those come out exact up to
//! rounding; for rough and layered models the mean of the fixed samples
//! approximates ρ(ωo) (a denoiser needs the surface's colour, not ρ to the
//! last digit: OIDN asks for an albedo in [0, 1] and accepts
//! approximations). The BSDF is sampled in importance mode, so that
//! transmission is not scaled by 1/η² (that compresses radiance; the
//! energy carried through is 1 − F). Clamped to [0, 1].

use glam::{Vec2, Vec3};

use crate::accel::Intersector;
use crate::bsdf::{Lobe, TransportMode};
use crate::integrator::Tracer;
use crate::integrator::tracer::Shading;
use crate::math::Rgb;

/// Samples per estimate.
const SAMPLES: usize = 8;

/// The fixed sample points (u_lobe, u): u on a 2-D Hammersley set of
/// `SAMPLES` points (x = (i + ½)/n, y = the base-2 radical inverse of i
/// shifted by ½n), the lobe coordinate stratified in the order 3i mod n so
/// that it is not correlated with either.
fn point(i: usize) -> (f32, Vec2) {
    let n = SAMPLES as f32;
    let radical = (i as u32).reverse_bits() as f32 / 4_294_967_296.0;
    let u = Vec2::new((i as f32 + 0.5) / n, radical + 0.5 / n);
    let lobe = ((3 * i) % SAMPLES) as f32 + 0.5;
    (lobe / n, u)
}

/// ρ(ωo) of the BSDF at `sh`, seen from unit world direction `wo` (from
/// the surface towards the camera), clamped to [0, 1]. One sample for the
/// models whose every sample weighs ρ exactly (Lambertian, a smooth
/// conductor's single Dirac lobe), [`SAMPLES`] for the others.
pub(super) fn albedo<I: Intersector>(tracer: &mut Tracer<'_, I>, sh: &Shading, wo: Vec3) -> Rgb {
    let wo = sh.frame.to_local(wo);
    let n = match sh.bsdf.lobe() {
        Lobe::Diffuse | Lobe::SpecularReflection => 1,
        _ => SAMPLES,
    };
    let mut sum = Rgb::ZERO;
    for i in 0..n {
        let (u_lobe, u) = point(i);
        if let Some(s) = tracer.sample_bsdf(&sh.bsdf, wo, u_lobe, u, TransportMode::Importance)
            && s.pdf > 0.0
        {
            sum += s.f * (s.wi.z.abs() / s.pdf);
        }
    }
    clamped(sum / n as f32)
}

/// An albedo clamped to [0, 1] (NaN to 0), as the outputs hold it.
pub(super) fn clamped(a: Rgb) -> Rgb {
    a.map(|v| if v > 0.0 { v.min(1.0) } else { 0.0 })
}
