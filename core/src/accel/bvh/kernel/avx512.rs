//! AVX-512F: 16 lanes per register ([`LaneVec`] for `__m512`) for
//! packets; single rays and narrower packets run the AVX2 code
//! ([`Avx512Box`]). Only run inside functions compiled with AVX-512F,
//! after the CPU was checked.

use core::arch::x86_64::*;

use super::avx2::Avx2Box;
use super::lane_vec::LaneVec;
use super::{BoxTest, RegLanes};
use crate::accel::bvh::node::{BoxFrustum, BoxRay, FrustumHits, Node, WIDTH};

/// AVX-512F: the single-ray tests of [`Avx2Box`], and packets of 16 lanes
/// in one 512-bit register. Only called from functions compiled with
/// AVX-512F enabled.
pub(crate) struct Avx512Box;

impl BoxTest for Avx512Box {
    /// Four triangles per SSE step.
    const SSE_LEAF: bool = true;

    type Lanes = RegLanes<core::arch::x86_64::__m512, <Avx2Box as BoxTest>::Lanes>;

    #[inline(always)]
    fn boxes(node: &Node, r: &BoxRay, t_max: f32) -> (u32, [f32; WIDTH]) {
        Avx2Box::boxes(node, r, t_max)
    }

    #[inline(always)]
    fn boxes_frustum(node: &Node, f: &BoxFrustum, t_far: f32) -> FrustumHits {
        Avx2Box::boxes_frustum(node, f, t_far)
    }
}

/// AVX-512F: 16 lanes; only inside functions compiled with AVX-512F
/// (trait docs).
impl LaneVec for __m512 {
    const W: usize = 16;

    #[inline(always)]
    fn load(p: &[f32]) -> Self {
        let p = &p[..16];
        // SAFETY: AVX-512F is enabled where this is used (trait docs); `p`
        // holds 16 floats.
        unsafe { _mm512_loadu_ps(p.as_ptr()) }
    }
    #[inline(always)]
    fn store(self, p: &mut [f32]) {
        let p = &mut p[..16];
        // SAFETY: as `load`.
        unsafe { _mm512_storeu_ps(p.as_mut_ptr(), self) }
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY (this and the following register-only methods): AVX-512F
        // is enabled where this is used (trait docs); no memory access.
        unsafe { _mm512_set1_ps(x) }
    }
    #[inline(always)]
    fn add(self, b: Self) -> Self {
        unsafe { _mm512_add_ps(self, b) }
    }
    #[inline(always)]
    fn sub(self, b: Self) -> Self {
        unsafe { _mm512_sub_ps(self, b) }
    }
    #[inline(always)]
    fn mul(self, b: Self) -> Self {
        unsafe { _mm512_mul_ps(self, b) }
    }
    #[inline(always)]
    fn div(self, b: Self) -> Self {
        unsafe { _mm512_div_ps(self, b) }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        unsafe { _mm512_abs_ps(self) }
    }
    #[inline(always)]
    fn neg(self) -> Self {
        unsafe {
            _mm512_castsi512_ps(_mm512_xor_si512(
                _mm512_castps_si512(self),
                _mm512_set1_epi32(i32::MIN),
            ))
        }
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        unsafe { _mm512_max_ps(self, b) }
    }
    #[inline(always)]
    fn min(self, b: Self) -> Self {
        unsafe { _mm512_min_ps(self, b) }
    }
    #[inline(always)]
    fn select(bits: u32, a: Self, b: Self) -> Self {
        unsafe { _mm512_mask_blend_ps(bits as u16, b, a) }
    }
    #[inline(always)]
    fn eq(self, b: Self) -> u32 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(self, b) as u32 }
    }
    #[inline(always)]
    fn ne(self, b: Self) -> u32 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(self, b) as u32 }
    }
    #[inline(always)]
    fn lt(self, b: Self) -> u32 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OQ>(self, b) as u32 }
    }
    #[inline(always)]
    fn gt(self, b: Self) -> u32 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_GT_OQ>(self, b) as u32 }
    }
    #[inline(always)]
    fn le(self, b: Self) -> u32 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_LE_OQ>(self, b) as u32 }
    }
    #[inline(always)]
    fn sign_bits(self) -> u32 {
        // A set sign bit is a negative 32-bit integer (AVX-512F has no
        // float movemask).
        unsafe { _mm512_cmplt_epi32_mask(_mm512_castps_si512(self), _mm512_setzero_si512()) as u32 }
    }
    #[inline(always)]
    fn min_lane(self) -> f32 {
        unsafe {
            _mm256_min_ps(
                _mm512_castps512_ps256(self),
                _mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(_mm512_castps_pd(self))),
            )
            .min_lane()
        }
    }
    #[inline(always)]
    fn min_lanes8(v: [Self; 8]) -> [f32; 8] {
        // [c | c + 1], eight partial lanes per child.
        min_pairs8([
            fold_halves(v[0], v[1]),
            fold_halves(v[2], v[3]),
            fold_halves(v[4], v[5]),
            fold_halves(v[6], v[7]),
        ])
    }
}

/// `[a′ | b′]`, eight lanes each, `a′` the pairwise minimum of `a`'s
/// halves (AVX-512F, see [`LaneVec`]).
#[inline(always)]
fn fold_halves(a: __m512, b: __m512) -> __m512 {
    // SAFETY: AVX-512F is enabled where this is used; no memory access.
    unsafe {
        _mm512_min_ps(
            _mm512_shuffle_f32x4::<0x44>(a, b),
            _mm512_shuffle_f32x4::<0xEE>(a, b),
        )
    }
}

/// The smallest lane of each half of four registers: child `2k` in the
/// low half of `v[k]`, child `2k + 1` in its high half (the layout of
/// [`LaneVec::min_lanes8`] after one fold). No lane may be NaN.
/// AVX-512F, see [`LaneVec`].
#[inline(always)]
fn min_pairs8(v: [__m512; 4]) -> [f32; 8] {
    let mut out = [0.0f32; 8];
    // SAFETY: AVX-512F is enabled where this is used; register-only but
    // the last store, which writes the 8 floats of `out`.
    unsafe {
        // [c0 c1 c2 c3] and [c4 c5 c6 c7], four partial lanes each.
        let q0 = _mm512_min_ps(
            _mm512_shuffle_f32x4::<0x88>(v[0], v[1]),
            _mm512_shuffle_f32x4::<0xDD>(v[0], v[1]),
        );
        let q4 = _mm512_min_ps(
            _mm512_shuffle_f32x4::<0x88>(v[2], v[3]),
            _mm512_shuffle_f32x4::<0xDD>(v[2], v[3]),
        );
        // Per 128-bit block k: [ck ck ck+4 ck+4] (two partials) ...
        let r = _mm512_min_ps(
            _mm512_shuffle_ps::<0x44>(q0, q4),
            _mm512_shuffle_ps::<0xEE>(q0, q4),
        );
        // ... and each pair reduced: [ck ck ck+4 ck+4] (final).
        let m = _mm512_min_ps(r, _mm512_shuffle_ps::<0xB1>(r, r));
        let order = _mm512_setr_epi32(0, 4, 8, 12, 2, 6, 10, 14, 0, 0, 0, 0, 0, 0, 0, 0);
        let m = _mm512_permutexvar_ps(order, m);
        _mm256_storeu_ps(out.as_mut_ptr(), _mm512_castps512_ps256(m));
    }
    out
}
