//! Single-ray traversal: closest hit (front to back) and any hit.

use core::mem::MaybeUninit;

use super::BvhView;
#[cfg(target_arch = "x86_64")]
use super::kernel::{Avx2Box, Kernel, Sse2Box};
use super::kernel::{BoxTest, ScalarBox};
use super::leaf::slot_id;
use super::node::{BoxRay, FAR_SCALE, STACK_SIZE, WIDTH};
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

/// Entries of a single-ray traversal stack: [`STACK_SIZE`] rounded up to
/// a power of two, so an index masked with `STACK_CAP - 1` is in bounds
/// without a check.
const STACK_CAP: usize = STACK_SIZE.next_power_of_two();

/// A traversal stack; see `node::MAX_DEPTH` for why a validated layout
/// never holds more than [`STACK_SIZE`] entries in it.
///
/// The storage is left uninitialised: zeroing 1.1 KB per ray (as
/// `[Entry::default(); STACK_SIZE]` did) was a measurable share of a short
/// traversal, and only the entries below `len` are ever read. Indices are
/// masked to the capacity instead of bounds-checked: an overflow (which a
/// validated layout cannot produce) would overwrite older entries, never
/// memory outside the stack. (The packet kernel's own stack stays a zeroed
/// array: this type measured slower there.)
pub(super) struct Stack<T: Copy> {
    items: [MaybeUninit<T>; STACK_CAP],
    len: usize,
}

impl<T: Copy> Stack<T> {
    /// An empty stack.
    #[inline(always)]
    pub fn new() -> Self {
        Stack {
            items: [const { MaybeUninit::uninit() }; STACK_CAP],
            len: 0,
        }
    }

    /// Drops every entry.
    #[inline(always)]
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Pushes `e`.
    #[inline(always)]
    pub fn push(&mut self, e: T) {
        self.items[self.len & (STACK_CAP - 1)].write(e);
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
        // `items[len & mask]` before incrementing, so the slot of every
        // position below `len` (here the old `len - 1`) was written, and
        // `MaybeUninit` slots are never de-initialised.
        Some(unsafe { self.items[self.len & (STACK_CAP - 1)].assume_init() })
    }
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
pub(super) fn prepare(view: &BvhView<'_>, ray: &Ray) -> Option<Prepared> {
    if view.nodes.is_empty() || !(ray.t_max > 0.0) {
        return None;
    }
    let wr = WatertightRay::new(ray)?;
    Some(Prepared {
        wr,
        br: BoxRay::new(ray.o.to_array(), ray.d.to_array()),
    })
}

/// The order key of a hit child: its entry distance above, its slot
/// below. Entry distances are never NaN or `−0` (they start at `+0` and
/// `max_keep` only takes strictly larger values), so the keys compare like
/// (distance, slot): nearest first, lower slot first on a tie.
#[inline(always)]
fn key(near: f32, slot: usize) -> u64 {
    (near.to_bits() as u64) << 32 | slot as u64
}

/// The slot of a [`key`].
#[inline(always)]
fn key_slot(k: u64) -> usize {
    (k as usize) & (WIDTH - 1)
}

/// The child to enter next among a node's hit children `mask` (entry
/// distances `near`), made by `entry`; the other hit children go to
/// `defer` far-to-near, so the next pop is the next nearest. `None` when
/// no child is hit. Shared by the single-ray and packet kernels, so both
/// visit a node's children in the same order (nearest first, lower slot
/// on a tie).
///
/// One child hit (the common case below the top levels) is entered
/// without sorting or touching the stack; two (a fifth of the visits on
/// incoherent rays, a quarter of packet visits on MTM bundles) take one
/// comparison; more are sorted by insertion. The hit children are found
/// by bit scans: testing each slot's bit was a branch per slot, taken at
/// random (8% of the time of packets of 8 on the mesh's MTM bundles).
#[inline(always)]
pub(super) fn descend<E>(
    mask: u32,
    near: &[f32; WIDTH],
    entry: impl Fn(usize) -> E,
    mut defer: impl FnMut(E),
) -> Option<E> {
    match mask.count_ones() {
        0 => None,
        1 => Some(entry(mask.trailing_zeros() as usize & (WIDTH - 1))),
        2 => {
            let (n, f) = two_hits(mask, near);
            defer(entry(f));
            Some(entry(n))
        }
        n => {
            let keys = sorted_keys(mask, n as usize, near);
            for &k in keys[1..n as usize].iter().rev() {
                defer(entry(key_slot(k)));
            }
            Some(entry(key_slot(keys[0])))
        }
    }
}

/// [`descend`] for occlusion: children whose box holds the ray's origin
/// go last. Any blocker ends an occlusion query, so the order is chosen to
/// find one soon, and the answer does not depend on it. The packet
/// kernels use it too, with each child's smallest entry distance over the
/// lanes (so a box holding some lane's origin goes last).
///
/// Why the origin's boxes last: a shadow ray starts on the surface it
/// leaves (offset off it, `geometry::offset`), so the boxes around its
/// origin (entry distance exactly 0) hold that surface, which the ray
/// does not hit; nearest-first enters them first at every level and tests
/// their leaves in vain before looking where a blocker can be. Among the
/// children ahead of the origin the nearest is entered; the rest are
/// deferred in slot order, not sorted (sorting cost mispredicted
/// branches), with the origin's boxes below them on the stack.
///
/// Measured against nearest-first (Zen 4): per shadow
/// ray on the 260k-triangle mesh 9.7 inner nodes and 2.4 leaves instead
/// of 10.6 and 3.6; single rays' Mrays/s ÷ Embree's `rtcOccluded1`
/// 1.20–1.23× on the mesh, 1.17–1.22× on cornell-box, 1.13× on
/// veach-ajar, 1.04–1.06× on veach-bidir and 0.95–0.98× on veach-mis;
/// packets of 4, 8 and 16 on the same shadow rays 1.14–1.21× on the
/// mesh, 0.97–1.15× on cornell-box and veach-ajar, 0.92–0.99× on
/// veach-bidir and veach-mis.
#[inline(always)]
pub(super) fn descend_any<E>(
    mask: u32,
    near: &[f32; WIDTH],
    entry: impl Fn(usize) -> E,
    mut defer: impl FnMut(E),
) -> Option<E> {
    if mask & (mask.wrapping_sub(1)) == 0 {
        return descend(mask, near, entry, defer);
    }
    // Hit children whose entry distance is 0 (never −0 or NaN, [`key`]).
    let mut inside = 0u32;
    let mut bits = mask;
    while bits != 0 {
        let c = bits.trailing_zeros() as usize & (WIDTH - 1);
        bits &= bits - 1;
        inside |= ((near[c] == 0.0) as u32) << c;
    }
    let ahead = mask & !inside;
    // Nearest of the children ahead, lower slot on a tie (strict `<` keeps
    // the first); if every hit child holds the origin, the lowest slot.
    let pool = if ahead != 0 { ahead } else { inside };
    let mut best = pool.trailing_zeros() as usize & (WIDTH - 1);
    let mut bits = pool & (pool - 1);
    while bits != 0 {
        let c = bits.trailing_zeros() as usize & (WIDTH - 1);
        bits &= bits - 1;
        if near[c] < near[best] {
            best = c;
        }
    }
    for group in [inside, ahead] {
        let mut bits = group & !(1 << best);
        while bits != 0 {
            let c = bits.trailing_zeros() as usize & (WIDTH - 1);
            bits &= bits - 1;
            defer(entry(c));
        }
    }
    Some(entry(best))
}

/// The keys ([`key`]) of the `n` hit children in `mask`, nearest first,
/// in `keys[..n]`: an insertion sort over the hit children only (an 8-key
/// network would sort eight every time).
#[inline(always)]
fn sorted_keys(mask: u32, n: usize, near: &[f32; WIDTH]) -> [u64; WIDTH] {
    let mut keys = [u64::MAX; WIDTH];
    let mut bits = mask;
    for k in keys.iter_mut().take(n) {
        let c = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        *k = key(near[c & (WIDTH - 1)], c);
    }
    for i in 1..n {
        let x = keys[i];
        let mut j = i;
        while j > 0 && keys[j - 1] > x {
            keys[j] = keys[j - 1];
            j -= 1;
        }
        keys[j] = x;
    }
    keys
}

/// The two hit children of `mask` (exactly two bits set), nearer first;
/// on a tie the lower slot first, as [`sorted_keys`] orders them.
#[inline(always)]
fn two_hits(mask: u32, near: &[f32; WIDTH]) -> (usize, usize) {
    let c0 = mask.trailing_zeros() as usize & (WIDTH - 1);
    let c1 = (mask & (mask - 1)).trailing_zeros() as usize & (WIDTH - 1);
    if near[c1] < near[c0] {
        (c1, c0)
    } else {
        (c0, c1)
    }
}

/// Traverses the subtree `start` (a node or a leaf, as in [`Entry`]) for
/// one ray whose closest hit so far is at `*t_max`. Children are visited
/// nearest first (for occlusion, the nearest of those ahead of the origin,
/// the boxes holding the origin last, [`descend_any`]) and
/// a deferred child is culled once its entry distance is beyond the closest
/// hit; with `ANY` the first hit ends the traversal. Returns the triangle
/// slot and barycentrics of a closer hit, whose distance is left in
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
            if let Some(e) = visit_node::<B, ANY>(view, r, cur.child, *t_max, stack) {
                cur = e;
                continue;
            }
        } else if let Some(h) = visit_leaf::<B, ANY>(view, r, cur, t_max) {
            best = Some(h);
            if ANY {
                break 'outer;
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

/// Box-tests node `index`'s children; returns the nearest hit child to
/// enter and defers the other hit children ([`descend`], or for `ANY`
/// [`descend_any`]).
#[inline(always)]
fn visit_node<B: BoxTest, const ANY: bool>(
    view: &BvhView<'_>,
    r: &Prepared,
    index: u32,
    t_max: f32,
    stack: &mut Stack<Entry>,
) -> Option<Entry> {
    let node = &view.nodes[index as usize];
    let (mask, near) = B::boxes(node, &r.br, t_max);
    let entry = |c: usize| Entry {
        child: node.child[c],
        count: node.count[c],
        t: near[c],
    };
    if ANY {
        descend_any(mask, &near, entry, |e| defer(view, stack, e))
    } else {
        descend(mask, &near, entry, |e| defer(view, stack, e))
    }
}

/// Tests the triangles of `leaf` (`count > 0`); on a hit closer than
/// `*t_max`, moves `*t_max` to it and returns its slot and barycentrics.
#[inline(always)]
fn visit_leaf<B: BoxTest, const ANY: bool>(
    view: &BvhView<'_>,
    r: &Prepared,
    leaf: Entry,
    t_max: &mut f32,
) -> Option<(usize, f32, f32)> {
    let first = leaf.child as usize;
    let count = leaf.count as usize;
    let blocks = &view.blocks[first / 4..(first + count).div_ceil(4)];
    let (j, t, b1, b2) = B::leaf::<ANY>(&r.wr, blocks, count, *t_max)?;
    *t_max = t;
    Some((first + j, b1, b2))
}

/// Where one ray's traversal stands between two [`Walk::step`]s: what
/// [`traverse_from`] keeps in registers, and what the interleaved stream
/// traversal (`super::stream`) keeps per ray in flight.
#[derive(Clone, Copy)]
pub(super) struct Walk {
    /// The node or leaf to visit next.
    pub cur: Entry,
    /// Distance of the closest hit so far (the ray's `t_max` at first).
    pub t_max: f32,
    /// Triangle slot and barycentrics of the closest hit so far.
    pub best: Option<(usize, f32, f32)>,
}

impl Walk {
    /// One iteration of [`traverse_from`]'s loop: visits `cur`, then
    /// moves `cur` to the next entry (the nearest hit child, or else the
    /// next stacked child still in front of the closest hit) and
    /// prefetches it, since the stream visits other rays before this
    /// one's next step. Returns `false` when the traversal is over (stack
    /// empty, or with `ANY` a hit).
    ///
    /// [`traverse_from`] keeps its own loop over the same two visits:
    /// written as a loop over this step, the single-ray kernel ran 4% more
    /// instructions (the mesh's diffuse bounces, callgrind).
    #[inline(always)]
    pub(super) fn step<B: BoxTest, const ANY: bool>(
        &mut self,
        view: &BvhView<'_>,
        r: &Prepared,
        stack: &mut Stack<Entry>,
    ) -> bool {
        let cur = self.cur;
        if cur.count == 0 {
            if let Some(e) = visit_node::<B, ANY>(view, r, cur.child, self.t_max, stack) {
                prefetch(view, e.child, e.count);
                self.cur = e;
                return true;
            }
        } else if let Some(h) = visit_leaf::<B, ANY>(view, r, cur, &mut self.t_max) {
            self.best = Some(h);
            if ANY {
                return false;
            }
        }
        // Stacked entries were prefetched when they were deferred.
        while let Some(e) = stack.pop() {
            if e.t <= self.t_max * FAR_SCALE {
                self.cur = e;
                return true;
            }
        }
        false
    }
}

/// Puts `e` on the stack for later and starts loading it ([`prefetch`]).
#[inline(always)]
fn defer(view: &BvhView<'_>, stack: &mut Stack<Entry>, e: Entry) {
    prefetch(view, e.child, e.count);
    stack.push(e);
}

/// Starts loading a deferred child (`child`, `count` as in [`Entry`]):
/// every cache line of an inner node, or the first 192 bytes from a
/// leaf's first block (the whole 160-byte block, wherever its 32-byte
/// alignment puts it in a line).
///
/// A child goes on the stack because its box was hit, so it is likely to
/// be visited, but only after the nearer subtree is done; on scenes larger
/// than the caches its first touch would otherwise stall the traversal.
/// Measured in one process against the same traversal without it: 5%
/// faster on the mesh's diffuse bounces and on
/// veach-mis's shadow rays, within ±2% elsewhere.
///
/// A prefetch never faults and changes no result; the address is formed
/// with `wrapping_add`, so even an index a layout would reject is harmless.
#[inline(always)]
pub(super) fn prefetch(view: &BvhView<'_>, child: u32, count: u32) {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // Cache lines to load: a whole node, or three for a block.
        let (p, lines) = if count == 0 {
            let p = view.nodes.as_ptr().wrapping_add(child as usize);
            (p.cast::<i8>(), size_of::<super::Node>() / 64)
        } else {
            let p = view.blocks.as_ptr().wrapping_add(child as usize / 4);
            (p.cast::<i8>(), 3)
        };
        for line in 0..lines {
            // SAFETY: SSE is part of the x86_64 baseline; a prefetch is a
            // hint that reads nothing the program can observe and never
            // faults, at any address.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64 * line)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (view, child, count);
}

/// The whole tree, from the root.
pub(super) const ROOT: Entry = Entry {
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
        prim: slot_id(view.blocks, j),
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
/// single rays; see `kernel`).
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The child entered and the deferred ones in push order (unused
    /// places `WIDTH`).
    fn any_order(mask: u32, near: [f32; WIDTH]) -> (Option<usize>, [usize; WIDTH]) {
        let mut pushed = [WIDTH; WIDTH];
        let mut n = 0;
        let first = descend_any(
            mask,
            &near,
            |c| c,
            |c| {
                pushed[n] = c;
                n += 1;
            },
        );
        (first, pushed)
    }

    /// `order` padded to `WIDTH` entries as [`any_order`] gives them.
    fn pad(order: &[usize]) -> [usize; WIDTH] {
        let mut p = [WIDTH; WIDTH];
        p[..order.len()].copy_from_slice(order);
        p
    }

    #[test]
    fn occlusion_enters_the_nearest_child_ahead_and_defers_the_origins_boxes_below_the_rest() {
        let mut near = [9.0; WIDTH];
        (near[1], near[3], near[5], near[6]) = (0.0, 2.0, 1.0, 0.0);
        let mask = 1 << 1 | 1 << 3 | 1 << 5 | 1 << 6;
        // Slot 5 is the nearest ahead of the origin; 1 and 6 hold the
        // origin and go to the bottom of the stack (pushed first), so the
        // pops come 3, then 6, then 1.
        assert_eq!(any_order(mask, near), (Some(5), pad(&[1, 6, 3])));
        // Closest hits keep nearest-first: the origin's box 1 is entered.
        assert_eq!(descend(mask, &near, |c| c, |_| {}), Some(1));
    }

    #[test]
    fn occlusion_with_every_hit_child_at_the_origin_or_one_child_enters_the_lowest_slot() {
        let near = [0.0; WIDTH];
        assert_eq!(any_order(1 << 2 | 1 << 4, near), (Some(2), pad(&[4])));
        assert_eq!(any_order(1 << 7, near), (Some(7), pad(&[])));
        assert_eq!(any_order(0, near), (None, pad(&[])));
        // Two children ahead: nearer first, as for closest hits.
        let mut near = [0.0; WIDTH];
        (near[0], near[1]) = (3.0, 1.5);
        assert_eq!(any_order(0b11, near), (Some(1), pad(&[0])));
    }
}
