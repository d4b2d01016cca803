//! Stream traversal: many independent rays, several in flight at once.
//!
//! A single ray's walk is a chain of dependent loads: the next node's
//! address comes out of the current node's box test. On a tree larger than
//! the core's caches each link waits for memory, and one ray leaves the
//! core idle for much of that wait (the 260k-triangle benchmark mesh's
//! diffuse bounces run about 1.2 instructions per cycle, where
//! veach-mis' 3.4 MiB tree runs its bounces at about two). Here [`LANES`] rays take turns, one
//! [`Walk::step`] each: a step prefetches the entry its ray visits next,
//! and the other rays' steps run while that load is under way. It is the
//! overlap a core's hardware threads would give, done in software, and
//! unlike a packet it asks nothing of the rays' coherence.
//!
//! Every ray follows exactly its own single-ray traversal, same arithmetic
//! and same order, so each answer is bit-identical to
//! [`super::traverse::intersect`]'s or [`super::traverse::occluded`]'s.

use super::BvhView;
use super::kernel::{BoxTest, ScalarBox};
#[cfg(target_arch = "x86_64")]
use super::kernel::{Kernel, Sse2Box};
use super::leaf::slot_id;
use super::traverse::{Entry, Prepared, ROOT, Stack, Walk, prepare};
use crate::geometry::{Hit, Ray};

/// Rays in flight. Four, eight and sixteen traced the 260k-triangle
/// mesh's diffuse bounces alike (1.96, 1.96 and 1.86 Mrays/s in one set of
/// runs); eight stacks take 24 KB, half of this machine's L1 data cache.
pub(super) const LANES: usize = 8;

/// The tree size (bytes of nodes and leaf blocks) from which streams are
/// interleaved by default ([`super::BvhView::with_interleave_from`]).
/// Trees smaller than this are traced ray by ray: their nodes stay in the
/// caches, and taking turns only costs. Interleaving mixes the rays'
/// branches in the predictor's history (veach-mis' diffuse bounces: 44%
/// more mispredictions, 14% more instructions, callgrind) and wins only
/// once the walk waits on memory. Measured on the benchmark mesh's
/// diffuse bounces (`bench rays --scenes mesh --mesh-triangles N --sets
/// diffuse --kernels ours-avx2,ours-stream`, interleaving forced),
/// interleaved ÷ ray by ray: 0.86–0.88 at 1.1 MiB of tree, 0.91–0.94 at 3.7 MiB,
/// 0.92–1.02 at 7.3 MiB, 1.17 at 11 MiB, 1.13 at 14.6 MiB, 1.14–1.35 at
/// 19 MiB and 2.3 at 1M triangles; the shared scenes (all below 4 MiB)
/// 0.64–0.80. The line depends on the machine's caches (here 2 MiB of L2
/// per core).
pub const INTERLEAVE_MIN_BYTES: usize = 8 << 20;

/// One ray in flight: its index in the stream, its set-up and its walk.
#[derive(Clone, Copy)]
struct Slot {
    ray: usize,
    r: Prepared,
    walk: Walk,
}

/// Traces `rays`, [`LANES`] at a time, and reports each ray's outcome once
/// as `finish(index, walk)` (with `walk.best` the hit slot, if any, and
/// `walk.t_max` its distance). Rays that cannot hit anything are reported
/// at once with no hit.
#[inline(always)]
fn run<B: BoxTest, const ANY: bool>(
    view: &BvhView<'_>,
    rays: &[Ray],
    mut finish: impl FnMut(usize, &Walk),
) {
    let mut stacks: [Stack<Entry>; LANES] = core::array::from_fn(|_| Stack::new());
    let mut slots: [Option<Slot>; LANES] = [None; LANES];
    let mut next = 0;
    // The next ray that can hit something, in stream order; the others
    // are finished on the way.
    let load = |next: &mut usize, finish: &mut dyn FnMut(usize, &Walk)| {
        while *next < rays.len() {
            let i = *next;
            *next += 1;
            let ray = &rays[i];
            let walk = Walk {
                cur: ROOT,
                t_max: ray.t_max,
                best: None,
            };
            match prepare(view, ray) {
                Some(r) => return Some(Slot { ray: i, r, walk }),
                None => finish(i, &walk),
            }
        }
        None
    };
    let mut live = 0;
    for s in slots.iter_mut() {
        *s = load(&mut next, &mut finish);
        live += s.is_some() as usize;
    }
    while live > 0 {
        for (s, stack) in slots.iter_mut().zip(stacks.iter_mut()) {
            let Some(slot) = s else { continue };
            if slot.walk.step::<B, ANY>(view, &slot.r, stack) {
                continue;
            }
            finish(slot.ray, &slot.walk);
            stack.clear();
            *s = load(&mut next, &mut finish);
            live -= s.is_none() as usize;
        }
    }
}

/// Closest hits of `rays` into `hits` (same length), with box test `B`.
#[inline(always)]
pub(super) fn intersect_with<B: BoxTest>(
    view: &BvhView<'_>,
    rays: &[Ray],
    hits: &mut [Option<Hit>],
) {
    run::<B, false>(view, rays, |i, w| {
        hits[i] = w.best.map(|(j, b1, b2)| Hit {
            t: w.t_max,
            prim: slot_id(view.blocks, j),
            b1,
            b2,
        });
    });
}

/// Occlusion of `rays` into `occluded` (same length), with box test `B`.
#[inline(always)]
pub(super) fn occluded_with<B: BoxTest>(view: &BvhView<'_>, rays: &[Ray], occluded: &mut [bool]) {
    run::<B, true>(view, rays, |i, w| occluded[i] = w.best.is_some());
}

/// The stream traversal compiled for AVX2 (what the AVX2 and AVX-512
/// kernels run, as for single rays).
#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use crate::accel::bvh::kernel::Avx2Box;

    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn intersect_avx2(view: &BvhView<'_>, rays: &[Ray], hits: &mut [Option<Hit>]) {
        intersect_with::<Avx2Box>(view, rays, hits)
    }

    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn occluded_avx2(view: &BvhView<'_>, rays: &[Ray], occluded: &mut [bool]) {
        occluded_with::<Avx2Box>(view, rays, occluded)
    }
}

/// Closest hits of `rays` into `hits` (same length) with the view's
/// kernel: interleaved for trees of the view's `interleave_from` bytes
/// (default [`INTERLEAVE_MIN_BYTES`]) and more, ray by ray below.
pub(super) fn intersect(view: &BvhView<'_>, rays: &[Ray], hits: &mut [Option<Hit>]) {
    if view.size_bytes() < view.interleave_from {
        for (r, h) in rays.iter().zip(hits) {
            *h = super::traverse::intersect(view, r);
        }
    } else {
        intersect_interleaved(view, rays, hits);
    }
}

/// Occlusion of `rays` into `occluded` (same length) with the view's
/// kernel; interleaved as in [`intersect`].
pub(super) fn occluded(view: &BvhView<'_>, rays: &[Ray], occluded: &mut [bool]) {
    if view.size_bytes() < view.interleave_from {
        for (r, o) in rays.iter().zip(occluded) {
            *o = super::traverse::occluded(view, r);
        }
    } else {
        occluded_interleaved(view, rays, occluded);
    }
}

/// [`intersect`], interleaved whatever the tree's size.
pub(super) fn intersect_interleaved(view: &BvhView<'_>, rays: &[Ray], hits: &mut [Option<Hit>]) {
    match view.kernel {
        #[cfg(target_arch = "x86_64")]
        Kernel::Sse2 => intersect_with::<Sse2Box>(view, rays, hits),
        // SAFETY: a view only holds an available kernel (`with_kernel`);
        // AVX-512 implies the AVX2 this runs.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 | Kernel::Avx512 => unsafe { x86::intersect_avx2(view, rays, hits) },
        _ => intersect_with::<ScalarBox>(view, rays, hits),
    }
}

/// [`occluded`], interleaved whatever the tree's size.
pub(super) fn occluded_interleaved(view: &BvhView<'_>, rays: &[Ray], occluded: &mut [bool]) {
    match view.kernel {
        #[cfg(target_arch = "x86_64")]
        Kernel::Sse2 => occluded_with::<Sse2Box>(view, rays, occluded),
        // SAFETY: as in `intersect_interleaved`.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 | Kernel::Avx512 => unsafe { x86::occluded_avx2(view, rays, occluded) },
        _ => occluded_with::<ScalarBox>(view, rays, occluded),
    }
}
