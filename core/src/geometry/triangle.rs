//! Watertight ray–triangle intersection (Woop, Benthin, Wald 2013,
//! "Watertight Ray/Triangle Intersection", JCGT 2(1)).
//!
//! The test transforms the triangle into a ray-aligned space in which the ray
//! starts at the origin and points down +z: translate by the ray origin,
//! permute the axes so that `z` is the dominant direction axis, then shear
//! x/y so the ray becomes the z axis (paper §3, eqs. 1–4). Inside/outside is
//! decided by 2D edge functions of the sheared vertices (eq. 5). Because an
//! edge shared by two triangles is evaluated from the *same* sheared
//! vertices with the arguments swapped, the two triangles see exactly
//! negated values: a ray can never slip between them (no leaks through
//! shared edges or vertices). An exact zero is re-evaluated in f64, where the
//! products of two f32 are exact (paper §3.3), so a zero produced by
//! cancellation cannot turn a miss into a hit.
//!
//! On top of the paper, a hit must have `t` provably positive under the
//! rounding error of the test (pbrt-v4 §6.8.7); see [`WatertightRay::intersect`].
//!
//! Everything here is `no_std` and allocation-free. The arithmetic lives in
//! small `#[inline(always)]` helpers that the single-ray test and the
//! lane-parallel packet kernel of the BVH both call, so both produce
//! bit-identical `(t, b1, b2)`.

use glam::Vec3;

use super::Ray;
use super::offset::gamma;

/// Per-ray precomputation of the watertight test (paper §3.2): the axis
/// permutation and the shear constants.
///
/// Build it once per ray, then test any number of triangles with
/// [`WatertightRay::intersect`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WatertightRay {
    /// Axis permutation `[kx, ky, kz]`: `kz` is the axis of the largest
    /// `|d|` component; `kx, ky` follow cyclically, swapped when `d[kz] < 0`
    /// to preserve the triangles' winding in the sheared space.
    pub(crate) k: [usize; 3],
    /// The ray origin, permuted: `[o[kx], o[ky], o[kz]]`.
    pub(crate) org: [f32; 3],
    /// Shear constants `[Sx, Sy, Sz] = [d[kx]/d[kz], d[ky]/d[kz], 1/d[kz]]`.
    pub(crate) shear: [f32; 3],
}

impl WatertightRay {
    /// Precomputes the permutation and shear of `ray`.
    ///
    /// `None` when the origin or direction has a non-finite component or the
    /// direction is zero: such a ray hits nothing. (`ray.t_max` is not looked
    /// at; it is passed to [`WatertightRay::intersect`].)
    #[inline]
    pub fn new(ray: &Ray) -> Option<Self> {
        let o = ray.o.to_array();
        let d = ray.d.to_array();
        if !(ray.o.is_finite() && ray.d.is_finite()) {
            return None;
        }
        let a = [abs(d[0]), abs(d[1]), abs(d[2])];
        // Dominant axis; the first one wins a tie, deterministically.
        let kz = if a[0] >= a[1] && a[0] >= a[2] {
            0
        } else if a[1] >= a[2] {
            1
        } else {
            2
        };
        if d[kz] == 0.0 {
            return None;
        }
        let mut kx = if kz == 2 { 0 } else { kz + 1 };
        let mut ky = if kx == 2 { 0 } else { kx + 1 };
        if d[kz] < 0.0 {
            core::mem::swap(&mut kx, &mut ky);
        }
        let sz = 1.0 / d[kz];
        Some(WatertightRay {
            k: [kx, ky, kz],
            org: [o[kx], o[ky], o[kz]],
            shear: [d[kx] / d[kz], d[ky] / d[kz], sz],
        })
    }

    /// Vertex `p` in ray space: translated, permuted and sheared (eqs. 1–4).
    #[inline(always)]
    fn ray_space(&self, p: Vec3) -> [f32; 4] {
        // Padded to 4 and masked so the gathers need no bounds checks.
        let p = [p.x, p.y, p.z, p.z];
        transform(
            p[self.k[0] & 3],
            p[self.k[1] & 3],
            p[self.k[2] & 3],
            self.org,
            self.shear,
        )
    }

    /// Intersects triangle `(p0, p1, p2)`: `(t, b1, b2)` for a hit with
    /// `t` in `(0, t_max)`, where the hit point is
    /// `(1 − b1 − b2)·p0 + b1·p1 + b2·p2`. Both faces are hit.
    ///
    /// Triangles that are degenerate because two vertices coincide always
    /// miss (their edge functions cancel exactly); for the general
    /// zero-area check see [`is_degenerate`]. Non-finite vertices miss.
    ///
    /// Hits are also rejected when `t` is not provably positive given the
    /// rounding error of the test (pbrt-v4 §6.8.7): this is what lets a ray
    /// spawned with [`super::offset::offset_ray_origin`] never re-hit its own
    /// triangle.
    #[inline(always)]
    pub fn intersect(&self, p0: Vec3, p1: Vec3, p2: Vec3, t_max: f32) -> Option<(f32, f32, f32)> {
        let a = self.ray_space(p0);
        let b = self.ray_space(p1);
        let c = self.ray_space(p2);
        let (mut u, mut v, mut w) = edge_functions(a, b, c);
        if u == 0.0 || v == 0.0 || w == 0.0 {
            (u, v, w) = edge_functions_f64(a, b, c);
        }
        // Mixed signs: outside. Zeros are compatible with either sign, so a
        // ray through an edge or vertex is inside every triangle sharing it
        // whose other edge functions agree (no back-face culling).
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let (t, b1, b2, dt) = solve(a, b, c, u, v, w, det);
        let t = if t > dt {
            t
        } else if t > -dt {
            decide_t_f64(t, [p0, p1, p2], self.k, self.org, self.shear)?
        } else {
            return None;
        };
        (t < t_max).then_some((t, b1, b2))
    }
}

/// Four triangles in SoA form, `planes[vertex][axis][lane]`: the layout of
/// the BVH's leaf blocks (`accel::bvh::TriBlock`), one triangle per lane.
pub(crate) type Planes4 = [[[f32; 4]; 3]; 3];

/// Lane `l`'s triangle of `p`.
#[inline(always)]
pub(crate) fn planes_tri(p: &Planes4, l: usize) -> [Vec3; 3] {
    let l = l & 3;
    let v = |v: usize| Vec3::new(p[v][0][l], p[v][1][l], p[v][2][l]);
    [v(0), v(1), v(2)]
}

impl WatertightRay {
    /// The closest hit among `count` triangles `tri(0..count)`:
    /// `(index, t, b1, b2)` with `t` in `(0, t_max)`, the first of equally
    /// close hits. Tests them one by one with [`WatertightRay::intersect`],
    /// shrinking `t_max` at each hit; with `ANY`, stops at the first hit.
    #[inline(always)]
    pub(crate) fn intersect_many<const ANY: bool>(
        &self,
        count: usize,
        tri: impl Fn(usize) -> [Vec3; 3],
        mut t_max: f32,
    ) -> Option<(usize, f32, f32, f32)> {
        let mut best = None;
        for j in 0..count {
            let tri = tri(j);
            if let Some((t, b1, b2)) = self.intersect(tri[0], tri[1], tri[2], t_max) {
                t_max = t;
                best = Some((j, t, b1, b2));
                if ANY {
                    break;
                }
            }
        }
        best
    }
}

/// Intersects `ray` with triangle (p0, p1, p2): `(t, b1, b2)` for `t` in
/// `(0, ray.t_max)`, hit point `(1 − b1 − b2)·p0 + b1·p1 + b2·p2`.
///
/// Convenience wrapper: precomputes a [`WatertightRay`] (better done once
/// per ray when testing many triangles) and rejects degenerate triangles
/// ([`is_degenerate`]). Non-finite rays or vertices give `None`.
#[inline]
pub fn intersect_triangle(ray: &Ray, p0: Vec3, p1: Vec3, p2: Vec3) -> Option<(f32, f32, f32)> {
    if is_degenerate(p0, p1, p2) {
        return None;
    }
    WatertightRay::new(ray)?.intersect(p0, p1, p2, ray.t_max)
}

/// True for triangles that can never be hit: a non-finite vertex, or zero
/// area, i.e. `(p1 − p0) × (p2 − p0)` evaluates to exactly zero in f64
/// (coincident vertices, and collinear ones in all but contrived cases).
///
/// Accelerators leave these triangles out and the brute-force reference
/// skips them, so that all backends agree on them.
#[inline]
pub fn is_degenerate(p0: Vec3, p1: Vec3, p2: Vec3) -> bool {
    if !(p0.is_finite() && p1.is_finite() && p2.is_finite()) {
        return true;
    }
    let d = |a: f32, b: f32| f64::from(a) - f64::from(b);
    let e1 = [d(p1.x, p0.x), d(p1.y, p0.y), d(p1.z, p0.z)];
    let e2 = [d(p2.x, p0.x), d(p2.y, p0.y), d(p2.z, p0.z)];
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    n == [0.0; 3]
}

// ---------------------------------------------------------------------------
// Shared arithmetic. The single-ray test above and the lane-parallel kernel
// below evaluate exactly these expressions, in this order, so their results
// are bit-identical (Rust never contracts a*b+c into an FMA on its own).

#[inline(always)]
fn abs(x: f32) -> f32 {
    f32::from_bits(x.to_bits() & 0x7fff_ffff)
}

/// Translation, then shear (paper eqs. 3–4) of a vertex whose components are
/// already permuted to `(x=kx, y=ky, z=kz)`: `[x', y', z'·Sz, z']`.
///
/// `x', y'` and the unscaled `z'` are in world units; `z'·Sz` is in units of
/// the ray parameter `t`. The error bound in [`solve`] needs both.
#[inline(always)]
fn transform(px: f32, py: f32, pz: f32, org: [f32; 3], shear: [f32; 3]) -> [f32; 4] {
    let ax = px - org[0];
    let ay = py - org[1];
    let az = pz - org[2];
    [ax - shear[0] * az, ay - shear[1] * az, shear[2] * az, az]
}

/// The 2D edge functions (paper eq. 5): `U` is the weight of vertex 0 (edge
/// 1→2), `V` of vertex 1 (edge 2→0), `W` of vertex 2 (edge 0→1), all scaled
/// by the determinant.
#[inline(always)]
fn edge_functions(a: [f32; 4], b: [f32; 4], c: [f32; 4]) -> (f32, f32, f32) {
    let u = c[0] * b[1] - c[1] * b[0];
    let v = a[0] * c[1] - a[1] * c[0];
    let w = b[0] * a[1] - b[1] * a[0];
    (u, v, w)
}

/// The edge functions re-evaluated in f64 (paper §3.3): products of two f32
/// are exact in f64, so the sign of each difference is exact. Only reached
/// when an f32 edge function is exactly zero.
#[cold]
#[inline(never)]
fn edge_functions_f64(a: [f32; 4], b: [f32; 4], c: [f32; 4]) -> (f32, f32, f32) {
    let [ax, ay, bx, by, cx, cy] = [a[0], a[1], b[0], b[1], c[0], c[1]].map(f64::from);
    let u = (cx * by - cy * bx) as f32;
    let v = (ax * cy - ay * cx) as f32;
    let w = (bx * ay - by * ax) as f32;
    (u, v, w)
}

/// Hit distance, barycentrics and the conservative lower bound `δt` on a
/// provably positive `t`, given nonzero `det = U + V + W`.
///
/// `t = (U·Az + V·Bz + W·Cz) / det` (paper eq. 6). `δt` is the rounding
/// error bound of that `t` derived in pbrt-v4 §6.8.7 for this same
/// translate/permute/shear arithmetic: a hit with `t ≤ δt` may lie behind
/// the origin and is rejected.
///
/// One deliberate difference: the x/y shear error `δx = γ(5)(max|x'| +
/// max|z'|)` uses the *unscaled* `z'` (world units, like `x'`), where pbrt
/// uses `z'·Sz`. The two agree only for unit-length directions; with the
/// scaled one, a short unnormalised direction (`|d| ≪ 1`) inflates `δt` to
/// the point of rejecting genuine hits at `t ≈ 1`.
#[inline(always)]
fn solve(
    a: [f32; 4],
    b: [f32; 4],
    c: [f32; 4],
    u: f32,
    v: f32,
    w: f32,
    det: f32,
) -> (f32, f32, f32, f32) {
    let t_scaled = u * a[2] + v * b[2] + w * c[2];
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    let b1 = v * inv_det;
    let b2 = w * inv_det;

    let max_x = max3(abs(a[0]), abs(b[0]), abs(c[0]));
    let max_y = max3(abs(a[1]), abs(b[1]), abs(c[1]));
    let max_z = max3(abs(a[2]), abs(b[2]), abs(c[2]));
    let max_zw = max3(abs(a[3]), abs(b[3]), abs(c[3]));
    let delta_z = gamma(3) * max_z;
    let delta_x = gamma(5) * (max_x + max_zw);
    let delta_y = gamma(5) * (max_y + max_zw);
    let delta_e = 2.0 * (gamma(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
    let max_e = max3(abs(u), abs(v), abs(w));
    let delta_t =
        3.0 * (gamma(3) * max_e * max_z + delta_e * max_z + delta_z * max_e) * abs(inv_det);
    (t, b1, b2, delta_t)
}

/// The hit distance of a ray with a triangle whose edge functions say
/// "inside", when its f32 value `t` is within the bound `δt` of [`solve`]
/// of zero (either sign): `t` itself when it is positive, the f64 distance
/// when only that is, `None` when the hit is not provably in front of the
/// origin. Both kernels call this, so they stay bit-identical.
///
/// A ray that starts next to a surface and crosses it at once has a `t`
/// below `δt`, and its f32 value may come out ≤ 0: the walk from a hit
/// next to a mesh edge, spawned a few ulps inside the adjacent face,
/// missed that face and left the closed mesh (the stability suite's edge
/// leak).
#[inline(always)]
pub(crate) fn decide_t_f64(
    t: f32,
    tri: [Vec3; 3],
    k: [usize; 3],
    org: [f32; 3],
    shear: [f32; 3],
) -> Option<f32> {
    let (num, den) = positive_t_f64(tri, k, org, shear)?;
    Some(certified_t(t, num, den, shear[2]))
}

/// The distance of a hit [`positive_t_f64`] certified to lie in front of
/// the origin: the f32 `t` when it is positive, else the f64 quotient
/// rounded to f32 and kept positive (the division is left to this rare
/// case).
#[inline(always)]
fn certified_t(t: f32, num: f64, den: f64, shear_z: f32) -> f32 {
    if t > 0.0 {
        t
    } else {
        (((num / den) * f64::from(shear_z)) as f32).max(f32::from_bits(1))
    }
}

/// Whether the hit of a ray with a triangle whose edge functions say
/// "inside" lies provably in front of the origin: then `Some((num, den))`,
/// the hit distance in units of `|d|` being `num / den · shear₂`. Decided
/// in f64 from the unrounded inputs: the ray's permuted
/// origin `org` and sheared direction `(shear₀, shear₁, 1)·d_z`
/// (permutation `k`) and the world-space vertices.
///
/// Reached only when the f32 `t` is not provably of either sign (within
/// the bound `δt` of [`solve`]). That bound grows with the triangle's
/// extent, so a triangle much larger than its distance to the origin (a
/// 10⁶-wide ceiling one unit above the camera: a stability-suite case)
/// was missed altogether. In f64, `t = ((p₀ − o)·n) / (d·n)` with
/// `n = (p₁ − p₀) × (p₂ − p₀)` has a relative error near 2⁻⁵⁰ instead; the
/// sign is accepted only when both numerator and denominator exceed their
/// error bounds (conservatively counting the f32 rounding of the shear),
/// so a ray spawned off its own triangle is still never re-hit.
#[cold]
#[inline(never)]
fn positive_t_f64(
    tri: [Vec3; 3],
    k: [usize; 3],
    org: [f32; 3],
    shear: [f32; 3],
) -> Option<(f64, f64)> {
    // No `array::map` here: it compiled to outlined `try_map` calls, a
    // measurable share of this function's cost on shadow rays.
    let (kx, ky, kz) = (k[0] % 3, k[1] % 3, k[2] % 3);
    let perm = |p: Vec3| {
        let a = p.to_array();
        [f64::from(a[kx]), f64::from(a[ky]), f64::from(a[kz])]
    };
    let (positive, num, den) = t_sign_f64([perm(tri[0]), perm(tri[1]), perm(tri[2])], org, shear);
    positive.then_some((num, den))
}

/// The arithmetic of [`positive_t_f64`] on permuted f64 vertices:
/// `(provably positive, num, den)`. Branch-free, so the lane loop of
/// [`positive_t_f64_lanes`] vectorises; both forms give the same bits.
#[inline(always)]
fn t_sign_f64(p: [[f64; 3]; 3], org: [f32; 3], shear: [f32; 3]) -> (bool, f64, f64) {
    let [p0, p1, p2] = p;
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let (e1, e2) = (sub(p1, p0), sub(p2, p0));
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let n_abs = [
        (e1[1] * e2[2]).abs() + (e1[2] * e2[1]).abs(),
        (e1[2] * e2[0]).abs() + (e1[0] * e2[2]).abs(),
        (e1[0] * e2[1]).abs() + (e1[1] * e2[0]).abs(),
    ];
    let q = sub(
        p0,
        [f64::from(org[0]), f64::from(org[1]), f64::from(org[2])],
    );
    let d = [f64::from(shear[0]), f64::from(shear[1]), 1.0];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let abs3 = |a: [f64; 3]| [a[0].abs(), a[1].abs(), a[2].abs()];
    // γ(12) in f64 for the differences, the cross product and the dot
    // product; 2⁻²² more for the denominator's f32 shear.
    let g = 12.0 * f64::EPSILON;
    let (num, num_err) = (dot(q, n), g * dot(abs3(q), n_abs));
    let (den, den_err) = (
        dot(d, n),
        (g + 1.0 / 4_194_304.0/* 2⁻²² */) * dot(abs3(d), n_abs),
    );
    // `&`, not `&&`, to stay branch-free (NaN compares false either way).
    let certain = (num.abs() > num_err) & (den.abs() > den_err);
    // t in units of |d| is num / den times 1 / d_z = shear₂; its sign is
    // the product of the three signs (all three are non-zero when certain).
    let negatives = (num < 0.0) as u32 + (den < 0.0) as u32 + (shear[2] < 0.0) as u32;
    (certain & negatives.is_multiple_of(2), num, den)
}

/// [`positive_t_f64`] for every lane of a packet at once, from the
/// permuted vertices `sel[vertex][axis][lane]` that [`intersect_lanes`]
/// already selected: bit `i` of the mask says lane `i`'s hit is provably
/// in front of its origin, with its `num`, `den`. The lane loop is
/// branch-free, so LLVM vectorises the f64 arithmetic; one call costs
/// about as much as two scalar ones, and a shadow packet leaving a surface
/// has some ten of 16 lanes to decide per triangle (measured).
#[inline(always)]
fn positive_t_f64_lanes<const N: usize>(
    sel: &[[[f32; N]; 3]; 3],
    r: &WatertightLanes<N>,
) -> (u32, [f64; N], [f64; N]) {
    let mut positive = [false; N];
    let mut num = [0.0f64; N];
    let mut den = [0.0f64; N];
    for i in 0..N {
        let p = |vi: usize| {
            let [x, y, z] = &sel[vi];
            [f64::from(x[i]), f64::from(y[i]), f64::from(z[i])]
        };
        let org = [r.org[0][i], r.org[1][i], r.org[2][i]];
        let shear = [r.shear[0][i], r.shear[1][i], r.shear[2][i]];
        (positive[i], num[i], den[i]) = t_sign_f64([p(0), p(1), p(2)], org, shear);
    }
    (lane_mask(&positive), num, den)
}

#[inline(always)]
fn max3(a: f32, b: f32, c: f32) -> f32 {
    let m = if a > b { a } else { b };
    if m > c { m } else { c }
}

// ---------------------------------------------------------------------------
// Lane-parallel form for packet traversal.

/// Watertight precomputation for `N` rays in SoA form, the packet
/// counterpart of [`WatertightRay`]. Lanes that carry no ray hold a benign
/// dummy (finite, never hitting) so kernels may compute all lanes and mask.
#[derive(Clone, Copy, Debug)]
pub(crate) struct WatertightLanes<const N: usize> {
    /// Permutation per lane, `k[j][i]` = axis `j` of lane `i`.
    pub k: [[u32; N]; 3],
    /// Permuted origin per lane.
    pub org: [[f32; N]; 3],
    /// Shear constants per lane.
    pub shear: [[f32; N]; 3],
    /// The permutation shared by all live lanes, if there is one (typical
    /// of coherent bundles): vertex components are then picked once per
    /// triangle instead of once per lane.
    pub uniform: Option<[usize; 3]>,
    /// Lane masks of `k[j][i] == 0` and `k[j][i] == 1` per axis `j`, for
    /// picking vertex components by mask; set by [`Self::finish`] when
    /// `uniform` is `None` (the only case that reads them).
    pub k_is: [[u32; 2]; 3],
}

impl<const N: usize> WatertightLanes<N> {
    /// All lanes dummies (origin 0, ray along +z).
    pub fn new() -> Self {
        WatertightLanes {
            k: [[0; N], [1; N], [2; N]],
            org: [[0.0; N]; 3],
            shear: [[0.0; N], [0.0; N], [1.0; N]],
            uniform: None,
            k_is: [[0; 2]; 3],
        }
    }

    /// Stores lane `i`.
    #[cfg(test)]
    #[inline]
    pub fn set(&mut self, i: usize, r: &WatertightRay) {
        for j in 0..3 {
            self.k[j][i] = r.k[j] as u32;
            self.org[j][i] = r.org[j];
            self.shear[j][i] = r.shear[j];
        }
    }

    /// Lane `i` as a single ray, bit for bit.
    #[inline]
    pub fn get(&self, i: usize) -> WatertightRay {
        WatertightRay {
            // Spelled out: `array::map` compiled to outlined calls here.
            k: [
                self.k[0][i] as usize,
                self.k[1][i] as usize,
                self.k[2][i] as usize,
            ],
            org: [self.org[0][i], self.org[1][i], self.org[2][i]],
            shear: [self.shear[0][i], self.shear[1][i], self.shear[2][i]],
        }
    }

    /// Sets up, branch-free, every lane of `lanes` whose ray (origin `o`,
    /// direction `d`, SoA) is valid for [`WatertightRay::new`], bit for bit
    /// as that function would; returns those lanes. The other lanes become
    /// dummies, as [`Self::new`] makes them.
    #[inline(always)]
    pub fn set_lanes(&mut self, o: [&[f32; N]; 3], d: [&[f32; N]; 3], lanes: u32) -> u32 {
        let mut ok = [false; N];
        // Every lane is written, an invalid one with the dummy's constants:
        // keeping the old value instead (`if valid { .. } else {
        // self.k[j][i] }`) was compiled to masked stores (`vmaskmovps`),
        // which AMD's cores run as long microcoded sequences; with nine of
        // them per register of lanes, this set-up took a fifth of the time
        // of packets of 8 on cornell-box's MTM bundles (Zen 4, perf
        // samples).
        let dummy = Self::new();
        for i in 0..N {
            let (ox, oy, oz) = (o[0][i], o[1][i], o[2][i]);
            let (dx, dy, dz) = (d[0][i], d[1][i], d[2][i]);
            let finite = ox.is_finite()
                && oy.is_finite()
                && oz.is_finite()
                && dx.is_finite()
                && dy.is_finite()
                && dz.is_finite();
            let (ax, ay, az) = (abs(dx), abs(dy), abs(dz));
            // Dominant axis as in `WatertightRay::new` (first wins a tie),
            // then kx, ky cyclically after it.
            let z0 = ax >= ay && ax >= az;
            let z1 = !z0 && ay >= az;
            let (kx, ky, kz) = if z0 {
                (1u32, 2u32, 0u32)
            } else if z1 {
                (2, 0, 1)
            } else {
                (0, 1, 2)
            };
            let pick = |k: u32, v: [f32; 3]| {
                if k == 0 {
                    v[0]
                } else if k == 1 {
                    v[1]
                } else {
                    v[2]
                }
            };
            let (dv, ov) = ([dx, dy, dz], [ox, oy, oz]);
            let dkz = pick(kz, dv);
            // Swapped for a negative dominant component.
            let swap = dkz < 0.0;
            let (kx, ky) = if swap { (ky, kx) } else { (kx, ky) };
            let (dkx, dky) = (pick(kx, dv), pick(ky, dv));
            let valid = lanes >> i & 1 != 0 && finite && dkz != 0.0;
            ok[i] = valid;
            let k = [kx, ky, kz];
            let org = [pick(kx, ov), pick(ky, ov), pick(kz, ov)];
            let shear = [dkx / dkz, dky / dkz, 1.0 / dkz];
            for j in 0..3 {
                self.k[j][i] = if valid { k[j] } else { dummy.k[j][i] };
                self.org[j][i] = if valid { org[j] } else { dummy.org[j][i] };
                self.shear[j][i] = if valid { shear[j] } else { dummy.shear[j][i] };
            }
        }
        lane_mask(&ok)
    }

    /// Records whether the lanes in `live` share one permutation, and the
    /// permutation masks (call after the last [`Self::set_lanes`]). Dummy lanes
    /// may then be evaluated with the shared permutation; their results are
    /// masked anyway.
    #[inline(always)]
    pub fn finish(&mut self, live: u32) {
        let first = live.trailing_zeros() as usize;
        self.uniform = None;
        if first < N {
            let k0 = [0, 1, 2].map(|j| self.k[j][first]);
            let mut same = [true; N];
            for (i, s) in same.iter_mut().enumerate() {
                *s = self.k[0][i] == k0[0] && self.k[1][i] == k0[1] && self.k[2][i] == k0[2];
            }
            if lane_mask(&same) & live == live {
                self.uniform = Some(k0.map(|k| k as usize & 3));
            }
        }
        // The masks are read only when there is no shared permutation.
        if self.uniform.is_none() {
            for j in 0..3 {
                for (v, m) in self.k_is[j].iter_mut().enumerate() {
                    let mut is = [false; N];
                    for (f, &k) in is.iter_mut().zip(&self.k[j]) {
                        *f = k == v as u32;
                    }
                    *m = lane_mask(&is);
                }
            }
        }
    }
}

/// Hits of one triangle for all `N` lanes of a packet: bit `i` of the
/// returned mask is set when lane `i` (restricted to `lanes`) hits with `t`
/// provably positive and below `t_max[i]`; `t`, `b1`, `b2` are valid for
/// those lanes only.
///
/// The lane loops are branch-free (selects, `&` rather than `&&`) so LLVM
/// vectorises them; the rare lanes with an exactly zero edge function are
/// redone by [`WatertightRay::intersect`] (which re-evaluates them in f64),
/// and the distance/barycentric part is skipped when no lane is inside the
/// edges. Per lane, every value is bit-identical to
/// [`WatertightRay::intersect`].
#[inline(always)]
pub(crate) fn intersect_lanes<const N: usize>(
    r: &WatertightLanes<N>,
    tri: &[Vec3; 3],
    t_max: &[f32; N],
    lanes: u32,
    t: &mut [f32; N],
    b1: &mut [f32; N],
    b2: &mut [f32; N],
) -> u32 {
    let sel = permuted_lanes(r, tri);
    // Vertex `vi` of lane `i` in ray space. Recomputed where needed rather
    // than stored: writing all twelve ray-space arrays per triangle and
    // reading them back was a fifth of the packet kernel's time, and most
    // triangles are missed by every lane before `solve` is reached.
    let vertex = |vi: usize, i: usize| {
        transform(
            sel[vi][0][i],
            sel[vi][1][i],
            sel[vi][2][i],
            [r.org[0][i], r.org[1][i], r.org[2][i]],
            [r.shear[0][i], r.shear[1][i], r.shear[2][i]],
        )
    };

    // Edge functions and the inside test, in one loop whose values stay in
    // registers. Lanes with an exact zero edge function (rare) are redone
    // below by the single-ray test, which re-evaluates them in f64.
    let mut zero_lane = [false; N];
    let mut inside_lane = [false; N];
    for i in 0..N {
        let (ui, vi, wi) = edge_functions(vertex(0, i), vertex(1, i), vertex(2, i));
        zero_lane[i] = (ui == 0.0) | (vi == 0.0) | (wi == 0.0);
        let mixed = ((ui < 0.0) | (vi < 0.0) | (wi < 0.0)) & ((ui > 0.0) | (vi > 0.0) | (wi > 0.0));
        inside_lane[i] = !mixed;
    }
    let zero = lane_mask(&zero_lane) & lanes;
    let inside = lane_mask(&inside_lane) & lanes & !zero;
    let (mut ok, mut unsure) = (0, 0);
    if inside != 0 {
        let mut ok_lane = [false; N];
        let mut unsure_lane = [false; N];
        for i in 0..N {
            let (a, b, c) = (vertex(0, i), vertex(1, i), vertex(2, i));
            let (ui, vi, wi) = edge_functions(a, b, c);
            let det = ui + vi + wi;
            let (ti, b1i, b2i, dt) = solve(a, b, c, ui, vi, wi, det);
            t[i] = ti;
            b1[i] = b1i;
            b2[i] = b2i;
            // `&`, not `&&`: short-circuits became branches and kept LLVM
            // from vectorising this loop (it ran lane by lane in scalar
            // code).
            ok_lane[i] = (det != 0.0) & (ti > dt) & (ti < t_max[i]);
            unsure_lane[i] = (det != 0.0) & (ti <= dt) & (ti > -dt);
        }
        ok = lane_mask(&ok_lane) & inside;
        unsure = lane_mask(&unsure_lane) & inside;
    }
    finish_lanes(r, tri, t_max, ok, unsure, zero, Some(&sel), t, b1, b2)
}

/// The vertices' components permuted per lane, `sel[vertex][axis][lane]`
/// (splats when the lanes share a permutation): what the lane tests
/// compute with. Picking a component is exact, so every form of the test
/// that picks them otherwise (from registers, from a leaf block) has the
/// same values in its lanes.
#[inline(always)]
pub(crate) fn permuted_lanes<const N: usize>(
    r: &WatertightLanes<N>,
    tri: &[Vec3; 3],
) -> [[[f32; N]; 3]; 3] {
    let mut sel = [[[0.0f32; N]; 3]; 3];
    for (vi, p) in tri.iter().enumerate() {
        let pv = [p.x, p.y, p.z, p.z];
        if let Some(k) = r.uniform {
            for (j, s) in sel[vi].iter_mut().enumerate() {
                *s = [pv[k[j]]; N];
            }
        } else {
            for (j, s) in sel[vi].iter_mut().enumerate() {
                for (si, &k) in s.iter_mut().zip(&r.k[j]) {
                    *si = if k == 0 {
                        pv[0]
                    } else if k == 1 {
                        pv[1]
                    } else {
                        pv[2]
                    };
                }
            }
        }
    }
    sel
}

/// The part of [`intersect_lanes`] after the f32 test, shared by its
/// portable and register forms: lanes `ok` hit already; lanes `unsure`
/// (inside, with an f32 `t` not provably of either sign) are decided in
/// f64 from `sel` (the permuted vertices, as [`intersect_lanes`] selects
/// them; only the `unsure` lanes are read, and it may be `None` when there
/// are none), all at once, as the single-ray test decides them — a packet
/// leaving the surface its rays start on has many; lanes `zero` (an exactly
/// zero edge function) are redone by the single-ray test. Returns the lanes
/// that hit.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn finish_lanes<const N: usize>(
    r: &WatertightLanes<N>,
    tri: &[Vec3; 3],
    t_max: &[f32; N],
    mut ok: u32,
    mut unsure: u32,
    mut zero: u32,
    sel: Option<&[[[f32; N]; 3]; 3]>,
    t: &mut [f32; N],
    b1: &mut [f32; N],
    b2: &mut [f32; N],
) -> u32 {
    debug_assert!(unsure == 0 || sel.is_some());
    if let (true, Some(sel)) = (unsure != 0, sel) {
        let (positive, num, den) = positive_t_f64_lanes(sel, r);
        unsure &= positive;
        while unsure != 0 {
            let i = unsure.trailing_zeros() as usize;
            unsure &= unsure - 1;
            t[i] = certified_t(t[i], num[i], den[i], r.shear[2][i]);
            ok |= ((t[i] < t_max[i]) as u32) << i;
        }
    }
    while zero != 0 {
        let i = zero.trailing_zeros() as usize;
        zero &= zero - 1;
        if let Some((ti, b1i, b2i)) = r.get(i).intersect(tri[0], tri[1], tri[2], t_max[i]) {
            (t[i], b1[i], b2[i]) = (ti, b1i, b2i);
            ok |= 1 << i;
        }
    }
    ok
}

/// Bit `i` set where `flags[i]` (`N ≤ 32`).
///
/// Eight flags at a time as the bytes of a `u64` (each 0 or 1): the
/// multiplication moves byte `i`'s bit to bit `56 + i` with no carries
/// (the other partial products land on distinct lower bits), so the top
/// byte is the mask. LLVM turns the plain per-lane loop into a long
/// shift-and-or reduction of a vector instead.
#[inline(always)]
pub(crate) fn lane_mask<const N: usize>(flags: &[bool; N]) -> u32 {
    const MAGIC: u64 = 0x0102_0408_1020_4080;
    let mut m = 0u32;
    let mut chunks = flags.chunks_exact(8);
    for (k, c) in chunks.by_ref().enumerate() {
        let bytes: [u8; 8] = core::array::from_fn(|j| c[j] as u8);
        let b = u64::from_le_bytes(bytes);
        m |= ((b.wrapping_mul(MAGIC) >> 56) as u32) << (8 * k);
    }
    let base = N - chunks.remainder().len();
    for (j, &f) in chunks.remainder().iter().enumerate() {
        m |= (f as u32) << (base + j);
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    // The register kernels live with the BVH's other kernels; these tests
    // hold them to the portable form defined here.
    #[cfg(target_arch = "x86_64")]
    use crate::accel::bvh::kernel::triangle::intersect_lanes_simd as kernel_lanes;

    /// [`intersect_lanes`] in every form this CPU runs — portable, and in
    /// SSE2, AVX2 and AVX-512F registers where `N` fits — which must agree
    /// exactly (the hit mask and the bits of each hit's `t`, `b1`, `b2`);
    /// returns the portable answer for the test to check.
    fn every_lanes_form<const N: usize>(
        r: &WatertightLanes<N>,
        tri: &[Vec3; 3],
        t_max: &[f32; N],
        lanes: u32,
        t: &mut [f32; N],
        b1: &mut [f32; N],
        b2: &mut [f32; N],
    ) -> u32 {
        let m = intersect_lanes(r, tri, t_max, lanes, t, b1, b2);
        #[cfg(target_arch = "x86_64")]
        {
            // The triangle in one slot of a block whose other slots hold
            // something else, in each of the four slots in turn.
            let other = [Vec3::new(9.0, 8.0, 7.0), Vec3::new(-3.0, 2.0, 5.0), Vec3::X];
            use core::arch::x86_64::{__m128, __m256, __m512};
            type Form<const N: usize> = fn(
                &WatertightLanes<N>,
                &Planes4,
                usize,
                &[f32; N],
                u32,
                &mut [f32; N],
                &mut [f32; N],
                &mut [f32; N],
            ) -> u32;
            #[target_feature(enable = "avx2")]
            #[allow(clippy::too_many_arguments)]
            fn avx2<const N: usize>(
                r: &WatertightLanes<N>,
                planes: &Planes4,
                slot: usize,
                t_max: &[f32; N],
                lanes: u32,
                t: &mut [f32; N],
                b1: &mut [f32; N],
                b2: &mut [f32; N],
            ) -> u32 {
                kernel_lanes::<__m256, N>(r, planes, slot, t_max, lanes, t, b1, b2)
            }
            #[target_feature(enable = "avx2,avx512f")]
            #[allow(clippy::too_many_arguments)]
            fn avx512<const N: usize>(
                r: &WatertightLanes<N>,
                planes: &Planes4,
                slot: usize,
                t_max: &[f32; N],
                lanes: u32,
                t: &mut [f32; N],
                b1: &mut [f32; N],
                b2: &mut [f32; N],
            ) -> u32 {
                kernel_lanes::<__m512, N>(r, planes, slot, t_max, lanes, t, b1, b2)
            }
            let mut forms: Vec<(&str, Form<N>)> = Vec::new();
            if N.is_multiple_of(4) {
                forms.push(("sse2", kernel_lanes::<__m128, N>));
            }
            if N.is_multiple_of(8) && std::is_x86_feature_detected!("avx2") {
                // SAFETY: AVX2 was just detected.
                forms.push(("avx2", |r, p, slot, tm, l, t, b1, b2| unsafe {
                    avx2(r, p, slot, tm, l, t, b1, b2)
                }));
            }
            if N.is_multiple_of(16)
                && std::is_x86_feature_detected!("avx2")
                && std::is_x86_feature_detected!("avx512f")
            {
                // SAFETY: AVX2 and AVX-512F were just detected.
                forms.push(("avx512", |r, p, slot, tm, l, t, b1, b2| unsafe {
                    avx512(r, p, slot, tm, l, t, b1, b2)
                }));
            }
            for (name, form) in forms {
                for slot in 0..4 {
                    let mut planes: Planes4 = [[[0.0; 4]; 3]; 3];
                    for (vi, rows) in planes.iter_mut().enumerate() {
                        for (a, row) in rows.iter_mut().enumerate() {
                            for (l, x) in row.iter_mut().enumerate() {
                                let v = if l == slot { tri } else { &other };
                                *x = v[vi].to_array()[a];
                            }
                        }
                    }
                    let (mut ft, mut fb1, mut fb2) = ([0.0; N], [0.0; N], [0.0; N]);
                    let fm = form(r, &planes, slot, t_max, lanes, &mut ft, &mut fb1, &mut fb2);
                    assert_eq!(fm, m, "{name}, slot {slot}: hit lanes");
                    for i in (0..N).filter(|&i| m >> i & 1 == 1) {
                        assert_eq!(
                            [ft[i], fb1[i], fb2[i]].map(f32::to_bits),
                            [t[i], b1[i], b2[i]].map(f32::to_bits),
                            "{name}, slot {slot}: lane {i}"
                        );
                    }
                }
            }
        }
        m
    }

    fn ray(o: Vec3, d: Vec3) -> Ray {
        Ray::new(o, d)
    }

    #[test]
    fn hits_and_barycentrics() {
        let (p0, p1, p2) = (
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        );
        for d in [Vec3::Z, -Vec3::Z] {
            let o = Vec3::new(0.25, 0.5, 0.0) - d * 2.0;
            let (t, b1, b2) = intersect_triangle(&ray(o, d), p0, p1, p2).unwrap();
            assert_eq!((t, b1, b2), (2.0, 0.25, 0.5));
        }
        // Unnormalised direction: t in units of |d|.
        let (t, ..) = intersect_triangle(
            &ray(Vec3::new(0.25, 0.25, 4.0), Vec3::new(0.0, 0.0, -2.0)),
            p0,
            p1,
            p2,
        )
        .unwrap();
        assert_eq!(t, 2.0);
        // Open interval.
        let mut r = ray(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z);
        r.t_max = 1.0;
        assert!(intersect_triangle(&r, p0, p1, p2).is_none());
        r.t_max = 1.0000001;
        assert!(intersect_triangle(&r, p0, p1, p2).is_some());
        assert!(
            intersect_triangle(&ray(Vec3::new(0.25, 0.25, 1.0), Vec3::Z), p0, p1, p2).is_none()
        );
        assert!(
            intersect_triangle(&ray(Vec3::new(0.75, 0.75, 1.0), -Vec3::Z), p0, p1, p2).is_none()
        );
    }

    #[test]
    fn degenerate_and_non_finite() {
        let (p0, p1) = (Vec3::ZERO, Vec3::X);
        let r = ray(Vec3::new(0.5, 0.0, 1.0), -Vec3::Z);
        assert!(intersect_triangle(&r, p0, p1, p1).is_none());
        assert!(intersect_triangle(&r, p0, p1, Vec3::X * 2.0).is_none());
        assert!(is_degenerate(p0, p1, Vec3::new(3.0, 0.0, 0.0)));
        assert!(is_degenerate(p0, p1, Vec3::new(f32::NAN, 1.0, 0.0)));
        let tri = (Vec3::ZERO, Vec3::X, Vec3::Y);
        for bad in [Vec3::NAN, Vec3::INFINITY, Vec3::ZERO] {
            assert!(
                intersect_triangle(&ray(Vec3::new(0.2, 0.2, 1.0), bad), tri.0, tri.1, tri.2)
                    .is_none()
            );
            assert!(intersect_triangle(&ray(bad, -Vec3::Z), tri.0, tri.1, tri.2).is_none());
        }
        let mut r = ray(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z);
        r.t_max = f32::NAN;
        assert!(intersect_triangle(&r, tri.0, tri.1, tri.2).is_none());
    }

    /// A ray just outside edge 2→0 where the f32 edge function `V` rounds
    /// to exactly 0 (the two products round to the same value) while the
    /// exact value is −2⁻⁴⁶: without the f64 re-evaluation the zero would
    /// count as "on the edge" and the ray would hit.
    #[test]
    fn f64_fallback_decides_exact_zero() {
        let e = f32::EPSILON; // 2^-23
        // Ray along −z from the origin: ray space is (x', y') = (y, x).
        let (a, b, c) = ([1.0 + e, 1.0], [1.0, -1.0], [-(1.0 + 2.0 * e), -(1.0 + e)]);
        assert_eq!(
            a[0] * c[1] - a[1] * c[0],
            0.0,
            "the f32 edge function must cancel"
        );
        let world = |p: [f32; 2]| Vec3::new(p[1], p[0], -1.0);
        let tri = [world(a), world(b), world(c)];
        let r = ray(Vec3::ZERO, -Vec3::Z);
        assert_eq!(intersect_triangle(&r, tri[0], tri[1], tri[2]), None);
        let mut lanes = WatertightLanes::<4>::new();
        for i in 0..4 {
            lanes.set(i, &WatertightRay::new(&r).unwrap());
        }
        lanes.finish(0b1111);
        let (mut t, mut b1, mut b2) = ([0.0; 4], [0.0; 4], [0.0; 4]);
        assert_eq!(
            every_lanes_form(
                &lanes,
                &tri,
                &[f32::INFINITY; 4],
                0b1111,
                &mut t,
                &mut b1,
                &mut b2
            ),
            0
        );
        // Moved to the inside of that edge, it hits.
        let inside = ray(Vec3::new(-0.01, 0.0, 0.0), -Vec3::Z);
        assert!(intersect_triangle(&inside, tri[0], tri[1], tri[2]).is_some());
    }

    /// A ray starting 1 ulp off the plane of a large triangle and crossing
    /// it at once (t ≈ 10⁻⁷, under δt): its f32 `t` comes out negative,
    /// and only the f64 decision finds the hit — in both kernels. The ray
    /// is a walk step from next to an edge of the closed cube that left it
    /// this way (the stability suite's edge leak).
    #[test]
    fn a_surface_crossed_at_the_origin_is_hit() {
        let tri = [
            Vec3::new(-1.0, -1.0, -1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, -1.0),
        ];
        let r = ray(
            Vec3::new(0.9999995, -0.99999994, -0.37992558),
            Vec3::new(-0.44689378, -0.5778847, -0.68288743),
        );
        let wr = WatertightRay::new(&r).unwrap();
        let (a, b, c) = (
            wr.ray_space(tri[0]),
            wr.ray_space(tri[1]),
            wr.ray_space(tri[2]),
        );
        let (u, v, w) = edge_functions(a, b, c);
        assert!(solve(a, b, c, u, v, w, u + v + w).0 <= 0.0, "f32 t");
        let (t, ..) = intersect_triangle(&r, tri[0], tri[1], tri[2]).expect("hit");
        assert!(t > 0.0 && t < 1e-6, "t = {t}");
        let mut lanes = WatertightLanes::<4>::new();
        lanes.set(0, &wr);
        lanes.finish(0b1);
        let (mut tl, mut b1, mut b2) = ([0.0; 4], [0.0; 4], [0.0; 4]);
        let m = every_lanes_form(
            &lanes,
            &tri,
            &[f32::INFINITY; 4],
            0b1,
            &mut tl,
            &mut b1,
            &mut b2,
        );
        assert_eq!(m, 0b1);
        assert_eq!(
            (tl[0], b1[0], b2[0]),
            intersect_triangle(&r, tri[0], tri[1], tri[2]).unwrap()
        );
        // Going the other way it is behind the origin.
        assert_eq!(
            intersect_triangle(&ray(r.o, -r.d), tri[0], tri[1], tri[2]),
            None
        );
    }

    #[test]
    fn lane_mask_bits() {
        let mut x = 0x9e37_79b9u32;
        for _ in 0..200 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let f16: [bool; 16] = core::array::from_fn(|i| x >> i & 1 != 0);
            assert_eq!(lane_mask(&f16), x & 0xffff);
            let f8: [bool; 8] = core::array::from_fn(|i| x >> i & 1 != 0);
            assert_eq!(lane_mask(&f8), x & 0xff);
            let f4: [bool; 4] = core::array::from_fn(|i| x >> i & 1 != 0);
            assert_eq!(lane_mask(&f4), x & 0xf);
            let f32_: [bool; 32] = core::array::from_fn(|i| x >> i & 1 != 0);
            assert_eq!(lane_mask(&f32_), x);
            let f13: [bool; 13] = core::array::from_fn(|i| x >> i & 1 != 0);
            assert_eq!(lane_mask(&f13), x & 0x1fff);
        }
    }

    #[test]
    fn lanes_match_single() {
        let tri = [
            Vec3::new(-1.0, -0.5, 0.3),
            Vec3::new(1.0, -0.2, -0.1),
            Vec3::new(0.1, 1.0, 0.05),
        ];
        let dirs = [
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.3, -0.2, -1.0),
            Vec3::new(-1.0, 0.1, 0.0),
            Vec3::X,
            Vec3::new(0.0, -1.0, 0.2),
        ];
        let mut lanes = WatertightLanes::<8>::new();
        let mut t_max = [f32::INFINITY; 8];
        let mut singles = [None; 8];
        for (i, d) in dirs.iter().enumerate() {
            let r = ray(Vec3::new(0.05, 0.1, 0.1) - *d * 3.0, *d);
            let wr = WatertightRay::new(&r).unwrap();
            lanes.set(i, &wr);
            singles[i] = wr.intersect(tri[0], tri[1], tri[2], f32::INFINITY);
            t_max[i] = f32::INFINITY;
        }
        lanes.finish(0b111111);
        let (mut t, mut b1, mut b2) = ([0.0; 8], [0.0; 8], [0.0; 8]);
        let m = every_lanes_form(&lanes, &tri, &t_max, 0b111111, &mut t, &mut b1, &mut b2);
        for i in 0..dirs.len() {
            let got = (m >> i & 1 == 1).then_some((t[i], b1[i], b2[i]));
            assert_eq!(got, singles[i], "lane {i}");
        }
    }

    /// Lanes through a vertex or an edge (exact zero edge functions, redone
    /// by the single-ray test), lanes starting on the triangle (distance
    /// within δt of zero, decided in f64) and ordinary lanes, in one packet
    /// with one lane left out: every lane in the mask equals its single-ray
    /// test, and the left-out lane reports nothing.
    #[test]
    fn lanes_match_single_on_edges_and_origins() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let down = Vec3::new(0.0, 0.0, -1.0);
        let rays = [
            ray(Vec3::new(0.0, 0.0, 1.0), down),                     // vertex
            ray(Vec3::new(0.5, 0.0, 1.0), down),                     // edge y = 0
            ray(Vec3::new(0.5, 0.5, 1.0), down),                     // hypotenuse
            ray(Vec3::new(0.25, 0.25, 1.0), down),                   // inside
            ray(Vec3::new(2.0, 2.0, 1.0), down),                     // outside
            ray(Vec3::new(0.2, 0.2, 0.0), Vec3::new(0.1, 0.2, 1.0)), // leaves it
            ray(Vec3::new(0.2, 0.2, 0.0), Vec3::new(0.1, 0.2, -1.0)), // leaves it
            ray(Vec3::new(0.0, 0.25, 1.0), down),                    // edge x = 0
            ray(Vec3::new(0.3, 0.3, 1.0), down),                     // left out
        ];
        let mut lanes = WatertightLanes::<16>::new();
        let mut singles = [None; 16];
        for (i, r) in rays.iter().enumerate() {
            let wr = WatertightRay::new(r).unwrap();
            lanes.set(i, &wr);
            singles[i] = wr.intersect(tri[0], tri[1], tri[2], f32::INFINITY);
        }
        let mask = (1u32 << (rays.len() - 1)) - 1;
        lanes.finish(mask);
        // The edge cases are hits, so the lanes' fallbacks are exercised.
        for i in [0, 1, 2, 3, 7] {
            assert!(singles[i].is_some(), "lane {i} should hit");
        }
        let t_max = [f32::INFINITY; 16];
        let (mut t, mut b1, mut b2) = ([0.0; 16], [0.0; 16], [0.0; 16]);
        let m = every_lanes_form(&lanes, &tri, &t_max, mask, &mut t, &mut b1, &mut b2);
        assert_eq!(m & !mask, 0, "a lane outside the mask reported a hit");
        for i in 0..rays.len() - 1 {
            let got = (m >> i & 1 == 1).then_some((t[i], b1[i], b2[i]));
            assert_eq!(got, singles[i], "lane {i}");
        }
        // The first 8 lanes as a packet of 8 (the two-triangle form).
        assert_eq!(first_eight(&lanes, &tri, mask), m & 0xff);
    }

    /// Lanes 0–7 of `lanes` as a packet of 8, tested against `tri` in
    /// every form (restricted to `mask`); returns the hit mask.
    fn first_eight(lanes: &WatertightLanes<16>, tri: &[Vec3; 3], mask: u32) -> u32 {
        let mut l8 = WatertightLanes::<8>::new();
        for i in 0..8 {
            l8.set(i, &lanes.get(i));
        }
        l8.finish(mask & 0xff);
        let (mut t, mut b1, mut b2) = ([0.0; 8], [0.0; 8], [0.0; 8]);
        every_lanes_form(
            &l8,
            tri,
            &[f32::INFINITY; 8],
            mask & 0xff,
            &mut t,
            &mut b1,
            &mut b2,
        )
    }

    /// Rays starting on, just in front of and just behind a tilted
    /// triangle, in all octants (so lanes differ in permutation): most
    /// lanes' f32 distance is not provably of either sign, so the packet
    /// decides them all at once in f64. Each lane must match its single-ray
    /// test bit for bit, and the lane form of the f64 decision must match
    /// the scalar one lane by lane.
    #[test]
    fn lanes_decide_near_origin_hits_like_single() {
        let tri = [
            Vec3::new(0.1, 0.2, 0.3),
            Vec3::new(1.3, 0.4, -0.2),
            Vec3::new(0.2, 1.1, 0.9),
        ];
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut decided, mut hits, mut misses) = (0, 0, 0);
        for _ in 0..200 {
            let mut lanes = WatertightLanes::<16>::new();
            let mut singles = [None; 16];
            for i in 0..16 {
                let (u, v) = (next() * 0.5, next() * 0.5);
                let on = tri[0] + u * (tri[1] - tri[0]) + v * (tri[2] - tri[0]);
                // On the plane, or a few ulps to either side of it.
                let off = [0.0, 1e-7, -1e-7, 3e-7][i % 4];
                let d = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                let wr = WatertightRay::new(&ray(on + off * n, d)).unwrap();
                lanes.set(i, &wr);
                singles[i] = wr.intersect(tri[0], tri[1], tri[2], f32::INFINITY);
            }
            lanes.finish(u32::MAX >> 16);
            // The permuted vertices `intersect_lanes` passes, built here
            // from each lane's own permutation.
            let sel: [[[f32; 16]; 3]; 3] = core::array::from_fn(|vi| {
                core::array::from_fn(|j| {
                    core::array::from_fn(|i| tri[vi].to_array()[lanes.get(i).k[j]])
                })
            });
            let (positive, num, den) = positive_t_f64_lanes(&sel, &lanes);
            for i in 0..16 {
                let l = lanes.get(i);
                let scalar = positive_t_f64(tri, l.k, l.org, l.shear);
                let lane = (positive >> i & 1 == 1).then_some((num[i], den[i]));
                assert_eq!(
                    lane.map(|(a, b)| (a.to_bits(), b.to_bits())),
                    scalar.map(|(a, b)| (a.to_bits(), b.to_bits())),
                    "f64 decision, lane {i}"
                );
                decided += scalar.is_some() as u32;
            }
            let t_max = [f32::INFINITY; 16];
            let (mut t, mut b1, mut b2) = ([0.0; 16], [0.0; 16], [0.0; 16]);
            let m = every_lanes_form(
                &lanes,
                &tri,
                &t_max,
                u32::MAX >> 16,
                &mut t,
                &mut b1,
                &mut b2,
            );
            for i in 0..16 {
                let got = (m >> i & 1 == 1).then_some((t[i], b1[i], b2[i]));
                assert_eq!(got, singles[i], "lane {i}");
                hits += got.is_some() as u32;
                misses += got.is_none() as u32;
            }
            assert_eq!(first_eight(&lanes, &tri, u32::MAX >> 16), m & 0xff);
        }
        // Both outcomes occur, and the f64 test certifies some hits.
        assert!(
            hits > 100 && misses > 100 && decided > 100,
            "{hits} {misses} {decided}"
        );
    }
}
