//! Explicit SIMD lane vectors for the packet box test.
//!
//! The packet kernel's box test (`packet::box4_lanes`) is written over
//! `[f32; N]` arrays for any `N`; LLVM vectorised it across the four
//! children instead of across the lanes and then transposed every result
//! into lane order, which cost more than the arithmetic. [`LaneVec`] spells
//! the lane-parallel form out for one register width — SSE2 (4 lanes),
//! AVX2 (8) and AVX-512F (16) — and [`box4_lanes_simd`] runs it over a
//! packet in register-sized chunks.
//!
//! Every operation is the IEEE operation the scalar form performs, in the
//! same order (`sub`, then `mul`, no FMA); `max`/`min` keep the
//! accumulator when the new value is NaN, exactly like `node::max_keep` /
//! `node::min_keep` (x86 `maxps(x, acc)` returns its second operand when
//! either is NaN or both are zero), so the masks and entry distances are
//! bit-identical to the portable form. (x86_64 only; other targets use the
//! portable form.)

use core::arch::x86_64::*;

use super::node::{FAR_SCALE, Node4};

/// One register of lanes. Implementations are only used inside functions
/// compiled for their instruction set (see each impl's safety note).
pub(super) trait LaneVec: Copy {
    /// Lanes per register.
    const W: usize;
    /// Loads `W` lanes from `p[..W]`.
    fn load(p: &[f32]) -> Self;
    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// `(b − o) · inv` per lane, rounded after each operation.
    fn slab(b: Self, o: Self, inv: Self) -> Self;
    /// `max_keep(acc, x)` per lane.
    fn max_keep(acc: Self, x: Self) -> Self;
    /// `min_keep(acc, x)` per lane.
    fn min_keep(acc: Self, x: Self) -> Self;
    /// Per lane, `a` where bit `i` of `bits` is set, else `b`.
    fn select(bits: u32, a: Self, b: Self) -> Self;
    /// Bit `i` set where `near[i] <= far[i] · FAR_SCALE` (NaN: clear).
    fn hits(near: Self, far: Self) -> u32;
    /// The smallest lane (no lane may be NaN).
    fn min_lane(self) -> f32;
}

/// Robust slab test of `N` lanes against a node's four children, as
/// `packet::box4_lanes`: per child, the lanes of `lanes` that hit it and
/// their smallest entry distance (`+∞` for none).
///
/// `o`, `inv` and `t_max` are the packet's lanes (SoA); `neg[a]` has bit
/// `i` set when lane `i`'s direction is negative on axis `a` (its near
/// plane is then the box's max), and `uniform` says all live lanes agree,
/// so the planes are picked once per node. `N` must be a multiple of
/// `V::W`.
#[inline(always)]
pub(super) fn box4_lanes_simd<V: LaneVec, const N: usize>(
    node: &Node4,
    o: &[[f32; N]; 3],
    inv: &[[f32; N]; 3],
    t_max: &[f32; N],
    neg: [u32; 3],
    uniform: Option<[bool; 3]>,
    lanes: u32,
) -> ([u32; 4], [f32; 4]) {
    debug_assert!(N.is_multiple_of(V::W));
    let mut masks = [0u32; 4];
    let mut t_min = [f32::INFINITY; 4];
    let inf = V::splat(f32::INFINITY);
    for chunk in 0..N / V::W {
        let at = chunk * V::W;
        let shift = at as u32;
        let tm = V::load(&t_max[at..]);
        let mut near = [V::splat(0.0); 4];
        let mut far = [tm; 4];
        for a in 0..3 {
            let oa = V::load(&o[a][at..]);
            let ia = V::load(&inv[a][at..]);
            for c in 0..4 {
                let (lo, hi) = (V::splat(node.min[a][c]), V::splat(node.max[a][c]));
                let (nb, fb) = match uniform {
                    Some(u) if u[a] => (hi, lo),
                    Some(_) => (lo, hi),
                    None => {
                        let n = neg[a] >> shift;
                        (V::select(n, hi, lo), V::select(n, lo, hi))
                    }
                };
                near[c] = V::max_keep(near[c], V::slab(nb, oa, ia));
                far[c] = V::min_keep(far[c], V::slab(fb, oa, ia));
            }
        }
        let live = lanes >> shift;
        for c in 0..4 {
            let hit = V::hits(near[c], far[c]) & live & lane_bits(V::W);
            masks[c] |= hit << shift;
            // Entry distances are never NaN (they start at +0 and
            // `max_keep` drops NaN), so the reduction order is free.
            let key = V::select(hit, near[c], inf).min_lane();
            t_min[c] = if key < t_min[c] { key } else { t_min[c] };
        }
    }
    (masks, t_min)
}

/// The low `w` bits.
#[inline(always)]
const fn lane_bits(w: usize) -> u32 {
    if w >= 32 { u32::MAX } else { (1 << w) - 1 }
}

/// SSE2: 4 lanes (the x86_64 baseline).
impl LaneVec for __m128 {
    const W: usize = 4;

    #[inline(always)]
    fn load(p: &[f32]) -> Self {
        let p = &p[..4];
        // SAFETY: SSE2 is part of the x86_64 baseline; `p` holds 4 floats.
        unsafe { _mm_loadu_ps(p.as_ptr()) }
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: SSE2 baseline; no memory access.
        unsafe { _mm_set1_ps(x) }
    }
    #[inline(always)]
    fn slab(b: Self, o: Self, inv: Self) -> Self {
        // SAFETY: SSE2 baseline; no memory access.
        unsafe { _mm_mul_ps(_mm_sub_ps(b, o), inv) }
    }
    #[inline(always)]
    fn max_keep(acc: Self, x: Self) -> Self {
        // SAFETY: SSE2 baseline. maxps(x, acc) returns acc for a NaN x.
        unsafe { _mm_max_ps(x, acc) }
    }
    #[inline(always)]
    fn min_keep(acc: Self, x: Self) -> Self {
        // SAFETY: SSE2 baseline. minps(x, acc) returns acc for a NaN x.
        unsafe { _mm_min_ps(x, acc) }
    }
    #[inline(always)]
    fn select(bits: u32, a: Self, b: Self) -> Self {
        // SAFETY: SSE2 baseline; no memory access.
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
    fn hits(near: Self, far: Self) -> u32 {
        // SAFETY: SSE2 baseline; no memory access.
        unsafe {
            _mm_movemask_ps(_mm_cmple_ps(near, _mm_mul_ps(far, _mm_set1_ps(FAR_SCALE)))) as u32
        }
    }
    #[inline(always)]
    fn min_lane(self) -> f32 {
        // SAFETY: SSE2 baseline; no memory access.
        unsafe {
            let m = _mm_min_ps(self, _mm_movehl_ps(self, self));
            let m = _mm_min_ss(m, _mm_shuffle_ps::<0b01>(m, m));
            _mm_cvtss_f32(m)
        }
    }
}

/// AVX2: 8 lanes. Only instantiated inside functions compiled with AVX2
/// enabled, which run after `Kernel::is_available` confirmed it.
impl LaneVec for __m256 {
    const W: usize = 8;

    #[inline(always)]
    fn load(p: &[f32]) -> Self {
        let p = &p[..8];
        // SAFETY: AVX2 is enabled where this is used (type docs); `p`
        // holds 8 floats.
        unsafe { _mm256_loadu_ps(p.as_ptr()) }
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: AVX2 enabled (type docs); no memory access.
        unsafe { _mm256_set1_ps(x) }
    }
    #[inline(always)]
    fn slab(b: Self, o: Self, inv: Self) -> Self {
        // SAFETY: AVX2 enabled (type docs); no memory access.
        unsafe { _mm256_mul_ps(_mm256_sub_ps(b, o), inv) }
    }
    #[inline(always)]
    fn max_keep(acc: Self, x: Self) -> Self {
        // SAFETY: AVX2 enabled. vmaxps(x, acc) returns acc for a NaN x.
        unsafe { _mm256_max_ps(x, acc) }
    }
    #[inline(always)]
    fn min_keep(acc: Self, x: Self) -> Self {
        // SAFETY: AVX2 enabled. vminps(x, acc) returns acc for a NaN x.
        unsafe { _mm256_min_ps(x, acc) }
    }
    #[inline(always)]
    fn select(bits: u32, a: Self, b: Self) -> Self {
        // SAFETY: AVX2 enabled (type docs); no memory access.
        unsafe {
            let bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let m = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(bits as i32), bit), bit);
            _mm256_blendv_ps(b, a, _mm256_castsi256_ps(m))
        }
    }
    #[inline(always)]
    fn hits(near: Self, far: Self) -> u32 {
        // SAFETY: AVX2 enabled (type docs); no memory access.
        unsafe {
            let far = _mm256_mul_ps(far, _mm256_set1_ps(FAR_SCALE));
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32
        }
    }
    #[inline(always)]
    fn min_lane(self) -> f32 {
        // SAFETY: AVX2 enabled (type docs); no memory access.
        unsafe {
            let m = _mm_min_ps(
                _mm256_castps256_ps128(self),
                _mm256_extractf128_ps::<1>(self),
            );
            m.min_lane()
        }
    }
}

/// AVX-512F: 16 lanes. Only instantiated inside functions compiled with
/// AVX-512F enabled, which run after `Kernel::is_available` confirmed it.
impl LaneVec for __m512 {
    const W: usize = 16;

    #[inline(always)]
    fn load(p: &[f32]) -> Self {
        let p = &p[..16];
        // SAFETY: AVX-512F is enabled where this is used (type docs); `p`
        // holds 16 floats.
        unsafe { _mm512_loadu_ps(p.as_ptr()) }
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: AVX-512F enabled (type docs); no memory access.
        unsafe { _mm512_set1_ps(x) }
    }
    #[inline(always)]
    fn slab(b: Self, o: Self, inv: Self) -> Self {
        // SAFETY: AVX-512F enabled (type docs); no memory access.
        unsafe { _mm512_mul_ps(_mm512_sub_ps(b, o), inv) }
    }
    #[inline(always)]
    fn max_keep(acc: Self, x: Self) -> Self {
        // SAFETY: AVX-512F enabled. vmaxps(x, acc) returns acc for a NaN x.
        unsafe { _mm512_max_ps(x, acc) }
    }
    #[inline(always)]
    fn min_keep(acc: Self, x: Self) -> Self {
        // SAFETY: AVX-512F enabled. vminps(x, acc) returns acc for a NaN x.
        unsafe { _mm512_min_ps(x, acc) }
    }
    #[inline(always)]
    fn select(bits: u32, a: Self, b: Self) -> Self {
        // SAFETY: AVX-512F enabled (type docs); no memory access.
        unsafe { _mm512_mask_blend_ps(bits as u16, b, a) }
    }
    #[inline(always)]
    fn hits(near: Self, far: Self) -> u32 {
        // SAFETY: AVX-512F enabled (type docs); no memory access.
        unsafe {
            let far = _mm512_mul_ps(far, _mm512_set1_ps(FAR_SCALE));
            _mm512_cmp_ps_mask::<_CMP_LE_OQ>(near, far) as u32
        }
    }
    #[inline(always)]
    fn min_lane(self) -> f32 {
        // SAFETY: AVX-512F enabled (type docs); no memory access.
        unsafe {
            let m = _mm256_min_ps(
                _mm512_castps512_ps256(self),
                _mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(_mm512_castps_pd(self))),
            );
            m.min_lane()
        }
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::accel::bvh::packet::box4_lanes_portable;

    /// A small xorshift generator: the test needs no statistics, only
    /// varied inputs.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 32) as u32
        }
        fn f(&mut self, lo: f32, hi: f32) -> f32 {
            lo + (hi - lo) * (self.next() as f32 / u32::MAX as f32)
        }
    }

    type Inputs = (Node4, [[f32; 16]; 3], [[f32; 16]; 3], [f32; 16], [u32; 3]);

    /// A node (some slots empty, some boxes flat) and 16 lanes whose
    /// origins often lie exactly on a slab plane and whose directions
    /// often have zero components (`inv = ±∞`, slab distances `0·∞ =
    /// NaN`), with `t_max` sometimes below the boxes or a dummy's `−1`.
    fn inputs(rng: &mut Rng) -> Inputs {
        let mut node = Node4::EMPTY;
        for c in 0..4 {
            if rng.next().is_multiple_of(5) {
                continue;
            }
            let mut lo = [0.0; 3];
            let mut hi = [0.0; 3];
            for a in 0..3 {
                let x = (rng.next() % 5) as f32 - 2.0;
                lo[a] = x;
                hi[a] = if rng.next().is_multiple_of(4) {
                    x
                } else {
                    x + rng.f(0.1, 2.0)
                };
            }
            node.set_bounds(c, lo, hi);
        }
        let (mut o, mut inv) = ([[0.0; 16]; 3], [[0.0; 16]; 3]);
        let mut t_max = [0.0; 16];
        let mut neg = [0u32; 3];
        for i in 0..16 {
            for a in 0..3 {
                o[a][i] = match rng.next() % 3 {
                    // On a plane of some box (or of the empty slots' ±∞).
                    0 => node.min[a][(rng.next() % 4) as usize],
                    _ => rng.f(-4.0, 4.0),
                };
                if !o[a][i].is_finite() {
                    o[a][i] = 0.0;
                }
                let d = match rng.next() % 4 {
                    0 => 0.0,
                    1 => -0.0,
                    _ => rng.f(-1.0, 1.0),
                };
                inv[a][i] = 1.0 / d;
                neg[a] |= (inv[a][i].is_sign_negative() as u32) << i;
            }
            t_max[i] = match rng.next() % 6 {
                0 => -1.0,
                1 => rng.f(0.0, 0.5),
                _ => rng.f(0.0, 20.0),
            };
        }
        (node, o, inv, t_max, neg)
    }

    /// Runs `V`'s box test and the portable one on the same inputs and
    /// requires the same masks and the same bits of every entry distance.
    fn check<V: LaneVec>(rng: &mut Rng) {
        for _ in 0..4000 {
            let (node, o, inv, t_max, neg) = inputs(rng);
            let lanes = rng.next() & 0xffff;
            // Uniform signs only when they are (as `Lanes::new` decides);
            // otherwise the per-lane selection.
            let uniform = (neg.iter().all(|&m| m & lanes == 0 || m & lanes == lanes) && lanes != 0)
                .then(|| neg.map(|m| m & lanes != 0));
            for uniform in [None, uniform] {
                let want = box4_lanes_portable(&node, &o, &inv, &t_max, neg, uniform, lanes);
                let got = box4_lanes_simd::<V, 16>(&node, &o, &inv, &t_max, neg, uniform, lanes);
                assert_eq!(got.0, want.0, "masks, uniform {uniform:?}");
                assert_eq!(
                    got.1.map(f32::to_bits),
                    want.1.map(f32::to_bits),
                    "entry distances, uniform {uniform:?}"
                );
            }
        }
    }

    #[target_feature(enable = "avx2")]
    fn check_avx2(rng: &mut Rng) {
        check::<__m256>(rng);
    }

    #[target_feature(enable = "avx2,avx512f")]
    fn check_avx512(rng: &mut Rng) {
        check::<__m512>(rng);
    }

    /// Every register width agrees with the portable lane loops bit for
    /// bit, NaN slabs, flat and empty boxes, dummy lanes and partial
    /// masks included (the packet tests compare final hits only; this
    /// compares the box test itself).
    #[test]
    fn simd_box_test_matches_portable() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        check::<__m128>(&mut rng);
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: AVX2 was just detected.
            unsafe { check_avx2(&mut rng) };
        }
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("avx512f") {
            // SAFETY: AVX2 and AVX-512F were just detected.
            unsafe { check_avx512(&mut rng) };
        }
    }
}
