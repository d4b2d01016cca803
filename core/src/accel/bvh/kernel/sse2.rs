//! SSE2, the x86_64 baseline: 4 lanes per register ([`LaneVec`] for
//! `__m128`), a node's child boxes four per register and plane
//! ([`Sse2Box`]), and the single-ray leaf test four triangles per step
//! ([`intersect_many`]).

use core::arch::x86_64::*;

use super::boxes::{boxes_in, frustum_in};
use super::lane_vec::LaneVec;
use super::{BoxTest, PortableLanes, RegLanes};
use crate::accel::bvh::node::{BoxFrustum, BoxRay, FrustumHits, Node, WIDTH};
use crate::geometry::offset::gamma;
use crate::geometry::triangle::{Planes4, WatertightRay, decide_t_f64, planes_tri};

/// SSE2: 4 lanes (the x86_64 baseline, always available).
impl LaneVec for __m128 {
    const W: usize = 4;

    #[inline(always)]
    fn load(p: &[f32]) -> Self {
        let p = &p[..4];
        // SAFETY: SSE2 is x86_64 baseline; `p` holds 4 floats.
        unsafe { _mm_loadu_ps(p.as_ptr()) }
    }
    #[inline(always)]
    fn store(self, p: &mut [f32]) {
        let p = &mut p[..4];
        // SAFETY: SSE2 baseline; `p` holds 4 floats.
        unsafe { _mm_storeu_ps(p.as_mut_ptr(), self) }
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY (this and the following register-only methods): SSE2 is
        // x86_64 baseline and nothing touches memory.
        unsafe { _mm_set1_ps(x) }
    }
    #[inline(always)]
    fn add(self, b: Self) -> Self {
        unsafe { _mm_add_ps(self, b) }
    }
    #[inline(always)]
    fn sub(self, b: Self) -> Self {
        unsafe { _mm_sub_ps(self, b) }
    }
    #[inline(always)]
    fn mul(self, b: Self) -> Self {
        unsafe { _mm_mul_ps(self, b) }
    }
    #[inline(always)]
    fn div(self, b: Self) -> Self {
        unsafe { _mm_div_ps(self, b) }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        unsafe { _mm_andnot_ps(_mm_set1_ps(-0.0), self) }
    }
    #[inline(always)]
    fn neg(self) -> Self {
        unsafe { _mm_xor_ps(_mm_set1_ps(-0.0), self) }
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        unsafe { _mm_max_ps(self, b) }
    }
    #[inline(always)]
    fn min(self, b: Self) -> Self {
        unsafe { _mm_min_ps(self, b) }
    }
    #[inline(always)]
    fn select(bits: u32, a: Self, b: Self) -> Self {
        unsafe {
            let bit = _mm_setr_epi32(1, 2, 4, 8);
            let m = _mm_castsi128_ps(_mm_cmpeq_epi32(
                _mm_and_si128(_mm_set1_epi32(bits as i32), bit),
                bit,
            ));
            _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b))
        }
    }
    #[inline(always)]
    fn eq(self, b: Self) -> u32 {
        unsafe { _mm_movemask_ps(_mm_cmpeq_ps(self, b)) as u32 }
    }
    #[inline(always)]
    fn ne(self, b: Self) -> u32 {
        unsafe { _mm_movemask_ps(_mm_cmpneq_ps(self, b)) as u32 }
    }
    #[inline(always)]
    fn lt(self, b: Self) -> u32 {
        unsafe { _mm_movemask_ps(_mm_cmplt_ps(self, b)) as u32 }
    }
    #[inline(always)]
    fn gt(self, b: Self) -> u32 {
        unsafe { _mm_movemask_ps(_mm_cmpgt_ps(self, b)) as u32 }
    }
    #[inline(always)]
    fn le(self, b: Self) -> u32 {
        unsafe { _mm_movemask_ps(_mm_cmple_ps(self, b)) as u32 }
    }
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        unsafe { _mm_movemask_ps(self) as u32 }
    }
    #[inline(always)]
    fn min_lane(self) -> f32 {
        unsafe {
            let m = _mm_min_ps(self, _mm_movehl_ps(self, self));
            let m = _mm_min_ss(m, _mm_shuffle_ps::<0b01>(m, m));
            _mm_cvtss_f32(m)
        }
    }
}

/// SSE2: one register holds one plane of all four children.
pub(crate) struct Sse2Box;

impl BoxTest for Sse2Box {
    /// Four triangles per SSE step.
    const SSE_LEAF: bool = true;

    type Lanes = RegLanes<core::arch::x86_64::__m128, PortableLanes>;

    /// Four children per SSE register and plane.
    #[inline(always)]
    fn boxes(node: &Node, r: &BoxRay, t_max: f32) -> (u32, [f32; WIDTH]) {
        boxes_in::<core::arch::x86_64::__m128>(node, r, t_max)
    }

    /// Four children per SSE register and plane.
    #[inline(always)]
    fn boxes_frustum(node: &Node, f: &BoxFrustum, t_far: f32) -> FrustumHits {
        frustum_in::<core::arch::x86_64::__m128>(node, f, t_far)
    }
}

/// [`WatertightRay::intersect_many`] with SSE over groups of four triangles in
/// SoA form (`groups`, `count` triangles in all, the last group's lanes
/// past `count` ignored): one group per step, one triangle per lane
/// (the permutation is the ray's, shared by all lanes).
///
/// Same answer bit for bit: every lane evaluates the IEEE operations of
/// the scalar helpers in the same order (`transform`, `edge_functions`,
/// `solve`; `maxps(a, b)` is `if a > b { a } else { b }` like `max3`,
/// no FMA), zero edge functions and unsure distances go through the
/// same scalar f64 helpers, and a triangle hits only below the `t_max`
/// of its group of four, so the closest of a group (first on a tie) is
/// the one the sequential loop keeps. It replaces a chain of
/// data-dependent branches per triangle, which mispredict often, with
/// one mask test per group.
///
/// Leaves of one or two triangles take this path too, although it costs
/// more instructions than the scalar test for them: their scalar
/// branches mispredict on incoherent rays, which are what single rays
/// mostly trace. Together with `traverse::prefetch`, measured in one
/// process against the scalar rule: diffuse
/// bounces 2–6% faster on all five benchmark scenes, coherent primary
/// rays 5% slower on the four small ones, where the branches predict.
#[inline(always)]
pub(crate) fn intersect_many<'g, const ANY: bool>(
    ray: &WatertightRay,
    groups: impl Iterator<Item = &'g Planes4>,
    count: usize,
    mut t_max: f32,
) -> Option<(usize, f32, f32, f32)> {
    let mut best = None;
    for (g, group) in groups.enumerate() {
        let n = count.saturating_sub(4 * g).min(4);
        if n == 0 {
            break;
        }
        if let Some((j, t, b1, b2)) = intersect4(ray, group, n, t_max) {
            t_max = t;
            best = Some((4 * g + j, t, b1, b2));
            if ANY {
                break;
            }
        }
    }
    best
}

/// One group of `n` (1–4) triangles for [`intersect_many`]:
/// lanes `0..n` of `p`.
///
/// The ray's axis permutation is applied by the addresses of the nine
/// plane loads (`p[vertex][k[i]]`), so the permuted planes go straight
/// into registers.
#[inline(always)]
fn intersect4(
    ray: &WatertightRay,
    p: &Planes4,
    n: usize,
    t_max: f32,
) -> Option<(usize, f32, f32, f32)> {
    use core::arch::x86_64::*;

    /// One vertex of the four triangles in ray space, as `transform`:
    /// `[ax − Sx·az, ay − Sy·az, Sz·az, az]`, from its planes `v`
    /// (`v[axis]`, one lane per triangle) permuted by `k`.
    #[inline(always)]
    fn ray_space(
        v: &[[f32; 4]; 3],
        k: [usize; 3],
        org: [__m128; 3],
        shear: [__m128; 3],
    ) -> [__m128; 4] {
        // SAFETY: SSE2 is part of the x86_64 baseline; each load reads
        // one `[f32; 4]` of `v` (`k[i] < 3`; unaligned loads).
        unsafe {
            let ax = _mm_sub_ps(_mm_loadu_ps(v[k[0]].as_ptr()), org[0]);
            let ay = _mm_sub_ps(_mm_loadu_ps(v[k[1]].as_ptr()), org[1]);
            let az = _mm_sub_ps(_mm_loadu_ps(v[k[2]].as_ptr()), org[2]);
            [
                _mm_sub_ps(ax, _mm_mul_ps(shear[0], az)),
                _mm_sub_ps(ay, _mm_mul_ps(shear[1], az)),
                _mm_mul_ps(shear[2], az),
                az,
            ]
        }
    }

    /// `abs` of every lane.
    #[inline(always)]
    fn abs(x: __m128) -> __m128 {
        // SAFETY: SSE2 is part of the x86_64 baseline.
        unsafe { _mm_andnot_ps(_mm_set1_ps(-0.0), x) }
    }

    /// `max3` per lane: `maxps(p, q)` is `if p > q { p } else { q }`.
    #[inline(always)]
    fn max3(p: __m128, q: __m128, r: __m128) -> __m128 {
        // SAFETY: SSE2 is part of the x86_64 baseline.
        unsafe { _mm_max_ps(_mm_max_ps(p, q), r) }
    }

    let live = (1u32 << n) - 1;
    let k = ray.k.map(|k| k % 3);
    let mut t = [0.0f32; 4];
    let mut b1 = [0.0f32; 4];
    let mut b2 = [0.0f32; 4];
    // SAFETY: SSE2 is part of the x86_64 baseline; the only memory
    // accesses are stores of whole registers into the `[f32; 4]` arrays
    // above (unaligned stores).
    let (mut ok, mut unsure, zero) = unsafe {
        let org = ray.org.map(|x| _mm_set1_ps(x));
        let shear = ray.shear.map(|x| _mm_set1_ps(x));
        let (a, b, c) = (
            ray_space(&p[0], k, org, shear),
            ray_space(&p[1], k, org, shear),
            ray_space(&p[2], k, org, shear),
        );
        // `edge_functions`.
        let u = _mm_sub_ps(_mm_mul_ps(c[0], b[1]), _mm_mul_ps(c[1], b[0]));
        let v = _mm_sub_ps(_mm_mul_ps(a[0], c[1]), _mm_mul_ps(a[1], c[0]));
        let w = _mm_sub_ps(_mm_mul_ps(b[0], a[1]), _mm_mul_ps(b[1], a[0]));
        let z = _mm_setzero_ps();
        let zero = _mm_or_ps(
            _mm_or_ps(_mm_cmpeq_ps(u, z), _mm_cmpeq_ps(v, z)),
            _mm_cmpeq_ps(w, z),
        );
        let zero = _mm_movemask_ps(zero) as u32 & live;
        if zero != 0 {
            // Rare: some lane needs the f64 edge functions; the scalar
            // test does the rest of those lanes.
            (0, 0, zero)
        } else {
            let neg = _mm_or_ps(
                _mm_or_ps(_mm_cmplt_ps(u, z), _mm_cmplt_ps(v, z)),
                _mm_cmplt_ps(w, z),
            );
            let pos = _mm_or_ps(
                _mm_or_ps(_mm_cmpgt_ps(u, z), _mm_cmpgt_ps(v, z)),
                _mm_cmpgt_ps(w, z),
            );
            let inside = !(_mm_movemask_ps(_mm_and_ps(neg, pos)) as u32) & live;
            if inside == 0 {
                return None;
            }
            // `solve`.
            let det = _mm_add_ps(_mm_add_ps(u, v), w);
            let t_scaled = _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(u, a[2]), _mm_mul_ps(v, b[2])),
                _mm_mul_ps(w, c[2]),
            );
            let inv_det = _mm_div_ps(_mm_set1_ps(1.0), det);
            let tt = _mm_mul_ps(t_scaled, inv_det);
            _mm_storeu_ps(t.as_mut_ptr(), tt);
            _mm_storeu_ps(b1.as_mut_ptr(), _mm_mul_ps(v, inv_det));
            _mm_storeu_ps(b2.as_mut_ptr(), _mm_mul_ps(w, inv_det));
            let sign = _mm_set1_ps(-0.0);
            let max_x = max3(abs(a[0]), abs(b[0]), abs(c[0]));
            let max_y = max3(abs(a[1]), abs(b[1]), abs(c[1]));
            let max_z = max3(abs(a[2]), abs(b[2]), abs(c[2]));
            let max_zw = max3(abs(a[3]), abs(b[3]), abs(c[3]));
            let g = |k: i32| _mm_set1_ps(gamma(k));
            let delta_z = _mm_mul_ps(g(3), max_z);
            let delta_x = _mm_mul_ps(g(5), _mm_add_ps(max_x, max_zw));
            let delta_y = _mm_mul_ps(g(5), _mm_add_ps(max_y, max_zw));
            let delta_e = _mm_mul_ps(
                _mm_set1_ps(2.0),
                _mm_add_ps(
                    _mm_add_ps(
                        _mm_mul_ps(_mm_mul_ps(g(2), max_x), max_y),
                        _mm_mul_ps(delta_y, max_x),
                    ),
                    _mm_mul_ps(delta_x, max_y),
                ),
            );
            let max_e = max3(abs(u), abs(v), abs(w));
            let sum = _mm_add_ps(
                _mm_add_ps(
                    _mm_mul_ps(_mm_mul_ps(g(3), max_e), max_z),
                    _mm_mul_ps(delta_e, max_z),
                ),
                _mm_mul_ps(delta_z, max_e),
            );
            let dt = _mm_mul_ps(_mm_mul_ps(_mm_set1_ps(3.0), sum), abs(inv_det));
            let det_ok = _mm_cmpneq_ps(det, z);
            let ok = _mm_and_ps(
                det_ok,
                _mm_and_ps(_mm_cmpgt_ps(tt, dt), _mm_cmplt_ps(tt, _mm_set1_ps(t_max))),
            );
            let unsure = _mm_and_ps(
                det_ok,
                _mm_and_ps(_mm_cmple_ps(tt, dt), _mm_cmpgt_ps(tt, _mm_xor_ps(dt, sign))),
            );
            (
                _mm_movemask_ps(ok) as u32 & inside,
                _mm_movemask_ps(unsure) as u32 & inside,
                0,
            )
        }
    };
    if zero != 0 {
        // The scalar test, lane by lane, from the first lane (the
        // lanes before the zero ones were fine but are redone too:
        // the order of hits must stay the sequential one).
        return ray.intersect_many::<false>(n, |j| planes_tri(p, j), t_max);
    }
    while unsure != 0 {
        let j = unsure.trailing_zeros() as usize;
        unsure &= unsure - 1;
        if let Some(tj) = decide_t_f64(t[j], planes_tri(p, j), ray.k, ray.org, ray.shear) {
            t[j] = tj;
            if tj < t_max {
                ok |= 1 << j;
            }
        }
    }
    if ok == 0 {
        return None;
    }
    // The closest hit, the first on a tie (strict `<`, like the
    // sequential loop's `t < t_max`).
    let mut j = ok.trailing_zeros() as usize;
    let mut rest = ok & (ok - 1);
    while rest != 0 {
        let i = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        if t[i] < t[j] {
            j = i;
        }
    }
    Some((j, t[j], b1[j], b2[j]))
}
