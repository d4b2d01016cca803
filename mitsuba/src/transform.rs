//! `<transform>` elements and what the loader derives from them.
//!
//! Mitsuba composes the children of a `<transform>` in document order, each
//! new operation multiplied from the *left* (`T ← op · T`): the first
//! element is applied to the geometry first. `<translate/><rotate/>` thus
//! rotates the translated object about the origin. Matrices are composed
//! in double precision, as Mitsuba's parser does.

use glam::{Affine2, DMat3, DMat4, DVec3, Mat2, Mat4, Vec2};
use roxmltree::Node;

use super::error::LoadError;
use super::xml::{Xml, parse_f64, three, tokens, xyz};

/// Parses a `<transform>` element into a 4×4 matrix (column vectors).
pub(crate) fn parse(xml: &Xml, node: Node) -> Result<DMat4, LoadError> {
    let mut m = DMat4::IDENTITY;
    for child in node.children().filter(|n| n.is_element()) {
        let tag = child.tag_name().name();
        let op = match tag {
            "translate" => DMat4::from_translation(DVec3::from(xyz(xml, child, 0.0)?)),
            "scale" => DMat4::from_scale(DVec3::from(xyz(xml, child, 1.0)?)),
            "rotate" => {
                let axis = DVec3::from(xyz(xml, child, 0.0)?);
                if axis == DVec3::ZERO {
                    return Err(xml.err(child, "<rotate> needs a non-zero axis (x, y, z or value)"));
                }
                let angle = xml.req_attr(child, "angle")?;
                let deg = parse_f64(&angle)
                    .map_err(|e| xml.err(child, format!("<rotate> angle: {e}")))?;
                // Right-handed rotation about the normalised axis, angle in
                // degrees (Mitsuba's Transform::rotate).
                DMat4::from_axis_angle(axis.normalize(), deg.to_radians())
            }
            "lookat" => {
                let origin = DVec3::from(three(
                    xml,
                    child,
                    "lookat origin",
                    &xml.req_attr(child, "origin")?,
                )?);
                let target = DVec3::from(three(
                    xml,
                    child,
                    "lookat target",
                    &xml.req_attr(child, "target")?,
                )?);
                let up = match xml.attr(child, "up")? {
                    Some(s) if !s.trim().is_empty() => {
                        DVec3::from(three(xml, child, "lookat up", &s)?)
                    }
                    _ => DVec3::ZERO,
                };
                look_at(origin, target, up).ok_or_else(|| {
                    xml.err(child, "invalid <lookat>: origin equals target, or up is parallel to the view direction")
                })?
            }
            "matrix" => {
                let v = xml.req_attr(child, "value")?;
                let t = tokens(&v);
                let n = match t.len() {
                    16 => 4,
                    9 => 3,
                    k => {
                        return Err(
                            xml.err(child, format!("<matrix> must have 9 or 16 values, got {k}"))
                        );
                    }
                };
                let mut m = DMat4::IDENTITY;
                for i in 0..n {
                    for j in 0..n {
                        let x = parse_f64(t[i * n + j])
                            .map_err(|e| xml.err(child, format!("<matrix>: {e}")))?;
                        // Values are row-major; glam stores columns.
                        m.col_mut(j)[i] = x;
                    }
                }
                m
            }
            other => return Err(xml.err(child, format!("unexpected <{other}> inside <transform>"))),
        };
        m = op * m;
    }
    if !m.is_finite() {
        return Err(xml.err(node, "transform is not finite (values too large?)"));
    }
    Ok(m)
}

/// Mitsuba's `look_at`: the frame's z axis points at the target, x is
/// `normalize(up × dir)` ("left" in the image), y completes the frame. A
/// zero `up` is replaced by an arbitrary perpendicular vector, as Mitsuba
/// does. Returns `None` when the frame is degenerate.
pub(crate) fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (target - origin).normalize();
    let up = if up == DVec3::ZERO {
        perpendicular(dir)
    } else {
        up
    };
    let left = up.cross(dir).normalize();
    let new_up = dir.cross(left);
    let m = DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    );
    m.is_finite().then_some(m)
}

/// Some unit vector perpendicular to the unit vector `n` (Duff et al. 2017,
/// "Building an orthonormal basis, revisited").
fn perpendicular(n: DVec3) -> DVec3 {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x)
}

/// True when the last row is (0, 0, 0, 1): Mitsuba's `to_world` is affine.
pub(crate) fn is_affine(m: &DMat4) -> bool {
    let r = m.row(3);
    r.x.abs() < 1e-9 && r.y.abs() < 1e-9 && r.z.abs() < 1e-9 && (r.w - 1.0).abs() < 1e-9
}

/// The upper-left 3×3 block.
pub(crate) fn linear(m: &DMat4) -> DMat3 {
    DMat3::from_mat4(*m)
}

/// The matrix that transforms normals: the inverse transpose of the linear
/// part (Mitsuba's `Transform * Normal`). `None` for a singular transform.
pub(crate) fn normal_matrix(m: &DMat4) -> Option<DMat3> {
    let l = linear(m);
    let det = l.determinant();
    if !(det.is_finite() && det.abs() > 1e-300) {
        return None;
    }
    let n = l.inverse().transpose();
    n.is_finite().then_some(n)
}

/// Mitsuba's test for a scale in a camera transform: M·Mᵀ must be the
/// identity within 1e-3 (a mirror is allowed, a scale is not).
pub(crate) fn has_scale(m: &DMat4) -> bool {
    scale_deviation(m) > 1e-3
}

/// The largest entry of |M·Mᵀ − I| for the linear part M of `m`: zero for
/// a rotation or a mirror.
pub(crate) fn scale_deviation(m: &DMat4) -> f64 {
    let l = linear(m);
    let p = l * l.transpose() - DMat3::IDENTITY;
    (0..3)
        .flat_map(|c| (0..3).map(move |r| p.col(c)[r].abs()))
        .fold(0.0, f64::max)
}

/// The 2D affine map a texture applies to uv: Mitsuba extracts the
/// upper-left 2×2 block and the translation column of the 4×4 `to_uv`.
pub(crate) fn to_uv(m: &DMat4) -> Affine2 {
    let a = Mat2::from_cols(
        Vec2::new(m.x_axis.x as f32, m.x_axis.y as f32),
        Vec2::new(m.y_axis.x as f32, m.y_axis.y as f32),
    );
    Affine2::from_mat2_translation(a, Vec2::new(m.w_axis.x as f32, m.w_axis.y as f32))
}

/// Single-precision copy for the renderer.
pub(crate) fn to_f32(m: &DMat4) -> Mat4 {
    m.as_mat4()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_frame_matches_mitsuba() {
        let m = look_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y).unwrap();
        // Looking down −z with +y up: z axis = −z, x ("left") = up × dir = −x.
        assert!((m.z_axis.truncate() - DVec3::NEG_Z).length() < 1e-12);
        assert!((m.x_axis.truncate() - DVec3::NEG_X).length() < 1e-12);
        assert!((m.y_axis.truncate() - DVec3::Y).length() < 1e-12);
        assert!(look_at(DVec3::ZERO, DVec3::ZERO, DVec3::Y).is_none());
        assert!(look_at(DVec3::ZERO, DVec3::Y, DVec3::Y).is_none());
        let z = look_at(DVec3::ZERO, DVec3::X, DVec3::ZERO).unwrap();
        assert!(z.x_axis.truncate().dot(DVec3::X).abs() < 1e-12);
    }
}
