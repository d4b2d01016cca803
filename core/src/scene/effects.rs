//! Scene analysis: which light-transport effects a scene can call for,
//! derived once from its materials, emitters and camera, and what the
//! renderer can therefore leave out (the caustic perturbation without
//! specular chains, lens sampling for a pinhole, depth for a scene whose
//! surfaces do not scatter).
//!
//! Only materials some mesh uses count: a material that is defined but
//! never referenced calls for nothing.

use core::fmt;

use super::material::{Material, MaterialKind};
use super::texture::Texture;

/// One effect a scene may need.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Effect {
    /// Lambertian reflection.
    Diffuse = 0,
    /// Rough (microfacet) reflection.
    Glossy = 1,
    /// Smooth mirror reflection (Dirac lobes).
    SpecularReflection = 2,
    /// Smooth dielectric reflection and refraction (Dirac lobes).
    Refraction = 3,
    /// Spatially varying reflectance (bitmap or procedural textures).
    Textures = 4,
    /// Emitting surfaces.
    AreaLights = 5,
    /// A thin-lens camera (an aperture to sample).
    DepthOfField = 6,
    /// Normal or bump maps (a perturbed shading frame).
    NormalMapping = 7,
    /// Alpha masks (stochastically transparent surfaces).
    AlphaMasks = 8,
    /// Plastics: a dielectric coating over a diffuse base.
    Coating = 9,
    /// Rough dielectric reflection and refraction (microfacet lobes).
    RoughRefraction = 10,
    /// Point, spot and directional lights (delta positions or directions).
    PointLights = 11,
    /// An environment around the scene (constant or an environment map).
    Environment = 12,
    /// Mitsuba 3's principled BSDF.
    Principled = 13,
    /// Rough diffuse (Oren–Nayar) reflection.
    RoughDiffuse = 14,
    /// Participating media and null (index-matched) boundaries.
    Media = 15,
}

impl Effect {
    /// Every effect, in bit order.
    pub const ALL: [Effect; 16] = [
        Effect::Diffuse,
        Effect::Glossy,
        Effect::SpecularReflection,
        Effect::Refraction,
        Effect::Textures,
        Effect::AreaLights,
        Effect::DepthOfField,
        Effect::NormalMapping,
        Effect::AlphaMasks,
        Effect::Coating,
        Effect::RoughRefraction,
        Effect::PointLights,
        Effect::Environment,
        Effect::Principled,
        Effect::RoughDiffuse,
        Effect::Media,
    ];

    /// A short lower-case name (`"specular-reflection"` …).
    pub fn name(self) -> &'static str {
        match self {
            Effect::Diffuse => "diffuse",
            Effect::Glossy => "glossy",
            Effect::SpecularReflection => "specular-reflection",
            Effect::Refraction => "refraction",
            Effect::Textures => "textures",
            Effect::AreaLights => "area-lights",
            Effect::DepthOfField => "depth-of-field",
            Effect::NormalMapping => "normal-mapping",
            Effect::AlphaMasks => "alpha-masks",
            Effect::Coating => "coating",
            Effect::RoughRefraction => "rough-refraction",
            Effect::PointLights => "point-lights",
            Effect::Environment => "environment",
            Effect::Principled => "principled",
            Effect::RoughDiffuse => "rough-diffuse",
            Effect::Media => "media",
        }
    }

    /// The cargo feature of the core that builds this effect's code
    /// (`None` for diffuse reflection and area lights, always built).
    pub fn feature(self) -> Option<&'static str> {
        match self {
            Effect::Glossy => Some("glossy"),
            Effect::SpecularReflection => Some("specular"),
            Effect::Refraction => Some("refraction"),
            Effect::Textures => Some("textures"),
            Effect::DepthOfField => Some("depth-of-field"),
            Effect::NormalMapping => Some("normal-mapping"),
            Effect::AlphaMasks => Some("alpha-masks"),
            Effect::Coating => Some("coating"),
            Effect::RoughRefraction => Some("rough-refraction"),
            Effect::PointLights => Some("delta-lights"),
            Effect::Environment => Some("environment"),
            Effect::Principled => Some("principled"),
            Effect::RoughDiffuse => Some("rough-diffuse"),
            Effect::Media => Some("media"),
            Effect::Diffuse | Effect::AreaLights => None,
        }
    }

    /// Whether this build of the core can simulate the effect (its
    /// [`Effect::feature`] is on).
    pub fn is_built(self) -> bool {
        match self {
            Effect::Glossy => cfg!(feature = "glossy"),
            Effect::SpecularReflection => cfg!(feature = "specular"),
            Effect::Refraction => cfg!(feature = "refraction"),
            Effect::Textures => cfg!(feature = "textures"),
            Effect::DepthOfField => cfg!(feature = "depth-of-field"),
            Effect::NormalMapping => cfg!(feature = "normal-mapping"),
            Effect::AlphaMasks => cfg!(feature = "alpha-masks"),
            Effect::Coating => cfg!(feature = "coating"),
            Effect::RoughRefraction => cfg!(feature = "rough-refraction"),
            Effect::PointLights => cfg!(feature = "delta-lights"),
            Effect::Environment => cfg!(feature = "environment"),
            Effect::Principled => cfg!(feature = "principled"),
            Effect::RoughDiffuse => cfg!(feature = "rough-diffuse"),
            Effect::Media => cfg!(feature = "media"),
            Effect::Diffuse | Effect::AreaLights => true,
        }
    }

    /// Why a scene does not need this effect.
    fn absent_because(self) -> &'static str {
        match self {
            Effect::Diffuse => "no diffuse material",
            Effect::Glossy => "no rough conductor",
            Effect::SpecularReflection => "no smooth conductor",
            Effect::Refraction => "no dielectric",
            Effect::Textures => "constant colours only",
            Effect::AreaLights => "no emitting mesh",
            Effect::DepthOfField => "pinhole camera: no lens sampling",
            Effect::NormalMapping => "no normal or bump map",
            Effect::AlphaMasks => "no alpha mask: plain closest-hit and any-hit rays",
            Effect::Coating => "no plastic",
            Effect::RoughRefraction => "no rough dielectric",
            Effect::PointLights => "no point, spot or directional light",
            Effect::Environment => "no environment: escaping rays carry nothing",
            Effect::Principled => "no principled material",
            Effect::RoughDiffuse => "no rough diffuse material",
            Effect::Media => "no medium or null boundary: rays run from surface to surface",
        }
    }
}

/// A set of [`Effect`]s (bit `e as u32` for effect `e`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EffectSet(pub u32);

impl EffectSet {
    /// No effect.
    pub const NONE: EffectSet = EffectSet(0);
    /// Every effect.
    pub const ALL: EffectSet = EffectSet((1 << Effect::ALL.len()) - 1);

    /// Whether `e` is in the set.
    pub fn contains(self, e: Effect) -> bool {
        self.0 >> e as u32 & 1 != 0
    }

    /// The set with `e` added.
    pub fn with(self, e: Effect) -> EffectSet {
        EffectSet(self.0 | 1 << e as u32)
    }

    /// The effects in the set, in bit order.
    pub fn iter(self) -> impl Iterator<Item = Effect> {
        Effect::ALL.into_iter().filter(move |&e| self.contains(e))
    }

    /// The effects this build of the core can simulate
    /// ([`Effect::is_built`]).
    pub fn built() -> EffectSet {
        Effect::ALL
            .into_iter()
            .filter(|e| e.is_built())
            .fold(EffectSet::NONE, EffectSet::with)
    }
}

/// What a scene calls for, and what follows for the renderer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Analysis {
    /// The effects present.
    pub effects: EffectSet,
    /// Specular chains can occur (a smooth conductor or dielectric is
    /// used): only then can the caustic perturbation apply, or the lens
    /// perturbation cross specular vertices.
    pub specular_chains: bool,
    /// No surface scatters light (every used material is black or there
    /// are none): paths longer than one segment carry nothing.
    pub emitters_only: bool,
}

impl Analysis {
    /// Analyses the materials used by meshes (`used(i)` says whether
    /// material `i` is referenced), whether any mesh emits, and the camera's
    /// aperture.
    pub fn of(
        materials: &[Material],
        used: impl Fn(usize) -> bool,
        has_emitters: bool,
        aperture_radius: f32,
    ) -> Self {
        let mut effects = EffectSet::NONE;
        let mut scatters = false;
        for (i, m) in materials.iter().enumerate() {
            if !used(i) {
                continue;
            }
            let (effect, textures) = match &m.kind {
                MaterialKind::Diffuse { reflectance } => {
                    (Effect::Diffuse, [Some(reflectance), None])
                }
                MaterialKind::RoughDiffuse { reflectance, .. } => {
                    (Effect::RoughDiffuse, [Some(reflectance), None])
                }
                MaterialKind::RoughConductor {
                    specular_reflectance,
                    ..
                } => (Effect::Glossy, [Some(specular_reflectance), None]),
                MaterialKind::Conductor {
                    specular_reflectance,
                    ..
                } => (
                    Effect::SpecularReflection,
                    [Some(specular_reflectance), None],
                ),
                MaterialKind::Dielectric { .. } => (Effect::Refraction, [None, None]),
                MaterialKind::TintedDielectric {
                    specular_reflectance,
                    specular_transmittance,
                    ..
                }
                | MaterialKind::ThinDielectric {
                    specular_reflectance,
                    specular_transmittance,
                    ..
                } => (
                    Effect::Refraction,
                    [Some(specular_reflectance), Some(specular_transmittance)],
                ),
                MaterialKind::Plastic {
                    diffuse_reflectance,
                    specular_reflectance,
                    ..
                }
                | MaterialKind::RoughPlastic {
                    diffuse_reflectance,
                    specular_reflectance,
                    ..
                } => (
                    Effect::Coating,
                    [Some(diffuse_reflectance), Some(specular_reflectance)],
                ),
                MaterialKind::RoughDielectric {
                    specular_reflectance,
                    specular_transmittance,
                    ..
                } => (
                    Effect::RoughRefraction,
                    [Some(specular_reflectance), Some(specular_transmittance)],
                ),
                // Its many textures are visited below.
                MaterialKind::Principled(_) => (Effect::Principled, [None, None]),
                MaterialKind::Null => (Effect::Media, [None, None]),
            };
            effects = effects.with(effect);
            let principled = match &m.kind {
                MaterialKind::Principled(p) => Some(p.textures()),
                _ => None,
            };
            for t in textures
                .into_iter()
                .flatten()
                .chain(principled.into_iter().flatten())
            {
                match t {
                    Texture::Constant(c) => scatters |= c.r > 0.0 || c.g > 0.0 || c.b > 0.0,
                    _ => {
                        effects = effects.with(Effect::Textures);
                        scatters = true;
                    }
                }
            }
            // Surface detail: its own effects, and textures when it varies.
            if m.detail.perturbs_frame() {
                effects = effects.with(Effect::NormalMapping);
            }
            if m.detail.opacity.is_some() {
                effects = effects.with(Effect::AlphaMasks);
            }
            if m.detail.textures().any(|t| !t.is_constant()) {
                effects = effects.with(Effect::Textures);
            }
            // A dielectric always scatters (it reflects and transmits); the
            // tinted and thin ones and plastics are counted as scattering
            // too, which only keeps paths that may carry nothing.
            scatters |= matches!(
                m.kind,
                MaterialKind::Dielectric { .. }
                    | MaterialKind::TintedDielectric { .. }
                    | MaterialKind::ThinDielectric { .. }
                    | MaterialKind::RoughDielectric { .. }
                    | MaterialKind::Plastic { .. }
                    | MaterialKind::RoughPlastic { .. }
                    | MaterialKind::Principled(_)
            );
        }
        if has_emitters {
            effects = effects.with(Effect::AreaLights);
        }
        if aperture_radius > 0.0 {
            effects = effects.with(Effect::DepthOfField);
        }
        Analysis {
            specular_chains: effects.contains(Effect::SpecularReflection)
                || effects.contains(Effect::Refraction),
            emitters_only: !scatters,
            effects,
        }
    }

    /// The first effect the scene needs that this build left out (see
    /// [`Effect::feature`]): such a scene must be rejected, never rendered.
    pub fn unbuilt(&self) -> Option<Effect> {
        self.effects.iter().find(|e| !e.is_built())
    }

    /// The analysis of a scene that needs everything (`--all-effects`).
    pub fn all() -> Self {
        Analysis {
            effects: EffectSet::ALL,
            specular_chains: true,
            emitters_only: false,
        }
    }

    /// A readable report: the effects in use, then each thing switched off
    /// with its reason.
    pub fn report(&self) -> Report<'_> {
        Report(self)
    }
}

/// [`Analysis::report`]'s text.
pub struct Report<'a>(&'a Analysis);

impl fmt::Display for Report<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = self.0;
        f.write_str("effects:")?;
        for e in a.effects.iter() {
            write!(f, " {}", e.name())?;
        }
        if a.effects == EffectSet::NONE {
            f.write_str(" none")?;
        }
        for e in Effect::ALL.into_iter().filter(|&e| !a.effects.contains(e)) {
            write!(f, "; off: {} ({})", e.name(), e.absent_because())?;
        }
        if !a.specular_chains {
            f.write_str("; off: caustic perturbation (no specular chains)")?;
        }
        if a.emitters_only {
            f.write_str("; off: paths beyond one segment (no surface scatters)")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rgb;

    fn diffuse(c: f32) -> Material {
        Material::diffuse(Rgb::splat(c))
    }

    #[test]
    fn only_used_materials_count() {
        let glass = Material {
            kind: MaterialKind::Dielectric { eta: 1.5 },
            two_sided: false,
            detail: Default::default(),
        };
        let a = Analysis::of(&[diffuse(0.5), glass], |i| i == 0, true, 0.0);
        assert_eq!(
            a.effects,
            EffectSet::NONE
                .with(Effect::Diffuse)
                .with(Effect::AreaLights)
        );
        assert!(!a.specular_chains && !a.emitters_only);
        let b = Analysis::of(&[diffuse(0.5), glass], |_| true, true, 0.0);
        assert!(b.effects.contains(Effect::Refraction) && b.specular_chains);
    }

    #[test]
    fn black_surfaces_leave_emitters_only_and_a_lens_is_depth_of_field() {
        let a = Analysis::of(&[diffuse(0.0)], |_| true, true, 0.1);
        assert!(a.emitters_only);
        assert!(a.effects.contains(Effect::DepthOfField));
        let text = a.report().to_string();
        assert!(
            text.contains("paths beyond one segment") && text.contains("caustic perturbation"),
            "{text}"
        );
        let none = Analysis::of(&[], |_| true, false, 0.0);
        assert_eq!(none.effects, EffectSet::NONE);
        assert!(none.report().to_string().starts_with("effects: none"));
        assert_eq!(Analysis::all().effects.iter().count(), Effect::ALL.len());
    }
}
