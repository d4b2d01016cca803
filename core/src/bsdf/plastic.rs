//! Smooth plastic (Mitsuba 3's `plastic`): a smooth dielectric interface
//! over a Lambertian base.
//!
//! Light either reflects off the interface (a Dirac lobe with the Fresnel
//! reflectance F) or enters, scatters diffusely in the base and leaves.
//! Weidlich & Wilkie 2007 ("Arbitrarily layered micro-facet surfaces") and
//! Mitsuba's documentation give the diffuse part in closed form:
//!
//!   f_d = ρ / (1 − F_dr) · (1 − F(cos θo)) (1 − F(cos θi)) / (η² π),
//!
//! where 1/(1 − F_dr) sums the light bounced back into the base by total
//! and partial internal reflection (F_dr: the interface's diffuse
//! reflectance seen from inside) and 1/η² is the radiance compression on
//! leaving through the interface. `nonlinear` replaces 1 − F_dr by
//! 1 − ρ·F_dr (each internal bounce also meets the base's albedo), which
//! saturates colours.
//!
//! The BSDF is *mixed*: `eval`/`pdf` give the smooth part only, `sample`
//! reports the coating's reflection with `delta: true` (see the module docs
//! of `bsdf` and `mlt::perturbation` for how estimators treat that).

use glam::{Vec2, Vec3};

use super::{BsdfSample, diffuse, fresnel};
use crate::math::{INV_PI, Rgb};

/// The parameters of a resolved smooth plastic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Plastic {
    /// Relative index η of the coating.
    pub eta: f32,
    /// ρ/(1 − F_dr)/η² (or the nonlinear variant), per channel: the
    /// diffuse lobe without its Fresnel and 1/π factors.
    pub diffuse: Rgb,
    /// Multiplier of the coating's reflection.
    pub specular: Rgb,
    /// Probability weight of the coating lobe before Fresnel weighting
    /// (Mitsuba's `specular_sampling_weight`).
    pub spec_weight: f32,
}

/// Diffuse Fresnel reflectance: the hemispherical, cosine-weighted average
/// of F for relative index `eta`, by the fits Mitsuba 3 uses
/// (`fresnel_diffuse_reflectance`): Egan & Hilgeman 1973 for η < 1 and
/// d'Eon & Irving 2011 otherwise (both accurate to < 1% for η in the range
/// of real coatings).
pub(super) fn diffuse_fresnel(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        0.919_317
            + inv * (-3.4793 + inv * (6.75335 + inv * (-7.80989 + inv * (4.98554 - inv * 1.36881))))
    }
}

/// The factor of the base's albedo ρ common to both plastics:
/// ρ / (1 − R_int) (or ρ / (1 − ρ R_int) when `nonlinear`) / η², where
/// `r_int` is the coating's internal diffuse reflectance. Channels whose
/// denominator is not positive (an albedo beyond 1/R_int, unphysical) are 0.
pub(super) fn base_factor(rho: Rgb, r_int: f32, nonlinear: bool, eta: f32) -> Rgb {
    let inv_eta2 = 1.0 / (eta * eta);
    let f = |a: f32| {
        let den = 1.0 - if nonlinear { a * r_int } else { r_int };
        if den > 0.0 { a / den * inv_eta2 } else { 0.0 }
    };
    Rgb::new(f(rho.r), f(rho.g), f(rho.b))
}

/// Mitsuba's `specular_sampling_weight`: mean specular over mean specular
/// plus mean diffuse albedo (here of the values at the shading point).
pub(super) fn spec_weight(rho: Rgb, spec: Rgb) -> f32 {
    let (d, s) = (rho.average(), spec.average());
    if d + s > 0.0 { s / (d + s) } else { 0.5 }
}

impl Plastic {
    /// Probability of sampling the coating's reflection for `cos_o`, and
    /// F(cos θo).
    #[inline]
    fn prob_specular(&self, cos_o: f32) -> (f32, f32) {
        let f = fresnel::dielectric(cos_o, self.eta).reflectance;
        let ps = f * self.spec_weight;
        let pd = (1.0 - f) * (1.0 - self.spec_weight);
        let sum = ps + pd;
        (if sum > 0.0 { ps / sum } else { 1.0 }, f)
    }

    /// The diffuse lobe f_d (upper hemisphere only; the coating is
    /// one-sided like Mitsuba's).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let t_o = 1.0 - fresnel::dielectric(wo.z, self.eta).reflectance;
        let t_i = 1.0 - fresnel::dielectric(wi.z, self.eta).reflectance;
        self.diffuse * (t_o * t_i * INV_PI)
    }

    /// Density of the diffuse lobe's directions: (1 − P_spec)·cos θi/π.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        (1.0 - self.prob_specular(wo.z).0) * diffuse::pdf(wo, wi)
    }

    /// Picks the coating (Dirac, `u_lobe < P_spec`) or the base (cosine
    /// sampling by `u`).
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let (ps, f) = self.prob_specular(wo.z);
        if u_lobe < ps {
            // Weight specular·F/P_spec; delta convention f = weight·pdf/cos.
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            return Some(BsdfSample {
                wi,
                f: self.specular * (f / wo.z),
                pdf: ps,
                delta: true,
                eta: 1.0,
            });
        }
        super::diffuse::sample_cosine(u, |wi| self.eval(wo, wi), |wi| self.pdf(wo, wi))
    }
}
