//! Single-ray traversal: closest hit (front to back) and any hit.

use core::mem::MaybeUninit;

use super::BvhView;
use super::node::{BoxRay, FAR_SCALE, STACK_SIZE};
#[cfg(target_arch = "x86_64")]
use super::simd::{Avx2Box, Kernel, Sse2Box};
use super::simd::{BoxTest, ScalarBox};
use crate::geometry::triangle::WatertightRay;
use crate::geometry::{Hit, Ray};

/// A deferred child: an inner node (`count == 0`, `child` = node index) or
/// a leaf (`count` triangles from `child`), entered at distance `t`.
#[derive(Clone, Copy, Default)]
pub(super) struct Entry {
    pub child: u32,
    pub count: u32,
    pub t: f32,
}

/// A traversal stack of [`STACK_SIZE`] entries; see `node::MAX_DEPTH` for
/// why it cannot overflow on a validated layout (a push beyond it panics).
///
/// The storage is left uninitialised: zeroing 1.1 KB per ray (as
/// `[Entry::default(); STACK_SIZE]` did) was a measurable share of a short
/// traversal, and only the entries below `len` are ever read. (The packet
/// kernel's own stack stays a zeroed array: this type measured slower
/// there.)
pub(super) struct Stack<T: Copy> {
    items: [MaybeUninit<T>; STACK_SIZE],
    len: usize,
}

impl<T: Copy> Stack<T> {
    /// An empty stack.
    #[inline(always)]
    pub fn new() -> Self {
        Stack {
            items: [const { MaybeUninit::uninit() }; STACK_SIZE],
            len: 0,
        }
    }

    /// Drops every entry.
    #[inline(always)]
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Pushes `e`; panics when full (impossible on a validated layout).
    #[inline(always)]
    pub fn push(&mut self, e: T) {
        self.items[self.len].write(e);
        self.len += 1;
    }

    /// Pops the top entry, if any.
    #[inline(always)]
    pub fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: `push` is the only way `len` grows and it writes
        // `items[len]` before incrementing, so every item below the old
        // `len` (here `items[self.len]`) is initialised.
        Some(unsafe { self.items[self.len].assume_init() })
    }
}

/// The hit children of a node, sorted by key (nearest first); returns the
/// slots and how many there are. At most four, so an insertion sort (it
/// measured faster than a branch-free sorting network).
#[inline(always)]
pub(super) fn order4(mask: u32, key: &[f32; 4]) -> ([usize; 4], usize) {
    let mut order = [0usize; 4];
    let mut n = 0;
    for c in 0..4 {
        if mask >> c & 1 != 0 {
            order[n] = c;
            n += 1;
        }
    }
    for i in 1..n {
        let mut j = i;
        while j > 0 && key[order[j - 1]] > key[order[j]] {
            order.swap(j - 1, j);
            j -= 1;
        }
    }
    (order, n)
}

/// A ray's precomputation for both tests.
#[derive(Clone, Copy)]
pub(super) struct Prepared {
    pub wr: WatertightRay,
    pub br: BoxRay,
}

/// Per-ray set-up; `None` if the ray cannot hit anything (non-finite, zero
/// direction, `t_max` not positive, empty BVH).
#[inline(always)]
fn prepare(view: &BvhView<'_>, ray: &Ray) -> Option<Prepared> {
    if view.nodes.is_empty() || !(ray.t_max > 0.0) {
        return None;
    }
    let wr = WatertightRay::new(ray)?;
    Some(Prepared {
        wr,
        br: BoxRay::new(ray.o.to_array(), ray.d.to_array()),
    })
}

/// Traverses the subtree `start` (a node or a leaf, as in [`Entry`]) for
/// one ray whose closest hit so far is at `*t_max`. Children are visited
/// nearest first (for occlusion too: it finds blockers sooner, measured) and
/// a deferred child is culled once its entry distance is beyond the closest
/// hit; with `ANY` the first hit ends the traversal. Returns the leaf-order
/// index and barycentrics of a closer hit, whose distance is left in
/// `*t_max`.
#[inline(always)]
pub(super) fn traverse_from<B: BoxTest, const ANY: bool>(
    view: &BvhView<'_>,
    r: &Prepared,
    start: Entry,
    t_max: &mut f32,
    stack: &mut Stack<Entry>,
) -> Option<(usize, f32, f32)> {
    let mut best: Option<(usize, f32, f32)> = None;
    stack.clear();
    let mut cur = start;
    'outer: loop {
        if cur.count == 0 {
            let node = &view.nodes[cur.child as usize];
            let (mask, near) = B::box4(node, &r.br, *t_max);
            // One child hit (the common case below the top levels):
            // descend without sorting or touching the stack.
            if mask != 0 && mask & (mask - 1) == 0 {
                let c = mask.trailing_zeros() as usize;
                cur = Entry {
                    child: node.child[c],
                    count: node.count[c],
                    t: near[c],
                };
                continue;
            }
            if mask != 0 {
                let (order, n) = order4(mask, &near);
                // Push the farther children far-to-near so the next pop is
                // the next nearest; descend into the nearest right away.
                for &c in order[1..n].iter().rev() {
                    stack.push(Entry {
                        child: node.child[c],
                        count: node.count[c],
                        t: near[c],
                    });
                }
                let c = order[0];
                cur = Entry {
                    child: node.child[c],
                    count: node.count[c],
                    t: near[c],
                };
                continue;
            }
        } else {
            let first = cur.child as usize;
            let tris = &view.tris[first..first + cur.count as usize];
            if let Some((j, t, b1, b2)) = B::leaf::<ANY>(&r.wr, tris, *t_max) {
                *t_max = t;
                best = Some((first + j, b1, b2));
                if ANY {
                    break 'outer;
                }
            }
        }
        // Pop the next child still in front of the closest hit (same
        // conservative widening as the box test).
        loop {
            let Some(e) = stack.pop() else {
                break 'outer;
            };
            if e.t <= *t_max * FAR_SCALE {
                cur = e;
                continue 'outer;
            }
        }
    }
    best
}

/// The whole tree, from the root.
const ROOT: Entry = Entry {
    child: 0,
    count: 0,
    t: 0.0,
};

/// Closest hit of `ray` with box test `B`.
#[inline(always)]
pub(super) fn intersect_with<B: BoxTest>(view: &BvhView<'_>, ray: &Ray) -> Option<Hit> {
    let r = prepare(view, ray)?;
    let mut t = ray.t_max;
    let mut stack = Stack::new();
    traverse_from::<B, false>(view, &r, ROOT, &mut t, &mut stack).map(|(j, b1, b2)| Hit {
        t,
        prim: view.prim_ids[j],
        b1,
        b2,
    })
}

/// Whether anything blocks `ray` in `(0, t_max)`, with box test `B`.
#[inline(always)]
pub(super) fn occluded_with<B: BoxTest>(view: &BvhView<'_>, ray: &Ray) -> bool {
    let Some(r) = prepare(view, ray) else {
        return false;
    };
    let mut t = ray.t_max;
    let mut stack = Stack::new();
    traverse_from::<B, true>(view, &r, ROOT, &mut t, &mut stack).is_some()
}

/// The traversal compiled for AVX2 (also what the AVX-512 kernel runs for
/// single rays; see `simd`).
#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;

    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn intersect_avx2(view: &BvhView<'_>, ray: &Ray) -> Option<Hit> {
        intersect_with::<Avx2Box>(view, ray)
    }

    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn occluded_avx2(view: &BvhView<'_>, ray: &Ray) -> bool {
        occluded_with::<Avx2Box>(view, ray)
    }
}

/// Closest hit of `ray` with the view's kernel.
pub(super) fn intersect(view: &BvhView<'_>, ray: &Ray) -> Option<Hit> {
    match view.kernel {
        #[cfg(target_arch = "x86_64")]
        Kernel::Sse2 => intersect_with::<Sse2Box>(view, ray),
        // SAFETY: a view only holds an available kernel (`with_kernel`).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { x86::intersect_avx2(view, ray) },
        // SAFETY: as above (AVX-512 implies the AVX2 this runs).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { x86::intersect_avx2(view, ray) },
        _ => intersect_with::<ScalarBox>(view, ray),
    }
}

/// Whether anything blocks `ray` in `(0, t_max)`, with the view's kernel.
pub(super) fn occluded(view: &BvhView<'_>, ray: &Ray) -> bool {
    match view.kernel {
        #[cfg(target_arch = "x86_64")]
        Kernel::Sse2 => occluded_with::<Sse2Box>(view, ray),
        // SAFETY: a view only holds an available kernel (`with_kernel`).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { x86::occluded_avx2(view, ray) },
        // SAFETY: as above (AVX-512 implies the AVX2 this runs).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { x86::occluded_avx2(view, ray) },
        _ => occluded_with::<ScalarBox>(view, ray),
    }
}
