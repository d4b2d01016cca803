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

/// Where a segment's occlusion test hands over from the ray leaving its
/// first point to the ray leaving its second (see [`spawn_rays_between`]):
/// a relative position on the segment, not a scene-scale epsilon. The first
/// ray stops this fraction short of the far end, whose own surface it could
/// otherwise report through the rounding of the hit distance near t = 1.
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

/// A point on a triangle with its error bound, as [`triangle_point`]
/// computes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrianglePoint {
    /// Position.
    pub p: Vec3,
    /// Conservative per-axis absolute error bound of `p` with respect to
    /// the point of weights `b` on the triangle.
    pub p_error: Vec3,
    /// Barycentric weights of the three vertices (non-negative, summing to
    /// one), the ones `p` interpolates: attributes (normals, uvs) should be
    /// interpolated with them too.
    pub b: [f32; 3],
}

/// The point of barycentrics `(b1, b2)` (weights of vertices 1 and 2, as a
/// hit reports them) on triangle `tri`, moved into the triangle where
/// needed so that a ray spawned from it cannot leave through a
/// neighbouring face.
///
/// Invariant (against the edge leak): `p` lies in the triangle at an
/// in-plane distance of at least `m = 2·|γ(7)·maxᵢ|pᵢ||` from each of its
/// edges — more than its own error bound plus the rounding of the spawn
/// offset — so it is strictly on the inner side of the plane of a face
/// meeting the triangle at an edge at a right or obtuse dihedral angle
/// (boxes, tessellated smooth surfaces), and a ray spawned from it crosses
/// that face rather than starting on it. Without it, a hit next to an edge
/// of a closed cube was computed on, or one ulp beyond, the plane of the
/// adjacent face; the offset along the own normal leaves that coordinate
/// alone, and the next ray left the mesh (through a plane it starts on: a
/// crossing at t = 0, which no intersector reports).
///
/// How: a point closer than `m` to an edge moves away from it,
/// perpendicularly, to distance `m`; next to a vertex, to the corner of the
/// triangle inset by `m`. Where that is a move of more than `4m` (next to a
/// vertex sharper than 29°) or the triangle is too small for the margin,
/// the weights are only clamped to the triangle and the point keeps no
/// margin. The largest
/// weight is then computed as the remainder `1 − bᵢ − bₖ`: being at least
/// ⅓, its rounding error is relative (γ(4)), which with γ(3) for the sum
/// of products gives pbrt-v4's γ(7) bound ([`barycentric_error`]) with
/// respect to a point exactly on the triangle. (`1 − b1 − b2` as the weight
/// of vertex 0 has no relative bound when it is near 0, where the cube's
/// leak was.)
pub fn triangle_point(tri: [Vec3; 3], b1: f32, b2: f32) -> TrianglePoint {
    let b = margin_weights(tri, [1.0 - b1 - b2, b1, b2]);
    let p = tri[0] * b[0] + tri[1] * b[1] + tri[2] * b[2];
    TrianglePoint {
        p,
        p_error: barycentric_error(tri[0], tri[1], tri[2], b[0], b[1], b[2]),
        b,
    }
}

/// The weights of [`triangle_point`]: `given` moved off the edges by the
/// margin where that is a short move within the triangle, else only
/// clamped to it; the largest recomputed as the remainder of the others.
///
/// Most hits lie well inside their triangle: [`clear_of_margins`] settles
/// those from squared lengths, without the four square roots and three
/// divisions of [`moved_off_edges`], and with bit for bit its result.
#[inline]
fn margin_weights(tri: [Vec3; 3], given: [f32; 3]) -> [f32; 3] {
    // f32::max maps a NaN weight to 0.
    let clamped = given.map(|b| b.max(0.0));
    if clear_of_margins(tri, clamped) {
        with_remainder(clamped)
    } else {
        moved_off_edges(tri, clamped)
    }
}

/// Relative slack of [`clear_of_margins`]'s squared test over the rounding
/// of both sides (each within a few ulps of its exact value).
const MARGIN_SLACK: f32 = 1.001;

/// Whether every weight `clamped[i]` (non-negative) is at least the margin
/// weight lᵢ = m·|eᵢ|/(2·area) that [`moved_off_edges`] computes, with room
/// for rounding: then it moves no weight, and both of its branches return
/// `with_remainder(clamped)`. Tested as bᵢ²·(2·area)² ≥ slack·m²·|eᵢ|² on
/// the same rounded cross product, edges and error box as that function
/// (their squared lengths are what its square roots read), where both
/// sides are normal finite numbers; anything else (a degenerate triangle,
/// overflow, underflow) goes the long way.
#[inline]
fn clear_of_margins(tri: [Vec3; 3], clamped: [f32; 3]) -> bool {
    let area2_sq = (tri[1] - tri[0]).cross(tri[2] - tri[0]).length_squared();
    if !area2_sq.is_normal() {
        return false;
    }
    let max_abs = tri[0].abs().max(tri[1].abs()).max(tri[2].abs());
    let m_sq = 4.0 * (max_abs * gamma(7)).length_squared();
    let edge = |i: usize| tri[(i + 2) % 3] - tri[(i + 1) % 3];
    (0..3).all(|i| {
        let need = MARGIN_SLACK * m_sq * edge(i).length_squared();
        let have = clamped[i] * clamped[i] * area2_sq;
        need.is_normal() && have.is_finite() && have >= need
    })
}

/// [`margin_weights`] for `clamped`, the given weights clamped to ≥ 0: the
/// moves off the edges, by the margin.
fn moved_off_edges(tri: [Vec3; 3], clamped: [f32; 3]) -> [f32; 3] {
    let area2 = (tri[1] - tri[0]).cross(tri[2] - tri[0]).length();
    let max_abs = tri[0].abs().max(tri[1].abs()).max(tri[2].abs());
    let m = 2.0 * (max_abs * gamma(7)).length();
    // The distance to edge i (opposite vertex i) is bᵢ·hᵢ with height
    // hᵢ = area2 / |edge|: it is m at weight lᵢ (infinite or NaN on a
    // degenerate triangle, which then keeps no margin).
    let edge = |i: usize| tri[(i + 2) % 3] - tri[(i + 1) % 3];
    let l = [0, 1, 2].map(|i| m * edge(i).length() / area2);
    // Away from each edge that is too close, along the altitude from the
    // opposite vertex i, whose foot has weights (1 − s, s) for (j, k).
    let mut b = clamped;
    for i in 0..3 {
        let raise = l[i] - clamped[i];
        if raise > 0.0 {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            let s = (tri[i] - tri[j]).dot(edge(i)) / edge(i).length_squared();
            b[i] += raise;
            b[j] -= raise * (1.0 - s);
            b[k] -= raise * s;
        }
    }
    // At a vertex that is not a right angle the two moves do not reach
    // both margins: the corner of the inset triangle does.
    let b = with_remainder([0, 1, 2].map(|i| b[i].max(l[i])));
    let shift = (0..3)
        .map(|i| tri[i] * (b[i] - clamped[i]))
        .sum::<Vec3>()
        .length();
    if (0..3).all(|i| b[i] >= l[i]) && shift <= 4.0 * m {
        b
    } else {
        with_remainder(clamped)
    }
}

/// `b` with its largest weight replaced by one minus the other two (the
/// three cases spelled out: a write at a computed index went through
/// memory and stalled the reads after it).
#[inline]
fn with_remainder([b0, b1, b2]: [f32; 3]) -> [f32; 3] {
    if b0 >= b1 && b0 >= b2 {
        [1.0 - b1 - b2, b1, b2]
    } else if b1 >= b2 {
        [b0, 1.0 - b2 - b0, b2]
    } else {
        [b0, b1, 1.0 - b0 - b1]
    }
}

/// Moves `p` (with per-axis error bound `p_error`) off the surface with
/// geometric normal `ng` to the side that `w` points into.
#[inline]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, ng: Vec3, w: Vec3) -> Vec3 {
    offset_to_side(p, p_error, ng, if w.dot(ng) < 0.0 { -1.0 } else { 1.0 })
}

/// Moves `p` off its surface by the projection of its error box onto `ng`,
/// to the side `side` (±1) of `ng`, rounding each coordinate one ulp further
/// so the offset is not lost to the rounding of the sum.
#[inline]
fn offset_to_side(p: Vec3, p_error: Vec3, ng: Vec3, side: f32) -> Vec3 {
    let offset = ng * (ng.abs().dot(p_error) * side);
    let mut po = p + offset;
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

/// The occlusion test of the open segment between two points, as rays that
/// each start off their own surface (see [`spawn_rays_between`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentRays {
    /// From the first point towards the second, over `t ∈ (0, 1 −
    /// SHADOW_EPSILON)`, or up to the second point itself when that is not
    /// on a surface.
    pub main: Ray,
    /// From the second point back over the last `2·SHADOW_EPSILON` of the
    /// segment, overlapping `main`; `None` when the second point is not on a
    /// surface (`main` then reaches it).
    pub tail: Option<Ray>,
}

/// The side (±1) of the plane through a surface point with normal `ng` on
/// which the point `p + w` lies; 0 for a point on no surface (`ng` zero);
/// `None` when `ng · w` is within its rounding error bound, so that its sign
/// may disagree with the BSDF's (which evaluates the same cosine through the
/// normalised direction): such a connection is tangent to the surface to
/// within γ(5) and carries nothing.
#[inline]
pub fn side_of(ng: Vec3, w: Vec3) -> Option<f32> {
    if ng == Vec3::ZERO {
        return Some(0.0);
    }
    let c = ng.dot(w);
    if c.abs() <= gamma(5) * ng.abs().dot(w.abs()) {
        None
    } else if c < 0.0 {
        Some(-1.0)
    } else {
        Some(1.0)
    }
}

/// Occlusion rays between two points `p0`, `p1` with error bounds and
/// geometric normals (a zero normal marks a point on no surface, such as a
/// pinhole lens, which is not offset). `None` when the segment is tangent
/// to one of the surfaces to within rounding ([`side_of`]); callers treat
/// it as blocked.
///
/// Each end is offset to the side of its surface on which the *other
/// point* lies, the side that the BSDF at that end sees the connection
/// leave on. (pbrt-v4 offsets the second end towards the already offset
/// first end instead: when both points lie on one plane within their error
/// bounds — a light path on the outside of a wall, a camera path on its
/// inside — that pushed both ends outside, and the ray between them crossed
/// nothing while both BSDFs reflected.) With consistent sides, the ray
/// crosses every surface whose two sides the two BSDFs put the ends on.
///
/// The segment is covered by two rays, each starting at an offset point
/// (where the intersector's provably-positive-t test excludes that point's
/// own surface and still finds any other surface, even one crossed
/// immediately): `main` from `p0` up to 1 − `SHADOW_EPSILON`, `tail` from
/// `p1` back over 2·`SHADOW_EPSILON`. A single ray stopping short of `p1`
/// (pbrt's `SpawnRayTo`) misses a surface crossed within that margin of
/// `p1`, which on a convex mesh is every exit through a face next to `p1`'s
/// at a grazing connection: light leaked into closed meshes.
#[inline]
pub fn spawn_rays_between(
    p0: Vec3,
    e0: Vec3,
    n0: Vec3,
    p1: Vec3,
    e1: Vec3,
    n1: Vec3,
) -> Option<SegmentRays> {
    let d = p1 - p0;
    let side0 = side_of(n0, d)?;
    let side1 = side_of(n1, -d)?;
    let o = offset_to_side(p0, e0, n0, side0);
    let end = offset_to_side(p1, e1, n1, side1);
    let free_end = side1 == 0.0;
    Some(SegmentRays {
        main: Ray {
            o,
            d: end - o,
            t_max: if free_end { 1.0 } else { 1.0 - SHADOW_EPSILON },
        },
        tail: (!free_end).then(|| Ray {
            o: end,
            d: o - end,
            t_max: 2.0 * SHADOW_EPSILON,
        }),
    })
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

    /// Points on a face of the cube [-1, 1]³ next to its edges x = 1,
    /// y = −1 (whose neighbouring faces meet it at right angles) and its
    /// diagonal, weights rounded so that `1 − b1 − b2` is not the exact
    /// remainder: the point stays inside the face by the margin, its error
    /// bound covers its distance to the face's plane, and a point away
    /// from the edges is interpolated as given.
    #[test]
    fn triangle_points_keep_off_the_edges() {
        let tri = [
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(1.0, 1.0, 1.0),
        ];
        let m = 2.0 * (Vec3::ONE * gamma(7)).length();
        let below = |x: f32| next_float_down(x);
        for (b1, b2) in [
            (0.6, 0.4),
            (0.6, below(0.4)),
            (below(0.7), 0.3),
            (1.0, 0.0),
            (0.0, 0.0),
            (0.0, 1.0),
            (0.3, 0.0),
            (1e-8, 0.5),
            (below(1.0), 1e-7),
        ] {
            let tp = triangle_point(tri, b1, b2);
            let at = format!("b = ({b1}, {b2}): {tp:?}");
            assert!(tp.p.x <= 1.0 - m * 0.9 && tp.p.y >= -1.0 + m * 0.9, "{at}");
            let diagonal = (tp.p.x - tp.p.y) / 2f32.sqrt();
            assert!(diagonal >= m * 0.9, "off the diagonal: {at}");
            assert!((tp.p.z - 1.0).abs() <= tp.p_error.z, "{at}");
            assert!(tp.b.iter().all(|&b| b >= 0.0), "{at}");
            assert_eq!(tp.b.iter().sum::<f32>(), 1.0, "{at}");
        }
        let inner = triangle_point(tri, 0.5, 0.25);
        assert_eq!(inner.b, [0.25, 0.5, 0.25]);
        assert_eq!(inner.p, Vec3::new(0.5, -0.5, 1.0));
    }

    /// The squared-length shortcut ([`clear_of_margins`]) gives bit for
    /// bit the weights of the full computation ([`moved_off_edges`]), on
    /// random triangles from 10⁻⁶ to 10⁶ in size and offset, at random
    /// weights drawn so that many lie within a few margins of an edge or a
    /// vertex (where the shortcut must decline), and it takes almost every
    /// point 1 % or more clear of the margins (else it would not be worth
    /// its test).
    #[test]
    fn the_margin_shortcut_matches_the_full_computation() {
        use rand_core::Rng;
        let mut rng = rand_pcg::Pcg32::new(0x0FF5E7, 3);
        let mut unit = || (rng.next_u32() >> 8) as f32 / 16_777_216.0;
        let (mut inside, mut taken) = (0u32, 0u32);
        for n in 0..200_000 {
            let scale = 10f32.powf(unit() * 12.0 - 6.0);
            let origin = Vec3::new(unit(), unit(), unit()) * 10f32.powf(unit() * 12.0 - 6.0);
            let mut v = || origin + Vec3::new(unit(), unit(), unit()) * scale;
            let tri = [v(), v(), v()];
            // A weight at k margins' worth of its edge, k spread over
            // 10⁻² … 10⁴ on a log scale, or an ordinary interior weight.
            let max_abs = tri[0].abs().max(tri[1].abs()).max(tri[2].abs());
            let m = 2.0 * (max_abs * gamma(7)).length();
            let area2 = (tri[1] - tri[0]).cross(tri[2] - tri[0]).length();
            let l = [0, 1, 2].map(|i| m * (tri[(i + 2) % 3] - tri[(i + 1) % 3]).length() / area2);
            let mut w = || unit();
            let b1 = w() * 0.5;
            let b2 = if n % 2 == 0 {
                w() * 0.5
            } else {
                let k = 10f32.powf(w() * 6.0 - 2.0);
                (1.0 - b1 - k * l[0]).max(0.0)
            };
            let clamped = [1.0 - b1 - b2, b1, b2].map(|b: f32| b.max(0.0));
            let fast = margin_weights(tri, [1.0 - b1 - b2, b1, b2]);
            let full = moved_off_edges(tri, clamped);
            assert_eq!(
                fast.map(f32::to_bits),
                full.map(f32::to_bits),
                "{tri:?} at ({b1}, {b2})"
            );
            if (0..3).all(|i| clamped[i] > 1.01 * l[i]) {
                inside += 1;
                taken += u32::from(clear_of_margins(tri, clamped));
            }
        }
        assert!(
            taken as f32 > 0.99 * inside as f32,
            "shortcut taken at {taken} of {inside} interior points"
        );
    }

    /// Where the margin does not fit (a sliver narrower than it, the sharp
    /// end of a thin triangle) or the triangle is degenerate, the weights
    /// are only clamped to the triangle.
    #[test]
    fn triangle_points_without_room_for_the_margin_are_clamped() {
        let sliver = [
            Vec3::ZERO,
            Vec3::new(1.0, 1e-7, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
        ];
        let degenerate = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        for tri in [sliver, degenerate] {
            for ((b1, b2), b) in [
                ((0.5, 0.0), [0.5, 0.5, 0.0]),
                ((0.2, 0.3), [1.0 - 0.2 - 0.3, 0.2, 0.3]),
                ((0.0, 1.0), [0.0, 0.0, 1.0]),
                ((0.7, 0.4), [0.0, 0.6, 0.4]),
            ] {
                let tp = triangle_point(tri, b1, b2);
                assert_eq!(tp.b, b, "{tri:?}");
                assert!(tp.p.is_finite());
            }
        }
    }

    /// Whether any of the segment's rays hits one of `tris`.
    fn blocked(seg: &SegmentRays, tris: &[[Vec3; 3]]) -> bool {
        let hits = |r: &Ray| {
            tris.iter()
                .any(|t| super::super::triangle::intersect_triangle(r, t[0], t[1], t[2]).is_some())
        };
        hits(&seg.main) || seg.tail.as_ref().is_some_and(hits)
    }

    /// The square z = 1, |x|, |y| ≤ 1, as two triangles.
    const WALL: [[Vec3; 3]; 2] = [
        [
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(1.0, 1.0, 1.0),
        ],
        [
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(-1.0, 1.0, 1.0),
        ],
    ];

    /// Two points of one wall, the first lit from outside, the second seen
    /// from inside, whose computed positions put each on its own side (the
    /// first rounded one ulp inside, the stability suite's cube leak): the segment's
    /// rays cross the wall, so the connection is blocked.
    #[test]
    fn a_connection_between_the_two_sides_of_a_wall_crosses_it() {
        let ng = Vec3::new(0.0, 0.0, -1.0);
        let e = Vec3::splat(gamma(7));
        let outside = Vec3::new(-0.4996641, 0.12642178, 0.99999994);
        let inside = Vec3::new(0.6616, 0.74359167, 1.0);
        let seg = spawn_rays_between(outside, e, ng, inside, e, ng).unwrap();
        assert!(seg.main.o.z > 1.0, "the first end stays outside");
        assert!(seg.main.at(1.0).z < 1.0, "the second end stays inside");
        assert!(blocked(&seg, &WALL));
    }

    /// A segment tangent to a surface to within rounding is refused.
    #[test]
    fn a_tangent_connection_is_refused() {
        let ng = Vec3::new(0.0, 0.0, -1.0);
        let e = Vec3::splat(gamma(7));
        let a = Vec3::new(-0.5, 0.1, 1.0);
        let b = Vec3::new(0.6, 0.7, 1.0);
        assert_eq!(spawn_rays_between(a, e, ng, b, e, ng), None);
        assert!(spawn_rays_between(a, e, ng, b - 1e-3 * ng, e, Vec3::ZERO).is_some());
    }

    /// A wall crossed 10⁻⁵ before the far end of a unit segment (inside
    /// the margin the first ray leaves out near its target) blocks it:
    /// the tail ray from the far end finds it.
    #[test]
    fn a_surface_crossed_next_to_the_far_end_blocks() {
        // Floor z = 0 (p1 on it, normal up); a wall y = 0 just in front.
        let p1 = Vec3::new(0.0, 1e-5, 0.0);
        let p0 = Vec3::new(0.0, -1.0, 1.0);
        let wall = [[
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(0.0, 0.0, 2.0),
        ]];
        let e = Vec3::splat(gamma(7));
        let seg = spawn_rays_between(p0, Vec3::ZERO, Vec3::ZERO, p1, e, Vec3::Z).unwrap();
        assert!(blocked(&seg, &wall));
        assert!(
            !blocked(&SegmentRays { tail: None, ..seg }, &wall),
            "the main ray alone leaves the crossing out"
        );
        // Without the wall nothing is hit, the floor under p1 included.
        let floor = [[
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ]];
        assert!(!blocked(&seg, &floor));
    }
}
