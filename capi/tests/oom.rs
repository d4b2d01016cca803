//! The failing-allocator sweep: a host allocator (`cmlt_set_allocator`)
//! that returns NULL at the N-th allocation, for every N a whole session
//! makes — scene, texture, material, meshes, light, commit, memory query,
//! renderer, prepare, frames, a mesh update. The call during which the
//! N-th allocation falls returns `CMLT_ERROR_OUT_OF_MEMORY` (every call
//! before it succeeds), after the releases every block of the allocator is
//! freed again, and the same session run again with a working allocator
//! succeeds. A second sweep refuses every allocation from the N-th on (a
//! host that stays out of memory). The same for a session on the built-in
//! scene (the scene-file loader and obvhs's BVH builder) in builds with
//! the `loader` feature. No N is
//! excluded: allocations that Rust code makes infallibly (obvhs, `Vec`
//! growth in the core) are caught by the library's allocator (see
//! `cmlt_capi::alloc`), those sized by input are reserved fallibly first.
//!
//! Its own binary without the test harness (`harness = false`): one
//! thread, so the allocator's counts are this session's alone.

use std::alloc::{GlobalAlloc, Layout, System};
use std::ffi::{CStr, c_void};
use std::ptr::{null, null_mut};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

use cmlt_capi::alloc::{cmlt_allocator, cmlt_set_allocator};
use cmlt_capi::error::cmlt_last_error;
use cmlt_capi::error::cmlt_status::{self, *};
use cmlt_capi::renderer::*;
use cmlt_capi::scene::*;

#[path = "common/mod.rs"]
mod common;
use common::{CAMERA, FLOOR, LIGHT, POSITIONS, WHITE, mesh};

/// Allocations made through the hooks so far.
static MADE: AtomicU64 = AtomicU64::new(0);
/// Blocks of the hooks not freed yet.
static LIVE: AtomicUsize = AtomicUsize::new(0);
/// The allocation (1-based) to refuse; 0 = none.
static FAIL_AT: AtomicU64 = AtomicU64::new(0);
/// Whether every allocation from `FAIL_AT` on is refused, not just it.
static FAIL_ON: AtomicBool = AtomicBool::new(false);
/// Whether a C API call runs: only its allocations are counted and
/// refused, not the test's own.
static ARMED: AtomicBool = AtomicBool::new(false);

unsafe extern "C" fn failing_alloc(_: *mut c_void, size: usize, align: usize) -> *mut c_void {
    if ARMED.load(Ordering::Relaxed) {
        let n = MADE.fetch_add(1, Ordering::Relaxed) + 1;
        let at = FAIL_AT.load(Ordering::Relaxed);
        if at != 0 && (n == at || (n > at && FAIL_ON.load(Ordering::Relaxed))) {
            return null_mut();
        }
    }
    LIVE.fetch_add(1, Ordering::Relaxed);
    // SAFETY: size > 0 (the library adds a header), align a power of two.
    unsafe {
        System
            .alloc(Layout::from_size_align(size, align).unwrap())
            .cast()
    }
}

unsafe extern "C" fn failing_free(_: *mut c_void, ptr: *mut c_void, size: usize, align: usize) {
    LIVE.fetch_sub(1, Ordering::Relaxed);
    // SAFETY: `ptr` came from `failing_alloc` with this size and alignment.
    unsafe { System.dealloc(ptr.cast(), Layout::from_size_align(size, align).unwrap()) }
}

const TEXELS: [u8; 12] = [200, 10, 10, 10, 200, 10, 10, 10, 200, 90, 90, 90];

/// The first failing call of a session: its name, status, the allocation
/// count before and after it, and the start of its message. Plain data: a
/// leak check runs while it is alive, and only the library's blocks count.
#[derive(Clone, Copy)]
struct Failure {
    call: &'static str,
    status: cmlt_status,
    before: u64,
    after: u64,
    message: [u8; 160],
}

impl Failure {
    fn text(&self) -> String {
        let end = self.message.iter().position(|&b| b == 0).unwrap_or(160);
        format!(
            "{} → {:?}: {}",
            self.call,
            self.status,
            String::from_utf8_lossy(&self.message[..end])
        )
    }
}

/// What a session did: how many calls succeeded, and the first failure.
struct Outcome {
    ok_calls: usize,
    failed: Option<Failure>,
}

/// Runs one session (CMLT, two workers) and releases what it made.
fn session() -> Outcome {
    let (mut scene, mut renderer) = (null_mut(), null_mut());
    let mut out = Outcome {
        ok_calls: 0,
        failed: None,
    };
    let mut config = std::mem::MaybeUninit::uninit();
    // SAFETY: valid out pointer (no allocation: plain data).
    let mut config = unsafe {
        assert_eq!(
            cmlt_renderer_config_default(CMLT_ESTIMATOR_CMLT, config.as_mut_ptr()),
            CMLT_OK
        );
        config.assume_init()
    };
    config.width = 16;
    config.height = 12;
    config.workers = 2;
    config.chains = 16;
    config.bootstrap_samples = 100;
    // One pass, without the small-image floor: every case of the sweep
    // renders, and b's accuracy is not what is tested.
    config.normalisation_passes = 1;
    config.normalisation_min_samples = 0;
    config.k = 4;
    config.m = 2;
    let mut pixels = [0.0f32; 16 * 12 * 3];
    let moved = POSITIONS.map(|v| v + 0.01);
    let (mut tex, mut grid, mut mat, mut bytes) = (0u32, 0u32, 0u32, 0usize);
    // An opaque grid (every voxel 1) read as the floor's opacity.
    let voxels = [1.0f32; 2];
    let grid_desc = cmlt_grid {
        resolution: [2, 1, 1],
        channels: 1,
        voxels: voxels.as_ptr(),
        to_world: [0.0; 12],
        filter: CMLT_GRID_TRILINEAR,
        wrap: CMLT_GRID_CLAMP,
    };
    let point = cmlt_light {
        type_: CMLT_LIGHT_POINT,
        color: [1.0; 3],
        position: [0.0, 0.8, 0.0],
        direction: [0.0, -1.0, 0.0],
        cutoff_angle: 20.0,
        beam_width: 15.0,
        texels: null(),
        width: 0,
        height: 0,
        stride: 0,
        to_world: [0.0; 9],
    };
    // SAFETY: valid pointers throughout; handles from this session.
    unsafe {
        let mut call = |name, f: &mut dyn FnMut() -> cmlt_status| call(&mut out, name, f);
        let _ = call("scene_new", &mut || cmlt_scene_new(&mut scene))
            && call("add_texture", &mut || {
                cmlt_scene_add_texture(scene, 2, 2, 3, TEXELS.as_ptr(), 0, 1, &mut tex)
            })
            && call("add_grid_texture", &mut || {
                cmlt_scene_add_grid_texture(scene, &grid_desc, &mut grid)
            })
            && call("add_material", &mut || {
                let m = cmlt_material {
                    color_texture: tex,
                    opacity_texture: grid,
                    ..WHITE
                };
                cmlt_scene_add_material(scene, &m, &mut mat)
            })
            && call("add_mesh floor", &mut || {
                cmlt_scene_add_mesh(scene, &mesh(&FLOOR, mat, 0.0), null_mut())
            })
            && call("add_mesh light", &mut || {
                cmlt_scene_add_mesh(scene, &mesh(&LIGHT, mat, 5.0), null_mut())
            })
            && call("add_light", &mut || {
                cmlt_scene_add_light(scene, &point, null_mut())
            })
            && call("commit", &mut || cmlt_scene_commit(scene))
            && call("memory_requirements", &mut || {
                cmlt_renderer_memory_requirements(scene, &config, &mut bytes, null_mut())
            })
            && call("renderer_new", &mut || {
                cmlt_renderer_new(scene, &config, &CAMERA, &mut renderer)
            })
            && (0..2).all(|frame| {
                call("prepare", &mut || cmlt_renderer_prepare(renderer))
                    && call("render 0", &mut || {
                        cmlt_renderer_render(renderer, 0, 200, null_mut())
                    })
                    && call("render 1", &mut || {
                        cmlt_renderer_render(renderer, 1, 200, null_mut())
                    })
                    && call("resolve", &mut || {
                        cmlt_renderer_resolve(
                            renderer,
                            CMLT_FORMAT_RGB32F,
                            pixels.as_mut_ptr().cast(),
                            0,
                            std::mem::size_of_val(&pixels),
                        )
                    })
                    && call("update_mesh", &mut || {
                        let p = if frame == 0 { &moved } else { &POSITIONS };
                        cmlt_scene_update_mesh(scene, 1, p.as_ptr(), 8, 0, null(), 0)
                    })
            });
        cmlt_renderer_release(renderer);
        cmlt_scene_release(scene);
    }
    // The test's own blocks (a failure's message) are freed outside the
    // hooks' count of live blocks.
    ARMED.store(false, Ordering::Relaxed);
    out
}

/// A session on the built-in Cornell box (the scene-file loader's path,
/// its BVH built by obvhs): scene, renderer, one frame.
#[cfg(feature = "loader")]
fn builtin_session() -> Outcome {
    let (mut scene, mut renderer) = (null_mut(), null_mut());
    let mut out = Outcome {
        ok_calls: 0,
        failed: None,
    };
    let mut camera = CAMERA;
    let mut config = std::mem::MaybeUninit::uninit();
    // SAFETY: valid out pointer (no allocation: plain data).
    let mut config = unsafe {
        assert_eq!(
            cmlt_renderer_config_default(CMLT_ESTIMATOR_MLT, config.as_mut_ptr()),
            CMLT_OK
        );
        config.assume_init()
    };
    (config.width, config.height, config.workers, config.chains) = (16, 16, 1, 8);
    (config.bootstrap_samples, config.normalisation_passes) = (50, 1);
    config.normalisation_min_samples = 0;
    let mut pixels = [0.0f32; 16 * 16 * 3];
    // SAFETY: valid pointers throughout; handles from this session.
    unsafe {
        let _ = call(&mut out, "new_builtin", &mut || {
            cmlt_scene_new_builtin(c"cornell-box".as_ptr(), 16, 16, &mut scene, &mut camera)
        }) && call(&mut out, "renderer_new", &mut || {
            cmlt_renderer_new(scene, &config, &camera, &mut renderer)
        }) && call(&mut out, "prepare", &mut || cmlt_renderer_prepare(renderer))
            && call(&mut out, "render", &mut || {
                cmlt_renderer_render(renderer, 0, 256, null_mut())
            })
            && call(&mut out, "resolve", &mut || {
                cmlt_renderer_resolve(
                    renderer,
                    CMLT_FORMAT_RGB32F,
                    pixels.as_mut_ptr().cast(),
                    0,
                    std::mem::size_of_val(&pixels),
                )
            });
        cmlt_renderer_release(renderer);
        cmlt_scene_release(scene);
    }
    ARMED.store(false, Ordering::Relaxed);
    out
}

/// Runs one call with the hooks armed and records its outcome; false when
/// it failed.
fn call(out: &mut Outcome, name: &'static str, f: &mut dyn FnMut() -> cmlt_status) -> bool {
    let before = MADE.load(Ordering::Relaxed);
    ARMED.store(true, Ordering::Relaxed);
    let status = f();
    ARMED.store(false, Ordering::Relaxed);
    let after = MADE.load(Ordering::Relaxed);
    if status == CMLT_OK {
        out.ok_calls += 1;
        return true;
    }
    // SAFETY: never NULL, NUL-terminated.
    let msg = unsafe { CStr::from_ptr(cmlt_last_error()) }.to_bytes();
    let mut message = [0u8; 160];
    let n = msg.len().min(159);
    message[..n].copy_from_slice(&msg[..n]);
    out.failed = Some(Failure {
        call: name,
        status,
        before,
        after,
        message,
    });
    false
}

/// A session to sweep: its name, the session, and the least number of
/// calls a working run makes.
type Session = (&'static str, fn() -> Outcome, usize);

fn main() {
    let hooks = cmlt_allocator {
        user: null_mut(),
        alloc: Some(failing_alloc),
        free: Some(failing_free),
    };
    // SAFETY: process-lifetime callbacks.
    assert_eq!(unsafe { cmlt_set_allocator(&hooks) }, CMLT_OK);
    let (mut passed, mut failed) = (0u64, 0u64);
    let sessions: &[Session] = &[
        ("a scene built call by call", session, 19),
        #[cfg(feature = "loader")]
        ("the built-in scene", builtin_session, 5),
    ];
    for &(name, session, calls) in sessions {
        // A working run: how many allocations a whole session makes.
        let start = MADE.load(Ordering::Relaxed);
        let live = LIVE.load(Ordering::Relaxed);
        let full = session();
        assert!(full.failed.is_none(), "{:?}", full.failed.map(|f| f.text()));
        assert!(full.ok_calls >= calls, "only {} calls ran", full.ok_calls);
        let total = MADE.load(Ordering::Relaxed) - start;
        assert_eq!(
            LIVE.load(Ordering::Relaxed),
            live,
            "a working session leaks"
        );
        assert!(
            total > 20,
            "only {total} allocations went through the hooks"
        );
        for persistent in [false, true] {
            FAIL_ON.store(persistent, Ordering::Relaxed);
            for n in 1..=total {
                let base = MADE.load(Ordering::Relaxed);
                FAIL_AT.store(base + n, Ordering::Relaxed);
                let run = session();
                FAIL_AT.store(0, Ordering::Relaxed);
                let leaked = LIVE.load(Ordering::Relaxed) as isize - live as isize;
                let retry = session();
                let retry_leaked = LIVE.load(Ordering::Relaxed) as isize - live as isize;
                let mut problems = Vec::new();
                match run.failed {
                    None => problems.push("every call succeeded".to_string()),
                    Some(f) => {
                        if f.status != CMLT_ERROR_OUT_OF_MEMORY {
                            problems.push(f.text());
                        }
                        if !(f.before < base + n && base + n <= f.after) {
                            problems.push(format!("{} did not make allocation {n}", f.text()));
                        }
                    }
                }
                if leaked != 0 {
                    problems.push(format!("{leaked} blocks leaked"));
                }
                if let Some(f) = retry.failed {
                    problems.push(format!("the retry failed: {}", f.text()));
                }
                if retry_leaked != 0 {
                    problems.push(format!("the retry leaked {retry_leaked} blocks"));
                }
                if problems.is_empty() {
                    passed += 1;
                } else {
                    failed += 1;
                    eprintln!(
                        "{name}: N = {n} of {total} ({}): {}",
                        if persistent { "from N on" } else { "only N" },
                        problems.join("; ")
                    );
                }
            }
        }
        println!("{name}: failing-allocator sweep over {total} allocations, twice");
    }
    println!("{passed} passed, {failed} failed");
    if failed > 0 {
        std::process::exit(1);
    }
}
