//! The wide node layout ([`WIDTH`] children per node), its robust box
//! test, and the exact refit of its boxes.

#[cfg(feature = "alloc")]
use glam::Vec3;

#[cfg(feature = "alloc")]
use super::leaf::{TriBlock, slot_tri};

use crate::geometry::offset::gamma;

/// `child` value of an empty slot.
pub const EMPTY_CHILD: u32 = u32::MAX;

/// Children per node.
///
/// Eight, as Embree's BVH8: a node's eight boxes are tested in one 256-bit
/// register per plane (two SSE registers on the SSE2 kernel), so a visit
/// costs about what a 4-wide one did, and the tree has half the nodes
/// (the benchmark mesh: 16,247 against 32,658 at four wide; single-ray
/// diffuse bounces 12% fewer instructions).
pub const WIDTH: usize = 8;

/// Maximum depth (levels of [`Node`], root = level 1) of a valid layout.
///
/// The builder flattens anything deeper into one leaf, and
/// [`super::BvhView::new`] rejects deeper layouts, so traversal can use a
/// fixed stack of [`STACK_SIZE`] entries: while visiting a node, the stack
/// holds at most the `WIDTH − 1` unvisited siblings from each ancestor
/// level. A balanced 8-wide tree of depth 32 addresses 8³² leaves; the
/// benchmark scenes' builds are 2–10 levels deep (the 260k-triangle mesh
/// 10).
pub const MAX_DEPTH: usize = 32;

/// Entries in a traversal stack: `WIDTH − 1` per level (see
/// [`MAX_DEPTH`]).
pub const STACK_SIZE: usize = (WIDTH - 1) * MAX_DEPTH;

/// Scale applied to the far end of a box's ray interval, `1 + 2γ(3)`.
///
/// Ize 2013 ("Robust BVH Ray Traversal", JCGT 2(2)) shows that the computed
/// slab distances `(b − o)·(1/d)` are within a relative `γ(3)` of the exact
/// ones (subtraction, reciprocal, product), so widening the far end by
/// `2γ(3)` makes the test conservative: a ray that meets a box in exact
/// arithmetic is never culled by rounding.
pub const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

/// A wide BVH node: the bounds of its (up to) [`WIDTH`] children in SoA
/// form, plus what each child is. 256 bytes: four cache lines, aligned to
/// one.
///
/// Child slot `c` is
/// - an **inner node** when `count[c] == 0 && child[c] != EMPTY_CHILD`:
///   `child[c]` is its index in the node array (always greater than this
///   node's index);
/// - a **leaf** when `count[c] > 0`: triangle slots `child[c] .. child[c] +
///   count[c]` of the [`super::TriBlock`] array (`child[c]` a multiple of
///   4: a leaf starts a block);
/// - **empty** when `count[c] == 0 && child[c] == EMPTY_CHILD`: its bounds are
///   inverted (`min = +∞`, `max = −∞`), so every ray misses it.
///
/// The layout is plain data (`repr(C)`, no pointers), so a host can build or
/// map it and hand it to [`super::BvhView::new`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Node {
    /// Lower bounds, `min[axis][child]`.
    pub min: [[f32; WIDTH]; 3],
    /// Upper bounds, `max[axis][child]`.
    pub max: [[f32; WIDTH]; 3],
    /// Node index or first triangle per child (see the type docs).
    pub child: [u32; WIDTH],
    /// Triangle count per child; 0 for inner and empty slots.
    pub count: [u32; WIDTH],
}

// Whole cache lines exactly; `repr(C)` keeps the field order.
const _: () = assert!(core::mem::size_of::<Node>() == 32 * WIDTH);

impl Node {
    /// A node with every slot empty.
    pub const EMPTY: Node = Node {
        min: [[f32::INFINITY; WIDTH]; 3],
        max: [[f32::NEG_INFINITY; WIDTH]; 3],
        child: [EMPTY_CHILD; WIDTH],
        count: [0; WIDTH],
    };

    /// Whether slot `c` is empty.
    #[inline]
    pub fn is_empty(&self, c: usize) -> bool {
        self.count[c] == 0 && self.child[c] == EMPTY_CHILD
    }

    /// Whether slot `c` is a leaf.
    #[inline]
    pub fn is_leaf(&self, c: usize) -> bool {
        self.count[c] != 0
    }

    /// Whether slot `c` is an inner node.
    #[inline]
    pub fn is_inner(&self, c: usize) -> bool {
        self.count[c] == 0 && self.child[c] != EMPTY_CHILD
    }

    /// The node's bytes as eight rows of [`WIDTH`] floats: rows 0–2 are
    /// `min[axis]`, rows 3–5 `max[axis]`; rows 6 and 7 alias `child` and
    /// `count` and are never read as planes. Indexing a row with `& 7`
    /// needs no bounds check, which is what the single-ray box tests use
    /// with [`BoxRay`]'s precomputed plane rows.
    #[inline(always)]
    pub(crate) fn rows(&self) -> &[[f32; WIDTH]; 8] {
        // SAFETY: `Node` is `repr(C)`, `8 · 4 · WIDTH` bytes (asserted
        // above) with no padding (six `[f32; WIDTH]` then two `[u32;
        // WIDTH]`), so all its bytes are initialised; every bit pattern is
        // a valid `f32`, the target type's alignment (4) divides the
        // node's (64), and the shared borrow keeps the node immutable for
        // the reference's lifetime.
        unsafe { &*(self as *const Node).cast::<[[f32; WIDTH]; 8]>() }
    }

    /// Sets the bounds of slot `c`.
    #[inline]
    pub fn set_bounds(&mut self, c: usize, min: [f32; 3], max: [f32; 3]) {
        for a in 0..3 {
            self.min[a][c] = min[a];
            self.max[a][c] = max[a];
        }
    }
}

/// The per-ray part of the slab test.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoxRay {
    /// Origin.
    pub o: [f32; 3],
    /// `1/d` per axis; `±∞` for a zero component (the sign of the zero
    /// picks the sign of the infinity, consistently with the planes).
    pub inv: [f32; 3],
    /// Per axis, the row of [`Node::rows`] holding the near plane: `min`
    /// (row `a`) when `inv[a]` is positive, `max` (row `3 + a`) when its
    /// sign bit is set. Picked once per ray, so the box test does no
    /// per-node selection.
    pub near: [usize; 3],
    /// Per axis, the row of the far plane (the other one of the pair).
    pub far: [usize; 3],
}

impl BoxRay {
    /// Set-up of a ray with origin `o` and direction `d`.
    #[inline]
    pub fn new(o: [f32; 3], d: [f32; 3]) -> Self {
        Self::with_inv(o, [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]])
    }

    /// Set-up from the origin and the reciprocal direction.
    #[inline]
    pub fn with_inv(o: [f32; 3], inv: [f32; 3]) -> Self {
        let neg = inv.map(|x| x.is_sign_negative() as usize);
        BoxRay {
            o,
            inv,
            near: [3 * neg[0], 1 + 3 * neg[1], 2 + 3 * neg[2]],
            far: [3 - 3 * neg[0], 4 - 3 * neg[1], 5 - 3 * neg[2]],
        }
    }
}

/// `max(acc, x)` that ignores a NaN `x` (and compiles to one `maxps`).
///
/// A slab distance is NaN only for `0·∞`: the direction is parallel to the
/// slab and the origin lies exactly on its plane. That slab then does not
/// constrain the ray, which is what dropping the NaN does (Ize 2013, §3).
#[inline(always)]
pub(crate) fn max_keep(acc: f32, x: f32) -> f32 {
    if x > acc { x } else { acc }
}

/// `min(acc, x)` that ignores a NaN `x`.
#[inline(always)]
pub(crate) fn min_keep(acc: f32, x: f32) -> f32 {
    if x < acc { x } else { acc }
}

/// Robust slab test of one ray against a node's child boxes over `[0,
/// t_max]`. Returns the hit mask (bit `c` = child `c`) and the entry
/// distances.
///
/// The portable per-node kernel (the scalar kernel's; `kernel::Sse2Box`
/// and `kernel::Avx2Box` are the same in SSE and AVX registers): the
/// node's boxes, one ray, straight-line code over `[f32; WIDTH]`.
#[inline(always)]
pub(crate) fn boxes(node: &Node, r: &BoxRay, t_max: f32) -> (u32, [f32; WIDTH]) {
    let rows = node.rows();
    let mut near = [0.0f32; WIDTH];
    let mut far = [t_max; WIDTH];
    for a in 0..3 {
        let (nb, fb) = (&rows[r.near[a] & 7], &rows[r.far[a] & 7]);
        for c in 0..WIDTH {
            near[c] = max_keep(near[c], (nb[c] - r.o[a]) * r.inv[a]);
            far[c] = min_keep(far[c], (fb[c] - r.o[a]) * r.inv[a]);
        }
    }
    let mut mask = 0;
    for c in 0..WIDTH {
        mask |= ((near[c] <= far[c] * FAR_SCALE) as u32) << c;
    }
    (mask, near)
}

/// The rays of a packet that share one origin and one direction octant,
/// bounded as one ray with an interval of reciprocal directions: a
/// frustum whose box test ([`boxes_frustum`]) is conservative, to the
/// bit, against every lane's own slab test.
///
/// Why to the bit: with the origin shared, each lane's slab distance is
/// `fl(fl(b − o) · inv)` with the same `fl(b − o)`, and a rounded product
/// is monotone in either factor; so the smaller of the two products with
/// `inv_lo` and `inv_hi` is never above any lane's distance, and the
/// larger never below. The reciprocals must be finite (no `0·∞ = NaN`
/// slab, which a lane drops and the bound could not).
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoxFrustum {
    /// The shared origin.
    pub o: [f32; 3],
    /// Per axis, the smallest `1/d` among the rays (finite).
    pub inv_lo: [f32; 3],
    /// Per axis, the largest `1/d` among the rays (finite, same sign as
    /// `inv_lo`).
    pub inv_hi: [f32; 3],
    /// Per axis, the row of [`Node::rows`] holding the near plane, as in
    /// [`BoxRay::near`] (the same for every ray of the frustum).
    pub near: [usize; 3],
    /// Per axis, the row of the far plane.
    pub far: [usize; 3],
}

impl BoxFrustum {
    /// The frustum of rays from `o` with reciprocal directions between
    /// `inv_lo` and `inv_hi` per axis; `None` unless every bound is finite
    /// and both bounds of an axis have the same sign.
    #[inline(always)]
    pub fn new(o: [f32; 3], inv_lo: [f32; 3], inv_hi: [f32; 3]) -> Option<Self> {
        for a in 0..3 {
            let ok = inv_lo[a].is_finite()
                && inv_hi[a].is_finite()
                && inv_lo[a] <= inv_hi[a]
                && inv_lo[a].is_sign_negative() == inv_hi[a].is_sign_negative();
            if !ok {
                return None;
            }
        }
        let r = BoxRay::with_inv(o, inv_lo);
        Some(BoxFrustum {
            o,
            inv_lo,
            inv_hi,
            near: r.near,
            far: r.far,
        })
    }
}

/// What [`boxes_frustum`] finds for a node.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FrustumHits {
    /// Bit `c` set when some ray of the frustum may meet child `c` (always
    /// when one does).
    pub mask: u32,
    /// Per child, a lower bound of the rays' entry distances.
    pub near: [f32; WIDTH],
    /// The plane offsets `fl(b − o)` per child: rows 0–2 the near planes
    /// of each axis, rows 3–5 the far planes. Every ray's own slab
    /// distance is this times its `1/d` (the origin is shared), so a lane
    /// test of one child needs no subtraction ([`child_lanes`]).
    pub offsets: [[f32; WIDTH]; 6],
}

/// The box test of a [`BoxFrustum`] over `[0, t_far]`, where `t_far` is
/// the largest `t_max` among its rays. The same operations as the SIMD
/// forms (`x < y ? x : y` is `minps(x, y)`), so the same bits.
#[inline(always)]
pub(crate) fn boxes_frustum(node: &Node, f: &BoxFrustum, t_far: f32) -> FrustumHits {
    let rows = node.rows();
    let mut near = [0.0f32; WIDTH];
    let mut far = [t_far; WIDTH];
    let mut offsets = [[0.0f32; WIDTH]; 6];
    for a in 0..3 {
        let (nb, fb) = (&rows[f.near[a] & 7], &rows[f.far[a] & 7]);
        for c in 0..WIDTH {
            let (dn, df) = (nb[c] - f.o[a], fb[c] - f.o[a]);
            offsets[a][c] = dn;
            offsets[3 + a][c] = df;
            let (x, y) = (dn * f.inv_lo[a], dn * f.inv_hi[a]);
            near[c] = max_keep(near[c], if x < y { x } else { y });
            let (x, y) = (df * f.inv_lo[a], df * f.inv_hi[a]);
            far[c] = min_keep(far[c], if x > y { x } else { y });
        }
    }
    let mut mask = 0;
    for c in 0..WIDTH {
        mask |= ((near[c] <= far[c] * FAR_SCALE) as u32) << c;
    }
    FrustumHits {
        mask,
        near,
        offsets,
    }
}

/// The lanes (within `lanes`) whose own slab test meets child `c` of a
/// node whose frustum test gave `offsets` ([`FrustumHits::offsets`]): for
/// lanes of that frustum, the same bits as the per-lane test
/// (`packet::boxes_lanes`), since `fl(b − o)` is the same for all of
/// them. Portable form; `kernel::boxes::child_lanes_simd` is the same in
/// registers.
#[inline(always)]
pub(crate) fn child_lanes<const N: usize>(
    offsets: &[[f32; WIDTH]; 6],
    c: usize,
    inv: &[[f32; N]; 3],
    t_max: &[f32; N],
    lanes: u32,
) -> u32 {
    let c = c & (WIDTH - 1);
    let mut hit = 0;
    for i in 0..N {
        let (mut near, mut far) = (0.0f32, t_max[i]);
        for a in 0..3 {
            near = max_keep(near, offsets[a][c] * inv[a][i]);
            far = min_keep(far, offsets[3 + a][c] * inv[a][i]);
        }
        hit |= ((near <= far * FAR_SCALE) as u32) << i;
    }
    hit & lanes
}

/// Recomputes every child box exactly from the stored triangles, bottom up
/// (children come after parents). The builders' boxes would do, but this
/// way the conservativeness of the boxes never depends on a builder.
#[cfg(feature = "alloc")]
pub(super) fn refit(nodes: &mut [Node], blocks: &[TriBlock]) {
    for i in (0..nodes.len()).rev() {
        for c in 0..WIDTH {
            let node = &nodes[i];
            let (lo, hi) = if node.is_leaf(c) {
                let first = node.child[c] as usize;
                let mut lo = Vec3::INFINITY;
                let mut hi = Vec3::NEG_INFINITY;
                for s in first..first + node.count[c] as usize {
                    for v in slot_tri(blocks, s) {
                        lo = lo.min(v);
                        hi = hi.max(v);
                    }
                }
                (lo, hi)
            } else if node.is_inner(c) {
                let child = &nodes[node.child[c] as usize];
                let lo = Vec3::new(
                    min_of(child.min[0]),
                    min_of(child.min[1]),
                    min_of(child.min[2]),
                );
                let hi = Vec3::new(
                    max_of(child.max[0]),
                    max_of(child.max[1]),
                    max_of(child.max[2]),
                );
                (lo, hi)
            } else {
                continue;
            };
            nodes[i].set_bounds(c, lo.to_array(), hi.to_array());
        }
    }
}

#[cfg(feature = "alloc")]
fn min_of(v: [f32; WIDTH]) -> f32 {
    v.into_iter().fold(f32::INFINITY, f32::min)
}

#[cfg(feature = "alloc")]
fn max_of(v: [f32; WIDTH]) -> f32 {
    v.into_iter().fold(f32::NEG_INFINITY, f32::max)
}
