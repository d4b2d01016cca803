//! Rough diffuse reflection (Mitsuba 0.6's `roughdiffuse`): the
//! Oren–Nayar model (M. Oren and S. K. Nayar, "Generalization of
//! Lambert's reflectance model", SIGGRAPH 1994), ideal diffuse facets in
//! V-shaped grooves with shadowing, masking and interreflection.
//!
//! Roughness: Mitsuba's `alpha` is an RMS facet slope, made portable with
//! the microfacet models; Oren–Nayar's σ (standard deviation of facet
//! angles, radians) is α/√2, Mitsuba 0.6's conversion.
//!
//! Which form is used when (as Mitsuba 0.6):
//! - by default (`useFastApprox` false) the paper's full *qualitative*
//!   model, eq. 30 (single scattering: C1, C2 with its backscatter
//!   correction, C3) plus eq. 32 (the interreflection term in ρ², C4);
//! - with `useFastApprox` the paper's simplified model, eq. 31
//!   (A + B·max(0, cos Δφ)·sin α·tan β), single scattering only.
//!
//! Both reduce to Lambert's ρ/π exactly at α = 0 and are symmetric in the
//! two directions (reciprocal). Neither is energy-conserving at grazing
//! incidence: the published fits reflect up to ≈ 5 % (full) and ≈ 1.5 %
//! (fast) more than they receive for ρ = 1 near 90° (the tests bound
//! this); we keep Mitsuba's model, whose renders are the references.
//!
//! Where the full model's fit turns negative (α ≳ 1, both directions near
//! grazing on opposite sides) f is clamped to 0, unlike Mitsuba 0.6.
//!
//! One-sided like `diffuse`; sampling is cosine-weighted as in Mitsuba 0.6
//! (the Oren–Nayar factor varies slowly, so the weight f·cos/pdf stays
//! near ρ).

use glam::{Vec2, Vec3};

use super::BsdfSample;
use crate::math::{INV_PI, Rgb, safe_sqrt, warp};

/// An Oren–Nayar surface resolved at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct RoughDiffuse {
    /// Albedo ρ of the facets.
    pub albedo: Rgb,
    /// σ², the variance of facet angles (σ = α/√2).
    pub sigma2: f32,
    /// Mitsuba's `useFastApprox`: the simplified model (eq. 31).
    pub fast: bool,
}

impl RoughDiffuse {
    /// The model of albedo `albedo` and Mitsuba roughness `alpha`.
    pub fn new(albedo: Rgb, alpha: f32, fast: bool) -> Self {
        // σ = α/√2 (Mitsuba 0.6's fit from RMS slope to angle deviation).
        RoughDiffuse {
            albedo,
            sigma2: 0.5 * alpha * alpha,
            fast,
        }
    }

    /// f(wo, wi) without the cosine: ρ/π times the Oren–Nayar factor.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let s2 = self.sigma2;
        let (cos_o, cos_i) = (wo.z.min(1.0), wi.z.min(1.0));
        let (sin_o, sin_i) = (
            safe_sqrt(1.0 - cos_o * cos_o),
            safe_sqrt(1.0 - cos_i * cos_i),
        );
        // cos(φi − φo) from the projections onto the tangent plane; at the
        // pole the azimuth is undefined and its terms carry no weight.
        let cos_dphi = if sin_o > 1e-4 && sin_i > 1e-4 {
            ((wo.x * wi.x + wo.y * wi.y) / (sin_o * sin_i)).clamp(-1.0, 1.0)
        } else {
            0.0
        };
        // The paper's α = max(θi, θo) and β = min(θi, θo): the direction
        // nearer the normal gives β.
        let (sin_a, sin_b, cos_a, cos_b) = if cos_o > cos_i {
            (sin_i, sin_o, cos_i, cos_o)
        } else {
            (sin_o, sin_i, cos_o, cos_i)
        };
        let tan_b = sin_b / cos_b;
        let a = 1.0 - 0.5 * s2 / (s2 + 0.33);
        let g = s2 / (s2 + 0.09);
        if self.fast {
            // Eq. 31.
            let factor = a + 0.45 * g * cos_dphi.max(0.0) * sin_a * tan_b;
            return self.albedo * (INV_PI * factor);
        }
        // Eqs. 30 and 32 with the angles themselves.
        let (alpha, beta) = (libm::acosf(cos_a), libm::acosf(cos_b));
        let two_beta_pi = 2.0 * beta * INV_PI;
        let c2 = if cos_dphi > 0.0 {
            0.45 * g * sin_a
        } else {
            0.45 * g * (sin_a - two_beta_pi * two_beta_pi * two_beta_pi)
        };
        let ab = 4.0 * INV_PI * INV_PI * alpha * beta;
        let c3 = 0.125 * g * ab * ab;
        let c4 = 0.17 * s2 / (s2 + 0.13);
        // tan((α + β)/2) by the half-angle identity.
        let tan_half = (sin_a + sin_b) / (cos_a + cos_b);
        let single = a + cos_dphi * c2 * tan_b + (1.0 - cos_dphi.abs()) * c3 * tan_half;
        let double = c4 * (1.0 - cos_dphi * two_beta_pi * two_beta_pi);
        // For α ≳ 1 the backscatter correction of C2 drives the single-
        // scattering fit below zero when both directions are near grazing
        // on opposite azimuths; Mitsuba 0.6 returns that negative value,
        // we return 0 (a negative BSDF would subtract light).
        ((self.albedo * single + self.albedo * self.albedo * double) * INV_PI).map(|v| v.max(0.0))
    }

    /// Cosine-weighted hemisphere density (Mitsuba 0.6 samples the rough
    /// model like the smooth one).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 {
            0.0
        } else {
            warp::cosine_hemisphere_pdf(wi)
        }
    }

    /// Cosine-weighted sampling; `f` and `pdf` are `eval` and `pdf`.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        super::diffuse::sample_cosine(u, |wi| self.eval(wo, wi), |wi| self.pdf(wo, wi))
    }
}
