//! Rough dielectric interface (Mitsuba's `roughdielectric`): microfacet
//! reflection and refraction after Walter, Marschner, Li and Torrance 2007,
//! "Microfacet Models for Refraction through Rough Surfaces" (EGSR).
//!
//! Both sides of the surface are handled: `wo.z < 0` means `wo` is inside.
//! For a pair of directions the one microfacet normal that scatters `wo`
//! into `wi` is the generalised half vector (Walter et al., eqs. 13 and 16):
//! m ∝ wo + wi for reflection and m ∝ −(wo + η wi) for refraction, with
//! η = η_wi/η_wo the index of the side `wi` points into over that of the
//! side `wo` is on; it is taken in the upper hemisphere, where D lives.
//!
//! Sampling draws a visible normal from D_wo (for `wo` mirrored to the
//! upper hemisphere, as Mitsuba 3 does), picks reflection with probability
//! F(wo·m) and refraction otherwise, and reflects or refracts `wo` about m.
//! Half-vector Jacobians (Walter et al., eqs. 14 and 17):
//! |∂m/∂wi| = 1/(4 |wi·m|) for reflection and
//! η² |wi·m| / (wo·m + η wi·m)² for refraction.

use glam::{Vec2, Vec3};

use super::microfacet::Microfacet;
use super::{BsdfSample, TransportMode, fresnel};
use crate::math::Rgb;

/// A rough dielectric with its textures resolved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct RoughDielectric {
    /// Normal distribution of the microfacets.
    pub(super) mf: Microfacet,
    /// η_inside/η_outside (≠ 1: an index-matched rough interface has no
    /// refraction half vector).
    pub(super) eta: f32,
    /// Multiplier of the reflected lobe (Mitsuba's `specular_reflectance`).
    pub(super) reflectance: Rgb,
    /// Multiplier of the refracted lobe (`specular_transmittance`).
    pub(super) transmittance: Rgb,
}

/// What `eval` and `pdf` share for one pair of directions.
struct Terms {
    /// Whether `wi` is on `wo`'s side.
    reflect: bool,
    /// Generalised half vector, upper hemisphere.
    m: Vec3,
    /// η_wi / η_wo (1 for reflection).
    eta: f32,
    /// wo·m and wi·m.
    wo_m: f32,
    wi_m: f32,
    /// D(m).
    d: f32,
}

impl RoughDielectric {
    /// The microfacet normal linking `wo` and `wi` and the factors both the
    /// value and the density need; `None` where both vanish (grazing
    /// directions, or a pair on which the micro- and macro-surface disagree
    /// about the side: Smith's χ⁺ terms, which Mitsuba 3 applies to its
    /// density too).
    #[inline]
    fn terms(&self, wo: Vec3, wi: Vec3) -> Option<Terms> {
        if wo.z == 0.0 || wi.z == 0.0 {
            return None;
        }
        let reflect = wo.z * wi.z > 0.0;
        let eta = if reflect {
            1.0
        } else if wo.z > 0.0 {
            self.eta
        } else {
            1.0 / self.eta
        };
        let h = wo + wi * eta;
        let len2 = h.length_squared();
        if !(len2 > 0.0) {
            return None;
        }
        let m = h / libm::sqrtf(len2);
        let m = if m.z < 0.0 { -m } else { m };
        let (wo_m, wi_m) = (wo.dot(m), wi.dot(m));
        if wo_m * wo.z <= 0.0 || wi_m * wi.z <= 0.0 {
            return None;
        }
        let d = self.mf.d(m);
        (d > 0.0).then_some(Terms {
            reflect,
            m,
            eta,
            wo_m,
            wi_m,
            d,
        })
    }

    /// f(wo, wi) without the cosine (Walter et al. 2007, eqs. 20 and 21):
    ///
    ///   reflection  F D G / (4 |cos θo| |cos θi|),
    ///   refraction  (1 − F) D G η² |wo·m| |wi·m| / (|cos θo| |cos θi| (wo·m + η wi·m)²),
    ///
    /// with F = F(wo·m), G = G1(wo) G1(wi). Refracted radiance is scaled by
    /// 1/η² (solid-angle compression, Veach 1997, §5.2), importance is not:
    /// f_importance(wo, wi) = f_radiance(wi, wo), the adjoint.
    pub(super) fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Rgb {
        let Some(t) = self.terms(wo, wi) else {
            return Rgb::ZERO;
        };
        let f = fresnel::dielectric(t.wo_m, self.eta).reflectance;
        let g = self.mf.g1(wo, t.m) * self.mf.g1(wi, t.m);
        let cos = (wo.z * wi.z).abs();
        if t.reflect {
            return self.reflectance * (f * t.d * g / (4.0 * cos));
        }
        let denom = t.wo_m + t.eta * t.wi_m;
        let scale = match mode {
            TransportMode::Radiance => 1.0,
            TransportMode::Importance => t.eta * t.eta,
        };
        let v = (1.0 - f) * t.d * g * scale * (t.wo_m * t.wi_m).abs() / (cos * denom * denom);
        self.transmittance * v
    }

    /// Density of [`RoughDielectric::sample`]: the visible-normal density
    /// D_wo(m) = G1(wo) |wo·m| D(m) / |cos θo|, times the lobe's
    /// probability F or 1 − F, times the half-vector Jacobian.
    pub(super) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(t) = self.terms(wo, wi) else {
            return 0.0;
        };
        let wo_up = if wo.z < 0.0 { -wo } else { wo };
        let visible = self.mf.g1(wo_up, t.m) * wo_up.dot(t.m) * t.d / wo_up.z;
        let f = fresnel::dielectric(t.wo_m, self.eta).reflectance;
        let (prob, jacobian) = if t.reflect {
            (f, 1.0 / (4.0 * t.wi_m.abs()))
        } else {
            let denom = t.wo_m + t.eta * t.wi_m;
            (1.0 - f, t.eta * t.eta * t.wi_m.abs() / (denom * denom))
        };
        visible * prob * jacobian
    }

    /// Samples a visible normal m for `wo` (mirrored to the upper
    /// hemisphere), chooses reflection for `u_lobe < F(wo·m)` and refraction
    /// otherwise, and reflects or refracts `wo` about m. The value and
    /// density are recomputed from the final direction by `eval` and `pdf`,
    /// so they equal what those return exactly (MIS weights and Metropolis
    /// ratios compare them). Directions the single-scattering model drops
    /// (reflected below or refracted above the macro surface) give `None`.
    pub(super) fn sample(
        &self,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let wo_up = if wo.z < 0.0 { -wo } else { wo };
        let m = self.mf.sample_visible(wo_up, u);
        let wo_m = wo.dot(m);
        let fr = fresnel::dielectric(wo_m, self.eta);
        let reflect = u_lobe < fr.reflectance;
        let (wi, eta) = if reflect {
            ((2.0 * wo_m * m - wo).normalize_or_zero(), 1.0)
        } else {
            if fr.cos_t == 0.0 {
                return None;
            }
            // Snell's law about m (Mitsuba's `refract`): the tangential part
            // scales by η_wo/η_wi, the normal part is cos θt on m's far side.
            let wi = m * (wo_m * fr.eta_ti + fr.cos_t) - wo * fr.eta_ti;
            (wi.normalize_or_zero(), fr.eta_it)
        };
        // The lobe must leave on its own side (reflection on wo's, refraction
        // on the other): otherwise G1(wi, m) = 0 for the sampled m (Mitsuba 3
        // weighs such samples by that zero), and the direction belongs to
        // the other lobe's half vector, whose density `pdf` reports instead.
        if (wi.z * wo.z > 0.0) != reflect {
            return None;
        }
        let f = self.eval(wo, wi, mode);
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0 && pdf.is_finite()) || f.is_black() {
            return None;
        }
        Some(BsdfSample {
            wi,
            f,
            pdf,
            delta: false,
            eta,
        })
    }
}
