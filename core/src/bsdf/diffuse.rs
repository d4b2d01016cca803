//! Lambertian reflection (Mitsuba's `diffuse`), in the upper hemisphere.

use glam::{Vec2, Vec3};

use super::BsdfSample;
use crate::math::{INV_PI, Rgb, warp};

/// f = albedo/π when both directions are above the surface.
#[inline]
pub(super) fn eval(albedo: Rgb, wo: Vec3, wi: Vec3) -> Rgb {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        Rgb::ZERO
    } else {
        albedo * INV_PI
    }
}

/// Cosine-weighted hemisphere density, cos θi/π.
#[inline]
pub(super) fn pdf(wo: Vec3, wi: Vec3) -> f32 {
    if wo.z <= 0.0 {
        0.0
    } else {
        warp::cosine_hemisphere_pdf(wi)
    }
}

/// Cosine-weighted sampling: the weight f·cos θi/pdf is the albedo.
#[inline]
pub(super) fn sample(albedo: Rgb, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
    if wo.z <= 0.0 {
        return None;
    }
    sample_cosine(u, |wi| eval(albedo, wo, wi), |wi| pdf(wo, wi))
}

/// Cosine-weighted sampling of a smooth reflection lobe, returned with the
/// model's own value `f` and density `pdf` (which may mix in other lobes):
/// the diffuse-class models' sampler.
#[inline]
pub(super) fn sample_cosine(
    u: Vec2,
    f: impl FnOnce(Vec3) -> Rgb,
    pdf: impl FnOnce(Vec3) -> f32,
) -> Option<BsdfSample> {
    let wi = warp::square_to_cosine_hemisphere(u);
    let pdf = pdf(wi);
    // wi.z can round to 0 on the disk's rim; such a direction has no density.
    (pdf > 0.0).then(|| BsdfSample {
        wi,
        f: f(wi),
        pdf,
        delta: false,
        eta: 1.0,
    })
}
