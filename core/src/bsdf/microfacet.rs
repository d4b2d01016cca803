//! Isotropic microfacet distributions (Beckmann, GGX) with Smith masking and
//! visible-normal sampling.
//!
//! Notation follows Heitz 2014, "Understanding the Masking-Shadowing
//! Function in Microfacet-Based BRDFs" (JCGT 3(2)): D(m) is the normal
//! distribution, Λ(v) the Smith auxiliary function, G1(v) = 1/(1 + Λ(v)) and
//! D_v(m) = G1(v) ⟨v·m⟩ D(m) / cos θv the distribution of visible normals,
//! which integrates to one over the hemisphere of m for every v.
//!
//! Both samplers draw exactly from D_v, so G1(wo) D(m) / (4 cos θo), the
//! density of the reflected direction (see `conductor.rs`), is the true
//! sampling density; it enters MIS weights and Metropolis transition
//! densities. For Beckmann this requires the exact, erfc-based Λ; Mitsuba
//! evaluates G1 with a rational fit instead (< 0.35 % off) — see `g1`.

use glam::{Vec2, Vec3};

use crate::math::{PI, safe_sqrt};

/// Microfacet normal distribution of a rough conductor, plastic or
/// dielectric.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    /// Beckmann–Spizzichino.
    Beckmann,
    /// GGX / Trowbridge–Reitz.
    Ggx,
}

/// Smallest α used: below it D(m) of a perfectly aligned normal,
/// 1/(π α²), would approach the f32 range and the lobe is a mirror for any
/// practical purpose anyway.
pub(crate) const MIN_ALPHA: f32 = 1e-4;

/// √π.
const SQRT_PI: f32 = 1.772_453_9;
/// 1/√π.
const INV_SQRT_PI: f32 = 0.564_189_6;

/// An isotropic microfacet normal distribution with roughness α.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Microfacet {
    pub(crate) dist: Distribution,
    pub(crate) alpha: f32,
}

impl Microfacet {
    /// `alpha` is clamped to at least [`MIN_ALPHA`] (NaN becomes MIN_ALPHA,
    /// since `f32::max` ignores NaN).
    pub(crate) fn new(dist: Distribution, alpha: f32) -> Self {
        Microfacet {
            dist,
            alpha: alpha.max(MIN_ALPHA),
        }
    }

    /// D(m) per unit solid angle of m (normalised so ∫ D(m) cos θm dm = 1).
    pub(crate) fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let xy2 = m.x * m.x + m.y * m.y;
        let z2 = m.z * m.z;
        let d = match self.dist {
            // Walter et al. 2007, §5.1: exp(−tan²θ/α²) / (π α² cos⁴θ),
            // with tan²θ from the vector to avoid cancellation in 1 − cos².
            Distribution::Beckmann => {
                let e = libm::expf(-xy2 / (z2 * a2));
                if e == 0.0 {
                    return 0.0;
                }
                e / (PI * a2 * z2 * z2)
            }
            // Walter et al. 2007, §5.3, rewritten with unit m:
            // cos⁴θ (1 + tan²θ/α²)² = (xy²/α² + z²)², which stays finite and
            // exact for tiny α instead of forming tan²θ/α².
            Distribution::Ggx => {
                let t = xy2 / a2 + z2;
                1.0 / (PI * a2 * t * t)
            }
        };
        if d.is_finite() { d } else { 0.0 }
    }

    /// Smith G1(v, m): the fraction of microfacets with normal m visible
    /// from v. Zero when v sees the back of m (the χ⁺ factor of Heitz 2014).
    ///
    /// Beckmann uses the exact Λ (Walter et al. 2007, §5.1) because the
    /// sampler draws from the exact D_v; Mitsuba uses Walter's rational
    /// approximation instead, which differs by < 0.35 %.
    pub(crate) fn g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let xy2 = v.x * v.x + v.y * v.y;
        if xy2 == 0.0 {
            return 1.0; // normal incidence: nothing is shadowed
        }
        match self.dist {
            Distribution::Beckmann => {
                // a = 1/(α tan θ).
                let a = v.z.abs() / (self.alpha * libm::sqrtf(xy2));
                1.0 / (1.0 + beckmann_lambda(a))
            }
            Distribution::Ggx => {
                // Λ = (−1 + √(1 + α² tan²θ))/2 (Walter et al. 2007, §5.3;
                // Heitz 2014, §5.3), so G1 = 2 / (1 + √(1 + α² tan²θ)); an
                // infinite tan²θ (v in the plane) correctly gives 0.
                let t2 = self.alpha * self.alpha * xy2 / (v.z * v.z);
                2.0 / (1.0 + libm::sqrtf(1.0 + t2))
            }
        }
    }

    /// Samples a microfacet normal from D_wo(m) (`wo.z > 0`).
    pub(crate) fn sample_visible(&self, wo: Vec3, u: Vec2) -> Vec3 {
        match self.dist {
            Distribution::Ggx => self.sample_ggx(wo, u),
            Distribution::Beckmann => self.sample_beckmann(wo, u),
        }
    }

    /// GGX visible normals, Heitz 2018, "Sampling the GGX Distribution of
    /// Visible Normals" (JCGT 7(4)), §4: stretch wo to the α = 1
    /// configuration, where the visible normals are those of a hemisphere;
    /// sample the hemisphere's projected disk (a half disk warped to account
    /// for the part hidden by the hemisphere's own projection), lift to the
    /// hemisphere, unstretch.
    fn sample_ggx(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        let vh = Vec3::new(a * wo.x, a * wo.y, wo.z).normalize();
        // Orthonormal basis around vh with t1 horizontal. At normal incidence
        // any horizontal t1 works.
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 {
            Vec3::new(-vh.y, vh.x, 0.0) / libm::sqrtf(len2)
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        // Uniform point on the unit disk (polar map; continuity in u matters
        // more to Metropolis mutations than the concentric map's lower
        // distortion).
        let r = libm::sqrtf(u.x);
        let phi = 2.0 * PI * u.y;
        let p1 = r * libm::cosf(phi);
        let p2 = r * libm::sinf(phi);
        // Heitz 2018, §4: the lower half of the disk is squashed towards the
        // part of the projected hemisphere not hidden by its own outline;
        // s = (1 + cos θ_vh)/2.
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * safe_sqrt(1.0 - p1 * p1) + s * p2;
        let nh = t1 * p1 + t2 * p2 + vh * safe_sqrt(1.0 - p1 * p1 - p2 * p2);
        // Unstretch: normals transform with the inverse transpose, i.e.
        // (α x, α y, z) for the stretch (x/α, y/α, z) of the surface.
        Vec3::new(a * nh.x, a * nh.y, nh.z.max(0.0)).normalize()
    }

    /// Beckmann visible normals by the slope-space method of Heitz & d'Eon
    /// 2014, "Importance Sampling Microfacet-Based BSDFs using the
    /// Distribution of Visible Normals" (EGSR), §4 and appendix: stretch wo
    /// to α = 1, draw the visible slopes (x̃, ỹ) for an incident direction at
    /// azimuth 0, rotate to wo's azimuth, unstretch the slopes by α.
    ///
    /// For α = 1 Beckmann the slope density is P22(x, y) = e^{−x²−y²}/π,
    /// and visibility weighs it by (cos θ − x̃ sin θ)⁺, so x̃ and ỹ are
    /// independent: ỹ has density e^{−y²}/√π and x̃ density
    /// ∝ (cos θ − x sin θ) e^{−x²} on x < cot θ. Both are drawn by inverting
    /// their CDFs numerically ([`visible_slope`]), which keeps the map from
    /// `u` continuous and monotone (as Metropolis mutations need) and exact
    /// to f32 precision.
    fn sample_beckmann(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        let ws = Vec3::new(a * wo.x, a * wo.y, wo.z).normalize();
        let sin_t = libm::sqrtf(ws.x * ws.x + ws.y * ws.y);
        let cos_t = ws.z;
        let (cos_phi, sin_phi) = if sin_t > 0.0 {
            (ws.x / sin_t, ws.y / sin_t)
        } else {
            (1.0, 0.0)
        };
        let xs = visible_slope(u.x, cos_t, sin_t);
        let ys = normal_slope(u.y);
        // Rotate the slope vector from azimuth 0 to wo's azimuth, unstretch.
        let x = a * (cos_phi * xs - sin_phi * ys);
        let y = a * (sin_phi * xs + cos_phi * ys);
        // A facet with slopes (x, y) has normal ∝ (−x, −y, 1).
        Vec3::new(-x, -y, 1.0).normalize()
    }
}

/// An anisotropic GGX distribution with roughnesses (αx, αy) along the
/// shading frame's x and y axes: the principled BSDF's main lobe (Mitsuba
/// 3's `MicrofacetDistribution` with `alpha_u`, `alpha_v`, visible-normal
/// sampling on). With αx = αy it is [`Microfacet`]'s GGX.
#[cfg(feature = "principled")]
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct AnisoGgx {
    pub(crate) ax: f32,
    pub(crate) ay: f32,
}

#[cfg(feature = "principled")]
impl AnisoGgx {
    /// D(m) = 1 / (π αx αy (mx²/αx² + my²/αy² + mz²)²) (Heitz 2014, eq. 85),
    /// normalised so that ∫ D(m) cos θm dm = 1; zero below the plane.
    pub(crate) fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let t = m.x * m.x / (self.ax * self.ax) + m.y * m.y / (self.ay * self.ay) + m.z * m.z;
        let d = 1.0 / (PI * self.ax * self.ay * t * t);
        if d.is_finite() { d } else { 0.0 }
    }

    /// Smith G1(v, m) = 2 / (1 + √(1 + α(φ)² tan²θ)) with
    /// α(φ)² tan²θ = ((αx vx)² + (αy vy)²)/vz² (Heitz 2014, §5.3); zero
    /// when v sees the back of m.
    pub(crate) fn g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let xy = (self.ax * v.x) * (self.ax * v.x) + (self.ay * v.y) * (self.ay * v.y);
        if xy == 0.0 {
            return 1.0;
        }
        2.0 / (1.0 + libm::sqrtf(1.0 + xy / (v.z * v.z)))
    }

    /// The visible-normal density D_v(m) = G1(v, m) |v·m| D(m) / cos θv of
    /// [`AnisoGgx::sample_visible`] (`v.z > 0`).
    pub(crate) fn pdf_visible(&self, v: Vec3, m: Vec3) -> f32 {
        self.g1(v, m) * v.dot(m).abs() * self.d(m) / v.z
    }

    /// Samples m from D_v (`v.z > 0`): Heitz 2018's stretch–sample–unstretch
    /// with the stretch (αx, αy) (see [`Microfacet::sample_visible`]).
    pub(crate) fn sample_visible(&self, v: Vec3, u: Vec2) -> Vec3 {
        let vh = Vec3::new(self.ax * v.x, self.ay * v.y, v.z).normalize();
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 {
            Vec3::new(-vh.y, vh.x, 0.0) / libm::sqrtf(len2)
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        let r = libm::sqrtf(u.x);
        let phi = 2.0 * PI * u.y;
        let p1 = r * libm::cosf(phi);
        let p2 = r * libm::sinf(phi);
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * safe_sqrt(1.0 - p1 * p1) + s * p2;
        let nh = t1 * p1 + t2 * p2 + vh * safe_sqrt(1.0 - p1 * p1 - p2 * p2);
        Vec3::new(self.ax * nh.x, self.ay * nh.y, nh.z.max(0.0)).normalize()
    }
}

/// Burley's GTR1 ("generalised Trowbridge–Reitz", γ = 1) distribution of
/// the principled BSDF's clearcoat (Burley 2012, "Physically Based Shading
/// at Disney", appendix B): D(m) = (α² − 1) / (π ln α² (1 + (α² − 1) cos²θ)),
/// sampled from D(m) cos θm (not visible normals, as Mitsuba 3: the lobe
/// is weak and mostly sharp).
#[cfg(feature = "principled")]
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Gtr1 {
    pub(crate) alpha: f32,
}

#[cfg(feature = "principled")]
impl Gtr1 {
    /// D(m), zero where D cos θm underflows (as Mitsuba, below 1e-20).
    pub(crate) fn d(&self, m: Vec3) -> f32 {
        let a2 = self.alpha * self.alpha;
        let d = (a2 - 1.0) / (PI * libm::logf(a2) * (1.0 + (a2 - 1.0) * m.z * m.z));
        if d * m.z > 1e-20 { d } else { 0.0 }
    }

    /// Density of [`Gtr1::sample`]: D(m) cos θm.
    pub(crate) fn pdf(&self, m: Vec3) -> f32 {
        if m.z < 0.0 { 0.0 } else { m.z * self.d(m) }
    }

    /// Inverts the CDF of D cos θ: cos²θ = (1 − α^{2(1−u)}) / (1 − α²).
    pub(crate) fn sample(&self, u: Vec2) -> Vec3 {
        let phi = 2.0 * PI * u.x;
        let a2 = self.alpha * self.alpha;
        let cos2 = (1.0 - libm::powf(a2, 1.0 - u.y)) / (1.0 - a2);
        let sin = safe_sqrt(1.0 - cos2);
        Vec3::new(
            libm::cosf(phi) * sin,
            libm::sinf(phi) * sin,
            safe_sqrt(cos2),
        )
    }
}

/// Smith Λ of the Beckmann distribution as a function of a = 1/(α tan θ)
/// (Walter et al. 2007, §5.1, before their rational fit):
/// Λ = (erf(a) − 1)/2 + e^{−a²}/(2a√π), written with erfc to keep the
/// relative precision of the two small terms for large a.
fn beckmann_lambda(a: f32) -> f32 {
    if a == 0.0 {
        return f32::INFINITY;
    }
    if a >= 3.5 {
        // Λ ≈ e^{−a²}/(4a³√π) < 1.6e-8 here, under half an ulp of 1, so
        // G1 = 1/(1 + Λ) rounds to 1 anyway: skip erfc and exp.
        return 0.0;
    }
    let l = 0.5 * (libm::expf(-a * a) * INV_SQRT_PI / a - libm::erfcf(a));
    l.max(0.0)
}

/// Half-width of the slope interval searched by the inversions, in α = 1
/// slope units. The probability mass outside is below erfc(6) ≈ 2e-17, far
/// below what f32 inputs can resolve.
const SLOPE_MAX: f32 = 6.0;

/// Unnormalised CDF of the α = 1 Beckmann visible slope x̃ for an incident
/// direction with cos θ = `ct`, sin θ = `st`, and its first two derivatives
/// (for Halley's method), sharing one exponential:
///
///   C(x)   = ∫_{−∞}^{x} (ct − t·st) e^{−t²} dt
///          = ct (√π/2) erfc(−x) + st e^{−x²}/2,      x ≤ cot θ,
///   C'(x)  = (ct − x·st) e^{−x²},
///   C''(x) = −st e^{−x²} − 2x C'(x).
///
/// Multiplying the density by sin θ (instead of writing it as
/// cot θ − x) keeps C bounded at both normal and grazing incidence.
#[inline]
fn slope_cdf(x: f32, ct: f32, st: f32) -> (f32, f32, f32) {
    let e = libm::expf(-x * x);
    let d = (ct - x * st) * e;
    (
        ct * (0.5 * SQRT_PI) * libm::erfcf(-x) + st * 0.5 * e,
        d,
        -st * e - 2.0 * x * d,
    )
}

/// Slope with density e^{−y²}/√π (a normal with variance ½) at quantile `u`.
///
/// The distribution is symmetric, so only the lower half is solved, where
/// the quantile p = min(u, 1 − u) and the CDF are both small and f32 keeps
/// their relative precision. From the Abramowitz & Stegun guess (error
/// < 3.2e-4 here), one Halley step on (1/2) erfc(−y) = p leaves an error
/// of order 10⁻⁹ (cubic convergence), below f32 resolution, so no residual
/// check is needed.
fn normal_slope(u: f32) -> f32 {
    let p = if u > 0.5 { 1.0 - u } else { u };
    let g = normal_slope_guess(p);
    let r = 0.5 * libm::erfcf(-g) - p;
    let d = libm::expf(-g * g) * INV_SQRT_PI;
    // Halley with C'' = −2y C' for this density.
    let y = g - 2.0 * r * d / (2.0 * d * d + 2.0 * g * d * r);
    let y = if y.is_finite() { y } else { g };
    if u > 0.5 { -y } else { y }
}

/// Initial guess for the quantile of e^{−y²}/√π: the inverse normal CDF
/// approximation of Abramowitz & Stegun 26.2.23 (|error| < 4.5e-4 in
/// standard deviations), scaled by 1/√2 to unit-α slopes.
fn normal_slope_guess(u: f32) -> f32 {
    let (p, sign) = if u < 0.5 { (u, -1.0) } else { (1.0 - u, 1.0) };
    let t = libm::sqrtf(-2.0 * libm::logf(p.max(1e-30)));
    let num = 2.515_517 + t * (0.802_853 + t * 0.010_328);
    let den = 1.0 + t * (1.432_788 + t * (0.189_269 + t * 0.001_308));
    sign * (t - num / den) * core::f32::consts::FRAC_1_SQRT_2
}

/// The quantile `u` ∈ [0, 1) of the visible slope x̃ (see [`slope_cdf`]):
/// solves C(x) = u·C(cot θ) by Halley's method safeguarded by bisection
/// (the bracket always holds the root since C increases on x < cot θ).
///
/// Two closed-form guesses bracket the behaviour: the normal quantile
/// (exact at θ = 0) and −√(−ln u), the exact root at θ = 90° where
/// C(x)/C(0) = e^{−x²}. One or two Halley steps typically follow.
fn visible_slope(u: f32, ct: f32, st: f32) -> f32 {
    // Upper end cot θ, clamped where the remaining mass is negligible.
    let hi0 = if st * SLOPE_MAX < ct {
        SLOPE_MAX
    } else {
        ct / st
    };
    // When the upper end is clamped, C(6) = ct√π + st e^{−36}/2 equals ct√π
    // in f32 (erfc(−6) rounds to 2): no evaluation needed.
    let total = if hi0 == SLOPE_MAX {
        ct * SQRT_PI
    } else {
        slope_cdf(hi0, ct, st).0
    };
    let target = u * total;
    let (mut lo, mut hi) = (-SLOPE_MAX, hi0);
    // Stop once the CDF matches to a few ulps of its range, beyond which
    // f32 evaluation noise dominates.
    let tol = 3e-7 * total;

    // The Rayleigh-type part of the density carries a mass fraction of
    // about st / (st + 2√π ct): evaluate whichever guess applies, or both
    // in between, and keep the better.
    let use_normal = st < 8.0 * ct;
    let use_rayleigh = ct < 0.5 * st;
    // Best point so far: (x, C(x) − target, C'(x), C''(x)).
    let mut best = (0.0f32, f32::INFINITY, 0.0f32, 0.0f32);
    let mut try_guess = |g: f32, lo: &mut f32, hi: &mut f32| {
        let g = g.clamp(*lo, *hi);
        let (c, d, d2) = slope_cdf(g, ct, st);
        let r = c - target;
        if r > 0.0 {
            *hi = g;
        } else {
            *lo = g;
        }
        if r.abs() < best.1.abs() {
            best = (g, r, d, d2);
        }
    };
    if use_normal {
        try_guess(normal_slope_guess(u), &mut lo, &mut hi);
    }
    if use_rayleigh || !use_normal {
        try_guess(-libm::sqrtf(-libm::logf(u.max(1e-30))), &mut lo, &mut hi);
    }
    let (mut x, mut r, mut d, mut d2) = best;
    for _ in 0..32 {
        if r.abs() <= tol || hi - lo <= 1e-6 * (1.0 + x.abs()) {
            break;
        }
        // Halley: x − 2 r C' / (2 C'² − r C''); bisect whenever the step
        // leaves the bracket (including NaN from a vanishing C').
        let mut next = x - 2.0 * r * d / (2.0 * d * d - r * d2);
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        x = next;
        let (c, dc, dc2) = slope_cdf(x, ct, st);
        (r, d, d2) = (c - target, dc, dc2);
        if r > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f64 reference of the normalised visible-slope CDF.
    fn cdf64(x: f64, ct: f64, st: f64) -> f64 {
        let c = |x: f64| {
            ct * 0.5 * core::f64::consts::PI.sqrt() * libm::erfc(-x) + st * 0.5 * (-x * x).exp()
        };
        let hi = if st * 6.0 < ct { 6.0 } else { ct / st };
        c(x) / c(hi)
    }

    #[test]
    fn visible_slope_inverts_its_cdf() {
        // The sampler is exact only if the inversion is: compare the CDF of
        // the returned slope with u over the whole range of θ and u.
        for &theta in &[0.0f32, 1e-4, 0.2, 0.7, 1.0, 1.3, 1.5, 1.565, 1.5705] {
            let (st, ct) = (libm::sinf(theta), libm::cosf(theta));
            let mut worst = 0.0f64;
            let n = 4000;
            for i in 0..n {
                let u = (i as f32 + 0.5) / n as f32;
                let x = visible_slope(u, ct, st);
                assert!(x.is_finite());
                worst = worst.max((cdf64(x as f64, ct as f64, st as f64) - u as f64).abs());
            }
            assert!(worst < 1e-6, "theta {theta}: CDF error {worst}");
        }
        for i in 0..4000 {
            let u = (i as f32 + 0.5) / 4000.0;
            let y = normal_slope(u) as f64;
            let cdf = 0.5 * libm::erfc(-y);
            assert!((cdf - u as f64).abs() < 2e-7, "u {u}: {cdf}");
        }
        // Extremes of the input must stay finite.
        for u in [0.0f32, 1e-30, 1.0 - f32::EPSILON] {
            assert!(visible_slope(u, 0.6, 0.8).is_finite() && normal_slope(u).is_finite());
        }
    }
}
