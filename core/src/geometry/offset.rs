//! Robust spawn points for secondary rays (pbrt-v4, §6.8.6, "Robust Spawned
//! Ray Origins").
//!
//! A hit point computed from barycentrics carries a conservative per-axis
//! absolute error bound. Offsetting the origin along the geometric normal by
//! the projection of that box, then rounding each coordinate one ulp further
//! away, puts the origin strictly on the intended side of the surface: no
//! re-intersection, at any scene scale or distance from the origin, with no
//! fixed epsilon.

use glam::Vec3;

use super::Ray;

/// Unit roundoff of f32 (2^-24).
pub const MACHINE_EPSILON: f32 = f32::EPSILON * 0.5;

/// Shadow rays stop this fraction short of their (already offset) target so
/// that the target's own surface, reached at t ≈ 1, is not reported as an
/// occluder. A relative bound on the segment, not a scene-scale epsilon.
pub const SHADOW_EPSILON: f32 = 1e-4;

/// γ(n) = nε / (1 − nε), the rounding-error growth bound of n operations
/// (Higham 2002, as used by pbrt).
#[inline]
pub const fn gamma(n: i32) -> f32 {
    (n as f32 * MACHINE_EPSILON) / (1.0 - n as f32 * MACHINE_EPSILON)
}

/// The next representable f32 above `v` (towards +∞).
#[inline]
pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v >= 0.0 { bits + 1 } else { bits - 1 };
    f32::from_bits(bits)
}

/// The next representable f32 below `v` (towards −∞).
#[inline]
pub fn next_float_down(v: f32) -> f32 {
    if v.is_infinite() && v < 0.0 {
        return v;
    }
    let v = if v == 0.0 { -0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v > 0.0 { bits - 1 } else { bits + 1 };
    f32::from_bits(bits)
}

/// Conservative error bound of the point `b0·p0 + b1·p1 + b2·p2`
/// interpolated from a triangle's vertices (pbrt-v4, eq. 6.25: γ(7)·Σ|bᵢpᵢ|).
#[inline]
pub fn barycentric_error(p0: Vec3, p1: Vec3, p2: Vec3, b0: f32, b1: f32, b2: f32) -> Vec3 {
    ((p0 * b0).abs() + (p1 * b1).abs() + (p2 * b2).abs()) * gamma(7)
}

/// Moves `p` (with per-axis error bound `p_error`) off the surface with
/// geometric normal `ng` to the side that `w` points into.
#[inline]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, ng: Vec3, w: Vec3) -> Vec3 {
    let d = ng.abs().dot(p_error);
    let mut offset = ng * d;
    if w.dot(ng) < 0.0 {
        offset = -offset;
    }
    let mut po = p + offset;
    // Round away from p so the offset is not lost to rounding of the sum.
    for i in 0..3 {
        if offset[i] > 0.0 {
            po[i] = next_float_up(po[i]);
        } else if offset[i] < 0.0 {
            po[i] = next_float_down(po[i]);
        }
    }
    po
}

/// A ray leaving a surface point in direction `d`.
#[inline]
pub fn spawn_ray(p: Vec3, p_error: Vec3, ng: Vec3, d: Vec3) -> Ray {
    Ray::new(offset_ray_origin(p, p_error, ng, d), d)
}

/// A shadow/connection ray between two surface points; both ends are offset
/// off their surfaces, and the ray covers `t ∈ (0, 1 − SHADOW_EPSILON)`.
/// A zero normal (`Vec3::ZERO`) marks a point that is not on a surface
/// (a pinhole camera), which is then not offset.
#[inline]
pub fn spawn_ray_between(p0: Vec3, e0: Vec3, n0: Vec3, p1: Vec3, e1: Vec3, n1: Vec3) -> Ray {
    let o = offset_ray_origin(p0, e0, n0, p1 - p0);
    let t = offset_ray_origin(p1, e1, n1, o - p1);
    Ray {
        o,
        d: t - o,
        t_max: 1.0 - SHADOW_EPSILON,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_float_moves_one_ulp() {
        for v in [1.0f32, -1.0, 0.0, -0.0, 1e-30, 3.5e7] {
            let up = next_float_up(v);
            let down = next_float_down(v);
            assert!(up > v && down < v);
        }
    }

    #[test]
    fn offset_lands_on_requested_side() {
        let ng = Vec3::new(0.0, 0.0, 1.0);
        for scale in [1e-4f32, 1.0, 1e6] {
            let p = Vec3::new(1e5, -3.0 * scale, 0.0);
            let err = Vec3::splat(gamma(7) * (p.abs().max_element()));
            let up = offset_ray_origin(p, err, ng, Vec3::Z);
            let down = offset_ray_origin(p, err, ng, -Vec3::Z);
            assert!(up.z > 0.0 && down.z < 0.0);
        }
    }
}
