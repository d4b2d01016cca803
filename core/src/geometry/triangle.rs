//! PLACEHOLDER: watertight ray–triangle intersection (being written).

use glam::Vec3;

use super::Ray;

/// Intersects `ray` with triangle (p0, p1, p2): `(t, b1, b2)` for `t` in
/// `(0, ray.t_max)`.
pub fn intersect_triangle(ray: &Ray, p0: Vec3, p1: Vec3, p2: Vec3) -> Option<(f32, f32, f32)> {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let pv = ray.d.cross(e2);
    let det = e1.dot(pv);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let tv = ray.o - p0;
    let u = tv.dot(pv) * inv;
    let q = tv.cross(e1);
    let v = ray.d.dot(q) * inv;
    let t = e2.dot(q) * inv;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 && t < ray.t_max).then_some((t, u, v))
}
