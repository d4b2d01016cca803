//! Explicit SIMD lane vectors (x86_64): one register of packet lanes.
//!
//! The packet kernels (the BVH's box test, the watertight triangle test)
//! have portable forms over `[f32; N]` arrays, which LLVM vectorises, but
//! not always across the lanes: it vectorised the box test across a node's
//! four children and then transposed every result into lane order. The
//! kernels are therefore also written once over [`LaneVec`], which SSE2
//! (4 lanes), AVX2 (8) and AVX-512F (16) implement, and run over a packet
//! in register-sized chunks.
//!
//! Every operation is one IEEE operation, rounded as its scalar
//! counterpart (no FMA), and the comparisons and `max`/`min` have the
//! scalar semantics spelled out on each method, NaN included — so a kernel
//! written over `LaneVec` gives the portable form's bits exactly.

use core::arch::x86_64::*;

/// One register of `W` lanes. The SSE2 implementation runs anywhere on
/// x86_64; the AVX2 and AVX-512F ones must only be used inside functions
/// compiled with those features (`#[target_feature]`), which are only
/// called after `Kernel::is_available` confirmed them — that is the
/// invariant behind their `unsafe` blocks.
pub(crate) trait LaneVec: Copy {
    /// Lanes per register.
    const W: usize;
    /// Loads lanes `p[..W]`.
    fn load(p: &[f32]) -> Self;
    /// Stores the lanes to `p[..W]`.
    fn store(self, p: &mut [f32]);
    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// `self + b` per lane.
    fn add(self, b: Self) -> Self;
    /// `self − b` per lane.
    fn sub(self, b: Self) -> Self;
    /// `self · b` per lane.
    fn mul(self, b: Self) -> Self;
    /// `self / b` per lane.
    fn div(self, b: Self) -> Self;
    /// `|self|` per lane (clears the sign bit).
    fn abs(self) -> Self;
    /// `−self` per lane (flips the sign bit).
    fn neg(self) -> Self;
    /// `if self > b { self } else { b }` per lane (x86 `maxps`: `b` for a
    /// NaN or for two zeros).
    fn max(self, b: Self) -> Self;
    /// `if self < b { self } else { b }` per lane (x86 `minps`).
    fn min(self, b: Self) -> Self;
    /// Per lane, `a` where bit `i` of `bits` is set, else `b`.
    fn select(bits: u32, a: Self, b: Self) -> Self;
    /// Bits of `self == b` (false for NaN).
    fn eq(self, b: Self) -> u32;
    /// Bits of `self != b` (true for NaN, like Rust's `!=`).
    fn ne(self, b: Self) -> u32;
    /// Bits of `self < b` (false for NaN).
    fn lt(self, b: Self) -> u32;
    /// Bits of `self > b` (false for NaN).
    fn gt(self, b: Self) -> u32;
    /// Bits of `self <= b` (false for NaN).
    fn le(self, b: Self) -> u32;
    /// The lanes' sign bits (set for `−0`, negative numbers and NaNs
    /// with the sign bit).
    fn sign_bits(self) -> u32;
    /// The smallest lane; no lane may be NaN (the reduction order is
    /// unspecified).
    fn min_lane(self) -> f32;
    /// [`Self::min_lane`] of eight registers at once. A tree of shuffles
    /// across the registers (AVX2, AVX-512F) takes about a third of the
    /// instructions of eight separate reductions, which were most of a
    /// packet's per-child box test after the slabs. No lane may be NaN.
    #[inline(always)]
    fn min_lanes8(v: [Self; 8]) -> [f32; 8] {
        let mut out = [0.0; 8];
        for (o, x) in out.iter_mut().zip(v) {
            *o = x.min_lane();
        }
        out
    }
}

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
