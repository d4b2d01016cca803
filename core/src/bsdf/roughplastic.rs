//! Rough plastic (Mitsuba 3's `roughplastic`): a microfacet dielectric
//! coating over a Lambertian base.
//!
//! The coating reflects like a rough conductor with the dielectric Fresnel
//! term (Walter et al. 2007: f_s = F(wo·m) D(m) G1(wo) G1(wi) /
//! (4 cos θo cos θi)); the base's light passes the rough interface twice,
//! and, as in Mitsuba 3, the smooth plastic's diffuse formula is kept with
//! the Fresnel transmittances replaced by the rough interface's directional
//! transmittance t(cos θ) and F_dr by the rough interface's internal
//! diffuse reflectance (Kelemen & Szirmay-Kalos 2001 use the same
//! approximation):
//!
//!   f_d = ρ / (1 − R_int) · t(cos θo) t(cos θi) / (η² π).
//!
//! t and R_int are integrals over visible microfacet normals computed once
//! per material: the [`RoughCoating`] table, which this module declares,
//! computes ([`RoughCoating::new`]) and interpolates, and which a rough
//! plastic material holds; the lobe choice follows Mitsuba: P_spec ∝
//! (1 − t(cos θo))·w_s, P_diff ∝ t(cos θo)·(1 − w_s).
//!
//! The table's type is built in every build (every build's materials name
//! it); the model and the table's computation only with `coating`.

use glam::{Vec2, Vec3};

use super::microfacet::{Distribution, Microfacet};
use super::{BsdfSample, diffuse, fresnel};
use crate::math::{INV_PI, Rgb, warp};

/// What the diffuse part of a rough plastic needs of its coating, precomputed
/// per material (Mitsuba's `roughplastic` does the same at load time): the
/// rough interface's transmittance t(cos θ) into the coating at a few
/// cosines, and the base's internal reflectance (the hemispherical average
/// of the interface's reflectance seen from inside).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughCoating {
    /// t at [`RoughCoating::node`] k, as a 16-bit fraction of 1.
    pub(super) transmittance: [u16; RoughCoating::NODES],
    /// Internal diffuse reflectance in [0, 1].
    pub(super) internal_reflectance: f32,
}

impl RoughCoating {
    /// Number of tabulated cosines (kept small: the table rides in every
    /// resolved BSDF, which must stay small).
    pub const NODES: usize = 8;

    /// The k-th tabulated cosine: quadratically spaced, dense near grazing
    /// where t changes fastest.
    #[inline]
    pub fn node(k: usize) -> f32 {
        let x = k as f32 / (Self::NODES - 1) as f32;
        x * x
    }

    /// Integrates the coating's transmittance and internal reflectance for
    /// `distribution`, roughness `alpha` and relative index `eta` over the
    /// visible microfacet normals, as Mitsuba's `roughplastic` does. Takes
    /// a few milliseconds: call once per material. Without the `coating`
    /// feature the table is empty (such a material is refused by the scene
    /// builder anyway).
    pub fn new(distribution: Distribution, alpha: f32, eta: f32) -> Self {
        #[cfg(feature = "coating")]
        {
            rough_coating(distribution, alpha, eta)
        }
        #[cfg(not(feature = "coating"))]
        {
            let _ = (distribution, alpha, eta);
            RoughCoating {
                transmittance: [0; Self::NODES],
                internal_reflectance: 0.0,
            }
        }
    }

    /// The internal diffuse reflectance.
    pub fn internal_reflectance(&self) -> f32 {
        self.internal_reflectance
    }

    /// Transmittance into the coating at cosine `cos` (linear
    /// interpolation of the table).
    #[inline]
    pub fn transmittance(&self, cos: f32) -> f32 {
        coating_lerp(&self.transmittance, cos)
    }
}

/// Linear interpolation of a [`RoughCoating`] table at cosine `cos`.
#[inline]
fn coating_lerp(t: &[u16; RoughCoating::NODES], cos: f32) -> f32 {
    let c = cos.clamp(0.0, 1.0);
    // Nodes are (k/(n−1))², so the interval is found from √cos.
    let x = libm::sqrtf(c) * (RoughCoating::NODES - 1) as f32;
    let k = (x as usize).min(RoughCoating::NODES - 2);
    let (a, b) = (RoughCoating::node(k), RoughCoating::node(k + 1));
    let w = ((c - a) / (b - a)).clamp(0.0, 1.0);
    let (ta, tb) = (t[k] as f32, t[k + 1] as f32);
    (ta + w * (tb - ta)) * (1.0 / 65535.0)
}

/// The parameters of a resolved rough plastic (kept small: it rides in
/// every [`super::Bsdf`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct RoughPlastic {
    pub mf: Microfacet,
    pub eta: f32,
    /// Mitsuba's `specular_sampling_weight`.
    pub spec_weight: f32,
    /// ρ/(1 − R_int)/η² (see `plastic::base_factor`).
    pub diffuse: Rgb,
    /// Multiplier of the coating's reflection.
    pub specular: Rgb,
    /// The coating's transmittance table ([`RoughCoating`]).
    pub t: [u16; RoughCoating::NODES],
}

impl RoughPlastic {
    /// Probability of sampling the coating lobe given cos θo.
    #[inline]
    fn prob_specular(&self, cos_o: f32) -> f32 {
        let t = coating_lerp(&self.t, cos_o);
        let ps = (1.0 - t) * self.spec_weight;
        let pd = t * (1.0 - self.spec_weight);
        let sum = ps + pd;
        if sum > 0.0 { ps / sum } else { 1.0 }
    }

    /// f_s + f_d (upper hemisphere only).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let m = (wo + wi).normalize();
        let d = self.mf.d(m);
        let mut f = Rgb::ZERO;
        if d > 0.0 {
            let fr = fresnel::dielectric(wo.dot(m), self.eta).reflectance;
            let g = self.mf.g1(wo, m) * self.mf.g1(wi, m);
            f = self.specular * (fr * d * g / (4.0 * wo.z * wi.z));
        }
        let t = coating_lerp(&self.t, wo.z) * coating_lerp(&self.t, wi.z);
        f + self.diffuse * (t * INV_PI)
    }

    /// P_spec · (visible-normal density of the reflection) + P_diff ·
    /// cos θi/π.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let ps = self.prob_specular(wo.z);
        let m = (wo + wi).normalize();
        // D_wo(m)/(4 wo·m) = G1(wo) D(m)/(4 cos θo) (Heitz 2018, §3).
        let spec = self.mf.g1(wo, m) * self.mf.d(m) / (4.0 * wo.z);
        ps * spec + (1.0 - ps) * diffuse::pdf(wo, wi)
    }

    /// Picks the coating (`u_lobe < P_spec`: a visible normal, reflected)
    /// or the base (cosine sampling); `f` and `pdf` are the full `eval`
    /// and `pdf` of the direction, as for every non-delta sample.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.prob_specular(wo.z) {
            let m = self.mf.sample_visible(wo, u);
            (2.0 * wo.dot(m) * m - wo).normalize_or_zero()
        } else {
            warp::square_to_cosine_hemisphere(u)
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(BsdfSample {
            wi,
            f: self.eval(wo, wi),
            pdf,
            delta: false,
            eta: 1.0,
        })
    }
}

/// Gauss–Legendre nodes and weights on [0, 1] with `n` points (Newton's
/// method on the Legendre polynomial, in f64).
fn gauss_legendre(n: usize, nodes: &mut [f64], weights: &mut [f64]) {
    for i in 0..n {
        // Tricomi's initial guess for the i-th root of P_n.
        let mut x = libm::cos(core::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5));
        let mut dp = 1.0;
        for _ in 0..100 {
            // P_n(x) and P_n'(x) by the three-term recurrence.
            let (mut p0, mut p1) = (1.0f64, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        // Map [−1, 1] to [0, 1].
        nodes[i] = 0.5 * (1.0 - x);
        weights[i] = 1.0 / ((1.0 - x * x) * dp * dp);
    }
}

/// Most quadrature points per axis (Mitsuba uses 32, or 128 seen from the
/// inside where total internal reflection makes the integrand jump; 64 keeps
/// the precomputation to milliseconds at a change of < 0.1% in R_int).
const MAX_QUAD: usize = 64;

/// E over visible normals m ~ D_wo of `g(wo, m)`, by Gauss–Legendre
/// cubature over the sampler's unit square (as Mitsuba's
/// `eval_transmittance`/`eval_reflectance` do).
fn visible_average(
    mf: &Microfacet,
    wo: Vec3,
    n: usize,
    nodes: &[f64],
    weights: &[f64],
    g: impl Fn(Vec3, Vec3) -> f64,
) -> f64 {
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let m = mf.sample_visible(wo, Vec2::new(nodes[i] as f32, nodes[j] as f32));
            sum += weights[i] * weights[j] * g(wo, m);
        }
    }
    sum
}

/// The [`RoughCoating`] of a rough dielectric interface: for each table
/// cosine μ, t(μ) = E_m[(1 − F(wo·m)) G1(wt, m)] with wt the refracted
/// direction (Mitsuba's `eval_transmittance`), and the internal diffuse
/// reflectance 2·mean_μ[μ R(μ)] over 64 evenly spaced μ seen from inside,
/// with R(μ) = E_m[F(wo·m, 1/η) G1(wr, m)] over reflected directions wr
/// above the surface (Mitsuba's `eval_reflectance` and its average).
fn rough_coating(distribution: Distribution, alpha: f32, eta: f32) -> RoughCoating {
    let mf = Microfacet::new(distribution, alpha);
    let mut nodes = [0.0f64; MAX_QUAD];
    let mut weights = [0.0f64; MAX_QUAD];
    let dir = |mu: f32| {
        let mu = mu.max(1e-6);
        Vec3::new(libm::sqrtf(1.0 - mu * mu), 0.0, mu)
    };

    let n = 32;
    gauss_legendre(n, &mut nodes, &mut weights);
    let mut transmittance = [0u16; RoughCoating::NODES];
    for (k, t) in transmittance.iter_mut().enumerate() {
        let wo = dir(RoughCoating::node(k));
        let v = visible_average(&mf, wo, n, &nodes, &weights, |wo, m| {
            let fr = fresnel::dielectric(wo.dot(m), eta);
            if fr.cos_t == 0.0 {
                return 0.0;
            }
            // Refraction about m (Walter et al. 2007, eq. 40), below the
            // macrosurface: wt = (η_ti (wo·m) + cos θt) m − η_ti wo with
            // cos θt ≤ 0 on the far side.
            let c = wo.dot(m);
            let wt = (fr.eta_ti * c + fr.cos_t) * m - fr.eta_ti * wo;
            if wt.z * wo.z >= 0.0 {
                return 0.0;
            }
            ((1.0 - fr.reflectance) * mf.g1(wt, m)) as f64
        });
        *t = (v.clamp(0.0, 1.0) * 65535.0 + 0.5) as u16;
    }

    let n = MAX_QUAD;
    gauss_legendre(n, &mut nodes, &mut weights);
    let inv_eta = 1.0 / eta;
    let res = 64;
    let mut r_int = 0.0;
    for k in 0..res {
        let mu = k as f32 / (res - 1) as f32;
        let wo = dir(mu);
        let r = visible_average(&mf, wo, n, &nodes, &weights, |wo, m| {
            let wr = 2.0 * wo.dot(m) * m - wo;
            if wr.z <= 0.0 {
                return 0.0;
            }
            (fresnel::dielectric(wo.dot(m), inv_eta).reflectance * mf.g1(wr, m)) as f64
        });
        r_int += r * wo.z as f64;
    }
    RoughCoating {
        transmittance,
        internal_reflectance: (2.0 * r_int / res as f64).clamp(0.0, 0.999) as f32,
    }
}
