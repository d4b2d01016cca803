//! Packet traversal: one shared stack for `N` rays, in one of two forms.
//!
//! - **Frustum** ([`traverse_frustum`]): when the live lanes share their
//!   origin bit for bit and point within [`FRUSTUM_SPREAD`] of each other
//!   (pinhole tiles, the multiple-try step's bundles), the packet walks
//!   the tree once as a single ray would, with one conservative box test
//!   of its frustum per node (`node::BoxFrustum`); leaves are tested lane
//!   by lane.
//! - **Per lane** ([`traverse()`]): otherwise a node is visited when any
//!   live lane's ray hits its box, each child tested for every lane; a
//!   deferred child is dropped for the lanes whose closest hit is already
//!   in front of it.
//!
//! Per-lane `t_max` shrinks as hits are found in both. The kernels
//! ([`boxes_lanes`], the frustum tests and the triangle test) come from the
//! view's [`Kernel`] through [`BoxTest`]: in registers of its width
//! (`kernel::boxes`, `kernel::triangle`), or as the portable
//! lane loops over `[f32; N]` arrays for the scalar kernel and odd widths.
//! Both forms give every lane the closest hit its own single-ray traversal
//! finds (a tie between two triangles at the same distance aside).
//!
//! Lanes outside the active mask never influence anything: the kernels
//! work on an internal copy in which those lanes hold a dummy ray (the
//! copy's lane loops read every lane and select), and every result is
//! masked, so they are never written to the output.

use super::BvhView;
#[cfg(target_arch = "x86_64")]
use super::kernel::{Avx2Box, Avx512Box, Kernel, Sse2Box};
use super::kernel::{BoxTest, LaneTests, ScalarBox, TriLanesOut};
use super::leaf::slot_id;
use super::node::{BoxFrustum, BoxRay, FAR_SCALE, Node, WIDTH, max_keep, min_keep};
use super::traverse::{self, Prepared, Stack, descend, descend_any, traverse_from};
use crate::accel::{intersect_lanes, occluded_lanes};
use crate::geometry::triangle::{WatertightLanes, lane_mask};
use crate::geometry::{Hit, HitPacket, LaneMask, RayPacket};
use core::any::Any;

/// A packet prepared for traversal, the packet form of
/// [`Prepared`]: an SoA copy of its live rays with their box and
/// triangle precomputation.
struct PreparedPacket<const N: usize> {
    o: [[f32; N]; 3],
    inv: [[f32; N]; 3],
    /// Per axis, the valid lanes whose direction is negative (the sign
    /// bit of `1/d`: the near plane is the box's max).
    neg_bits: [u32; 3],
    /// The direction signs shared by all live lanes, if any.
    uniform_neg: Option<[bool; 3]>,
    /// Subtrees reached by this many live lanes or fewer are finished ray
    /// by ray ([`single_ray_lanes`]).
    single_lanes: u32,
    /// Current upper bound per lane (shrinks with closest hits).
    t_max: [f32; N],
    wt: WatertightLanes<N>,
    /// The live lanes as one frustum, when they share their origin and
    /// direction octant and point within [`FRUSTUM_SPREAD`] of each other
    /// ([`frustum_of`]): the packet is then traversed as one ray
    /// ([`traverse_frustum`]).
    frustum: Option<BoxFrustum>,
}

impl<const N: usize> PreparedPacket<N> {
    /// Every lane a dummy: a finite ray with an empty interval.
    #[inline(always)]
    fn dummies() -> Self {
        PreparedPacket {
            o: [[0.0; N]; 3],
            inv: [[1.0; N]; 3],
            neg_bits: [0; 3],
            uniform_neg: None,
            single_lanes: 1,
            t_max: [-1.0; N],
            wt: WatertightLanes::new(),
            frustum: None,
        }
    }

    /// Copies the valid active lanes of `rays` into lanes fresh from
    /// [`Self::dummies`]; returns their mask. The other lanes stay dummies
    /// (an empty interval), with the first valid lane's origin and
    /// direction so that reductions over all lanes need no mask.
    /// Invalid lanes (non-finite, zero direction, `t_max` not positive)
    /// cannot hit anything and are left out, like in the single-ray path.
    ///
    /// Branch-free lane loops (inlined into the kernels' target-feature
    /// functions, so they vectorise to the kernel's width): every lane is
    /// computed and inactive or invalid ones are replaced by the dummy.
    /// Filled in place: built apart and moved, the set-up (1.5 KB for 16
    /// lanes) was copied by `memcpy` calls on every packet.
    #[inline(always)]
    fn set<B: BoxTest>(&mut self, rays: &RayPacket<N>, active: LaneMask) -> u32 {
        let active = active.0 & LaneMask::first(N).0;
        let mut t_ok = [false; N];
        for (ok, &t) in t_ok.iter_mut().zip(&rays.t_max) {
            *ok = t > 0.0;
        }
        let valid = self.wt.set_lanes(
            [&rays.ox, &rays.oy, &rays.oz],
            [&rays.dx, &rays.dy, &rays.dz],
            active & lane_mask(&t_ok),
        );
        self.wt.finish(valid);
        let neg_bits = B::Lanes::prepare_lanes(
            rays,
            valid,
            LanesOut {
                o: &mut self.o,
                inv: &mut self.inv,
                t_max: &mut self.t_max,
            },
        );
        if valid != 0 && neg_bits.iter().all(|&m| m == 0 || m == valid) {
            self.uniform_neg = Some(neg_bits.map(|m| m != 0));
        }
        self.single_lanes = single_ray_lanes::<N>(neg_bits, valid);
        self.neg_bits = neg_bits;
        if self.uniform_neg.is_some() && valid.count_ones() >= 2 {
            self.frustum = frustum_of(&self.o, &self.inv);
        }
        valid
    }

    /// Lane `i` as a single ray, bit-identical to its own set-up.
    #[inline]
    fn prepared(&self, i: usize) -> Prepared {
        let o = [self.o[0][i], self.o[1][i], self.o[2][i]];
        let inv = [self.inv[0][i], self.inv[1][i], self.inv[2][i]];
        Prepared {
            wr: self.wt.get(i),
            // A live lane's `neg` is the sign of its `inv`, so this is the
            // lane's own set-up.
            br: BoxRay::with_inv(o, inv),
        }
    }
}

/// Where a packet's box-test set-up goes ([`LaneTests::prepare_lanes`]).
pub(super) struct LanesOut<'a, const N: usize> {
    /// Origins.
    pub o: &'a mut [[f32; N]; 3],
    /// `1/d` per lane.
    pub inv: &'a mut [[f32; N]; 3],
    /// Upper bound per lane (`−1`, an empty interval, for dummies).
    pub t_max: &'a mut [f32; N],
}

/// The box-test half of [`PreparedPacket::set`]: origins, reciprocal directions
/// and `t_max` of the `valid` lanes; the other lanes become dummies with
/// the first valid lane's origin and direction and an empty interval, so
/// that reductions over all lanes need no mask (`frustum_of`). Returns
/// per axis the valid lanes whose reciprocal direction has its sign bit
/// set. Portable form; `kernel::boxes::prepare_lanes_simd` is the same in
/// registers.
#[inline(always)]
pub(super) fn prepare_lanes_portable<const N: usize>(
    rays: &RayPacket<N>,
    valid: u32,
    out: LanesOut<'_, N>,
) -> [u32; 3] {
    let (o, d) = (
        [&rays.ox, &rays.oy, &rays.oz],
        [&rays.dx, &rays.dy, &rays.dz],
    );
    let first = (valid.trailing_zeros() as usize).min(N - 1);
    let mut neg_bits = [0u32; 3];
    for a in 0..3 {
        let (o0, inv0) = (o[a][first], 1.0 / d[a][first]);
        let mut neg = [false; N];
        for i in 0..N {
            let v = valid >> i & 1 != 0;
            let inv = 1.0 / d[a][i];
            out.o[a][i] = if v { o[a][i] } else { o0 };
            out.inv[a][i] = if v { inv } else { inv0 };
            neg[i] = v && inv.is_sign_negative();
        }
        neg_bits[a] = lane_mask(&neg);
    }
    for i in 0..N {
        out.t_max[i] = if valid >> i & 1 != 0 {
            rays.t_max[i]
        } else {
            -1.0
        };
    }
    neg_bits
}

/// The widest spread of a frustum packet's unit directions, per axis
/// (about 2.9°).
///
/// A frustum is traversed as one ray, so every lane is tested against
/// every triangle any part of the frustum reaches: two MTM bundles far
/// apart in one packet span the whole scene between them (measured at
/// 0.06 Mrays/s for such packets traversed as a frustum). Pinhole tiles of
/// 4×4 pixels and bundles of ±1-pixel perturbations are far below it.
const FRUSTUM_SPREAD: f32 = 0.05;

/// The frustum of a packet's lanes (set up in `o`, `inv`, dummies
/// included: they copy a live lane, see [`PreparedPacket::set`]) when they share
/// their origin bit for bit and their directions lie within
/// [`FRUSTUM_SPREAD`] of each other, with finite reciprocals of one sign
/// per axis (see [`BoxFrustum::new`]).
///
/// The spread is bounded from the reciprocals' ranges alone, so the
/// set-up is a few reductions: with `m` the largest over the axes of the
/// smallest `|d_a|`, every lane's `|d| ≥ m`, so the lanes' unit directions
/// differ per axis by at most `(max d_a − min d_a) / m`. Directions of
/// unequal lengths only make the bound looser (the packet then takes the
/// per-lane traversal, which is always right).
#[inline(always)]
fn frustum_of<const N: usize>(o: &[[f32; N]; 3], inv: &[[f32; N]; 3]) -> Option<BoxFrustum> {
    let o0 = [o[0][0], o[1][0], o[2][0]];
    let mut differs = 0u32;
    for (row, &o0) in o.iter().zip(&o0) {
        for &v in row {
            differs |= v.to_bits() ^ o0.to_bits();
        }
    }
    if differs != 0 {
        return None;
    }
    let inv_lo = [min_lanes(inv[0]), min_lanes(inv[1]), min_lanes(inv[2])];
    let inv_hi = [max_lanes(inv[0]), max_lanes(inv[1]), max_lanes(inv[2])];
    let f = BoxFrustum::new(o0, inv_lo, inv_hi)?;
    // `d = 1/inv`: the range of `d_a` is between the reciprocals of the
    // bounds (one sign per axis, both finite and non-zero).
    let mut m = 0.0f32;
    let mut range = 0.0f32;
    for a in 0..3 {
        let (x, y) = (1.0 / inv_lo[a], 1.0 / inv_hi[a]);
        m = max_keep(m, min_keep(x.abs(), y.abs()));
        range = max_keep(range, (x - y).abs());
    }
    (range <= FRUSTUM_SPREAD * m).then_some(f)
}

/// How many octants the `live` lanes' directions span (their signs per
/// axis are the bits of `neg`).
#[inline(always)]
fn octants(neg: [u32; 3], live: u32) -> u32 {
    let mut occupied = 0;
    for octant in 0..8 {
        let mut m = live;
        for (a, &n) in neg.iter().enumerate() {
            m &= if octant >> a & 1 != 0 { n } else { !n };
        }
        occupied += (m != 0) as u32;
    }
    occupied
}

/// A subtree reached by this many live lanes or fewer is finished ray by
/// ray (same arithmetic, same answers): one lane for packets whose
/// directions span at most four octants, a quarter of the lanes for more
/// divergent ones.
///
/// With the box and triangle tests in registers of the kernel's width, a
/// packet step costs little more than a single-ray one, so coherent
/// packets leave only lone lanes: on MTM bundles of the 260k-triangle mesh
/// that traced 10% more rays per second than leaving at a quarter of the
/// lanes (the best threshold while the lane loops were auto-vectorised),
/// and four octants rather than two traced shadow packets of 16 lanes
/// 1.05–1.4× faster. Incoherent packets (diffuse bounces) drag every lane
/// through every node any lane visits; they used to be finished ray by
/// ray from the root (1.5–3× faster than auto-vectorised packets), but in
/// registers, traversed as packets down to a quarter of their lanes, they
/// trace the room scenes' bounces 1.25–1.35× faster than ray by ray, and
/// the open 260k-triangle mesh's as fast as before (16 lanes: 2.04 -> 2.07
/// Mrays/s; leaving at one lane lost 6% there). Measured worse with the earlier kernels: one octant only for
/// coherence (k = 8 bundles in 16 lanes lost 15–20%), at least half the
/// lanes in one octant (shadow sets lost), and splitting a packet by
/// octant into smaller packets.
#[inline(always)]
fn single_ray_lanes<const N: usize>(neg: [u32; 3], live: u32) -> u32 {
    if octants(neg, live) <= 4 {
        1
    } else {
        (N as u32 / 4).max(1)
    }
}

/// Robust slab test (see `node::boxes`) of all lanes against a node's
/// children: per child, the mask of lanes (within `lanes`) that hit it and
/// the smallest entry distance among them; in the kernel's instruction set
/// ([`LaneTests::boxes_lanes`]).
///
/// Packets with distinct origins (shadow rays, bounces) have no cheap
/// exact frustum: an interval bound over the lanes' origins and
/// reciprocal directions, as a culling step before this test or as the
/// whole node test, was measured slower in three separate trials.
/// Shared origins make the bound as cheap as one ray's
/// test ([`traverse_frustum`]).
#[inline(always)]
fn boxes_lanes<B: BoxTest, const N: usize>(
    node: &Node,
    l: &PreparedPacket<N>,
    lanes: u32,
) -> ([u32; WIDTH], [f32; WIDTH]) {
    let b = BoxLanes {
        o: &l.o,
        inv: &l.inv,
        t_max: &l.t_max,
        neg_bits: l.neg_bits,
        uniform_neg: l.uniform_neg,
    };
    B::Lanes::boxes_lanes(node, &b, lanes)
}

/// A packet's lanes as every form of the box test reads them (SoA).
#[derive(Clone, Copy)]
pub(super) struct BoxLanes<'a, const N: usize> {
    /// Origins.
    pub o: &'a [[f32; N]; 3],
    /// `1/d` per lane (`±∞` for a zero component).
    pub inv: &'a [[f32; N]; 3],
    /// Current upper bound per lane.
    pub t_max: &'a [f32; N],
    /// Per axis, the lanes whose direction is negative (near plane = box
    /// max).
    pub neg_bits: [u32; 3],
    /// The signs shared by all live lanes, if they agree: the planes are
    /// then picked once per node instead of per lane.
    pub uniform_neg: Option<[bool; 3]>,
}

/// The portable form of [`boxes_lanes`], for any `N`.
#[inline(always)]
pub(super) fn boxes_lanes_portable<const N: usize>(
    node: &Node,
    l: &BoxLanes<'_, N>,
    lanes: u32,
) -> ([u32; WIDTH], [f32; WIDTH]) {
    let mut near = [[0.0f32; N]; WIDTH];
    let mut far = [*l.t_max; WIDTH];
    if let Some(neg) = l.uniform_neg {
        for (a, &neg) in neg.iter().enumerate() {
            let (nb, fb) = if neg {
                (&node.max[a], &node.min[a])
            } else {
                (&node.min[a], &node.max[a])
            };
            for c in 0..WIDTH {
                for i in 0..N {
                    near[c][i] = max_keep(near[c][i], (nb[c] - l.o[a][i]) * l.inv[a][i]);
                    far[c][i] = min_keep(far[c][i], (fb[c] - l.o[a][i]) * l.inv[a][i]);
                }
            }
        }
    } else {
        for a in 0..3 {
            for c in 0..WIDTH {
                let (lo, hi) = (node.min[a][c], node.max[a][c]);
                for i in 0..N {
                    let (nb, fb) = if l.neg_bits[a] >> i & 1 != 0 {
                        (hi, lo)
                    } else {
                        (lo, hi)
                    };
                    near[c][i] = max_keep(near[c][i], (nb - l.o[a][i]) * l.inv[a][i]);
                    far[c][i] = min_keep(far[c][i], (fb - l.o[a][i]) * l.inv[a][i]);
                }
            }
        }
    }
    let mut masks = [0u32; WIDTH];
    let mut t_min = [f32::INFINITY; WIDTH];
    for c in 0..WIDTH {
        let mut hit = [false; N];
        let mut key = [f32::INFINITY; N];
        for i in 0..N {
            let h = near[c][i] <= far[c][i] * FAR_SCALE;
            hit[i] = h;
            key[i] = if h & (lanes >> i & 1 != 0) {
                near[c][i]
            } else {
                f32::INFINITY
            };
        }
        masks[c] = lane_mask(&hit) & lanes;
        t_min[c] = min_lanes(key);
    }
    (masks, t_min)
}

/// The smallest of `v` (none NaN), reduced pairwise ([`pairwise`]).
/// Entry distances are never NaN and never `−0` (they start at `+0` and
/// `max_keep` only takes strictly larger values), so every order of the
/// comparisons gives the same bits.
#[inline(always)]
fn min_lanes<const N: usize>(v: [f32; N]) -> f32 {
    pairwise(v, f32::INFINITY, min_keep)
}

/// The largest of `v` (none NaN), reduced pairwise ([`pairwise`]).
#[inline(always)]
fn max_lanes<const N: usize>(v: [f32; N]) -> f32 {
    pairwise(v, f32::NEG_INFINITY, max_keep)
}

/// `v` reduced by `op` in halves, so that each step is a vector
/// operation: a left-to-right chain is one dependent compare per lane,
/// which LLVM may not reorder (it was a fifth of the packet kernel's time
/// on MTM bundles). `empty` for `N = 0`.
#[inline(always)]
fn pairwise<const N: usize>(mut v: [f32; N], empty: f32, op: fn(f32, f32) -> f32) -> f32 {
    let mut w = N;
    while w > 1 {
        let h = w.div_ceil(2);
        for i in 0..w - h {
            v[i] = op(v[i], v[i + h]);
        }
        w = h;
    }
    if N == 0 { empty } else { v[0] }
}

/// A deferred child with the lanes that hit it and their smallest entry
/// distance.
#[derive(Clone, Copy, Default)]
struct Entry {
    child: u32,
    count: u32,
    mask: u32,
    t: f32,
}

/// Closest hits (`ANY = false`) or occlusion (`ANY = true`) of the `live`
/// lanes. Returns, per lane, the slot (see [`super::TriBlock`]) of the hit triangle
/// (`u32::MAX` for none) with `b1`, `b2`; hit distances are left in
/// `l.t_max`. For `ANY`, the returned mask holds the occluded lanes.
#[inline(always)]
#[allow(clippy::type_complexity)]
fn traverse<B: BoxTest, const N: usize, const ANY: bool>(
    view: &BvhView<'_>,
    l: &mut PreparedPacket<N>,
    live: u32,
) -> (u32, [u32; N], [f32; N], [f32; N]) {
    if let Some(f) = l.frustum {
        return traverse_frustum::<B, N, ANY>(view, l, &f, live);
    }
    let mut found = Found::new();
    let mut done = 0u32;
    let mut alive = live;
    // Bounded by the layout's depth check; see `node::MAX_DEPTH`. Left
    // uninitialised: zeroing its 3.5 KB (7 entries per level for 8-wide
    // nodes) was 39% of the instructions of MTM bundles of 8 (callgrind,
    // 8k-triangle mesh); with 4-wide nodes' 1.5 KB the zeroed array had
    // measured 2–3% faster.
    let mut stack = Stack::<Entry>::new();
    // Only set up if a subtree is finished ray by ray.
    let mut single_stack: Option<Stack<traverse::Entry>> = None;
    let mut cur = Entry {
        child: 0,
        count: 0,
        mask: live,
        t: 0.0,
    };
    'outer: loop {
        if cur.mask.count_ones() <= l.single_lanes {
            // Same arithmetic as the packet kernels, so the same answers.
            let mut bits = cur.mask;
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let start = traverse::Entry {
                    child: cur.child,
                    count: cur.count,
                    t: cur.t,
                };
                if let Some((j, hb1, hb2)) = traverse_from::<B, ANY>(
                    view,
                    &l.prepared(i),
                    start,
                    &mut l.t_max[i],
                    single_stack.get_or_insert_with(Stack::new),
                ) {
                    found.best[i] = j as u32;
                    found.b1[i] = hb1;
                    found.b2[i] = hb2;
                    if ANY {
                        done |= 1 << i;
                        alive &= !(1 << i);
                    }
                }
            }
            if ANY && alive == 0 {
                break 'outer;
            }
        } else if cur.count == 0 {
            let node = &view.nodes[cur.child as usize];
            let (masks, t_min) = boxes_lanes::<B, N>(node, l, cur.mask);
            let mut any = 0u32;
            for (c, m) in masks.iter().enumerate() {
                any |= ((*m != 0) as u32) << c;
            }
            let entry = |c: usize| Entry {
                child: node.child[c],
                count: node.count[c],
                mask: masks[c],
                t: t_min[c],
            };
            let defer = |e: Entry| {
                traverse::prefetch(view, e.child, e.count);
                stack.push(e);
            };
            // In the single-ray kernel's order (`traverse::descend`, or
            // for occlusion `traverse::descend_any`, the boxes holding some
            // lane's origin last).
            let next = if ANY {
                descend_any(any, &t_min, entry, defer)
            } else {
                descend(any, &t_min, entry, defer)
            };
            if let Some(e) = next {
                cur = e;
                continue;
            }
        } else {
            let m = leaf::<B, N, ANY>(view, l, (cur.child, cur.count), cur.mask, &mut found);
            if ANY && m != 0 {
                done |= m;
                alive &= !m;
                if alive == 0 {
                    break 'outer;
                }
            }
        }
        // Pop the next child that some live lane may still hit in front of
        // its closest hit.
        loop {
            let Some(e) = stack.pop() else {
                break 'outer;
            };
            let mut keep = [false; N];
            for (k, &t) in keep.iter_mut().zip(&l.t_max) {
                *k = e.t <= t * FAR_SCALE;
            }
            let m = e.mask & alive & lane_mask(&keep);
            if m != 0 {
                cur = Entry { mask: m, ..e };
                continue 'outer;
            }
        }
    }
    (done, found.best, found.b1, found.b2)
}

/// [`traverse()`] for a packet whose live lanes form one frustum
/// ([`PreparedPacket::frustum`]): the tree is walked once, as by a single ray, with
/// the frustum's box test ([`BoxTest::boxes_frustum`]) in place of the
/// per-lane one; the lanes are tested only against the boxes of the
/// leaves it meets and against the triangles (Embree's coherent traversal
/// tests every child the frustum meets lane by lane).
///
/// The frustum meets every box any lane's own slab test meets, and its
/// entry distance is below every lane's, so each lane tests every triangle
/// its own traversal would and finds the same closest hit (a lane's
/// distance to a triangle does not depend on the route); only a tie
/// between two triangles at the same distance may go the other way, as
/// between single rays and packets.
///
/// Why: a per-lane visit of an 8-wide node costs a box test per child and
/// register of lanes (about 350 AVX2 instructions for packets of 8), while
/// the frustum test is one register per plane for all eight children;
/// on pinhole tiles and MTM bundles it meets few boxes the lanes miss
/// (on the mesh's MTM bundles of 8, 0.5% of the inner nodes and 4% of the
/// leaves it meets).
#[inline(always)]
#[allow(clippy::type_complexity)]
fn traverse_frustum<B: BoxTest, const N: usize, const ANY: bool>(
    view: &BvhView<'_>,
    l: &mut PreparedPacket<N>,
    f: &BoxFrustum,
    live: u32,
) -> (u32, [u32; N], [f32; N], [f32; N]) {
    let mut found = Found::new();
    let mut done = 0u32;
    let mut alive = live;
    let mut t_far = far_of(&l.t_max, alive);
    let mut stack = Stack::<traverse::Entry>::new();
    let mut cur = traverse::Entry {
        child: 0,
        count: 0,
        t: 0.0,
    };
    'outer: loop {
        if cur.count == 0 {
            let node = &view.nodes[cur.child as usize];
            let h = B::boxes_frustum(node, f, t_far);
            // Leaves the frustum meets but no lane does are dropped: on
            // geometry finer than the lanes' spacing (veach-mis' lamps) the
            // frustum meets twice the leaves the lanes do, and a lane test
            // of one box costs less than its triangles. The others' blocks
            // are prefetched at once, so their misses overlap: on the
            // 260k-triangle mesh, stalls on the first load of a block took
            // 8% of the time of packets of 8 on MTM bundles (perf
            // samples) when only deferred children were prefetched. Timed
            // against that, 1.12 on the mesh's
            // mtm8 in packets of 8 and 1.09 on its mtm16 in packets of
            // 16; prefetching the leaves before their lane tests (and so
            // also those no lane meets) cost veach-mis's packets of 16
            // 8–9%.
            let mut mask = h.mask;
            let mut leaves = mask & leaf_bits(node);
            while leaves != 0 {
                let c = leaves.trailing_zeros() as usize;
                leaves &= leaves - 1;
                if B::Lanes::child_lanes(&h.offsets, c, &l.inv, &l.t_max, alive) == 0 {
                    mask &= !(1 << c);
                } else {
                    traverse::prefetch(view, node.child[c], node.count[c]);
                }
            }
            let near = h.near;
            let entry = |c: usize| traverse::Entry {
                child: node.child[c],
                count: node.count[c],
                t: near[c],
            };
            let defer = |e: traverse::Entry| {
                // Leaves were prefetched above.
                if e.count == 0 {
                    traverse::prefetch(view, e.child, e.count);
                }
                stack.push(e);
            };
            let next = if ANY {
                descend_any(mask, &near, entry, defer)
            } else {
                descend(mask, &near, entry, defer)
            };
            if let Some(e) = next {
                cur = e;
                continue;
            }
        } else {
            let m = leaf::<B, N, ANY>(view, l, (cur.child, cur.count), alive, &mut found);
            if m != 0 {
                if ANY {
                    done |= m;
                    alive &= !m;
                    if alive == 0 {
                        break 'outer;
                    }
                }
                t_far = far_of(&l.t_max, alive);
            }
        }
        // Pop the next child some live lane may still hit in front of its
        // closest hit.
        loop {
            let Some(e) = stack.pop() else {
                break 'outer;
            };
            if e.t <= t_far * FAR_SCALE {
                cur = e;
                continue 'outer;
            }
        }
    }
    (done, found.best, found.b1, found.b2)
}

/// The slots of `node` that are leaves.
#[inline(always)]
fn leaf_bits(node: &Node) -> u32 {
    let mut m = 0;
    for (c, &n) in node.count.iter().enumerate() {
        m |= ((n != 0) as u32) << c;
    }
    m
}

/// The largest `t_max` of the `lanes`: the frustum's far end.
#[inline(always)]
fn far_of<const N: usize>(t_max: &[f32; N], lanes: u32) -> f32 {
    let mut v = [f32::NEG_INFINITY; N];
    for (i, (x, &t)) in v.iter_mut().zip(t_max).enumerate() {
        *x = if lanes >> i & 1 != 0 {
            t
        } else {
            f32::NEG_INFINITY
        };
    }
    max_lanes(v)
}

/// The closest hit so far per lane (triangle slot, `u32::MAX` for none,
/// and barycentrics; the distance is the lane's `t_max`), with scratch
/// space for the triangle test.
struct Found<const N: usize> {
    best: [u32; N],
    b1: [f32; N],
    b2: [f32; N],
    /// The test's outputs: `t`, `b1`, `b2` per lane.
    scratch: [[f32; N]; 3],
}

impl<const N: usize> Found<N> {
    #[inline(always)]
    fn new() -> Self {
        Found {
            best: [u32::MAX; N],
            b1: [0.0; N],
            b2: [0.0; N],
            scratch: [[0.0; N]; 3],
        }
    }
}

/// Tests the `lanes` against the leaf `(first, count)` and records closer
/// hits in `found` and `l.t_max`; returns the lanes that hit. With `ANY`
/// a lane stops at its first hit.
#[inline(always)]
fn leaf<B: BoxTest, const N: usize, const ANY: bool>(
    view: &BvhView<'_>,
    l: &mut PreparedPacket<N>,
    (first, count): (u32, u32),
    mut lanes: u32,
    found: &mut Found<N>,
) -> u32 {
    let (first, count) = (first as usize, count as usize);
    // The leaf's blocks (bounds-checked once): slot `first + j` is lane
    // `j % 4` of `blocks[j / 4]`.
    let blocks = &view.blocks[first / 4..(first + count).div_ceil(4)];
    let Found {
        best,
        b1,
        b2,
        scratch: [tt, tb1, tb2],
    } = found;
    let mut hit = 0;
    for j in 0..count {
        let out = TriLanesOut {
            t: &mut *tt,
            b1: &mut *tb1,
            b2: &mut *tb2,
        };
        let m = B::Lanes::tri_lanes(&l.wt, &blocks[j / 4].v, j % 4, &l.t_max, lanes, out);
        B::Lanes::apply_hits(
            m,
            (first + j) as u32,
            (&*tt, &*tb1, &*tb2),
            &mut l.t_max,
            best,
            b1,
            b2,
        );
        hit |= m;
        if ANY && m != 0 {
            lanes &= !m;
            if lanes == 0 {
                break;
            }
        }
    }
    hit
}

/// Records the hits `m` on triangle slot `idx` with their `t`,
/// `b1`, `b2`: the closest hit so far of those lanes.
#[inline(always)]
pub(super) fn apply_hits<const N: usize>(
    m: u32,
    idx: u32,
    (t, tb1, tb2): (&[f32; N], &[f32; N], &[f32; N]),
    t_max: &mut [f32; N],
    best: &mut [u32; N],
    b1: &mut [f32; N],
    b2: &mut [f32; N],
) {
    if m == 0 {
        return;
    }
    // Branch-free selects, one loop per array, so the update is compiled
    // to blends and whole-register stores. One loop over all four arrays
    // was compiled lane by lane, a store per lane and array: for 16 lanes
    // 5.1% of the samples on the mesh's MTM bundles (AVX-512), against
    // 3.4% for the split loops. For 8 lanes the lane stores likely also
    // defeat store forwarding, as the next triangle test loads `t_max` as
    // one register right after them (not observable without hardware
    // counters): callgrind counts 0.8% more instructions
    // for the split loops, yet timed in alternating runs against Embree's
    // packets of 8 the split loops gave 1.04–1.10
    // on the mesh's and 1.00–1.10 on veach-mis's primary rays and bundles.
    // Fewer lanes keep the single loop (one register or less).
    if N >= 8 {
        let mut hit = [false; N];
        for (i, h) in hit.iter_mut().enumerate() {
            *h = m >> i & 1 != 0;
        }
        for ((d, &s), &h) in t_max.iter_mut().zip(t).zip(&hit) {
            *d = if h { s } else { *d };
        }
        for (d, &h) in best.iter_mut().zip(&hit) {
            *d = if h { idx } else { *d };
        }
        for ((d, &s), &h) in b1.iter_mut().zip(tb1).zip(&hit) {
            *d = if h { s } else { *d };
        }
        for ((d, &s), &h) in b2.iter_mut().zip(tb2).zip(&hit) {
            *d = if h { s } else { *d };
        }
        return;
    }
    for i in 0..N {
        let h = m >> i & 1 != 0;
        t_max[i] = if h { t[i] } else { t_max[i] };
        best[i] = if h { idx } else { best[i] };
        b1[i] = if h { tb1[i] } else { b1[i] };
        b2[i] = if h { tb2[i] } else { b2[i] };
    }
}

/// Closest hits of the active lanes; inactive lanes of `hits` untouched.
#[inline(always)]
fn intersect_packet_with<B: BoxTest, const N: usize>(
    view: &BvhView<'_>,
    rays: &RayPacket<N>,
    active: LaneMask,
    hits: &mut HitPacket<N>,
) {
    if N > 32 {
        for i in active.iter().filter(|&i| i < N) {
            hits.set(i, traverse::intersect_with::<B>(view, &rays.get(i)));
        }
        return;
    }
    if view.nodes.is_empty() {
        for i in active.iter().filter(|&i| i < N) {
            hits.set(i, None);
        }
        return;
    }
    let mut l = PreparedPacket::dummies();
    let valid = l.set::<B>(rays, active);
    // One live ray: the single-ray kernel is cheaper and gives the same
    // answer bit for bit.
    if valid.count_ones() <= 1 {
        for i in active.iter().filter(|&i| i < N) {
            let h = if valid >> i & 1 != 0 {
                traverse::intersect_with::<B>(view, &rays.get(i))
            } else {
                None
            };
            hits.set(i, h);
        }
        return;
    }
    let (_, best, b1, b2) = traverse::<B, N, false>(view, &mut l, valid);
    for i in active.iter().filter(|&i| i < N) {
        let h = (best[i] != u32::MAX).then(|| Hit {
            t: l.t_max[i],
            prim: slot_id(view.blocks, best[i] as usize),
            b1: b1[i],
            b2: b2[i],
        });
        hits.set(i, h);
    }
}

/// Occlusion of the active lanes; bit `i` set = lane `i` occluded.
#[inline(always)]
fn occluded_packet_with<B: BoxTest, const N: usize>(
    view: &BvhView<'_>,
    rays: &RayPacket<N>,
    active: LaneMask,
) -> LaneMask {
    let mut out = LaneMask::NONE;
    if N > 32 {
        for i in active.iter().filter(|&i| i < N) {
            if traverse::occluded_with::<B>(view, &rays.get(i)) {
                out.set(i);
            }
        }
        return out;
    }
    if view.nodes.is_empty() {
        return out;
    }
    let mut l = PreparedPacket::dummies();
    let valid = l.set::<B>(rays, active);
    if valid.count_ones() <= 1 {
        for i in LaneMask(valid).iter() {
            if traverse::occluded_with::<B>(view, &rays.get(i)) {
                out.set(i);
            }
        }
        return out;
    }
    let (done, ..) = traverse::<B, N, true>(view, &mut l, valid);
    LaneMask(done)
}

/// The packet traversal compiled for AVX2 (8-lane loops in 256-bit
/// registers) and AVX-512F (16 lanes in 512 bits).
#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;

    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn intersect_avx2<const N: usize>(
        view: &BvhView<'_>,
        rays: &RayPacket<N>,
        active: LaneMask,
        hits: &mut HitPacket<N>,
    ) {
        intersect_packet_with::<Avx2Box, N>(view, rays, active, hits)
    }

    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn occluded_avx2<const N: usize>(
        view: &BvhView<'_>,
        rays: &RayPacket<N>,
        active: LaneMask,
    ) -> LaneMask {
        occluded_packet_with::<Avx2Box, N>(view, rays, active)
    }

    /// # Safety
    /// The CPU must support AVX2 and AVX-512F.
    #[target_feature(enable = "avx2,avx512f")]
    pub unsafe fn intersect_avx512<const N: usize>(
        view: &BvhView<'_>,
        rays: &RayPacket<N>,
        active: LaneMask,
        hits: &mut HitPacket<N>,
    ) {
        intersect_packet_with::<Avx512Box, N>(view, rays, active, hits)
    }

    /// # Safety
    /// The CPU must support AVX2 and AVX-512F.
    #[target_feature(enable = "avx2,avx512f")]
    pub unsafe fn occluded_avx512<const N: usize>(
        view: &BvhView<'_>,
        rays: &RayPacket<N>,
        active: LaneMask,
    ) -> LaneMask {
        occluded_packet_with::<Avx512Box, N>(view, rays, active)
    }
}

/// Closest hits of the active lanes with the view's kernel.
fn intersect_packet_kernel<const N: usize>(
    view: &BvhView<'_>,
    rays: &RayPacket<N>,
    active: LaneMask,
    hits: &mut HitPacket<N>,
) {
    match view.kernel {
        #[cfg(target_arch = "x86_64")]
        Kernel::Sse2 => intersect_packet_with::<Sse2Box, N>(view, rays, active, hits),
        // SAFETY: a view only holds an available kernel (`with_kernel`).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { x86::intersect_avx2(view, rays, active, hits) },
        // SAFETY: as above.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 if N > 8 => unsafe { x86::intersect_avx512(view, rays, active, hits) },
        // Packets of up to 8 lanes fit AVX2's registers, and measured
        // faster there (see `kernel`'s module docs).
        // SAFETY: an AVX-512 kernel is only available with AVX2.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { x86::intersect_avx2(view, rays, active, hits) },
        _ => intersect_packet_with::<ScalarBox, N>(view, rays, active, hits),
    }
}

/// Occlusion of the active lanes with the view's kernel.
fn occluded_packet_kernel<const N: usize>(
    view: &BvhView<'_>,
    rays: &RayPacket<N>,
    active: LaneMask,
) -> LaneMask {
    match view.kernel {
        #[cfg(target_arch = "x86_64")]
        Kernel::Sse2 => occluded_packet_with::<Sse2Box, N>(view, rays, active),
        // SAFETY: a view only holds an available kernel (`with_kernel`).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { x86::occluded_avx2(view, rays, active) },
        // SAFETY: as above.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 if N > 8 => unsafe { x86::occluded_avx512(view, rays, active) },
        // SAFETY: an AVX-512 kernel is only available with AVX2.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { x86::occluded_avx2(view, rays, active) },
        _ => occluded_packet_with::<ScalarBox, N>(view, rays, active),
    }
}

/// Compiles the traversal once, in this crate, for the packet widths the
/// core traces (`$n`), and defines [`intersect_packet`] and
/// [`occluded_packet`] to send those widths there.
///
/// Why: the traversal is generic over the width, and Rust compiles a
/// generic function again in every crate that instantiates it (the
/// kernels are about 0.9 MB of machine code per crate at opt-level 3: the
/// frustum and per-lane forms for the scalar, SSE2, AVX2 and AVX-512
/// boxes, inlined into each width). Here each width is one non-generic
/// function, so other crates call it. `Any` picks the width without
/// `unsafe`; the type comparison folds to a constant. Other widths trace
/// lane by lane (the trait's default, same answers): a generic fallback
/// into the kernels would be instantiated, and fully optimised by LLVM
/// before the fold removes it, in every crate that traces packets.
macro_rules! widths_compiled_here {
    ($($n:literal: $intersect:ident, $occluded:ident;)*) => {
        $(
            #[inline(never)]
            fn $intersect(
                view: &BvhView<'_>,
                rays: &RayPacket<$n>,
                active: LaneMask,
                hits: &mut HitPacket<$n>,
            ) {
                intersect_packet_kernel(view, rays, active, hits)
            }

            #[inline(never)]
            fn $occluded(view: &BvhView<'_>, rays: &RayPacket<$n>, active: LaneMask) -> LaneMask {
                occluded_packet_kernel(view, rays, active)
            }
        )*

        /// Closest hits of the active lanes with the view's kernel.
        #[inline]
        pub(super) fn intersect_packet<const N: usize>(
            view: &BvhView<'_>,
            rays: &RayPacket<N>,
            active: LaneMask,
            hits: &mut HitPacket<N>,
        ) {
            let any_rays: &dyn Any = rays;
            let any_hits: &mut dyn Any = &mut *hits;
            $(
                if let (Some(r), Some(h)) = (
                    any_rays.downcast_ref::<RayPacket<$n>>(),
                    any_hits.downcast_mut::<HitPacket<$n>>(),
                ) {
                    return $intersect(view, r, active, h);
                }
            )*
            intersect_lanes(view, rays, active, hits)
        }

        /// Occlusion of the active lanes with the view's kernel.
        #[inline]
        pub(super) fn occluded_packet<const N: usize>(
            view: &BvhView<'_>,
            rays: &RayPacket<N>,
            active: LaneMask,
        ) -> LaneMask {
            let any_rays: &dyn Any = rays;
            $(
                if let Some(r) = any_rays.downcast_ref::<RayPacket<$n>>() {
                    return $occluded(view, r, active);
                }
            )*
            occluded_lanes(view, rays, active)
        }
    };
}

// The widths of the renderer's bundles (`mlt::perturbation::retrace`,
// `integrator::tracer`, `aov`): 1, 4, 8 and 16 lanes.
widths_compiled_here! {
    1: intersect_1, occluded_1;
    4: intersect_4, occluded_4;
    8: intersect_8, occluded_8;
    16: intersect_16, occluded_16;
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::geometry::Ray;
    use glam::Vec3;

    /// A packet of 8 rays from `o` towards `dirs`.
    fn packet(o: [Vec3; 8], dirs: [Vec3; 8]) -> RayPacket<8> {
        let mut p = RayPacket::default();
        for i in 0..8 {
            p.set(i, &Ray::new(o[i], dirs[i]));
        }
        p
    }

    /// Directions around `d`, `step` apart.
    fn fan(d: Vec3, step: f32) -> [Vec3; 8] {
        core::array::from_fn(|i| {
            let (u, v) = ((i % 4) as f32 - 1.5, (i / 4) as f32 - 0.5);
            (d + Vec3::new(u * step, v * step, 0.0)).normalize()
        })
    }

    fn frustum(p: &RayPacket<8>, active: u32) -> Option<BoxFrustum> {
        let mut l = PreparedPacket::<8>::dummies();
        l.set::<ScalarBox>(p, LaneMask(active));
        l.frustum
    }

    /// Which packets are traversed as a frustum: a pinhole tile or MTM
    /// bundle (one origin, directions close together) is; a bundle wider
    /// than `FRUSTUM_SPREAD`, two origins, mixed signs or a zero direction
    /// component is not. Inactive lanes do not count.
    #[test]
    fn frustum_packets_are_chosen_by_origin_and_spread() {
        let o = [Vec3::new(0.1, 0.2, -3.0); 8];
        let d = Vec3::new(0.3, 0.2, 1.0);
        let tile = packet(o, fan(d, 0.002));
        let f = frustum(&tile, 0xff).expect("a pinhole tile is a frustum");
        assert_eq!(f.o, [0.1, 0.2, -3.0]);
        for a in 0..3 {
            assert!(f.inv_lo[a] < f.inv_hi[a] || a == 2);
        }
        assert!(frustum(&packet(o, fan(d, 0.2)), 0xff).is_none(), "too wide");
        let mut two = o;
        two[5].x += 1e-3;
        assert!(
            frustum(&packet(two, fan(d, 0.002)), 0xff).is_none(),
            "two origins"
        );
        // Lane 5 alone has another origin: left out, the others are one.
        assert!(frustum(&packet(two, fan(d, 0.002)), 0xdf).is_some());
        let mut mixed = fan(d, 0.002);
        mixed[3].x = -mixed[3].x;
        assert!(frustum(&packet(o, mixed), 0xff).is_none(), "mixed signs");
        let flat = fan(Vec3::new(0.0, 0.2, 1.0), 0.0);
        assert!(frustum(&packet(o, flat), 0xff).is_none(), "zero component");
        assert!(frustum(&tile, 0x10).is_none(), "one live lane");
    }
}
