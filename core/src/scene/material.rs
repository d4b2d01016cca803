//! Materials as the scene describes them, before textures are evaluated.
//!
//! A [`Material`] is resolved at a hit point into a [`Bsdf`] with plain
//! colours ([`Material::bsdf`]); the BSDF code never sees textures. The
//! parameter types of the models a material holds ([`ConductorFresnel`],
//! [`Distribution`], [`RoughCoating`]) are the BSDF module's, re-exported
//! by the scene.

use super::detail::Detail;
use super::texture::Texture;
use crate::bsdf::Bsdf;
#[cfg(feature = "principled")]
use crate::bsdf::PrincipledValues;
use crate::bsdf::conductor::ConductorFresnel;
use crate::bsdf::microfacet::Distribution;
use crate::bsdf::roughplastic::RoughCoating;
use crate::math::Rgb;

/// Index of a [`Material`] in [`crate::scene::Scene::materials`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaterialId(pub u32);

/// A surface's scattering model.
// The principled variant carries eleven textures. A material is stored once
// in the scene and read by reference at each hit (only the resolved `Bsdf`
// travels with a path), and `no_std` builds have no `Box`.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MaterialKind {
    /// Lambertian reflection.
    Diffuse {
        /// Albedo in [0, 1] per channel.
        reflectance: Texture,
    },
    /// Rough diffuse reflection (Mitsuba 0.6's `roughdiffuse`): the
    /// Oren–Nayar model of diffuse facets in V-grooves.
    RoughDiffuse {
        /// Albedo ρ of the facets in [0, 1] per channel.
        reflectance: Texture,
        /// Mitsuba's RMS facet slope α in [0, 1e4] (Oren–Nayar's σ is
        /// α/√2); 0 is Lambertian.
        alpha: f32,
        /// Mitsuba's `useFastApprox`: the simplified single-scattering
        /// model instead of the full one with interreflections.
        fast_approx: bool,
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
    /// Smooth dielectric whose reflected and transmitted light are tinted
    /// (Mitsuba's `dielectric` with `specular_reflectance` or
    /// `specular_transmittance` other than 1); the same Dirac lobes, chosen
    /// with the same Fresnel probabilities, weighted by the tints.
    TintedDielectric {
        /// Relative index of refraction, interior over exterior (> 0).
        eta: f32,
        /// Multiplier of the reflected light.
        specular_reflectance: Texture,
        /// Multiplier of the transmitted light.
        specular_transmittance: Texture,
    },
    /// Infinitely thin dielectric slab (Mitsuba's `thindielectric`, a
    /// window pane): Dirac reflection with the slab's total reflectance
    /// R' = R + T²R/(1 − R²) and straight, unbent transmission 1 − R'.
    ThinDielectric {
        /// Relative index of refraction of the slab over its surroundings
        /// (> 0).
        eta: f32,
        /// Multiplier of the reflected light.
        specular_reflectance: Texture,
        /// Multiplier of the transmitted light.
        specular_transmittance: Texture,
    },
    /// Smooth plastic (Mitsuba's `plastic`): a smooth dielectric coating
    /// (Dirac reflection) over a Lambertian base that light reaches and
    /// leaves through the interface, with internal reflections accounted
    /// for in closed form.
    Plastic {
        /// Relative index of refraction of the coating, interior over
        /// exterior (> 0).
        eta: f32,
        /// Albedo of the base in [0, 1].
        diffuse_reflectance: Texture,
        /// Multiplier of the coating's reflection.
        specular_reflectance: Texture,
        /// Mitsuba's `nonlinear`: internal reflections tint the base
        /// (colours get more saturated) instead of just brightening it.
        nonlinear: bool,
    },
    /// Rough plastic (Mitsuba's `roughplastic`): a microfacet coating over
    /// a Lambertian base, the base's light scaled by the coating's
    /// precomputed rough transmittance.
    RoughPlastic {
        /// Microfacet distribution of the coating.
        distribution: Distribution,
        /// Isotropic roughness α (> 0).
        alpha: f32,
        /// Relative index of refraction, interior over exterior (> 0, ≠ 1).
        eta: f32,
        /// Albedo of the base in [0, 1].
        diffuse_reflectance: Texture,
        /// Multiplier of the coating's reflection.
        specular_reflectance: Texture,
        /// Mitsuba's `nonlinear` (see [`MaterialKind::Plastic`]).
        nonlinear: bool,
        /// The coating's transmittance and internal reflectance, computed
        /// once from (distribution, α, η) by [`RoughCoating::new`].
        coating: RoughCoating,
    },
    /// Mitsuba 3's `principled`: Burley's metallic-roughness model (diffuse
    /// with retro-reflection, sheen, anisotropic GGX reflection and
    /// transmission, a GTR1 clearcoat).
    Principled(PrincipledParams),
    /// Mitsuba's `null` BSDF: an index-matched boundary that only changes
    /// the medium a ray is in (see [`crate::scene::medium`]); rays pass it
    /// unchanged and it never scatters. Needs the `media` effect.
    Null,
}

/// The parameters of [`MaterialKind::Principled`], named as Mitsuba 3 names
/// them. Every one but `eta` may vary over the surface; the scalar ones read
/// a texture as [`Texture::eval_1`] does (its luminance).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrincipledParams {
    /// Base colour in [0, 1] per channel.
    pub base_color: Texture,
    /// Perceptual roughness in [0, 1] (GGX α = roughness²).
    pub roughness: Texture,
    /// Anisotropy in [0, 1].
    pub anisotropic: Texture,
    /// Metallic blend in [0, 1].
    pub metallic: Texture,
    /// Transmission blend in [0, 1].
    pub spec_trans: Texture,
    /// Tint of the dielectric specular towards the base colour, in [0, 1].
    pub spec_tint: Texture,
    /// Sheen weight in [0, 1].
    pub sheen: Texture,
    /// Tint of the sheen towards the base colour, in [0, 1].
    pub sheen_tint: Texture,
    /// Clearcoat weight in [0, 1].
    pub clearcoat: Texture,
    /// Clearcoat glossiness in [0, 1].
    pub clearcoat_gloss: Texture,
    /// Blend of the diffuse lobe towards fake subsurface, in [0, 1].
    pub flatness: Texture,
    /// Relative index of refraction, interior over exterior (> 0; ≠ 1 when
    /// `spec_trans` is not zero). Mitsuba's `specular` s stands for
    /// η = 2/(1 − √(0.08 s)) − 1.
    pub eta: f32,
}

impl PrincipledParams {
    /// Mitsuba 3's defaults: base colour 0.5, roughness 0.5, specular 0.5
    /// (η ≈ 1.5), everything else 0.
    pub const DEFAULT: PrincipledParams = {
        let zero = Texture::Constant(Rgb::splat(0.0));
        let half = Texture::Constant(Rgb::splat(0.5));
        PrincipledParams {
            base_color: half,
            roughness: half,
            anisotropic: zero,
            metallic: zero,
            spec_trans: zero,
            spec_tint: zero,
            sheen: zero,
            sheen_tint: zero,
            clearcoat: zero,
            clearcoat_gloss: zero,
            flatness: zero,
            eta: 1.5,
        }
    };

    /// The relative index Mitsuba derives from `specular` (Burley 2015:
    /// specular 0.5 is F0 = 0.04, η = 1.5).
    pub fn eta_from_specular(specular: f32) -> f32 {
        2.0 / (1.0 - libm::sqrtf(0.08 * specular)) - 1.0
    }

    /// The scalar parameters with their names, in declaration order.
    pub fn scalars(&self) -> [(&'static str, &Texture); 10] {
        [
            ("roughness", &self.roughness),
            ("anisotropic", &self.anisotropic),
            ("metallic", &self.metallic),
            ("spec_trans", &self.spec_trans),
            ("spec_tint", &self.spec_tint),
            ("sheen", &self.sheen),
            ("sheen_tint", &self.sheen_tint),
            ("clearcoat", &self.clearcoat),
            ("clearcoat_gloss", &self.clearcoat_gloss),
            ("flatness", &self.flatness),
        ]
    }

    /// Every texture of the material, mutably (base colour first, then the
    /// scalars in [`PrincipledParams::scalars`]' order).
    pub fn textures_mut(&mut self) -> [&mut Texture; 11] {
        [
            &mut self.base_color,
            &mut self.roughness,
            &mut self.anisotropic,
            &mut self.metallic,
            &mut self.spec_trans,
            &mut self.spec_tint,
            &mut self.sheen,
            &mut self.sheen_tint,
            &mut self.clearcoat,
            &mut self.clearcoat_gloss,
            &mut self.flatness,
        ]
    }

    /// Every texture of the material (base colour first).
    pub fn textures(&self) -> impl Iterator<Item = &Texture> {
        core::iter::once(&self.base_color).chain(self.scalars().into_iter().map(|(_, t)| t))
    }

    /// Checks the parameters: a colour in [0, 1], every constant scalar
    /// (and both colours of a checkerboard, as luminances) in [0, 1], η
    /// finite, > 0 and ≠ 1 when transmitting.
    pub fn validate(&self) -> Result<(), &'static str> {
        fn in_unit(c: &Rgb) -> bool {
            let ok = |x: f32| (0.0..=1.0).contains(&x);
            ok(c.r) && ok(c.g) && ok(c.b)
        }
        fn colours(t: &Texture) -> (Option<&Rgb>, Option<&Rgb>) {
            match t {
                Texture::Constant(c) => (Some(c), None),
                Texture::Checkerboard { color0, color1, .. } => (Some(color0), Some(color1)),
                // A grid's range is checked against its voxels when the
                // scene is built (`SceneBuilder::build`).
                Texture::Bitmap { .. } | Texture::Grid(_) => (None, None),
            }
        }
        let (a, b) = colours(&self.base_color);
        if !a.into_iter().chain(b).all(in_unit) {
            return Err("principled base_color must be in [0, 1]");
        }
        for (_, t) in self.scalars() {
            if let Texture::Bitmap { to_uv, .. } | Texture::Checkerboard { to_uv, .. } = t
                && !to_uv.is_finite()
            {
                return Err("principled texture transforms must be finite");
            }
            let (a, b) = colours(t);
            if !a
                .into_iter()
                .chain(b)
                .all(|c| c.is_finite() && (0.0..=1.0).contains(&c.luminance()))
            {
                return Err("principled scalar parameters must be in [0, 1]");
            }
        }
        if let Texture::Bitmap { to_uv, .. } | Texture::Checkerboard { to_uv, .. } =
            &self.base_color
            && !to_uv.is_finite()
        {
            return Err("principled texture transforms must be finite");
        }
        let transmits = self.spec_trans != Texture::Constant(Rgb::ZERO);
        if !(self.eta.is_finite() && self.eta > 0.0 && !(transmits && self.eta == 1.0)) {
            return Err("principled eta must be finite, > 0 and != 1 with spec_trans");
        }
        Ok(())
    }
}

/// Largest microfacet roughness α accepted (rough conductor, plastic and
/// dielectric; Mitsuba's `roughdiffuse` α too). Mitsuba accepts α > 1
/// ("extremely rough"; single scattering then loses most of the energy);
/// beyond 1e4, α² and the distributions' normalisations leave f32's
/// comfortable range.
pub const MAX_ROUGHNESS: f32 = 1e4;

/// Whether `alpha` is a valid microfacet roughness: finite, in
/// (0, [`MAX_ROUGHNESS`]] (0 is a smooth surface: its own, Dirac model).
pub fn roughness_ok(alpha: f32) -> bool {
    alpha > 0.0 && alpha <= MAX_ROUGHNESS
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
    /// Normal map, bump map and alpha mask ([`Detail::NONE`]: none).
    pub detail: Detail,
}

impl Material {
    /// A two-sided Lambertian material with constant albedo.
    pub const fn diffuse(albedo: Rgb) -> Self {
        Material {
            kind: MaterialKind::Diffuse {
                reflectance: Texture::Constant(albedo),
            },
            two_sided: true,
            detail: Detail::NONE,
        }
    }

    /// True when every lobe of the material is a Dirac delta, so that no
    /// connection (light sample or BDPT edge) can ever end on it.
    pub fn is_delta(&self) -> bool {
        matches!(
            self.kind,
            MaterialKind::Conductor { .. }
                | MaterialKind::Dielectric { .. }
                | MaterialKind::TintedDielectric { .. }
                | MaterialKind::ThinDielectric { .. }
        )
    }

    /// True for a principled material with anisotropy (not the constant 0):
    /// its shading frame must follow ∂p/∂u.
    #[inline]
    pub fn is_anisotropic(&self) -> bool {
        matches!(&self.kind, MaterialKind::Principled(p)
            if p.anisotropic != Texture::Constant(Rgb::ZERO))
    }

    /// Resolves the material at one point: its [`Bsdf`], with `texture`
    /// evaluating a texture there (the caller supplies the point and the
    /// bitmaps, so the BSDF code needs neither).
    ///
    /// A model left out of the build (see [`crate::bsdf`]) resolves to
    /// black diffuse.
    // Forced: with the plain hint the compiler kept it out of line and
    // every shading point paid a call and a copy of the `Bsdf`.
    #[inline(always)]
    pub fn bsdf(&self, texture: impl Fn(&Texture) -> Rgb) -> Bsdf {
        // The models of the shared scenes (diffuse, conductors, the clear
        // dielectric) are built inline, so that the caller writes the
        // `Bsdf` in place (an out-of-line constructor returns it through
        // memory and the caller copies it on); the rest out of line
        // (`bsdf_other`), as in `Bsdf::eval` and `Bsdf::sample`.
        #[allow(unreachable_patterns)]
        match &self.kind {
            MaterialKind::Diffuse { reflectance } => {
                Bsdf::diffuse(texture(reflectance), self.two_sided)
            }
            #[cfg(feature = "specular")]
            MaterialKind::Conductor {
                fresnel,
                specular_reflectance,
            } => Bsdf::conductor(*fresnel, texture(specular_reflectance), self.two_sided),
            #[cfg(feature = "glossy")]
            MaterialKind::RoughConductor {
                distribution,
                alpha,
                fresnel,
                specular_reflectance,
            } => Bsdf::rough_conductor(
                *distribution,
                *alpha,
                *fresnel,
                texture(specular_reflectance),
                self.two_sided,
            ),
            #[cfg(feature = "refraction")]
            MaterialKind::Dielectric { eta } => Bsdf::dielectric(*eta, (Rgb::ONE, Rgb::ONE)),
            _ => self.bsdf_other(texture),
        }
    }

    /// [`Material::bsdf`] of the models it does not build inline.
    #[inline(never)]
    #[allow(unused_variables)]
    fn bsdf_other(&self, texture: impl Fn(&Texture) -> Rgb) -> Bsdf {
        // The fallback arm: a model left out of the build, and the null
        // material, which no estimator shades (the path tracer's and
        // BDPT's walks and transmittance queries pass it by, and so do
        // the path-space mutations' walks).
        #[allow(unreachable_patterns)]
        match &self.kind {
            #[cfg(feature = "refraction")]
            MaterialKind::TintedDielectric {
                eta,
                specular_reflectance,
                specular_transmittance,
            } => Bsdf::dielectric(
                *eta,
                (
                    texture(specular_reflectance),
                    texture(specular_transmittance),
                ),
            ),
            #[cfg(feature = "refraction")]
            MaterialKind::ThinDielectric {
                eta,
                specular_reflectance,
                specular_transmittance,
            } => Bsdf::thin_dielectric(
                *eta,
                (
                    texture(specular_reflectance),
                    texture(specular_transmittance),
                ),
            ),
            #[cfg(feature = "coating")]
            MaterialKind::Plastic {
                eta,
                diffuse_reflectance,
                specular_reflectance,
                nonlinear,
            } => Bsdf::plastic(
                *eta,
                (texture(diffuse_reflectance), texture(specular_reflectance)),
                *nonlinear,
                self.two_sided,
            ),
            #[cfg(feature = "coating")]
            MaterialKind::RoughPlastic {
                distribution,
                alpha,
                eta,
                diffuse_reflectance,
                specular_reflectance,
                nonlinear,
                coating,
            } => Bsdf::rough_plastic(
                *distribution,
                *alpha,
                *eta,
                coating,
                (texture(diffuse_reflectance), texture(specular_reflectance)),
                *nonlinear,
                self.two_sided,
            ),
            #[cfg(feature = "rough-refraction")]
            MaterialKind::RoughDielectric {
                distribution,
                alpha,
                eta,
                specular_reflectance,
                specular_transmittance,
            } => Bsdf::rough_dielectric(
                *distribution,
                *alpha,
                *eta,
                (
                    texture(specular_reflectance),
                    texture(specular_transmittance),
                ),
            ),
            #[cfg(feature = "principled")]
            MaterialKind::Principled(p) => {
                // Scalars read textures as `Texture::eval_1`.
                let scalar = |t: &Texture| Texture::scalar(texture(t));
                let values = PrincipledValues {
                    base_color: texture(&p.base_color),
                    roughness: scalar(&p.roughness),
                    anisotropic: scalar(&p.anisotropic),
                    metallic: scalar(&p.metallic),
                    spec_trans: scalar(&p.spec_trans),
                    eta: p.eta,
                    spec_tint: scalar(&p.spec_tint),
                    sheen: scalar(&p.sheen),
                    sheen_tint: scalar(&p.sheen_tint),
                    clearcoat: scalar(&p.clearcoat),
                    clearcoat_gloss: scalar(&p.clearcoat_gloss),
                    flatness: scalar(&p.flatness),
                };
                Bsdf::principled(&values, self.two_sided)
            }
            #[cfg(feature = "rough-diffuse")]
            MaterialKind::RoughDiffuse {
                reflectance,
                alpha,
                fast_approx,
            } => Bsdf::rough_diffuse(texture(reflectance), *alpha, *fast_approx, self.two_sided),
            _ => Bsdf::diffuse(Rgb::ZERO, self.two_sided),
        }
    }

    /// Checks the parameters a host may hand in; returns what is wrong.
    ///
    /// The rules, the same for the C API and the scene loader (both call
    /// this): every reflectance, albedo and tint given as a constant lies
    /// in [0, 1] per channel — above 1 a surface reflects more light than
    /// it receives, so a closed scene's path throughput grows with depth
    /// and no estimator converges (Mitsuba 0.6 silently rescales such a
    /// value, Mitsuba 3 renders it; we refuse it with this message). A
    /// bitmap's texels are in [0, 1] by construction. Microfacet
    /// roughness: [`roughness_ok`]; rough diffuse α in [0, 1e4].
    pub fn validate(&self) -> Result<(), &'static str> {
        self.detail.validate()?;
        fn unit(c: &Rgb) -> bool {
            c.is_finite() && [c.r, c.g, c.b].iter().all(|v| (0.0..=1.0).contains(v))
        }
        fn tex_ok(t: &Texture) -> bool {
            match t {
                Texture::Constant(c) => unit(c),
                Texture::Bitmap { to_uv, .. } => to_uv.is_finite(),
                // Checked against its voxels when the scene is built.
                Texture::Grid(_) => true,
                Texture::Checkerboard {
                    color0,
                    color1,
                    to_uv,
                } => {
                    // In [0, 1] like a constant: a negative albedo made
                    // negative contributions.
                    unit(color0) && unit(color1) && to_uv.is_finite()
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
                .ok_or("diffuse reflectance must be finite and in [0, 1]"),
            MaterialKind::RoughDiffuse {
                reflectance, alpha, ..
            } => {
                // Beyond 1e4 σ² leaves f32's range in the model's ratios.
                if !(alpha.is_finite() && (0.0..=MAX_ROUGHNESS).contains(alpha)) {
                    return Err("roughdiffuse alpha must be finite and in [0, 1e4]");
                }
                tex_ok(reflectance)
                    .then_some(())
                    .ok_or("roughdiffuse reflectance must be finite and in [0, 1]")
            }
            MaterialKind::Conductor {
                fresnel,
                specular_reflectance,
            } => (fresnel_ok(fresnel) && tex_ok(specular_reflectance))
                .then_some(())
                .ok_or("conductor eta and k must be finite, specular_reflectance in [0, 1]"),
            MaterialKind::RoughConductor {
                alpha,
                fresnel,
                specular_reflectance,
                ..
            } => {
                if !roughness_ok(*alpha) {
                    return Err("roughconductor alpha must be in (0, 1e4]");
                }
                (fresnel_ok(fresnel) && tex_ok(specular_reflectance))
                    .then_some(())
                    .ok_or(
                        "roughconductor eta and k must be finite, specular_reflectance in [0, 1]",
                    )
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
                if !roughness_ok(*alpha) {
                    return Err("roughdielectric alpha must be in (0, 1e4]");
                }
                // Index-matched, the refraction half vector wo + η wi
                // vanishes for the straight-through direction (Mitsuba
                // refuses it too).
                if !(eta.is_finite() && *eta > 0.0 && *eta != 1.0) {
                    return Err("roughdielectric eta must be finite, > 0 and != 1");
                }
                (tex_ok(specular_reflectance) && tex_ok(specular_transmittance))
                    .then_some(())
                    .ok_or("roughdielectric reflectance and transmittance must be finite and in [0, 1]")
            }
            MaterialKind::TintedDielectric {
                eta,
                specular_reflectance,
                specular_transmittance,
            }
            | MaterialKind::ThinDielectric {
                eta,
                specular_reflectance,
                specular_transmittance,
            } => {
                if !(eta.is_finite() && *eta > 0.0) {
                    return Err("dielectric eta must be finite and > 0");
                }
                (tex_ok(specular_reflectance) && tex_ok(specular_transmittance))
                    .then_some(())
                    .ok_or("dielectric tints must be finite and in [0, 1]")
            }
            MaterialKind::Plastic {
                eta,
                diffuse_reflectance,
                specular_reflectance,
                ..
            } => {
                if !(eta.is_finite() && *eta > 0.0) {
                    return Err("plastic eta must be finite and > 0");
                }
                (tex_ok(diffuse_reflectance) && tex_ok(specular_reflectance))
                    .then_some(())
                    .ok_or("plastic reflectances must be finite and in [0, 1]")
            }
            MaterialKind::RoughPlastic {
                alpha,
                eta,
                diffuse_reflectance,
                specular_reflectance,
                coating,
                ..
            } => {
                if !roughness_ok(*alpha) {
                    return Err("roughplastic alpha must be in (0, 1e4]");
                }
                if !(eta.is_finite() && *eta > 0.0 && *eta != 1.0) {
                    return Err("roughplastic eta must be finite, > 0 and ≠ 1");
                }
                let r = coating.internal_reflectance();
                if !(r.is_finite() && (0.0..1.0).contains(&r)) {
                    return Err("roughplastic coating table is invalid");
                }
                (tex_ok(diffuse_reflectance) && tex_ok(specular_reflectance))
                    .then_some(())
                    .ok_or("roughplastic reflectances must be finite and in [0, 1]")
            }
            MaterialKind::Principled(p) => p.validate(),
            MaterialKind::Null => Ok(()),
        }
    }
}

// The material's own rules: validation, and what its `bsdf` makes of
// `two_sided`; the BSDF models are tested in `bsdf`.
#[cfg(test)]
mod tests;
