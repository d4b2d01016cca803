//! Traversal kernels: which instruction set the box tests and lane loops
//! use, chosen per [`super::BvhView`] with [`Kernel`].
//!
//! Every kernel evaluates the same IEEE operations in the same order (the
//! robust slab test of `node::boxes`; SSE `maxps(x, acc)` / `minps(x, acc)`
//! return `acc` for a NaN `x`, exactly like `max_keep` / `min_keep`), and no
//! kernel contracts products into FMAs, so all kernels return bit-identical
//! hits. The scalar kernel exists on every target and can be forced (for
//! Miri, or to compare).
//!
//! - `Scalar`: portable code over `[f32; WIDTH]`.
//! - `Sse2`: a node's child boxes four per SSE register and plane, 4
//!   triangles of a leaf per SSE step, packets 4 lanes per register
//!   (x86_64 baseline, always available there).
//! - `Avx2`: a node's eight child boxes in one 256-bit register per plane;
//!   packets 8 lanes per 256-bit register; the traversal compiled with
//!   AVX2 enabled.
//! - `Avx512`: packets of 16 lanes per 512-bit register; single rays and
//!   packets of up to 8 lanes run the `Avx2` code. Nothing in a node's
//!   test needs 512 bits: the same single-ray traversal compiled for
//!   AVX-512F measured 5–7% slower with 4-wide nodes, and packets of 8 in
//!   the traversal compiled for AVX-512F (two children or triangles per
//!   512-bit register on their per-lane path) traced veach-mis' primary
//!   rays at 20 Mrays/s and the mesh's MTM bundles at 8.7 where the AVX2
//!   code does 32 and 11.7, once coherent packets took the frustum
//!   traversal (single runs; why was not found).
//!
//! Each instruction set's file holds its [`lane_vec::LaneVec`] register
//! and its box test: `sse2.rs` (also the single-ray leaf test, four
//! triangles per step), `avx2.rs`, `avx512.rs`; the code written once
//! over `LaneVec` is in `boxes.rs` (box tests) and `triangle.rs` (the
//! packet's triangle test).
//!
//! Packet kernels run `boxes.rs` and `triangle.rs`
//! over `LaneVec` registers of the kernel's width,
//! through each kernel's [`BoxTest::Lanes`]: a chain of [`RegLanes`] from
//! its widest register down to [`PortableLanes`], so a packet narrower
//! than the registers runs the next narrower kernel's code.
//!
//! Selection: [`Kernel::best`] picks the widest kernel the CPU supports —
//! detected at run time under `std`, from the build's `target-feature`s
//! otherwise.

use super::leaf::{TriBlock, slot_tri};
use super::node::{
    BoxFrustum, BoxRay, FrustumHits, Node, WIDTH, boxes, boxes_frustum, child_lanes,
};
use super::packet::{BoxLanes, LanesOut, apply_hits, boxes_lanes_portable, prepare_lanes_portable};
use crate::geometry::RayPacket;
use crate::geometry::triangle::WatertightRay;
use crate::geometry::triangle::{Planes4, WatertightLanes, intersect_lanes, planes_tri};
#[cfg(target_arch = "x86_64")]
use boxes::{apply_hits_simd, boxes_lanes_simd, child_lanes_simd, prepare_lanes_simd};
#[cfg(target_arch = "x86_64")]
use lane_vec::LaneVec;
#[cfg(target_arch = "x86_64")]
use triangle::intersect_lanes_simd;

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
#[cfg(target_arch = "x86_64")]
mod boxes;
#[cfg(target_arch = "x86_64")]
pub(crate) mod lane_vec;
#[cfg(target_arch = "x86_64")]
mod sse2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod triangle;

#[cfg(target_arch = "x86_64")]
pub(super) use avx2::Avx2Box;
#[cfg(target_arch = "x86_64")]
pub(super) use avx512::Avx512Box;
#[cfg(target_arch = "x86_64")]
pub(super) use sse2::Sse2Box;

/// Where [`LaneTests::tri_lanes`] writes each hit lane's `t`, `b1`, `b2`
/// (other lanes' entries are left unspecified).
pub(super) struct TriLanesOut<'a, const N: usize> {
    /// Hit distance per lane.
    pub t: &'a mut [f32; N],
    /// Barycentric of vertex 1 per lane.
    pub b1: &'a mut [f32; N],
    /// Barycentric of vertex 2 per lane.
    pub b2: &'a mut [f32; N],
}

/// A traversal kernel (instruction set of the box tests and lane loops).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Portable scalar code; available everywhere.
    Scalar,
    /// SSE2 box tests (x86_64).
    Sse2,
    /// Traversal compiled for AVX2; packets 8 lanes per register (x86_64).
    Avx2,
    /// Packets 16 lanes per AVX-512F register; single rays as `Avx2`
    /// (x86_64).
    Avx512,
}

impl Kernel {
    /// Every kernel, narrowest first.
    pub const ALL: [Kernel; 4] = [Kernel::Scalar, Kernel::Sse2, Kernel::Avx2, Kernel::Avx512];

    /// Short lower-case name (`scalar`, `sse2`, `avx2`, `avx512`).
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Scalar => "scalar",
            Kernel::Sse2 => "sse2",
            Kernel::Avx2 => "avx2",
            Kernel::Avx512 => "avx512",
        }
    }

    /// Whether this CPU (under `std`) or this build (without `std`) can run
    /// the kernel.
    pub fn is_available(self) -> bool {
        match self {
            Kernel::Scalar => true,
            #[cfg(target_arch = "x86_64")]
            Kernel::Sse2 => true,
            #[cfg(all(target_arch = "x86_64", feature = "std"))]
            Kernel::Avx2 => std::is_x86_feature_detected!("avx2"),
            #[cfg(all(target_arch = "x86_64", not(feature = "std")))]
            Kernel::Avx2 => cfg!(target_feature = "avx2"),
            #[cfg(all(target_arch = "x86_64", feature = "std"))]
            Kernel::Avx512 => {
                std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("avx512f")
            }
            #[cfg(all(target_arch = "x86_64", not(feature = "std")))]
            Kernel::Avx512 => cfg!(all(target_feature = "avx2", target_feature = "avx512f")),
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The widest available kernel.
    pub fn best() -> Kernel {
        Kernel::ALL
            .into_iter()
            .rev()
            .find(|k| k.is_available())
            .unwrap_or(Kernel::Scalar)
    }
}

/// One robust slab test of a ray against a node's children: the hit mask
/// and entry distances, as `node::boxes`.
///
/// Also the single-ray leaf test: the closest hit among a leaf's triangles
/// (the first hit for `ANY`), as `WatertightRay::intersect_many`.
pub(super) trait BoxTest {
    /// Whether leaves are tested four triangles per SSE step
    /// (`sse2::intersect_many`, x86_64 only) rather than one by
    /// one; both give the same answer bit for bit.
    #[cfg(target_arch = "x86_64")]
    const SSE_LEAF: bool = false;

    /// The packet lane tests: in registers of this kernel's width when a
    /// packet fills them, else those of the next narrower kernel.
    type Lanes: LaneTests;

    fn boxes(node: &Node, r: &BoxRay, t_max: f32) -> (u32, [f32; WIDTH]);

    /// The frustum test (`node::boxes_frustum`) of a packet whose rays
    /// share their origin: a node's children against all rays at once.
    #[inline(always)]
    fn boxes_frustum(node: &Node, f: &BoxFrustum, t_far: f32) -> FrustumHits {
        boxes_frustum(node, f, t_far)
    }

    /// The leaf test [`Self::SSE_LEAF`] selects (a compile-time choice),
    /// over the `count` triangles that start the leaf's `blocks`: the
    /// index (`0..count`), `t`, `b1`, `b2` of the closest hit.
    #[inline(always)]
    fn leaf<const ANY: bool>(
        r: &WatertightRay,
        blocks: &[TriBlock],
        count: usize,
        t_max: f32,
    ) -> Option<(usize, f32, f32, f32)> {
        #[cfg(target_arch = "x86_64")]
        if Self::SSE_LEAF {
            return sse2::intersect_many::<ANY>(r, blocks.iter().map(|b| &b.v), count, t_max);
        }
        r.intersect_many::<ANY>(count, |j| slot_tri(blocks, j), t_max)
    }
}

/// The packet tests of a kernel, one lane per ray: the set-up
/// (`packet::prepare_lanes_portable`), the per-lane box test of a node
/// (`packet::boxes_lanes`), the per-lane test of one child after the
/// frustum test (`node::child_lanes`) and the triangle test
/// (`triangle::intersect_lanes`). Every implementation gives the portable
/// loops' bits.
pub(super) trait LaneTests {
    /// The box-test set-up of a packet: writes the lanes' origins,
    /// reciprocal directions and `t_max` (dummies with an empty interval in
    /// lanes outside `valid`) and returns, per axis, the `valid` lanes whose
    /// reciprocal direction has its sign bit set.
    fn prepare_lanes<const N: usize>(
        rays: &RayPacket<N>,
        valid: u32,
        out: LanesOut<'_, N>,
    ) -> [u32; 3];

    /// The `lanes` whose rays meet child `c`, from the frustum test's
    /// plane offsets.
    fn child_lanes<const N: usize>(
        offsets: &[[f32; WIDTH]; 6],
        c: usize,
        inv: &[[f32; N]; 3],
        t_max: &[f32; N],
        lanes: u32,
    ) -> u32;

    /// `N` lanes against a node's children: per child the lanes that hit
    /// it, and its smallest entry distance.
    fn boxes_lanes<const N: usize>(
        node: &Node,
        l: &BoxLanes<'_, N>,
        lanes: u32,
    ) -> ([u32; WIDTH], [f32; WIDTH]);

    /// Triangle `slot` of a leaf block's `planes` against `N` lanes: the
    /// lanes that hit it in front of their `t_max`, with `t`, `b1`, `b2` in
    /// `out`.
    fn tri_lanes<const N: usize>(
        r: &WatertightLanes<N>,
        planes: &Planes4,
        slot: usize,
        t_max: &[f32; N],
        lanes: u32,
        out: TriLanesOut<'_, N>,
    ) -> u32;

    /// Records the hits `m` of the lanes on triangle slot `idx`, with the
    /// test's `t`, `b1`, `b2` in `found`: the closest hit so far of those
    /// lanes (`packet::apply_hits`).
    fn apply_hits<const N: usize>(
        m: u32,
        idx: u32,
        found: (&[f32; N], &[f32; N], &[f32; N]),
        t_max: &mut [f32; N],
        best: &mut [u32; N],
        b1: &mut [f32; N],
        b2: &mut [f32; N],
    );
}

/// The portable lane loops over `[f32; N]`: the scalar kernel's, and
/// every kernel's last resort for packets narrower than its registers.
pub(super) struct PortableLanes;

impl LaneTests for PortableLanes {
    #[inline(always)]
    fn prepare_lanes<const N: usize>(
        rays: &RayPacket<N>,
        valid: u32,
        out: LanesOut<'_, N>,
    ) -> [u32; 3] {
        prepare_lanes_portable(rays, valid, out)
    }

    #[inline(always)]
    fn child_lanes<const N: usize>(
        offsets: &[[f32; WIDTH]; 6],
        c: usize,
        inv: &[[f32; N]; 3],
        t_max: &[f32; N],
        lanes: u32,
    ) -> u32 {
        child_lanes(offsets, c, inv, t_max, lanes)
    }

    #[inline(always)]
    fn boxes_lanes<const N: usize>(
        node: &Node,
        l: &BoxLanes<'_, N>,
        lanes: u32,
    ) -> ([u32; WIDTH], [f32; WIDTH]) {
        boxes_lanes_portable(node, l, lanes)
    }

    #[inline(always)]
    fn tri_lanes<const N: usize>(
        r: &WatertightLanes<N>,
        planes: &Planes4,
        slot: usize,
        t_max: &[f32; N],
        lanes: u32,
        out: TriLanesOut<'_, N>,
    ) -> u32 {
        let tri = planes_tri(planes, slot);
        intersect_lanes(r, &tri, t_max, lanes, out.t, out.b1, out.b2)
    }

    #[inline(always)]
    fn apply_hits<const N: usize>(
        m: u32,
        idx: u32,
        found: (&[f32; N], &[f32; N], &[f32; N]),
        t_max: &mut [f32; N],
        best: &mut [u32; N],
        b1: &mut [f32; N],
        b2: &mut [f32; N],
    ) {
        apply_hits(m, idx, found, t_max, best, b1, b2)
    }
}

/// The lane tests in registers `V` (`V::W` lanes each) when `N` is a
/// multiple of `V::W`, else `Narrower`'s: AVX-512 runs packets of 8 in
/// AVX registers and packets of 4 in SSE ones. `N` is a constant, so the
/// choice is made at compile time.
#[cfg(target_arch = "x86_64")]
pub(super) struct RegLanes<V, Narrower>(core::marker::PhantomData<(V, Narrower)>);

#[cfg(target_arch = "x86_64")]
impl<V: LaneVec, Narrower: LaneTests> LaneTests for RegLanes<V, Narrower> {
    #[inline(always)]
    fn prepare_lanes<const N: usize>(
        rays: &RayPacket<N>,
        valid: u32,
        out: LanesOut<'_, N>,
    ) -> [u32; 3] {
        if N.is_multiple_of(V::W) {
            prepare_lanes_simd::<V, N>(rays, valid, out)
        } else {
            Narrower::prepare_lanes(rays, valid, out)
        }
    }

    #[inline(always)]
    fn child_lanes<const N: usize>(
        offsets: &[[f32; WIDTH]; 6],
        c: usize,
        inv: &[[f32; N]; 3],
        t_max: &[f32; N],
        lanes: u32,
    ) -> u32 {
        if N.is_multiple_of(V::W) {
            child_lanes_simd::<V, N>(offsets, c, inv, t_max, lanes)
        } else {
            Narrower::child_lanes(offsets, c, inv, t_max, lanes)
        }
    }

    #[inline(always)]
    fn boxes_lanes<const N: usize>(
        node: &Node,
        l: &BoxLanes<'_, N>,
        lanes: u32,
    ) -> ([u32; WIDTH], [f32; WIDTH]) {
        if N.is_multiple_of(V::W) {
            boxes_lanes_simd::<V, N>(node, l, lanes)
        } else {
            Narrower::boxes_lanes(node, l, lanes)
        }
    }

    #[inline(always)]
    fn tri_lanes<const N: usize>(
        r: &WatertightLanes<N>,
        planes: &Planes4,
        slot: usize,
        t_max: &[f32; N],
        lanes: u32,
        out: TriLanesOut<'_, N>,
    ) -> u32 {
        if N.is_multiple_of(V::W) {
            intersect_lanes_simd::<V, N>(r, planes, slot, t_max, lanes, out.t, out.b1, out.b2)
        } else {
            Narrower::tri_lanes(r, planes, slot, t_max, lanes, out)
        }
    }

    #[inline(always)]
    fn apply_hits<const N: usize>(
        m: u32,
        idx: u32,
        found: (&[f32; N], &[f32; N], &[f32; N]),
        t_max: &mut [f32; N],
        best: &mut [u32; N],
        b1: &mut [f32; N],
        b2: &mut [f32; N],
    ) {
        // AVX-512 only: with narrower registers LLVM turns the select
        // stored back in place into a masked store (`vmaskmovps`), which
        // AMD's cores run microcoded; their portable loops compile to
        // blends and whole-register stores (packets of 8).
        if N.is_multiple_of(V::W) && V::W >= 16 {
            apply_hits_simd::<V, N>(m, idx, found, t_max, best, b1, b2)
        } else {
            Narrower::apply_hits(m, idx, found, t_max, best, b1, b2)
        }
    }
}

/// The portable box test.
pub(super) struct ScalarBox;

impl BoxTest for ScalarBox {
    type Lanes = PortableLanes;

    #[inline(always)]
    fn boxes(node: &Node, r: &BoxRay, t_max: f32) -> (u32, [f32; WIDTH]) {
        boxes(node, r, t_max)
    }
}
