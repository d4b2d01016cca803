//! Scattering models in the local shading frame (z = shading normal).
//!
//! PLACEHOLDER API (being completed): directions `wo` (towards the viewer /
//! previous vertex) and `wi` (sampled, towards the light / next vertex) both
//! point away from the surface.

use glam::{Vec2, Vec3};

use crate::math::{Rgb, warp};
use crate::scene::{Material, MaterialKind, Texture};

/// Whether a path carries radiance (camera side) or importance (light side);
/// refraction scales by 1/η² only for radiance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    /// Camera subpaths.
    Radiance,
    /// Light subpaths.
    Importance,
}

/// Result of sampling a BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// Sampled direction (local frame).
    pub wi: Vec3,
    /// BSDF value f(wo, wi) (for a delta lobe: weight·pdf/|cos θi|).
    pub f: Rgb,
    /// Solid-angle density (for a delta lobe: the lobe's discrete probability).
    pub pdf: f32,
    /// True when the sampled lobe is a Dirac delta.
    pub delta: bool,
    /// Relative IOR crossed (1 for reflection).
    pub eta: f32,
}

/// A material resolved at one point (textures evaluated).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bsdf {
    albedo: Rgb,
    two_sided: bool,
}

impl Bsdf {
    /// Resolves `material` at one point; `texture` evaluates a texture
    /// there (the scene supplies it, so this module needs no bitmaps).
    pub fn new(material: &Material, texture: impl Fn(&Texture) -> Rgb) -> Self {
        let albedo = match &material.kind {
            MaterialKind::Diffuse { reflectance } => texture(reflectance),
            _ => Rgb::ZERO,
        };
        Bsdf { albedo, two_sided: material.two_sided }
    }

    /// True when every lobe is a Dirac delta.
    pub fn is_delta(&self) -> bool {
        false
    }

    /// f(wo, wi), without the cosine; zero for delta lobes.
    pub fn eval(&self, wo: Vec3, wi: Vec3, _mode: TransportMode) -> Rgb {
        let (wo, wi) = if self.two_sided && wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.albedo * crate::math::INV_PI
    }

    /// Solid-angle density of sampling `wi` given `wo`; zero for deltas.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = if self.two_sided && wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        if wo.z <= 0.0 {
            return 0.0;
        }
        warp::cosine_hemisphere_pdf(wi)
    }

    /// Samples `wi`; `u_lobe` chooses a lobe, `u` the direction.
    pub fn sample(&self, wo: Vec3, _u_lobe: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        let flip = self.two_sided && wo.z < 0.0;
        let wo_l = if flip { -wo } else { wo };
        if wo_l.z <= 0.0 {
            return None;
        }
        let mut wi = warp::square_to_cosine_hemisphere(u);
        let pdf = warp::cosine_hemisphere_pdf(wi);
        if flip {
            wi = -wi;
        }
        (pdf > 0.0).then(|| BsdfSample { wi, f: self.eval(wo, wi, mode), pdf, delta: false, eta: 1.0 })
    }
}
