//! The principled BSDF (Mitsuba 3's `principled`): Burley's 2012/2015
//! metallic-roughness model of "Physically Based Shading at Disney" and
//! "Extending the Disney BRDF to a BSDF with Integrated Subsurface
//! Scattering", as Mitsuba 3 implements it, whose renders are our
//! references. Its lobes, with f written without the cosine factor:
//!
//! - **diffuse** (weight (1 − metallic)(1 − spec_trans)): Burley's diffuse
//!   with retro-reflection, (base/π)·((1 − F_L/2)(1 − F_V/2) +
//!   R_R (F_L + F_V + F_L F_V (R_R − 1))) with R_R = 2 roughness cos²θd and
//!   F_x the Schlick weight (1 − cos θx)⁵, blended by `flatness` towards the Hanrahan–Krueger
//!   "fake subsurface" 1.25 (F_ss (1/(cos θL + cos θV) − ½) + ½);
//! - **sheen** (weight sheen·(1 − metallic), only where the diffuse lobe
//!   has weight): F_d = (1 − cos θd)⁵ tinted towards the base colour's hue;
//! - **main specular**: anisotropic GGX reflection with the blended Fresnel
//!   of [`Principled::front_fresnel`] (outside) or the plain dielectric
//!   Fresnel times the transmission weight (inside);
//! - **transmission** (weight (1 − metallic) spec_trans): GGX refraction as
//!   the rough dielectric's (Walter et al. 2007) tinted by √base;
//! - **clearcoat** (weight clearcoat/4, outside only): GTR1 with Schlick
//!   Fresnel (F0 = 0.04) and separable GGX masking with α = 0.25. As in
//!   Mitsuba, f = clearcoat/4 · F D G without the usual 1/(4 cos θL cos θV).
//!
//! Mitsuba's model is not energy-conserving by construction: the
//! retro-reflection term and the sheen add light at grazing angles and are
//! added on top of the specular lobe rather than below it (see the tests).
//!
//! Sampling follows Mitsuba 3: one visible GGX normal m is drawn for `wo`
//! (mirrored to the upper hemisphere) and the dielectric F(wo·m) splits
//! the specular weight between reflection and refraction; outside, the
//! lobes are chosen with probabilities ∝ (diffuse: weight of the diffuse
//! lobe, clearcoat: clearcoat/4, reflection: 1 − w_t (1 − F), refraction:
//! w_t (1 − F)), inside ∝ (F, 1 − F). Outside the sum does not depend on
//! F, so [`Principled::pdf`], which recomputes F at the half vector of the
//! final pair, is the sampler's exact density.

use glam::{Vec2, Vec3};

use super::microfacet::{AnisoGgx, Distribution, Gtr1, Microfacet};
use super::{BsdfSample, TransportMode, fresnel};
use crate::math::{INV_PI, Rgb, safe_sqrt, warp};

/// The principled parameters at one point as plain numbers, named as
/// Mitsuba 3 names them: what a principled material's textures evaluate
/// to (the scalars as their luminance). [`super::Bsdf::principled`] builds
/// the model from them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PrincipledValues {
    /// Base colour.
    pub base_color: Rgb,
    /// Perceptual roughness.
    pub roughness: f32,
    /// Anisotropy.
    pub anisotropic: f32,
    /// Metallic blend.
    pub metallic: f32,
    /// Transmission blend.
    pub spec_trans: f32,
    /// Relative index of refraction, interior over exterior.
    pub eta: f32,
    /// Tint of the dielectric specular towards the base colour.
    pub spec_tint: f32,
    /// Sheen weight.
    pub sheen: f32,
    /// Tint of the sheen towards the base colour.
    pub sheen_tint: f32,
    /// Clearcoat weight.
    pub clearcoat: f32,
    /// Clearcoat glossiness.
    pub clearcoat_gloss: f32,
    /// Blend of the diffuse lobe towards fake subsurface.
    pub flatness: f32,
}

/// A principled material with its textures resolved (every parameter as
/// Mitsuba 3 names it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Principled {
    /// Albedo of the diffuse lobe, F0 of the metal, tint of transmission.
    pub(super) base_color: Rgb,
    /// Perceptual roughness r: GGX α = r² (and the retro-reflection).
    pub(super) roughness: f32,
    /// Anisotropy in [0, 1]: α stretched along x and shrunk along y.
    pub(super) anisotropic: f32,
    /// Blend from dielectric (0) to metal (1).
    pub(super) metallic: f32,
    /// Blend of the dielectric part from opaque (0) to transmitting (1).
    pub(super) spec_trans: f32,
    /// Relative index of refraction, interior over exterior (> 0, ≠ 1 when
    /// transmitting).
    pub(super) eta: f32,
    /// How much the dielectric's specular F0 takes the base colour's hue.
    pub(super) spec_tint: Unit16,
    /// Weight of the sheen lobe.
    pub(super) sheen: f32,
    /// How much the sheen takes the base colour's hue.
    pub(super) sheen_tint: Unit16,
    /// Weight of the clearcoat lobe.
    pub(super) clearcoat: f32,
    /// Glossiness of the clearcoat: GTR1 α = lerp(0.1, 0.001, gloss).
    pub(super) clearcoat_gloss: Unit16,
    /// Blend of the diffuse lobe towards the fake subsurface.
    pub(super) flatness: Unit16,
}

/// A blend weight in [0, 1] as a 16-bit fraction (within 8·10⁻⁶ of the
/// value; the rough plastic's coating table is stored the same way). The
/// four tints and shape blends are kept so, which keeps [`super::Bsdf`]
/// within its size bound; the energy weights stay `f32`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Unit16(u16);

impl Unit16 {
    /// `x` clamped to [0, 1] and rounded to the nearest 1/65535.
    #[inline]
    pub(super) fn new(x: f32) -> Self {
        Unit16(libm::roundf(x.clamp(0.0, 1.0) * 65535.0) as u16)
    }

    /// The stored weight.
    #[inline]
    pub(super) fn get(self) -> f32 {
        self.0 as f32 * (1.0 / 65535.0)
    }
}

/// Schlick's weight (1 − c)⁵, c clamped to [0, 1].
#[inline]
fn schlick_weight(c: f32) -> f32 {
    let m = (1.0 - c).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// The Schlick weight w with which F = F0 + (1 − F0) w, for a direction
/// with signed cosine `cos_i` to the facet normal and relative index `eta`:
/// taken at the incident angle when entering the denser side and at the
/// refracted angle otherwise (Mitsuba's `calc_schlick`; its w is 1 under
/// total internal reflection).
#[inline]
fn schlick_fresnel_weight(cos_i: f32, eta: f32) -> f32 {
    let (eta_it, eta_ti) = if cos_i >= 0.0 {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    if eta_it > 1.0 {
        schlick_weight(cos_i.abs())
    } else {
        schlick_weight(safe_sqrt(1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti))
    }
}

/// F0 of a dielectric with relative index `eta`: ((η − 1)/(η + 1))².
#[inline]
fn schlick_r0(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// `c` over its luminance (the hue at unit luminance), white when black.
#[inline]
fn hue(c: Rgb) -> Rgb {
    let lum = c.luminance();
    if lum > 0.0 { c / lum } else { Rgb::ONE }
}

/// The sign of `x` as ±1 (Mitsuba's `mulsign`: +1 for +0).
#[inline]
fn sign(x: f32) -> f32 {
    if x.is_sign_negative() { -1.0 } else { 1.0 }
}

/// The lobes' selection probabilities (diffuse, clearcoat, refraction,
/// reflection), normalised; `f` is the dielectric Fresnel reflectance at
/// the facet.
#[inline]
fn lobe_probabilities(
    front: bool,
    w_diffuse: f32,
    w_trans: f32,
    clearcoat: f32,
    f: f32,
) -> [f32; 4] {
    let p = if front {
        [
            w_diffuse,
            0.25 * clearcoat,
            w_trans * (1.0 - f),
            1.0 - w_trans * (1.0 - f),
        ]
    } else {
        [0.0, 0.0, 1.0 - f, f]
    };
    let total = p[0] + p[1] + p[2] + p[3];
    p.map(|x| x / total)
}

/// Reflection of `v` about the unit normal `m`.
#[inline]
fn reflect(v: Vec3, m: Vec3) -> Vec3 {
    2.0 * v.dot(m) * m - v
}

/// Whether a facet with normal `m` (upper hemisphere) can scatter `wo`
/// into `wi` on the side the lobe needs (Mitsuba's `mac_mic_compatibility`):
/// `wo` in front of m as seen from `wo`'s side, `wi` in front for
/// reflection and behind for refraction.
#[inline]
fn facet_compatible(m: Vec3, wo: Vec3, wi: Vec3, reflection: bool) -> bool {
    let ms = m * sign(wo.z);
    wo.dot(ms) > 0.0
        && if reflection {
            wi.dot(ms) > 0.0
        } else {
            wi.dot(ms) < 0.0
        }
}

/// The separable Smith masking of the clearcoat: GGX with α = 0.25.
const CLEARCOAT_MASKING: Microfacet = Microfacet {
    dist: Distribution::Ggx,
    alpha: 0.25,
};

impl Principled {
    /// The model of `v`. Weights are kept in [0, 1] (a material's constants
    /// are validated; a bitmap's texel could leave the range, where the
    /// model means nothing).
    #[inline]
    pub(super) fn new(v: &PrincipledValues) -> Self {
        let unit = |x: f32| x.clamp(0.0, 1.0);
        Principled {
            base_color: v.base_color,
            roughness: unit(v.roughness),
            anisotropic: unit(v.anisotropic),
            metallic: unit(v.metallic),
            spec_trans: unit(v.spec_trans),
            eta: v.eta,
            spec_tint: Unit16::new(v.spec_tint),
            sheen: unit(v.sheen),
            sheen_tint: Unit16::new(v.sheen_tint),
            clearcoat: unit(v.clearcoat),
            clearcoat_gloss: Unit16::new(v.clearcoat_gloss),
            flatness: Unit16::new(v.flatness),
        }
    }

    /// Weights of the diffuse (BRDF) and transmitting (BSDF) parts:
    /// (1 − metallic)(1 − spec_trans) and (1 − metallic) spec_trans.
    #[inline]
    fn weights(&self) -> (f32, f32) {
        let dielectric = 1.0 - self.metallic;
        (
            dielectric * (1.0 - self.spec_trans),
            dielectric * self.spec_trans,
        )
    }

    /// Whether any light crosses the surface.
    pub(super) fn transmits(&self) -> bool {
        self.weights().1 > 0.0
    }

    /// The main lobe's GGX roughnesses from Burley 2012's
    /// parametrisation: α = r², stretched by 1/√(1 − 0.9 anisotropic)
    /// along x and by its inverse along y, each at least 0.001.
    #[inline]
    pub(super) fn distribution(&self) -> AnisoGgx {
        let r2 = self.roughness * self.roughness;
        let aspect = libm::sqrtf(1.0 - 0.9 * self.anisotropic);
        AnisoGgx {
            ax: (r2 / aspect).max(0.001),
            ay: (r2 * aspect).max(0.001),
        }
    }

    /// The clearcoat's GTR1 distribution.
    #[inline]
    fn clearcoat_distribution(&self) -> Gtr1 {
        Gtr1 {
            alpha: 0.1 + (0.001 - 0.1) * self.clearcoat_gloss.get(),
        }
    }

    /// The main lobe's Fresnel factor outside (Mitsuba's
    /// `principled_fresnel`): the dielectric F weighted by
    /// (1 − metallic)(1 − spec_tint), plus Schlick terms for the metal
    /// (F0 = base colour) and the tinted dielectric (F0 = hue·R0(η)), at the
    /// facet cosine `cos` (the viewer's).
    #[inline]
    fn front_fresnel(&self, f_dielectric: f32, cos: f32) -> Rgb {
        let w = schlick_fresnel_weight(cos, self.eta);
        let schlick = |f0: Rgb| f0 + (Rgb::ONE - f0) * w;
        let spec_tint = self.spec_tint.get();
        let mut f = Rgb::splat((1.0 - self.metallic) * (1.0 - spec_tint) * f_dielectric);
        if self.metallic > 0.0 {
            f += schlick(self.base_color) * self.metallic;
        }
        if spec_tint > 0.0 {
            let eta_it = if cos >= 0.0 { self.eta } else { 1.0 / self.eta };
            let f0 = hue(self.base_color) * schlick_r0(eta_it);
            f += schlick(f0) * ((1.0 - self.metallic) * spec_tint);
        }
        f
    }

    /// The generalised half vector of the pair (upper hemisphere) and
    /// η_wi/η_wo along the path (1 for reflection); `None` when it is
    /// undefined.
    #[inline]
    fn half_vector(&self, wo: Vec3, wi: Vec3) -> Option<(Vec3, f32)> {
        let reflect = wo.z * wi.z > 0.0;
        let eta_path = if reflect {
            1.0
        } else if wo.z > 0.0 {
            self.eta
        } else {
            1.0 / self.eta
        };
        let h = (wo + wi * eta_path).try_normalize()?;
        Some((if h.z < 0.0 { -h } else { h }, eta_path))
    }

    /// f(wo, wi) without the cosine: the sum of the lobes listed in the
    /// module docs. Refracted radiance carries 1/η² as in the rough
    /// dielectric, so eval(wo, wi, Importance) = eval(wi, wo, Radiance).
    // Out of line: keeps `Bsdf`'s dispatch small enough to inline for
    // the other models.
    #[inline(never)]
    pub(super) fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Rgb {
        if wo.z == 0.0 || wi.z == 0.0 {
            return Rgb::ZERO;
        }
        let Some((h, eta_path)) = self.half_vector(wo, wi) else {
            return Rgb::ZERO;
        };
        let front = wo.z > 0.0;
        let reflect = wo.z * wi.z > 0.0;
        let (w_diffuse, w_trans) = self.weights();
        let (wo_h, wi_h) = (wo.dot(h), wi.dot(h));
        let f_d = fresnel::dielectric(wo_h, self.eta).reflectance;
        let ggx = self.distribution();
        let cos2 = (wo.z * wi.z).abs();
        let mut value = Rgb::ZERO;
        let compatible = facet_compatible(h, wo, wi, reflect);
        if compatible && (reflect && f_d > 0.0 || !reflect && w_trans > 0.0 && f_d < 1.0) {
            let dg = ggx.d(h) * ggx.g1(wo, h) * ggx.g1(wi, h);
            if reflect {
                // Walter et al. 2007, eq. 20, with the blended Fresnel.
                let f = if front {
                    self.front_fresnel(f_d, wo_h)
                } else {
                    Rgb::splat(w_trans * f_d)
                };
                value += f * (dg / (4.0 * cos2));
            } else {
                // Walter et al. 2007, eq. 21; radiance carries 1/η².
                let scale = match mode {
                    TransportMode::Radiance => 1.0,
                    TransportMode::Importance => eta_path * eta_path,
                };
                let denom = wo_h + eta_path * wi_h;
                let t = scale * (1.0 - f_d) * dg * (wo_h * wi_h).abs() / (cos2 * denom * denom);
                value += self.base_color.map(libm::sqrtf) * (w_trans * t);
            }
        }
        if !(front && reflect) {
            return value;
        }
        if self.clearcoat > 0.0 && compatible {
            let f = 0.04 + 0.96 * schlick_fresnel_weight(wo_h, self.eta);
            let d = self.clearcoat_distribution().d(h);
            let g = CLEARCOAT_MASKING.g1(wo, h) * CLEARCOAT_MASKING.g1(wi, h);
            value += Rgb::splat(0.25 * self.clearcoat * f * d * g);
        }
        if w_diffuse > 0.0 {
            let (cos_l, cos_v) = (wi.z, wo.z);
            let (fl, fv) = (schlick_weight(cos_l), schlick_weight(cos_v));
            let cos_d = wi_h;
            let f_diff = (1.0 - 0.5 * fl) * (1.0 - 0.5 * fv);
            let rr = 2.0 * self.roughness * cos_d * cos_d;
            let f_retro = rr * (fl + fv + fl * fv * (rr - 1.0));
            let mut lobe = f_diff + f_retro;
            let flatness = self.flatness.get();
            if flatness > 0.0 {
                // Hanrahan–Krueger-like subsurface approximation (Burley
                // 2015), F_ss90 = R_R/2.
                let fss90 = 0.5 * rr;
                let fss = (1.0 + (fss90 - 1.0) * fl) * (1.0 + (fss90 - 1.0) * fv);
                let f_ss = 1.25 * (fss * (1.0 / (cos_l + cos_v) - 0.5) + 0.5);
                lobe += (f_ss - lobe) * flatness;
            }
            value += self.base_color * (w_diffuse * INV_PI * lobe);
            if self.sheen > 0.0 && self.metallic < 1.0 {
                let tint = Rgb::ONE + (hue(self.base_color) - Rgb::ONE) * self.sheen_tint.get();
                let f = self.sheen * (1.0 - self.metallic) * schlick_weight(cos_d.abs());
                value += tint * f;
            }
        }
        value
    }

    /// The density of [`Principled::sample`]: the lobe probabilities times
    /// each lobe's density (visible GGX normals or GTR1 normals through the
    /// half-vector Jacobian, cosine-weighted for the diffuse lobe). Zero
    /// inside when nothing transmits, where `sample` scatters nothing.
    // Out of line: keeps `Bsdf`'s dispatch small enough to inline for
    // the other models.
    #[inline(never)]
    pub(super) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z == 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        let (w_diffuse, w_trans) = self.weights();
        let front = wo.z > 0.0;
        if !front && w_trans <= 0.0 {
            return 0.0;
        }
        let Some((h, eta_path)) = self.half_vector(wo, wi) else {
            return 0.0;
        };
        let reflect = wo.z * wi.z > 0.0;
        let (wo_h, wi_h) = (wo.dot(h), wi.dot(h));
        let f_d = fresnel::dielectric(wo_h, self.eta).reflectance;
        let [p_diffuse, p_clearcoat, p_trans, p_reflect] =
            lobe_probabilities(front, w_diffuse, w_trans, self.clearcoat, f_d);
        // |∂h/∂wi| (Walter et al. 2007, eqs. 14 and 17).
        let jacobian = if reflect {
            1.0 / (4.0 * wi_h.abs())
        } else {
            let denom = wo_h + eta_path * wi_h;
            (eta_path * eta_path * wi_h / (denom * denom)).abs()
        };
        let mut pdf = 0.0;
        if reflect {
            pdf += p_diffuse * warp::cosine_hemisphere_pdf(wi);
        }
        if facet_compatible(h, wo, wi, reflect) {
            let wo_up = wo * sign(wo.z);
            let specular = if reflect { p_reflect } else { p_trans };
            pdf += specular * self.distribution().pdf_visible(wo_up, h) * jacobian;
            if reflect && p_clearcoat > 0.0 {
                pdf += p_clearcoat * self.clearcoat_distribution().pdf(h) * jacobian;
            }
        }
        pdf
    }

    /// Samples `wi` as Mitsuba 3 does (module docs): `u_lobe` picks the
    /// lobe, `u` both the GGX visible normal (which sets F) and then the
    /// chosen lobe's direction. Value and density come from `eval` and
    /// `pdf` of the final pair. `None` when the chosen lobe leaves on the
    /// wrong side or the pair has no density.
    // Out of line: keeps `Bsdf`'s dispatch small enough to inline for
    // the other models.
    #[inline(never)]
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
        let (w_diffuse, w_trans) = self.weights();
        let front = wo.z > 0.0;
        if !front && w_trans <= 0.0 {
            return None;
        }
        let m = self.distribution().sample_visible(wo * sign(wo.z), u);
        let fr = fresnel::dielectric(wo.dot(m), self.eta);
        let [p_diffuse, p_clearcoat, p_trans, _] =
            lobe_probabilities(front, w_diffuse, w_trans, self.clearcoat, fr.reflectance);
        let (wi, eta) = if u_lobe < p_diffuse {
            (warp::square_to_cosine_hemisphere(u), 1.0)
        } else if u_lobe < p_diffuse + p_clearcoat {
            let mc = self.clearcoat_distribution().sample(u);
            let wi = reflect(wo, mc);
            if wi.z * wo.z <= 0.0 || !facet_compatible(mc, wo, wi, true) {
                return None;
            }
            (wi, 1.0)
        } else if u_lobe < p_diffuse + p_clearcoat + p_trans {
            if fr.cos_t == 0.0 {
                return None;
            }
            // Snell's law about m, as in the rough dielectric.
            let wi = (m * (wo.dot(m) * fr.eta_ti + fr.cos_t) - wo * fr.eta_ti).normalize_or_zero();
            if wi.z * wo.z >= 0.0 || !facet_compatible(m, wo, wi, false) {
                return None;
            }
            (wi, fr.eta_it)
        } else {
            let wi = reflect(wo, m);
            if wi.z * wo.z <= 0.0 || !facet_compatible(m, wo, wi, true) {
                return None;
            }
            (wi, 1.0)
        };
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(BsdfSample {
            wi,
            f: self.eval(wo, wi, mode),
            pdf,
            delta: false,
            eta,
        })
    }
}
