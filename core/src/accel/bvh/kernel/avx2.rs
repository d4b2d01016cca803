//! AVX2: 8 lanes per register ([`LaneVec`] for `__m256`) and a node's
//! eight child boxes in one register per plane ([`Avx2Box`]). Only run
//! inside functions compiled with AVX2, after the CPU was checked.

use core::arch::x86_64::*;

use super::boxes::{boxes_in, frustum_in};
use super::lane_vec::LaneVec;
use super::sse2::Sse2Box;
use super::{BoxTest, RegLanes};
use crate::accel::bvh::node::{BoxFrustum, BoxRay, FrustumHits, Node, WIDTH};

/// AVX2: 8 lanes; only inside functions compiled with AVX2 (trait docs).
impl LaneVec for __m256 {
    const W: usize = 8;

    #[inline(always)]
    fn load(p: &[f32]) -> Self {
        let p = &p[..8];
        // SAFETY: AVX2 is enabled where this is used (trait docs); `p`
        // holds 8 floats.
        unsafe { _mm256_loadu_ps(p.as_ptr()) }
    }
    #[inline(always)]
    fn store(self, p: &mut [f32]) {
        let p = &mut p[..8];
        // SAFETY: as `load`.
        unsafe { _mm256_storeu_ps(p.as_mut_ptr(), self) }
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY (this and the following register-only methods): AVX2 is
        // enabled where this is used (trait docs); no memory access.
        unsafe { _mm256_set1_ps(x) }
    }
    #[inline(always)]
    fn add(self, b: Self) -> Self {
        unsafe { _mm256_add_ps(self, b) }
    }
    #[inline(always)]
    fn sub(self, b: Self) -> Self {
        unsafe { _mm256_sub_ps(self, b) }
    }
    #[inline(always)]
    fn mul(self, b: Self) -> Self {
        unsafe { _mm256_mul_ps(self, b) }
    }
    #[inline(always)]
    fn div(self, b: Self) -> Self {
        unsafe { _mm256_div_ps(self, b) }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self) }
    }
    #[inline(always)]
    fn neg(self) -> Self {
        unsafe { _mm256_xor_ps(_mm256_set1_ps(-0.0), self) }
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        unsafe { _mm256_max_ps(self, b) }
    }
    #[inline(always)]
    fn min(self, b: Self) -> Self {
        unsafe { _mm256_min_ps(self, b) }
    }
    #[inline(always)]
    fn select(bits: u32, a: Self, b: Self) -> Self {
        unsafe {
            let bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let m = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(bits as i32), bit), bit);
            _mm256_blendv_ps(b, a, _mm256_castsi256_ps(m))
        }
    }
    #[inline(always)]
    fn eq(self, b: Self) -> u32 {
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(self, b)) as u32 }
    }
    #[inline(always)]
    fn ne(self, b: Self) -> u32 {
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_NEQ_UQ>(self, b)) as u32 }
    }
    #[inline(always)]
    fn lt(self, b: Self) -> u32 {
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(self, b)) as u32 }
    }
    #[inline(always)]
    fn gt(self, b: Self) -> u32 {
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(self, b)) as u32 }
    }
    #[inline(always)]
    fn le(self, b: Self) -> u32 {
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(self, b)) as u32 }
    }
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        unsafe { _mm256_movemask_ps(self) as u32 }
    }
    #[inline(always)]
    fn min_lane(self) -> f32 {
        unsafe {
            _mm_min_ps(
                _mm256_castps256_ps128(self),
                _mm256_extractf128_ps::<1>(self),
            )
            .min_lane()
        }
    }
    #[inline(always)]
    fn min_lanes8(v: [Self; 8]) -> [f32; 8] {
        /// Halves `a` and `b` into one register: `[a′ | b′]`, four lanes
        /// each, `a′` the pairwise minimum of `a`'s halves.
        #[inline(always)]
        fn fold(a: __m256, b: __m256) -> __m256 {
            unsafe {
                _mm256_min_ps(
                    _mm256_permute2f128_ps::<0x20>(a, b),
                    _mm256_permute2f128_ps::<0x31>(a, b),
                )
            }
        }
        let mut out = [0.0f32; 8];
        // SAFETY: AVX2 is enabled where this is used (trait docs);
        // register-only but the last store, which writes the 8 floats of
        // `out`.
        unsafe {
            // [c0 | c1], [c2 | c3], ..., four partial lanes per child.
            let (p01, p23) = (fold(v[0], v[1]), fold(v[2], v[3]));
            let (p45, p67) = (fold(v[4], v[5]), fold(v[6], v[7]));
            // Per 128-bit half: [c0 c0 c2 c2 | c1 c1 c3 c3] (two partials).
            let r0 = _mm256_min_ps(
                _mm256_shuffle_ps::<0x44>(p01, p23),
                _mm256_shuffle_ps::<0xEE>(p01, p23),
            );
            let r4 = _mm256_min_ps(
                _mm256_shuffle_ps::<0x44>(p45, p67),
                _mm256_shuffle_ps::<0xEE>(p45, p67),
            );
            // [c0 c2 c4 c6 | c1 c3 c5 c7].
            let m = _mm256_min_ps(
                _mm256_shuffle_ps::<0x88>(r0, r4),
                _mm256_shuffle_ps::<0xDD>(r0, r4),
            );
            let order = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
            _mm256_storeu_ps(out.as_mut_ptr(), _mm256_permutevar8x32_ps(m, order));
        }
        out
    }
}

/// AVX: near and far planes of one axis in one 256-bit register. Only
/// called from functions compiled with AVX2 enabled.
pub(crate) struct Avx2Box;

impl BoxTest for Avx2Box {
    /// Four triangles per SSE step.
    const SSE_LEAF: bool = true;

    type Lanes = RegLanes<core::arch::x86_64::__m256, <Sse2Box as BoxTest>::Lanes>;

    /// All eight children in one 256-bit register per plane.
    #[inline(always)]
    fn boxes(node: &Node, r: &BoxRay, t_max: f32) -> (u32, [f32; WIDTH]) {
        boxes_in::<core::arch::x86_64::__m256>(node, r, t_max)
    }

    /// All eight children in one 256-bit register per plane.
    #[inline(always)]
    fn boxes_frustum(node: &Node, f: &BoxFrustum, t_far: f32) -> FrustumHits {
        frustum_in::<core::arch::x86_64::__m256>(node, f, t_far)
    }
}
