//! Mitsuba's built-in shapes as triangles, and placing any mesh in the world.
//!
//! cmlt renders triangles only, so Mitsuba's analytic `sphere` and `disk`
//! are tessellated. Their vertices are pushed slightly outwards so that the
//! triangulated surface has exactly the analytic area: an area emitter then
//! emits exactly Mitsuba's power (power = π · L · area), and the surface
//! stays within 0.03 % of the true radius (64 × 128 sphere: the inscribed
//! tessellation lacks 5.0e-4 of the area, so vertices sit at radius
//! × (1 + 2.5e-4); 128-segment disk: 4.0e-4 and 1 + 2.0e-4).
//!
//! Sidedness follows Mitsuba 3.9 exactly. Mitsuba never re-winds a mesh for
//! a mirroring `to_world`: a mesh's geometric normal is always
//! `cross(p1 − p0, p2 − p0)` of the *transformed* vertices, and its shading
//! normals are the file's normals times the inverse transpose. Emission and
//! one-sided BSDFs use the shading frame. cmlt keeps the geometric normal
//! on the shading normal's side, so it agrees with Mitsuba either way; for
//! the built-in shapes (whose normals are authored outward) we additionally
//! re-wind under a negative determinant so that geometric and shading
//! normals agree on every triangle.

use std::f64::consts::PI;
use std::sync::OnceLock;

use glam::{DMat3, DMat4, DVec2, DVec3, Vec2, Vec3};

use super::mesh_io::RawMesh;
use super::transform;

/// Latitude rings of a tessellated sphere.
pub(crate) const SPHERE_RINGS: usize = 64;
/// Longitude segments of a tessellated sphere.
pub(crate) const SPHERE_SEGMENTS: usize = 128;
/// Segments of a tessellated disk.
pub(crate) const DISK_SEGMENTS: usize = 128;

/// A mesh ready for `cmlt::scene::Mesh` (world space, single precision).
pub(crate) struct WorldMesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub indices: Vec<[u32; 3]>,
}

/// Mitsuba's `rectangle`: [-1, 1]² in z = 0, normal +z, uv = ((x+1)/2,
/// (y+1)/2), split along the (1,−1)–(−1,1) diagonal like Mitsuba's mesh.
pub(crate) fn rectangle() -> RawMesh {
    let corners = [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)];
    RawMesh {
        positions: corners
            .iter()
            .map(|&(x, y)| DVec3::new(x, y, 0.0))
            .collect(),
        normals: vec![DVec3::Z; 4],
        uvs: corners
            .iter()
            .map(|&(x, y)| DVec2::new((x + 1.0) / 2.0, (y + 1.0) / 2.0))
            .collect(),
        indices: vec![[1, 2, 0], [1, 3, 2]],
    }
}

/// Mitsuba's `cube`: [-1, 1]³ as 24 vertices (four per face, so faces stay
/// sharp), outward face normals as vertex normals, each face mapped onto
/// [0, 1]² with the same orientation as Mitsuba's cube.
pub(crate) fn cube() -> RawMesh {
    // Per face: outward normal, the corner at uv (0, 0), and the unit
    // directions in which u and v grow (v × u = normal).
    let faces: [(DVec3, DVec3, DVec3, DVec3); 6] = [
        (
            DVec3::NEG_Y,
            DVec3::new(-1.0, -1.0, -1.0),
            DVec3::Z,
            DVec3::X,
        ),
        (
            DVec3::Y,
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::NEG_X,
            DVec3::NEG_Z,
        ),
        (DVec3::X, DVec3::new(1.0, -1.0, 1.0), DVec3::Y, DVec3::NEG_Z),
        (DVec3::Z, DVec3::new(-1.0, -1.0, 1.0), DVec3::Y, DVec3::X),
        (
            DVec3::NEG_X,
            DVec3::new(-1.0, -1.0, -1.0),
            DVec3::Y,
            DVec3::Z,
        ),
        (
            DVec3::NEG_Z,
            DVec3::new(-1.0, 1.0, -1.0),
            DVec3::NEG_Y,
            DVec3::X,
        ),
    ];
    let mut m = RawMesh::default();
    for (s, (n, o, u, v)) in faces.into_iter().enumerate() {
        let b = 4 * s as u32;
        for (du, dv) in [(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)] {
            m.positions.push(o + u * (2.0 * du) + v * (2.0 * dv));
            m.normals.push(n);
            m.uvs.push(DVec2::new(du, dv));
        }
        m.indices.push([b, b + 1, b + 2]);
        m.indices.push([b + 3, b, b + 2]);
    }
    m
}

/// Unit sphere directions on a latitude–longitude grid (θ from +z, φ from
/// +x towards +y). uv = (φ / 2π, θ / π) as Mitsuba's sphere; the seam and
/// the poles repeat vertices so that uv stays continuous. Winding is
/// outward (∂p/∂θ × ∂p/∂φ points outwards).
fn unit_sphere() -> RawMesh {
    let (nt, np) = (SPHERE_RINGS, SPHERE_SEGMENTS);
    let mut m = RawMesh::default();
    for i in 0..=nt {
        let theta = PI * i as f64 / nt as f64;
        for j in 0..=np {
            let phi = 2.0 * PI * j as f64 / np as f64;
            let d = DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            m.positions.push(d);
            m.normals.push(d);
            m.uvs
                .push(DVec2::new(j as f64 / np as f64, i as f64 / nt as f64));
        }
    }
    let at = |i: usize, j: usize| (i * (np + 1) + j) as u32;
    for i in 0..nt {
        for j in 0..np {
            // Skip the triangle that collapses at each pole.
            if i != nt - 1 {
                m.indices.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            }
            if i != 0 {
                m.indices.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
    }
    m
}

/// Total area of a mesh, in double precision.
fn area(m: &RawMesh) -> f64 {
    m.indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

/// The unit sphere, scaled so that its area is exactly 4π.
pub(crate) fn sphere_unit_exact() -> &'static RawMesh {
    static S: OnceLock<RawMesh> = OnceLock::new();
    S.get_or_init(|| {
        let mut m = unit_sphere();
        let s = (4.0 * PI / area(&m)).sqrt();
        for p in &mut m.positions {
            *p *= s;
        }
        m
    })
}

/// Mitsuba's `disk`: the unit disk in z = 0, normal +z, uv = (r, φ / 2π),
/// as a fan whose centre is repeated per segment (so v interpolates along
/// each wedge); scaled to area exactly π.
pub(crate) fn disk() -> RawMesh {
    let n = DISK_SEGMENTS;
    let mut m = RawMesh::default();
    for j in 0..=n {
        let phi = 2.0 * PI * j as f64 / n as f64;
        m.positions.push(DVec3::new(phi.cos(), phi.sin(), 0.0));
        m.normals.push(DVec3::Z);
        m.uvs.push(DVec2::new(1.0, j as f64 / n as f64));
    }
    for j in 0..n {
        let c = m.positions.len() as u32;
        m.positions.push(DVec3::ZERO);
        m.normals.push(DVec3::Z);
        m.uvs.push(DVec2::new(0.0, (j as f64 + 0.5) / n as f64));
        m.indices.push([c, j as u32, j as u32 + 1]);
    }
    let s = (PI / area(&m)).sqrt();
    for p in &mut m.positions {
        *p *= s;
    }
    m
}

/// Mitsuba's sphere placement: `to_world · translate(center) · scale(radius)`
/// reduced to a centre, a radius `|M x̂|` and a rotation; a negative
/// determinant turns the sphere inside out (Mitsuba flips its normals).
/// Returns (placement matrix with uniform scale, flip) or a reason.
pub(crate) fn sphere_placement(m: &DMat4) -> Result<(DMat4, bool, bool), String> {
    let l = transform::linear(m);
    let radius = l.x_axis.length();
    if !(radius.is_finite() && radius > 0.0) {
        return Err(format!(
            "sphere radius must be positive and finite, got {radius}"
        ));
    }
    let det = l.determinant();
    let flip = det < 0.0;
    // Rotation part by Gram–Schmidt; Mitsuba warns about (and ignores)
    // shear and non-uniform scale, which we report as `distorted`.
    let r = if flip { -l } else { l } * (1.0 / radius);
    let x = r.x_axis.normalize();
    let y = (r.y_axis - x * x.dot(r.y_axis)).normalize();
    let z = x.cross(y);
    let rot = DMat3::from_cols(x, y, z);
    let distorted = (0..3).any(|c| (r.col(c) - rot.col(c)).length() > 1e-4);
    if !rot.is_finite() {
        return Err("sphere transform is degenerate".into());
    }
    let center = m.w_axis.truncate();
    let place = DMat4::from_cols(
        (rot.x_axis * radius).extend(0.0),
        (rot.y_axis * radius).extend(0.0),
        (rot.z_axis * radius).extend(0.0),
        center.extend(1.0),
    );
    Ok((place, flip, distorted))
}

/// Applies `to_world`: positions by the matrix, normals by its inverse
/// transpose (renormalised). With `rewind_mirrored`, a negative
/// determinant reverses the winding (built-in shapes, see module docs).
pub(crate) fn place(raw: &RawMesh, m: &DMat4, rewind_mirrored: bool) -> Result<RawMesh, String> {
    if !transform::is_affine(m) {
        return Err("to_world must be affine (last row 0 0 0 1)".into());
    }
    let nm = transform::normal_matrix(m).ok_or("to_world is singular (a zero scale?)")?;
    let mut out = RawMesh {
        positions: raw
            .positions
            .iter()
            .map(|&p| m.transform_point3(p))
            .collect(),
        normals: raw
            .normals
            .iter()
            .map(|&n| (nm * n).normalize_or_zero())
            .collect(),
        uvs: raw.uvs.clone(),
        indices: raw.indices.clone(),
    };
    if rewind_mirrored && transform::linear(m).determinant() < 0.0 {
        for t in &mut out.indices {
            t.swap(1, 2);
        }
    }
    Ok(out)
}

/// Mitsuba's `flip_normals`: the other side becomes the front.
pub(crate) fn flip(m: &mut RawMesh) {
    for t in &mut m.indices {
        t.swap(1, 2);
    }
    for n in &mut m.normals {
        *n = -*n;
    }
}

/// Smooth vertex normals as Mitsuba computes them for meshes without
/// normals when `face_normals` is false: face normals weighted by the
/// corner angle (Thürmer and Wüthrich 1998), per vertex index; a vertex on
/// degenerate faces only gets (1, 0, 0) like Mitsuba.
pub(crate) fn recompute_normals(m: &mut RawMesh) {
    let mut acc = vec![DVec3::ZERO; m.positions.len()];
    for t in &m.indices {
        let p = t.map(|i| m.positions[i as usize]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let len = n.length();
        if !(len > 0.0 && len.is_finite()) {
            continue;
        }
        let n = n / len;
        for k in 0..3 {
            let a = p[(k + 1) % 3] - p[k];
            let b = p[(k + 2) % 3] - p[k];
            let angle = a.cross(b).length().atan2(a.dot(b));
            acc[t[k] as usize] += n * angle;
        }
    }
    m.normals = acc
        .into_iter()
        .map(|n| {
            if n.length() > 0.0 {
                n.normalize()
            } else {
                DVec3::X
            }
        })
        .collect();
}

/// Converts to single precision, checking that everything stayed finite.
pub(crate) fn to_world_mesh(m: RawMesh) -> Result<WorldMesh, String> {
    let positions: Vec<Vec3> = m.positions.iter().map(|p| p.as_vec3()).collect();
    if let Some(v) = positions.iter().position(|p| !p.is_finite()) {
        return Err(format!(
            "vertex {v} is not finite after the to_world transform (values too large?)"
        ));
    }
    Ok(WorldMesh {
        positions,
        normals: m.normals.iter().map(|n| n.as_vec3()).collect(),
        uvs: m.uvs.iter().map(|u| u.as_vec2()).collect(),
        indices: m.indices,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn face_normal(m: &RawMesh, t: usize) -> DVec3 {
        let [a, b, c] = m.indices[t].map(|i| m.positions[i as usize]);
        (b - a).cross(c - a).normalize()
    }

    #[test]
    fn builtin_windings_agree_with_normals() {
        for m in [rectangle(), cube(), disk(), sphere_unit_exact().clone()] {
            for t in 0..m.indices.len() {
                let n = m.indices[t]
                    .map(|i| m.normals[i as usize])
                    .into_iter()
                    .sum::<DVec3>();
                assert!(face_normal(&m, t).dot(n) > 0.0, "triangle {t}");
            }
        }
    }

    #[test]
    fn exact_areas() {
        assert!((area(sphere_unit_exact()) - 4.0 * PI).abs() < 1e-9);
        assert!((area(&disk()) - PI).abs() < 1e-9);
        assert!((area(&cube()) - 24.0).abs() < 1e-12);
        // The correction is small: vertices move out by less than 0.03 %.
        let r = sphere_unit_exact().positions[SPHERE_SEGMENTS + 7].length();
        assert!(r > 1.0 && r < 1.0003, "{r}");
    }

    #[test]
    fn cube_uvs_span_each_face() {
        let c = cube();
        assert_eq!(c.positions.len(), 24);
        assert_eq!(c.indices.len(), 12);
        // Mitsuba's first face (−y): uv (0, 0) at (−1, −1, −1), (1, 0) at (−1, −1, 1).
        assert_eq!(c.positions[3], DVec3::new(-1.0, -1.0, -1.0));
        assert_eq!(c.uvs[3], DVec2::new(0.0, 0.0));
        assert_eq!(c.positions[2], DVec3::new(-1.0, -1.0, 1.0));
        assert_eq!(c.uvs[2], DVec2::new(1.0, 0.0));
        assert_eq!(c.positions[0], DVec3::new(1.0, -1.0, -1.0));
    }
}
