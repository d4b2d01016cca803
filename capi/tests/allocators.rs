//! Host allocators installed again and again: a game that installs a new
//! arena per level (`cmlt_set_allocator`) and releases the level's objects
//! before the next level's is never refused, and every block goes back to
//! the allocator that made it; while 16 earlier allocators still hold
//! blocks, another is refused, and releasing one allocator's objects makes
//! room again.
//!
//! Its own binary without the test harness (`harness = false`): the global
//! allocator is the library's in a Rust test binary, so any other thread's
//! allocation (the harness's) would go through the hooks too and keep
//! their slots in use. The test itself allocates nothing of its own while
//! hooks are installed.

use std::ffi::c_void;
use std::ptr::{null, null_mut};
use std::sync::atomic::{AtomicIsize, AtomicUsize, Ordering};

use cmlt_capi::alloc::{MAX_ALLOCATORS, cmlt_allocator, cmlt_set_allocator};
use cmlt_capi::error::cmlt_status::*;
use cmlt_capi::renderer::*;
use cmlt_capi::scene::*;

#[path = "common/mod.rs"]
mod common;
use common::{CAMERA, FLOOR, LIGHT, WHITE, expect, mesh};

/// One host allocator's record: blocks made and bytes still out.
struct Arena {
    made: AtomicUsize,
    live_bytes: AtomicIsize,
}

const LEVELS: usize = 40;
static ARENAS: [Arena; LEVELS + MAX_ALLOCATORS + 1] = [const {
    Arena {
        made: AtomicUsize::new(0),
        live_bytes: AtomicIsize::new(0),
    }
}; LEVELS + MAX_ALLOCATORS + 1];

unsafe extern "C" fn arena_alloc(user: *mut c_void, size: usize, align: usize) -> *mut c_void {
    // SAFETY: `user` is one of `ARENAS` (set below).
    let a = unsafe { &*(user as *const Arena) };
    a.made.fetch_add(1, Ordering::SeqCst);
    a.live_bytes.fetch_add(size as isize, Ordering::SeqCst);
    // SAFETY: a valid layout (the library passes a power-of-two alignment).
    unsafe {
        std::alloc::GlobalAlloc::alloc(
            &std::alloc::System,
            std::alloc::Layout::from_size_align_unchecked(size, align),
        )
    }
    .cast()
}

unsafe extern "C" fn arena_free(user: *mut c_void, ptr: *mut c_void, size: usize, align: usize) {
    // SAFETY: as above.
    let a = unsafe { &*(user as *const Arena) };
    a.live_bytes.fetch_sub(size as isize, Ordering::SeqCst);
    // SAFETY: `ptr` came from `arena_alloc` with this layout.
    unsafe {
        std::alloc::GlobalAlloc::dealloc(
            &std::alloc::System,
            ptr.cast(),
            std::alloc::Layout::from_size_align_unchecked(size, align),
        )
    }
}

fn hooks(i: usize) -> cmlt_allocator {
    cmlt_allocator {
        user: &ARENAS[i] as *const Arena as *mut c_void,
        alloc: Some(arena_alloc),
        free: Some(arena_free),
    }
}

/// A level: a committed floor-and-light scene and a PT renderer of it that
/// has rendered a pass.
fn level() -> (*mut cmlt_scene, *mut cmlt_renderer) {
    let (mut s, mut r, mut id) = (null_mut(), null_mut(), 0);
    let mut c = std::mem::MaybeUninit::uninit();
    // SAFETY: valid pointers throughout.
    unsafe {
        expect(cmlt_scene_new(&mut s), CMLT_OK, "scene_new");
        expect(
            cmlt_scene_add_material(s, &WHITE, &mut id),
            CMLT_OK,
            "material",
        );
        expect(
            cmlt_scene_add_mesh(s, &mesh(&FLOOR, id, 0.0), null_mut()),
            CMLT_OK,
            "floor",
        );
        expect(
            cmlt_scene_add_mesh(s, &mesh(&LIGHT, id, 5.0), null_mut()),
            CMLT_OK,
            "light",
        );
        expect(cmlt_scene_commit(s), CMLT_OK, "commit");
        expect(
            cmlt_renderer_config_default(CMLT_ESTIMATOR_PT, c.as_mut_ptr()),
            CMLT_OK,
            "config",
        );
        let mut c = c.assume_init();
        (c.width, c.height) = (16, 12);
        expect(
            cmlt_renderer_new(s, &c, &CAMERA, &mut r),
            CMLT_OK,
            "renderer_new",
        );
        expect(cmlt_renderer_prepare(r), CMLT_OK, "prepare");
        expect(
            cmlt_renderer_render(r, 0, 16 * 12, null_mut()),
            CMLT_OK,
            "render",
        );
    }
    (s, r)
}

fn release((s, r): (*mut cmlt_scene, *mut cmlt_renderer)) {
    // SAFETY: handles from `level`.
    unsafe {
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
}

fn main() {
    // Levels one after another, each under its own allocator: the 17th and
    // later are accepted because the earlier ones hold nothing any more.
    for (i, a) in ARENAS[..LEVELS].iter().enumerate() {
        // SAFETY: valid hooks with process-lifetime callbacks.
        unsafe { expect(cmlt_set_allocator(&hooks(i)), CMLT_OK, "cmlt_set_allocator") };
        release(level());
        assert!(
            a.made.load(Ordering::SeqCst) > 0,
            "level {i}: its allocator saw nothing"
        );
        assert_eq!(
            a.live_bytes.load(Ordering::SeqCst),
            0,
            "level {i}: blocks not returned to the allocator that made them"
        );
    }
    // Sixteen allocators each holding a live level: a seventeenth has no
    // room (the current one's slot is among the sixteen).
    let base = LEVELS;
    let mut alive = [(null_mut(), null_mut()); MAX_ALLOCATORS];
    for (k, slot) in alive.iter_mut().enumerate() {
        // SAFETY: as above.
        unsafe {
            expect(
                cmlt_set_allocator(&hooks(base + k)),
                CMLT_OK,
                "cmlt_set_allocator",
            )
        };
        *slot = level();
    }
    // SAFETY: as above.
    unsafe {
        expect(
            cmlt_set_allocator(&hooks(base + MAX_ALLOCATORS)),
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_set_allocator",
        );
    }
    // The first of them releases its level: its place is free again, and
    // its blocks went back to it although another allocator was current.
    release(alive[0]);
    assert_eq!(ARENAS[base].live_bytes.load(Ordering::SeqCst), 0);
    // SAFETY: as above.
    unsafe {
        expect(
            cmlt_set_allocator(&hooks(base + MAX_ALLOCATORS)),
            CMLT_OK,
            "cmlt_set_allocator",
        );
    }
    for l in &alive[1..] {
        release(*l);
    }
    for (k, a) in ARENAS[base..base + MAX_ALLOCATORS].iter().enumerate() {
        assert_eq!(a.live_bytes.load(Ordering::SeqCst), 0, "allocator {k}");
    }
    // SAFETY: NULL restores the system allocator.
    unsafe { expect(cmlt_set_allocator(null()), CMLT_OK, "cmlt_set_allocator") };
    println!("allocators: {LEVELS} levels in turn, then {MAX_ALLOCATORS} at once: ok");
}
