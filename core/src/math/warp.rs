//! Warps from the unit square to sampling domains, each with its density.
//!
//! Every warp's density is stated in the measure of its target domain; the
//! tests integrate them and compare histograms against the density, because
//! these densities enter the MIS weights and the Metropolis transition
//! densities T(x→y).

use glam::{Vec2, Vec3};

use super::{INV_PI, PI, safe_sqrt};

/// Concentric map of the square onto the unit disk (Shirley & Chiu 1997);
/// area-preserving up to a constant, so the density is 1/π.
#[inline]
pub fn square_to_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let o = u * 2.0 - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, (PI / 4.0) * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - (PI / 4.0) * (o.x / o.y))
    };
    Vec2::new(r * libm::cosf(theta), r * libm::sinf(theta))
}

/// Cosine-weighted hemisphere around +z (Malley's method).
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_uniform_disk_concentric(u);
    let z = safe_sqrt(1.0 - d.x * d.x - d.y * d.y);
    Vec3::new(d.x, d.y, z)
}

/// Density of [`square_to_cosine_hemisphere`] per unit solid angle.
#[inline]
pub fn cosine_hemisphere_pdf(v: Vec3) -> f32 {
    if v.z > 0.0 { v.z * INV_PI } else { 0.0 }
}

/// Uniform direction on the unit sphere; density 1/(4π).
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = safe_sqrt(1.0 - z * z);
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * libm::cosf(phi), r * libm::sinf(phi), z)
}

/// Uniform barycentrics (b1, b2) on a triangle (Heitz 2019, "A Low-Distortion
/// Map Between Triangle and Square"); density 1/area on the triangle.
#[inline]
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    let (mut b0, mut b1);
    if u.x < u.y {
        b0 = u.x / 2.0;
        b1 = u.y - b0;
    } else {
        b1 = u.y / 2.0;
        b0 = u.x - b1;
    }
    // Clamp rounding so the point never leaves the triangle.
    b0 = b0.clamp(0.0, 1.0);
    b1 = b1.clamp(0.0, 1.0 - b0);
    Vec2::new(b0, b1)
}

/// A 2-D isotropic Gaussian offset of standard deviation σ, truncated to
/// the disk of radius `r_max` ("clamped Gaussian", Segovia 2007, eq. 37, §2.4.1):
/// the perturbation density T of the lens, caustic and multi-chain perturbations.
///
/// ## Which truncation, and why the radius
///
/// The offset is conditioned on |d| ≤ r_max (a disk), not clamped per axis
/// nor onto the boundary:
/// - the density depends on |d| only, so for fixed σ and r_max the
///   perturbation is symmetric, T(x→y) = T(y→x), and its support is
///   symmetric too (Segovia 2007, eq. 31: T(x→y) > 0 ⇔ T(y→x) > 0);
/// - the radial distribution has a closed-form inverse CDF in `exp`/`log`
///   (below), so every candidate costs exactly two uniforms and no
///   rejection loop — a packet of k candidates stays in lockstep, and
///   stratified (jittered-grid) inputs map monotonically in the radius, the
///   Box–Muller-style map of Segovia 2007 (§2.4.2, fig. 13). A
///   per-axis (square) truncation would need erf⁻¹, which `libm` lacks;
/// - a bounded offset keeps the candidates of one step close together,
///   which is what makes them coherent.
///
/// Mapping the *clamped* value of an unbounded Gaussian onto the boundary
/// instead would put a point mass (probability e^(−r_max²/2σ²)) on the
/// circle, which no density describes: we condition, we do not clamp.
///
/// ## Normalisation (derivation)
///
/// The untruncated density is g(d) = exp(−|d|²/(2σ²)) / (2πσ²). Its mass
/// inside the disk, in polar coordinates (dA = r dr dφ):
///
/// ```text
///   Z = ∫₀^R ∫₀^{2π} g r dφ dr = ∫₀^R (r/σ²) e^{−r²/(2σ²)} dr
///     = 1 − e^{−R²/(2σ²)}           (R = r_max)
/// ```
///
/// so the clamped density is q(d) = e^{−|d|²/(2σ²)} / (2πσ² Z) on |d| ≤ R
/// and 0 outside; it integrates to 1 by construction. The radius has the
/// CDF F(r) = (1 − e^{−r²/(2σ²)}) / Z, inverted as
/// r = σ √(−2 ln(1 − u Z)); the angle is uniform, φ = 2π u₂. Check: the
/// density of (r, φ) is F′(r)/(2π) = r e^{−r²/(2σ²)} / (2πσ² Z), and
/// dividing by the Jacobian r gives q(d).
///
/// Segovia 2007's eq. 37, q = e^{−(x−μ)²/σ} / (2πσ), is not this: with the
/// exponent over σ its integral over the plane is πσ / (2πσ) = ½ (the
/// prefactor should be 1/(πσ)), and its width is √(σ/2) rather than the σ
/// the Box–Muller sampler of §2.4.2 draws with. Its division by ∫_Ω q
/// repairs the factor ½ but not the shape; the test
/// `clamped_gaussian_seed_eq37_is_wrong` shows both.
///
/// Numerics: Z and ln(1 − uZ) use `expm1`/`log1p`, so a disk much smaller
/// than σ (Z ≪ 1) keeps full precision. `r_max = ∞` is the untruncated
/// Gaussian (Z = 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClampedGaussian2 {
    sigma: f32,
    r_max: f32,
    /// r_max² with a few ulps of slack: a sample drawn at radius r_max may
    /// land a rounding error outside after cos/sin; it must still have
    /// density > 0, or its reverse move would look impossible (eq. 31).
    r_max2_slack: f32,
    inv_two_sigma2: f32,
    /// Z = 1 − e^{−R²/(2σ²)}: the untruncated Gaussian's mass in the disk.
    mass: f32,
    /// 1 / (2πσ² Z).
    norm: f32,
}

impl ClampedGaussian2 {
    /// The Gaussian of standard deviation `sigma` truncated to radius
    /// `r_max` (∞ for no truncation). `None` unless σ is positive and
    /// finite and r_max is positive (NaN is rejected).
    pub fn new(sigma: f32, r_max: f32) -> Option<Self> {
        if !(sigma > 0.0 && sigma.is_finite() && r_max > 0.0) {
            return None;
        }
        let inv_two_sigma2 = 0.5 / (sigma * sigma);
        if !inv_two_sigma2.is_finite() {
            return None;
        }
        // Z = 1 − e^{−R²/(2σ²)} = −expm1(−R²/(2σ²)); ∞ gives 1.
        let mass = -libm::expm1f(-(r_max * r_max) * inv_two_sigma2);
        if !(mass > 0.0) {
            return None;
        }
        let norm = inv_two_sigma2 / (PI * mass);
        Some(ClampedGaussian2 {
            sigma,
            r_max,
            r_max2_slack: r_max * r_max * (1.0 + 8.0 * f32::EPSILON),
            inv_two_sigma2,
            mass,
            norm,
        })
    }

    /// Standard deviation σ of the untruncated Gaussian (per axis).
    #[inline]
    pub fn sigma(&self) -> f32 {
        self.sigma
    }

    /// Truncation radius.
    #[inline]
    pub fn r_max(&self) -> f32 {
        self.r_max
    }

    /// Z: the probability that the untruncated Gaussian falls in the disk.
    #[inline]
    pub fn mass(&self) -> f32 {
        self.mass
    }

    /// Radius for a uniform `u` in [0, 1) by the inverse radial CDF
    /// (monotonic in `u`; 0 at u = 0, → r_max as u → 1).
    #[inline]
    pub fn radius(&self, u: f32) -> f32 {
        // ln(1 − uZ) = log1p(−uZ) ∈ (−∞, 0]; uZ < 1 for u < 1.
        let l = libm::log1pf(-(u * self.mass));
        (self.sigma * libm::sqrtf((-2.0 * l).max(0.0))).min(self.r_max)
    }

    /// The offset for uniforms `u` in [0, 1)²: radius from `u.x` (inverse
    /// CDF), angle 2π·`u.y`.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec2 {
        let r = self.radius(u.x);
        let phi = 2.0 * PI * u.y;
        Vec2::new(r * libm::cosf(phi), r * libm::sinf(phi))
    }

    /// The uniforms `u` with `sample(u) = d` (up to rounding): the radial
    /// CDF F(|d|) = (1 − e^{−|d|²/(2σ²)})/Z and the angle over 2π. `None`
    /// outside the disk, where no `u` maps.
    pub fn invert(&self, d: Vec2) -> Option<Vec2> {
        let d2 = d.length_squared();
        if !(d2 <= self.r_max2_slack) {
            return None;
        }
        let f = (-libm::expm1f(-d2 * self.inv_two_sigma2) / self.mass).min(1.0);
        let phi = libm::atan2f(d.y, d.x) * (0.5 / PI);
        let v = if phi < 0.0 { phi + 1.0 } else { phi };
        Some(Vec2::new(
            if f < 1.0 { f } else { 1.0 - f32::EPSILON / 2.0 },
            if v < 1.0 { v } else { 0.0 },
        ))
    }

    /// [`ClampedGaussian2::invert`] written into the first two entries of
    /// `u` (a multiple-try proposal's uniforms); false outside the disk.
    pub fn invert_into(&self, d: Vec2, u: &mut [f32]) -> bool {
        match self.invert(d) {
            Some(v) => {
                u[0] = v.x;
                u[1] = v.y;
                true
            }
            None => false,
        }
    }

    /// Density of [`ClampedGaussian2::sample`] per unit area at offset `d`:
    /// e^{−|d|²/(2σ²)} / (2πσ² Z) inside the disk, 0 outside.
    #[inline]
    pub fn pdf(&self, d: Vec2) -> f32 {
        let d2 = d.length_squared();
        if d2 <= self.r_max2_slack {
            self.norm * libm::expf(-d2 * self.inv_two_sigma2)
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize) -> impl Iterator<Item = Vec2> {
        (0..n * n).map(move |i| {
            Vec2::new(
                ((i % n) as f32 + 0.5) / n as f32,
                ((i / n) as f32 + 0.5) / n as f32,
            )
        })
    }

    #[test]
    fn cosine_hemisphere_integrates_cos() {
        // E[1/pdf * cos] over cosine sampling must equal ∫cos dω = π.
        let n = 256;
        let mut s = 0.0f64;
        for u in grid(n) {
            let v = square_to_cosine_hemisphere(u);
            assert!((v.length() - 1.0).abs() < 1e-4);
            let pdf = cosine_hemisphere_pdf(v);
            if pdf > 0.0 {
                s += (v.z / pdf) as f64;
            }
        }
        let est = s / (n * n) as f64;
        assert!((est - core::f64::consts::PI).abs() < 1e-3, "{est}");
    }

    #[test]
    fn uniform_sphere_is_unit_and_balanced() {
        let n = 128;
        let mut mean = Vec3::ZERO;
        for u in grid(n) {
            let v = square_to_uniform_sphere(u);
            assert!((v.length() - 1.0).abs() < 1e-4);
            mean += v;
        }
        assert!((mean / (n * n) as f32).length() < 1e-3);
    }

    #[test]
    fn triangle_barycentrics_are_uniform() {
        // Mean of uniform barycentrics over a triangle is (1/3, 1/3).
        let n = 256;
        let mut m = Vec2::ZERO;
        for u in grid(n) {
            let b = square_to_uniform_triangle(u);
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            m += b;
        }
        m /= (n * n) as f32;
        assert!((m - Vec2::splat(1.0 / 3.0)).length() < 1e-3, "{m}");
    }
}

#[cfg(test)]
mod clamped_gaussian_tests {
    // The crate is `no_std` without the `std` feature; the tests print.
    extern crate std;
    use std::eprintln;

    use super::*;
    use crate::sampler::SampleStream;

    /// Upper 1e-4 quantile of χ² with `dof` degrees of freedom
    /// (Wilson–Hilferty; accurate to a few percent for dof ≥ 10).
    fn chi2_quantile_1e4(dof: f64) -> f64 {
        let z = 3.719;
        let a = 2.0 / (9.0 * dof);
        dof * (1.0 - a + z * a.sqrt()).powi(3)
    }

    /// ∫ f over the square [−l, l]² by the midpoint rule on n × n cells.
    fn integrate(l: f64, n: usize, f: impl Fn(Vec2) -> f64) -> f64 {
        let h = 2.0 * l / n as f64;
        let mut s = 0.0;
        for j in 0..n {
            for i in 0..n {
                let p = Vec2::new(
                    (-l + (i as f64 + 0.5) * h) as f32,
                    (-l + (j as f64 + 0.5) * h) as f32,
                );
                s += f(p);
            }
        }
        s * h * h
    }

    const CASES: [(f32, f32); 4] = [(1.0, 1.5), (0.3, 0.25), (0.05, 0.2), (2.0, f32::INFINITY)];

    #[test]
    fn clamped_gaussian_integrates_to_one() {
        for (sigma, r_max) in CASES {
            let g = ClampedGaussian2::new(sigma, r_max).unwrap();
            let l = r_max.min(9.0 * sigma) as f64;
            let i = integrate(l, 1500, |d| g.pdf(d) as f64);
            assert!((i - 1.0).abs() < 2e-3, "σ={sigma} R={r_max}: ∫q = {i}");
        }
    }

    #[test]
    fn clamped_gaussian_seed_eq37_is_wrong() {
        // Eq. 37 as printed, q = e^{−d²/σ}/(2πσ): integrates to ½ over the
        // plane (untruncated, so nothing else can explain the deficit).
        let sigma = 0.7f32;
        let seed = |d: Vec2| (libm::expf(-d.length_squared() / sigma) / (2.0 * PI * sigma)) as f64;
        let i = integrate(8.0, 1500, seed);
        assert!((i - 0.5).abs() < 2e-3, "{i}");
        // And the untruncated Gaussian used without 1/Z integrates to Z.
        let g = ClampedGaussian2::new(1.0, 1.5).unwrap();
        let i = integrate(1.5, 1500, |d| (g.pdf(d) * g.mass()) as f64);
        assert!((i - 0.6753).abs() < 2e-3 && (i - 1.0).abs() > 0.3, "{i}");
    }

    #[test]
    fn clamped_gaussian_invert_round_trips() {
        let g = ClampedGaussian2::new(0.3, 0.9).unwrap();
        for u in (0..1600).map(|i| {
            Vec2::new(
                ((i % 40) as f32 + 0.5) / 40.0,
                ((i / 40) as f32 + 0.5) / 40.0,
            )
        }) {
            let d = g.sample(u);
            let v = g.invert(d).unwrap();
            assert!((g.sample(v) - d).length() < 1e-5, "{u} → {d} → {v}");
        }
        assert!(g.invert(Vec2::new(0.0, 1.0)).is_none());
    }

    #[test]
    fn clamped_gaussian_radius_is_monotonic_and_bounded() {
        for (sigma, r_max) in CASES {
            let g = ClampedGaussian2::new(sigma, r_max).unwrap();
            assert_eq!(g.radius(0.0), 0.0);
            let mut last = 0.0;
            for i in 0..=4096u32 {
                let u = (i as f32 / 4096.0).min(1.0 - f32::EPSILON / 2.0);
                let r = g.radius(u);
                assert!(r >= last && r <= r_max && r.is_finite(), "{u} {r}");
                last = r;
                let d = g.sample(Vec2::new(u, 0.37 * u));
                assert!(g.pdf(d) > 0.0, "sample outside the support: {d}");
            }
        }
        for (s, r) in [
            (0.0, 1.0),
            (-1.0, 1.0),
            (f32::NAN, 1.0),
            (1.0, 0.0),
            (1.0, f32::NAN),
        ] {
            assert!(ClampedGaussian2::new(s, r).is_none());
        }
    }

    /// Pearson χ² of `n` samples of `g` on a 12 × 12 grid over the disk's
    /// bounding square against the cell masses of `density` (midpoint rule
    /// on 64 × 64 sub-cells). Cells with mass < 5 expected samples are
    /// pooled into one.
    fn chi2_against(g: &ClampedGaussian2, n: usize, density: impl Fn(Vec2) -> f64) -> (f64, f64) {
        const C: usize = 12;
        let r = g.r_max() as f64;
        let mut counts = [0u64; C * C];
        let mut s = SampleStream::new(42, 0, 7);
        for _ in 0..n {
            let d = g.sample(s.next_2d());
            let i = (((d.x as f64 + r) / (2.0 * r) * C as f64) as usize).min(C - 1);
            let j = (((d.y as f64 + r) / (2.0 * r) * C as f64) as usize).min(C - 1);
            counts[j * C + i] += 1;
        }
        let h = 2.0 * r / C as f64;
        let (mut chi2, mut dof) = (0.0, -1.0);
        let (mut pool_o, mut pool_e) = (0.0, 0.0);
        for j in 0..C {
            for i in 0..C {
                let (x0, y0) = (-r + i as f64 * h, -r + j as f64 * h);
                let sub = 64;
                let hs = h / sub as f64;
                let mut m = 0.0;
                for b in 0..sub {
                    for a in 0..sub {
                        let p = Vec2::new(
                            (x0 + (a as f64 + 0.5) * hs) as f32,
                            (y0 + (b as f64 + 0.5) * hs) as f32,
                        );
                        m += density(p);
                    }
                }
                let e = m * hs * hs * n as f64;
                let o = counts[j * C + i] as f64;
                if e < 5.0 {
                    pool_o += o;
                    pool_e += e;
                } else {
                    chi2 += (o - e) * (o - e) / e;
                    dof += 1.0;
                }
            }
        }
        if pool_e > 0.0 {
            chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
            dof += 1.0;
        } else {
            assert_eq!(pool_o, 0.0, "samples where the density is 0");
        }
        (chi2, dof)
    }

    #[test]
    fn clamped_gaussian_samples_match_density_chi2() {
        let n = 400_000;
        for (sigma, r_max) in [(1.0, 1.5), (0.3, 0.25)] {
            let g = ClampedGaussian2::new(sigma, r_max).unwrap();
            let (chi2, dof) = chi2_against(&g, n, |d| g.pdf(d) as f64);
            eprintln!("clamped Gaussian σ={sigma} R={r_max}: χ²={chi2:.1}, dof={dof}");
            assert!(
                chi2 < chi2_quantile_1e4(dof),
                "σ={sigma}: χ²={chi2} dof={dof}"
            );
        }
        // Negative controls on the same samples: (a) the untruncated
        // density (no 1/Z), (b) Segovia 2007's eq. 37 shape e^{−d²/σ} even with the
        // paper's division by its integral over the disk.
        let g = ClampedGaussian2::new(1.0, 1.5).unwrap();
        let (chi2, dof) = chi2_against(&g, n, |d| (g.pdf(d) * g.mass()) as f64);
        eprintln!("negative control, no 1/Z: χ²={chi2:.1}");
        assert!(chi2 > 10.0 * chi2_quantile_1e4(dof), "no 1/Z: χ²={chi2}");
        let seed = |d: Vec2| libm::expf(-d.length_squared() / g.sigma()) as f64;
        let z = integrate(1.5, 1500, |d| if d.length() <= 1.5 { seed(d) } else { 0.0 });
        let (chi2, dof) =
            chi2_against(&g, n, |d| if d.length() <= 1.5 { seed(d) / z } else { 0.0 });
        eprintln!("negative control, eq. 37 shape: χ²={chi2:.1}");
        assert!(chi2 > 10.0 * chi2_quantile_1e4(dof), "eq. 37: χ²={chi2}");
    }
}
