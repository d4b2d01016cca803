//! Host allocator callbacks: every allocation the library makes (scene,
//! BVH, renderer, workers; never one inside a frame) goes through the
//! functions the host registered with [`cmlt_set_allocator`], or the system
//! allocator when none is set.
//!
//! The library's `#[global_allocator]` forwards to the hooks current at
//! allocation time and writes a small header in front of each block naming
//! the hooks that made it, so a block is always freed by its own allocator
//! even when the host switches allocators while objects are alive. Hooks
//! live in a fixed table of [`MAX_ALLOCATORS`] slots, written once each.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::ffi::c_void;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::error::{Error, cmlt_status, guard};

/// Allocation callbacks of a host. `alloc` returns a block of `size` bytes
/// aligned to `align` (a power of two), or NULL when out of memory; `free`
/// receives exactly what `alloc` returned with the same size and alignment.
/// Both may be called from any thread that calls into cmlt.
#[repr(C)]
#[derive(Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct cmlt_allocator {
    /// Passed to both callbacks.
    pub user: *mut c_void,
    /// Allocates.
    pub alloc:
        Option<unsafe extern "C" fn(user: *mut c_void, size: usize, align: usize) -> *mut c_void>,
    /// Frees.
    pub free: Option<
        unsafe extern "C" fn(user: *mut c_void, ptr: *mut c_void, size: usize, align: usize),
    >,
}

/// How many times [`cmlt_set_allocator`] can install hooks in one process.
pub const MAX_ALLOCATORS: usize = 16;

struct Hooks {
    user: usize,
    alloc: unsafe extern "C" fn(*mut c_void, usize, usize) -> *mut c_void,
    free: unsafe extern "C" fn(*mut c_void, *mut c_void, usize, usize),
}

/// Slot 0 is the system allocator (never set); slots 1.. hold host hooks,
/// stored inline so that installing hooks allocates nothing.
static SLOTS: [OnceLock<Hooks>; MAX_ALLOCATORS + 1] =
    [const { OnceLock::new() }; MAX_ALLOCATORS + 1];
/// Slot new allocations use.
static CURRENT: AtomicUsize = AtomicUsize::new(0);
/// Slots handed out so far (slot 0 included).
static USED: AtomicUsize = AtomicUsize::new(1);

/// The library's global allocator (see the module docs).
pub struct HostAllocator;

/// Bytes and largest alignment allocated (not yet freed) on one thread
/// while [`measure_allocations`] ran.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Usage {
    pub bytes: usize,
    pub max_align: usize,
}

thread_local! {
    /// Whether this thread is inside `measure_allocations`, and its tally
    /// (const-initialised, no destructor: safe to touch from the
    /// allocator).
    static MEASURING: Cell<bool> = const { Cell::new(false) };
    static USAGE: Cell<(isize, usize)> = const { Cell::new((0, 0)) };
}

fn tally(outer: Layout, sign: isize) {
    if MEASURING.with(Cell::get) {
        USAGE.with(|u| {
            let (b, a) = u.get();
            u.set((b + sign * outer.size() as isize, a.max(outer.align())));
        });
    }
}

/// Runs `f` and reports the bytes it left allocated on this thread, as the
/// host allocator sees them (headers included), and the largest alignment
/// requested.
pub(crate) fn measure_allocations<R>(f: impl FnOnce() -> R) -> (R, Usage) {
    USAGE.with(|u| u.set((0, 0)));
    MEASURING.with(|m| m.set(true));
    let r = f();
    MEASURING.with(|m| m.set(false));
    let (bytes, max_align) = USAGE.with(Cell::get);
    (
        r,
        Usage {
            bytes: bytes.max(0) as usize,
            max_align,
        },
    )
}

/// Bytes in front of every block: the slot number, padded to the block's
/// alignment so the block itself stays aligned.
fn header(layout: Layout) -> usize {
    layout.align().max(std::mem::size_of::<usize>())
}

// SAFETY: every block is `header` bytes into an allocation of `header +
// size` bytes with the caller's alignment, made by the allocator of the slot
// stored just in front of the block; `dealloc` rebuilds exactly that
// allocation and hands it to the same allocator.
unsafe impl GlobalAlloc for HostAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let h = header(layout);
        let Ok(outer) = Layout::from_size_align(layout.size() + h, layout.align().max(h)) else {
            return std::ptr::null_mut();
        };
        let slot = CURRENT.load(Ordering::Acquire);
        let base = match SLOTS[slot].get() {
            // SAFETY: `outer` has a non-zero size.
            None => unsafe { System.alloc(outer) },
            // SAFETY: the host's contract for `alloc`.
            Some(hk) => {
                unsafe { (hk.alloc)(hk.user as *mut c_void, outer.size(), outer.align()) }.cast()
            }
        };
        if base.is_null() {
            return base;
        }
        tally(outer, 1);
        // `dealloc` gets back only the block pointer, whose provenance the
        // caller may have narrowed to the block (Box/Vec retag it); the
        // header in front is reached through the base pointer's exposed
        // provenance instead (see `dealloc`).
        base.expose_provenance();
        // SAFETY: `base` spans `h + size` bytes, `h` ≥ size_of::<usize>()
        // and both `base` and `h` are multiples of align_of::<usize>().
        unsafe {
            base.add(h - std::mem::size_of::<usize>())
                .cast::<usize>()
                .write(slot);
            base.add(h)
        }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        let h = header(layout);
        // The header and the base are reached through `ptr` itself: freeing
        // through any other pointer would be a foreign write to memory the
        // caller's (protected) reference still covers. This is sound under
        // the Tree Borrows model, which Miri checks this crate with
        // (`-Zmiri-tree-borrows`); Stacked Borrows narrows `ptr` to the
        // block and rejects every header-prefix allocator.
        let base = ptr.wrapping_sub(h);
        // SAFETY: `ptr` came from `alloc` with this layout (GlobalAlloc's
        // contract), so the base and the slot word are where `alloc` put
        // them, inside the same allocation.
        unsafe {
            let slot = base
                .add(h - std::mem::size_of::<usize>())
                .cast::<usize>()
                .read();
            let outer = Layout::from_size_align_unchecked(layout.size() + h, layout.align().max(h));
            tally(outer, -1);
            match SLOTS[slot].get() {
                None => System.dealloc(base, outer),
                Some(hk) => (hk.free)(
                    hk.user as *mut c_void,
                    base.cast(),
                    outer.size(),
                    outer.align(),
                ),
            }
        }
    }
}

#[global_allocator]
static GLOBAL: HostAllocator = HostAllocator;

/// Routes every later allocation of the library through `allocator`'s
/// callbacks, or back to the system allocator when `allocator` is NULL.
/// Blocks allocated before keep being freed by the allocator that made
/// them. At most 16 host allocators can be installed per process
/// (`CMLT_ERROR_INVALID_OPERATION` after that).
///
/// # Safety
/// `allocator` is NULL or points to a valid `cmlt_allocator` whose
/// callbacks stay callable for the rest of the process.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_set_allocator(allocator: *const cmlt_allocator) -> cmlt_status {
    guard("cmlt_set_allocator", || {
        // SAFETY: the caller's contract.
        let Some(a) = (unsafe { allocator.as_ref() }) else {
            CURRENT.store(0, Ordering::Release);
            return Ok(());
        };
        let (Some(alloc), Some(free)) = (a.alloc, a.free) else {
            return Err(Error::null("allocator->alloc or allocator->free"));
        };
        let slot = USED.fetch_add(1, Ordering::AcqRel);
        if slot > MAX_ALLOCATORS {
            USED.fetch_sub(1, Ordering::AcqRel);
            return Err(Error::operation(
                "too many allocators installed in this process",
            ));
        }
        let hooks = Hooks {
            user: a.user as usize,
            alloc,
            free,
        };
        if SLOTS[slot].set(hooks).is_err() {
            return Err(Error::new(
                cmlt_status::CMLT_ERROR_INTERNAL,
                "allocator slot reused",
            ));
        }
        CURRENT.store(slot, Ordering::Release);
        Ok(())
    })
}
