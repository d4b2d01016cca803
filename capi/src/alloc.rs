//! Host allocator callbacks: every allocation the library makes (scene,
//! BVH, renderer, workers; never one inside a frame) goes through the
//! functions the host registered with [`cmlt_set_allocator`], or the system
//! allocator when none is set.
//!
//! The library's `#[global_allocator]` forwards to the hooks current at
//! allocation time and writes a small header in front of each block naming
//! the hooks that made it, so a block is always freed by its own allocator
//! even when the host switches allocators while objects are alive. Hooks
//! live in a fixed table of [`MAX_ALLOCATORS`] slots; a slot is written
//! again once its allocator is neither current nor holding a block
//! (`Slot` says how that stays sound against allocations racing the
//! switch).
//!
//! ## Out of memory
//!
//! Rust's infallible allocations (a `Vec` growing, a `Box`, inside cmlt and
//! inside its dependencies such as obvhs's BVH builder) abort the process
//! when the global allocator returns NULL, and stable Rust offers no way to
//! make them unwind. So a refusal inside a `cmlt_*` call is caught here
//! instead: the allocator notes it (per thread, in the `call` module), serves that block and the
//! call's later ones from the system allocator when the host refuses them
//! too, and the call then throws its work away and returns
//! `CMLT_ERROR_OUT_OF_MEMORY` (`check_oom` before anything is published),
//! so nothing the host refused outlives the call. A block from the system
//! is marked as such in its header and freed there. Sizes from input are
//! bounded and checked before they are allocated (`try_reserve`, checked
//! arithmetic), so the system is never asked for an absurd block; only when
//! the system refuses as well does an infallible allocation abort.
//! Outside a `cmlt_*` call nothing is caught.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::ffi::c_void;
use std::sync::atomic::{AtomicPtr, AtomicUsize, Ordering};

use crate::call;
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

/// How many host allocators can hold the library's blocks at once: each
/// takes a slot while it is current or any block it made is alive, and a
/// slot is reused once neither is true (a game that installs a new arena
/// per level and releases the level's objects before the next can do so
/// without end).
pub const MAX_ALLOCATORS: usize = 16;

type AllocFn = unsafe extern "C" fn(*mut c_void, usize, usize) -> *mut c_void;
type FreeFn = unsafe extern "C" fn(*mut c_void, *mut c_void, usize, usize);

/// One host allocator's hooks and what says whether its slot is in use.
///
/// The hooks sit in atomics, not a write-once cell, so that a slot can be
/// written again (and installing hooks allocates nothing). They are written only by
/// [`cmlt_set_allocator`], under [`SETTING`], and only while the slot is
/// idle: not current, `live` 0 (no block of it to free) and `entering` 0
/// (no allocation between reading [`CURRENT`] and calling the hooks). An
/// allocation announces itself in `entering` and then checks that its slot
/// is still current; the setter makes a slot current only after writing
/// it, so an allocation either reads the complete new hooks or backs off
/// without reading any (see `HostAllocator::alloc`).
struct Slot {
    user: AtomicPtr<c_void>,
    alloc: AtomicPtr<()>,
    free: AtomicPtr<()>,
    /// Blocks these hooks made that are not freed yet.
    live: AtomicUsize,
    /// Allocations that found this slot current and may be using it.
    entering: AtomicUsize,
}

impl Slot {
    /// The hooks. Only for a slot that is current with `entering` held, or
    /// that has a live block (either keeps the setter from writing it).
    fn hooks(&self) -> (*mut c_void, AllocFn, FreeFn) {
        let (a, f) = (
            self.alloc.load(Ordering::SeqCst),
            self.free.load(Ordering::SeqCst),
        );
        debug_assert!(!a.is_null() && !f.is_null());
        // SAFETY: both pointers were made from function pointers of these
        // types by `cmlt_set_allocator` before the slot became current
        // (the caller's condition); a pointer transmuted back keeps its
        // provenance (an integer would not).
        unsafe {
            (
                self.user.load(Ordering::SeqCst),
                std::mem::transmute::<*mut (), AllocFn>(a),
                std::mem::transmute::<*mut (), FreeFn>(f),
            )
        }
    }

    fn idle(&self) -> bool {
        self.live.load(Ordering::SeqCst) == 0 && self.entering.load(Ordering::SeqCst) == 0
    }
}

/// Slot 0 is the system allocator (never written); slots 1.. hold host
/// hooks.
static SLOTS: [Slot; MAX_ALLOCATORS + 1] = [const {
    Slot {
        user: AtomicPtr::new(std::ptr::null_mut()),
        alloc: AtomicPtr::new(std::ptr::null_mut()),
        free: AtomicPtr::new(std::ptr::null_mut()),
        live: AtomicUsize::new(0),
        entering: AtomicUsize::new(0),
    }
}; MAX_ALLOCATORS + 1];
/// Slot new allocations use.
static CURRENT: AtomicUsize = AtomicUsize::new(0);
/// Held while hooks are installed: one writer of slots at a time.
static SETTING: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The library's global allocator (see the module docs).
pub struct HostAllocator;

/// What one thread allocated while [`measure_allocations`] ran, as the
/// host allocator sees it (headers included).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Usage {
    /// The most bytes allocated at once at any point (at least what is
    /// left allocated at the end): what an allocator of fixed capacity
    /// must have free for the measured work.
    pub peak: usize,
    /// The largest alignment requested.
    pub max_align: usize,
}

/// The running tally of [`measure_allocations`]: live bytes, their peak,
/// the largest alignment.
#[derive(Clone, Copy)]
struct Tally {
    live: isize,
    peak: isize,
    align: usize,
}

thread_local! {
    /// Whether this thread is inside `measure_allocations`, and its tally
    /// (const-initialised, no destructor: safe to touch from the
    /// allocator).
    static MEASURING: Cell<bool> = const { Cell::new(false) };
    static USAGE: Cell<Tally> = const { Cell::new(Tally { live: 0, peak: 0, align: 0 }) };
}

fn tally(outer: Layout, sign: isize) {
    if MEASURING.with(Cell::get) {
        USAGE.with(|u| {
            let t = u.get();
            let live = t.live + sign * outer.size() as isize;
            u.set(Tally {
                live,
                peak: t.peak.max(live),
                align: t.align.max(outer.align()),
            });
        });
    }
}

/// Runs `f` and reports what it allocated on this thread ([`Usage`]).
pub(crate) fn measure_allocations<R>(f: impl FnOnce() -> R) -> (R, Usage) {
    USAGE.with(|u| {
        u.set(Tally {
            live: 0,
            peak: 0,
            align: 0,
        })
    });
    MEASURING.with(|m| m.set(true));
    let r = f();
    MEASURING.with(|m| m.set(false));
    let t = USAGE.with(Cell::get);
    (
        r,
        Usage {
            peak: t.peak.max(0) as usize,
            max_align: t.align,
        },
    )
}

/// Whether the system allocator can give `bytes` in one block right now:
/// asks it (fallibly) and frees the block at once. This bypasses the host's
/// hooks on purpose: a host's fixed-size pool never sees the probe, only
/// the blocks the library keeps, and what the probe guards against is the
/// system refusing a block the core would ask for infallibly (a host's
/// refusal is served by the system instead, see the module docs).
pub(crate) fn system_can_give(bytes: usize) -> crate::error::Result<()> {
    let refused = || {
        Error::out_of_memory(
            "out of memory: the system cannot give the renderer's upper bound of memory",
        )
    };
    if bytes == 0 {
        return Ok(());
    }
    let layout = Layout::from_size_align(bytes, 1).map_err(|_| refused())?;
    // SAFETY: `layout` has a non-zero size; the block is freed with the
    // same layout right away and never read or written. `black_box` keeps
    // the pair: a malloc whose block is never used may be removed by the
    // optimiser and assumed to succeed, which would make the probe a no-op.
    unsafe {
        let block = std::hint::black_box(System.alloc(layout));
        if block.is_null() {
            return Err(refused());
        }
        System.dealloc(block, layout);
    }
    Ok(())
}

/// `CMLT_ERROR_OUT_OF_MEMORY` if a block was refused so far in this call.
/// Entry points call it after their last allocation and before they change
/// the object or write a handle, so a refused call changes nothing.
pub(crate) fn check_oom() -> crate::error::Result<()> {
    match call::refused() {
        None => Ok(()),
        Some(_) => Err(Error::out_of_memory(
            "out of memory: the allocator refused a block; nothing was changed",
        )),
    }
}

/// `Vec::try_reserve_exact` as a C API error: for buffers whose size comes
/// from input, so an absurd size is refused before anything is allocated.
pub(crate) fn try_reserve<T>(v: &mut Vec<T>, additional: usize) -> crate::error::Result<()> {
    v.try_reserve_exact(additional).map_err(|_| {
        let mut m = String::new();
        let _ = std::fmt::Write::write_fmt(
            &mut m,
            format_args!(
                "out of memory: {additional} elements of {} bytes could not be allocated",
                std::mem::size_of::<T>()
            ),
        );
        Error::out_of_memory(m)
    })
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
        let (mut slot, mut base) = loop {
            let slot = CURRENT.load(Ordering::SeqCst);
            if slot == 0 {
                // SAFETY: `outer` has a non-zero size.
                break (0, unsafe { System.alloc(outer) });
            }
            let s = &SLOTS[slot];
            s.entering.fetch_add(1, Ordering::SeqCst);
            if CURRENT.load(Ordering::SeqCst) != slot {
                // Switched meanwhile: the slot may be rewritten; start over.
                s.entering.fetch_sub(1, Ordering::SeqCst);
                continue;
            }
            let (user, alloc, _) = s.hooks();
            // Counted before the call and while `entering` is held, so the
            // slot is never idle while a block of it exists.
            s.live.fetch_add(1, Ordering::SeqCst);
            // SAFETY: the host's contract for `alloc`.
            let base: *mut u8 = unsafe { alloc(user, outer.size(), outer.align()) }.cast();
            if base.is_null() {
                s.live.fetch_sub(1, Ordering::SeqCst);
            }
            s.entering.fetch_sub(1, Ordering::SeqCst);
            break (slot, base);
        };
        if base.is_null() && call::in_call() {
            // Caught (see the module docs): the call will fail with
            // out-of-memory; until then the system serves it.
            call::note_refused(layout.size());
            if slot != 0 {
                slot = 0;
                // SAFETY: `outer` has a non-zero size.
                base = unsafe { System.alloc(outer) };
            }
        }
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
            if slot == 0 {
                System.dealloc(base, outer);
            } else {
                // This block keeps the slot's `live` above 0, so its hooks
                // stay as they were until it is counted out, after `free`.
                let s = &SLOTS[slot];
                let (user, _, free) = s.hooks();
                free(user, base.cast(), outer.size(), outer.align());
                s.live.fetch_sub(1, Ordering::SeqCst);
            }
        }
    }
}

#[global_allocator]
static GLOBAL: HostAllocator = HostAllocator;

/// Routes every later allocation of the library through `allocator`'s
/// callbacks, or back to the system allocator when `allocator` is NULL.
/// Blocks allocated before keep being freed by the allocator that made
/// them. Up to 16 host allocators can hold blocks at once: an allocator
/// that is no longer current and whose blocks are all freed gives its place
/// up, so hooks can be installed any number of times (say one arena per
/// level, each level's objects released before the next level's hooks are
/// installed); `CMLT_ERROR_INVALID_OPERATION` when 16 earlier allocators
/// still hold blocks.
///
/// # Safety
/// `allocator` is NULL or points to a valid `cmlt_allocator` whose
/// callbacks stay callable for the rest of the process.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_set_allocator(allocator: *const cmlt_allocator) -> cmlt_status {
    guard("cmlt_set_allocator", || {
        // SAFETY: the caller's contract.
        let Some(a) = (unsafe { allocator.as_ref() }) else {
            CURRENT.store(0, Ordering::SeqCst);
            return Ok(());
        };
        let (Some(alloc), Some(free)) = (a.alloc, a.free) else {
            return Err(Error::null("allocator->alloc or allocator->free"));
        };
        let _setting = SETTING
            .lock()
            .map_err(|_| Error::new(cmlt_status::CMLT_ERROR_INTERNAL, "allocator lock poisoned"))?;
        let current = CURRENT.load(Ordering::SeqCst);
        // An idle slot that is not current: no block of it is alive and no
        // allocation is reading it, and none can start reading it before
        // CURRENT names it (`HostAllocator::alloc`).
        let Some(slot) = (1..=MAX_ALLOCATORS).find(|&i| i != current && SLOTS[i].idle()) else {
            return Err(Error::operation(
                "16 earlier host allocators still hold cmlt's blocks: release the \
                 objects made under one of them before installing another",
            ));
        };
        let s = &SLOTS[slot];
        s.user.store(a.user, Ordering::SeqCst);
        s.alloc.store(alloc as *mut (), Ordering::SeqCst);
        s.free.store(free as *mut (), Ordering::SeqCst);
        CURRENT.store(slot, Ordering::SeqCst);
        Ok(())
    })
}
