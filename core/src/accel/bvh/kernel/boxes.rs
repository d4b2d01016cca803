//! The box tests in explicit registers ([`LaneVec`]): the packet's
//! per-lane box tests and its set-up, and the single-ray test of a node's
//! children ([`boxes_in`], [`frustum_in`]).
//!
//! `packet::boxes_lanes_portable` is the portable form over `[f32; N]`;
//! LLVM vectorised it across a node's four children instead of across the
//! lanes and then transposed every result into lane order, which cost more
//! than the arithmetic. [`boxes_lanes_simd`] is the same test one register
//! of lanes at a time, bit for bit (`max_keep(acc, x)` is x86's
//! `maxps(x, acc)`, which returns `acc` for a NaN `x`, and `min_keep`
//! likewise). [`child_lanes_simd`] tests the lanes of a frustum packet
//! against one child (`node::child_lanes`), and [`prepare_lanes_simd`] is
//! the box half of the packet set-up (`packet::prepare_lanes_portable`,
//! whose divisions LLVM had left scalar). x86_64 only; other targets use
//! the portable forms.

use super::lane_vec::LaneVec;
use crate::accel::bvh::node::{BoxFrustum, BoxRay, FAR_SCALE, FrustumHits, Node, WIDTH};
use crate::accel::bvh::packet::{BoxLanes, LanesOut};
use crate::geometry::RayPacket;

/// Robust slab test of `N` lanes against a node's children, as
/// `packet::boxes_lanes`: per child, the lanes of `lanes` that hit it and
/// their smallest entry distance (`+∞` for none). `N` must be a multiple
/// of `V::W`.
#[inline(always)]
pub(super) fn boxes_lanes_simd<V: LaneVec, const N: usize>(
    node: &Node,
    l: &BoxLanes<'_, N>,
    lanes: u32,
) -> ([u32; WIDTH], [f32; WIDTH]) {
    debug_assert!(N.is_multiple_of(V::W));
    let mut masks = [0u32; WIDTH];
    let mut t_min = [f32::INFINITY; WIDTH];
    let inf = V::splat(f32::INFINITY);
    let scale = V::splat(FAR_SCALE);
    for chunk in 0..N / V::W {
        let at = chunk * V::W;
        let shift = at as u32;
        let tm = V::load(&l.t_max[at..]);
        // No closures (`map`): a closure is compiled without the caller's
        // target features, so the intrinsics in it would become calls.
        let o = [
            V::load(&l.o[0][at..]),
            V::load(&l.o[1][at..]),
            V::load(&l.o[2][at..]),
        ];
        let inv = [
            V::load(&l.inv[0][at..]),
            V::load(&l.inv[1][at..]),
            V::load(&l.inv[2][at..]),
        ];
        let neg = [
            l.neg_bits[0] >> shift,
            l.neg_bits[1] >> shift,
            l.neg_bits[2] >> shift,
        ];
        let live = lanes >> shift;
        // One child at a time: its two accumulators and the lanes' seven
        // ray registers fit in AVX2's sixteen, where all children's
        // accumulators at once (sixteen for eight children) spilled.
        let mut keys = [inf; WIDTH];
        for c in 0..WIDTH {
            let (mut near, mut far) = (V::splat(0.0), tm);
            if let Some(u) = l.uniform_neg {
                // The same planes for every lane: picked by row, with no
                // per-lane select (the selection was a tenth of the
                // instructions of MTM packets when matched per child).
                let rows = node.rows();
                for a in 0..3 {
                    let (nr, fr) = if u[a] { (3 + a, a) } else { (a, 3 + a) };
                    let p = (V::splat(rows[nr][c]), V::splat(rows[fr][c]));
                    (near, far) = slab(near, far, p, o[a], inv[a]);
                }
            } else {
                for a in 0..3 {
                    let (lo, hi) = (V::splat(node.min[a][c]), V::splat(node.max[a][c]));
                    (near, far) = slab(near, far, planes(lo, hi, neg[a]), o[a], inv[a]);
                }
            }
            let hit = near.le(far.mul(scale)) & live & lane_bits(V::W);
            masks[c] |= hit << shift;
            keys[c] = V::select(hit, near, inf);
        }
        // Entry distances are never NaN (they start at +0 and `max_keep`
        // drops NaN), so the reduction order is free.
        let mins = V::min_lanes8(keys);
        for c in 0..WIDTH {
            t_min[c] = if mins[c] < t_min[c] {
                mins[c]
            } else {
                t_min[c]
            };
        }
    }
    (masks, t_min)
}

/// `node::child_lanes` in registers of `V::W` lanes: the per-lane test of
/// child `c` from the frustum test's plane offsets, the same bits.
/// `N` must be a multiple of `V::W`.
#[inline(always)]
pub(super) fn child_lanes_simd<V: LaneVec, const N: usize>(
    offsets: &[[f32; WIDTH]; 6],
    c: usize,
    inv: &[[f32; N]; 3],
    t_max: &[f32; N],
    lanes: u32,
) -> u32 {
    debug_assert!(N.is_multiple_of(V::W));
    let c = c & (WIDTH - 1);
    let scale = V::splat(FAR_SCALE);
    let d: [V; 6] = [
        V::splat(offsets[0][c]),
        V::splat(offsets[1][c]),
        V::splat(offsets[2][c]),
        V::splat(offsets[3][c]),
        V::splat(offsets[4][c]),
        V::splat(offsets[5][c]),
    ];
    let mut hit = 0;
    for at in (0..N).step_by(V::W) {
        let mut near = V::splat(0.0);
        let mut far = V::load(&t_max[at..]);
        for a in 0..3 {
            let inv = V::load(&inv[a][at..]);
            near = d[a].mul(inv).max(near);
            far = d[3 + a].mul(inv).min(far);
        }
        hit |= (near.le(far.mul(scale)) & lane_bits(V::W)) << at;
    }
    hit & lanes
}

/// `packet::apply_hits` in registers of `V::W` lanes: a select per
/// register of `t_max`, `b1` and `b2`, and the slot stored in each hit
/// lane. `N` must be a multiple of `V::W`.
///
/// The portable loops over `[bool; N]` were compiled (AVX-512, 16 lanes)
/// to about 150 mask-register moves, shifts and permutes per call, in
/// place of the three masked moves they stand for: 13% of the samples of
/// packets of 16 on the 260k-triangle mesh's MTM bundles (Zen 4).
#[inline(always)]
pub(super) fn apply_hits_simd<V: LaneVec, const N: usize>(
    m: u32,
    idx: u32,
    (t, tb1, tb2): (&[f32; N], &[f32; N], &[f32; N]),
    t_max: &mut [f32; N],
    best: &mut [u32; N],
    b1: &mut [f32; N],
    b2: &mut [f32; N],
) {
    debug_assert!(N.is_multiple_of(V::W));
    if m == 0 {
        // The common case (most triangles are missed by every lane); the
        // branch also keeps `t_max` off the division's dependency chain
        // (`packet::apply_hits`).
        return;
    }
    for at in (0..N).step_by(V::W) {
        let h = m >> at & lane_bits(V::W);
        V::select(h, V::load(&t[at..]), V::load(&t_max[at..])).store(&mut t_max[at..]);
        V::select(h, V::load(&tb1[at..]), V::load(&b1[at..])).store(&mut b1[at..]);
        V::select(h, V::load(&tb2[at..]), V::load(&b2[at..])).store(&mut b2[at..]);
    }
    let mut bits = m;
    while bits != 0 {
        let i = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        if let Some(b) = best.get_mut(i) {
            *b = idx;
        }
    }
}

/// `packet::prepare_lanes_portable` in registers of `V::W` lanes: the
/// same values (one IEEE division per lane, selects), so the same bits.
/// `N` must be a multiple of `V::W`.
#[inline(always)]
pub(super) fn prepare_lanes_simd<V: LaneVec, const N: usize>(
    rays: &RayPacket<N>,
    valid: u32,
    out: LanesOut<'_, N>,
) -> [u32; 3] {
    debug_assert!(N.is_multiple_of(V::W));
    let (o, d) = (
        [&rays.ox, &rays.oy, &rays.oz],
        [&rays.dx, &rays.dy, &rays.dz],
    );
    let first = (valid.trailing_zeros() as usize).min(N - 1);
    let one = V::splat(1.0);
    let mut neg_bits = [0u32; 3];
    for a in 0..3 {
        let (o0, inv0) = (V::splat(o[a][first]), V::splat(1.0 / d[a][first]));
        for at in (0..N).step_by(V::W) {
            let bits = valid >> at & lane_bits(V::W);
            let inv = one.div(V::load(&d[a][at..]));
            V::select(bits, V::load(&o[a][at..]), o0).store(&mut out.o[a][at..]);
            V::select(bits, inv, inv0).store(&mut out.inv[a][at..]);
            neg_bits[a] |= (inv.sign_bits() & bits) << at;
        }
    }
    let empty = V::splat(-1.0);
    for at in (0..N).step_by(V::W) {
        let bits = valid >> at & lane_bits(V::W);
        V::select(bits, V::load(&rays.t_max[at..]), empty).store(&mut out.t_max[at..]);
    }
    neg_bits
}

/// One axis of the robust slab test for a register of lanes: the entry
/// and exit distances `near`, `far` narrowed by the near and far planes
/// `nb`, `fb` (picked by the direction's sign: per lane, or once for all
/// when the signs agree) with origin `o` and reciprocal direction `inv`.
/// `max_keep(acc, x)` is `maxps(x, acc)` (NaN `x` dropped), `min_keep`
/// likewise.
#[inline(always)]
fn slab<V: LaneVec>(near: V, far: V, (nb, fb): (V, V), o: V, inv: V) -> (V, V) {
    (nb.sub(o).mul(inv).max(near), fb.sub(o).mul(inv).min(far))
}

/// The near and far planes per lane: `hi`, `lo` where bit `neg` marks a
/// negative direction, `lo`, `hi` elsewhere.
#[inline(always)]
fn planes<V: LaneVec>(lo: V, hi: V, neg: u32) -> (V, V) {
    (V::select(neg, hi, lo), V::select(neg, lo, hi))
}

/// The low `w` bits.
#[inline(always)]
const fn lane_bits(w: usize) -> u32 {
    if w >= 32 { u32::MAX } else { (1 << w) - 1 }
}

/// The single-ray box test (`node::boxes`) in registers of `V::W`
/// children, `WIDTH / V::W` registers per plane: the same operations per
/// child (`LaneVec::max(x, acc)` is `maxps(x, acc)`, which keeps `acc` for
/// a NaN `x`, as `max_keep(acc, x)`), so the same bits.
#[inline(always)]
pub(super) fn boxes_in<V: LaneVec>(node: &Node, r: &BoxRay, t_max: f32) -> (u32, [f32; WIDTH]) {
    let mut out = [0.0f32; WIDTH];
    let mut mask = 0;
    let rows = node.rows();
    let scale = V::splat(FAR_SCALE);
    for at in (0..WIDTH).step_by(V::W) {
        let mut near = V::splat(0.0);
        let mut far = V::splat(t_max);
        for a in 0..3 {
            let (nb, fb) = (&rows[r.near[a] & 7], &rows[r.far[a] & 7]);
            let (o, inv) = (V::splat(r.o[a]), V::splat(r.inv[a]));
            near = V::load(&nb[at..]).sub(o).mul(inv).max(near);
            far = V::load(&fb[at..]).sub(o).mul(inv).min(far);
        }
        mask |= near.le(far.mul(scale)) << at;
        near.store(&mut out[at..]);
    }
    (mask, out)
}

/// The frustum test (`node::boxes_frustum`) in registers of `V::W`
/// children: the same operations per child, so the same bits.
#[inline(always)]
pub(super) fn frustum_in<V: LaneVec>(node: &Node, f: &BoxFrustum, t_far: f32) -> FrustumHits {
    debug_assert!(WIDTH.is_multiple_of(V::W));
    let mut out = [0.0f32; WIDTH];
    let mut offsets = [[0.0f32; WIDTH]; 6];
    let mut mask = 0;
    let rows = node.rows();
    let scale = V::splat(FAR_SCALE);
    for at in (0..WIDTH).step_by(V::W) {
        let mut near = V::splat(0.0);
        let mut far = V::splat(t_far);
        for a in 0..3 {
            let (nb, fb) = (&rows[f.near[a] & 7], &rows[f.far[a] & 7]);
            let o = V::splat(f.o[a]);
            let (lo, hi) = (V::splat(f.inv_lo[a]), V::splat(f.inv_hi[a]));
            let dn = V::load(&nb[at..]).sub(o);
            dn.store(&mut offsets[a][at..]);
            near = dn.mul(lo).min(dn.mul(hi)).max(near);
            let df = V::load(&fb[at..]).sub(o);
            df.store(&mut offsets[3 + a][at..]);
            far = df.mul(lo).max(df.mul(hi)).min(far);
        }
        mask |= near.le(far.mul(scale)) << at;
        near.store(&mut out[at..]);
    }
    FrustumHits {
        mask,
        near: out,
        offsets,
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::accel::bvh::node::{boxes_frustum, child_lanes};
    use crate::accel::bvh::packet::{boxes_lanes_portable, prepare_lanes_portable};
    use core::arch::x86_64::{__m128, __m256, __m512};

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

    type Inputs = (Node, [[f32; 16]; 3], [[f32; 16]; 3], [f32; 16], [u32; 3]);

    /// A node (some slots empty, some boxes flat) and 16 lanes whose
    /// origins often lie exactly on a slab plane and whose directions
    /// often have zero components (`inv = ±∞`, slab distances `0·∞ =
    /// NaN`), with `t_max` sometimes below the boxes or a dummy's `−1`.
    fn inputs(rng: &mut Rng) -> Inputs {
        let mut node = Node::EMPTY;
        for c in 0..WIDTH {
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
                    0 => node.min[a][rng.next() as usize % WIDTH],
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
            // Uniform signs only when they are (as `PreparedPacket::set` decides);
            // otherwise the per-lane selection.
            let uniform = (neg.iter().all(|&m| m & lanes == 0 || m & lanes == lanes) && lanes != 0)
                .then(|| neg.map(|m| m & lanes != 0));
            for uniform_neg in [None, uniform] {
                let b = BoxLanes {
                    o: &o,
                    inv: &inv,
                    t_max: &t_max,
                    neg_bits: neg,
                    uniform_neg,
                };
                let want = boxes_lanes_portable(&node, &b, lanes);
                let got = boxes_lanes_simd::<V, 16>(&node, &b, lanes);
                assert_eq!(got.0, want.0, "masks, uniform {uniform_neg:?}");
                assert_eq!(
                    got.1.map(f32::to_bits),
                    want.1.map(f32::to_bits),
                    "entry distances, uniform {uniform_neg:?}"
                );
            }
        }
    }

    /// `V`'s hit recording and the portable one, from the same state and
    /// hits (any lane mask, none and all included), leave the same bits.
    fn check_apply_hits<V: LaneVec>(rng: &mut Rng) {
        for round in 0..2000 {
            let lanes = |rng: &mut Rng| -> [f32; 16] { core::array::from_fn(|_| rng.f(0.0, 9.0)) };
            let found = (lanes(rng), lanes(rng), lanes(rng));
            let state = (
                lanes(rng),
                core::array::from_fn::<u32, 16, _>(|_| rng.next()),
                lanes(rng),
                lanes(rng),
            );
            let m = match round % 4 {
                0 => 0,
                1 => 0xffff,
                _ => rng.next() & 0xffff,
            };
            let idx = rng.next();
            let (mut want, mut got) = (state, state);
            let f = (&found.0, &found.1, &found.2);
            crate::accel::bvh::packet::apply_hits(
                m,
                idx,
                f,
                &mut want.0,
                &mut want.1,
                &mut want.2,
                &mut want.3,
            );
            apply_hits_simd::<V, 16>(m, idx, f, &mut got.0, &mut got.1, &mut got.2, &mut got.3);
            assert_eq!(
                got.0.map(f32::to_bits),
                want.0.map(f32::to_bits),
                "t_max, m {m:#x}"
            );
            assert_eq!(got.1, want.1, "slots, m {m:#x}");
            assert_eq!(
                got.2.map(f32::to_bits),
                want.2.map(f32::to_bits),
                "b1, m {m:#x}"
            );
            assert_eq!(
                got.3.map(f32::to_bits),
                want.3.map(f32::to_bits),
                "b2, m {m:#x}"
            );
        }
    }

    #[target_feature(enable = "avx2")]
    fn check_avx2(rng: &mut Rng) {
        check::<__m256>(rng);
        check_frustum::<__m256>(rng);
        check_prepare::<__m256>(rng);
        check_apply_hits::<__m256>(rng);
    }

    #[target_feature(enable = "avx2,avx512f")]
    fn check_avx512(rng: &mut Rng) {
        check::<__m512>(rng);
        check_frustum::<__m512>(rng);
        check_prepare::<__m512>(rng);
        check_apply_hits::<__m512>(rng);
    }

    /// Sixteen lanes from one origin (often on a slab plane of some box),
    /// directions within `spread` of a random one with the same signs and
    /// no zero component (a frustum's requirement), `t_max` varied. Returns
    /// the lanes' `o`, `inv`, `t_max`, sign bits and the frustum.
    #[allow(clippy::type_complexity)]
    fn frustum_inputs(
        rng: &mut Rng,
        node: &Node,
    ) -> (
        [[f32; 16]; 3],
        [[f32; 16]; 3],
        [f32; 16],
        [u32; 3],
        BoxFrustum,
    ) {
        let mut o0 = [0.0f32; 3];
        let mut d0 = [0.0f32; 3];
        for a in 0..3 {
            o0[a] = match rng.next() % 3 {
                0 => node.min[a][rng.next() as usize % WIDTH],
                _ => rng.f(-4.0, 4.0),
            };
            if !o0[a].is_finite() {
                o0[a] = 0.5;
            }
            d0[a] = rng.f(0.05, 1.0)
                * if rng.next().is_multiple_of(2) {
                    1.0
                } else {
                    -1.0
                };
        }
        let spread = [1e-4, 1e-2, 0.3][rng.next() as usize % 3];
        let (mut o, mut inv) = ([[0.0; 16]; 3], [[0.0; 16]; 3]);
        let mut t_max = [0.0; 16];
        let mut neg = [0u32; 3];
        for i in 0..16 {
            for a in 0..3 {
                o[a][i] = o0[a];
                // Same sign as `d0[a]`, never zero.
                let d = d0[a] * (1.0 + rng.f(-spread, spread)).max(0.01);
                inv[a][i] = 1.0 / d;
                neg[a] |= (inv[a][i].is_sign_negative() as u32) << i;
            }
            t_max[i] = match rng.next() % 4 {
                0 => rng.f(0.0, 0.5),
                1 => f32::INFINITY,
                _ => rng.f(0.0, 20.0),
            };
        }
        let lo = inv.map(|v| v.into_iter().fold(f32::INFINITY, f32::min));
        let hi = inv.map(|v| v.into_iter().fold(f32::NEG_INFINITY, f32::max));
        let f = BoxFrustum::new(o0, lo, hi).expect("finite reciprocals of one sign per axis");
        (o, inv, t_max, neg, f)
    }

    /// The frustum test meets every child any lane's own slab test meets,
    /// with an entry distance no larger than any such lane's, in every
    /// register width bit for bit; and the lane test of one child from
    /// the frustum's plane offsets (`child_lanes`) gives the per-lane
    /// test's mask exactly, for every child.
    fn check_frustum<V: LaneVec>(rng: &mut Rng) {
        let mut culled = 0;
        for _ in 0..4000 {
            let (node, ..) = inputs(rng);
            let (o, inv, t_max, neg, f) = frustum_inputs(rng, &node);
            let lanes = rng.next() & 0xffff | 1;
            // The frustum spans all sixteen lanes; its far end is the
            // largest `t_max` of the tested ones.
            let t_far = (0..16)
                .filter(|i| lanes >> i & 1 != 0)
                .map(|i| t_max[i])
                .fold(f32::NEG_INFINITY, f32::max);
            let b = BoxLanes {
                o: &o,
                inv: &inv,
                t_max: &t_max,
                neg_bits: neg,
                uniform_neg: Some(neg.map(|m| m != 0)),
            };
            let (masks, t_min) = boxes_lanes_portable(&node, &b, lanes);
            let want = boxes_frustum(&node, &f, t_far);
            // A node's eight children fill at most a 256-bit register
            // (AVX-512 kernels run the AVX2 frustum test).
            if V::W <= WIDTH {
                let got = frustum_in::<V>(&node, &f, t_far);
                assert_eq!(got.mask, want.mask, "frustum mask");
                assert_eq!(got.near.map(f32::to_bits), want.near.map(f32::to_bits));
                assert_eq!(
                    got.offsets.map(|r| r.map(f32::to_bits)),
                    want.offsets.map(|r| r.map(f32::to_bits))
                );
            }
            for c in 0..WIDTH {
                if masks[c] != 0 {
                    assert!(
                        want.mask >> c & 1 != 0,
                        "child {c} hit by lanes {:#x} culled",
                        masks[c]
                    );
                    assert!(
                        want.near[c] <= t_min[c],
                        "child {c}: frustum near above a lane's"
                    );
                } else if want.mask >> c & 1 != 0 {
                    culled += 1;
                }
                let one = child_lanes(&want.offsets, c, &inv, &t_max, lanes);
                let one_simd = child_lanes_simd::<V, 16>(&want.offsets, c, &inv, &t_max, lanes);
                assert_eq!(one, masks[c], "child_lanes, child {c}");
                assert_eq!(one_simd, masks[c], "child_lanes_simd, child {c}");
            }
        }
        // The frustum is looser than the lanes on wide spreads: some
        // children it keeps are missed by every lane (so the lane test of
        // leaves has something to do, and this test sees both outcomes).
        assert!(culled > 0);
    }

    /// The packet set-up in registers against the portable form, bit for
    /// bit: zero, negative-zero and infinite direction components, NaN
    /// garbage in the invalid lanes, random valid masks.
    fn check_prepare<V: LaneVec>(rng: &mut Rng) {
        for _ in 0..2000 {
            let mut rays = RayPacket::<16>::default();
            let valid = rng.next() & 0xffff;
            for i in 0..16 {
                let garbage = valid >> i & 1 == 0 && rng.next().is_multiple_of(2);
                let comp = |rng: &mut Rng| match rng.next() % 6 {
                    _ if garbage => f32::NAN,
                    0 => 0.0,
                    1 => -0.0,
                    _ => rng.f(-2.0, 2.0),
                };
                rays.ox[i] = comp(rng);
                rays.oy[i] = comp(rng);
                rays.oz[i] = comp(rng);
                rays.dx[i] = comp(rng);
                rays.dy[i] = comp(rng);
                rays.dz[i] = comp(rng);
                rays.t_max[i] = if garbage { f32::NAN } else { rng.f(0.0, 9.0) };
            }
            let mut want = ([[0.0f32; 16]; 3], [[0.0f32; 16]; 3], [0.0f32; 16]);
            let mut got = want;
            let nw = prepare_lanes_portable(
                &rays,
                valid,
                LanesOut {
                    o: &mut want.0,
                    inv: &mut want.1,
                    t_max: &mut want.2,
                },
            );
            let ng = prepare_lanes_simd::<V, 16>(
                &rays,
                valid,
                LanesOut {
                    o: &mut got.0,
                    inv: &mut got.1,
                    t_max: &mut got.2,
                },
            );
            assert_eq!(ng, nw, "sign bits, valid {valid:#x}");
            let bits = |a: &[[f32; 16]; 3]| a.map(|r| r.map(f32::to_bits));
            assert_eq!(bits(&got.0), bits(&want.0), "origins");
            assert_eq!(bits(&got.1), bits(&want.1), "reciprocals");
            assert_eq!(got.2.map(f32::to_bits), want.2.map(f32::to_bits), "t_max");
        }
    }

    /// Every register width agrees with the portable lane loops bit for
    /// bit, NaN slabs, flat and empty boxes, dummy lanes and partial masks
    /// included (the packet tests compare final hits only; this
    /// compares the box test, the set-up and the hit recording
    /// themselves).
    #[test]
    fn simd_box_test_matches_portable() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        check::<__m128>(&mut rng);
        check_frustum::<__m128>(&mut rng);
        check_prepare::<__m128>(&mut rng);
        check_apply_hits::<__m128>(&mut rng);
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
