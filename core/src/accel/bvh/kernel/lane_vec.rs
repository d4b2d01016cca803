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

/// One register of `W` lanes. The SSE2 implementation runs anywhere on
/// x86_64; the AVX2 and AVX-512F ones must only be used inside functions
/// compiled with those features (`#[target_feature]`), which are only
/// called after [`super::Kernel::is_available`] confirmed them — that is the
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
