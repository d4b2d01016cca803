//! Scattering models in the local shading frame (z = shading normal).
//!
//! Conventions (shared with the integrators):
//! - `wo` points towards the viewer / previous path vertex and `wi` towards
//!   the next one; both point away from the surface and have unit length.
//! - [`Bsdf::eval`] returns f(wo, wi) *without* the cosine factor; the
//!   caller multiplies by |cos θi|. [`Bsdf::pdf`] is per unit solid angle.
//! - Dirac lobes (smooth conductor and dielectric) have `eval` = `pdf` = 0;
//!   [`Bsdf::sample`] reports them with `delta: true`, `pdf` = the discrete
//!   probability of the chosen lobe and `f` = weight·pdf/|cos θi|, so the
//!   uniform throughput update f·|cos θi|/pdf gives the lobe's weight.
//!
//! The models follow Mitsuba 3 (`diffuse`, `conductor`, `roughconductor`,
//! `dielectric`, `thindielectric`, `plastic`, `roughplastic`, `twosided`),
//! whose `scalar_rgb` renders are our references, and Mitsuba 0.6 for
//! `roughdiffuse` (Oren–Nayar), which Mitsuba 3 lacks.
//!
//! Smooth plastic is *mixed*: a Dirac lobe (the coating) beside a smooth one
//! (the base). It is not [`Bsdf::is_delta`], so connections end on it and
//! see the smooth part through `eval`/`pdf`; `sample` flags the coating
//! with `delta: true`, which path tracing (MIS of emitter hits) and BDPT
//! (the vertex's `delta`) follow, and MLT level 2 leaves paths through that
//! lobe alone (`PathVertex::mixed_delta`).
//!
//! Files: [`fresnel`] (public Fresnel equations), `microfacet`
//! (distributions, Smith masking, visible-normal sampling), and one file per
//! material model, which owns its parameter types (the conductor's Fresnel
//! term, the rough plastic's coating table: declared, computed and read
//! there).
//!
//! Like pbrt-v4's BxDFs, the models know nothing of materials or textures:
//! this module does not use the scene. A scene material evaluates its
//! textures at a hit and builds its `Bsdf` through the constructors here
//! (`Bsdf::diffuse`, `Bsdf::rough_plastic`, …); the scene re-exports the
//! parameter types its materials hold.
//!
//! Models other than the diffuse one are built with their cargo features
//! (`glossy`, `specular`, `refraction`, `coating`, `rough-refraction`,
//! `principled`, `rough-diffuse`); a build without one has no constructor
//! for it, and the material resolves to black, which never renders because
//! [`crate::scene::SceneBuilder::build`] rejects scenes that use it.

// The parameter types of the models (`ConductorFresnel`, `Distribution`,
// `RoughCoating`) are declared beside the models that read them, in modules
// built in every build: every build's materials name them (the scene
// re-exports them), even where the model itself is left out.
pub(crate) mod conductor;
#[cfg(feature = "refraction")]
mod dielectric;
mod diffuse;
pub mod fresnel;
// The principled BSDF alone uses only GGX masking of the shared
// distribution; a build without any microfacet model only its type.
#[cfg_attr(
    not(any(feature = "glossy", feature = "coating", feature = "rough-refraction")),
    allow(dead_code)
)]
pub(crate) mod microfacet;
#[cfg(feature = "coating")]
mod plastic;
#[cfg(feature = "principled")]
mod principled;
#[cfg(feature = "rough-refraction")]
mod roughdielectric;
#[cfg(feature = "rough-diffuse")]
mod roughdiffuse;
// Without `coating` only the coating table's type is used.
#[cfg_attr(not(feature = "coating"), allow(dead_code))]
pub(crate) mod roughplastic;
#[cfg(feature = "refraction")]
mod thin_dielectric;

#[cfg(feature = "principled")]
pub(crate) use principled::PrincipledValues;

// The tests exercise every model.
#[cfg(all(test, feature = "std", feature = "effects"))]
pub(crate) mod chi2;
#[cfg(all(test, feature = "std", feature = "effects"))]
mod coating_tests;
#[cfg(all(test, feature = "std", feature = "effects"))]
mod tests;

use glam::{Vec2, Vec3};

use crate::math::Rgb;
#[cfg(any(feature = "glossy", feature = "specular"))]
use conductor::ConductorFresnel;
#[cfg(any(feature = "glossy", feature = "coating", feature = "rough-refraction"))]
use microfacet::{Distribution, Microfacet};
#[cfg(feature = "coating")]
use plastic::Plastic;
#[cfg(feature = "principled")]
use principled::Principled;
#[cfg(feature = "rough-refraction")]
use roughdielectric::RoughDielectric;
#[cfg(feature = "rough-diffuse")]
use roughdiffuse::RoughDiffuse;
#[cfg(feature = "coating")]
use roughplastic::{RoughCoating, RoughPlastic};

/// Whether a path carries radiance (camera side) or importance (light side);
/// refraction scales by 1/η² only for radiance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    /// Camera subpaths.
    Radiance,
    /// Light subpaths.
    Importance,
}

/// The kind of scattering a BSDF does, one per material model: what the
/// work counters ([`crate::integrator::Stats`]) are kept by, and the
/// [`crate::scene::Effect`] that model stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Lobe {
    /// Lambertian reflection.
    Diffuse = 0,
    /// Microfacet (rough conductor) reflection.
    Glossy = 1,
    /// Smooth conductor: Dirac reflection.
    SpecularReflection = 2,
    /// Smooth dielectric: Dirac reflection and refraction (also the thin
    /// dielectric's straight transmission).
    Refraction = 3,
    /// Plastic: a dielectric coating (Dirac or microfacet) over a
    /// Lambertian base.
    Coating = 4,
    /// Rough dielectric: microfacet reflection and refraction.
    RoughRefraction = 5,
    /// Principled: diffuse, sheen, GGX reflection and refraction, GTR1
    /// clearcoat.
    Principled = 6,
    /// Rough diffuse (Oren–Nayar) reflection: diffuse-class, smooth.
    RoughDiffuse = 7,
}

impl Lobe {
    /// Every lobe kind, in index order.
    pub const ALL: [Lobe; 8] = [
        Lobe::Diffuse,
        Lobe::Glossy,
        Lobe::SpecularReflection,
        Lobe::Refraction,
        Lobe::Coating,
        Lobe::RoughRefraction,
        Lobe::Principled,
        Lobe::RoughDiffuse,
    ];

    /// A short lower-case name (the matching effect's).
    pub fn name(self) -> &'static str {
        match self {
            Lobe::Diffuse => "diffuse",
            Lobe::Glossy => "glossy",
            Lobe::SpecularReflection => "specular-reflection",
            Lobe::Refraction => "refraction",
            Lobe::Coating => "coating",
            Lobe::RoughRefraction => "rough-refraction",
            Lobe::Principled => "principled",
            Lobe::RoughDiffuse => "rough-diffuse",
        }
    }
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
    /// Relative IOR crossed (1 for reflection): η of the side `wi` points
    /// into over η of the side `wo` is on.
    pub eta: f32,
}

/// The scattering model with its textures resolved.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Model {
    Diffuse {
        albedo: Rgb,
    },
    #[cfg(feature = "specular")]
    Conductor {
        fresnel: ConductorFresnel,
        tint: Rgb,
    },
    #[cfg(feature = "glossy")]
    RoughConductor {
        mf: Microfacet,
        fresnel: ConductorFresnel,
        tint: Rgb,
    },
    #[cfg(feature = "refraction")]
    Dielectric {
        eta: f32,
        /// (reflection, transmission) tints.
        tints: (Rgb, Rgb),
    },
    #[cfg(feature = "refraction")]
    ThinDielectric {
        eta: f32,
        /// (reflection, transmission) tints.
        tints: (Rgb, Rgb),
    },
    #[cfg(feature = "coating")]
    Plastic(Plastic),
    #[cfg(feature = "coating")]
    RoughPlastic(RoughPlastic),
    #[cfg(feature = "rough-refraction")]
    RoughDielectric(RoughDielectric),
    #[cfg(feature = "principled")]
    Principled(Principled),
    #[cfg(feature = "rough-diffuse")]
    RoughDiffuse(RoughDiffuse),
}

/// A material resolved at one point (textures evaluated). Small and `Copy`;
/// no allocation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bsdf {
    model: Model,
    /// Mitsuba's `twosided`: seen from below, the opaque models are
    /// evaluated with both directions mirrored to the upper hemisphere.
    two_sided: bool,
    /// The model's kind, kept beside it (in what would be padding) so that
    /// the work counters read one byte instead of matching the model.
    lobe: Lobe,
    /// Under a normal or bump map: the surface's own shading normal in
    /// this (perturbed) frame (see [`Bsdf::with_unperturbed_normal`]);
    /// zero without one (a `Vec3`, not an `Option`, to keep `Bsdf` small).
    #[cfg(feature = "normal-mapping")]
    unperturbed: Vec3,
    /// Whether `unperturbed` is set: one byte to test per query where
    /// comparing the vector with zero costs three.
    #[cfg(feature = "normal-mapping")]
    perturbed: bool,
}

/// Mirrors a direction through the tangent plane (Mitsuba's `twosided`
/// flips only z, which keeps azimuths, unlike negating the vector).
#[inline]
fn flip_z(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, -v.z)
}

impl Bsdf {
    /// The BSDF of `model`, of kind `lobe`. Every constructor ends here.
    // Forced, as the constructors of the shared scenes' models: the caller
    // (the scene's material, resolved at every shading point) then writes
    // the `Bsdf` in place, where an out-of-line constructor returns it
    // through memory and the caller copies it on.
    #[inline(always)]
    fn from_model(model: Model, lobe: Lobe, two_sided: bool) -> Self {
        debug_assert_eq!(lobe, Self::lobe_of(&model));
        Bsdf {
            model,
            two_sided,
            lobe,
            #[cfg(feature = "normal-mapping")]
            unperturbed: Vec3::ZERO,
            #[cfg(feature = "normal-mapping")]
            perturbed: false,
        }
    }

    /// Lambertian reflection with albedo `albedo`.
    #[inline(always)]
    pub(crate) fn diffuse(albedo: Rgb, two_sided: bool) -> Self {
        Self::from_model(Model::Diffuse { albedo }, Lobe::Diffuse, two_sided)
    }

    /// A smooth conductor: Dirac reflection weighted by `fresnel` times
    /// `tint`.
    #[cfg(feature = "specular")]
    #[inline(always)]
    pub(crate) fn conductor(fresnel: ConductorFresnel, tint: Rgb, two_sided: bool) -> Self {
        Self::from_model(
            Model::Conductor { fresnel, tint },
            Lobe::SpecularReflection,
            two_sided,
        )
    }

    /// A rough conductor of roughness `alpha`, clamped to ≥ 1e-4, where the
    /// lobe is already a mirror for all practical purposes and D(m) still
    /// fits in f32.
    #[cfg(feature = "glossy")]
    #[inline(always)]
    pub(crate) fn rough_conductor(
        distribution: Distribution,
        alpha: f32,
        fresnel: ConductorFresnel,
        tint: Rgb,
        two_sided: bool,
    ) -> Self {
        Self::from_model(
            Model::RoughConductor {
                mf: Microfacet::new(distribution, alpha),
                fresnel,
                tint,
            },
            Lobe::Glossy,
            two_sided,
        )
    }

    /// A smooth dielectric interface of relative index `eta` whose
    /// (reflection, transmission) are weighted by `tints`. Never two-sided:
    /// a dielectric is one interface with an inside and an outside, and so
    /// are the other transmitting models.
    #[cfg(feature = "refraction")]
    #[inline(always)]
    pub(crate) fn dielectric(eta: f32, tints: (Rgb, Rgb)) -> Self {
        Self::from_model(Model::Dielectric { eta, tints }, Lobe::Refraction, false)
    }

    /// A thin dielectric slab of relative index `eta`, (reflection,
    /// transmission) weighted by `tints`.
    #[cfg(feature = "refraction")]
    #[inline]
    pub(crate) fn thin_dielectric(eta: f32, tints: (Rgb, Rgb)) -> Self {
        Self::from_model(
            Model::ThinDielectric { eta, tints },
            Lobe::Refraction,
            false,
        )
    }

    /// A smooth plastic: a coating of relative index `eta` over a base of
    /// albedo ρ, with `reflectances` = (ρ, the coating's tint) and
    /// Mitsuba's `nonlinear`.
    #[cfg(feature = "coating")]
    #[inline]
    pub(crate) fn plastic(
        eta: f32,
        reflectances: (Rgb, Rgb),
        nonlinear: bool,
        two_sided: bool,
    ) -> Self {
        let (rho, specular) = reflectances;
        let r_int = plastic::diffuse_fresnel(1.0 / eta);
        let model = Model::Plastic(Plastic {
            eta,
            diffuse: plastic::base_factor(rho, r_int, nonlinear, eta),
            specular,
            spec_weight: plastic::spec_weight(rho, specular),
        });
        Self::from_model(model, Lobe::Coating, two_sided)
    }

    /// A rough plastic: a microfacet coating (`distribution`, `alpha`,
    /// `eta`, whose table `coating` was computed from them) over a base,
    /// with `reflectances` and `nonlinear` as in [`Bsdf::plastic`].
    #[cfg(feature = "coating")]
    #[inline]
    pub(crate) fn rough_plastic(
        distribution: Distribution,
        alpha: f32,
        eta: f32,
        coating: &RoughCoating,
        reflectances: (Rgb, Rgb),
        nonlinear: bool,
        two_sided: bool,
    ) -> Self {
        let (rho, specular) = reflectances;
        let r_int = coating.internal_reflectance;
        let model = Model::RoughPlastic(RoughPlastic {
            mf: Microfacet::new(distribution, alpha),
            eta,
            spec_weight: plastic::spec_weight(rho, specular),
            diffuse: plastic::base_factor(rho, r_int, nonlinear, eta),
            specular,
            t: coating.transmittance,
        });
        Self::from_model(model, Lobe::Coating, two_sided)
    }

    /// A rough dielectric interface, (reflection, transmission) weighted
    /// by `tints`; never two-sided (see [`Bsdf::dielectric`]).
    #[cfg(feature = "rough-refraction")]
    #[inline]
    pub(crate) fn rough_dielectric(
        distribution: Distribution,
        alpha: f32,
        eta: f32,
        tints: (Rgb, Rgb),
    ) -> Self {
        let model = Model::RoughDielectric(RoughDielectric {
            mf: Microfacet::new(distribution, alpha),
            eta,
            reflectance: tints.0,
            transmittance: tints.1,
        });
        Self::from_model(model, Lobe::RoughRefraction, false)
    }

    /// The principled BSDF of `values`; two-sided only when nothing
    /// transmits (see [`Bsdf::dielectric`]).
    #[cfg(feature = "principled")]
    #[inline]
    pub(crate) fn principled(values: &PrincipledValues, two_sided: bool) -> Self {
        let p = Principled::new(values);
        Self::from_model(
            Model::Principled(p),
            Lobe::Principled,
            two_sided && !p.transmits(),
        )
    }

    /// Rough diffuse (Oren–Nayar) reflection with albedo `rho`, Mitsuba's
    /// roughness `alpha` and `fast_approx`.
    #[cfg(feature = "rough-diffuse")]
    #[inline]
    pub(crate) fn rough_diffuse(rho: Rgb, alpha: f32, fast_approx: bool, two_sided: bool) -> Self {
        Self::from_model(
            Model::RoughDiffuse(RoughDiffuse::new(rho, alpha, fast_approx)),
            Lobe::RoughDiffuse,
            two_sided,
        )
    }

    /// The BSDF evaluated in a frame perturbed by a normal or bump map,
    /// whose unperturbed shading normal is `n` (in the perturbed frame's
    /// coordinates): as Mitsuba 3's `normalmap`/`bumpmap`, nothing is
    /// scattered when the light-side direction (`wi` for radiance, `wo`
    /// for importance) lies on different sides of the two normals. The
    /// densities stay the nested model's (what its sampler does), so every
    /// estimator weighs the same function.
    #[cfg(feature = "normal-mapping")]
    pub fn with_unperturbed_normal(mut self, n: Vec3) -> Self {
        self.unperturbed = n;
        self.perturbed = n != Vec3::ZERO;
        self
    }

    /// Whether the light-side direction passes the perturbed frame's side
    /// test ([`Bsdf::with_unperturbed_normal`]); always without one.
    #[inline]
    #[cfg_attr(not(feature = "normal-mapping"), allow(unused_variables))]
    fn light_side_ok(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> bool {
        #[cfg(feature = "normal-mapping")]
        if self.perturbed {
            let n = self.unperturbed;
            let l = if mode == TransportMode::Radiance {
                wi
            } else {
                wo
            };
            return l.dot(n) * l.z > 0.0;
        }
        true
    }

    /// The kind of scattering of this BSDF's model.
    #[inline]
    pub fn lobe(&self) -> Lobe {
        self.lobe
    }

    /// The kind of scattering of `model`.
    #[inline]
    fn lobe_of(model: &Model) -> Lobe {
        match model {
            Model::Diffuse { .. } => Lobe::Diffuse,
            #[cfg(feature = "glossy")]
            Model::RoughConductor { .. } => Lobe::Glossy,
            #[cfg(feature = "specular")]
            Model::Conductor { .. } => Lobe::SpecularReflection,
            #[cfg(feature = "refraction")]
            Model::Dielectric { .. } | Model::ThinDielectric { .. } => Lobe::Refraction,
            #[cfg(feature = "coating")]
            Model::Plastic(_) | Model::RoughPlastic(_) => Lobe::Coating,
            #[cfg(feature = "rough-refraction")]
            Model::RoughDielectric(..) => Lobe::RoughRefraction,
            #[cfg(feature = "principled")]
            Model::Principled(..) => Lobe::Principled,
            #[cfg(feature = "rough-diffuse")]
            Model::RoughDiffuse(..) => Lobe::RoughDiffuse,
        }
    }

    /// True when every lobe is a Dirac delta (no connection can end here).
    ///
    /// A *mixed* BSDF (smooth plastic: a Dirac coating over a diffuse base)
    /// is not delta: connections may end on it and `eval`/`pdf` give its
    /// smooth part, while `sample` flags the Dirac lobe with `delta: true`.
    pub fn is_delta(&self) -> bool {
        matches!(self.lobe(), Lobe::SpecularReflection | Lobe::Refraction)
    }

    /// True when the BSDF can scatter to the other side of the surface
    /// (only dielectrics, smooth, thin or rough). Rays leave from the side
    /// their direction points to (`offset::spawn_ray` picks it from the
    /// geometric normal), so callers need this only for two-sidedness.
    pub fn has_transmission(&self) -> bool {
        match &self.model {
            #[cfg(feature = "principled")]
            Model::Principled(p) => p.transmits(),
            _ => matches!(self.lobe(), Lobe::Refraction | Lobe::RoughRefraction),
        }
    }

    /// A coarse roughness hint in the microfacet α scale: 0 for Dirac-only
    /// models, the (clamped) α of a rough conductor, 1 for Lambertian.
    /// Useful to decide e.g. whether a connection through this vertex can
    /// carry any useful contribution.
    pub fn roughness(&self) -> f32 {
        match &self.model {
            Model::Diffuse { .. } => 1.0,
            #[cfg(feature = "rough-diffuse")]
            Model::RoughDiffuse(..) => 1.0,
            #[cfg(feature = "glossy")]
            Model::RoughConductor { mf, .. } => mf.alpha,
            // The diffuse base carries connections.
            #[cfg(feature = "coating")]
            Model::Plastic(_) | Model::RoughPlastic(_) => 1.0,
            #[cfg(feature = "rough-refraction")]
            Model::RoughDielectric(rd) => rd.mf.alpha,
            // The diffuse lobe carries connections when it has weight.
            #[cfg(feature = "principled")]
            Model::Principled(p) => {
                if p.metallic < 1.0 && p.spec_trans < 1.0 {
                    1.0
                } else {
                    let d = p.distribution();
                    libm::sqrtf(d.ax * d.ay)
                }
            }
            #[cfg(any(feature = "specular", feature = "refraction"))]
            _ => 0.0,
        }
    }

    /// The pair (wo, wi) as the opaque model sees it: mirrored to the upper
    /// hemisphere when two-sided and `wo` is below (Mitsuba's `twosided`).
    #[inline]
    fn orient(&self, wo: Vec3, wi: Vec3) -> (Vec3, Vec3) {
        if self.two_sided && wo.z < 0.0 {
            (flip_z(wo), flip_z(wi))
        } else {
            (wo, wi)
        }
    }

    /// f(wo, wi), without the cosine; zero for delta lobes. Reciprocal for
    /// the reflection models: eval(wo, wi) = eval(wi, wo). `mode` only
    /// matters for rough transmission, where refracted radiance carries the
    /// 1/η² that importance lacks: eval(wo, wi, Importance) =
    /// eval(wi, wo, Radiance) (the adjoint BSDF).
    // Forced: the inlined arms are a few instructions, the call to them
    // (which the plain hint left) as many again.
    #[inline(always)]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Rgb {
        if !self.light_side_ok(wo, wi, mode) {
            return Rgb::ZERO;
        }
        // The models of the shared scenes inline; the rest out of line
        // (`eval_other`), so that their code does not bloat every caller.
        #[allow(unreachable_patterns)]
        match &self.model {
            Model::Diffuse { albedo } => {
                let (wo, wi) = self.orient(wo, wi);
                diffuse::eval(*albedo, wo, wi)
            }
            #[cfg(feature = "glossy")]
            Model::RoughConductor { mf, fresnel, tint } => {
                let (wo, wi) = self.orient(wo, wi);
                conductor::eval_rough(mf, fresnel, *tint, wo, wi)
            }
            _ => self.eval_other(wo, wi, mode),
        }
    }

    /// [`Bsdf::eval`] of the models that are not diffuse or rough
    /// conductors (zero for Dirac-only ones).
    // A build without those models has only the fallback arm.
    #[inline(never)]
    #[allow(unused_variables)]
    fn eval_other(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Rgb {
        #[allow(unreachable_patterns)]
        match &self.model {
            #[cfg(feature = "coating")]
            Model::Plastic(p) => {
                let (wo, wi) = self.orient(wo, wi);
                p.eval(wo, wi)
            }
            #[cfg(feature = "coating")]
            Model::RoughPlastic(p) => {
                let (wo, wi) = self.orient(wo, wi);
                p.eval(wo, wi)
            }
            // Never two-sided, like the smooth dielectric.
            #[cfg(feature = "rough-refraction")]
            Model::RoughDielectric(rd) => rd.eval(wo, wi, mode),
            // Two-sided only when nothing transmits (see `Bsdf::principled`).
            #[cfg(feature = "principled")]
            Model::Principled(p) => {
                let (wo, wi) = self.orient(wo, wi);
                p.eval(wo, wi, mode)
            }
            #[cfg(feature = "rough-diffuse")]
            Model::RoughDiffuse(r) => {
                let (wo, wi) = self.orient(wo, wi);
                r.eval(wo, wi)
            }
            _ => Rgb::ZERO,
        }
    }

    /// Solid-angle density with which [`Bsdf::sample`] returns `wi` given
    /// `wo`; zero for deltas. It integrates to 1 for the diffuse model and
    /// to 1 minus the probability that `sample` fails for rough conductors.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        // Split as `eval` is.
        #[allow(unreachable_patterns)]
        match &self.model {
            Model::Diffuse { .. } => {
                let (wo, wi) = self.orient(wo, wi);
                diffuse::pdf(wo, wi)
            }
            #[cfg(feature = "glossy")]
            Model::RoughConductor { mf, .. } => {
                let (wo, wi) = self.orient(wo, wi);
                conductor::pdf_rough(mf, wo, wi)
            }
            _ => self.pdf_other(wo, wi),
        }
    }

    /// [`Bsdf::pdf`] of the models that are not diffuse or rough
    /// conductors (zero for Dirac-only ones).
    #[inline(never)]
    #[allow(unused_variables)]
    fn pdf_other(&self, wo: Vec3, wi: Vec3) -> f32 {
        #[allow(unreachable_patterns)]
        match &self.model {
            #[cfg(feature = "coating")]
            Model::Plastic(p) => {
                let (wo, wi) = self.orient(wo, wi);
                p.pdf(wo, wi)
            }
            #[cfg(feature = "coating")]
            Model::RoughPlastic(p) => {
                let (wo, wi) = self.orient(wo, wi);
                p.pdf(wo, wi)
            }
            #[cfg(feature = "rough-refraction")]
            Model::RoughDielectric(rd) => rd.pdf(wo, wi),
            #[cfg(feature = "principled")]
            Model::Principled(p) => {
                let (wo, wi) = self.orient(wo, wi);
                p.pdf(wo, wi)
            }
            #[cfg(feature = "rough-diffuse")]
            Model::RoughDiffuse(r) => {
                let (wo, wi) = self.orient(wo, wi);
                r.pdf(wo, wi)
            }
            _ => 0.0,
        }
    }

    /// The Dirac lobe of a specular BSDF chosen by `reflect` (reflection
    /// or refraction), followed deterministically: the outgoing direction
    /// and the lobe's throughput f·|cos θi| (Fresnel reflectance F, or
    /// (1 − F) times 1/η² for refracted radiance) — what a path through a
    /// specular vertex carries when the lobe is fixed rather than sampled
    /// (the level-2 perturbations retrace a specular chain this
    /// way). `None` for non-delta BSDFs, for a lobe the model lacks (a
    /// conductor's refraction) and where the lobe carries nothing (total
    /// internal reflection has no refraction).
    pub fn specular(&self, wo: Vec3, reflect: bool, mode: TransportMode) -> Option<(Vec3, Rgb)> {
        if !self.is_delta() {
            return None;
        }
        // The lobe choice of `sample`: reflection for u_lobe < F, which
        // u_lobe = 0 picks whenever F > 0 and u_lobe = 1 never does.
        let u_lobe = if reflect { 0.0 } else { 1.0 };
        let s = self.sample(wo, u_lobe, Vec2::ZERO, mode)?;
        let reflected = (s.wi.z > 0.0) == (wo.z > 0.0);
        if reflected != reflect {
            return None;
        }
        let weight = s.f * s.wi.z.abs();
        (weight.is_finite() && !weight.is_black()).then_some((s.wi, weight))
    }

    /// Samples `wi`; `u_lobe` chooses a lobe (dielectric reflection versus
    /// refraction), `u` the direction. `None` when nothing is scattered
    /// (one-sided and seen from below, a rough reflection below the
    /// horizon, grazing `wo`).
    ///
    /// For non-delta samples `f` and `pdf` equal `eval(wo, wi, mode)` and
    /// `pdf(wo, wi)` exactly. Directions depend continuously on `u` (only the
    /// discrete lobe choice by `u_lobe` jumps), which primary-sample-space
    /// Metropolis mutations rely on.
    // Only the dielectrics and plastics read `u_lobe`, the dielectric `mode`.
    #[cfg_attr(
        not(all(feature = "refraction", feature = "coating")),
        allow(unused_variables)
    )]
    // Forced, as `eval`: out of line its prologue and epilogue (registers
    // saved for the out-of-line models' call) cost as much as a diffuse
    // sample's own arithmetic.
    #[inline(always)]
    pub fn sample(
        &self,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        let flip = self.two_sided && wo.z < 0.0;
        let wo_up = if flip { flip_z(wo) } else { wo };
        // The models of the shared scenes inline, the rest out of line
        // (`sample_other`), as in `eval`.
        #[allow(unreachable_patterns)]
        let mut s = match &self.model {
            Model::Diffuse { albedo } => diffuse::sample(*albedo, wo_up, u),
            #[cfg(feature = "specular")]
            Model::Conductor { fresnel, tint } => conductor::sample_smooth(fresnel, *tint, wo_up),
            #[cfg(feature = "glossy")]
            Model::RoughConductor { mf, fresnel, tint } => {
                conductor::sample_rough(mf, fresnel, *tint, wo_up, u)
            }
            // Never two-sided: both sides are handled by the Fresnel code.
            #[cfg(feature = "refraction")]
            Model::Dielectric { eta, tints } => dielectric::sample(*eta, *tints, wo, u_lobe, mode),
            _ => self.sample_other(wo, wo_up, u_lobe, u, mode),
        }?;
        if flip {
            s.wi = flip_z(s.wi);
        }
        if !self.light_side_ok(wo, s.wi, mode) {
            return None;
        }
        // Last line of defence: a 1/cos θ of a direction a hair above the
        // plane can overflow; such a sample is dropped, never returned as Inf.
        (s.f.is_finite() && s.pdf.is_finite()).then_some(s)
    }

    /// [`Bsdf::sample`] of the models it does not inline, before the
    /// two-sided flip back: `wo` as given, `wo_up` mirrored to the upper
    /// hemisphere for two-sided models.
    #[inline(never)]
    #[allow(unused_variables)]
    fn sample_other(
        &self,
        wo: Vec3,
        wo_up: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        #[allow(unreachable_patterns)]
        match &self.model {
            #[cfg(feature = "refraction")]
            Model::ThinDielectric { eta, tints } => {
                thin_dielectric::sample(*eta, tints.0, tints.1, wo, u_lobe)
            }
            #[cfg(feature = "coating")]
            Model::Plastic(p) => p.sample(wo_up, u_lobe, u),
            #[cfg(feature = "coating")]
            Model::RoughPlastic(p) => p.sample(wo_up, u_lobe, u),
            #[cfg(feature = "rough-refraction")]
            Model::RoughDielectric(rd) => rd.sample(wo, u_lobe, u, mode),
            #[cfg(feature = "principled")]
            Model::Principled(p) => p.sample(wo_up, u_lobe, u, mode),
            #[cfg(feature = "rough-diffuse")]
            Model::RoughDiffuse(r) => r.sample(wo_up, u),
            // The inlined models never get here.
            _ => None,
        }
    }
}
