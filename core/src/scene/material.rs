//! Materials as the scene describes them, before textures are evaluated.
//!
//! A [`Material`] is resolved at a hit point into a [`crate::bsdf::Bsdf`]
//! with plain colours; the BSDF code never sees textures.

use super::texture::Texture;
use crate::math::Rgb;

/// Index of a [`Material`] in [`crate::scene::Scene::materials`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaterialId(pub u32);

/// Microfacet normal distribution of a rough conductor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    /// Beckmann–Spizzichino.
    Beckmann,
    /// GGX / Trowbridge–Reitz.
    Ggx,
}

/// Fresnel term of a conductor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConductorFresnel {
    /// Complex index of refraction `eta + i·k` per channel (relative to the
    /// exterior medium).
    Complex {
        /// Real part.
        eta: Rgb,
        /// Imaginary part (absorption).
        k: Rgb,
    },
    /// F = 1: Mitsuba's `material="none"`, an ideal mirror.
    Perfect,
}

/// A surface's scattering model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MaterialKind {
    /// Lambertian reflection.
    Diffuse {
        /// Albedo in [0, 1] per channel.
        reflectance: Texture,
    },
    /// Smooth conductor (Dirac delta reflection).
    Conductor {
        /// Fresnel model.
        fresnel: ConductorFresnel,
        /// Multiplier of the reflected radiance.
        specular_reflectance: Texture,
    },
    /// Rough conductor: microfacet reflection with Smith shadowing.
    RoughConductor {
        /// Normal distribution.
        distribution: Distribution,
        /// Isotropic roughness α (> 0).
        alpha: f32,
        /// Fresnel model.
        fresnel: ConductorFresnel,
        /// Multiplier of the reflected radiance.
        specular_reflectance: Texture,
    },
    /// Smooth dielectric interface (Dirac delta reflection and refraction).
    Dielectric {
        /// Relative index of refraction, interior over exterior (> 0).
        eta: f32,
    },
    /// Rough dielectric interface (Mitsuba's `roughdielectric`): microfacet
    /// reflection and refraction (Walter et al. 2007).
    RoughDielectric {
        /// Normal distribution.
        distribution: Distribution,
        /// Isotropic roughness α (> 0).
        alpha: f32,
        /// Relative index of refraction, interior over exterior (> 0, ≠ 1).
        eta: f32,
        /// Multiplier of the reflected lobe.
        specular_reflectance: Texture,
        /// Multiplier of the refracted lobe.
        specular_transmittance: Texture,
    },
}

/// A material: its scattering model and whether both sides scatter alike.
///
/// One-sided opaque materials are black seen from behind the shading normal,
/// as in Mitsuba; `two_sided` is Mitsuba's `twosided` wrapper. Dielectrics
/// are always one interface with an inside and an outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Scattering model.
    pub kind: MaterialKind,
    /// Scatter identically from both sides.
    pub two_sided: bool,
}

impl Material {
    /// A two-sided Lambertian material with constant albedo.
    pub const fn diffuse(albedo: Rgb) -> Self {
        Material {
            kind: MaterialKind::Diffuse {
                reflectance: Texture::Constant(albedo),
            },
            two_sided: true,
        }
    }

    /// True when every lobe of the material is a Dirac delta, so that no
    /// connection (light sample or BDPT edge) can ever end on it.
    pub fn is_delta(&self) -> bool {
        matches!(
            self.kind,
            MaterialKind::Conductor { .. } | MaterialKind::Dielectric { .. }
        )
    }

    /// Checks the parameters a host may hand in; returns what is wrong.
    pub fn validate(&self) -> Result<(), &'static str> {
        fn tex_ok(t: &Texture) -> bool {
            match t {
                Texture::Constant(c) => c.is_finite() && c.r >= 0.0 && c.g >= 0.0 && c.b >= 0.0,
                Texture::Bitmap { to_uv, .. } => to_uv.is_finite(),
                Texture::Checkerboard {
                    color0,
                    color1,
                    to_uv,
                } => {
                    // Non-negative like a constant: a negative albedo made
                    // negative contributions (issue 7's host-input cases).
                    let ok = |c: &Rgb| c.is_finite() && c.r >= 0.0 && c.g >= 0.0 && c.b >= 0.0;
                    ok(color0) && ok(color1) && to_uv.is_finite()
                }
            }
        }
        fn fresnel_ok(f: &ConductorFresnel) -> bool {
            match f {
                ConductorFresnel::Complex { eta, k } => eta.is_finite() && k.is_finite(),
                ConductorFresnel::Perfect => true,
            }
        }
        match &self.kind {
            MaterialKind::Diffuse { reflectance } => tex_ok(reflectance)
                .then_some(())
                .ok_or("diffuse reflectance must be finite and non-negative"),
            MaterialKind::Conductor {
                fresnel,
                specular_reflectance,
            } => (fresnel_ok(fresnel) && tex_ok(specular_reflectance))
                .then_some(())
                .ok_or("conductor parameters must be finite and non-negative"),
            MaterialKind::RoughConductor {
                alpha,
                fresnel,
                specular_reflectance,
                ..
            } => {
                if !(alpha.is_finite() && *alpha > 0.0) {
                    return Err("roughconductor alpha must be finite and > 0");
                }
                (fresnel_ok(fresnel) && tex_ok(specular_reflectance))
                    .then_some(())
                    .ok_or("roughconductor parameters must be finite and non-negative")
            }
            MaterialKind::Dielectric { eta } => (eta.is_finite() && *eta > 0.0)
                .then_some(())
                .ok_or("dielectric eta must be finite and > 0"),
            MaterialKind::RoughDielectric {
                alpha,
                eta,
                specular_reflectance,
                specular_transmittance,
                ..
            } => {
                if !(alpha.is_finite() && *alpha > 0.0) {
                    return Err("roughdielectric alpha must be finite and > 0");
                }
                // Index-matched, the refraction half vector wo + η wi
                // vanishes for the straight-through direction (Mitsuba
                // refuses it too).
                if !(eta.is_finite() && *eta > 0.0 && *eta != 1.0) {
                    return Err("roughdielectric eta must be finite, > 0 and != 1");
                }
                (tex_ok(specular_reflectance) && tex_ok(specular_transmittance))
                    .then_some(())
                    .ok_or("roughdielectric reflectance and transmittance must be finite and non-negative")
            }
        }
    }
}
