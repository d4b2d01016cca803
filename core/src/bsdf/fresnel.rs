//! Fresnel reflectance of smooth interfaces for unpolarised light.
//!
//! Both functions evaluate the exact Fresnel equations (Born & Wolf,
//! *Principles of Optics*: §1.5 for dielectrics, and the chapter on the
//! optics of metals, where Snell's law and the Fresnel formulae hold with a
//! complex index) and average the s- and p-polarised reflectances, as
//! Mitsuba 3's `fresnel` and `fresnel_conductor` do.

use crate::math::{Rgb, safe_sqrt};

/// Fresnel reflectance of a conductor with complex relative index of
/// refraction `eta + i·k`, for light arriving at `cos_i = cos θi` (clamped
/// to [0, 1]; only its magnitude matters).
///
/// Negative `eta` or `k` are unphysical and are taken by magnitude.
/// At grazing incidence (cos θi = 0) the result is 1 for every medium.
pub fn conductor(cos_i: f32, eta: f32, k: f32) -> f32 {
    let c = cos_i.abs().min(1.0);
    if c == 0.0 {
        // Limit of both amplitude ratios below: |r_s| = |r_p| = 1. Handling
        // it here also avoids 0/0 for the index-matched case n = 1.
        return 1.0;
    }
    let n = Complex::new(eta.abs(), k.abs());
    let n2 = n.mul(n);
    let sin2 = (1.0 - c * c).max(0.0);
    // w = n·cos θt = sqrt(n² − sin² θi) (Snell's law with a complex index).
    // The principal root has Re ≥ 0 and, because Im(n²) = 2ηk ≥ 0, also
    // Im ≥ 0: the transmitted wave decays into the conductor.
    let w = n2.sub_real(sin2).sqrt();
    // Amplitude ratios with n₁ = 1 (Fresnel formulae with cos θt = w/n):
    //   r_s = (cos θi − w) / (cos θi + w)
    //   r_p = (n² cos θi − w) / (n² cos θi + w)
    let rs = ratio_norm2(Complex::new(c, 0.0), w);
    let rp = ratio_norm2(n2.scale(c), w);
    (0.5 * (rs + rp)).clamp(0.0, 1.0)
}

/// [`conductor`] for each colour channel.
pub fn conductor_rgb(cos_i: f32, eta: Rgb, k: Rgb) -> Rgb {
    Rgb::new(
        conductor(cos_i, eta.r, k.r),
        conductor(cos_i, eta.g, k.g),
        conductor(cos_i, eta.b, k.b),
    )
}

/// |a − b|² / |a + b|², or 1 when both vanish (grazing, index-matched).
#[inline]
fn ratio_norm2(a: Complex, b: Complex) -> f32 {
    let num = (a.re - b.re) * (a.re - b.re) + (a.im - b.im) * (a.im - b.im);
    let den = (a.re + b.re) * (a.re + b.re) + (a.im + b.im) * (a.im + b.im);
    if den > 0.0 { num / den } else { 1.0 }
}

/// Minimal complex arithmetic for [`conductor`].
#[derive(Clone, Copy)]
struct Complex {
    re: f32,
    im: f32,
}

impl Complex {
    #[inline]
    fn new(re: f32, im: f32) -> Self {
        Complex { re, im }
    }

    #[inline]
    fn mul(self, o: Complex) -> Complex {
        Complex::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }

    #[inline]
    fn sub_real(self, x: f32) -> Complex {
        Complex::new(self.re - x, self.im)
    }

    #[inline]
    fn scale(self, s: f32) -> Complex {
        Complex::new(self.re * s, self.im * s)
    }

    /// Principal square root (Re ≥ 0; Im takes the sign of `self.im`).
    /// Of the two half-angle formulas, the one without cancellation is used
    /// and the other component is recovered from 2·Re·Im = im.
    #[inline]
    fn sqrt(self) -> Complex {
        let r = libm::hypotf(self.re, self.im);
        if r == 0.0 {
            return Complex::new(0.0, 0.0);
        }
        if self.re >= 0.0 {
            let re = safe_sqrt(0.5 * (r + self.re));
            Complex::new(re, self.im / (2.0 * re))
        } else {
            let im = safe_sqrt(0.5 * (r - self.re));
            let im = if self.im < 0.0 { -im } else { im };
            Complex::new(self.im / (2.0 * im), im)
        }
    }
}

/// Result of [`dielectric`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DielectricFresnel {
    /// Unpolarised reflectance F ∈ [0, 1] (1 under total internal reflection).
    pub reflectance: f32,
    /// Signed cosine of the refracted direction: opposite in sign to the
    /// incident cosine (the refracted ray leaves on the other side); 0 under
    /// total internal reflection.
    pub cos_t: f32,
    /// Relative index η_t/η_i of the side entered over the side left.
    pub eta_it: f32,
    /// Its reciprocal η_i/η_t, the factor on the tangential components in
    /// Snell's law.
    pub eta_ti: f32,
}

/// Fresnel reflectance of a smooth dielectric interface with relative index
/// `eta` = η_inside / η_outside, for a direction with signed cosine `cos_i`
/// to the normal (positive: outside, i.e. on the side the normal points to).
///
/// `eta == 1` is index-matched (F = 0, straight pass-through) and `eta < 1`
/// is allowed (then total internal reflection can happen from outside).
pub fn dielectric(cos_i: f32, eta: f32) -> DielectricFresnel {
    let (eta_it, ci) = if cos_i >= 0.0 {
        (eta, cos_i.min(1.0))
    } else {
        (1.0 / eta, (-cos_i).min(1.0))
    };
    let eta_ti = 1.0 / eta_it;
    // The refracted ray leaves on the opposite side.
    let sign_t = if cos_i >= 0.0 { -1.0 } else { 1.0 };
    if eta == 1.0 {
        // Index-matched: no interface at all. Special-cased because the
        // general formula is 0/0 at grazing incidence.
        return DielectricFresnel {
            reflectance: 0.0,
            cos_t: sign_t * ci,
            eta_it,
            eta_ti,
        };
    }
    // Snell: sin θt = (η_i/η_t) sin θi.
    let sin2_t = eta_ti * eta_ti * (1.0 - ci * ci);
    if sin2_t >= 1.0 || ci == 0.0 {
        // Total internal reflection, or grazing incidence where F → 1.
        return DielectricFresnel {
            reflectance: 1.0,
            cos_t: 0.0,
            eta_it,
            eta_ti,
        };
    }
    let ct = safe_sqrt(1.0 - sin2_t);
    // Amplitude ratios (Fresnel formulae), with η = η_t/η_i:
    //   r_s = (cos θi − η cos θt) / (cos θi + η cos θt)
    //   r_p = (η cos θi − cos θt) / (η cos θi + cos θt).
    let rs = (ci - eta_it * ct) / (ci + eta_it * ct);
    let rp = (eta_it * ci - ct) / (eta_it * ci + ct);
    DielectricFresnel {
        reflectance: (0.5 * (rs * rs + rp * rp)).clamp(0.0, 1.0),
        cos_t: sign_t * ct,
        eta_it,
        eta_ti,
    }
}
