//! Smooth (`conductor`) and rough (`roughconductor`) metals, in the upper
//! hemisphere, and their Fresnel term ([`ConductorFresnel`]).
//!
//! Each half is built with its feature: `specular` (smooth) and `glossy`
//! (rough); the Fresnel term's type always, since every build's materials
//! name it.

#[cfg(feature = "glossy")]
use glam::Vec2;
#[cfg(any(feature = "glossy", feature = "specular"))]
use glam::Vec3;

#[cfg(feature = "glossy")]
use super::microfacet::Microfacet;
#[cfg(any(feature = "glossy", feature = "specular"))]
use super::{BsdfSample, fresnel};
use crate::math::Rgb;

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

/// Fresnel reflectance at `cos_i` (cosine to the mirror / micro normal).
#[cfg(any(feature = "glossy", feature = "specular"))]
#[inline]
pub(super) fn fresnel(fresnel: &ConductorFresnel, cos_i: f32) -> Rgb {
    match fresnel {
        ConductorFresnel::Complex { eta, k } => fresnel::conductor_rgb(cos_i, *eta, *k),
        ConductorFresnel::Perfect => Rgb::ONE,
    }
}

/// Ideal mirror reflection: the only direction is (−x, −y, z), chosen with
/// probability 1, and the throughput weight is F(cos θo)·tint.
#[cfg(feature = "specular")]
pub(super) fn sample_smooth(fr: &ConductorFresnel, tint: Rgb, wo: Vec3) -> Option<BsdfSample> {
    // Seen edge-on the mirror reflects nothing back (and 1/cos θ below
    // would be infinite).
    if wo.z <= 0.0 {
        return None;
    }
    let wi = Vec3::new(-wo.x, -wo.y, wo.z);
    let weight = fresnel(fr, wo.z) * tint;
    // Delta convention: f = weight · pdf / |cos θi| with pdf = 1.
    Some(BsdfSample {
        wi,
        f: weight / wi.z,
        pdf: 1.0,
        delta: true,
        eta: 1.0,
    })
}

/// The factors shared by the rough lobe's value and density for a pair of
/// upper-hemisphere directions; `None` where both vanish.
#[cfg(feature = "glossy")]
struct RoughTerms {
    /// Half vector, the only microfacet normal reflecting wo into wi.
    m: Vec3,
    /// D(m).
    d: f32,
    /// G1(wo, m).
    g1_o: f32,
}

#[cfg(feature = "glossy")]
impl RoughTerms {
    #[inline]
    fn new(mf: &Microfacet, wo: Vec3, wi: Vec3) -> Option<Self> {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return None;
        }
        // wo + wi ≠ 0 because both are in the upper hemisphere.
        let m = (wo + wi).normalize();
        let d = mf.d(m);
        (d > 0.0).then(|| RoughTerms {
            m,
            d,
            g1_o: mf.g1(wo, m),
        })
    }

    /// Visible-normal density times the reflection Jacobian 1/(4 wo·m)
    /// (Walter et al. 2007, §4.1): D_wo(m)/(4 wo·m) = G1(wo) D(m)/(4 cos θo)
    /// (Heitz 2018, §3).
    #[inline]
    fn pdf(&self, wo: Vec3) -> f32 {
        self.g1_o * self.d / (4.0 * wo.z)
    }

    /// Torrance–Sparrow reflection with separable Smith masking (Walter et
    /// al. 2007, §3–4; Mitsuba's `roughconductor`):
    /// f = F(wi·m) D(m) G1(wo) G1(wi) / (4 cos θo cos θi).
    #[inline]
    fn f(&self, mf: &Microfacet, fr: &ConductorFresnel, tint: Rgb, wo: Vec3, wi: Vec3) -> Rgb {
        let g = self.g1_o * mf.g1(wi, self.m);
        fresnel(fr, wi.dot(self.m)) * tint * (self.d * g / (4.0 * wo.z * wi.z))
    }
}

/// f(wo, wi) of the rough conductor (see `RoughTerms::f`).
#[cfg(feature = "glossy")]
pub(super) fn eval_rough(
    mf: &Microfacet,
    fr: &ConductorFresnel,
    tint: Rgb,
    wo: Vec3,
    wi: Vec3,
) -> Rgb {
    RoughTerms::new(mf, wo, wi).map_or(Rgb::ZERO, |t| t.f(mf, fr, tint, wo, wi))
}

/// Density of [`sample_rough`] (see `RoughTerms::pdf`).
#[cfg(feature = "glossy")]
pub(super) fn pdf_rough(mf: &Microfacet, wo: Vec3, wi: Vec3) -> f32 {
    RoughTerms::new(mf, wo, wi).map_or(0.0, |t| t.pdf(wo))
}

/// Samples a visible normal m and reflects wo about it (Heitz & d'Eon 2014).
/// The sample's `f` and `pdf` are recomputed from the final direction by
/// the same code as [`eval_rough`] and [`pdf_rough`], so they equal what
/// `eval` and `pdf` return bit for bit (MIS weights and Metropolis
/// acceptance ratios compare those values); the weight is
/// f·cos θi/pdf = F·G1(wi) ≤ 1.
#[cfg(feature = "glossy")]
pub(super) fn sample_rough(
    mf: &Microfacet,
    fr: &ConductorFresnel,
    tint: Rgb,
    wo: Vec3,
    u: Vec2,
) -> Option<BsdfSample> {
    if wo.z <= 0.0 {
        return None;
    }
    let m = mf.sample_visible(wo, u);
    let wi = (2.0 * wo.dot(m) * m - wo).normalize_or_zero();
    // Visible normals can still reflect wo below the horizon (that light
    // would scatter again, which the single-scattering model drops).
    let t = RoughTerms::new(mf, wo, wi)?;
    let pdf = t.pdf(wo);
    if !(pdf > 0.0 && pdf.is_finite()) {
        return None;
    }
    let f = t.f(mf, fr, tint, wo, wi);
    f.is_finite().then_some(BsdfSample {
        wi,
        f,
        pdf,
        delta: false,
        eta: 1.0,
    })
}
