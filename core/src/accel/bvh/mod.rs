//! The default BVH: an 8-wide tree in a layout owned by this crate,
//! traversed by our own `no_std`, allocation-free code.
//!
//! - [`Node`]: [`WIDTH`] child boxes in SoA form plus child references
//!   (inner node / leaf range / empty).
//! - [`TriBlock`]: leaf triangles in blocks of four, transposed for the
//!   SIMD leaf test, with their scene-global ids.
//! - [`BvhView`]: traversal over borrowed slices — nodes and triangle
//!   blocks. A `no_std` host can build or map that memory itself and hand
//!   it over.
//! - [`Bvh`] (feature `alloc`): the owned form; [`Bvh::build`] (feature
//!   `std`) builds two binary BVHs (obvhs' PLOC with reinsertion, and our
//!   binned SAH builder), collapses each into the wide layout with the
//!   SAH-optimal collapse, and keeps the cheaper.
//!
//! Both implement [`Intersector`]: closest hit visits children front to
//! back; occlusion stops at the first hit; packets of 4/8/16 rays share one
//! traversal stack (a node is visited when any live lane hits its box), and
//! a subtree reached by a single lane is finished ray by ray with
//! the same arithmetic, so packet and single-ray answers are bit-identical.
//! Streams of independent rays ([`Intersector::intersect_stream`]) keep
//! several single-ray walks in flight, taking turns one step each, so that
//! their memory loads overlap on trees larger than the caches
//! ([`INTERLEAVE_MIN_BYTES`]); each answer is again bit-identical.
//! Traversal kernels ([`Kernel`]: scalar, SSE2, AVX2, AVX-512) differ only
//! in instruction set and return bit-identical answers; a view uses
//! [`Kernel::best`] unless told otherwise ([`BvhView::with_kernel`]), and the
//! scalar kernel can always be forced.
//! Box tests are the robust slab test of Ize 2013 and triangle tests the
//! watertight test of Woop et al. 2013, so a ray through a closed mesh never
//! leaks through an edge or a vertex, at any scale.
//!
//! ```
//! use cmlt::accel::{Intersector, bvh::Bvh};
//! use cmlt::geometry::Ray;
//! use cmlt::math::Vec3;
//!
//! // Triangles in scene-global order: `tris[i]` is reported as `prim == i`.
//! let tris = [[Vec3::ZERO, Vec3::X, Vec3::Y], [Vec3::Z, Vec3::X + Vec3::Z, Vec3::Y + Vec3::Z]];
//! let bvh = Bvh::build(&tris);
//! let hit = bvh.intersect(&Ray::new(Vec3::new(0.2, 0.2, 2.0), -Vec3::Z)).unwrap();
//! assert_eq!((hit.prim, hit.t), (1, 1.0));
//! assert!(bvh.view().occluded(&Ray { t_max: 0.6, ..Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::Z * 2.0) }));
//! ```

pub(crate) mod kernel;
mod leaf;
mod node;
mod packet;
mod stream;
mod traverse;

#[cfg(feature = "std")]
mod build;

pub use kernel::Kernel;
pub use leaf::TriBlock;
pub use node::{EMPTY_CHILD, FAR_SCALE, MAX_DEPTH, Node, STACK_SIZE, WIDTH};
pub use stream::INTERLEAVE_MIN_BYTES;

use glam::Vec3;

use super::Intersector;
use crate::geometry::{Hit, HitPacket, LaneMask, Ray, RayPacket};

#[cfg(feature = "alloc")]
use alloc::vec::Vec;

/// Why a set of slices is not a valid BVH layout (see [`BvhView::new`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayoutError {
    /// `tris` and `prim_ids` differ in length ([`Bvh::from_parts`]), or a
    /// slice is too long to be indexed by `u32` (blocks: by `u32` slots).
    Lengths,
    /// A primitive id equals [`HitPacket::MISS`], which is reserved.
    ReservedPrimId {
        /// Position in `prim_ids`, or slot (`4 · block + lane`) in the
        /// blocks.
        index: usize,
    },
    /// A child slot is inconsistent: an inner child that does not come
    /// after its parent or is out of range, a leaf range beyond the
    /// triangles (or, in blocks, not starting at a block boundary), or an
    /// empty slot whose bounds are not inverted.
    BadChild {
        /// Node index.
        node: usize,
        /// Slot within the node.
        slot: usize,
    },
    /// The tree is deeper than [`MAX_DEPTH`] levels.
    TooDeep,
}

impl core::fmt::Display for LayoutError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LayoutError::Lengths => write!(f, "BVH layout: mismatched or oversized slices"),
            LayoutError::ReservedPrimId { index } => write!(
                f,
                "BVH layout: the primitive id at position {index} is the reserved miss value"
            ),
            LayoutError::BadChild { node, slot } => {
                write!(f, "BVH layout: invalid child slot {slot} of node {node}")
            }
            LayoutError::TooDeep => write!(f, "BVH layout: deeper than {MAX_DEPTH} levels"),
        }
    }
}

/// A BVH over borrowed memory: the traversal-side type.
///
/// - `nodes[0]` is the root (no nodes = empty scene, every ray misses);
/// - `blocks` holds the leaves' triangles, four slots per [`TriBlock`]: a
///   leaf slot of a node covers slots `child .. child + count`, where
///   `child` is a multiple of 4 (slot `s` is lane `s % 4` of block
///   `s / 4`); each slot's id is reported in [`Hit::prim`].
///
/// Child bounds must contain their triangles (else hits are missed; memory
/// safety never depends on it).
#[derive(Clone, Copy, Debug)]
pub struct BvhView<'a> {
    nodes: &'a [Node],
    blocks: &'a [TriBlock],
    depth: u32,
    /// Always an available kernel (checked by [`BvhView::with_kernel`]).
    kernel: Kernel,
    /// Streams are interleaved from this tree size up
    /// ([`BvhView::with_interleave_from`]).
    interleave_from: usize,
}

impl<'a> BvhView<'a> {
    /// Checks the layout (see [`Node`] for the encoding) and wraps it.
    ///
    /// Runs in time linear in the number of root-to-node paths (the node
    /// count for a tree) without allocating.
    pub fn new(nodes: &'a [Node], blocks: &'a [TriBlock]) -> Result<Self, LayoutError> {
        let slots = 4 * blocks.len() as u64;
        if slots >= u32::MAX as u64 || nodes.len() >= u32::MAX as usize {
            return Err(LayoutError::Lengths);
        }
        // Every lane, padding included: a padding lane repeats a real one.
        if let Some(index) = blocks
            .iter()
            .flat_map(|b| b.ids)
            .position(|p| p == HitPacket::<1>::MISS)
        {
            return Err(LayoutError::ReservedPrimId { index });
        }
        for (i, node) in nodes.iter().enumerate() {
            for c in 0..WIDTH {
                let ok = if node.is_empty(c) {
                    (0..3).all(|a| {
                        node.min[a][c] == f32::INFINITY && node.max[a][c] == f32::NEG_INFINITY
                    })
                } else if node.is_leaf(c) {
                    node.child[c] % 4 == 0 && node.child[c] as u64 + node.count[c] as u64 <= slots
                } else {
                    (node.child[c] as usize) > i && (node.child[c] as usize) < nodes.len()
                };
                if !ok {
                    return Err(LayoutError::BadChild { node: i, slot: c });
                }
            }
        }
        let depth = if nodes.is_empty() {
            0
        } else {
            layout_depth(nodes)?
        };
        Ok(BvhView {
            nodes,
            blocks,
            depth,
            kernel: Kernel::best(),
            interleave_from: INTERLEAVE_MIN_BYTES,
        })
    }

    /// The same BVH with streams ([`Intersector::intersect_stream`])
    /// interleaved when the tree takes at least `bytes`
    /// ([`BvhView::size_bytes`]), and traced ray by ray below: 0 always
    /// interleaves, `usize::MAX` never does. The default is
    /// [`INTERLEAVE_MIN_BYTES`], measured on one machine; a host that
    /// knows its caches may move it. Answers are the same either way.
    pub fn with_interleave_from(self, bytes: usize) -> Self {
        BvhView {
            interleave_from: bytes,
            ..self
        }
    }

    /// The same BVH traversed with `kernel`; `None` if this CPU (or, without
    /// `std`, this build) cannot run it. All kernels return bit-identical
    /// answers; [`Kernel::Scalar`] is always available.
    pub fn with_kernel(self, kernel: Kernel) -> Option<Self> {
        kernel.is_available().then_some(BvhView { kernel, ..self })
    }

    /// The traversal kernel in use ([`Kernel::best`] unless changed).
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// The nodes; `nodes()[0]` is the root.
    pub fn nodes(&self) -> &'a [Node] {
        self.nodes
    }

    /// The leaves' triangle blocks.
    pub fn blocks(&self) -> &'a [TriBlock] {
        self.blocks
    }

    /// The triangles in the leaves (padding lanes left out), with their
    /// scene-global ids, in slot order.
    pub fn triangles(&self) -> impl Iterator<Item = ([Vec3; 3], u32)> + 'a {
        let blocks = self.blocks;
        self.nodes.iter().flat_map(move |n| {
            (0..WIDTH).filter(|&c| n.is_leaf(c)).flat_map(move |c| {
                let first = n.child[c] as usize;
                (first..first + n.count[c] as usize)
                    .map(move |s| (leaf::slot_tri(blocks, s), leaf::slot_id(blocks, s)))
            })
        })
    }

    /// Bytes of nodes and leaf blocks the view's traversal reads.
    pub fn size_bytes(&self) -> usize {
        size_of_val(self.nodes) + size_of_val(self.blocks)
    }

    /// Levels of nodes (0 for an empty BVH, 1 for a lone root).
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// True when there is nothing to hit.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }
}

/// Depth of a structurally checked layout (children after parents, so the
/// walk terminates), or [`LayoutError::TooDeep`].
fn layout_depth(nodes: &[Node]) -> Result<u32, LayoutError> {
    // Depth-first; a popped node pushes at most WIDTH children, so with
    // the depth capped the stack never holds more than (WIDTH − 1) ·
    // MAX_DEPTH + 1.
    let mut stack = [(0u32, 0u32); STACK_SIZE + WIDTH];
    stack[0] = (0, 1);
    let mut sp = 1;
    let mut depth = 1;
    while sp > 0 {
        sp -= 1;
        let (n, level) = stack[sp];
        depth = depth.max(level);
        let node = &nodes[n as usize];
        for c in 0..WIDTH {
            if node.is_inner(c) {
                if level as usize >= MAX_DEPTH {
                    return Err(LayoutError::TooDeep);
                }
                stack[sp] = (node.child[c], level + 1);
                sp += 1;
            }
        }
    }
    Ok(depth)
}

impl Intersector for BvhView<'_> {
    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        traverse::intersect(self, ray)
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        traverse::occluded(self, ray)
    }

    #[inline]
    fn intersect_packet<const N: usize>(
        &self,
        rays: &RayPacket<N>,
        active: LaneMask,
        hits: &mut HitPacket<N>,
    ) {
        packet::intersect_packet(self, rays, active, hits)
    }

    #[inline]
    fn occluded_packet<const N: usize>(&self, rays: &RayPacket<N>, active: LaneMask) -> LaneMask {
        packet::occluded_packet(self, rays, active)
    }

    #[inline]
    fn intersect_stream(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        let n = rays.len().min(hits.len());
        stream::intersect(self, &rays[..n], &mut hits[..n])
    }

    #[inline]
    fn occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]) {
        let n = rays.len().min(occluded.len());
        stream::occluded(self, &rays[..n], &mut occluded[..n])
    }
}

/// An owned BVH: the storage behind a [`BvhView`].
#[cfg(feature = "alloc")]
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    blocks: Vec<TriBlock>,
    depth: u32,
    /// Always an available kernel (checked by [`Bvh::with_kernel`]).
    kernel: Kernel,
}

#[cfg(feature = "alloc")]
impl Default for Bvh {
    fn default() -> Self {
        Bvh {
            nodes: Vec::new(),
            blocks: Vec::new(),
            depth: 0,
            kernel: Kernel::best(),
        }
    }
}

#[cfg(feature = "alloc")]
impl Bvh {
    /// Builds a BVH over `tris`, given in scene-global order (`tris[i]` is
    /// reported as `prim == i`).
    ///
    /// Two binary BVHs are built down to single triangles: obvhs' PLOC
    /// (wide search window, then reinsertion optimisation) and a top-down
    /// binned SAH build. Each is collapsed into wide nodes by dynamic
    /// programming that chooses leaves (up to 4 triangles) and node
    /// contents of least SAH cost, and the layout of lower SAH cost is
    /// kept: neither builder gives the better tree on every scene.
    /// Degenerate triangles
    /// ([`crate::geometry::triangle::is_degenerate`]) are left out: they can
    /// never be hit. An empty or fully degenerate input gives an empty BVH.
    ///
    /// # Panics
    /// If `tris.len() >= u32::MAX`.
    #[cfg(feature = "std")]
    pub fn build(tris: &[[Vec3; 3]]) -> Bvh {
        build::build(tris)
    }

    /// A BVH from a layout whose leaves index triangles in leaf order (a
    /// leaf slot's `child` is its first triangle in `tris`; `prim_ids[i]`
    /// is the scene-global id of `tris[i]`): checked like
    /// [`BvhView::new`], then packed into [`TriBlock`]s (leaf children
    /// become slot indices).
    pub fn from_parts(
        mut nodes: Vec<Node>,
        tris: Vec<[Vec3; 3]>,
        prim_ids: Vec<u32>,
    ) -> Result<Bvh, LayoutError> {
        if tris.len() != prim_ids.len() || tris.len() >= u32::MAX as usize / 4 {
            return Err(LayoutError::Lengths);
        }
        if let Some(index) = prim_ids.iter().position(|&p| p == HitPacket::<1>::MISS) {
            return Err(LayoutError::ReservedPrimId { index });
        }
        // The leaf ranges against `tris` (before packing, which trusts
        // them), and the slots the packed leaves will take (ranges may
        // overlap, so this is not bounded by `tris.len()`); the packed
        // layout is then checked in full.
        for (i, node) in nodes.iter().enumerate() {
            for c in (0..WIDTH).filter(|&c| node.is_leaf(c)) {
                if node.child[c] as u64 + node.count[c] as u64 > tris.len() as u64 {
                    return Err(LayoutError::BadChild { node: i, slot: c });
                }
            }
        }
        let n_blocks = leaf::blocks_needed(&nodes);
        if 4 * n_blocks >= u32::MAX as u64 {
            return Err(LayoutError::Lengths);
        }
        let blocks = leaf::pack(&mut nodes, &tris, &prim_ids, n_blocks as usize);
        Bvh::from_blocks(nodes, blocks)
    }

    /// Wraps prebuilt storage in the block layout after checking it like
    /// [`BvhView::new`].
    pub fn from_blocks(nodes: Vec<Node>, blocks: Vec<TriBlock>) -> Result<Bvh, LayoutError> {
        let depth = BvhView::new(&nodes, &blocks)?.depth;
        Ok(Bvh {
            nodes,
            blocks,
            depth,
            kernel: Kernel::best(),
        })
    }

    /// This BVH traversed with `kernel`; gives the BVH back unchanged as
    /// the error if the CPU cannot run it (see [`BvhView::with_kernel`]).
    pub fn with_kernel(self, kernel: Kernel) -> Result<Bvh, Bvh> {
        if kernel.is_available() {
            Ok(Bvh { kernel, ..self })
        } else {
            Err(self)
        }
    }

    /// The traversal kernel in use ([`Kernel::best`] unless changed).
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Moves the triangles to `triangle(prim)` (scene-global ids, the
    /// numbering of the build) and recomputes every box bottom-up, keeping
    /// the tree: what a host does when meshes move but keep their
    /// topology. Allocates nothing.
    ///
    /// Boxes stay exact (min/max of vertex coordinates, no rounding), so
    /// traversal stays watertight; only the tree's quality decays as
    /// triangles travel far from the neighbours they were grouped with
    /// (rebuild then). Triangles that were degenerate at build time are
    /// not in the tree and stay out: rebuild if one unfolds.
    pub fn refit(&mut self, triangle: impl Fn(u32) -> [Vec3; 3]) {
        // Padding lanes hold a copy of a real slot (id included), so they
        // follow it.
        for b in &mut self.blocks {
            for l in 0..4 {
                let id = b.ids[l];
                b.set(l, triangle(id), id);
            }
        }
        node::refit(&mut self.nodes, &self.blocks);
    }

    /// The storage: nodes and triangle blocks (as [`Bvh::from_blocks`]
    /// takes them).
    pub fn into_parts(self) -> (Vec<Node>, Vec<TriBlock>) {
        (self.nodes, self.blocks)
    }

    /// Borrows the BVH for traversal.
    #[inline]
    pub fn view(&self) -> BvhView<'_> {
        BvhView {
            nodes: &self.nodes,
            blocks: &self.blocks,
            depth: self.depth,
            kernel: self.kernel,
            interleave_from: INTERLEAVE_MIN_BYTES,
        }
    }
}

#[cfg(feature = "alloc")]
impl Intersector for Bvh {
    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.view().intersect(ray)
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        self.view().occluded(ray)
    }

    #[inline]
    fn intersect_packet<const N: usize>(
        &self,
        rays: &RayPacket<N>,
        active: LaneMask,
        hits: &mut HitPacket<N>,
    ) {
        self.view().intersect_packet(rays, active, hits)
    }

    #[inline]
    fn occluded_packet<const N: usize>(&self, rays: &RayPacket<N>, active: LaneMask) -> LaneMask {
        self.view().occluded_packet(rays, active)
    }

    #[inline]
    fn intersect_stream(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.view().intersect_stream(rays, hits)
    }

    #[inline]
    fn occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.view().occluded_stream(rays, occluded)
    }
}
