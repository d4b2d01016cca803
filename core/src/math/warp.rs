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
